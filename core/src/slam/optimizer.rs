//! Gauss-Newton and Levenberg-Marquardt on the sparse normal equations (notes §1: minimise
//! Σ_k ‖e_k(X)‖²_{Σ_k}).
//!
//! Each [`Optimizer::step`] linearises once (`H = JᵀΩJ`, `g = JᵀΩe`), solves
//! `(H + λI) δ = −g` by sparse Cholesky (λ = 0 for Gauss-Newton) and retracts `x ⊕ δ`. LM uses
//! Nielsen's damping update (as g2o): λ₀ = τ · max diag(H); a step is accepted when the gain
//! ratio ρ = (χ² − χ²_new) / (δᵀ(λδ − g)) is positive, then λ ← λ · max(1/10,
//! 1 − (2ρ − 1)³) (Nielsen's floor is 1/3; 1/10, GTSAM's factor, halves the iterations on the
//! SE-Sync graphs); otherwise λ ← λ·ν, ν ← 2ν and the solve is retried. Gauss-Newton accepts a
//! step only if χ² does not increase. [`Optimizer::optimize`] loops `step` until the relative χ²
//! decrease falls below `relative_tolerance`, χ² below `absolute_tolerance`, no decreasing step
//! exists, or `max_iterations` is reached (an error that still leaves the best estimate in
//! `values`: every accepted step lowers χ²).
//!
//! The optimised cost is χ² over the factors that touch a free variable (a constant offset from
//! factors between fixed variables would blunt the relative test in sliding-window use).
//! Cost per iteration: one linearisation O(factors) plus one sparse numeric Cholesky (its
//! symbolic analysis is cached while the structure stays the same).

use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::factors::FactorError;
use super::graph::FactorGraph;
use super::linear_system::{Factorisation, LinearSystem, SolveError};
use super::values::Values;

/// Smallest factor by which an accepted LM step shrinks λ (Nielsen uses 1/3; GTSAM 1/10).
const LAMBDA_MIN_DECREASE: f64 = 0.1;

/// How Levenberg-Marquardt adapts its damping λ.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum LambdaSchedule {
    /// λ₀ = τ · max diag(H) (τ = `lambda_initial_factor`); accept when the gain ratio ρ > 0,
    /// then λ ← λ · max(1/10, 1 − (2ρ − 1)³); reject: λ ← λ·ν, ν ← 2ν (Nielsen, as g2o).
    #[default]
    Nielsen,
    /// GTSAM's default: λ₀ = `lambda_initial_factor` (absolute); accept when ρ > 10⁻³, then
    /// λ ← λ/10; reject: λ ← 10 λ; give up the linearisation when λ exceeds 10⁵. Following the
    /// same path as GTSAM matters on non-convex problems started far from the optimum (MIT,
    /// Victoria Park), where the local minimum reached depends on the path.
    Gtsam,
}

/// GTSAM's `lambdaUpperBound`.
const GTSAM_LAMBDA_UPPER: f64 = 1e5;

/// Stopping rules and damping, with GTSAM-like defaults.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OptimizerParams {
    /// Maximum number of linearisations. Default 100.
    pub max_iterations: usize,
    /// Stop when (χ²_prev − χ²)/χ²_prev falls below this. Default 1e-10.
    pub relative_tolerance: f64,
    /// Stop when χ² falls below this. Default 1e-12.
    pub absolute_tolerance: f64,
    /// LM: λ₀ = τ · max diag(H). Default 1e-5.
    pub lambda_initial_factor: f64,
    /// LM: give up on a linearisation (no decreasing step) when λ exceeds this. Default 1e16.
    pub lambda_max: f64,
    /// LM damping schedule. Default Nielsen.
    pub lambda_schedule: LambdaSchedule,
    /// Sparse Cholesky: faer's fastest choice, or always simplicial for the same bits on every
    /// CPU and in wasm. Default fastest.
    pub factorisation: Factorisation,
}

