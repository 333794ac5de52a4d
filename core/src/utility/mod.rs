//! The utilities that rank frontier candidates (notes §5–6; paper §II-D).
//!
//! | file | what | paper |
//! |---|---|---|
//! | [`entropy`] | binary entropy `H`, visibility gain `g(N)` | eqs. 5–6 |
//! | [`rays`] | the ray fan and per-ray gains `ΔE^θ` (Amanatides–Woo) | eqs. 3–6 |
//! | [`theta_star`](mod@theta_star) | Θ* and ΔE: a circular sliding window of width Φ | eq. 7 |
//! | [`u1`] | `u1 = α·ρ_min/ρ + (1 − α)·ΔE/ΔE_max` | eq. 2 |
//! | [`voxels`] | landmarks binned into voxels with a 2D spatial index | §II-D |
//! | `fim` | bearing Jacobian, bearing covariance, Fisher information and its trace | eqs. 8–9 |
//! | [`u2`] | waypoints, camera poses, frustum, `I_p`, `u2 = β·u1 + (1 − β)·I_p` | eqs. 10–14 |

pub mod entropy;
pub(crate) mod fim;
pub mod rays;
pub mod theta_star;
pub mod u1;
pub mod u2;
pub mod voxels;

pub(crate) use rays::RayFan;
pub(crate) use theta_star::FovWindows;
pub use theta_star::{ThetaStar, theta_star};
pub(crate) use u1::u1_scores;
pub use u2::WaypointReport;
pub(crate) use u2::{PathView, normalise_path_information, path_information, path_tracked_share, u2_score};
pub use voxels::LandmarkVoxels;

use thiserror::Error;

/// Invalid input to a utility.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum UtilityError {
    /// A parameter is out of range (e.g. not finite and > 0).
    #[error("{name} is out of range (got {})", crate::params::Num(*value))]
    InvalidParameter {
        /// The parameter (e.g. `"voxel_m"`).
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// The landmark cloud's covariances, when given, are not one per point.
    #[error("the landmark cloud has {points} points but {covariances} covariances")]
    CovarianceCountMismatch {
        /// Points in the cloud.
        points: usize,
        /// Covariances given.
        covariances: usize,
    },
}
