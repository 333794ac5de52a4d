//! Keyframe graph SLAM for the simulator (notes §1, paper eq. 1): SE(3) keyframe poses and
//! 3D landmarks, odometry factors between consecutive keyframes, point observations in the
//! robot frame, the first keyframe anchored (fixed: the gauge).
//!
//! Updates: after each keyframe a **sliding window** optimises only the last `window_keyframes`
//! keyframes and the landmarks they saw, everything older fixed (their factors still constrain
//! the window). A **loop closure** (a landmark re-observed `loop_closure_gap_keyframes` or more
//! keyframes after it was last seen) triggers a full optimisation; [`GraphSlam::optimize_full`]
//! runs one on demand. Outputs: keyframe poses, landmark positions with their 3×3 marginal
//! covariances, and the current pose's 6×6 marginal covariance, always of the *full* problem at
//! the current linearisation (anchored at the first keyframe), never of the window alone.
//!
//! Cost: a window update is one sparse LM over O(window) variables plus an O(factors) pass;
//! a full update or a covariance query factorises the whole information matrix (sparse
//! Cholesky; a pose marginal is 6 solves, landmark marginals 3 per landmark).

use std::collections::BTreeMap;

use nalgebra::{Matrix3, Matrix6, Vector3};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::factors::{BetweenSe3, GaussianNoise, GravitySe3, NoiseError, PointObservation3};
use super::graph::{FactorGraph, GraphError};
use super::lie::Se3;
use super::marginals::{MarginalError, Marginals};
use super::optimizer::{LevenbergMarquardt, OptError, Optimizer, OptimizerParams, Summary};
use super::values::{Values, VarId, Variable};

/// Parameters of [`GraphSlam`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GraphSlamParams {
    /// Keyframes optimised by a sliding-window update (the most recent ones). Default 10.
    pub window_keyframes: usize,
    /// A landmark seen again after this many keyframes without being seen closes a loop and
    /// triggers a full optimisation. Default 20.
    pub loop_closure_gap_keyframes: usize,
    /// After a full optimisation, loop closures within this many keyframes are handled by the
    /// window update (the re-observed landmarks are free in it, anchored by their old
    /// observations): one revisit re-observes many old landmarks over several keyframes, and
    /// each would otherwise re-run the full problem. Default 0 (every closure runs it).
    pub full_cooldown_keyframes: usize,
    /// Stopping rules of each optimisation, and the factorisation of it and of the marginals
    /// ([`super::Factorisation`]). Default: [`OptimizerParams::default`] with 20 iterations.
    pub optimizer: OptimizerParams,
}

