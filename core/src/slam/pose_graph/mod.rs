//! Pose-graph SLAM, the class of RTAB-Map (Labbé & Michaud, "RTAB-Map as an open-source lidar
//! and visual SLAM library", JFR 36(2), 2019), the SLAM the paper's covariance came from: the
//! keyframe poses are the only variables; the landmarks live in the keyframes that saw them.
//!
//! Per keyframe k (each a [`SlamBackend::add_keyframe`]):
//! - **Odometry links** k−1 → k. The wheel odometry (with the gyro, its slip on slopes and its
//!   covariance) links every keyframe to the previous one. *Visual odometry* adds a second,
//!   independent link: the landmarks seen from both keyframes are aligned ([`alignment`]: robust
//!   weighted 3D–3D, from the wheels' guess); with at least `min_inliers` inliers the link is
//!   that alignment, its covariance the inverse of the inliers' information (fewer or
//!   worse-placed features, a larger covariance). Below it visual tracking is lost and the
//!   wheels alone link the keyframes until it comes back or place recognition relocalises
//!   (a new map session after a loss is linked the same way), as RTAB-Map with a wheel
//!   odometry input does. The two links are what RTAB-Map receives from an odometry that fuses
//!   wheels and camera, kept apart here so that each keeps its own covariance. The IMU's
//!   gravity factor holds the tilt at every keyframe.
//! - **Place recognition**: the older keyframe (at least `loop_gap_keyframes` back) sharing the
//!   most landmarks with k, if it shares `loop_min_inliers`, is verified by the same alignment
//!   (no guess: Kabsch) and, with `loop_min_inliers` inliers, proposed as a loop closure. With
//!   probability `false_closure_rate` per keyframe place recognition is fooled instead
//!   (perceptual aliasing): a random older keyframe with a plausible offset (up to 1 m, 0.5 rad)
//!   and the covariance a verified closure would have.
//! - **Closure rejection**: the closure's residual `r = Log(Z⁻¹ · T_j⁻¹ T_k)` against the current
//!   graph, whitened by `S = Σ_Z + Σ_k + Ad(T_k⁻¹ T_j) Σ_j Ad(T_k⁻¹ T_j)ᵀ` (the marginals of the
//!   two keyframes, their correlation ignored: a wider gate), must be below
//!   `closure_gate_chi2`; otherwise the closure is dropped (RTAB-Map's `RGBD/OptimizeMaxError`).
//! - **iSAM2 update** with the new pose, its links and gravity factor (a closure then
//!   relinearises what moved until the step settles); the new keyframe's exact 6×6 marginal
//!   comes from the Bayes tree's root.
//!
//! **Landmark map** (what u2 reads): each landmark is anchored to one keyframe, the one that saw
//! it with the smallest observation covariance among the views the verification kept; its
//! position is the anchor's current pose ⊕ the observation, its covariance
//! `R C Rᵀ + G Σ_anchor Gᵀ` (the observation's and the anchor's marginal through
//! `G = R [I, −[p]×]`). The anchor's marginal is the one at the keyframe's insertion until
//! [`SlamBackend::recent_landmarks`] computes it again from the Bayes tree.
//!
//! Cost per keyframe: the alignments O(features), place recognition O(features × keyframes per
//! landmark) through an inverted index, one iSAM2 update on poses only (6 unknowns each).

mod alignment;
mod params;
#[cfg(test)]
mod tests;

pub use params::PoseGraphParams;

use std::collections::BTreeMap;

use nalgebra::{Matrix3, Matrix6, UnitQuaternion, Vector3, Vector6};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use self::alignment::{Alignment, Correspondence, align};
use super::backend::{KeyframeUpdate, LandmarkEstimate, LandmarkObservation, LinkStats, Odometry, SlamBackend, SlamError};
use super::factors::{BetweenSe3, Factor, GaussianNoise, GravitySe3, PriorSe3};
use super::g2o::{G2oEdge, G2oFile, G2oVertex};
use super::graph::FactorGraph;
use super::graph_slam::ANCHOR_SIGMA;
use super::incremental::Isam2;
use super::lie::Se3;
use super::marginals::Marginals;
use super::optimizer::{OptError, Summary, Termination};
use super::propagation::anchored_landmark_covariance;
use super::values::{Values, VarId, Variable};
use crate::slam::Factorisation;

/// Relinearisation passes after an accepted loop closure.
const CLOSURE_PASSES: usize = 5;

/// Where a landmark is anchored.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Anchor {
    keyframe: usize,
    point_in_robot: Vector3<f64>,
    covariance: Matrix3<f64>,
    last_seen_keyframe: usize,
}