impl Default for OptimizerParams {
    fn default() -> Self {
        Self {
            max_iterations: 100,
            relative_tolerance: 1e-10,
            absolute_tolerance: 1e-12,
            lambda_initial_factor: 1e-5,
            lambda_max: 1e16,
            lambda_schedule: LambdaSchedule::Nielsen,
            factorisation: Factorisation::Fastest,
        }
    }
}

/// Why the loop stopped successfully.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Termination {
    /// An accepted step lowered χ² by at most `relative_tolerance` of its value.
    RelativeDecrease,
    /// χ² fell to `absolute_tolerance` or below.
    AbsoluteChi2,
    /// No step from the last linearisation lowered χ² (a minimum to numerical precision).
    NoDecrease,
}

/// What one [`Optimizer::step`] did.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct StepReport {
    /// Optimised χ² at the linearisation point.
    pub chi2_before: f64,
    /// χ² after the step (equal to `chi2_before` when rejected).
    pub chi2_after: f64,
    /// Whether the step lowered χ² and `values` were updated.
    pub accepted: bool,
    /// Damping used for the accepted (or last tried) step; 0 for Gauss-Newton.
    pub lambda: f64,
    /// ‖δ‖ of the accepted (or last tried) step.
    pub step_norm: f64,
}

/// The outcome of [`Optimizer::optimize`].
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// χ² at the initial values.
    pub initial_chi2: f64,
    /// χ² at the final values.
    pub final_chi2: f64,
    /// Number of linearisations (calls to `step`).
    pub iterations: usize,
    /// `None` when `max_iterations` was reached.
    pub termination: Option<Termination>,
    /// Every step, in order.
    pub steps: Vec<StepReport>,
}

/// Why an optimisation failed.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum OptError {
    /// A factor could not be evaluated at the values.
    #[error(transparent)]
    Factor(#[from] FactorError),
    /// The linear system could not be solved (e.g. an unconstrained variable or gauge freedom).
    #[error(transparent)]
    Solve(#[from] SolveError),
    /// χ² at the initial values is NaN or infinite.
    #[error("the initial χ² is not finite")]
    NonFiniteChi2,
    /// The values hold the best estimate found.
    #[error("no convergence after {} iterations (χ² {} → {})", .0.iterations, .0.initial_chi2, .0.final_chi2)]
    MaxIterations(Summary),
}

/// A nonlinear least-squares optimiser over a [`FactorGraph`].
pub trait Optimizer {
    /// The stopping rules and damping in use.
    fn params(&self) -> &OptimizerParams;

    /// One linearisation and (possibly damped) solve; updates `values` when the step is
    /// accepted and leaves them untouched otherwise.
    fn step(&mut self, graph: &FactorGraph, values: &mut Values) -> Result<StepReport, OptError>;

    /// Forgets per-problem state (damping, cached structure).
    fn reset(&mut self);

    /// Loops [`Optimizer::step`] until convergence. On `Err`, `values` hold the best estimate.
    fn optimize(&mut self, graph: &FactorGraph, values: &mut Values) -> Result<Summary, OptError> {
        self.reset();
        let params = self.params().clone();
        let mut summary = Summary { initial_chi2: f64::NAN, final_chi2: f64::NAN, iterations: 0, termination: None, steps: Vec::new() };
        while summary.iterations < params.max_iterations {
            let report = self.step(graph, values)?;
            if summary.iterations == 0 {
                if !report.chi2_before.is_finite() {
                    return Err(OptError::NonFiniteChi2);
                }
                summary.initial_chi2 = report.chi2_before;
            }
            summary.iterations += 1;
            summary.final_chi2 = report.chi2_after;
            summary.steps.push(report);
            if report.chi2_after <= params.absolute_tolerance {
                summary.termination = Some(Termination::AbsoluteChi2);
                break;
            }
            if !report.accepted {
                summary.termination = Some(Termination::NoDecrease);
                break;
            }
            if report.chi2_before - report.chi2_after <= params.relative_tolerance * report.chi2_before {
                summary.termination = Some(Termination::RelativeDecrease);
                break;
            }
        }
        if summary.termination.is_none() {
            return Err(OptError::MaxIterations(summary));
        }
        Ok(summary)
    }
}

/// Reuses `system` if it still describes `graph` and `values`, else rebuilds it.
fn ensure_system<'a>(
    system: &'a mut Option<LinearSystem>,
    graph: &FactorGraph,
    values: &Values,
    factorisation: Factorisation,
) -> Result<&'a mut LinearSystem, SolveError> {
    let stale = system.as_ref().is_none_or(|s| !s.matches(graph, values));
    if stale {
        *system = Some(LinearSystem::new(graph, values, factorisation)?);
    }
    system.as_mut().ok_or(SolveError::NoFreeVariables)
}

