//! Keyframe graph SLAM for the simulator (notes §1, paper eq. 1): SE(3) keyframe poses and
//! 3D landmarks, odometry factors between consecutive keyframes, point observations in the
//! robot frame, the first keyframe anchored (the gauge).
//!
//! Two solvers keep the estimate ([`SlamSolver`]); both give the keyframe poses, the landmark
//! positions with their 3×3 marginal covariances and the current pose's 6×6 marginal covariance
//! of the *full* problem at the current linearisation, anchored at the first keyframe.
//! - **Incremental** (default): every keyframe, loop closures included, is one [`Isam2`] update:
//!   only the Bayes-tree cliques the new factors and the relinearised variables touch are
//!   re-eliminated, and the newest pose sits in the root clique, so its marginal costs
//!   O(|root|²). The first keyframe is held by a prior of σ [`ANCHOR_SIGMA`] on every tangent
//!   component (a fixed variable has no place in a Bayes tree; the prior adds ~10⁻¹² to the
//!   variances).
//! - **Batch**: after each keyframe a sliding window optimises only the last `window_keyframes`
//!   keyframes and the landmarks they saw, everything older fixed (their factors still
//!   constrain the window), by sparse LM; a **loop closure** triggers a full LM. A marginal
//!   factorises the whole information matrix (sparse Cholesky; a pose marginal is 6 solves,
//!   landmark marginals 3 per landmark). The first keyframe is fixed.
//!
//! A **loop closure** is a landmark re-observed `loop_closure_gap_keyframes` or more keyframes
//! after it was last seen; [`KeyframeUpdate::full`] marks one outside the cool-down
//! (`full_cooldown_keyframes`), after which old keyframes may have moved.

use std::collections::BTreeMap;

use nalgebra::{Matrix3, Matrix6, Vector3};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::factors::{BetweenSe3, Factor, GaussianNoise, GravitySe3, NoiseError, PointObservation3, PriorSe3, RobustKernel};
use super::g2o::{G2oFile, G2oVertex};
use super::graph::{FactorGraph, GraphError};
use super::incremental::{IncrementalError, Isam2, Isam2Params};
use super::lie::Se3;
use super::marginals::{MarginalError, Marginals};
use super::optimizer::{LevenbergMarquardt, OptError, Optimizer, OptimizerParams, Summary, Termination};
use super::values::{Values, VarId, Variable};

/// σ of the incremental solver's prior on the first keyframe, on every tangent component (m,
/// rad): the gauge, tight enough that the anchored marginals match the batch solver's fixed
/// first keyframe to ~10⁻⁹ relative.
pub const ANCHOR_SIGMA: f64 = 1e-6;

/// Cauchy scale of the landmark observations, σ of the whitened 3-D residual. An inlier's norm
/// is below √(χ²₃ at 95 %) = 2.8 in 95 % of cases, where the weight 1/(1 + s²/k²) stays ≥ 0.67;
/// a wrong match 1 m off a 3 cm σ (s ≈ 30) weighs 0.02.
pub const OBSERVATION_CAUCHY_K: f64 = 4.0;

/// Which solver keeps [`GraphSlam`]'s estimate (see the module doc).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SlamSolver {
    /// iSAM2: one Bayes-tree update per keyframe, the exact marginal from the root.
    #[default]
    Incremental,
    /// Sliding-window LM per keyframe, full LM per loop closure, marginals by a full sparse
    /// Cholesky.
    Batch,
}

/// Parameters of [`GraphSlam`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GraphSlamParams {
    /// Incremental (iSAM2, default) or batch.
    pub solver: SlamSolver,
    /// The incremental solver's relinearisation and back-substitution thresholds. Default:
    /// GTSAM's ([`Isam2Params::default`]).
    pub isam2: Isam2Params,
    /// Batch: keyframes optimised by a sliding-window update (the most recent ones). Default 10.
    pub window_keyframes: usize,
    /// A landmark seen again after this many keyframes without being seen closes a loop.
    /// Default 20.
    pub loop_closure_gap_keyframes: usize,
    /// After a loop closure marked [`KeyframeUpdate::full`], closures within this many
    /// keyframes are not marked (batch: handled by the window update, the re-observed landmarks
    /// free in it, anchored by their old observations; one revisit re-observes many old
    /// landmarks over several keyframes, and each would otherwise re-run the full problem).
    /// Default 0 (every closure is marked).
    pub full_cooldown_keyframes: usize,
    /// The robust kernel on every landmark observation (wrong data associations). Default
    /// Cauchy with k = [`OBSERVATION_CAUCHY_K`] (decision 0018): its influence falls back to 0
    /// for a gross mismatch, where Huber's only stops growing.
    pub observation_kernel: RobustKernel,
    /// Batch: stopping rules of each optimisation, and the factorisation of it and of the
    /// marginals ([`super::Factorisation`]); both solvers: of [`SlamBackend::optimize_full`].
    /// Default: [`OptimizerParams::default`] with 20 iterations.
    pub optimizer: OptimizerParams,
}

impl Default for GraphSlamParams {
    fn default() -> Self {
        Self {
            solver: SlamSolver::default(),
            isam2: Isam2Params::default(),
            window_keyframes: 10,
            loop_closure_gap_keyframes: 20,
            full_cooldown_keyframes: 0,
            observation_kernel: RobustKernel::Cauchy { k: OBSERVATION_CAUCHY_K },
            optimizer: OptimizerParams { max_iterations: 20, ..OptimizerParams::default() },
        }
    }
}

/// Proprioception between consecutive keyframes: the relative motion measured by odometry and,
/// optionally, the IMU's gravity direction at the new keyframe.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Odometry {
    pub previous_from_current: Se3,
    /// Covariance in the tangent of `previous_from_current`, ξ = (δt, δφ), body frame.
    pub covariance: Matrix6<f64>,
    /// Absolute roll/pitch of the new keyframe ([`super::factors::GravitySe3`]); `None`: no IMU
    /// attitude (tilt then drifts with the odometry and is held only by landmarks).
    pub gravity: Option<Gravity>,
}

