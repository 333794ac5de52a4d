//! g2o graph files, pose graphs and landmark graphs:
//! - 2D: `VERTEX_SE2 id x y θ`, `EDGE_SE2 i j x y θ` + 6 information entries, landmarks
//!   `VERTEX_XY id x y` and `EDGE_SE2_XY i j x y` + 3 (the point in pose i's frame);
//! - 3D: `VERTEX_SE3:QUAT id x y z qx qy qz qw`, `EDGE_SE3:QUAT i j x y z qx qy qz qw` + 21,
//!   landmarks `VERTEX_TRACKXYZ id x y z` and `EDGE_SE3_TRACKXYZ i j k x y z` + 6 (the point in
//!   the frame of sensor k, whose pose on the robot is `PARAMS_SE3OFFSET k x y z qx qy qz qw`);
//! - `FIX id`.
//!
//! Information matrices are upper triangles, row by row; the SE(3) one is in (t, R) order, which
//! is our tangent order (GTSAM permutes it to (R, t)). Quaternions are normalised on reading (as
//! GTSAM does). `#` starts a comment. Lines with other tags are skipped, as g2o and GTSAM skip
//! them, and listed in [`G2oFile::skipped`] (tag, count, first line) for the caller to report.
//!
//! Reading is one pass over the bytes, O(size); errors name the 1-based line. A file with vertex
//! lines must define every vertex its edges use (before or after the edge): an edge to an
//! undefined vertex is an error naming the first such edge's line, not a vertex invented for it.
//! To a [`Problem`]: vertices become variables by increasing id; in a file of bare edges (no
//! vertex line, e.g. CSAIL) the vertices are initialised as GTSAM's `load2D` does (an unknown `i`
//! at the identity, an unknown `j` at `x_i · z_ij`), in file order, so such files start from
//! composed odometry.
//! A sensor-frame point `z` seen through offset `o` becomes the robot-frame observation `o · z`
//! with information `R_o Ω R_oᵀ`, which has the same residual norm: g2o's error is
//! `(x o)⁻¹ m − z = R_oᵀ (x⁻¹ m − o · z)`.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;

use nalgebra::{Matrix2, Matrix3, Matrix6, Quaternion, SMatrix, UnitQuaternion, Vector2, Vector3};
use thiserror::Error;

use super::factors::{BetweenSe2, BetweenSe3, GaussianNoise, NoiseError, PointObservation2, PointObservation3, Se2Residual};
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
    /// An edge uses a vertex that no `VERTEX_*` line defines, in a file that has vertex lines
    /// (the first such edge; files of bare edges have none and are chained instead).
    #[error("line {line}: {tag} uses vertex {id}, which no VERTEX line defines")]
    UndefinedVertex { line: usize, tag: &'static str, id: u64 },
    #[error("FIX of vertex {0}, which no vertex or edge defines")]
    UnknownFixed(u64),
    #[error("edge {edge} (0-based): information matrix: {source}")]
    EdgeInformation { edge: usize, source: NoiseError },
    #[error("edge {edge} (0-based): vertex {id} is a {found}, the edge needs a {expected}")]
    VertexKind { edge: usize, id: u64, expected: &'static str, found: &'static str },
    #[error("edge {edge} (0-based): sensor offset {id} has no PARAMS_SE3OFFSET line")]
    UnknownOffset { edge: usize, id: u64 },
    #[error("line {line}: PARAMS_SE3OFFSET {id} defined twice")]
    DuplicateOffset { line: usize, id: u64 },
    #[error("gauge: {0}")]
    Gauge(#[from] GaugeError),
}

/// A vertex (initial estimate of a pose or a landmark).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum G2oVertex {
    Se2 { id: u64, pose: Se2 },
    Se3 { id: u64, pose: Se3 },
    Point2 { id: u64, point: Vector2<f64> },
    Point3 { id: u64, point: Vector3<f64> },
}

impl G2oVertex {
    pub fn id(&self) -> u64 {
        match self {
            G2oVertex::Se2 { id, .. } | G2oVertex::Se3 { id, .. } | G2oVertex::Point2 { id, .. } | G2oVertex::Point3 { id, .. } => *id,
        }
    }

    fn variable(&self) -> Variable {
        match *self {
            G2oVertex::Se2 { pose, .. } => Variable::Se2(pose),
            G2oVertex::Se3 { pose, .. } => Variable::Se3(pose),
            G2oVertex::Point2 { point, .. } => Variable::Point2(point),
            G2oVertex::Point3 { point, .. } => Variable::Point3(point),
        }
    }
}

