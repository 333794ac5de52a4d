//! g2o pose-graph files: `VERTEX_SE2 id x y θ`, `EDGE_SE2 i j x y θ` + 6 information entries,
//! `VERTEX_SE3:QUAT id x y z qx qy qz qw`, `EDGE_SE3:QUAT i j x y z qx qy qz qw` + 21
//! information entries, and `FIX id`. Information matrices are upper triangles, row by row; the
//! 3D one is in (t, R) order, which is our tangent order (GTSAM permutes it to (R, t)).
//! Quaternions are normalised on reading (as GTSAM does). `#` starts a comment.
//!
//! Reading is one pass over the bytes, O(size); errors name the 1-based line. To a [`Problem`]:
//! vertices become variables by increasing id; an edge whose vertices are missing initialises
//! them as GTSAM's `load2D` does (an unknown `i` at the identity, an unknown `j` at
//! `x_i · z_ij`), in file order, so files of bare edges (CSAIL) start from composed odometry.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use nalgebra::{Matrix3, Matrix6, Quaternion, SMatrix, UnitQuaternion, Vector3};
use thiserror::Error;

use super::factors::{BetweenSe2, BetweenSe3, GaussianNoise, NoiseError, Se2Residual};
use super::lie::{Se2, Se3};
use super::problem::{Gauge, GaugeError, Problem};
use super::values::{Values, VarId, Variable};

#[derive(Clone, Debug, Error, PartialEq)]
pub enum G2oError {
    #[error("line {line}: not valid UTF-8")]
    NotUtf8 { line: usize },
    #[error("line {line}: unknown tag `{tag}`")]
    UnknownTag { line: usize, tag: String },
    #[error("line {line}: {tag} needs {expected} fields, found {found}")]
    FieldCount { line: usize, tag: &'static str, expected: usize, found: usize },
    #[error("line {line}: field {field} (`{text}`) is not a finite number or id")]
    BadNumber { line: usize, field: usize, text: String },
    #[error("line {line}: vertex {id} defined twice")]
    DuplicateVertex { line: usize, id: u64 },
    #[error("line {line}: 2D and 3D elements mixed in one file")]
    MixedDimensions { line: usize },
    #[error("line {line}: quaternion has zero norm")]
    ZeroQuaternion { line: usize },
    #[error("line {line}: edge connects vertex {id} to itself")]
    SelfLoop { line: usize, id: u64 },
    #[error("line {line}: information matrix: {source}")]
    Information { line: usize, source: NoiseError },
    #[error("FIX of vertex {0}, which no vertex or edge defines")]
    UnknownFixed(u64),
    #[error("edge {edge} (0-based): information matrix: {source}")]
    EdgeInformation { edge: usize, source: NoiseError },
    #[error("gauge: {0}")]
    Gauge(#[from] GaugeError),
}

/// A vertex (initial estimate of a pose).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum G2oVertex {
    Se2 { id: u64, pose: Se2 },
    Se3 { id: u64, pose: Se3 },
}

impl G2oVertex {
    pub fn id(&self) -> u64 {
        match self {
            G2oVertex::Se2 { id, .. } | G2oVertex::Se3 { id, .. } => *id,
        }
    }
}

/// A relative-pose edge `z ≈ x_from⁻¹ x_to` with its information matrix.
// Edges live in one Vec read once; boxing the 3D variant would cost an allocation per edge.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum G2oEdge {
    Se2 { from: u64, to: u64, measurement: Se2, information: Matrix3<f64> },
    Se3 { from: u64, to: u64, measurement: Se3, information: Matrix6<f64> },
}

impl G2oEdge {
    pub fn ids(&self) -> (u64, u64) {
        match self {
            G2oEdge::Se2 { from, to, .. } | G2oEdge::Se3 { from, to, .. } => (*from, *to),
        }
    }
}

/// The contents of a g2o file, in file order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct G2oFile {
    pub vertices: Vec<G2oVertex>,
    pub edges: Vec<G2oEdge>,
    /// Ids named by `FIX` lines.
    pub fixed: Vec<u64>,
    /// Whether the file is 3D (SE3:QUAT); `None` if it has no vertex or edge.
    pub is_3d: Option<bool>,
}