/// The accelerometer's "up" direction in the body frame and its angular noise.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Gravity {
    pub up_in_body: Vector3<f64>,
    /// σ of the tilt, radians (per body axis).
    pub sigma_rad: f64,
}

/// A landmark seen from the current keyframe.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LandmarkObservation {
    pub landmark_id: u64,
    pub point_in_robot: Vector3<f64>,
    /// Covariance of `point_in_robot`, m².
    pub covariance: Matrix3<f64>,
}

/// A landmark's estimate.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LandmarkEstimate {
    pub landmark_id: u64,
    pub position_in_world: Vector3<f64>,
    /// Marginal covariance, m² (world frame).
    pub covariance: Matrix3<f64>,
}

/// What [`SlamBackend::add_keyframe`] did.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct KeyframeUpdate {
    /// Index of the new keyframe (the first one is 0).
    pub keyframe: usize,
    /// Landmarks that closed a loop.
    pub loop_closures: Vec<u64>,
    /// A loop closure outside the cool-down: the batch solver optimised the whole graph, the
    /// incremental one re-eliminated what the closure touched; old keyframes may have moved.
    pub full: bool,
    /// The batch solver's optimisation (`None` for the incremental one, which does not evaluate
    /// the whole graph's error per update).
    pub summary: Option<Summary>,
}

/// Traces of a 6×6 pose covariance (notes §1 asks to log all three).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CovarianceTraces {
    /// Trace of the whole block (m² + rad², what the paper plots).
    pub cov_trace: f64,
    pub pos_cov_trace: f64,
    pub rot_cov_trace: f64,
}

impl CovarianceTraces {
    pub fn of(covariance: &Matrix6<f64>) -> Self {
        let pos = covariance[(0, 0)] + covariance[(1, 1)] + covariance[(2, 2)];
        let rot = covariance[(3, 3)] + covariance[(4, 4)] + covariance[(5, 5)];
        Self { cov_trace: pos + rot, pos_cov_trace: pos, rot_cov_trace: rot }
    }
}

