//! A g2o graph replayed as an online SLAM run, one [`Isam2::update`] per step, in vertex order
//! (increasing file id, poses and landmarks alike): step k adds the edges whose later end is
//! vertex k, with vertex k and any vertex first linked by them (a vertex linked only to later
//! ones enters with them). A new vertex starts at the current estimate of a known vertex composed
//! with the first of the step's edges that links them (file order); a vertex no such edge reaches
//! (a pose seen only from a landmark) starts at the file's value. The first pose is anchored by a
//! prior at its file value (GTSAM's gauge, as `--prior-sigma`). Vertices without edges never
//! enter. Building the schedule is O(E log V); each step adds its edges in O(edges).

use std::collections::BTreeMap;

use super::{IncrementalError, Isam2};
use crate::slam::factors::{
    BetweenSe2, BetweenSe3, Factor, GaussianNoise, NoiseError, PointObservation2, PointObservation3, PriorSe2, PriorSe3, RobustKernel,
    Se2Residual,
};
use crate::slam::g2o::{G2oEdge, G2oFile, G2oVertex};
use crate::slam::lie::{Se2, Se3};
use crate::slam::values::{VarId, Variable};

/// Why a g2o file could not be replayed.
#[derive(Clone, Debug, thiserror::Error, PartialEq)]
pub enum ReplayError {
    /// An edge's information matrix cannot weigh a factor.
    #[error("edge {edge} (0-based): information matrix: {source}")]
    Information {
        /// 0-based index into [`G2oFile::edges`].
        edge: usize,
        /// What is wrong with the matrix.
        source: NoiseError,
    },
    /// The first pose's prior sigma cannot make a noise model (not finite or not > 0).
    #[error("first-pose prior: {0}")]
    Prior(NoiseError),
    /// An `EDGE_SE3_TRACKXYZ` names a sensor offset that no `PARAMS_SE3OFFSET` line defines.
    #[error("edge {edge} (0-based): sensor offset {id} has no PARAMS_SE3OFFSET line")]
    UnknownOffset {
        /// 0-based index into [`G2oFile::edges`].
        edge: usize,
        /// The offset id.
        id: u64,
    },
    /// An edge joins vertices of the wrong kinds.
    #[error("edge {edge} (0-based): vertex {id} is a {found}, the edge needs a {expected}")]
    VertexKind {
        /// 0-based index into [`G2oFile::edges`].
        edge: usize,
        /// The vertex id.
        id: u64,
        /// The kind the edge needs (e.g. `"Point2"`).
        expected: &'static str,
        /// The vertex's kind.
        found: &'static str,
    },
    /// The file has no pose vertex to anchor.
    #[error("the graph has no pose")]
    NoPose,
    /// The incremental solver failed.
    #[error(transparent)]
    Solver(#[from] IncrementalError),
}

/// The update schedule of a g2o file.
#[derive(Debug)]
pub struct G2oReplay<'a> {
    file: &'a G2oFile,
    se2_residual: Se2Residual,
    prior_sigma: f64,
    /// On every landmark edge (g2o files carry no kernel).
    landmark_kernel: RobustKernel,
    /// File id of every vertex, by rank (increasing id).
    ids: Vec<u64>,
    /// The file's value of every vertex (identity / origin for ids only edges name).
    initial: Vec<Variable>,
    /// Per step: (rank of the step's vertex, edges in file order).
    steps: Vec<(usize, Vec<usize>)>,
    first_pose: usize,
    /// Solver variable of every rank, once entered.
    var_of: Vec<Option<VarId>>,
    next_step: usize,
}