struct Fields<'a> {
    line: usize,
    tokens: Vec<&'a str>,
}

impl<'a> Fields<'a> {
    fn new(line: usize, tag: &'static str, tokens: Vec<&'a str>, expected: usize) -> Result<Self, G2oError> {
        if tokens.len() != expected {
            return Err(G2oError::FieldCount { line, tag, expected, found: tokens.len() });
        }
        Ok(Self { line, tokens })
    }

    fn bad(&self, i: usize) -> G2oError {
        G2oError::BadNumber { line: self.line, field: i + 1, text: self.tokens[i].to_string() }
    }

    fn id(&self, i: usize) -> Result<u64, G2oError> {
        self.tokens[i].parse().map_err(|_| self.bad(i))
    }

    fn num(&self, i: usize) -> Result<f64, G2oError> {
        match self.tokens[i].parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(self.bad(i)),
        }
    }

    fn quaternion(&self, i: usize) -> Result<UnitQuaternion<f64>, G2oError> {
        let q = Quaternion::new(self.num(i + 3)?, self.num(i)?, self.num(i + 1)?, self.num(i + 2)?);
        if q.norm() == 0.0 {
            return Err(G2oError::ZeroQuaternion { line: self.line });
        }
        Ok(UnitQuaternion::from_quaternion(q))
    }

    /// Upper triangle, row by row, of a D×D symmetric matrix starting at field `i`.
    fn upper<const D: usize>(&self, i: usize) -> Result<SMatrix<f64, D, D>, G2oError> {
        let mut m = SMatrix::<f64, D, D>::zeros();
        let mut k = i;
        for r in 0..D {
            for c in r..D {
                let v = self.num(k)?;
                m[(r, c)] = v;
                m[(c, r)] = v;
                k += 1;
            }
        }
        // Validate it is an information matrix now, so the error names the line.
        GaussianNoise::from_information(&m).map_err(|source| G2oError::Information { line: self.line, source })?;
        Ok(m)
    }
}

fn set_dim(is_3d: &mut Option<bool>, three: bool, line: usize) -> Result<(), G2oError> {
    match *is_3d {
        Some(d) if d != three => Err(G2oError::MixedDimensions { line }),
        _ => {
            *is_3d = Some(three);
            Ok(())
        }
    }
}

/// Parses a g2o file.
pub fn read_g2o(bytes: &[u8]) -> Result<G2oFile, G2oError> {
    let mut file = G2oFile::default();
    let mut seen = std::collections::BTreeSet::new();
    for (n, raw) in bytes.split(|&b| b == b'\n').enumerate() {
        let line = n + 1;
        let text = std::str::from_utf8(raw).map_err(|_| G2oError::NotUtf8 { line })?;
        let text = text.split('#').next().unwrap_or("");
        let mut tokens = text.split_ascii_whitespace();
        let Some(tag) = tokens.next() else { continue };
        let rest: Vec<&str> = tokens.collect();
        match tag {
            "VERTEX_SE2" => {
                let f = Fields::new(line, "VERTEX_SE2", rest, 4)?;
                set_dim(&mut file.is_3d, false, line)?;
                let id = f.id(0)?;
                if !seen.insert(id) {
                    return Err(G2oError::DuplicateVertex { line, id });
                }
                file.vertices.push(G2oVertex::Se2 { id, pose: Se2::new(f.num(1)?, f.num(2)?, f.num(3)?) });
            }
            "VERTEX_SE3:QUAT" => {
                let f = Fields::new(line, "VERTEX_SE3:QUAT", rest, 8)?;
                set_dim(&mut file.is_3d, true, line)?;
                let id = f.id(0)?;
                if !seen.insert(id) {
                    return Err(G2oError::DuplicateVertex { line, id });
                }
                let t = Vector3::new(f.num(1)?, f.num(2)?, f.num(3)?);
                file.vertices.push(G2oVertex::Se3 { id, pose: Se3::new(f.quaternion(4)?, t) });
            }
            "EDGE_SE2" => {
                let f = Fields::new(line, "EDGE_SE2", rest, 11)?;
                set_dim(&mut file.is_3d, false, line)?;
                let (from, to) = (f.id(0)?, f.id(1)?);
                if from == to {
                    return Err(G2oError::SelfLoop { line, id: from });
                }
                let measurement = Se2::new(f.num(2)?, f.num(3)?, f.num(4)?);
                file.edges.push(G2oEdge::Se2 { from, to, measurement, information: f.upper::<3>(5)? });
            }
            "EDGE_SE3:QUAT" => {
                let f = Fields::new(line, "EDGE_SE3:QUAT", rest, 30)?;
                set_dim(&mut file.is_3d, true, line)?;
                let (from, to) = (f.id(0)?, f.id(1)?);
                if from == to {
                    return Err(G2oError::SelfLoop { line, id: from });
                }
                let t = Vector3::new(f.num(2)?, f.num(3)?, f.num(4)?);
                let measurement = Se3::new(f.quaternion(5)?, t);
                file.edges.push(G2oEdge::Se3 { from, to, measurement, information: f.upper::<6>(9)? });
            }
            "FIX" => {
                let f = Fields::new(line, "FIX", rest, 1)?;
                file.fixed.push(f.id(0)?);
            }
            other => return Err(G2oError::UnknownTag { line, tag: other.to_string() }),
        }
    }
    Ok(file)
}

