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

use std::collections::BTreeMap;

use nalgebra::{Matrix2, Matrix3, Matrix6, Vector2, Vector3};
use thiserror::Error;

use super::factors::{BetweenSe2, BetweenSe3, GaussianNoise, Measurement, NoiseError, PointObservation2, PointObservation3, Se2Residual};
use super::lie::{Se2, Se3};
use super::problem::{Gauge, GaugeError, Problem};
use super::values::{Values, VarId, Variable};

mod read;
mod write;

pub use read::read_g2o;
pub use write::write_g2o;

/// Why a g2o file could not be read or turned into a [`Problem`]. `line` is 1-based; `edge` is
/// the 0-based index into [`G2oFile::edges`].
#[derive(Clone, Debug, Error, PartialEq)]
pub enum G2oError {
    /// A line is not valid UTF-8.
    #[error("line {line}: not valid UTF-8")]
    NotUtf8 {
        /// 1-based line number.
        line: usize,
    },
    /// A tag the reader lists but does not parse (an internal inconsistency: tags of a file
    /// that the reader does not know are skipped and listed in [`G2oFile::skipped`]).
    #[error("line {line}: unknown tag `{tag}`")]
    UnknownTag {
        /// 1-based line number.
        line: usize,
        /// The tag.
        tag: String,
    },
    /// A line has the wrong number of fields after its tag.
    #[error("line {line}: {tag} needs {expected} fields, found {found}")]
    FieldCount {
        /// 1-based line number.
        line: usize,
        /// The line's tag.
        tag: &'static str,
        /// Fields the tag needs after it.
        expected: usize,
        /// Fields the line has after its tag.
        found: usize,
    },
    /// A field is not a finite number (or, where an id is expected, not an unsigned integer).
    #[error("line {line}: field {field} (`{text}`) is not a finite number or id")]
    BadNumber {
        /// 1-based line number.
        line: usize,
        /// 1-based position of the field after the tag.
        field: usize,
        /// The field's text.
        text: String,
    },
    /// Two vertex lines define the same id.
    #[error("line {line}: vertex {id} defined twice")]
    DuplicateVertex {
        /// 1-based line number of the second definition.
        line: usize,
        /// The vertex id.
        id: u64,
    },
    /// A 2D element (`*_SE2*`, `VERTEX_XY`) in a 3D file, or the reverse.
    #[error("line {line}: 2D and 3D elements mixed in one file")]
    MixedDimensions {
        /// 1-based line number of the first element of the other dimension.
        line: usize,
    },
    /// A quaternion that cannot be normalised.
    #[error("line {line}: quaternion has zero norm")]
    ZeroQuaternion {
        /// 1-based line number.
        line: usize,
    },
    /// An edge whose two ends are the same vertex.
    #[error("line {line}: edge connects vertex {id} to itself")]
    SelfLoop {
        /// 1-based line number.
        line: usize,
        /// The vertex id.
        id: u64,
    },
    /// An edge's information matrix is not symmetric positive definite and finite.
    #[error("line {line}: information matrix: {source}")]
    Information {
        /// 1-based line number.
        line: usize,
        /// What is wrong with the matrix.
        source: NoiseError,
    },
    /// An edge uses a vertex that no `VERTEX_*` line defines, in a file that has vertex lines
    /// (the first such edge; files of bare edges have none and are chained instead).
    #[error("line {line}: {tag} uses vertex {id}, which no VERTEX line defines")]
    UndefinedVertex {
        /// 1-based line number of the edge.
        line: usize,
        /// The edge's tag.
        tag: &'static str,
        /// The undefined vertex id.
        id: u64,
    },
    /// A `FIX` line names an id that no vertex or edge has (the id).
    #[error("FIX of vertex {0}, which no vertex or edge defines")]
    UnknownFixed(u64),
    /// An edge's information matrix cannot weigh a factor.
    #[error("edge {edge} (0-based): information matrix: {source}")]
    EdgeInformation {
        /// 0-based index into [`G2oFile::edges`].
        edge: usize,
        /// What is wrong with the matrix.
        source: NoiseError,
    },
    /// An edge joins vertices of the wrong kinds (e.g. a pose edge to a landmark).
    #[error("edge {edge} (0-based): vertex {id} is a {found}, the edge needs a {expected}")]
    VertexKind {
        /// 0-based index into [`G2oFile::edges`].
        edge: usize,
        /// The vertex id.
        id: u64,
        /// The kind the edge needs (e.g. `"SE3 pose"`).
        expected: &'static str,
        /// The vertex's kind.
        found: &'static str,
    },
    /// An `EDGE_SE3_TRACKXYZ` names a sensor offset that no `PARAMS_SE3OFFSET` line defines.
    #[error("edge {edge} (0-based): sensor offset {id} has no PARAMS_SE3OFFSET line")]
    UnknownOffset {
        /// 0-based index into [`G2oFile::edges`].
        edge: usize,
        /// The offset id.
        id: u64,
    },
    /// Two `PARAMS_SE3OFFSET` lines define the same id.
    #[error("line {line}: PARAMS_SE3OFFSET {id} defined twice")]
    DuplicateOffset {
        /// 1-based line number of the second definition.
        line: usize,
        /// The offset id.
        id: u64,
    },
    /// The gauge (which variables are held fixed) could not be applied.
    #[error("gauge: {0}")]
    Gauge(#[from] GaugeError),
}

/// A vertex (initial estimate of a pose or a landmark).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum G2oVertex {
    /// `VERTEX_SE2`: a planar pose in the world frame.
    Se2 {
        /// The vertex id.
        id: u64,
        /// The pose (x, y in metres, θ in radians).
        pose: Se2,
    },
    /// `VERTEX_SE3:QUAT`: a 3D pose in the world frame.
    Se3 {
        /// The vertex id.
        id: u64,
        /// The pose (translation in metres, unit quaternion).
        pose: Se3,
    },
    /// `VERTEX_XY`: a 2D landmark in the world frame.
    Point2 {
        /// The vertex id.
        id: u64,
        /// The position, metres.
        point: Vector2<f64>,
    },
    /// `VERTEX_TRACKXYZ`: a 3D landmark in the world frame.
    Point3 {
        /// The vertex id.
        id: u64,
        /// The position, metres.
        point: Vector3<f64>,
    },
}

