//! `scripts/tune` end to end on a tiny world: its unit tests (objectives, Pareto front and
//! parameter file with hand-derived values), then a study of two trials resumed by a second
//! process for one more through the same journal file: the paper's α = 0.35, β = 0.4, N = 7 is
//! trial 0 and only trial 0, a parameter added with `--search` is searched too, the report names
//! the paper's trial, and every Pareto parameter file is one that `fitslam params --params`
//! accepts with the trial's values in it.
//!
//! Needs the pinned Python environment of `scripts/sweep-venv` (target/sweep-venv or
//! `FITSLAM_SWEEP_VENV`); without it the test FAILS and says so.

#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failure should stop it

use std::path::PathBuf;
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_fitslam");

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn venv() -> PathBuf {
    let venv = std::env::var_os("FITSLAM_SWEEP_VENV").map_or_else(|| root().join("target/sweep-venv"), PathBuf::from);
    assert!(
        venv.join("bin/python").exists(),
        "no Optuna environment at {venv:?}: run scripts/sweep-venv (the README's test command does) or set FITSLAM_SWEEP_VENV"
    );
    venv
}

fn ok(o: &Output) -> String {
    assert!(o.status.success(), "stdout: {}\nstderr: {}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Runs the Python unit tests of `module` (in scripts/sweep/) and checks that all `count` ran.
fn python_unit_tests(module: &str, count: usize) {
    let out = Command::new(venv().join("bin/python"))
        .args(["-m", "unittest", "-v", module])
        .current_dir(root().join("scripts/sweep"))
        .output()
        .unwrap();
    ok(&out);
    let ran = format!("Ran {count} tests");
    assert!(String::from_utf8_lossy(&out.stderr).contains(&ran), "{}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn tune_unit_tests() {
    python_unit_tests("test_tune", 9);
}

#[test]
fn sensitivity_unit_tests() {
    python_unit_tests("test_sensitivity", 4);
}

/// `scripts/sensitivity` on the tiny world: one point per value, the default's flagged, the figure
/// written; a rerun keeps the missions already run.
#[test]
fn sensitivity_writes_a_point_per_value_and_its_figure() {
    let out = std::env::temp_dir().join(format!("fitslam-sensitivity-{}", std::process::id()));
    std::fs::remove_dir_all(&out).ok();
    let world = root().join("assets/worlds/tiny_test.toml");
    let run = || {
        Command::new(root().join("scripts/sensitivity"))
            .args(["--out", out.to_str().unwrap(), "--world", world.to_str().unwrap(), "--seeds", "2", "--jobs", "2"])
            .args(["--vary", "u2.beta=1,0.4", "--fitslam", BIN])
            .env("FITSLAM_SWEEP_VENV", venv())
            .output()
            .unwrap()
    };
    ok(&run());
    let csv = std::fs::read_to_string(out.join("sensitivity.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv.lines().skip(1).map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 2, "{csv}");
    assert_eq!((rows[0][0], rows[0][1], rows[0][2]), ("u2.beta", "0.4", "true"), "{csv}");
    assert_eq!((rows[1][1], rows[1][2]), ("1", "false"), "{csv}");
    assert!(rows.iter().all(|r| r[4].parse::<f64>().unwrap() > 0.0 && r[6].parse::<f64>().unwrap() > 0.0), "{csv}");
    assert!(out.join("sensitivity.png").exists() && out.join("sensitivity.svg").exists());
    assert!(out.join("runs/default/missions/summary.csv").exists() && out.join("runs/u2.beta=1.0/missions/summary.csv").exists());
    ok(&run());
    assert_eq!(std::fs::read_to_string(out.join("sensitivity.csv")).unwrap(), csv, "a rerun gives the same points");
    std::fs::remove_dir_all(&out).unwrap();
}

#[test]
fn a_study_resumed_through_its_journal_reports_its_pareto_front() {
    let study = std::env::temp_dir().join(format!("fitslam-tune-{}", std::process::id()));
    std::fs::remove_dir_all(&study).ok();
    let world = root().join("assets/worlds/tiny_test.toml");
    let tune = |trials: &str| {
        Command::new(root().join("scripts/tune"))
            .args(["--study", study.to_str().unwrap(), "--world", world.to_str().unwrap(), "--seeds", "2", "--jobs", "2"])
            .args(["--trials", trials, "--fitslam", BIN, "--search", "u2.sigma_bearing_rad=0.005..0.05"])
            .env("FITSLAM_SWEEP_VENV", venv())
            .output()
            .unwrap()
    };
    ok(&tune("2"));
    ok(&tune("1"));
    let csv = std::fs::read_to_string(study.join("pareto.csv")).unwrap();
    let rows: Vec<&str> = csv.lines().collect();
    assert_eq!(rows[0], "trial,alpha,beta,top_n,u2.sigma_bearing_rad,t90_s,matched_cov_trace,unreached,feasible,pareto,paper");
    assert_eq!(rows.len(), 4, "{csv}");
    assert!(rows[1].starts_with("0,0.35,0.4,7,") && rows[1].ends_with(",true"), "{csv}");
    // A bad --search is refused before anything is made.
    let bad = Command::new(root().join("scripts/tune"))
        .args(["--study", study.join("bad").to_str().unwrap(), "--world", world.to_str().unwrap(), "--fitslam", BIN])
        .args(["--search", "u2.no_such_key=0..1"])
        .env("FITSLAM_SWEEP_VENV", venv())
        .output()
        .unwrap();
    assert!(!bad.status.success() && String::from_utf8_lossy(&bad.stderr).contains("u2.no_such_key is not a numeric planner parameter"));
    assert!(!study.join("bad").exists());
    assert!(rows[2..].iter().all(|r| r.ends_with(",false")), "the paper's values are trial 0 only: {csv}");
    let md = std::fs::read_to_string(study.join("pareto.md")).unwrap();
    assert!(md.contains("the paper's"), "{md}");
    for f in ["pareto.png", "pareto.svg", "journal.log"] {
        assert!(study.join(f).metadata().unwrap().len() > 0, "{f}");
    }
    // Each Pareto point's file: whole, valid, with its trial's values.
    let on_front: Vec<&str> = rows[1..].iter().filter(|r| r.split(',').nth(9) == Some("true")).copied().collect();
    assert!(!on_front.is_empty());
    for row in on_front {
        let cols: Vec<&str> = row.split(',').collect();
        let file = study.join("pareto").join(format!("trial_{:04}.toml", cols[0].parse::<u32>().unwrap()));
        let printed = ok(&Command::new(BIN).args(["params", "--params", file.to_str().unwrap()]).output().unwrap());
        let alpha: f64 = cols[1].parse().unwrap();
        let value = |key: &str| -> f64 {
            printed.lines().find_map(|l| l.strip_prefix(&format!("{key} = "))).unwrap().trim_matches('"').parse().unwrap()
        };
        assert!((value("alpha") - alpha).abs() <= 1e-5 * alpha.max(1.0), "{file:?}: alpha");
        assert_eq!(value("top_n"), cols[3].parse::<f64>().unwrap(), "{file:?}: top_n");
        let sigma: f64 = cols[4].parse().unwrap();
        assert!((0.005..=0.05).contains(&sigma) && (value("sigma_bearing_rad") - sigma).abs() <= 1e-5 * sigma, "{file:?}: sigma");
    }
    std::fs::remove_dir_all(&study).ok();
}
