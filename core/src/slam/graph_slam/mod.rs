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

mod g2o_export;
mod params;
mod solver;
#[cfg(test)]
mod tests;

pub use params::{ANCHOR_SIGMA, GraphSlamParams, OBSERVATION_CAUCHY_K, SlamSolver};

use std::collections::BTreeMap;

use nalgebra::{Matrix3, Matrix6, Vector3};

use super::backend::{KeyframeUpdate, LandmarkEstimate, LandmarkObservation, Odometry, SlamBackend, SlamError};
use super::factors::{BetweenSe3, GaussianNoise, GravitySe3, PointObservation3, PriorSe3, RobustKernel};
use super::g2o::G2oFile;
use super::graph::FactorGraph;
use super::incremental::Isam2;
use super::lie::Se3;
use super::marginals::Marginals;
use super::optimizer::{LevenbergMarquardt, OptError, Summary, Termination};
use super::values::{Values, VarId, Variable};
use solver::{Batch, Incremental, Solver};

#[derive(Clone, Copy, Debug)]
struct LandmarkState {
    var: VarId,
    last_seen_keyframe: usize,
}

/// Keyframe graph SLAM over SE(3) with 3D point landmarks.
///
/// # Examples
///
/// Three odometry steps of 1 m along x, then landmark 7, seen from the first keyframe, is seen
/// again: a loop closure, which pulls the uncertainty of the current pose back down.
///
/// ```
/// use fitslam_core::slam::{
///     CovarianceTraces, GraphSlamParams, LandmarkObservation, Odometry, Se3, SlamBackend,
/// };
/// use fitslam_core::GraphSlam;
/// use nalgebra::{Matrix3, Matrix6, UnitQuaternion, Vector3};
///
/// let seen = |point_in_robot: Vector3<f64>| LandmarkObservation {
///     landmark_id: 7,
///     point_in_robot,
///     covariance: Matrix3::identity() * 1e-4, // 1 cm
/// };
/// let step = Odometry {
///     previous_from_current: Se3::new(UnitQuaternion::identity(), Vector3::new(1.0, 0.0, 0.0)),
///     covariance: Matrix6::identity() * 1e-2, // 10 cm and 0.1 rad per step
///     gravity: None,
/// };
/// // Landmark 7 stands at (2, 1, 0) in the world frame.
/// let first = [seen(Vector3::new(2.0, 1.0, 0.0))];
/// let params = GraphSlamParams { loop_closure_gap_keyframes: 2, ..GraphSlamParams::default() };
///
/// let run = |revisit: bool| -> Result<(GraphSlam, Vec<u64>), Box<dyn std::error::Error>> {
///     let mut slam = GraphSlam::new(params.clone(), Se3::identity(), &first)?;
///     slam.add_keyframe(&step, &[])?;
///     slam.add_keyframe(&step, &[])?;
///     // At (3, 0, 0) the landmark is 1 m behind and 1 m to the left.
///     let again = if revisit { vec![seen(Vector3::new(-1.0, 1.0, 0.0))] } else { vec![] };
///     let update = slam.add_keyframe(&step, &again)?;
///     Ok((slam, update.loop_closures))
/// };
/// let (closed, closures) = run(true)?;
/// let (open, no_closures) = run(false)?;
/// assert_eq!(closures, vec![7]);
/// assert!(no_closures.is_empty());
/// assert_eq!(closed.keyframe_count(), 4);
/// assert!((closed.current_pose().translation - Vector3::new(3.0, 0.0, 0.0)).norm() < 1e-6);
///
/// let position_var = |slam: &GraphSlam| -> Result<f64, Box<dyn std::error::Error>> {
///     Ok(CovarianceTraces::of(&slam.current_pose_covariance()?).pos_cov_trace)
/// };
/// assert!(position_var(&closed)? < position_var(&open)?);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
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

    /// Its parameters.
    pub fn params(&self) -> &GraphSlamParams {
        &self.params
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

impl SlamBackend for GraphSlam {
    /// Where the marginals are taken, with only the first keyframe fixed: the incremental
    /// solver's linearisation point θ (the estimate is θ ⊕ Δ), the batch solver's estimate.
    fn linearization_point(&self) -> Values {
        match &self.solver {
            Solver::Batch(_) => self.estimate(),
            Solver::Incremental(i) => self.first_fixed(i.isam.linearization_point().clone()),
        }
    }

    /// The variable of the latest keyframe.
    fn current_variable(&self) -> VarId {
        self.keyframes.last().copied().unwrap_or(VarId(0))
    }

    /// Every factor (for inspection and tests; the incremental solver's includes the anchor).
    fn graph(&self) -> &FactorGraph {
        match &self.solver {
            Solver::Batch(b) => &b.graph,
            Solver::Incremental(i) => i.isam.graph(),
        }
    }

    /// The current estimate of every variable, with only the first keyframe fixed.
    fn estimate(&self) -> Values {
        self.first_fixed(match &self.solver {
            Solver::Batch(b) => b.values.clone(),
            Solver::Incremental(i) => i.isam.estimate(),
        })
    }

    /// Number of keyframes, the first included.
    fn keyframe_count(&self) -> usize {
        self.keyframes.len()
    }

    /// `world_from_robot` of the latest keyframe.
    fn current_pose(&self) -> Se3 {
        self.keyframes.last().and_then(|&v| self.solver.se3(v)).unwrap_or_default()
    }

    /// Landmark positions by increasing id, without covariances. O(landmarks).
    fn landmark_positions(&self) -> Vec<(u64, Vector3<f64>)> {
        self.landmarks.iter().map(|(&id, s)| (id, self.solver.point3(s.var).unwrap_or_default())).collect()
    }

    /// Landmarks last seen at keyframe `since_keyframe` or later, by increasing id, with their
    /// exact marginal covariances (batch: one factorisation, then 3 sparse forward solves per
    /// landmark, [`Marginals::covariances`]; incremental: the clique joints on their paths to
    /// the root, [`Isam2::marginal_covariances`]). Cheaper than [`SlamBackend::landmarks`] when
    /// few are recent.
    fn recent_landmarks(&self, since_keyframe: usize) -> Result<Vec<LandmarkEstimate>, SlamError> {
        let recent: Vec<(u64, VarId)> =
            self.landmarks.iter().filter(|(_, s)| s.last_seen_keyframe >= since_keyframe).map(|(&id, s)| (id, s.var)).collect();
        if recent.is_empty() || self.keyframes.len() < 2 {
            return Ok(Vec::new());
        }
        self.estimates_of(&recent)
    }

    /// Number of landmarks in the map.
    fn landmark_count(&self) -> usize {
        self.landmarks.len()
    }

    /// Whether landmark `landmark_id` is in the map.
    fn has_landmark(&self, landmark_id: u64) -> bool {
        self.landmarks.contains_key(&landmark_id)
    }

    /// Marginals of the full problem at the current estimate (one sparse factorisation of the
    /// whole graph, whichever the solver: the reference for the incremental one).
    fn marginals(&self) -> Result<Marginals, SlamError> {
        Ok(Marginals::new(self.graph(), &self.estimate(), self.params.optimizer.factorisation)?)
    }

    fn exact_marginal_every_keyframe(&self) -> bool {
        self.params.solver == SlamSolver::Incremental
    }

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

    fn to_g2o(&self) -> (G2oFile, usize) {
        self.g2o_file()
    }
}