/// Undamped Gauss-Newton.
#[derive(Debug, Default)]
pub struct GaussNewton {
    /// Stopping rules (the damping fields are unused).
    pub params: OptimizerParams,
    system: Option<LinearSystem>,
    delta: Vec<f64>,
    trial: Values,
}

impl GaussNewton {
    /// An optimiser with these parameters.
    pub fn new(params: OptimizerParams) -> Self {
        Self { params, ..Self::default() }
    }
}

impl Optimizer for GaussNewton {
    fn params(&self) -> &OptimizerParams {
        &self.params
    }

    fn reset(&mut self) {}

    fn step(&mut self, graph: &FactorGraph, values: &mut Values) -> Result<StepReport, OptError> {
        let system = ensure_system(&mut self.system, graph, values, self.params.factorisation)?;
        let chi2 = system.linearize(graph, values)?;
        if chi2 <= self.params.absolute_tolerance {
            return Ok(StepReport { chi2_before: chi2, chi2_after: chi2, accepted: false, lambda: 0.0, step_norm: 0.0 });
        }
        system.solve_step(0.0, &mut self.delta)?;
        system.retract_into(values, &self.delta, &mut self.trial);
        let chi2_new = system.cost(graph, &self.trial)?;
        let step_norm = self.delta.iter().map(|v| v * v).sum::<f64>().sqrt();
        let accepted = chi2_new.is_finite() && chi2_new <= chi2;
        if accepted {
            std::mem::swap(values, &mut self.trial);
        }
        Ok(StepReport { chi2_before: chi2, chi2_after: if accepted { chi2_new } else { chi2 }, accepted, lambda: 0.0, step_norm })
    }
}

/// Levenberg-Marquardt with Nielsen's damping update.
///
/// # Examples
///
/// A planar pose pulled by a prior and by odometry from an anchored one; [`Optimizer::optimize`]
/// loops [`Optimizer::step`] until a stopping rule holds. (The [`crate::slam`] module's example
/// reads a pose graph from a g2o file instead.)
///
/// ```
/// use fitslam_core::slam::factors::{BetweenSe2, PriorSe2};
/// use fitslam_core::slam::{FactorGraph, GaussianNoise, Optimizer, OptimizerParams, Se2, Values, Variable};
/// use fitslam_core::LevenbergMarquardt;
///
/// let mut values = Values::new();
/// let x0 = values.push(Variable::Se2(Se2::identity()));
/// let x1 = values.push(Variable::Se2(Se2::new(0.5, 0.3, 0.4))); // a poor initial guess
/// values.set_fixed(x0, true);
///
/// let mut graph = FactorGraph::new();
/// let noise = GaussianNoise::from_sigmas(&[0.1, 0.1, 0.05])?; // m, m, rad
/// graph.add(BetweenSe2::new(x0, x1, Se2::new(2.0, 0.0, 0.0), noise))?;
/// graph.add(PriorSe2::new(x1, Se2::new(2.0, 0.0, 0.0), noise))?;
///
/// let mut lm = LevenbergMarquardt::new(OptimizerParams::default());
/// let summary = lm.optimize(&graph, &mut values)?;
/// assert!(summary.final_chi2 < 1e-12 && summary.final_chi2 < summary.initial_chi2);
/// assert!(summary.termination.is_some()); // converged, not out of iterations
/// let x = values.se2(x1).ok_or("x1 is an SE(2) pose")?;
/// assert!((x.x_m - 2.0).abs() < 1e-6 && x.y_m.abs() < 1e-6 && x.yaw_rad.abs() < 1e-6);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Default)]
pub struct LevenbergMarquardt {
    /// Stopping rules and damping.
    pub params: OptimizerParams,
    system: Option<LinearSystem>,
    lambda: Option<f64>,
    nu: f64,
    delta: Vec<f64>,
    trial: Values,
}