/// A proposed loop closure.
struct Closure {
    old_keyframe: usize,
    old_from_new: Se3,
    covariance: Matrix6<f64>,
    shared: Vec<u64>,
    inliers: Vec<u64>,
    aliased: bool,
}

/// The pose graph; see the module doc.
#[derive(Debug)]
pub struct PoseGraphSlam {
    params: PoseGraphParams,
    isam: Isam2,
    /// Each keyframe's observations, by increasing landmark id.
    views: Vec<Vec<LandmarkObservation>>,
    /// Each keyframe's marginal covariance at its insertion.
    marginal_at_insertion: Vec<Matrix6<f64>>,
    /// Landmark → the keyframes that saw it, increasing.
    seen_by: BTreeMap<u64, Vec<u32>>,
    anchors: BTreeMap<u64, Anchor>,
    stats: LinkStats,
    rng: ChaCha8Rng,
}

impl PoseGraphSlam {
    /// Starts a map at the first keyframe `world_from_first` (the gauge: a prior of σ
    /// [`ANCHOR_SIGMA`]) with what it observes; `seed` drives the aliased closures.
    pub fn new(params: PoseGraphParams, world_from_first: Se3, observations: &[LandmarkObservation], seed: u64) -> Result<Self, SlamError> {
        if !world_from_first.is_finite() {
            return Err(SlamError::NonFinite);
        }
        check_observations(observations)?;
        let mut isam = Isam2::new(params.isam2);
        let noise = GaussianNoise::isotropic(6, ANCHOR_SIGMA)?;
        let prior: Box<dyn Factor> = Box::new(PriorSe3::new(VarId(0), world_from_first, noise));
        isam.update(&[Variable::Se3(world_from_first)], vec![prior])?;
        let mut me = Self {
            params,
            isam,
            views: Vec::new(),
            marginal_at_insertion: vec![Matrix6::zeros()],
            seen_by: BTreeMap::new(),
            anchors: BTreeMap::new(),
            stats: LinkStats::default(),
            rng: ChaCha8Rng::seed_from_u64(seed ^ 0x9A5E_C10C),
        };
        me.store_view(0, observations, &[]);
        Ok(me)
    }

    /// Its parameters.
    pub fn params(&self) -> &PoseGraphParams {
        &self.params
    }

    fn pose(&self, keyframe: usize) -> Se3 {
        match self.isam.estimate_of(VarId(keyframe)) {
            Some(Variable::Se3(t)) => t,
            _ => Se3::identity(),
        }
    }

    /// The correspondences of two keyframes' views (a: `old`, b: `new`), by increasing id.
    fn correspondences(old: &[LandmarkObservation], new: &[LandmarkObservation]) -> (Vec<u64>, Vec<Correspondence>) {
        let (mut ids, mut pairs) = (Vec::new(), Vec::new());
        let (mut i, mut j) = (0, 0);
        while i < old.len() && j < new.len() {
            match old[i].landmark_id.cmp(&new[j].landmark_id) {
                std::cmp::Ordering::Less => i += 1,
                std::cmp::Ordering::Greater => j += 1,
                std::cmp::Ordering::Equal => {
                    ids.push(old[i].landmark_id);
                    pairs.push(Correspondence {
                        in_a: old[i].point_in_robot,
                        cov_a: old[i].covariance,
                        in_b: new[j].point_in_robot,
                        cov_b: new[j].covariance,
                    });
                    i += 1;
                    j += 1;
                }
            }
        }
        (ids, pairs)
    }

    /// Visual odometry from the previous keyframe; `None`: tracking lost.
    fn visual_odometry(&self, observations: &[LandmarkObservation], guess: &Se3) -> Option<(Alignment, Vec<u64>)> {
        let previous = self.views.last()?;
        let (ids, pairs) = Self::correspondences(previous, observations);
        if pairs.len() < self.params.min_inliers {
            return None;
        }
        let a = align(&pairs, Some(*guess), self.params.inlier_chi2)?;
        (a.inlier_count >= self.params.min_inliers).then_some((a, ids))
    }

