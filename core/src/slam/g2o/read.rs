//! Reading a g2o file: one pass over the bytes, errors naming the 1-based line.

use std::collections::{BTreeMap, BTreeSet};

use nalgebra::{Quaternion, SMatrix, UnitQuaternion, Vector2, Vector3};

use super::{G2oEdge, G2oError, G2oFile, G2oVertex, SkippedTag};
use crate::slam::factors::GaussianNoise;
use crate::slam::lie::{Se2, Se3};

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

    /// The id in field 0 of a vertex line, not seen before.
    fn new_vertex(&self, seen: &mut BTreeSet<u64>) -> Result<u64, G2oError> {
        let id = self.id(0)?;
        if !seen.insert(id) {
            return Err(G2oError::DuplicateVertex { line: self.line, id });
        }
        Ok(id)
    }

    /// The two distinct ids in fields 0 and 1 of an edge line.
    fn edge_ends(&self) -> Result<(u64, u64), G2oError> {
        let (from, to) = (self.id(0)?, self.id(1)?);
        if from == to {
            return Err(G2oError::SelfLoop { line: self.line, id: from });
        }
        Ok((from, to))
    }

    fn num(&self, i: usize) -> Result<f64, G2oError> {
        match self.tokens[i].parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(self.bad(i)),
        }
    }

    /// The three numbers from field `i`.
    fn vector3(&self, i: usize) -> Result<Vector3<f64>, G2oError> {
        Ok(Vector3::new(self.num(i)?, self.num(i + 1)?, self.num(i + 2)?))
    }

    /// `x y z qx qy qz qw` from field `i`.
    fn se3(&self, i: usize) -> Result<Se3, G2oError> {
        Ok(Se3::new(self.quaternion(i + 3)?, self.vector3(i)?))
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

/// The tags read: (tag, fields after it, whether it is 3D; `None`: either).
const TAGS: [(&str, usize, Option<bool>); 10] = [
    ("VERTEX_SE2", 4, Some(false)),
    ("VERTEX_SE3:QUAT", 8, Some(true)),
    ("VERTEX_XY", 3, Some(false)),
    ("VERTEX_TRACKXYZ", 4, Some(true)),
    ("EDGE_SE2", 11, Some(false)),
    ("EDGE_SE3:QUAT", 30, Some(true)),
    ("EDGE_SE2_XY", 7, Some(false)),
    ("EDGE_SE3_TRACKXYZ", 12, Some(true)),
    ("PARAMS_SE3OFFSET", 8, Some(true)),
    ("FIX", 1, None),
];

/// Parses a g2o file.
pub fn read_g2o(bytes: &[u8]) -> Result<G2oFile, G2oError> {
    let mut file = G2oFile::default();
    let mut seen = BTreeSet::new();
    let mut skipped_index: BTreeMap<String, usize> = BTreeMap::new();
    // Each id an edge uses, with the first edge that uses it: (line, 0 for `from` or 1 for `to`, tag).
    let mut used: BTreeMap<u64, (usize, u8, &'static str)> = BTreeMap::new();
    for (n, raw) in crate::io::without_bom(bytes).split(|&b| b == b'\n').enumerate() {
        let line = n + 1;
        let text = std::str::from_utf8(raw).map_err(|_| G2oError::NotUtf8 { line })?;
        let text = text.split('#').next().unwrap_or("");
        let mut tokens = text.split_ascii_whitespace();
        let Some(tag) = tokens.next() else { continue };
        let rest: Vec<&str> = tokens.collect();
        let Some(&(tag, fields, three_d)) = TAGS.iter().find(|t| t.0 == tag) else {
            let tag: String = tag.chars().take(40).collect();
            match skipped_index.get(&tag) {
                Some(&k) => file.skipped[k].lines += 1,
                None => {
                    skipped_index.insert(tag.clone(), file.skipped.len());
                    file.skipped.push(SkippedTag { tag, lines: 1, first_line: line });
                }
            }
            continue;
        };
        let f = Fields::new(line, tag, rest, fields)?;
        if let Some(three) = three_d {
            set_dim(&mut file.is_3d, three, line)?;
        }
        match tag {
            "VERTEX_SE2" => {
                let id = f.new_vertex(&mut seen)?;
                file.vertices.push(G2oVertex::Se2 { id, pose: Se2::new(f.num(1)?, f.num(2)?, f.num(3)?) });
            }
            "VERTEX_SE3:QUAT" => {
                let id = f.new_vertex(&mut seen)?;
                file.vertices.push(G2oVertex::Se3 { id, pose: f.se3(1)? });
            }
            "VERTEX_XY" => {
                let id = f.new_vertex(&mut seen)?;
                file.vertices.push(G2oVertex::Point2 { id, point: Vector2::new(f.num(1)?, f.num(2)?) });
            }
            "VERTEX_TRACKXYZ" => {
                let id = f.new_vertex(&mut seen)?;
                file.vertices.push(G2oVertex::Point3 { id, point: f.vector3(1)? });
            }
            "EDGE_SE2" => {
                let (from, to) = f.edge_ends()?;
                let measurement = Se2::new(f.num(2)?, f.num(3)?, f.num(4)?);
                file.edges.push(G2oEdge::Se2 { from, to, measurement, information: f.upper::<3>(5)? });
            }
            "EDGE_SE3:QUAT" => {
                let (from, to) = f.edge_ends()?;
                file.edges.push(G2oEdge::Se3 { from, to, measurement: f.se3(2)?, information: f.upper::<6>(9)? });
            }
            "EDGE_SE2_XY" => {
                let (from, to) = f.edge_ends()?;
                let measurement = Vector2::new(f.num(2)?, f.num(3)?);
                file.edges.push(G2oEdge::Se2Point2 { from, to, measurement, information: f.upper::<2>(4)? });
            }
            "EDGE_SE3_TRACKXYZ" => {
                let ((from, to), offset) = (f.edge_ends()?, f.id(2)?);
                file.edges.push(G2oEdge::Se3Point3 { from, to, offset, measurement: f.vector3(3)?, information: f.upper::<3>(6)? });
            }
            "PARAMS_SE3OFFSET" => {
                let id = f.id(0)?;
                if file.offsets.insert(id, f.se3(1)?).is_some() {
                    return Err(G2oError::DuplicateOffset { line, id });
                }
            }
            "FIX" => file.fixed.push(f.id(0)?),
            // Every tag of `TAGS` has its arm above.
            other => return Err(G2oError::UnknownTag { line, tag: other.to_string() }),
        }
        if let Some(edge) = file.edges.last().filter(|_| tag.starts_with("EDGE_")) {
            let (from, to) = edge.ids();
            for (end, id) in [(0, from), (1, to)] {
                used.entry(id).or_insert((line, end, tag));
            }
        }
    }
    if !file.vertices.is_empty() {
        let undefined = used.into_iter().filter(|(id, _)| !seen.contains(id)).min_by_key(|&(_, (line, end, _))| (line, end));
        if let Some((id, (line, _, tag))) = undefined {
            return Err(G2oError::UndefinedVertex { line, tag, id });
        }
    }
    Ok(file)
}
