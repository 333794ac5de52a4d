//! Graph SLAM backend (notes §1, paper eq. 1): keyframe poses on SE(3) (and SE(2) for 2D data
//! sets), landmarks in R³ / R², factors (priors, odometry, landmark observations), a sparse
//! Gauss-Newton / Levenberg-Marquardt optimiser with faer's sparse Cholesky, marginal
//! covariances, and g2o / Victoria Park readers for tests and benchmarks on real pose graphs.
//!
//! Conventions: right perturbations `x ⊕ ξ = x · Exp(ξ)`, tangent ξ = (δt, δφ) (translation
//! first); covariances are in the body frame. See [`lie`].
//!
//! ```
//! use fitslam_core::slam::{g2o::read_g2o, Factorisation, Gauge, LevenbergMarquardt, Marginals,
//!     Optimizer, OptimizerParams, Se2Residual};
//!
//! // Three poses, odometry and one loop closure; vertex 0 is fixed (g2o's gauge).
//! let text = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1.1 0 0\nVERTEX_SE2 2 1.0 1.2 1.5\n\
//!     EDGE_SE2 0 1 1 0 1.5707963 100 0 0 100 0 1000\n\
//!     EDGE_SE2 1 2 1 0 1.5707963 100 0 0 100 0 1000\n\
//!     EDGE_SE2 0 2 1 1 3.1415926 100 0 0 100 0 1000\n";
//! let mut problem = read_g2o(text.as_bytes())?.to_problem(Gauge::FixFirst, Se2Residual::Log)?;
//! let summary = LevenbergMarquardt::new(OptimizerParams::default())
//!     .optimize(&problem.graph, &mut problem.values)?;
//! assert!(summary.final_chi2 < 1e-6); // the three edges are consistent
//! let last = problem.last_pose().expect("poses");
//! let cov = Marginals::new(&problem.graph, &problem.values, Factorisation::Fastest)?.covariance(last)?;
//! assert_eq!(cov.shape(), (3, 3));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! | module | what |
//! |---|---|
//! | [`lie`] | SO(3), SE(2), SE(3): exp/log, adjoints, Jacobians |
//! | [`values`] | variables and their fixed flags |
//! | [`factors`] | `Factor` trait, noise models, prior / between / landmark factors |
//! | [`graph`] | the factor graph |
//! | `linear_system` | sparse normal equations, Cholesky with cached symbolic analysis |
//! | [`optimizer`] | Gauss-Newton and Levenberg-Marquardt (`step` / `optimize`) |
//! | [`incremental`] | iSAM2: Bayes tree, fluid relinearisation, wildfire back-substitution, marginals from the tree |
//! | [`marginals`] | marginal covariances by solving `H X = E` |
//! | [`g2o`] | g2o 2D/3D pose graphs: read, write, to a problem |
//! | [`victoria`] | Victoria Park (GTSAM `load2D` semantics) |
//! | [`backend`] | `SlamBackend`: what the simulator and the robot ask of a SLAM back end (keyframes in; poses, landmarks, covariances out) |
//! | `graph_slam` | `GraphSlam`, the landmark smoother: keyframes and landmarks as variables, incremental (iSAM2) or batch (sliding window + full), covariances |
//! | `pose_graph` | `PoseGraphSlam`, the RTAB-Map-like pose graph: keyframes only, visual-odometry and loop-closure links from 3D–3D alignment, closure rejection, landmarks anchored in keyframes |
//! | `propagation` | first-order covariance through SE(3) compositions |
//! | [`keyframes`] | keyframe SLAM front end: odometry in SE(3), landmark and gravity factors, keyframe clouds and re-registration |

pub mod backend;
pub mod factors;
pub mod g2o;
pub mod graph;
pub(crate) mod graph_slam;
pub mod incremental;
pub mod keyframes;
pub mod lie;
pub(crate) mod linear_system;
pub mod marginals;
pub mod optimizer;
pub(crate) mod pose_graph;
pub mod problem;
pub(crate) mod propagation;
#[cfg(test)]
mod real_data_tests;
pub mod values;
pub mod victoria;

pub use backend::{
    CovarianceTraces, Gravity, KeyframeUpdate, LandmarkEstimate, LandmarkObservation, LinkStats, Odometry, SlamBackend, SlamError,
};
pub use factors::{Factor, FactorError, GaussianNoise, RobustKernel, Se2Residual};
pub use graph::{FactorGraph, GraphError};
pub use graph_slam::{ANCHOR_SIGMA, GraphSlam, GraphSlamParams, OBSERVATION_CAUCHY_K, SlamSolver};
pub use incremental::{G2oReplay, IncrementalError, Isam2, Isam2Params, ReplayError, UpdateReport};
pub use lie::{Se2, Se3};
pub use linear_system::{Factorisation, SolveError};
pub use marginals::{FactorStats, MarginalError, Marginals};
pub use optimizer::{
    GaussNewton, LambdaSchedule, LevenbergMarquardt, OptError, Optimizer, OptimizerParams, StepReport, Summary, Termination,
};
pub use pose_graph::{PoseGraphParams, PoseGraphSlam};
pub use problem::{Gauge, Problem};
pub use values::{Values, VarId, Variable};