    /// Place recognition for keyframe `k` (see the module doc); draws the aliasing lot every
    /// keyframe so that the random stream does not depend on what the map holds.
    fn place_recognition(&mut self, k: usize, observations: &[LandmarkObservation], nominal: &Matrix6<f64>) -> Option<Closure> {
        let u: f64 = self.rng.random();
        let (yaw, dx, dy): (f64, f64, f64) =
            (self.rng.random_range(-0.5..0.5), self.rng.random_range(-1.0..1.0), self.rng.random_range(-1.0..1.0));
        let newest_old = k.checked_sub(self.params.loop_gap_keyframes)?;
        let pick: usize = self.rng.random_range(0..=newest_old);
        if u < self.params.false_closure_rate {
            let old_from_new = Se3::new(UnitQuaternion::from_euler_angles(0.0, 0.0, yaw), Vector3::new(dx, dy, 0.0));
            return Some(Closure {
                old_keyframe: pick,
                old_from_new,
                covariance: *nominal,
                shared: Vec::new(),
                inliers: Vec::new(),
                aliased: true,
            });
        }
        // Votes of the older keyframes, through the inverted index.
        let mut votes: BTreeMap<u32, usize> = BTreeMap::new();
        for o in observations {
            for &kf in self.seen_by.get(&o.landmark_id).map_or(&[][..], Vec::as_slice) {
                if (kf as usize) <= newest_old {
                    *votes.entry(kf).or_default() += 1;
                }
            }
        }
        // Most votes; among equals the oldest (deterministic).
        let (&best, &count) = votes.iter().max_by(|a, b| a.1.cmp(b.1).then(b.0.cmp(a.0)))?;
        if count < self.params.loop_min_inliers {
            return None;
        }
        let (ids, pairs) = Self::correspondences(&self.views[best as usize], observations);
        let a = align(&pairs, None, self.params.inlier_chi2)?;
        if a.inlier_count < self.params.loop_min_inliers {
            return None;
        }
        let inliers = ids.iter().zip(&a.inliers).filter(|(_, ok)| **ok).map(|(id, _)| *id).collect();
        Some(Closure {
            old_keyframe: best as usize,
            old_from_new: a.a_from_b,
            covariance: a.covariance,
            shared: ids,
            inliers,
            aliased: false,
        })
    }

    /// The closure gate (module doc): whether `c` agrees with the graph, `new_pose` and
    /// `new_cov` being the new keyframe's predicted pose and covariance.
    fn passes_gate(&self, c: &Closure, new_pose: &Se3, new_cov: &Matrix6<f64>) -> Result<bool, SlamError> {
        if self.params.closure_gate_chi2 <= 0.0 {
            return Ok(true);
        }
        let old_pose = self.pose(c.old_keyframe);
        let cov_old = self.isam.marginal_covariance(VarId(c.old_keyframe))?;
        let cov_old = Matrix6::from_fn(|r, cc| cov_old[(r, cc)]);
        let predicted = old_pose.between(new_pose);
        let r: Vector6<f64> = c.old_from_new.local(&predicted);
        let ad = predicted.inverse().adjoint();
        let s = c.covariance + new_cov + ad * cov_old * ad.transpose();
        let Some(chol) = s.cholesky() else { return Ok(false) };
        let chi2 = r.dot(&chol.solve(&r));
        Ok(chi2 <= self.params.closure_gate_chi2)
    }

    /// Stores keyframe `k`'s view: the inverted index, new anchors, and re-anchoring of the
    /// landmarks in `verified` when this view is better.
    fn store_view(&mut self, k: usize, observations: &[LandmarkObservation], verified: &[u64]) {
        let mut view = observations.to_vec();
        view.sort_by_key(|o| o.landmark_id);
        for o in &view {
            self.seen_by.entry(o.landmark_id).or_default().push(k as u32);
            let candidate = Anchor { keyframe: k, point_in_robot: o.point_in_robot, covariance: o.covariance, last_seen_keyframe: k };
            match self.anchors.get_mut(&o.landmark_id) {
                None => {
                    self.anchors.insert(o.landmark_id, candidate);
                }
                Some(a) => {
                    a.last_seen_keyframe = k;
                    if verified.binary_search(&o.landmark_id).is_ok() && o.covariance.trace() < a.covariance.trace() {
                        *a = candidate;
                    }
                }
            }
        }
        self.views.push(view);
    }

    /// The estimate of a landmark from its anchor, with the anchor's covariance `pose_cov`.
    fn landmark_estimate(&self, id: u64, a: &Anchor, pose: &Se3, pose_cov: &Matrix6<f64>) -> LandmarkEstimate {
        LandmarkEstimate {
            landmark_id: id,
            position_in_world: pose.transform_point(&a.point_in_robot),
            covariance: anchored_landmark_covariance(pose, pose_cov, &a.point_in_robot, &a.covariance),
        }
    }
}

