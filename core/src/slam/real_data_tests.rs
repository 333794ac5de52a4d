//! The optimiser on real pose graphs (assets/data/slam, see assets/data/SOURCES.md). The g2o
//! graphs run in every `cargo test` (well under a second each); Victoria Park is `#[ignore]`d
//! and runs in release: `cargo test -p fitslam-core --release slam::real_data -- --ignored
//! --nocapture`. Agreement with GTSAM is checked by `scripts/compare_gtsam.py`.

use super::factors::Se2Residual;
use super::g2o::read_g2o;
use super::optimizer::{GaussNewton, LambdaSchedule, LevenbergMarquardt, Optimizer, OptimizerParams, Summary, Termination};
use super::problem::{Gauge, Problem};
use super::victoria::read_victoria;

fn data(name: &str) -> Vec<u8> {
    let path = format!("{}/../assets/data/slam/{name}", env!("CARGO_MANIFEST_DIR"));
    std::fs::read(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

fn load_g2o(name: &str) -> Problem {
    read_g2o(&data(name)).unwrap().to_problem(Gauge::FixFirst, Se2Residual::Log).unwrap()
}

/// χ² decreases at every step and the loop ends on a converged criterion.
fn check_converged(name: &str, summary: &Summary) {
    eprintln!(
        "{name}: χ² {:.6} → {:.9}, {} iterations, {:?}",
        summary.initial_chi2, summary.final_chi2, summary.iterations, summary.termination
    );
    assert!(summary.final_chi2 < summary.initial_chi2, "{name}: χ² did not decrease");
    for s in &summary.steps {
        assert!(s.chi2_after <= s.chi2_before, "{name}: a step increased χ²");
    }
    assert!(matches!(summary.termination, Some(Termination::RelativeDecrease) | Some(Termination::NoDecrease)));
}

fn run_lm(name: &str) -> (Problem, Summary) {
    let mut p = load_g2o(name);
    let mut lm = LevenbergMarquardt::new(OptimizerParams { max_iterations: 1000, ..OptimizerParams::default() });
    let summary = lm.optimize(&p.graph, &mut p.values).unwrap_or_else(|e| panic!("{name}: {e}"));
    check_converged(name, &summary);
    (p, summary)
}

#[test]
fn intel_lm_reaches_a_stable_minimum() {
    let (mut p, summary) = run_lm("intel.g2o");
    // Stable: more iterations from the optimum do not lower χ² further (beyond rounding).
    let mut gn = GaussNewton::new(OptimizerParams::default());
    let again = gn.optimize(&p.graph, &mut p.values).unwrap();
    assert!((again.final_chi2 - summary.final_chi2).abs() <= 1e-9 * summary.final_chi2);
}

#[test]
fn mit_lm() {
    run_lm("MIT.g2o");
}

#[test]
fn small_grid_3d_lm() {
    run_lm("smallGrid3D.g2o");
}

#[test]
fn csail_lm() {
    run_lm("CSAIL.g2o");
}

#[test]
fn parking_garage_lm() {
    run_lm("parking-garage.g2o");
}

#[test]
fn mit_gtsam_schedule_reaches_gtsams_minimum_path() {
    // MIT from odometry is non-convex: both schedules converge, to different local minima.
    let mut p = load_g2o("MIT.g2o");
    let params = OptimizerParams { max_iterations: 1000, lambda_schedule: LambdaSchedule::Gtsam, ..OptimizerParams::default() };
    let summary = LevenbergMarquardt::new(params).optimize(&p.graph, &mut p.values).unwrap();
    check_converged("MIT.g2o (GTSAM schedule)", &summary);
}

#[test]
#[ignore = "6,969 poses, 151 landmarks, ~200 iterations: run in release"]
fn victoria_park_lm() {
    let p = read_victoria(&data("victoria_park.txt")).unwrap().to_problem(Gauge::FixFirst, Se2Residual::Log).unwrap();
    let mut optimum = p.values.clone();
    for schedule in [LambdaSchedule::Gtsam, LambdaSchedule::Nielsen] {
        let mut values = p.values.clone();
        let params = OptimizerParams { max_iterations: 1000, lambda_schedule: schedule, ..OptimizerParams::default() };
        let summary = LevenbergMarquardt::new(params).optimize(&p.graph, &mut values).unwrap();
        check_converged(&format!("victoria_park.txt ({schedule:?})"), &summary);
        if schedule == LambdaSchedule::Gtsam {
            optimum = values;
        }
    }
    // Stable: restarting from the GTSAM-schedule optimum lowers χ² by less than 1e-7 relative.
    let before = p.graph.chi2(&optimum).unwrap();
    let polish = LevenbergMarquardt::new(OptimizerParams::default()).optimize(&p.graph, &mut optimum).unwrap();
    eprintln!("victoria_park.txt polish: χ² {before:.9} → {:.9} in {} iterations", polish.final_chi2, polish.iterations);
    assert!(before - polish.final_chi2 < 1e-7 * before);
}