#[derive(Clone, Debug, Error, PartialEq)]
pub enum SlamError {
    #[error("odometry or observation covariance: {0}")]
    Noise(#[from] NoiseError),
    #[error(transparent)]
    Graph(#[from] GraphError),
    /// The estimate holds the best values found.
    #[error("optimisation: {0}")]
    Optimization(#[from] OptError),
    #[error("marginals: {0}")]
    Marginal(#[from] MarginalError),
    #[error("incremental solver: {0}")]
    Incremental(#[from] IncrementalError),
    #[error("non-finite odometry or observation")]
    NonFinite,
}

/// A SLAM back end as the simulator and the robot see it.
pub trait SlamBackend {
    /// Adds a keyframe reached by `odometry` from the previous one, with what it observes, and
    /// updates the estimate.
    fn add_keyframe(&mut self, odometry: &Odometry, observations: &[LandmarkObservation]) -> Result<KeyframeUpdate, SlamError>;
    /// Optimises the whole graph (first keyframe anchored) to convergence.
    fn optimize_full(&mut self) -> Result<Summary, SlamError>;
    /// `world_from_keyframe` of every keyframe, oldest first.
    fn keyframe_poses(&self) -> Vec<Se3>;
    /// Landmarks by increasing id, with marginal covariances.
    fn landmarks(&self) -> Result<Vec<LandmarkEstimate>, SlamError>;
    /// Marginal covariance of the latest keyframe, ξ = (δt, δφ), body frame, anchored at the
    /// first keyframe.
    fn current_pose_covariance(&self) -> Result<Matrix6<f64>, SlamError>;
}

#[derive(Clone, Copy, Debug)]
struct LandmarkState {
    var: VarId,
    last_seen_keyframe: usize,
}

/// The batch solver's state.
#[derive(Debug)]
struct Batch {
    graph: FactorGraph,
    values: Values,
    optimizer: LevenbergMarquardt,
}

/// The incremental solver and what the current keyframe adds to it.
#[derive(Debug)]
struct Incremental {
    isam: Isam2,
    new_variables: Vec<Variable>,
    new_factors: Vec<Box<dyn Factor>>,
}

#[derive(Debug)]
enum Solver {
    Batch(Box<Batch>),
    Incremental(Box<Incremental>),
}

impl Solver {
    /// The id the next variable added gets.
    fn next_id(&self) -> VarId {
        match self {
            Solver::Batch(b) => VarId(b.values.len()),
            Solver::Incremental(i) => VarId(i.isam.len() + i.new_variables.len()),
        }
    }

    fn add_variable(&mut self, v: Variable) -> VarId {
        match self {
            Solver::Batch(b) => b.values.push(v),
            Solver::Incremental(i) => {
                i.new_variables.push(v);
                VarId(i.isam.len() + i.new_variables.len() - 1)
            }
        }
    }

    fn add_factor(&mut self, f: impl Factor + 'static) -> Result<(), SlamError> {
        match self {
            Solver::Batch(b) => {
                b.graph.add(f)?;
            }
            Solver::Incremental(i) => i.new_factors.push(Box::new(f)),
        }
        Ok(())
    }

    /// The current estimate of `id` (a variable of this keyframe: its initial value).
    fn get(&self, id: VarId) -> Option<Variable> {
        match self {
            Solver::Batch(b) => b.values.get(id).copied(),
            Solver::Incremental(i) => match id.0.checked_sub(i.isam.len()) {
                Some(k) => i.new_variables.get(k).copied(),
                None => i.isam.estimate_of(id),
            },
        }
    }

    fn se3(&self, id: VarId) -> Option<Se3> {
        match self.get(id) {
            Some(Variable::Se3(t)) => Some(t),
            _ => None,
        }
    }

    fn point3(&self, id: VarId) -> Option<Vector3<f64>> {
        match self.get(id) {
            Some(Variable::Point3(p)) => Some(p),
            _ => None,
        }
    }
}

/// Keyframe graph SLAM over SE(3) with 3D point landmarks.
#[derive(Debug)]
pub struct GraphSlam {
    params: GraphSlamParams,
    solver: Solver,
    keyframes: Vec<VarId>,
    landmarks: BTreeMap<u64, LandmarkState>,
    /// Keyframe of the last loop closure marked full.
    last_full_keyframe: Option<usize>,
}

impl GraphSlam {
    /// Starts a map at the first keyframe `world_from_first` (the gauge), with what it
    /// observes.
    pub fn new(params: GraphSlamParams, world_from_first: Se3, observations: &[LandmarkObservation]) -> Result<Self, SlamError> {
        if !world_from_first.is_finite() {
            return Err(SlamError::NonFinite);
        }
        let solver = match params.solver {
            SlamSolver::Batch => Solver::Batch(Box::new(Batch {
                graph: FactorGraph::new(),
                values: Values::new(),
                optimizer: LevenbergMarquardt::new(params.optimizer.clone()),
            })),
            SlamSolver::Incremental => Solver::Incremental(Box::new(Incremental {
                isam: Isam2::new(params.isam2),
                new_variables: Vec::new(),
                new_factors: Vec::new(),
            })),
        };
        let mut slam = Self { params, solver, keyframes: Vec::new(), landmarks: BTreeMap::new(), last_full_keyframe: None };
        let first = slam.solver.add_variable(Variable::Se3(world_from_first));
        match &mut slam.solver {
            Solver::Batch(b) => b.values.set_fixed(first, true),
            Solver::Incremental(_) => {
                let noise = GaussianNoise::isotropic(6, ANCHOR_SIGMA)?;
                slam.solver.add_factor(PriorSe3::new(first, world_from_first, noise))?;
            }
        }
        slam.keyframes.push(first);
        // New landmarks start at their observation: nothing to optimise yet (the incremental
        // solver takes them in now).
        let noises = observation_noises(observations, slam.params.observation_kernel)?;
        slam.observe(0, observations, noises)?;
        slam.commit()?;
        Ok(slam)
    }

    pub fn params(&self) -> &GraphSlamParams {
        &self.params
    }

    /// Every factor (for inspection and tests; the incremental solver's includes the anchor).
    pub fn graph(&self) -> &FactorGraph {
        match &self.solver {
            Solver::Batch(b) => &b.graph,
            Solver::Incremental(i) => i.isam.graph(),
        }
    }

    /// The current estimate of every variable, with only the first keyframe fixed.
    pub fn estimate(&self) -> Values {
        self.first_fixed(match &self.solver {
            Solver::Batch(b) => b.values.clone(),
            Solver::Incremental(i) => i.isam.estimate(),
        })
    }

    /// Where the marginals are taken, with only the first keyframe fixed: the incremental
    /// solver's linearisation point θ (the estimate is θ ⊕ Δ), the batch solver's estimate.
    pub fn linearization_point(&self) -> Values {
        match &self.solver {
            Solver::Batch(_) => self.estimate(),
            Solver::Incremental(i) => self.first_fixed(i.isam.linearization_point().clone()),
        }
    }

    /// The variable of the latest keyframe.
    pub fn current_variable(&self) -> VarId {
        self.keyframes.last().copied().unwrap_or(VarId(0))
    }

    fn first_fixed(&self, mut v: Values) -> Values {
        for k in 0..v.len() {
            v.set_fixed(VarId(k), false);
        }
        if let Some(&first) = self.keyframes.first() {
            v.set_fixed(first, true);
        }
        v
    }

    pub fn keyframe_count(&self) -> usize {
        self.keyframes.len()
    }

    /// `world_from_robot` of the latest keyframe.
    pub fn current_pose(&self) -> Se3 {
        self.keyframes.last().and_then(|&v| self.solver.se3(v)).unwrap_or_default()
    }

    /// Landmark positions by increasing id, without covariances. O(landmarks).
    pub fn landmark_positions(&self) -> Vec<(u64, Vector3<f64>)> {
        self.landmarks.iter().map(|(&id, s)| (id, self.solver.point3(s.var).unwrap_or_default())).collect()
    }

    /// Landmarks last seen at keyframe `since_keyframe` or later, by increasing id, with their
    /// exact marginal covariances (batch: one factorisation, then 3 sparse forward solves per
    /// landmark, [`Marginals::covariances`]; incremental: the clique joints on their paths to
    /// the root, [`Isam2::marginal_covariances`]). Cheaper than [`SlamBackend::landmarks`] when
    /// few are recent.
    pub fn recent_landmarks(&self, since_keyframe: usize) -> Result<Vec<LandmarkEstimate>, SlamError> {
        let recent: Vec<(u64, VarId)> =
            self.landmarks.iter().filter(|(_, s)| s.last_seen_keyframe >= since_keyframe).map(|(&id, s)| (id, s.var)).collect();
        if recent.is_empty() || self.keyframes.len() < 2 {
            return Ok(Vec::new());
        }
        self.estimates_of(&recent)
    }

    /// Positions and marginal covariances of `landmarks` (id, variable).
    fn estimates_of(&self, landmarks: &[(u64, VarId)]) -> Result<Vec<LandmarkEstimate>, SlamError> {
        let ids: Vec<VarId> = landmarks.iter().map(|r| r.1).collect();
        let covs = match &self.solver {
            Solver::Batch(_) => self.marginals()?.covariances(&ids)?,
            Solver::Incremental(i) => i.isam.marginal_covariances(&ids)?,
        };
        Ok(landmarks
            .iter()
            .zip(covs)
            .map(|(&(landmark_id, var), cov)| LandmarkEstimate {
                landmark_id,
                position_in_world: self.solver.point3(var).unwrap_or_default(),
                covariance: Matrix3::from_fn(|r, c| cov[(r, c)]),
            })
            .collect())
    }

    /// Number of landmarks in the map.
    pub fn landmark_count(&self) -> usize {
        self.landmarks.len()
    }

    /// Whether landmark `landmark_id` is in the map.
    pub fn has_landmark(&self, landmark_id: u64) -> bool {
        self.landmarks.contains_key(&landmark_id)
    }

    /// Adds the observation factors of keyframe `k` (`noises` from [`observation_noises`]);
    /// returns the landmarks that closed a loop.
    fn observe(&mut self, k: usize, observations: &[LandmarkObservation], noises: Vec<GaussianNoise>) -> Result<Vec<u64>, SlamError> {
        let pose_var = self.keyframes[k];
        let world_from_robot = self.solver.se3(pose_var).unwrap_or_default();
        let mut closures = Vec::new();
        for (obs, noise) in observations.iter().zip(noises) {
            let var = match self.landmarks.get_mut(&obs.landmark_id) {
                Some(state) => {
                    if k.saturating_sub(state.last_seen_keyframe) >= self.params.loop_closure_gap_keyframes {
                        closures.push(obs.landmark_id);
                    }
                    state.last_seen_keyframe = k;
                    state.var
                }
                None => {
                    let p = world_from_robot.transform_point(&obs.point_in_robot);
                    let var = self.solver.add_variable(Variable::Point3(p));
                    self.landmarks.insert(obs.landmark_id, LandmarkState { var, last_seen_keyframe: k });
                    var
                }
            };
            self.solver.add_factor(PointObservation3::new(pose_var, var, obs.point_in_robot, noise))?;
        }
        closures.sort_unstable();
        closures.dedup();
        Ok(closures)
    }

    /// Incremental: one iSAM2 update with this keyframe's variables and factors.
    fn commit(&mut self) -> Result<(), SlamError> {
        if let Solver::Incremental(i) = &mut self.solver {
            let factors = std::mem::take(&mut i.new_factors);
            let result = i.isam.update(&i.new_variables, factors);
            i.new_variables.clear();
            result?;
        }
        Ok(())
    }

    /// Batch: frees the last `window` keyframes (never the first) and the landmarks seen from
    /// them, and optimises.
    fn optimize_window(&mut self) -> Result<Summary, SlamError> {
        let Solver::Batch(b) = &mut self.solver else { return Ok(Summary::default()) };
        let n = self.keyframes.len();
        let start = n.saturating_sub(self.params.window_keyframes.max(1)).max(1);
        for (k, &v) in self.keyframes.iter().enumerate() {
            b.values.set_fixed(v, k < start);
        }
        for state in self.landmarks.values() {
            b.values.set_fixed(state.var, state.last_seen_keyframe < start);
        }
        b.run()
    }

    /// Marginals of the full problem at the current estimate (one sparse factorisation of the
    /// whole graph, whichever the solver: the reference for the incremental one).
    pub fn marginals(&self) -> Result<Marginals, SlamError> {
        Ok(Marginals::new(self.graph(), &self.estimate(), self.params.optimizer.factorisation)?)
    }

    /// The graph as a g2o file in *replay order*: per keyframe, the landmarks it saw first, then
    /// its pose, so that [`super::G2oReplay`] makes one update per keyframe with the factors
    /// this solver's update had. Vertices at the current estimate; the odometry as
    /// `EDGE_SE3:QUAT`, the observations as `EDGE_SE3_TRACKXYZ` through sensor offset 0 (the
    /// identity). The anchor and the gravity factors have no g2o form and the robust kernel is
    /// dropped: returns the file and how many factors it leaves out. O(variables + factors).
    pub fn to_g2o(&self) -> (G2oFile, usize) {
        let estimate = self.estimate();
        let n = estimate.len();
        // Variables from one keyframe's to the next are that keyframe's new landmarks.
        let mut file_id = vec![0u64; n];
        let mut next = 0u64;
        for (k, &pose) in self.keyframes.iter().enumerate() {
            let end = self.keyframes.get(k + 1).map_or(n, |v| v.0);
            for id in &mut file_id[pose.0 + 1..end] {
                *id = next;
                next += 1;
            }
            file_id[pose.0] = next;
            next += 1;
        }
        let mut file = G2oFile::default();
        file.offsets.insert(0, Se3::identity());
        let mut by_file_id: Vec<(u64, Variable)> = estimate.iter().map(|(v, var)| (file_id[v.0], *var)).collect();
        by_file_id.sort_unstable_by_key(|&(id, _)| id);
        file.vertices = by_file_id
            .into_iter()
            .filter_map(|(id, var)| match var {
                Variable::Se3(pose) => Some(G2oVertex::Se3 { id, pose }),
                Variable::Point3(point) => Some(G2oVertex::Point3 { id, point }),
                _ => None,
            })
            .collect();
        let factors = self.graph().factors();
        file.edges = factors.iter().filter_map(|f| f.g2o_edge()).map(|e| e.renumbered(|v| file_id[v as usize])).collect();
        let left_out = factors.len() - file.edges.len();
        (file, left_out)
    }
}

/// The noise model of every observation, after checking that its point is finite.
fn observation_noises(observations: &[LandmarkObservation], kernel: RobustKernel) -> Result<Vec<GaussianNoise>, SlamError> {
    observations
        .iter()
        .map(|obs| {
            if !obs.point_in_robot.iter().all(|v| v.is_finite()) {
                return Err(SlamError::NonFinite);
            }
            Ok(GaussianNoise::from_covariance(&obs.covariance)?.with_kernel(kernel))
        })
        .collect()
}

impl Batch {
    fn run(&mut self) -> Result<Summary, SlamError> {
        match self.optimizer.optimize(&self.graph, &mut self.values) {
            Ok(s) => Ok(s),
            // Not converged within the budget: the values hold the best estimate; keep going.
            Err(OptError::MaxIterations(s)) => Ok(s),
            Err(e) => Err(e.into()),
        }
    }
}

impl SlamBackend for GraphSlam {
    fn add_keyframe(&mut self, odometry: &Odometry, observations: &[LandmarkObservation]) -> Result<KeyframeUpdate, SlamError> {
        if !odometry.previous_from_current.is_finite() {
            return Err(SlamError::NonFinite);
        }
        // Every input is checked before the map changes, so a rejected keyframe leaves it as it
        // was (adding a factor checks only its keys, distinct by construction here).
        let noise = GaussianNoise::from_covariance(&odometry.covariance)?;
        let var = self.solver.next_id();
        let gravity = match odometry.gravity {
            Some(g) => {
                let noise = GaussianNoise::isotropic(2, g.sigma_rad)?;
                Some(GravitySe3::new(var, g.up_in_body, noise).map_err(|_| SlamError::NonFinite)?)
            }
            None => None,
        };
        let noises = observation_noises(observations, self.params.observation_kernel)?;
        let prev = *self.keyframes.last().unwrap_or(&VarId(0));
        let world_from_prev = self.solver.se3(prev).unwrap_or_default();
        let added = self.solver.add_variable(Variable::Se3(world_from_prev * odometry.previous_from_current));
        debug_assert_eq!(added, var);
        self.keyframes.push(var);
        self.solver.add_factor(BetweenSe3::new(prev, var, odometry.previous_from_current, noise))?;
        if let Some(factor) = gravity {
            self.solver.add_factor(factor)?;
        }
        let k = self.keyframes.len() - 1;
        let loop_closures = self.observe(k, observations, noises)?;
        let cooling = self.last_full_keyframe.is_some_and(|f| k < f + self.params.full_cooldown_keyframes);
        let full = !loop_closures.is_empty() && !cooling;
        if full {
            self.last_full_keyframe = Some(k);
        }
        let summary = match self.solver {
            Solver::Incremental(_) => {
                self.commit()?;
                None
            }
            Solver::Batch(_) if full => Some(self.optimize_full()?),
            Solver::Batch(_) => Some(self.optimize_window()?),
        };
        Ok(KeyframeUpdate { keyframe: k, loop_closures, full, summary })
    }

    /// Batch: LM on the whole graph. Incremental: relinearisation of every variable that moved
    /// and re-elimination, repeated (Gauss-Newton) until χ² decreases by less than the
    /// optimiser's relative tolerance or its iteration budget is spent.
    fn optimize_full(&mut self) -> Result<Summary, SlamError> {
        let estimate = self.estimate();
        match &mut self.solver {
            Solver::Batch(b) => {
                b.values = estimate;
                b.run()
            }
            Solver::Incremental(i) => {
                let initial_chi2 = i.isam.chi2().map_err(OptError::from)?;
                let mut summary = Summary { initial_chi2, final_chi2: initial_chi2, ..Summary::default() };
                while summary.iterations < self.params.optimizer.max_iterations {
                    i.isam.relinearize(0.0)?;
                    summary.iterations += 1;
                    let chi2 = i.isam.chi2().map_err(OptError::from)?;
                    let decrease = summary.final_chi2 - chi2;
                    summary.final_chi2 = chi2;
                    if decrease <= self.params.optimizer.relative_tolerance * chi2.max(f64::MIN_POSITIVE) {
                        summary.termination = Some(Termination::RelativeDecrease);
                        break;
                    }
                }
                Ok(summary)
            }
        }
    }

    fn keyframe_poses(&self) -> Vec<Se3> {
        self.keyframes.iter().filter_map(|&v| self.solver.se3(v)).collect()
    }

    fn landmarks(&self) -> Result<Vec<LandmarkEstimate>, SlamError> {
        if self.landmarks.is_empty() {
            return Ok(Vec::new());
        }
        let all: Vec<(u64, VarId)> = self.landmarks.iter().map(|(&id, s)| (id, s.var)).collect();
        self.estimates_of(&all)
    }

    fn current_pose_covariance(&self) -> Result<Matrix6<f64>, SlamError> {
        let Some(&current) = self.keyframes.last() else { return Ok(Matrix6::zeros()) };
        if self.keyframes.len() == 1 {
            return Ok(Matrix6::zeros());
        }
        let cov = match &self.solver {
            Solver::Batch(_) => self.marginals()?.covariance(current)?,
            Solver::Incremental(i) => i.isam.marginal_covariance(current)?,
        };
        Ok(Matrix6::from_fn(|r, c| cov[(r, c)]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::slam::lie::so3_exp;
    use nalgebra::{DMatrix, Vector6};
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn gaussian(rng: &mut ChaCha8Rng) -> f64 {
        // Box-Muller.
        let u1: f64 = rng.random::<f64>().max(1e-300);
        let u2: f64 = rng.random::<f64>();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }

    /// A sample of N(0, diag(sigmas²)).
    fn sample<const D: usize>(rng: &mut ChaCha8Rng, sigmas: [f64; D]) -> nalgebra::SVector<f64, D> {
        nalgebra::SVector::<f64, D>::from_fn(|i, _| sigmas[i] * gaussian(rng))
    }

    /// Ground truth: a rover driving a 40 m loop (40 keyframes, 1 m apart) on gently rolling
    /// ground, 12 landmarks around it, seen within 4 m; odometry and observations corrupted with
    /// known noise.
    struct World {
        truth: Vec<Se3>,
        landmarks: Vec<Vector3<f64>>,
    }

    const ODOM_SIGMAS: [f64; 6] = [0.02, 0.02, 0.01, 0.005, 0.005, 0.01];
    const OBS_SIGMA_M: f64 = 0.05;
    const RANGE_M: f64 = 4.0;

    fn world(keyframes: usize) -> World {
        let radius = 40.0 / std::f64::consts::TAU;
        let truth = (0..keyframes)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / keyframes as f64;
                let yaw = a + std::f64::consts::FRAC_PI_2;
                let rot = so3_exp(&Vector3::new(0.02 * a.sin(), 0.03 * a.cos(), yaw));
                Se3::new(rot, Vector3::new(radius * a.cos(), radius * a.sin(), 0.1 * (2.0 * a).sin()))
            })
            .collect();
        let landmarks = (0..12)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / 12.0 + 0.1;
                let r = if i % 2 == 0 { radius + 1.5 } else { radius - 1.0 };
                Vector3::new(r * a.cos(), r * a.sin(), 0.3 + 0.1 * i as f64)
            })
            .collect();
        World { truth, landmarks }
    }

    fn observations(w: &World, k: usize, rng: &mut ChaCha8Rng) -> Vec<LandmarkObservation> {
        w.landmarks
            .iter()
            .enumerate()
            .filter_map(|(i, m)| {
                let p = w.truth[k].inverse_transform_point(m);
                (p.norm() < RANGE_M).then(|| LandmarkObservation {
                    landmark_id: i as u64 * 10 + 3,
                    point_in_robot: p + sample(rng, [OBS_SIGMA_M; 3]),
                    covariance: Matrix3::identity() * OBS_SIGMA_M * OBS_SIGMA_M,
                })
            })
            .collect()
    }

    fn odometry(prev: &Se3, current: &Se3, rng: &mut ChaCha8Rng) -> Odometry {
        let rel = prev.between(current);
        let noise: Vector6<f64> = sample(rng, ODOM_SIGMAS);
        Odometry {
            previous_from_current: rel.retract(&noise),
            covariance: Matrix6::from_diagonal(&Vector6::from_row_slice(&ODOM_SIGMAS).map(|s| s * s)),
            gravity: None,
        }
    }

    /// Runs the loop (and 5 keyframes of a second lap, closing the loop).
    fn run(seed: u64, params: GraphSlamParams) -> (World, GraphSlam, Vec<KeyframeUpdate>) {
        let n = 40;
        let w = world(n);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut slam = GraphSlam::new(params, w.truth[0], &observations(&w, 0, &mut rng)).unwrap();
        let mut updates = Vec::new();
        let mut truth = w.truth.clone();
        for k in 1..n + 5 {
            let kk = k % n;
            let rel = odometry(&w.truth[(k - 1) % n], &w.truth[kk], &mut rng);
            let obs = observations(&w, kk, &mut rng);
            updates.push(slam.add_keyframe(&rel, &obs).unwrap());
            if k >= n {
                truth.push(w.truth[kk]);
            }
        }
        (World { truth, landmarks: w.landmarks }, slam, updates)
    }

    fn mahalanobis2<const D: usize>(err: &nalgebra::SVector<f64, D>, cov: &nalgebra::SMatrix<f64, D, D>) -> f64 {
        let inv = cov.try_inverse().unwrap();
        (err.transpose() * inv * err)[(0, 0)]
    }

    /// Tilt from gravity: odometry whose roll drifts by 5 mrad per keyframe (a biased gyro),
    /// no landmarks. Without the IMU's gravity factors the roll error grows with the chain;
    /// with them (σ 3 mrad) it stays at the gravity noise level.
    #[test]
    fn gravity_factors_hold_the_absolute_tilt() {
        let level = Se3::new(so3_exp(&Vector3::zeros()), Vector3::zeros());
        let step = Se3::new(so3_exp(&Vector3::new(0.0, 0.0, 0.05)), Vector3::new(0.5, 0.0, 0.0));
        let biased = Se3::new(so3_exp(&Vector3::new(0.005, 0.0, 0.05)), Vector3::new(0.5, 0.0, 0.0));
        let cov = Matrix6::from_diagonal(&Vector6::new(1e-4, 1e-4, 1e-4, 1e-5, 1e-5, 1e-5));
        let last_roll = |gravity: bool| {
            let mut slam = GraphSlam::new(GraphSlamParams::default(), level, &[]).unwrap();
            let mut truth = level;
            for _ in 0..30 {
                truth = truth * step;
                let up_in_body = truth.rotation_matrix().transpose() * Vector3::z();
                let g = gravity.then_some(Gravity { up_in_body, sigma_rad: 0.003 });
                slam.add_keyframe(&Odometry { previous_from_current: biased, covariance: cov, gravity: g }, &[]).unwrap();
            }
            slam.optimize_full().unwrap();
            let r = slam.current_pose().rotation_matrix();
            // Roll error: the body's y axis against the level plane.
            (r * Vector3::y()).z.asin().abs()
        };
        let (without, with) = (last_roll(false), last_roll(true));
        assert!(without > 0.05, "30 × 5 mrad of drift: {without}");
        assert!(with < 0.01, "held by gravity: {with}");
    }

    #[test]
    fn loop_closure_is_detected_and_triggers_full_optimisation() {
        let (_, slam, updates) = run(7, GraphSlamParams::default());
        // Landmarks are seen for a few metres: no landmark returns before the loop comes round.
        assert!(updates.iter().take(29).all(|u| !u.full), "no loop closure during the first 30 m");
        let closing: Vec<&KeyframeUpdate> = updates.iter().filter(|u| u.full).collect();
        assert!(!closing.is_empty(), "coming back to the start closes the loop");
        assert!(closing.iter().all(|u| !u.loop_closures.is_empty() && u.keyframe >= 30));
        // After a full optimisation the graph is at a minimum: another full run barely moves χ².
        let mut slam = slam;
        let before = slam.graph().chi2(&slam.estimate()).unwrap();
        let again = slam.optimize_full().unwrap();
        assert!(again.final_chi2 <= before * (1.0 + 1e-9));
    }

    #[test]
    fn estimate_is_consistent_with_reported_covariance() {
        const SEEDS: u64 = 40;
        // Several seeds; each normalised error is χ²-distributed if the covariance is right.
        let mut pose_d2 = Vec::new();
        let mut lm_d2 = Vec::new();
        for seed in 0..SEEDS {
            let (w, mut slam, _) = run(seed, GraphSlamParams::default());
            slam.optimize_full().unwrap();
            let est = slam.current_pose();
            let truth = w.truth[w.truth.len() - 1];
            let err = truth.local(&est);
            pose_d2.push(mahalanobis2(&err, &slam.current_pose_covariance().unwrap()));
            for lm in slam.landmarks().unwrap() {
                let i = ((lm.landmark_id - 3) / 10) as usize;
                lm_d2.push(mahalanobis2(&(lm.position_in_world - w.landmarks[i]), &lm.covariance));
            }
        }
        // Per sample: χ²(6) 99.99 % quantile 27.9, χ²(3) 99.998 % ≈ 24.5. The means of 40 χ²(6)
        // and 480 χ²(3) samples are 6 ± 0.55 and 3 ± 0.11 (one σ); the bounds are ±5σ.
        assert!(pose_d2.iter().all(|&d| d < 27.9), "{pose_d2:?}");
        assert!(lm_d2.iter().all(|&d| d < 24.5), "{lm_d2:?}");
        let mean_pose = pose_d2.iter().sum::<f64>() / pose_d2.len() as f64;
        let mean_lm = lm_d2.iter().sum::<f64>() / lm_d2.len() as f64;
        eprintln!("mean Mahalanobis²: pose {mean_pose:.2} (6 dof), landmarks {mean_lm:.2} (3 dof)");
        assert!((3.0..9.0).contains(&mean_pose), "mean pose Mahalanobis² {mean_pose}");
        assert!((2.4..3.6).contains(&mean_lm), "mean landmark Mahalanobis² {mean_lm}");
    }

    /// A keyframe with one bad input (a NaN point, a covariance that is not positive definite,
    /// a zero gravity direction, a NaN odometry) is rejected before the map changes: the run
    /// goes on, and ends where the same run without the rejected keyframes ends, bit for bit.
    #[test]
    fn a_rejected_keyframe_leaves_the_map_as_it_was() {
        for params in [GraphSlamParams::default(), batch()] {
            let n = 12;
            let w = world(n);
            let run = |reject: bool| {
                let mut rng = ChaCha8Rng::seed_from_u64(5);
                let mut slam = GraphSlam::new(params.clone(), w.truth[0], &observations(&w, 0, &mut rng)).unwrap();
                for k in 1..n {
                    let rel = odometry(&w.truth[k - 1], &w.truth[k], &mut rng);
                    let obs = observations(&w, k, &mut rng);
                    if reject && k % 3 == 0 && !obs.is_empty() {
                        let mut nan_point = obs.clone();
                        nan_point[obs.len() / 2].point_in_robot.y = f64::NAN;
                        let mut not_pd = obs.clone();
                        not_pd[obs.len() - 1].covariance[(2, 2)] = -1.0;
                        let zero_up = Odometry { gravity: Some(Gravity { up_in_body: Vector3::zeros(), sigma_rad: 0.01 }), ..rel };
                        let mut nan_odometry = rel;
                        nan_odometry.previous_from_current = Se3::new(so3_exp(&Vector3::zeros()), Vector3::new(f64::NAN, 0.0, 0.0));
                        assert!(slam.add_keyframe(&rel, &nan_point).is_err());
                        assert!(slam.add_keyframe(&rel, &not_pd).is_err());
                        assert!(slam.add_keyframe(&zero_up, &obs).is_err());
                        assert!(slam.add_keyframe(&nan_odometry, &obs).is_err());
                    }
                    slam.add_keyframe(&rel, &obs).unwrap();
                }
                (slam.keyframe_poses(), slam.landmark_positions(), slam.current_pose_covariance().unwrap())
            };
            let (clean, rejected) = (run(false), run(true));
            assert_eq!(clean.0.len(), n);
            assert_eq!(clean, rejected, "{:?}", params.solver);
        }
    }

    fn batch() -> GraphSlamParams {
        GraphSlamParams { solver: SlamSolver::Batch, ..GraphSlamParams::default() }
    }

    /// Scalar offset of `var` in the information matrix of the full problem (only the first
    /// keyframe fixed): poses are pushed in order with landmarks in between.
    fn free_offset(values: &Values, var: VarId) -> usize {
        values.iter().take_while(|(id, _)| *id != var).filter(|(id, _)| !values.is_fixed(*id)).map(|(_, v)| v.dim()).sum()
    }

    /// Both solvers' current-pose marginal is the block of the dense inverse of the full
    /// problem's information (an independent nalgebra inverse). The incremental one's is at its
    /// linearisation point, so the comparison is after convergence.
    #[test]
    fn current_pose_covariance_is_the_dense_inverse() {
        for params in [GraphSlamParams { window_keyframes: 5, ..batch() }, GraphSlamParams::default()] {
            let (_, mut slam, _) = run(3, params.clone());
            let tolerance = match params.solver {
                SlamSolver::Batch => 1e-9,
                SlamSolver::Incremental => {
                    slam.optimize_full().unwrap();
                    1e-6
                }
            };
            let cov = slam.current_pose_covariance().unwrap();
            let inv: DMatrix<f64> = slam.marginals().unwrap().dense_information().try_inverse().unwrap();
            let offset = free_offset(&slam.estimate(), *slam.keyframes.last().unwrap());
            let block = inv.view((offset, offset), (6, 6));
            let rel = (cov - block).amax() / block.amax();
            assert!(rel < tolerance, "{:?}: relative difference {rel:e}", params.solver);
            let traces = CovarianceTraces::of(&cov);
            assert!((traces.cov_trace - cov.trace()).abs() < 1e-15 && traces.pos_cov_trace > 0.0 && traces.rot_cov_trace > 0.0);
        }
    }

    /// The two solvers on the same measurements (the loop, closed), with least squares and with
    /// the default robust kernel on the observations: after a full optimisation the same
    /// keyframes, landmarks and marginals to 1e-6; before it, after one update per keyframe,
    /// the least-squares incremental estimate is within 2 mm (and mrad) of the optimum.
    #[test]
    fn incremental_and_batch_solvers_agree() {
        for observation_kernel in [RobustKernel::None, GraphSlamParams::default().observation_kernel] {
            // Relinearised at every update from 1 cm / 10 mrad (GTSAM's defaults, 0.1 every 10th
            // update, leave it ~4 mm off here, as one Gauss-Newton step per update from a stale
            // linearisation point does).
            let isam2 = Isam2Params { relinearize_threshold: 0.01, relinearize_skip: 1, ..Isam2Params::default() };
            let (_, mut inc, updates) = run(5, GraphSlamParams { isam2, observation_kernel, ..GraphSlamParams::default() });
            assert!(updates.iter().any(|u| u.full) && updates.iter().all(|u| u.summary.is_none()));
            let before = inc.keyframe_poses();
            let (_, mut bat, _) = run(5, GraphSlamParams { observation_kernel, ..batch() });
            let batch_online = bat.keyframe_poses();
            bat.optimize_full().unwrap();
            let optimum = bat.keyframe_poses();
            let off = |poses: &[Se3]| poses.iter().zip(&optimum).map(|(a, b)| b.local(a).amax()).fold(0.0, f64::max);
            eprintln!("{observation_kernel:?} online: incremental {:e}, batch {:e} from the optimum", off(&before), off(&batch_online));
            if observation_kernel == RobustKernel::None {
                assert!(off(&before) < 2e-3, "one update per keyframe: {:e} from the optimum", off(&before));
            }
            inc.optimize_full().unwrap();
            for (k, (a, b)) in inc.keyframe_poses().iter().zip(&optimum).enumerate() {
                assert!(b.local(a).amax() < 1e-6, "{observation_kernel:?} keyframe {k}: {:e}", b.local(a).amax());
            }
            let rel = |a: &Matrix3<f64>, b: &Matrix3<f64>| (a - b).amax() / b.amax();
            for (a, b) in inc.landmarks().unwrap().iter().zip(bat.landmarks().unwrap()) {
                assert_eq!(a.landmark_id, b.landmark_id);
                assert!((a.position_in_world - b.position_in_world).amax() < 1e-6);
                assert!(rel(&a.covariance, &b.covariance) < 1e-6, "landmark {}: {:e}", a.landmark_id, rel(&a.covariance, &b.covariance));
            }
            let (ci, cb) = (inc.current_pose_covariance().unwrap(), bat.current_pose_covariance().unwrap());
            assert!((ci - cb).amax() / cb.amax() < 1e-6);
            let recent = inc.recent_landmarks(30).unwrap();
            assert!(!recent.is_empty() && recent.iter().all(|l| inc.landmarks.get(&l.landmark_id).unwrap().last_seen_keyframe >= 30));
        }
    }

    #[test]
    fn window_update_leaves_old_keyframes_fixed() {
        let w = world(40);
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let params = GraphSlamParams { window_keyframes: 3, ..batch() };
        let mut slam = GraphSlam::new(params, w.truth[0], &observations(&w, 0, &mut rng)).unwrap();
        for k in 1..8 {
            let before = slam.keyframe_poses();
            let u = slam.add_keyframe(&odometry(&w.truth[k - 1], &w.truth[k], &mut rng), &observations(&w, k, &mut rng)).unwrap();
            assert!(!u.full);
            let after = slam.keyframe_poses();
            // Keyframes older than the window did not move.
            for j in 0..(k + 1).saturating_sub(3) {
                assert_eq!(before[j], after[j], "keyframe {j} moved at update {k}");
            }
        }
        assert_eq!(slam.keyframe_count(), 8);
        assert_eq!(slam.keyframe_poses()[0], w.truth[0]);
    }

    /// The exported graph, written and read back, replays as the same updates: one per
    /// keyframe, the same factors (the anchor re-made by the replay's prior of the same σ), so
    /// the same estimate.
    #[test]
    fn the_g2o_export_replays_as_the_same_updates() {
        let params = GraphSlamParams { observation_kernel: RobustKernel::None, ..GraphSlamParams::default() };
        let (_, slam, _) = run(7, params.clone());
        let (file, left_out) = slam.to_g2o();
        assert_eq!(left_out, 1, "only the anchor has no g2o form here");
        assert_eq!(file.edges.len(), slam.graph().len() - 1);
        let text = crate::slam::g2o::write_g2o(&file);
        let read = crate::slam::g2o::read_g2o(text.as_bytes()).unwrap();
        assert_eq!(read.vertices.len(), slam.estimate().len());
        let mut replay = crate::slam::G2oReplay::new(&read, crate::slam::Se2Residual::default(), ANCHOR_SIGMA).unwrap();
        assert_eq!(replay.len(), slam.keyframe_count());
        let mut isam = Isam2::new(params.isam2);
        while replay.step(&mut isam).unwrap().is_some() {}
        let estimate = slam.estimate();
        for v in &read.vertices {
            let ours = replay.var_of(v.id()).and_then(|r| isam.estimate_of(r)).unwrap();
            let theirs = match *v {
                crate::slam::g2o::G2oVertex::Se3 { pose, .. } => Variable::Se3(pose),
                crate::slam::g2o::G2oVertex::Point3 { point, .. } => Variable::Point3(point),
                _ => unreachable!("the export writes SE(3) poses and 3-D points"),
            };
            let gap = match (ours, theirs) {
                (Variable::Se3(a), Variable::Se3(b)) => a.between(&b).log().norm(),
                (Variable::Point3(a), Variable::Point3(b)) => (a - b).norm(),
                _ => panic!("vertex {} changed kind", v.id()),
            };
            assert!(gap < 1e-6, "vertex {}: {gap}", v.id());
        }
        // The vertices are the estimate, in replay order: the first keyframe after its landmarks.
        let first_pose = read.vertices.iter().position(|v| matches!(v, crate::slam::g2o::G2oVertex::Se3 { .. })).unwrap();
        assert_eq!(
            read.vertices[first_pose],
            crate::slam::g2o::G2oVertex::Se3 { id: first_pose as u64, pose: estimate.se3(VarId(0)).unwrap() }
        );
    }
}