/// Every observation finite, its covariance usable.
fn check_observations(observations: &[LandmarkObservation]) -> Result<(), SlamError> {
    for o in observations {
        if !o.point_in_robot.iter().all(|v| v.is_finite()) {
            return Err(SlamError::NonFinite);
        }
        GaussianNoise::from_covariance(&o.covariance)?;
    }
    Ok(())
}

impl SlamBackend for PoseGraphSlam {
    fn add_keyframe(&mut self, odometry: &Odometry, observations: &[LandmarkObservation]) -> Result<KeyframeUpdate, SlamError> {
        if !odometry.previous_from_current.is_finite() {
            return Err(SlamError::NonFinite);
        }
        check_observations(observations)?;
        let wheel_noise = GaussianNoise::from_covariance(&odometry.covariance)?;
        let k = self.views.len();
        let var = VarId(k);
        let gravity = match odometry.gravity {
            Some(g) => {
                Some(GravitySe3::new(var, g.up_in_body, GaussianNoise::isotropic(2, g.sigma_rad)?).map_err(|_| SlamError::NonFinite)?)
            }
            None => None,
        };
        let mut sorted = observations.to_vec();
        sorted.sort_by_key(|o| o.landmark_id);

        // The odometry links: the wheels' always, visual odometry's while tracking.
        let vo = self.visual_odometry(&sorted, &odometry.previous_from_current);
        let mut verified: Vec<u64> = Vec::new();
        let mut factors: Vec<Box<dyn Factor>> =
            vec![Box::new(BetweenSe3::new(VarId(k - 1), var, odometry.previous_from_current, wheel_noise))];
        let (link, link_cov) = match &vo {
            Some((a, ids)) => {
                self.stats.visual_links += 1;
                verified.extend(ids.iter().zip(&a.inliers).filter(|(_, ok)| **ok).map(|(id, _)| *id));
                factors.push(Box::new(BetweenSe3::new(VarId(k - 1), var, a.a_from_b, GaussianNoise::from_covariance(&a.covariance)?)));
                // The two links fused (information added, at the visual estimate).
                let fused = (a.covariance.try_inverse().unwrap_or_else(Matrix6::zeros)
                    + odometry.covariance.try_inverse().unwrap_or_else(Matrix6::zeros))
                .try_inverse()
                .unwrap_or(a.covariance);
                (a.a_from_b, (fused + fused.transpose()) * 0.5)
            }
            None => {
                self.stats.wheel_links += 1;
                (odometry.previous_from_current, odometry.covariance)
            }
        };
        let previous = self.pose(k - 1);
        let new_pose = previous * link;
        let new_cov = super::propagation::compound_covariance(&self.marginal_at_insertion[k - 1], &link, &link_cov);
        if let Some(g) = gravity {
            factors.push(Box::new(g));
        }

        // Place recognition and the closure gate.
        let mut loop_closures = Vec::new();
        let mut closed = false;
        if let Some(c) = self.place_recognition(k, &sorted, &link_cov) {
            self.stats.false_closures += u64::from(c.aliased);
            if self.passes_gate(&c, &new_pose, &new_cov)? {
                self.stats.closures_accepted += 1;
                self.stats.false_closures_accepted += u64::from(c.aliased);
                factors.push(Box::new(BetweenSe3::new(
                    VarId(c.old_keyframe),
                    var,
                    c.old_from_new,
                    GaussianNoise::from_covariance(&c.covariance)?,
                )));
                loop_closures = c.shared;
                verified.extend(c.inliers);
                closed = true;
            } else {
                self.stats.closures_rejected += 1;
            }
        }

        self.isam.update(&[Variable::Se3(new_pose)], factors)?;
        if closed {
            for _ in 0..CLOSURE_PASSES {
                if self.isam.relinearize(self.params.isam2.relinearize_threshold)?.relinearized == 0 {
                    break;
                }
            }
        }
        let marginal = self.isam.marginal_covariance(var)?;
        self.marginal_at_insertion.push(Matrix6::from_fn(|r, c| marginal[(r, c)]));
        verified.sort_unstable();
        verified.dedup();
        self.store_view(k, &sorted, &verified);
        Ok(KeyframeUpdate { keyframe: k, loop_closures, full: closed, summary: None })
    }