impl<'a> G2oReplay<'a> {
    /// The schedule of `file`, its first pose anchored by a prior of standard deviation
    /// `prior_sigma` on every tangent component.
    pub fn new(file: &'a G2oFile, se2_residual: Se2Residual, prior_sigma: f64) -> Result<Self, ReplayError> {
        let mut by_id: BTreeMap<u64, Variable> = BTreeMap::new();
        for v in &file.vertices {
            let var = match *v {
                G2oVertex::Se2 { pose, .. } => Variable::Se2(pose),
                G2oVertex::Se3 { pose, .. } => Variable::Se3(pose),
                G2oVertex::Point2 { point, .. } => Variable::Point2(point),
                G2oVertex::Point3 { point, .. } => Variable::Point3(point),
            };
            by_id.insert(v.id(), var);
        }
        for e in &file.edges {
            let (from, to) = e.ids();
            let (a, b) = match e {
                G2oEdge::Se2 { .. } => (Variable::Se2(Se2::identity()), Variable::Se2(Se2::identity())),
                G2oEdge::Se3 { .. } => (Variable::Se3(Se3::identity()), Variable::Se3(Se3::identity())),
                G2oEdge::Se2Point2 { .. } => (Variable::Se2(Se2::identity()), Variable::Point2(nalgebra::Vector2::zeros())),
                G2oEdge::Se3Point3 { .. } => (Variable::Se3(Se3::identity()), Variable::Point3(nalgebra::Vector3::zeros())),
            };
            by_id.entry(from).or_insert(a);
            by_id.entry(to).or_insert(b);
        }
        let ids: Vec<u64> = by_id.keys().copied().collect();
        let initial: Vec<Variable> = by_id.values().copied().collect();
        let rank = |id: u64| ids.partition_point(|&x| x < id);
        let first_pose = initial.iter().position(|v| matches!(v, Variable::Se2(_) | Variable::Se3(_))).ok_or(ReplayError::NoPose)?;
        let mut at_rank: Vec<Vec<usize>> = vec![Vec::new(); ids.len()];
        for (k, e) in file.edges.iter().enumerate() {
            let (from, to) = e.ids();
            at_rank[rank(from).max(rank(to))].push(k);
        }
        let steps: Vec<(usize, Vec<usize>)> =
            at_rank.into_iter().enumerate().filter(|(r, edges)| !edges.is_empty() || *r == first_pose).collect();
        let n = ids.len();
        Ok(Self {
            file,
            se2_residual,
            prior_sigma,
            landmark_kernel: RobustKernel::None,
            ids,
            initial,
            steps,
            first_pose,
            var_of: vec![None; n],
            next_step: 0,
        })
    }

    /// The same schedule with `kernel` on every landmark observation (`EDGE_SE2_XY`,
    /// `EDGE_SE3_TRACKXYZ`), e.g. the simulator SLAM's Cauchy kernel on a graph it exported.
    pub fn with_landmark_kernel(self, kernel: RobustKernel) -> Self {
        Self { landmark_kernel: kernel, ..self }
    }

    /// Number of updates.
    pub fn len(&self) -> usize {
        self.steps.len()
    }

    /// Whether there is no update.
    pub fn is_empty(&self) -> bool {
        self.steps.is_empty()
    }

    /// The solver variable of a file id, once it entered.
    pub fn var_of(&self, id: u64) -> Option<VarId> {
        let r = self.ids.partition_point(|&x| x < id);
        if self.ids.get(r) == Some(&id) { self.var_of[r] } else { None }
    }

