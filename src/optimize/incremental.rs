//! `fitslam optimize --incremental`: the g2o file replayed as an online run through the core's
//! iSAM2 ([`fitslam_core::slam::G2oReplay`]: vertex order, one update per step), with the
//! newest pose's estimate and marginal covariance read after every update, as a SLAM front end
//! would. `total_ms` covers the whole replay (updates, estimates, marginals), not reading;
//! `max_update_ms` is the slowest step's update alone. `final_chi2` is Σ eᵀΩe of every factor
//! (the first-pose prior included: 2 × GTSAM's graph error) at the final estimate.

use std::time::Instant;

use anyhow::{Context, Result, bail};
use fitslam_core::slam::g2o::read_g2o;
use fitslam_core::slam::{G2oReplay, Isam2, Isam2Params, RobustKernel, Se2Residual};

use super::OptimizeArgs;

/// First-pose prior when `--prior-sigma` is not given: variance 1e-6 per tangent component.
const DEFAULT_PRIOR_SIGMA: f64 = 1e-3;

pub fn run(args: &OptimizeArgs, residual: Se2Residual) -> Result<()> {
    let path = args.g2o.display();
    if args.out.is_some() {
        bail!("--incremental does not write --out");
    }
    let bytes = std::fs::read(&args.g2o).with_context(|| format!("reading {path}"))?;
    let file = read_g2o(&bytes).with_context(|| format!("{path} (--incremental reads g2o)"))?;
    let params = Isam2Params {
        relinearize_threshold: args.relinearize_threshold,
        relinearize_skip: args.relinearize_skip,
        wildfire_threshold: args.wildfire_threshold,
        ..Isam2Params::default()
    };
    let mut replay = G2oReplay::new(&file, residual, args.prior_sigma.unwrap_or(DEFAULT_PRIOR_SIGMA)).with_context(|| format!("{path}"))?;
    if let Some(k) = args.landmark_cauchy_k {
        if !(k.is_finite() && k > 0.0) {
            bail!("--landmark-cauchy-k must be positive and finite (got {k})");
        }
        replay = replay.with_landmark_kernel(RobustKernel::Cauchy { k });
    }
    let steps = replay.len();
    let mut isam = Isam2::new(params);
    let mut max_update_ms = 0.0f64;
    let mut last_marginal = Vec::new();
    let start = Instant::now();
    loop {
        let t = Instant::now();
        let Some(newest) = replay.step(&mut isam).with_context(|| format!("{path}: update"))? else { break };
        max_update_ms = max_update_ms.max(t.elapsed().as_secs_f64() * 1e3);
        if isam.estimate_of(newest).is_none() {
            bail!("{path}: no estimate of the newest vertex");
        }
        if !args.no_marginal {
            let cov = isam.marginal_covariance(newest).with_context(|| format!("{path}: marginal of the newest vertex"))?;
            last_marginal = (0..cov.nrows()).flat_map(|r| (0..cov.ncols()).map(move |c| (r, c))).map(|(r, c)| cov[(r, c)]).collect();
        }
    }
    let total_ms = start.elapsed().as_secs_f64() * 1e3;
    let final_chi2 = isam.chi2().with_context(|| format!("{path}: χ²"))?;
    if args.json {
        let v = serde_json::json!({
            "final_chi2": final_chi2,
            "total_ms": total_ms,
            "max_update_ms": max_update_ms,
            "steps": steps,
            "last_marginal": last_marginal,
        });
        outln!("{v}")?;
    } else {
        outln!("file          {path}")?;
        outln!("steps         {steps}  (one iSAM2 update each)")?;
        outln!("chi2          {final_chi2:.9}")?;
        outln!("time          {total_ms:.3} ms  (slowest update {max_update_ms:.3} ms)")?;
        if !last_marginal.is_empty() {
            let d = (last_marginal.len() as f64).sqrt() as usize;
            outln!("newest pose marginal ({d}x{d}, tangent (dt, dphi), body frame):")?;
            for r in 0..d {
                let row: Vec<String> = (0..d).map(|c| format!("{:>13.6e}", last_marginal[r * d + c])).collect();
                outln!("  {}", row.join(" "))?;
            }
        }
    }
    Ok(())
}
