//! `fitslam optimize`: optimise a real pose graph with the core's SLAM backend and report χ²,
//! iterations, time and the marginal covariance of the last pose.
//!
//! Input: a g2o file (2D or 3D poses, optionally with point landmarks: see
//! [`fitslam_core::slam::g2o`]) or the
//! Victoria Park text format (`ODOMETRY`/`LANDMARK`, read with GTSAM's `load2D` semantics),
//! told apart by the first tag. Gauge: the first pose is fixed unless the file's `FIX` lines fix
//! some vertex (g2o), or anchored by a prior (`--prior-sigma`, GTSAM). `time_ms` covers the optimisation only (not reading, not the
//! marginal). `last_marginal` is the covariance of the pose with the largest id, row-major, in
//! our tangent order ξ = (δt, δφ), body frame.

mod incremental;

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use fitslam_core::slam::g2o::read_g2o;
use fitslam_core::slam::victoria::read_victoria;
use fitslam_core::slam::{
    Gauge, GaussNewton, LambdaSchedule, LevenbergMarquardt, Marginals, OptError, Optimizer, OptimizerParams, Problem, Se2Residual,
};

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Levenberg-Marquardt (Nielsen damping).
    Lm,
    /// Gauss-Newton (a step that raises χ² ends the run).
    Gn,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Schedule {
    /// Nielsen's damping update (g2o-like).
    Nielsen,
    /// GTSAM's default (λ₀ = 1e-5, ×10 / ÷10): follows GTSAM's path on non-convex problems.
    Gtsam,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Residual2d {
    /// Log(z⁻¹ x_i⁻¹ x_j) on SE(2) (GTSAM 4.3).
    Log,
    /// (x, y, θ) of z⁻¹ x_i⁻¹ x_j (g2o's EdgeSE2).
    Vector,
}

#[derive(clap::Args, Debug)]
pub struct OptimizeArgs {
    /// Graph to optimise: g2o 2D/3D (poses, optional point landmarks), or Victoria Park
    /// (ODOMETRY/LANDMARK) text.
    #[arg(long)]
    pub g2o: PathBuf,
    /// Write the optimised graph here as g2o (g2o inputs only).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print one JSON object: initial_chi2, final_chi2, iterations, time_ms, last_marginal.
    #[arg(long)]
    pub json: bool,
    /// Optimisation method
    #[arg(long, value_enum, default_value_t = Method::Lm)]
    pub method: Method,
    /// Most iterations (linearisations) before the run stops
    #[arg(long, default_value_t = 100)]
    pub max_iterations: usize,
    /// Stop when the relative χ² decrease of a step falls below this.
    #[arg(long, default_value_t = 1e-10)]
    pub relative_tolerance: f64,
    /// Anchor the first pose with a prior of this standard deviation on every tangent component
    /// (GTSAM's convention) instead of fixing it (g2o's).
    #[arg(long)]
    pub prior_sigma: Option<f64>,
    /// LM damping schedule. GTSAM's by default: on the real graphs of docs/benchmarks.md it reaches
    /// the same or a lower χ² than Nielsen's, in as many or fewer iterations.
    #[arg(long, value_enum, default_value_t = Schedule::Gtsam)]
    pub lambda_schedule: Schedule,
    /// Residual of 2D between factors.
    #[arg(long, value_enum, default_value_t = Residual2d::Log)]
    pub se2_residual: Residual2d,
    /// Skip the marginal covariance (last_marginal is then empty).
    #[arg(long)]
    pub no_marginal: bool,
    /// Replay the g2o file through iSAM2, one update per vertex (JSON: final_chi2, total_ms,
    /// max_update_ms, steps, last_marginal); the first pose is anchored by a prior
    /// (`--prior-sigma`, 1e-3 by default).
    #[arg(long)]
    pub incremental: bool,
    /// iSAM2: relinearise a variable when its step's max-abs reaches this (m, rad).
    #[arg(long, default_value_t = 0.1)]
    pub relinearize_threshold: f64,
    /// iSAM2: check relinearisation every this many updates.
    #[arg(long, default_value_t = 10)]
    pub relinearize_skip: usize,
    /// iSAM2: stop back-substitution below cliques whose step moved by at most this.
    #[arg(long, default_value_t = 0.001)]
    pub wildfire_threshold: f64,
    /// iSAM2: a Cauchy kernel of this scale (on the whitened residual's norm) on every landmark
    /// edge, as the simulator's SLAM has (4) on the graph `explore --slam-g2o` writes.
    #[arg(long)]
    pub landmark_cauchy_k: Option<f64>,
}

enum Input {
    G2o(fitslam_core::slam::g2o::G2oFile),
    Victoria,
}

pub fn run(args: &OptimizeArgs) -> Result<()> {
    let bytes = std::fs::read(&args.g2o).with_context(|| format!("reading {}", args.g2o.display()))?;
    let gauge = match args.prior_sigma {
        Some(sigma) => Gauge::PriorOnFirst { sigma },
        None => Gauge::FixFirst,
    };
    let residual = match args.se2_residual {
        Residual2d::Log => Se2Residual::Log,
        Residual2d::Vector => Se2Residual::Vector,
    };
    if args.incremental {
        return incremental::run(args, residual);
    }
    if args.landmark_cauchy_k.is_some() {
        anyhow::bail!("--landmark-cauchy-k needs --incremental");
    }
    let first_tag = fitslam_core::io::without_bom(&bytes)
        .split(|b| b.is_ascii_whitespace())
        .find(|t| !t.is_empty())
        .map(|t| String::from_utf8_lossy(t).into_owned())
        .unwrap_or_default();
    let (input, mut problem): (Input, Problem) = if first_tag == "ODOMETRY" || first_tag == "LANDMARK" {
        let vp = read_victoria(&bytes).with_context(|| format!("{}", args.g2o.display()))?;
        let p = vp.to_problem(gauge, residual).with_context(|| format!("{}", args.g2o.display()))?;
        (Input::Victoria, p)
    } else {
        let file = read_g2o(&bytes).with_context(|| format!("{}", args.g2o.display()))?;
        if !file.skipped.is_empty() {
            let tags: Vec<String> =
                file.skipped.iter().map(|s| format!("{} × {} (first on line {})", s.tag, s.lines, s.first_line)).collect();
            eprintln!("warning: {}: skipped lines with tags it does not read: {}", args.g2o.display(), tags.join(", "));
        }
        let p = file.to_problem(gauge, residual).with_context(|| format!("{}", args.g2o.display()))?;
        (Input::G2o(file), p)
    };
    let Some(last) = problem.last_pose() else { bail!("{} has no pose", args.g2o.display()) };
    if args.out.is_some() && matches!(input, Input::Victoria) {
        bail!("--out writes g2o and needs a g2o input");
    }

    let params = OptimizerParams {
        max_iterations: args.max_iterations,
        relative_tolerance: args.relative_tolerance,
        lambda_schedule: match args.lambda_schedule {
            Schedule::Nielsen => LambdaSchedule::Nielsen,
            Schedule::Gtsam => LambdaSchedule::Gtsam,
        },
        ..OptimizerParams::default()
    };
    let factorisation = params.factorisation;
    let start = Instant::now();
    let result = match args.method {
        Method::Lm => LevenbergMarquardt::new(params).optimize(&problem.graph, &mut problem.values),
        Method::Gn => GaussNewton::new(params).optimize(&problem.graph, &mut problem.values),
    };
    let time_ms = start.elapsed().as_secs_f64() * 1e3;
    let summary = match result {
        Ok(s) => s,
        Err(OptError::MaxIterations(s)) => {
            eprintln!("warning: {}: no convergence after {} iterations; reporting the best estimate", args.g2o.display(), s.iterations);
            s
        }
        Err(e) => return Err(e).with_context(|| format!("{}: optimisation failed", args.g2o.display())),
    };

    let marginal: Vec<f64> = if args.no_marginal {
        Vec::new()
    } else {
        // A graph whose gauge is not fixed everywhere (two disconnected parts, one anchored)
        // still optimises under LM's damping, but has no marginal: say what was reached.
        let reached = || {
            format!(
                "{}: marginal covariance of the last pose, after optimising χ² {} -> {} in {} iterations (--no-marginal skips it)",
                args.g2o.display(),
                summary.initial_chi2,
                summary.final_chi2,
                summary.iterations
            )
        };
        let m = Marginals::new(&problem.graph, &problem.values, factorisation).with_context(reached)?;
        let cov = m.covariance(last).with_context(reached)?;
        // Row-major.
        (0..cov.nrows()).flat_map(|r| (0..cov.ncols()).map(move |c| (r, c))).map(|(r, c)| cov[(r, c)]).collect()
    };

    if let Some(out) = &args.out {
        match &input {
            Input::G2o(file) => {
                let text = fitslam_core::slam::g2o::write_g2o(&file.with_poses(&problem, &problem.values));
                std::fs::write(out, text).with_context(|| format!("writing {}", out.display()))?;
            }
            Input::Victoria => {}
        }
    }

    if args.json {
        let v = serde_json::json!({
            "initial_chi2": summary.initial_chi2,
            "final_chi2": summary.final_chi2,
            "iterations": summary.iterations,
            "time_ms": time_ms,
            "last_marginal": marginal,
        });
        outln!("{v}")?;
    } else {
        outln!("file          {}", args.g2o.display())?;
        outln!("poses         {}  landmarks {}  factors {}", problem.poses.len(), problem.landmarks.len(), problem.graph.len())?;
        outln!("chi2          {:.9} -> {:.9}", summary.initial_chi2, summary.final_chi2)?;
        outln!("iterations    {}  ({:?})", summary.iterations, summary.termination)?;
        outln!("time          {time_ms:.3} ms")?;
        if !marginal.is_empty() {
            let d = (marginal.len() as f64).sqrt() as usize;
            outln!("last pose marginal ({d}x{d}, tangent (dt, dphi), body frame):")?;
            for r in 0..d {
                let row: Vec<String> = (0..d).map(|c| format!("{:>13.6e}", marginal[r * d + c])).collect();
                outln!("  {}", row.join(" "))?;
            }
        }
    }
    Ok(())
}