    /// Runs the next step on `isam`; returns the variable of the step's vertex (the newest), or
    /// `None` when every step ran.
    pub fn step(&mut self, isam: &mut Isam2) -> Result<Option<VarId>, ReplayError> {
        let Some((vertex, edges)) = self.steps.get(self.next_step) else { return Ok(None) };
        let (vertex, edges) = (*vertex, edges.clone());
        self.next_step += 1;
        let rank = |id: u64| self.ids.partition_point(|&x| x < id);
        // New vertices, initialised by composition (passes until no edge reaches a new one).
        let mut fresh: BTreeMap<usize, Option<Variable>> = BTreeMap::new();
        if self.var_of[vertex].is_none() {
            fresh.insert(vertex, None);
        }
        for &k in &edges {
            let (from, to) = self.file.edges[k].ids();
            for r in [rank(from), rank(to)] {
                if self.var_of[r].is_none() {
                    fresh.entry(r).or_insert(None);
                }
            }
        }
        if let Some(v) = fresh.get_mut(&self.first_pose) {
            *v = Some(self.initial[self.first_pose]);
        }
        loop {
            let mut progress = false;
            for &k in &edges {
                let e = &self.file.edges[k];
                let (from, to) = e.ids();
                let (rf, rt) = (rank(from), rank(to));
                let known = |r: usize| match fresh.get(&r) {
                    Some(v) => *v,
                    None => self.var_of[r].and_then(|v| isam.estimate_of(v)),
                };
                let composed = match (
                    known(rf),
                    known(rt),
                    fresh.get(&rf).is_some_and(Option::is_none),
                    fresh.get(&rt).is_some_and(Option::is_none),
                ) {
                    (Some(a), None, _, true) => compose_forward(e, &a, self.file).map(|v| (rt, v)),
                    (None, Some(b), true, _) => compose_backward(e, &b).map(|v| (rf, v)),
                    _ => None,
                };
                if let Some((r, v)) = composed {
                    fresh.insert(r, Some(v));
                    progress = true;
                }
            }
            if !progress {
                break;
            }
        }
        let mut new_variables = Vec::with_capacity(fresh.len());
        for (&r, v) in &fresh {
            self.var_of[r] = Some(VarId(isam.len() + new_variables.len()));
            new_variables.push(v.unwrap_or(self.initial[r]));
        }
        let mut factors: Vec<Box<dyn Factor>> = Vec::with_capacity(edges.len() + 1);
        if fresh.contains_key(&self.first_pose)
            && let Some(v) = self.var_of[self.first_pose]
        {
            factors.push(match self.initial[self.first_pose] {
                Variable::Se3(p) => {
                    Box::new(PriorSe3::new(v, p, GaussianNoise::isotropic(6, self.prior_sigma).map_err(ReplayError::Prior)?))
                }
                Variable::Se2(p) => {
                    Box::new(PriorSe2::new(v, p, GaussianNoise::isotropic(3, self.prior_sigma).map_err(ReplayError::Prior)?))
                }
                _ => return Err(ReplayError::NoPose),
            });
        }
        for &k in &edges {
            factors.push(self.factor(k, &rank)?);
        }
        isam.update(&new_variables, factors)?;
        Ok(self.var_of[vertex])
    }

    fn factor(&self, k: usize, rank: &dyn Fn(u64) -> usize) -> Result<Box<dyn Factor>, ReplayError> {
        let e = &self.file.edges[k];
        let (from, to) = e.ids();
        let var = |id: u64, expected: &'static str, ok: fn(&Variable) -> bool| {
            let r = rank(id);
            match (self.var_of[r], ok(&self.initial[r])) {
                (Some(v), true) => Ok(v),
                _ => Err(ReplayError::VertexKind { edge: k, id, expected, found: self.initial[r].kind() }),
            }
        };
        let information = |source| ReplayError::Information { edge: k, source };
        Ok(match *e {
            G2oEdge::Se2 { measurement, information: info, .. } => {
                let is = |v: &Variable| matches!(v, Variable::Se2(_));
                let noise = GaussianNoise::from_information(&info).map_err(information)?;
                Box::new(BetweenSe2::new(var(from, "SE2", is)?, var(to, "SE2", is)?, measurement, noise).with_residual(self.se2_residual))
            }
            G2oEdge::Se3 { measurement, information: info, .. } => {
                let is = |v: &Variable| matches!(v, Variable::Se3(_));
                let noise = GaussianNoise::from_information(&info).map_err(information)?;
                Box::new(BetweenSe3::new(var(from, "SE3", is)?, var(to, "SE3", is)?, measurement, noise))
            }
            G2oEdge::Se2Point2 { measurement, information: info, .. } => {
                let noise = GaussianNoise::from_information(&info).map_err(information)?.with_kernel(self.landmark_kernel);
                let pose = var(from, "SE2", |v| matches!(v, Variable::Se2(_)))?;
                Box::new(PointObservation2::new(pose, var(to, "Point2", |v| matches!(v, Variable::Point2(_)))?, measurement, noise))
            }
            G2oEdge::Se3Point3 { offset, measurement, information: info, .. } => {
                let o = self.file.offsets.get(&offset).ok_or(ReplayError::UnknownOffset { edge: k, id: offset })?;
                let r = o.rotation_matrix();
                let noise =
                    GaussianNoise::from_information(&(r * info * r.transpose())).map_err(information)?.with_kernel(self.landmark_kernel);
                let pose = var(from, "SE3", |v| matches!(v, Variable::Se3(_)))?;
                let point = var(to, "Point3", |v| matches!(v, Variable::Point3(_)))?;
                Box::new(PointObservation3::new(pose, point, o.transform_point(&measurement), noise))
            }
        })
    }
}