    /// Relinearises every variable and re-eliminates, until χ² decreases by less than 10⁻⁶
    /// relative (at most 20 passes).
    fn optimize_full(&mut self) -> Result<Summary, SlamError> {
        let initial_chi2 = self.isam.chi2().map_err(OptError::from)?;
        let mut summary = Summary { initial_chi2, final_chi2: initial_chi2, ..Summary::default() };
        while summary.iterations < 20 {
            self.isam.relinearize(0.0)?;
            summary.iterations += 1;
            let chi2 = self.isam.chi2().map_err(OptError::from)?;
            let decrease = summary.final_chi2 - chi2;
            summary.final_chi2 = chi2;
            if decrease <= 1e-6 * chi2.max(f64::MIN_POSITIVE) {
                summary.termination = Some(Termination::RelativeDecrease);
                break;
            }
        }
        Ok(summary)
    }

    fn keyframe_poses(&self) -> Vec<Se3> {
        (0..self.views.len()).map(|k| self.pose(k)).collect()
    }

    fn landmarks(&self) -> Result<Vec<LandmarkEstimate>, SlamError> {
        self.recent_landmarks(0)
    }

    fn current_pose_covariance(&self) -> Result<Matrix6<f64>, SlamError> {
        Ok(self.marginal_at_insertion.last().copied().unwrap_or_else(Matrix6::zeros))
    }

    fn keyframe_count(&self) -> usize {
        self.views.len()
    }

    fn current_pose(&self) -> Se3 {
        self.pose(self.views.len().saturating_sub(1))
    }

    fn landmark_count(&self) -> usize {
        self.anchors.len()
    }

    fn has_landmark(&self, landmark_id: u64) -> bool {
        self.anchors.contains_key(&landmark_id)
    }

    fn landmark_positions(&self) -> Vec<(u64, Vector3<f64>)> {
        let poses = self.keyframe_poses();
        self.anchors.iter().map(|(&id, a)| (id, poses[a.keyframe].transform_point(&a.point_in_robot))).collect()
    }

    /// The anchors' marginals from the Bayes tree (each anchor keyframe once).
    fn recent_landmarks(&self, since_keyframe: usize) -> Result<Vec<LandmarkEstimate>, SlamError> {
        let recent: Vec<(u64, &Anchor)> =
            self.anchors.iter().filter(|(_, a)| a.last_seen_keyframe >= since_keyframe).map(|(&id, a)| (id, a)).collect();
        let mut keyframes: Vec<usize> = recent.iter().map(|(_, a)| a.keyframe).collect();
        keyframes.sort_unstable();
        keyframes.dedup();
        let vars: Vec<VarId> = keyframes.iter().map(|&k| VarId(k)).collect();
        let covs = self.isam.marginal_covariances(&vars)?;
        let by_keyframe: BTreeMap<usize, (Se3, Matrix6<f64>)> =
            keyframes.iter().zip(covs).map(|(&k, c)| (k, (self.pose(k), Matrix6::from_fn(|r, cc| c[(r, cc)])))).collect();
        Ok(recent
            .into_iter()
            .map(|(id, a)| {
                let (pose, cov) = &by_keyframe[&a.keyframe];
                self.landmark_estimate(id, a, pose, cov)
            })
            .collect())
    }

    fn exact_marginal_every_keyframe(&self) -> bool {
        true
    }

    fn link_stats(&self) -> LinkStats {
        self.stats
    }

    fn graph(&self) -> &FactorGraph {
        self.isam.graph()
    }

    fn estimate(&self) -> Values {
        let mut v = self.isam.estimate();
        for k in 0..v.len() {
            v.set_fixed(VarId(k), k == 0);
        }
        v
    }

    fn linearization_point(&self) -> Values {
        let mut v = self.isam.linearization_point().clone();
        for k in 0..v.len() {
            v.set_fixed(VarId(k), k == 0);
        }
        v
    }

    fn current_variable(&self) -> VarId {
        VarId(self.views.len().saturating_sub(1))
    }

    fn marginals(&self) -> Result<Marginals, SlamError> {
        Ok(Marginals::new(self.graph(), &self.estimate(), Factorisation::default())?)
    }

    /// Every keyframe as `VERTEX_SE3:QUAT` (id = keyframe index) and every link as
    /// `EDGE_SE3:QUAT`; the anchor prior and the gravity factors have no g2o form.
    fn to_g2o(&self) -> (G2oFile, usize) {
        let factors = self.graph().factors();
        let file = G2oFile {
            vertices: (0..self.views.len()).map(|k| G2oVertex::Se3 { id: k as u64, pose: self.pose(k) }).collect(),
            edges: factors.iter().filter_map(|f| f.measurement()).map(|m| G2oEdge::of_measurement(&m, |v| v.0 as u64)).collect(),
            ..G2oFile::default()
        };
        let left_out = factors.len() - file.edges.len();
        (file, left_out)
    }
}
