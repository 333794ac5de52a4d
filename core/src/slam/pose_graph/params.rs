//! [`PoseGraphSlam`](super::PoseGraphSlam)'s parameters, with their sources (RTAB-Map's names
//! where it has the parameter; decision record 0020).

use serde::{Deserialize, Serialize};

use crate::params::{InvalidParam, check_non_negative};
use crate::slam::incremental::Isam2Params;

/// Parameters of the pose-graph SLAM ([`PoseGraphSlam`](crate::slam::PoseGraphSlam); decision 0021).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PoseGraphParams {
    /// A visual-odometry link needs at least this many inlier correspondences with the previous
    /// keyframe; below it, tracking is lost and the wheel odometry (with its slip) links the
    /// keyframes. Default 6: RTAB-Map's `Vis/MinInliers` is 20 of `Vis/MaxFeatures` 1000
    /// features; of the simulator's 30-feature budget that would be under one, so the floor
    /// that keeps a 6-DoF alignment over-determined under outliers, as the tracking threshold
    /// (`vision.min_tracked`).
    pub min_inliers: usize,
    /// A loop closure needs at least this many inlier correspondences with the old keyframe.
    /// Default 10 (`vision.relocalise_min`: a place is recognised from more matches than
    /// tracking needs).
    pub loop_min_inliers: usize,
    /// Place recognition looks only at keyframes at least this many keyframes older than the
    /// new one (the recent ones are linked by odometry already; RTAB-Map's working memory
    /// keeps them out of its loop hypotheses likewise, `Mem/STMSize`). Default 10.
    pub loop_gap_keyframes: usize,
    /// A correspondence is an inlier when its whitened squared residual is below this (χ²₃).
    /// Default 11.34 (99 %).
    pub inlier_chi2: f64,
    /// A loop closure is rejected when its residual against the current graph, whitened by the
    /// closure's covariance plus the two keyframes' marginals (moved into one frame), exceeds
    /// this (χ²₆); 0 accepts every verified closure. Default 22.46 (99.9 %), the joint 6-DoF
    /// form of RTAB-Map's `RGBD/OptimizeMaxError` = 3 σ, tested before the update instead of
    /// after it (a factor once in the Bayes tree is not taken out).
    pub closure_gate_chi2: f64,
    /// Probability per keyframe that place recognition returns a wrong place which passes
    /// geometric verification (perceptual aliasing: repeated texture, symmetric rooms); such a
    /// closure links the keyframe to a random older one with a plausible offset. Default 0.01
    /// (RTAB-Map's loop-closure detection at `Rtabmap/LoopThr` 0.11 reports precision near 99 %
    /// on its benchmarks).
    pub false_closure_rate: f64,
    /// The incremental solver's thresholds. Default: GTSAM's ([`Isam2Params::default`]).
    pub isam2: Isam2Params,
}

impl Default for PoseGraphParams {
    fn default() -> Self {
        Self {
            min_inliers: 6,
            loop_min_inliers: 10,
            loop_gap_keyframes: 10,
            inlier_chi2: 11.34,
            closure_gate_chi2: 22.46,
            false_closure_rate: 0.01,
            isam2: Isam2Params::default(),
        }
    }
}

impl PoseGraphParams {
    /// Checks ranges; the error names the first bad field.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        let at_least = |name: &str, v: usize, min: usize| {
            if v >= min {
                Ok(())
            } else {
                Err(InvalidParam::new(format!("slam.pose_graph.{name}"), format!("must be ≥ {min} (got {v})")))
            }
        };
        at_least("min_inliers", self.min_inliers, 3)?;
        at_least("loop_min_inliers", self.loop_min_inliers, 3)?;
        at_least("loop_gap_keyframes", self.loop_gap_keyframes, 1)?;
        crate::params::check_positive("slam.pose_graph.inlier_chi2", self.inlier_chi2)?;
        check_non_negative("slam.pose_graph.closure_gate_chi2", self.closure_gate_chi2)?;
        if !(0.0..=1.0).contains(&self.false_closure_rate) {
            return Err(InvalidParam::new(
                "slam.pose_graph.false_closure_rate",
                format!("must be in [0, 1] (got {})", crate::params::Num(self.false_closure_rate)),
            ));
        }
        check_non_negative("slam.pose_graph.isam2.relinearize_threshold", self.isam2.relinearize_threshold)?;
        check_non_negative("slam.pose_graph.isam2.wildfire_threshold", self.isam2.wildfire_threshold)?;
        Ok(())
    }
}