impl Default for GraphSlamParams {
    fn default() -> Self {
        Self {
            window_keyframes: 10,
            loop_closure_gap_keyframes: 20,
            full_cooldown_keyframes: 0,
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
    /// Whether the update optimised the whole graph (loop closure, outside the cool-down) or a
    /// window.
    pub full: bool,
    pub summary: Summary,
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
    #[error("non-finite odometry or observation")]
    NonFinite,
}

/// A SLAM back end as the simulator and the robot see it.
pub trait SlamBackend {
    /// Adds a keyframe reached by `odometry` from the previous one, with what it observes, and
    /// updates the estimate (window, or full on a loop closure).
    fn add_keyframe(&mut self, odometry: &Odometry, observations: &[LandmarkObservation]) -> Result<KeyframeUpdate, SlamError>;
    /// Optimises the whole graph (first keyframe fixed).
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

/// Keyframe graph SLAM over SE(3) with 3D point landmarks.
#[derive(Debug)]
pub struct GraphSlam {
    params: GraphSlamParams,
    graph: FactorGraph,
    values: Values,
    keyframes: Vec<VarId>,
    landmarks: BTreeMap<u64, LandmarkState>,
    optimizer: LevenbergMarquardt,
    /// Keyframe of the last full optimisation triggered by a loop closure.
    last_full_keyframe: Option<usize>,
}

impl GraphSlam {
    /// Starts a map at the first keyframe `world_from_first` (fixed: the gauge), with what it
    /// observes.
    pub fn new(params: GraphSlamParams, world_from_first: Se3, observations: &[LandmarkObservation]) -> Result<Self, SlamError> {
        if !world_from_first.is_finite() {
            return Err(SlamError::NonFinite);
        }
        let optimizer = LevenbergMarquardt::new(params.optimizer.clone());
        let mut slam = Self {
            params,
            graph: FactorGraph::new(),
            values: Values::new(),
            keyframes: Vec::new(),
            landmarks: BTreeMap::new(),
            optimizer,
            last_full_keyframe: None,
        };
        let first = slam.values.push(Variable::Se3(world_from_first));
        slam.values.set_fixed(first, true);
        slam.keyframes.push(first);
        // New landmarks start at their observation: nothing to optimise yet.
        slam.observe(0, observations)?;
        Ok(slam)
    }

    pub fn params(&self) -> &GraphSlamParams {
        &self.params
    }

    /// The factor graph (for inspection and tests).
    pub fn graph(&self) -> &FactorGraph {
        &self.graph
    }

    /// Current values; fixed flags reflect the last update.
    pub fn values(&self) -> &Values {
        &self.values
    }

    pub fn keyframe_count(&self) -> usize {
        self.keyframes.len()
    }

    /// `world_from_robot` of the latest keyframe.
    pub fn current_pose(&self) -> Se3 {
        self.keyframes.last().and_then(|&v| self.values.se3(v)).unwrap_or_default()
    }

    /// Landmark positions by increasing id, without covariances. O(landmarks).
    pub fn landmark_positions(&self) -> Vec<(u64, Vector3<f64>)> {
        self.landmarks.iter().map(|(&id, s)| (id, self.values.point3(s.var).unwrap_or_default())).collect()
    }

    /// Landmarks last seen at keyframe `since_keyframe` or later, by increasing id, with their
    /// exact marginal covariances (one factorisation, then 3 sparse forward solves per landmark,
    /// [`Marginals::covariances`]: cheaper than [`SlamBackend::landmarks`] when few are recent).
    pub fn recent_landmarks(&self, since_keyframe: usize) -> Result<Vec<LandmarkEstimate>, SlamError> {
        let recent: Vec<(u64, VarId)> =
            self.landmarks.iter().filter(|(_, s)| s.last_seen_keyframe >= since_keyframe).map(|(&id, s)| (id, s.var)).collect();
        if recent.is_empty() || self.keyframes.len() < 2 {
            return Ok(Vec::new());
        }
        let ids: Vec<VarId> = recent.iter().map(|r| r.1).collect();
        let covs = self.marginals()?.covariances(&ids)?;
        Ok(recent
            .iter()
            .zip(covs)
            .map(|(&(landmark_id, var), cov)| LandmarkEstimate {
                landmark_id,
                position_in_world: self.values.point3(var).unwrap_or_default(),
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

    /// Adds the observation factors of keyframe `k`; returns the landmarks that closed a loop.
    fn observe(&mut self, k: usize, observations: &[LandmarkObservation]) -> Result<Vec<u64>, SlamError> {
        let pose_var = self.keyframes[k];
        let world_from_robot = self.values.se3(pose_var).unwrap_or_default();
        let mut closures = Vec::new();
        for obs in observations {
            if !obs.point_in_robot.iter().all(|v| v.is_finite()) {
                return Err(SlamError::NonFinite);
            }
            let noise = GaussianNoise::from_covariance(&obs.covariance)?;
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
                    let var = self.values.push(Variable::Point3(p));
                    self.landmarks.insert(obs.landmark_id, LandmarkState { var, last_seen_keyframe: k });
                    var
                }
            };
            self.graph.add(PointObservation3::new(pose_var, var, obs.point_in_robot, noise))?;
        }
        closures.sort_unstable();
        closures.dedup();
        Ok(closures)
    }

    /// Frees the last `window` keyframes (never the first) and the landmarks seen from them.
    fn set_window_flags(&mut self, window: usize) {
        let n = self.keyframes.len();
        let start = n.saturating_sub(window).max(1);
        for (k, &v) in self.keyframes.iter().enumerate() {
            self.values.set_fixed(v, k < start);
        }
        for state in self.landmarks.values() {
            self.values.set_fixed(state.var, state.last_seen_keyframe < start);
        }
    }

    /// The values with only the first keyframe fixed (the full problem).
    fn full_values(&self) -> Values {
        let mut v = self.values.clone();
        for (id, _) in self.values.iter() {
            v.set_fixed(id, false);
        }
        if let Some(&first) = self.keyframes.first() {
            v.set_fixed(first, true);
        }
        v
    }

    fn run(&mut self) -> Result<Summary, SlamError> {
        match self.optimizer.optimize(&self.graph, &mut self.values) {
            Ok(s) => Ok(s),
            // Not converged within the budget: the values hold the best estimate; keep going.
            Err(OptError::MaxIterations(s)) => Ok(s),
            Err(e) => Err(e.into()),
        }
    }

    /// Marginals of the full problem at the current estimate.
    pub fn marginals(&self) -> Result<Marginals, SlamError> {
        Ok(Marginals::new(&self.graph, &self.full_values(), self.params.optimizer.factorisation)?)
    }
}

impl SlamBackend for GraphSlam {
    fn add_keyframe(&mut self, odometry: &Odometry, observations: &[LandmarkObservation]) -> Result<KeyframeUpdate, SlamError> {
        if !odometry.previous_from_current.is_finite() {
            return Err(SlamError::NonFinite);
        }
        let noise = GaussianNoise::from_covariance(&odometry.covariance)?;
        let prev = *self.keyframes.last().unwrap_or(&VarId(0));
        let world_from_prev = self.values.se3(prev).unwrap_or_default();
        let var = self.values.push(Variable::Se3(world_from_prev * odometry.previous_from_current));
        self.keyframes.push(var);
        self.graph.add(BetweenSe3::new(prev, var, odometry.previous_from_current, noise))?;
        if let Some(g) = odometry.gravity {
            let noise = GaussianNoise::isotropic(2, g.sigma_rad)?;
            let factor = GravitySe3::new(var, g.up_in_body, noise).map_err(|_| SlamError::NonFinite)?;
            self.graph.add(factor)?;
        }
        let k = self.keyframes.len() - 1;
        let loop_closures = self.observe(k, observations)?;
        let cooling = self.last_full_keyframe.is_some_and(|f| k < f + self.params.full_cooldown_keyframes);
        let full = !loop_closures.is_empty() && !cooling;
        if full {
            self.last_full_keyframe = Some(k);
        }
        let summary = if full {
            self.optimize_full()?
        } else {
            self.set_window_flags(self.params.window_keyframes.max(1));
            self.run()?
        };
        Ok(KeyframeUpdate { keyframe: k, loop_closures, full, summary })
    }

    fn optimize_full(&mut self) -> Result<Summary, SlamError> {
        self.values = self.full_values();
        self.run()
    }

    fn keyframe_poses(&self) -> Vec<Se3> {
        self.keyframes.iter().filter_map(|&v| self.values.se3(v)).collect()
    }

    fn landmarks(&self) -> Result<Vec<LandmarkEstimate>, SlamError> {
        if self.landmarks.is_empty() {
            return Ok(Vec::new());
        }
        let marginals = self.marginals()?;
        let ids: Vec<VarId> = self.landmarks.values().map(|s| s.var).collect();
        let covs = marginals.covariances(&ids)?;
        Ok(self
            .landmarks
            .iter()
            .zip(covs)
            .map(|((&landmark_id, state), cov)| LandmarkEstimate {
                landmark_id,
                position_in_world: self.values.point3(state.var).unwrap_or_default(),
                covariance: Matrix3::from_fn(|r, c| cov[(r, c)]),
            })
            .collect())
    }

    fn current_pose_covariance(&self) -> Result<Matrix6<f64>, SlamError> {
        let Some(&current) = self.keyframes.last() else { return Ok(Matrix6::zeros()) };
        if self.keyframes.len() == 1 {
            return Ok(Matrix6::zeros());
        }
        let cov = self.marginals()?.covariance(current)?;
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
        let before = slam.graph().chi2(slam.values()).unwrap();
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

    #[test]
    fn current_pose_covariance_is_the_dense_inverse() {
        let (_, slam, _) = run(3, GraphSlamParams { window_keyframes: 5, ..GraphSlamParams::default() });
        let cov = slam.current_pose_covariance().unwrap();
        let marginals = slam.marginals().unwrap();
        let h: DMatrix<f64> = marginals.dense_information();
        let inv = h.try_inverse().unwrap();
        // The current keyframe is the last pose; its columns in H: poses are pushed in order
        // with landmarks in between, so locate it by counting free dims before it.
        let values = slam.full_values();
        let current = *slam.keyframes.last().unwrap();
        let offset: usize =
            values.iter().take_while(|(id, _)| *id != current).filter(|(id, _)| !values.is_fixed(*id)).map(|(_, v)| v.dim()).sum();
        let block = inv.view((offset, offset), (6, 6));
        let rel = (cov - block).amax() / block.amax();
        assert!(rel < 1e-9, "relative difference {rel:e}");
        let traces = CovarianceTraces::of(&cov);
        assert!((traces.cov_trace - cov.trace()).abs() < 1e-15 && traces.pos_cov_trace > 0.0 && traces.rot_cov_trace > 0.0);
    }

    #[test]
    fn window_update_leaves_old_keyframes_fixed() {
        let w = world(40);
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let params = GraphSlamParams { window_keyframes: 3, ..GraphSlamParams::default() };
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
}