impl LevenbergMarquardt {
    /// An optimiser with these parameters.
    pub fn new(params: OptimizerParams) -> Self {
        Self { params, ..Self::default() }
    }

    /// Current damping (after the last step), if any step was taken.
    pub fn lambda(&self) -> Option<f64> {
        self.lambda
    }
}

impl Optimizer for LevenbergMarquardt {
    fn params(&self) -> &OptimizerParams {
        &self.params
    }

    fn reset(&mut self) {
        self.lambda = None;
        self.nu = 2.0;
    }

    fn step(&mut self, graph: &FactorGraph, values: &mut Values) -> Result<StepReport, OptError> {
        let system = ensure_system(&mut self.system, graph, values, self.params.factorisation)?;
        let chi2 = system.linearize(graph, values)?;
        if chi2 <= self.params.absolute_tolerance {
            return Ok(StepReport { chi2_before: chi2, chi2_after: chi2, accepted: false, lambda: 0.0, step_norm: 0.0 });
        }
        let gtsam = self.params.lambda_schedule == LambdaSchedule::Gtsam;
        let mut lambda = match self.lambda {
            Some(l) => l,
            None if gtsam => self.params.lambda_initial_factor,
            None => {
                let max_diag = system.diagonal().fold(0.0f64, f64::max);
                (self.params.lambda_initial_factor * max_diag).max(1e-12)
            }
        };
        if self.nu < 2.0 {
            self.nu = 2.0;
        }
        let lambda_max = if gtsam { GTSAM_LAMBDA_UPPER } else { self.params.lambda_max };
        let mut step_norm = 0.0;
        while lambda <= lambda_max {
            match system.solve_step(lambda, &mut self.delta) {
                Ok(()) => {}
                Err(SolveError::NotPositiveDefinite) => {
                    lambda = if gtsam { lambda * 10.0 } else { lambda * self.nu };
                    self.nu *= 2.0;
                    continue;
                }
                Err(e) => return Err(e.into()),
            }
            system.retract_into(values, &self.delta, &mut self.trial);
            let chi2_new = system.cost(graph, &self.trial)?;
            // Predicted decrease of the linear model: δᵀ(λδ − g).
            let predicted: f64 = self.delta.iter().zip(system.gradient()).map(|(d, g)| d * (lambda * d - g)).sum();
            step_norm = self.delta.iter().map(|v| v * v).sum::<f64>().sqrt();
            let rho = (chi2 - chi2_new) / predicted;
            let accept = chi2_new.is_finite() && predicted > 0.0 && if gtsam { rho > 1e-3 } else { chi2_new < chi2 };
            if accept {
                std::mem::swap(values, &mut self.trial);
                if gtsam {
                    lambda /= 10.0;
                } else {
                    let factor = 1.0 - (2.0 * rho - 1.0).powi(3);
                    lambda *= factor.max(LAMBDA_MIN_DECREASE);
                }
                self.nu = 2.0;
                self.lambda = Some(lambda.max(1e-300));
                return Ok(StepReport { chi2_before: chi2, chi2_after: chi2_new, accepted: true, lambda, step_norm });
            }
            lambda = if gtsam { lambda * 10.0 } else { lambda * self.nu };
            self.nu *= 2.0;
        }
        self.lambda = Some(lambda);
        Ok(StepReport { chi2_before: chi2, chi2_after: chi2, accepted: false, lambda, step_norm })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::slam::factors::{BetweenSe2, GaussianNoise, PriorSe2, Se2Residual};
    use crate::slam::lie::Se2;
    use crate::slam::values::{VarId, Variable};

    /// One pose, two priors at x = 0 and x = 2 (σ = 1, same y and yaw): the optimum is x = 1
    /// with χ² = 1 + 1 = 2 (hand-derived).
    fn two_priors() -> (FactorGraph, Values) {
        let mut values = Values::new();
        let x = values.push(Variable::Se2(Se2::new(5.0, 0.3, 0.2)));
        let mut graph = FactorGraph::new();
        let n = GaussianNoise::isotropic(3, 1.0).unwrap();
        graph.add(PriorSe2::new(x, Se2::new(0.0, 0.0, 0.0), n).with_residual(Se2Residual::Vector)).unwrap();
        graph.add(PriorSe2::new(x, Se2::new(2.0, 0.0, 0.0), n).with_residual(Se2Residual::Vector)).unwrap();
        (graph, values)
    }

    #[test]
    fn both_methods_find_the_hand_derived_optimum() {
        for method in 0..3 {
            let (graph, mut values) = two_priors();
            let params = OptimizerParams {
                lambda_schedule: if method == 2 { LambdaSchedule::Gtsam } else { LambdaSchedule::Nielsen },
                ..OptimizerParams::default()
            };
            let summary = if method == 0 {
                GaussNewton::new(params).optimize(&graph, &mut values).unwrap()
            } else {
                LevenbergMarquardt::new(params).optimize(&graph, &mut values).unwrap()
            };
            let x = values.se2(VarId(0)).unwrap();
            assert!((x.x_m - 1.0).abs() < 1e-6 && x.y_m.abs() < 1e-6 && x.yaw_rad.abs() < 1e-6, "{x:?}");
            assert!((summary.final_chi2 - 2.0).abs() < 1e-9, "{summary:?}");
        }
    }

    #[test]
    fn consistent_measurements_reach_zero_chi2() {
        let mut values = Values::new();
        let a = values.push(Variable::Se2(Se2::identity()));
        let b = values.push(Variable::Se2(Se2::new(0.5, 0.5, 1.0)));
        values.set_fixed(a, true);
        let mut graph = FactorGraph::new();
        graph.add(BetweenSe2::new(a, b, Se2::new(2.0, -1.0, 0.3), GaussianNoise::isotropic(3, 0.1).unwrap())).unwrap();
        let summary = LevenbergMarquardt::new(OptimizerParams::default()).optimize(&graph, &mut values).unwrap();
        assert_eq!(summary.termination, Some(Termination::AbsoluteChi2));
        let x = values.se2(b).unwrap();
        assert!((x.x_m - 2.0).abs() < 1e-6 && (x.y_m + 1.0).abs() < 1e-6 && (x.yaw_rad - 0.3).abs() < 1e-6);
    }

    #[test]
    fn max_iterations_returns_the_best_estimate() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/data/slam/MIT.g2o");
        let file = crate::slam::g2o::read_g2o(&std::fs::read(path).unwrap()).unwrap();
        let mut p = file.to_problem(crate::slam::Gauge::FixFirst, Se2Residual::Log).unwrap();
        let params = OptimizerParams { max_iterations: 3, ..OptimizerParams::default() };
        match LevenbergMarquardt::new(params).optimize(&p.graph, &mut p.values) {
            Err(OptError::MaxIterations(s)) => {
                assert_eq!(s.iterations, 3);
                assert!(s.final_chi2 < s.initial_chi2);
                // The values left behind are the reported best estimate.
                let chi2 = p.graph.chi2(&p.values).unwrap();
                assert!((chi2 - s.final_chi2).abs() <= 1e-9 * chi2);
            }
            other => panic!("expected MaxIterations, got {other:?}"),
        }
    }

    #[test]
    fn gauss_newton_without_gauge_reports_singular_system() {
        let mut values = Values::new();
        let a = values.push(Variable::Se2(Se2::identity()));
        let b = values.push(Variable::Se2(Se2::new(1.0, 0.0, 0.0)));
        let mut graph = FactorGraph::new();
        graph.add(BetweenSe2::new(a, b, Se2::new(1.0, 0.0, 0.1), GaussianNoise::isotropic(3, 1.0).unwrap())).unwrap();
        let r = GaussNewton::new(OptimizerParams::default()).optimize(&graph, &mut values);
        assert_eq!(r, Err(OptError::Solve(SolveError::NotPositiveDefinite)));
    }
}