/// The `to` end of an edge from its `from` end: `x_from · z`, or the landmark `x_from · z`.
fn compose_forward(e: &G2oEdge, from: &Variable, file: &G2oFile) -> Option<Variable> {
    match (*e, from) {
        (G2oEdge::Se2 { measurement, .. }, Variable::Se2(p)) => Some(Variable::Se2(*p * measurement)),
        (G2oEdge::Se3 { measurement, .. }, Variable::Se3(p)) => Some(Variable::Se3(*p * measurement)),
        (G2oEdge::Se2Point2 { measurement, .. }, Variable::Se2(p)) => Some(Variable::Point2(p.transform_point(&measurement))),
        (G2oEdge::Se3Point3 { offset, measurement, .. }, Variable::Se3(p)) => {
            file.offsets.get(&offset).map(|o| Variable::Point3(p.transform_point(&o.transform_point(&measurement))))
        }
        _ => None,
    }
}

/// The `from` end of a pose edge from its `to` end: `x_to · z⁻¹` (a landmark does not give a pose).
fn compose_backward(e: &G2oEdge, to: &Variable) -> Option<Variable> {
    match (*e, to) {
        (G2oEdge::Se2 { measurement, .. }, Variable::Se2(p)) => Some(Variable::Se2(*p * measurement.inverse())),
        (G2oEdge::Se3 { measurement, .. }, Variable::Se3(p)) => Some(Variable::Se3(*p * measurement.inverse())),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::slam::g2o::read_g2o;
    use crate::slam::incremental::Isam2Params;
    use nalgebra::Vector2;

    /// Exact measurements of a known scene (the file's vertex values are all zero, so every
    /// vertex but the first must come from composition): landmark 1 is seen only from the later
    /// pose 2, pose 3 is linked only to the later pose 4, landmark 5 from poses 0 and 4.
    /// Truth: x0 = (0, 0, 0), x2 = (1, 0, 0), x3 = (2, −1, π/2), x4 = (2, 0, π/2),
    /// l1 = (1.5, 1), l5 = (3, 2); each measurement is the later end in the earlier's frame,
    /// e.g. l5 from x4: R(−π/2) ((3, 2) − (2, 0)) = (2, −1).
    const SCENE: &str = "\
VERTEX_SE2 0 0 0 0
VERTEX_XY 1 0 0
VERTEX_SE2 2 0 0 0
VERTEX_SE2 3 0 0 0
VERTEX_SE2 4 0 0 0
VERTEX_XY 5 0 0
EDGE_SE2 0 2 1 0 0 100 0 0 100 0 1000
EDGE_SE2_XY 2 1 0.5 1 100 0 100
EDGE_SE2 3 4 1 0 0 100 0 0 100 0 1000
EDGE_SE2 2 4 1 0 1.5707963267948966 100 0 0 100 0 1000
EDGE_SE2_XY 0 5 3 2 100 0 100
EDGE_SE2_XY 4 5 2 -1 100 0 100
";

    fn pose(isam: &Isam2, replay: &G2oReplay, id: u64) -> Se2 {
        match replay.var_of(id).and_then(|v| isam.estimate_of(v)) {
            Some(Variable::Se2(p)) => p,
            other => panic!("vertex {id}: {other:?}"),
        }
    }

    fn point(isam: &Isam2, replay: &G2oReplay, id: u64) -> Vector2<f64> {
        match replay.var_of(id).and_then(|v| isam.estimate_of(v)) {
            Some(Variable::Point2(p)) => p,
            other => panic!("vertex {id}: {other:?}"),
        }
    }

    fn near(p: Se2, x: f64, y: f64, yaw: f64) -> bool {
        (p.x_m - x).abs() < 1e-9 && (p.y_m - y).abs() < 1e-9 && (p.yaw_rad - yaw).abs() < 1e-9
    }

    #[test]
    fn vertices_enter_in_id_order_with_the_edges_whose_later_end_they_are() {
        let file = read_g2o(SCENE.as_bytes()).unwrap();
        let mut replay = G2oReplay::new(&file, Se2Residual::Log, 1e-3).unwrap();
        // Steps: vertex 0 (the anchor), 2 (with landmark 1), 4 (with pose 3), 5.
        assert_eq!(replay.len(), 4);
        let mut isam = isam_fresh();
        let entered = |r: &G2oReplay| [0, 1, 2, 3, 4, 5].map(|id| r.var_of(id).is_some());
        assert_eq!(replay.step(&mut isam).unwrap(), Some(VarId(0)));
        assert_eq!(entered(&replay), [true, false, false, false, false, false]);
        assert!(replay.step(&mut isam).unwrap().is_some());
        assert_eq!(entered(&replay), [true, true, true, false, false, false]);
        assert!(near(pose(&isam, &replay, 2), 1.0, 0.0, 0.0));
        assert!((point(&isam, &replay, 1) - Vector2::new(1.5, 1.0)).amax() < 1e-9, "composed forward from the later pose");
        assert!(replay.step(&mut isam).unwrap().is_some());
        let half_pi = std::f64::consts::FRAC_PI_2;
        assert!(near(pose(&isam, &replay, 4), 2.0, 0.0, half_pi));
        assert!(near(pose(&isam, &replay, 3), 2.0, -1.0, half_pi), "composed backward: {:?}", pose(&isam, &replay, 3));
        assert_eq!(replay.step(&mut isam).unwrap(), replay.var_of(5));
        assert!((point(&isam, &replay, 5) - Vector2::new(3.0, 2.0)).amax() < 1e-9);
        assert_eq!(replay.step(&mut isam).unwrap(), None, "every step ran");
        assert!(isam.chi2().unwrap() < 1e-12);
        // The anchor plus the six edges.
        assert_eq!(isam.graph().len(), 7);
    }

    #[test]
    fn malformed_graphs_give_typed_errors() {
        let no_pose = read_g2o(b"VERTEX_XY 0 1 2\nVERTEX_XY 1 1 2\n").unwrap();
        assert!(matches!(G2oReplay::new(&no_pose, Se2Residual::Log, 1e-3), Err(ReplayError::NoPose)));
        // A landmark edge whose landmark is a pose.
        let kind = read_g2o(b"VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 0 0\nEDGE_SE2_XY 0 1 1 0 1 0 1\n").unwrap();
        let mut replay = G2oReplay::new(&kind, Se2Residual::Log, 1e-3).unwrap();
        let mut isam = isam_fresh();
        replay.step(&mut isam).unwrap();
        let err = replay.step(&mut isam).unwrap_err();
        assert_eq!(err, ReplayError::VertexKind { edge: 0, id: 1, expected: "Point2", found: "SE2" });
        // A non-positive prior σ.
        let ok = read_g2o(SCENE.as_bytes()).unwrap();
        let mut replay = G2oReplay::new(&ok, Se2Residual::Log, 0.0).unwrap();
        assert!(matches!(replay.step(&mut isam_fresh()), Err(ReplayError::Prior(_))));
    }

    fn isam_fresh() -> Isam2 {
        Isam2::new(Isam2Params::default())
    }

    /// A landmark kernel holds a landmark against a gross outlier: l5 is seen at (3, 2) from x0
    /// and, 10 m off, at (−7, 2) from x4 (σ 0.1 m each, as weak as the odometry). Least squares
    /// drags l5 (and the poses) metres towards the outlier; a Cauchy kernel (k = 1) weighs the
    /// outlier's s ≈ 100 residual by ≈ 10⁻⁴ and keeps l5 where its first sighting put it.
    #[test]
    fn a_landmark_kernel_holds_the_landmark_against_an_outlier() {
        let outlier = SCENE.replace("EDGE_SE2_XY 4 5 2 -1 ", "EDGE_SE2_XY 4 5 2 9 ");
        let file = read_g2o(outlier.as_bytes()).unwrap();
        let l5 = |kernel: RobustKernel| {
            let mut replay = G2oReplay::new(&file, Se2Residual::Log, 1e-3).unwrap().with_landmark_kernel(kernel);
            let mut isam = isam_fresh();
            while replay.step(&mut isam).unwrap().is_some() {}
            point(&isam, &replay, 5)
        };
        let plain = l5(RobustKernel::None);
        assert!((plain - Vector2::new(3.0, 2.0)).norm() > 1.0, "least squares: {plain}");
        let robust = l5(RobustKernel::Cauchy { k: 1.0 });
        assert!((robust - Vector2::new(3.0, 2.0)).amax() < 0.05, "Cauchy: {robust}");
    }
}
