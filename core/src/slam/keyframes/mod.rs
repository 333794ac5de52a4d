//! The simulator's SLAM front end (notes §1, §2, §8): turns the measured odometry, the IMU
//! attitude, the camera's landmark observations and the sensor clouds into keyframes for the
//! [`GraphSlam`](crate::slam::GraphSlam) back end (incremental or batch), and gives the mission its pose estimate, 6×6
//! covariance, landmark map and the keyframe clouds to re-register the traversability map after
//! a loop closure.
//!
//! **Keyframes.** A keyframe is taken when the odometry says the robot moved
//! `keyframe_every_m` (0.5 m) or turned `keyframe_every_rad` (0.5 rad) since the last one (never
//! while standing still). The first keyframe is the start pose (the map frame, anchored: the
//! gauge).
//!
//! **Odometry in SE(3), integrated in the body frame** (notes §8). Each control tick the wheels
//! measure the distance driven `d` (along the body's x axis) and the gyro the body-frame rotation
//! increment `δφ` (roll and pitch with σ_g² dt per axis, σ_g = `tilt_gyro_sigma_per_sqrt_s`;
//! yaw with the odometry's own noise, `crate::sim::odometry`). The motion since the latest keyframe
//! is composed from those increments, `T_rel ← T_rel · ΔT`, `ΔT = (Exp(δφ), Exp(δφ/2) (d, 0, 0))`
//! (the chord of the tick's arc), so the odometry factor between keyframes a, b holds only the
//! noise of the ticks between them, as a real gyro's relative rotation does. (Integrating an
//! *absolute* odometry attitude and differencing two of them lets the absolute tilt drift leak
//! into every relative rotation when the robot turns; unmodelled, that made the gravity factors
//! and the odometry disagree: docs/benchmarks.md, SLAM backend.) Its covariance, in `T_rel`'s right
//! tangent (ξ = (δt, δφ)), is propagated per tick: `Σ ← Ad(ΔT⁻¹) Σ Ad(ΔT⁻¹)ᵀ + J Q Jᵀ` with
//! `Q = diag(σ_d², σ_z² |d|, σ_roll², σ_pitch², σ_yaw²)` (σ_z = `z_sigma_per_sqrt_m`: the
//! terrain's curvature under the chord) and `J` the tick's noise Jacobian
//! (`propagate_relative`). A floor of 10⁻⁸ on the diagonal keeps it invertible when standing
//! still or turning in place.
//!
//! **Landmark factors.** At each keyframe the camera observes; each observation is the landmark
//! in the robot frame with the camera model's covariance (bearing σ_b across the line of
//! sight, σ_d = k d² along it; `crate::sim::camera`). Correspondences are the landmark ids the
//! front end matched (in the simulator `crate::sim::vision`: a budget of detected features, a
//! share of them matched wrongly, which the back end's robust kernel absorbs); every observation
//! given is used.
//!
//! **Between keyframes** the estimate is `T = T_k ⊕ (T_o(k)⁻¹ T_o(now))` and its covariance the
//! keyframe's marginal compounded with the odometry since: `Σ = Ad(T_rel⁻¹) Σ_k Ad(T_rel⁻¹)ᵀ +
//! Σ_rel` (right perturbations): the marginal of a pose joined to keyframe k by that odometry
//! alone, to first order. **Keyframe marginals**: with the incremental solver (default,
//! [`crate::slam::SlamSolver`]) the exact 6×6 marginal of the full problem at every keyframe,
//! from the Bayes tree's root (at the solver's linearisation point). With the batch solver the
//! exact marginal (one sparse Cholesky of the whole problem) after every loop closure and every
//! `marginal_every_keyframes` keyframes; at the other keyframes the compounded covariance above
//! is kept (it ignores the landmark information since the last exact marginal, so it
//! over-estimates; the exact one drops back). Landmark covariances for the planner: at a
//! decision, when `landmark_refresh_keyframes` keyframes were added since the last refresh, the
//! exact marginals of the landmarks seen since the last refresh; older landmarks keep their last
//! exact covariance (a later loop closure lowers the true one: theirs is then conservative); a
//! landmark added since the last refresh gets `R C Rᵀ + G Σ_k Gᵀ` (its observation's covariance
//! plus its keyframe's pose covariance through `G = R [I, −[p]×]`, correlations ignored).
//!
//! **Re-registration.** Every sensor cloud (LiDAR, depth camera, footprint) is stored in the body
//! frame of the latest keyframe (`p_k = T_o(k)⁻¹ T_o(now) p_body`), one point per
//! `cloud_voxel_m` 3D voxel per keyframe, as f32. When a full optimisation moves some keyframe
//! by more than `reregister_shift_m` (|Δt| + `reregister_lever_m` · |Δφ|, the lever standing for
//! a typical point range) from the pose its clouds were registered with, the traversability map
//! is rebuilt from every keyframe cloud with the new poses (`reregister`). Points forgotten by a
//! trapped robot's recovery ([`SlamFrontend::forget_disc`]) stay out of every later rebuild.
//!
//! Cost per tick O(1); per keyframe one iSAM2 update (the cliques the keyframe's factors touch
//! and their paths to the root: small while exploring, up to the whole trajectory since a
//! re-observed landmark was last seen) or, batch, one window optimisation (O(window)) plus one
//! full sparse Cholesky every `marginal_every_keyframes`; per stored point O(1) (a hash-set lookup); a
//! re-registration O(stored points + cells × disc).

mod clouds;
mod frontend;
mod odometry;
mod params;

pub use clouds::KeyframeClouds;

pub(crate) use crate::slam::propagation::{anchored_landmark_covariance, compound_covariance};
#[cfg(test)]
pub(crate) use clouds::reregister;
pub(crate) use clouds::{height_variance, reregister_moved};
pub use frontend::{CameraObservation, SlamFrontend, SlamModel};
pub(crate) use odometry::{BodyIncrement, propagate_relative};
pub use params::SlamParams;

#[cfg(test)]
mod tests;
