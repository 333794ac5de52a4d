//! Writing a g2o file.

use std::fmt::Write as _;

use nalgebra::SMatrix;

use super::{G2oEdge, G2oFile, G2oVertex};

/// Writes a g2o file (shortest round-trip decimal representation of every number).
pub fn write_g2o(file: &G2oFile) -> String {
    let mut s = String::new();
    // Writing to a String cannot fail.
    for (id, o) in &file.offsets {
        let (t, q) = (o.translation, o.rotation);
        let _ = writeln!(s, "PARAMS_SE3OFFSET {id} {} {} {} {} {} {} {}", t.x, t.y, t.z, q.i, q.j, q.k, q.w);
    }
    for v in &file.vertices {
        let _ = match v {
            G2oVertex::Se2 { id, pose } => writeln!(s, "VERTEX_SE2 {id} {} {} {}", pose.x_m, pose.y_m, pose.yaw_rad),
            G2oVertex::Se3 { id, pose } => {
                let (t, q) = (pose.translation, pose.rotation);
                writeln!(s, "VERTEX_SE3:QUAT {id} {} {} {} {} {} {} {}", t.x, t.y, t.z, q.i, q.j, q.k, q.w)
            }
            G2oVertex::Point2 { id, point: p } => writeln!(s, "VERTEX_XY {id} {} {}", p.x, p.y),
            G2oVertex::Point3 { id, point: p } => writeln!(s, "VERTEX_TRACKXYZ {id} {} {} {}", p.x, p.y, p.z),
        };
    }
    for e in &file.edges {
        match e {
            G2oEdge::Se2 { from, to, measurement: z, information } => {
                let _ = write!(s, "EDGE_SE2 {from} {to} {} {} {}", z.x_m, z.y_m, z.yaw_rad);
                write_upper(&mut s, information);
            }
            G2oEdge::Se3 { from, to, measurement: z, information } => {
                let (t, q) = (z.translation, z.rotation);
                let _ = write!(s, "EDGE_SE3:QUAT {from} {to} {} {} {} {} {} {} {}", t.x, t.y, t.z, q.i, q.j, q.k, q.w);
                write_upper(&mut s, information);
            }
            G2oEdge::Se2Point2 { from, to, measurement: z, information } => {
                let _ = write!(s, "EDGE_SE2_XY {from} {to} {} {}", z.x, z.y);
                write_upper(&mut s, information);
            }
            G2oEdge::Se3Point3 { from, to, offset, measurement: z, information } => {
                let _ = write!(s, "EDGE_SE3_TRACKXYZ {from} {to} {offset} {} {} {}", z.x, z.y, z.z);
                write_upper(&mut s, information);
            }
        }
    }
    for id in &file.fixed {
        let _ = writeln!(s, "FIX {id}");
    }
    s
}

fn write_upper<const D: usize>(s: &mut String, m: &SMatrix<f64, D, D>) {
    for r in 0..D {
        for c in r..D {
            let _ = write!(s, " {}", m[(r, c)]);
        }
    }
    s.push('\n');
}