/// An edge with its information matrix: a relative pose `z ≈ x_from⁻¹ x_to`, or a landmark `to`
/// seen from pose `from` (in the robot frame, or in the frame of sensor `offset`).
// Edges live in one Vec read once; boxing the 3D variant would cost an allocation per edge.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum G2oEdge {
    Se2 { from: u64, to: u64, measurement: Se2, information: Matrix3<f64> },
    Se3 { from: u64, to: u64, measurement: Se3, information: Matrix6<f64> },
    Se2Point2 { from: u64, to: u64, measurement: Vector2<f64>, information: Matrix2<f64> },
    Se3Point3 { from: u64, to: u64, offset: u64, measurement: Vector3<f64>, information: Matrix3<f64> },
}

impl G2oEdge {
    pub fn ids(&self) -> (u64, u64) {
        match self {
            G2oEdge::Se2 { from, to, .. }
            | G2oEdge::Se3 { from, to, .. }
            | G2oEdge::Se2Point2 { from, to, .. }
            | G2oEdge::Se3Point3 { from, to, .. } => (*from, *to),
        }
    }
}

/// The name of a variable's kind, for errors.
fn kind(v: &Variable) -> &'static str {
    match v {
        Variable::Se2(_) => "SE2 pose",
        Variable::Se3(_) => "SE3 pose",
        Variable::Point2(_) => "2D point",
        Variable::Point3(_) => "3D point",
    }
}

/// The contents of a g2o file, in file order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct G2oFile {
    pub vertices: Vec<G2oVertex>,
    pub edges: Vec<G2oEdge>,
    /// Ids named by `FIX` lines.
    pub fixed: Vec<u64>,
    /// `PARAMS_SE3OFFSET` sensor poses on the robot, by id.
    pub offsets: BTreeMap<u64, Se3>,
    /// Whether the file is 3D (SE3:QUAT); `None` if it has no vertex or edge.
    pub is_3d: Option<bool>,
    /// Tags not read, in order of first appearance (e.g. `EDGE_SE2_PRIOR`, `PARAMS_CAMERACALIB`).
    pub skipped: Vec<SkippedTag>,
}

/// Lines skipped by [`read_g2o`] for one tag it does not read.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SkippedTag {
    /// The tag (its first 40 characters).
    pub tag: String,
    /// How many lines had it.
    pub lines: usize,
    /// The first of them (1-based).
    pub first_line: usize,
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