impl G2oVertex {
    /// The vertex id.
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
    /// `EDGE_SE2`: a relative planar pose.
    Se2 {
        /// The pose vertex the measurement is taken from.
        from: u64,
        /// The pose vertex measured.
        to: u64,
        /// Pose of `to` in the frame of `from` (x, y in metres, θ in radians).
        measurement: Se2,
        /// Information matrix in (x, y, θ) order.
        information: Matrix3<f64>,
    },
    /// `EDGE_SE3:QUAT`: a relative 3D pose.
    Se3 {
        /// The pose vertex the measurement is taken from.
        from: u64,
        /// The pose vertex measured.
        to: u64,
        /// Pose of `to` in the frame of `from` (translation in metres).
        measurement: Se3,
        /// Information matrix in (translation, rotation) tangent order.
        information: Matrix6<f64>,
    },
    /// `EDGE_SE2_XY`: a 2D landmark seen from a planar pose.
    Se2Point2 {
        /// The pose vertex.
        from: u64,
        /// The landmark vertex.
        to: u64,
        /// The landmark in the frame of `from`, metres.
        measurement: Vector2<f64>,
        /// Information matrix of the point, m⁻².
        information: Matrix2<f64>,
    },
    /// `EDGE_SE3_TRACKXYZ`: a 3D landmark seen by a sensor on a 3D pose.
    Se3Point3 {
        /// The pose vertex.
        from: u64,
        /// The landmark vertex.
        to: u64,
        /// The `PARAMS_SE3OFFSET` id of the sensor's pose on the robot.
        offset: u64,
        /// The landmark in the sensor frame, metres.
        measurement: Vector3<f64>,
        /// Information matrix of the point in the sensor frame, m⁻².
        information: Matrix3<f64>,
    },
}

impl G2oEdge {
    /// The ids of the edge's two vertices, `(from, to)`.
    pub fn ids(&self) -> (u64, u64) {
        match self {
            G2oEdge::Se2 { from, to, .. }
            | G2oEdge::Se3 { from, to, .. }
            | G2oEdge::Se2Point2 { from, to, .. }
            | G2oEdge::Se3Point3 { from, to, .. } => (*from, *to),
        }
    }

    /// The edge of a factor's measurement, its variables numbered `id(var)`: a relative pose as
    /// `EDGE_SE3:QUAT`, a point seen from a pose as `EDGE_SE3_TRACKXYZ` through sensor offset 0
    /// (which a file must hold as the identity).
    pub fn of_measurement(m: &Measurement, id: impl Fn(VarId) -> u64) -> Self {
        match *m {
            Measurement::Se3Between { from, to, z, information } => {
                G2oEdge::Se3 { from: id(from), to: id(to), measurement: z, information }
            }
            Measurement::Point3InSe3 { pose, point, point_in_pose, information } => {
                G2oEdge::Se3Point3 { from: id(pose), to: id(point), offset: 0, measurement: point_in_pose, information }
            }
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
    /// Vertex lines, in file order.
    pub vertices: Vec<G2oVertex>,
    /// Edge lines, in file order.
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
mod tests;