/// Writes a g2o file (shortest round-trip decimal representation of every number).
pub fn write_g2o(file: &G2oFile) -> String {
    let mut s = String::new();
    for v in &file.vertices {
        // Writing to a String cannot fail.
        let _ = match v {
            G2oVertex::Se2 { id, pose } => writeln!(s, "VERTEX_SE2 {id} {} {} {}", pose.x_m, pose.y_m, pose.yaw_rad),
            G2oVertex::Se3 { id, pose } => {
                let (t, q) = (pose.translation, pose.rotation);
                writeln!(s, "VERTEX_SE3:QUAT {id} {} {} {} {} {} {} {}", t.x, t.y, t.z, q.i, q.j, q.k, q.w)
            }
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

impl G2oFile {
    /// Builds the factor graph and initial values, then applies `gauge` (and `FIX` lines).
    /// `se2_residual` chooses the 2D edge error (see [`Se2Residual`]; 3D edges use `Log`).
    pub fn to_problem(&self, gauge: Gauge, se2_residual: Se2Residual) -> Result<Problem, G2oError> {
        // Initial poses: vertices, then GTSAM-style chaining for edges with missing vertices.
        let mut init: BTreeMap<u64, Variable> = BTreeMap::new();
        for v in &self.vertices {
            match v {
                G2oVertex::Se2 { id, pose } => init.insert(*id, Variable::Se2(*pose)),
                G2oVertex::Se3 { id, pose } => init.insert(*id, Variable::Se3(*pose)),
            };
        }
        for e in &self.edges {
            match e {
                G2oEdge::Se2 { from, to, measurement, .. } => {
                    let xi = match init.get(from) {
                        Some(Variable::Se2(p)) => *p,
                        _ => Se2::identity(),
                    };
                    init.entry(*from).or_insert(Variable::Se2(xi));
                    init.entry(*to).or_insert(Variable::Se2(xi * *measurement));
                }
                G2oEdge::Se3 { from, to, measurement, .. } => {
                    let xi = match init.get(from) {
                        Some(Variable::Se3(p)) => *p,
                        _ => Se3::identity(),
                    };
                    init.entry(*from).or_insert(Variable::Se3(xi));
                    init.entry(*to).or_insert(Variable::Se3(xi * *measurement));
                }
            }
        }
        let mut problem = Problem::default();
        let mut var_of: BTreeMap<u64, VarId> = BTreeMap::new();
        for (id, var) in &init {
            let v = problem.values.push(*var);
            var_of.insert(*id, v);
            problem.poses.push((*id, v));
        }
        let var = |id: &u64| var_of.get(id).copied().unwrap_or(VarId(usize::MAX));
        for (k, e) in self.edges.iter().enumerate() {
            let res = match e {
                G2oEdge::Se2 { from, to, measurement, information } => GaussianNoise::from_information(information)
                    .map(|n| problem.graph.add(BetweenSe2::new(var(from), var(to), *measurement, n).with_residual(se2_residual))),
                G2oEdge::Se3 { from, to, measurement, information } => GaussianNoise::from_information(information)
                    .map(|n| problem.graph.add(BetweenSe3::new(var(from), var(to), *measurement, n))),
            };
            match res {
                Ok(Ok(_)) => {}
                Ok(Err(g)) => return Err(G2oError::Gauge(GaugeError::Graph(g))),
                Err(source) => return Err(G2oError::EdgeInformation { edge: k, source }),
            }
        }
        for id in &self.fixed {
            match var_of.get(id) {
                Some(v) => problem.values.set_fixed(*v, true),
                None => return Err(G2oError::UnknownFixed(*id)),
            }
        }
        problem.apply_gauge(gauge)?;
        Ok(problem)
    }

    /// This file with its vertices replaced by the poses in `values` (for writing results).
    pub fn with_poses(&self, problem: &Problem, values: &Values) -> G2oFile {
        let vertices = problem
            .poses
            .iter()
            .filter_map(|&(id, v)| match values.get(v) {
                Some(Variable::Se2(pose)) => Some(G2oVertex::Se2 { id, pose: *pose }),
                Some(Variable::Se3(pose)) => Some(G2oVertex::Se3 { id, pose: *pose }),
                _ => None,
            })
            .collect();
        G2oFile { vertices, edges: self.edges.clone(), fixed: self.fixed.clone(), is_3d: self.is_3d }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SMALL_2D: &str = "# two poses\nVERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1.5 0.1 0.2\n\
        EDGE_SE2 0 1 1.4 0.0 0.25 100 0 0 100 0 400\nFIX 0\n";

    #[test]
    fn reads_2d_with_values() {
        let f = read_g2o(SMALL_2D.as_bytes()).unwrap();
        assert_eq!(f.vertices.len(), 2);
        assert_eq!(f.is_3d, Some(false));
        assert_eq!(f.fixed, vec![0]);
        let G2oEdge::Se2 { from, to, measurement, information } = f.edges[0] else { panic!("2D edge") };
        assert_eq!((from, to), (0, 1));
        assert_eq!(measurement, Se2::new(1.4, 0.0, 0.25));
        assert_eq!(information, Matrix3::new(100.0, 0.0, 0.0, 0.0, 100.0, 0.0, 0.0, 0.0, 400.0));
        // χ² at the file's values by hand: z⁻¹ x₁ = (0.1, 0.1, −0.05) rotated by −0.25
        let p = f.to_problem(Gauge::FixFirst, Se2Residual::Vector).unwrap();
        let (s, c) = (-0.25f64).sin_cos();
        let e = [c * 0.1 - s * 0.1, s * 0.1 + c * 0.1, -0.05];
        let expected = 100.0 * e[0] * e[0] + 100.0 * e[1] * e[1] + 400.0 * e[2] * e[2];
        assert!((p.graph.chi2(&p.values).unwrap() - expected).abs() < 1e-12);
        assert!(p.values.is_fixed(VarId(0)) && !p.values.is_fixed(VarId(1)));
    }

    #[test]
    fn errors_name_the_line() {
        assert_eq!(read_g2o(b"VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 x 0\n"), Err(G2oError::BadNumber { line: 2, field: 3, text: "x".into() }));
        assert_eq!(
            read_g2o(b"\nEDGE_SE2 0 1 0 0 0 1 0 0 1 0\n"),
            Err(G2oError::FieldCount { line: 2, tag: "EDGE_SE2", expected: 11, found: 10 })
        );
        assert_eq!(read_g2o(b"VERTEX_XY 1 2 3\n"), Err(G2oError::UnknownTag { line: 1, tag: "VERTEX_XY".into() }));
        assert!(matches!(read_g2o(b"EDGE_SE2 0 1 0 0 0 1 0 0 -1 0 1\n"), Err(G2oError::Information { line: 1, .. })));
        assert_eq!(read_g2o(b"VERTEX_SE2 0 0 0 0\nVERTEX_SE3:QUAT 1 0 0 0 0 0 0 1\n"), Err(G2oError::MixedDimensions { line: 2 }));
        assert_eq!(read_g2o(b"VERTEX_SE2 3 0 0 0\nVERTEX_SE2 3 1 0 0\n"), Err(G2oError::DuplicateVertex { line: 2, id: 3 }));
        assert_eq!(read_g2o(b"VERTEX_SE3:QUAT 1 0 0 0 0 0 0 0\n"), Err(G2oError::ZeroQuaternion { line: 1 }));
        assert!(matches!(read_g2o(b"VERTEX_SE2 0 nan 0 0\n"), Err(G2oError::BadNumber { line: 1, field: 2, .. })));
        assert!(read_g2o(&[b'V', 0xff, b'\n']).is_err());
    }

    #[test]
    fn bare_edges_chain_like_gtsam() {
        // No vertices: x0 = I, x1 = x0 z01, x2 = x1 z12.
        let f = read_g2o(b"EDGE_SE2 0 1 1 0 1.5707963267948966 1 0 0 1 0 1\nEDGE_SE2 1 2 2 0 0 1 0 0 1 0 1\n").unwrap();
        let p = f.to_problem(Gauge::FixFirst, Se2Residual::Log).unwrap();
        let x2 = p.values.se2(p.poses[2].1).unwrap();
        assert!((x2.x_m - 1.0).abs() < 1e-12 && (x2.y_m - 2.0).abs() < 1e-12);
        assert!(p.graph.chi2(&p.values).unwrap() < 1e-20);
    }

    fn roundtrip(path: &str) {
        let bytes = std::fs::read(path).unwrap();
        let a = read_g2o(&bytes).unwrap();
        let b = read_g2o(write_g2o(&a).as_bytes()).unwrap();
        assert_eq!(a.vertices.len(), b.vertices.len());
        assert_eq!(a.edges.len(), b.edges.len());
        for (u, v) in a.vertices.iter().zip(&b.vertices) {
            match (u, v) {
                (G2oVertex::Se2 { .. }, G2oVertex::Se2 { .. }) => assert_eq!(u, v),
                (G2oVertex::Se3 { id: i, pose: p }, G2oVertex::Se3 { id: j, pose: q }) => {
                    assert_eq!(i, j);
                    assert_eq!(p.translation, q.translation);
                    assert!((p.rotation.coords - q.rotation.coords).amax() < 1e-15);
                }
                _ => panic!("vertex kind changed"),
            }
        }
        for (u, v) in a.edges.iter().zip(&b.edges) {
            match (u, v) {
                (G2oEdge::Se2 { .. }, G2oEdge::Se2 { .. }) => assert_eq!(u, v),
                (
                    G2oEdge::Se3 { from: f1, to: t1, measurement: m1, information: i1 },
                    G2oEdge::Se3 { from: f2, to: t2, measurement: m2, information: i2 },
                ) => {
                    assert_eq!((f1, t1, i1), (f2, t2, i2));
                    assert_eq!(m1.translation, m2.translation);
                    assert!((m1.rotation.coords - m2.rotation.coords).amax() < 1e-15);
                }
                _ => panic!("edge kind changed"),
            }
        }
    }

    #[test]
    fn roundtrip_real_2d_and_3d_files() {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/data/slam/");
        roundtrip(&format!("{dir}intel.g2o"));
        roundtrip(&format!("{dir}smallGrid3D.g2o"));
    }

    #[test]
    fn real_file_sizes() {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/data/slam/");
        let f = read_g2o(&std::fs::read(format!("{dir}parking-garage.g2o")).unwrap()).unwrap();
        assert_eq!((f.vertices.len(), f.edges.len(), f.is_3d), (1661, 6275, Some(true)));
        let f = read_g2o(&std::fs::read(format!("{dir}CSAIL.g2o")).unwrap()).unwrap();
        assert_eq!((f.vertices.len(), f.edges.len()), (0, 1172));
        let p = f.to_problem(Gauge::FixFirst, Se2Residual::Log).unwrap();
        assert_eq!(p.values.len(), 1045);
    }
}