impl G2oFile {
    /// Builds the factor graph and initial values, then applies `FIX` lines and `gauge`
    /// ([`Gauge::FixFirst`] only when no `FIX` line fixes a vertex, as g2o does).
    /// `se2_residual` chooses the 2D edge error (see [`Se2Residual`]; 3D edges use `Log`).
    pub fn to_problem(&self, gauge: Gauge, se2_residual: Se2Residual) -> Result<Problem, G2oError> {
        // Initial values: vertices, then GTSAM-style chaining for edges with missing vertices.
        let mut init: BTreeMap<u64, Variable> = self.vertices.iter().map(|v| (v.id(), v.variable())).collect();
        for (k, e) in self.edges.iter().enumerate() {
            let (from, to) = e.ids();
            let at = init.get(&from).copied();
            let se2 = match at {
                Some(Variable::Se2(p)) => p,
                _ => Se2::identity(),
            };
            let se3 = match at {
                Some(Variable::Se3(p)) => p,
                _ => Se3::identity(),
            };
            let (pose, seen) = match *e {
                G2oEdge::Se2 { measurement, .. } => (Variable::Se2(se2), Variable::Se2(se2 * measurement)),
                G2oEdge::Se2Point2 { measurement, .. } => (Variable::Se2(se2), Variable::Point2(se2.transform_point(&measurement))),
                G2oEdge::Se3 { measurement, .. } => (Variable::Se3(se3), Variable::Se3(se3 * measurement)),
                G2oEdge::Se3Point3 { offset, measurement, .. } => {
                    let o = self.offsets.get(&offset).ok_or(G2oError::UnknownOffset { edge: k, id: offset })?;
                    (Variable::Se3(se3), Variable::Point3(se3.transform_point(&o.transform_point(&measurement))))
                }
            };
            init.entry(from).or_insert(pose);
            init.entry(to).or_insert(seen);
        }
        let mut problem = Problem::default();
        let mut var_of: BTreeMap<u64, VarId> = BTreeMap::new();
        for (id, var) in &init {
            let v = problem.values.push(*var);
            var_of.insert(*id, v);
            match var {
                Variable::Se2(_) | Variable::Se3(_) => problem.poses.push((*id, v)),
                Variable::Point2(_) | Variable::Point3(_) => problem.landmarks.push((*id, v)),
            }
        }
        // Every id of an edge is in `init` now; its kind must be the edge's.
        let var = |edge: usize, id: u64, expected: &'static str| {
            let found = kind(&init[&id]);
            if found == expected { Ok(var_of[&id]) } else { Err(G2oError::VertexKind { edge, id, expected, found }) }
        };
        for (k, e) in self.edges.iter().enumerate() {
            let information = |source| G2oError::EdgeInformation { edge: k, source };
            let added = match *e {
                G2oEdge::Se2 { from, to, measurement, information: info } => {
                    let (a, b) = (var(k, from, "SE2 pose")?, var(k, to, "SE2 pose")?);
                    let noise = GaussianNoise::from_information(&info).map_err(information)?;
                    problem.graph.add(BetweenSe2::new(a, b, measurement, noise).with_residual(se2_residual))
                }
                G2oEdge::Se3 { from, to, measurement, information: info } => {
                    let (a, b) = (var(k, from, "SE3 pose")?, var(k, to, "SE3 pose")?);
                    let noise = GaussianNoise::from_information(&info).map_err(information)?;
                    problem.graph.add(BetweenSe3::new(a, b, measurement, noise))
                }
                G2oEdge::Se2Point2 { from, to, measurement, information: info } => {
                    let (a, m) = (var(k, from, "SE2 pose")?, var(k, to, "2D point")?);
                    let noise = GaussianNoise::from_information(&info).map_err(information)?;
                    problem.graph.add(PointObservation2::new(a, m, measurement, noise))
                }
                G2oEdge::Se3Point3 { from, to, offset, measurement, information: info } => {
                    let (a, m) = (var(k, from, "SE3 pose")?, var(k, to, "3D point")?);
                    // Present: checked while initialising.
                    let o = self.offsets[&offset];
                    let r = o.rotation_matrix();
                    let noise = GaussianNoise::from_information(&(r * info * r.transpose())).map_err(information)?;
                    problem.graph.add(PointObservation3::new(a, m, o.transform_point(&measurement), noise))
                }
            };
            added.map_err(|g| G2oError::Gauge(GaugeError::Graph(g)))?;
        }
        for id in &self.fixed {
            match var_of.get(id) {
                Some(v) => problem.values.set_fixed(*v, true),
                None => return Err(G2oError::UnknownFixed(*id)),
            }
        }
        // g2o fixes the first pose only when the file fixes nothing itself.
        let gauge = if gauge == Gauge::FixFirst && !self.fixed.is_empty() { Gauge::Free } else { gauge };
        problem.apply_gauge(gauge)?;
        Ok(problem)
    }

    /// This file with its vertices replaced by the poses and landmarks in `values` (for writing
    /// results).
    pub fn with_poses(&self, problem: &Problem, values: &Values) -> G2oFile {
        let vertices = problem
            .poses
            .iter()
            .chain(&problem.landmarks)
            .filter_map(|&(id, v)| match values.get(v) {
                Some(Variable::Se2(pose)) => Some(G2oVertex::Se2 { id, pose: *pose }),
                Some(Variable::Se3(pose)) => Some(G2oVertex::Se3 { id, pose: *pose }),
                Some(Variable::Point2(point)) => Some(G2oVertex::Point2 { id, point: *point }),
                Some(Variable::Point3(point)) => Some(G2oVertex::Point3 { id, point: *point }),
                None => None,
            })
            .collect();
        G2oFile {
            vertices,
            edges: self.edges.clone(),
            fixed: self.fixed.clone(),
            offsets: self.offsets.clone(),
            is_3d: self.is_3d,
            skipped: self.skipped.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::slam::optimizer::{LevenbergMarquardt, Optimizer, OptimizerParams};

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
    fn fix_lines_replace_the_first_pose_gauge() {
        // FIX 1 anchors the graph: pose 0 stays free and moves to satisfy the edge from pose 1.
        let text = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nFIX 1\nEDGE_SE2 0 1 1.2 0 0.1 1 0 0 1 0 1\n";
        let f = read_g2o(text.as_bytes()).unwrap();
        let mut p = f.to_problem(Gauge::FixFirst, Se2Residual::Log).unwrap();
        assert!(!p.values.is_fixed(VarId(0)) && p.values.is_fixed(VarId(1)));
        LevenbergMarquardt::new(OptimizerParams::default()).optimize(&p.graph, &mut p.values).unwrap();
        assert!(p.graph.chi2(&p.values).unwrap() < 1e-18);
        assert_eq!(p.values.se2(VarId(1)).unwrap(), Se2::new(1.0, 0.0, 0.0));
        // Without FIX lines the first pose is the gauge.
        let q = read_g2o(text.replace("FIX 1\n", "").as_bytes()).unwrap().to_problem(Gauge::FixFirst, Se2Residual::Log).unwrap();
        assert!(q.values.is_fixed(VarId(0)) && !q.values.is_fixed(VarId(1)));
    }

    #[test]
    fn errors_name_the_line() {
        assert_eq!(read_g2o(b"VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 x 0\n"), Err(G2oError::BadNumber { line: 2, field: 3, text: "x".into() }));
        assert_eq!(
            read_g2o(b"\nEDGE_SE2 0 1 0 0 0 1 0 0 1 0\n"),
            Err(G2oError::FieldCount { line: 2, tag: "EDGE_SE2", expected: 11, found: 10 })
        );
        // Other tags are skipped, as g2o and GTSAM skip them, and listed.
        let f = read_g2o(b"VERTEX_XY 1 2 3\nEDGE_PRIOR_SE2 1\nTUTORIAL_PARAMS 0\nEDGE_PRIOR_SE2 2 1 1\n").unwrap();
        assert_eq!(f.vertices.len(), 1);
        let skipped = |tag: &str, lines, first_line| SkippedTag { tag: tag.into(), lines, first_line };
        assert_eq!(f.skipped, vec![skipped("EDGE_PRIOR_SE2", 2, 2), skipped("TUTORIAL_PARAMS", 1, 3)]);
        assert_eq!(read_g2o(b"VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_XY 1 2 3\n"), Err(G2oError::MixedDimensions { line: 2 }));
        let offset = b"PARAMS_SE3OFFSET 0 0 0 0 0 0 0 1\n";
        assert_eq!(read_g2o(&[&offset[..], offset].concat()), Err(G2oError::DuplicateOffset { line: 2, id: 0 }));
        assert!(matches!(read_g2o(b"EDGE_SE2 0 1 0 0 0 1 0 0 -1 0 1\n"), Err(G2oError::Information { line: 1, .. })));
        assert_eq!(read_g2o(b"VERTEX_SE2 0 0 0 0\nVERTEX_SE3:QUAT 1 0 0 0 0 0 0 1\n"), Err(G2oError::MixedDimensions { line: 2 }));
        assert_eq!(read_g2o(b"VERTEX_SE2 3 0 0 0\nVERTEX_SE2 3 1 0 0\n"), Err(G2oError::DuplicateVertex { line: 2, id: 3 }));
        assert_eq!(read_g2o(b"VERTEX_SE3:QUAT 1 0 0 0 0 0 0 0\n"), Err(G2oError::ZeroQuaternion { line: 1 }));
        assert!(matches!(read_g2o(b"VERTEX_SE2 0 nan 0 0\n"), Err(G2oError::BadNumber { line: 1, field: 2, .. })));
        assert!(read_g2o(&[b'V', 0xff, b'\n']).is_err());
    }

    #[test]
    fn landmark_edges_on_the_wrong_vertex_kind_or_offset_are_errors() {
        let f = read_g2o(b"VERTEX_SE2 0 0 0 0\nVERTEX_XY 1 2 3\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n").unwrap();
        assert_eq!(
            f.to_problem(Gauge::FixFirst, Se2Residual::Log).unwrap_err(),
            G2oError::VertexKind { edge: 0, id: 1, expected: "SE2 pose", found: "2D point" }
        );
        let f = read_g2o(b"VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_TRACKXYZ 1 1 2 3\nEDGE_SE3_TRACKXYZ 0 1 7 1 2 3 1 0 0 1 0 1\n").unwrap();
        assert_eq!(f.to_problem(Gauge::FixFirst, Se2Residual::Log).unwrap_err(), G2oError::UnknownOffset { edge: 0, id: 7 });
    }

    #[test]
    fn landmarks_2d_hand_chi2_and_optimum() {
        // Pose 0 at the origin, pose 1 at (2, 0) facing +y; landmark 5 at (2, 3): seen at (2, 3)
        // from pose 0 and at (3, 0) from pose 1.
        let text = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 2 0 1.5707963267948966\nVERTEX_XY 5 2.5 2.5\n\
            EDGE_SE2 0 1 2 0 1.5707963267948966 100 0 0 100 0 100\n\
            EDGE_SE2_XY 0 5 2 3 4 0 25\nEDGE_SE2_XY 1 5 3 0 9 1 16\n";
        let f = read_g2o(text.as_bytes()).unwrap();
        assert_eq!(f.is_3d, Some(false));
        let mut p = f.to_problem(Gauge::FixFirst, Se2Residual::Log).unwrap();
        assert_eq!((p.poses.len(), p.landmarks.len(), p.graph.len()), (2, 1, 3));
        // At the file's values: from pose 0, e = (0.5, −0.5), χ² = 4·0.25 + 25·0.25 = 7.25; from
        // pose 1, p = Rᵀ(0.5, 2.5) = (2.5, −0.5), e = (−0.5, −0.5), χ² = 9·0.25 + 2·1·0.25 + 16·0.25
        // = 6.75; the odometry edge is exact.
        assert!((p.graph.chi2(&p.values).unwrap() - 14.0).abs() < 1e-12);
        let s = LevenbergMarquardt::new(OptimizerParams::default()).optimize(&p.graph, &mut p.values).unwrap();
        assert!(s.final_chi2 < 1e-16, "{s:?}");
        let m = p.values.point2(p.landmarks[0].1).unwrap();
        assert!((m - Vector2::new(2.0, 3.0)).norm() < 1e-8);
        // Round trip, with the optimised landmark written back.
        let back = read_g2o(write_g2o(&f.with_poses(&p, &p.values)).as_bytes()).unwrap();
        assert_eq!(back.edges, f.edges);
        assert!(matches!(back.vertices[2], G2oVertex::Point2 { id: 5, point } if (point - Vector2::new(2.0, 3.0)).norm() < 1e-8));
    }

    #[test]
    fn landmarks_3d_through_a_sensor_offset_match_g2os_error() {
        // Sensor 3 sits 0.2 m ahead of the robot, turned −π/2 about z (looking right).
        let text = "PARAMS_SE3OFFSET 3 0.2 0 0 0 0 -0.7071067811865476 0.7071067811865476\n\
            VERTEX_SE3:QUAT 0 1 2 0 0 0 0.3894183423086505 0.9210609940028851\n\
            VERTEX_TRACKXYZ 9 4 5 1\n\
            EDGE_SE3_TRACKXYZ 0 9 3 0.5 1.5 0.8 4 1 0 9 -2 16\n";
        let f = read_g2o(text.as_bytes()).unwrap();
        let p = f.to_problem(Gauge::Free, Se2Residual::Log).unwrap();
        // g2o's error, by hand from its definition: e = (x o)⁻¹ m − z, χ² = eᵀ Ω e.
        let x = Se3::new(
            UnitQuaternion::from_quaternion(Quaternion::new(0.9210609940028851, 0.0, 0.0, 0.3894183423086505)),
            Vector3::new(1.0, 2.0, 0.0),
        );
        let o = Se3::new(
            UnitQuaternion::from_quaternion(Quaternion::new(std::f64::consts::FRAC_1_SQRT_2, 0.0, 0.0, -std::f64::consts::FRAC_1_SQRT_2)),
            Vector3::new(0.2, 0.0, 0.0),
        );
        let e = (x * o).inverse_transform_point(&Vector3::new(4.0, 5.0, 1.0)) - Vector3::new(0.5, 1.5, 0.8);
        let omega = Matrix3::new(4.0, 1.0, 0.0, 1.0, 9.0, -2.0, 0.0, -2.0, 16.0);
        let expected = (e.transpose() * omega * e)[0];
        assert!(expected > 1.0, "a test point with a real error: {expected}");
        assert!((p.graph.chi2(&p.values).unwrap() - expected).abs() < 1e-10 * expected);
        // A missing landmark vertex in a file with vertices is an error (it was once invented).
        let missing = text.replace("VERTEX_TRACKXYZ 9 4 5 1\n", "");
        assert_eq!(read_g2o(missing.as_bytes()), Err(G2oError::UndefinedVertex { line: 3, tag: "EDGE_SE3_TRACKXYZ", id: 9 }));
        // In a file of bare edges the landmark starts where the edge puts it: zero error.
        let bare = read_g2o(missing.replace("VERTEX_SE3:QUAT 0 1 2 0 0 0 0.3894183423086505 0.9210609940028851\n", "").as_bytes()).unwrap();
        assert!(bare.vertices.is_empty());
        let q = bare.to_problem(Gauge::Free, Se2Residual::Log).unwrap();
        assert!(q.graph.chi2(&q.values).unwrap() < 1e-20);
        let back = read_g2o(write_g2o(&f).as_bytes()).unwrap();
        assert_eq!((back.offsets.len(), back.edges.len()), (1, 1));
        assert_eq!(back.edges, f.edges);
    }

    proptest::proptest! {
        /// Mutated and truncated files give a problem or a typed error, never a panic.
        #[test]
        fn mutated_files_never_panic(edits in proptest::collection::vec((proptest::prelude::any::<proptest::sample::Index>(), proptest::prelude::any::<u8>()), 1..4), cut in proptest::prelude::any::<proptest::sample::Index>(), three_d in proptest::prelude::any::<bool>()) {
            let text: &[u8] = if three_d {
                b"PARAMS_SE3OFFSET 3 0.2 0 0 0 0 0 1\nVERTEX_SE3:QUAT 0 1 2 0 0 0 0 1\nVERTEX_TRACKXYZ 9 4 5 1\nEDGE_SE3_TRACKXYZ 0 9 3 0.5 1.5 0.8 4 1 0 9 -2 16\nEDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1 1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1\nFIX 0\n"
            } else {
                b"VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 2 0 1.5\nVERTEX_XY 5 2.5 2.5\nEDGE_SE2 0 1 2 0 1.5 100 0 0 100 0 100\nEDGE_SE2_XY 0 5 2 3 4 0 25\nFIX 1\n"
            };
            let mut m = text.to_vec();
            for (pos, byte) in edits {
                let i = pos.index(m.len());
                m[i] = byte;
            }
            m.truncate(cut.index(m.len() + 1));
            if let Ok(f) = read_g2o(&m) {
                let _ = f.to_problem(Gauge::FixFirst, Se2Residual::Log);
            }
        }
    }

    /// An edge to a vertex no VERTEX line defines was once given an invented vertex (reported as
    /// the last pose); in a file with vertex lines it is an error naming the first such edge.
    #[test]
    fn edges_to_undefined_vertices_are_errors() {
        let text = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_SE2 2 2 0 0\n\
            EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\nEDGE_SE2 1 2 1 0 0 1 0 0 1 0 1\nEDGE_SE2 1 7 1 0 0 1 0 0 1 0 1\n";
        let e = read_g2o(text.as_bytes()).unwrap_err();
        assert_eq!(e, G2oError::UndefinedVertex { line: 6, tag: "EDGE_SE2", id: 7 });
        assert_eq!(e.to_string(), "line 6: EDGE_SE2 uses vertex 7, which no VERTEX line defines");
        // The first offending edge in file order, its `from` before its `to`.
        let two = "VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 9 1 0 0 1 0 0 1 0 1\nEDGE_SE2 8 3 1 0 0 1 0 0 1 0 1\n";
        assert_eq!(read_g2o(two.as_bytes()), Err(G2oError::UndefinedVertex { line: 2, tag: "EDGE_SE2", id: 9 }));
        let two = "VERTEX_SE2 0 0 0 0\nEDGE_SE2 8 3 1 0 0 1 0 0 1 0 1\n";
        assert_eq!(read_g2o(two.as_bytes()), Err(G2oError::UndefinedVertex { line: 2, tag: "EDGE_SE2", id: 8 }));
        // A landmark edge to an undefined landmark.
        let lm = "VERTEX_SE2 0 0 0 0\nVERTEX_XY 5 1 1\nEDGE_SE2_XY 0 5 1 1 1 0 1\nEDGE_SE2_XY 0 6 1 1 1 0 1\n";
        assert_eq!(read_g2o(lm.as_bytes()), Err(G2oError::UndefinedVertex { line: 4, tag: "EDGE_SE2_XY", id: 6 }));
        // A vertex defined after the edge that uses it is fine, as before.
        let late = "VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\nVERTEX_SE2 1 1 0 0\n";
        let p = read_g2o(late.as_bytes()).unwrap().to_problem(Gauge::FixFirst, Se2Residual::Log).unwrap();
        assert_eq!(p.poses.len(), 2);
        assert!(p.graph.chi2(&p.values).unwrap() < 1e-20);
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
