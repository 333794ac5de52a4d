//! `fitslam explore` end to end on the tiny world: every output file is written, the summary has
//! the documented keys and no ground-truth violation, and the same seed gives a byte-identical
//! metrics.csv.

#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failure should stop it

use std::path::PathBuf;
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_fitslam");

fn world() -> String {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets/worlds/tiny_test.toml").display().to_string()
}

fn explore(name: &str, strategy: &str, seed: &str) -> PathBuf {
    let out = std::env::temp_dir().join(format!("fitslam-explore-{}-{name}", std::process::id()));
    let o = Command::new(BIN)
        .args(["explore", "--world", &world(), "--strategy", strategy, "--seed", seed, "--time-limit-s", "120", "--out"])
        .arg(&out)
        .output()
        .expect("run fitslam");
    assert!(o.status.success(), "stderr: {}", String::from_utf8_lossy(&o.stderr));
    out
}

#[test]
fn explore_writes_everything_and_is_reproducible() {
    let a = explore("a", "fit", "3");
    for f in [
        "metrics.csv",
        "timing.csv",
        "trajectory_est.tum",
        "trajectory_gt.tum",
        "summary.json",
        "map.yaml",
        "map.pgm",
        "map_gt.yaml",
        "map_gt.pgm",
        "unexplored.svg",
        "unexplored.png",
        "cov_trace.svg",
        "cov_trace.png",
    ] {
        assert!(a.join(f).is_file(), "missing {f}");
    }
    let metrics = std::fs::read_to_string(a.join("metrics.csv")).unwrap();
    assert!(metrics.starts_with("time_s,unexplored_pct,cov_trace,pos_cov_trace,rot_cov_trace,ate_m,distance_m,loop_closures\n"));
    assert!(!metrics.contains("plan_ms"));
    let summary: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(a.join("summary.json")).unwrap()).unwrap();
    for key in ["gt_violations", "unexplored_pct", "time_s", "distance_m", "end_reason", "strategy", "ate_rmse_m"] {
        assert!(summary.get(key).is_some(), "summary lacks {key}");
    }
    assert_eq!(summary["gt_violations"], 0);
    let tum = std::fs::read_to_string(a.join("trajectory_gt.tum")).unwrap();
    assert!(tum.lines().all(|l| l.split(' ').count() == 8));
    let b = explore("b", "fit", "3");
    assert_eq!(metrics.as_bytes(), std::fs::read(b.join("metrics.csv")).unwrap().as_slice());
    let r = explore("r", "random", "4");
    assert!(r.join("metrics.csv").is_file());
    for d in [a, b, r] {
        let _ = std::fs::remove_dir_all(d);
    }
}

/// `--slam-g2o` writes the mission's factor graph in replay order: `optimize --incremental`
/// replays it as one update per keyframe (the summary's count). Without SLAM there is no graph:
/// one clear error before the mission runs.
#[test]
fn the_slam_graph_replays_as_one_update_per_keyframe() {
    let out = std::env::temp_dir().join(format!("fitslam-explore-{}-g2o", std::process::id()));
    let g2o = out.join("slam.g2o");
    let o = Command::new(BIN)
        .args(["explore", "--world", &world(), "--seed", "2", "--time-limit-s", "60", "--out"])
        .arg(&out)
        .arg("--slam-g2o")
        .arg(&g2o)
        .output()
        .expect("run fitslam");
    assert!(o.status.success(), "stderr: {}", String::from_utf8_lossy(&o.stderr));
    let summary: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    let keyframes = summary["keyframes"].as_u64().expect("summary.keyframes");
    assert!(keyframes > 5, "a 60 s mission takes keyframes: {keyframes}");
    let r = Command::new(BIN)
        .args(["optimize", "--incremental", "--json", "--landmark-cauchy-k", "4", "--g2o"])
        .arg(&g2o)
        .output()
        .expect("run fitslam");
    assert!(r.status.success(), "stderr: {}", String::from_utf8_lossy(&r.stderr));
    let j: serde_json::Value = serde_json::from_slice(&r.stdout).unwrap();
    assert_eq!(j["steps"].as_u64(), Some(keyframes));
    assert!(j["final_chi2"].as_f64().unwrap().is_finite());

    let gt = Command::new(BIN)
        .args(["explore", "--world", &world(), "--localisation", "ground-truth", "--time-limit-s", "10", "--out"])
        .arg(out.join("gt"))
        .arg("--slam-g2o")
        .arg(out.join("gt.g2o"))
        .output()
        .expect("run fitslam");
    let stderr = String::from_utf8_lossy(&gt.stderr);
    assert!(!gt.status.success() && stderr.contains("--slam-g2o needs --localisation slam"), "stderr: {stderr}");
    assert!(!out.join("gt").join("metrics.csv").exists(), "the mission should not run");
}

/// `[family] keep_start`: every member starts at the file's start (a world built around it);
/// without it a member starts where `World::draw_start` puts it.
#[test]
fn a_family_that_keeps_its_start_starts_every_member_there() {
    let dir = std::env::temp_dir().join(format!("fitslam-explore-{}-keep-start", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let tiny = std::fs::read_to_string(world()).unwrap();
    let first_pose = |text: &str, name: &str| {
        let file = dir.join(format!("{name}.toml"));
        std::fs::write(&file, text).unwrap();
        let out = dir.join(name);
        let o = Command::new(BIN)
            .args(["explore", "--world"])
            .arg(&file)
            .args(["--world-seed", "3", "--time-limit-s", "2", "--out"])
            .arg(&out)
            .output()
            .unwrap();
        assert!(o.status.success(), "stderr: {}", String::from_utf8_lossy(&o.stderr));
        let tum = std::fs::read_to_string(out.join("trajectory_gt.tum")).unwrap();
        let xy: Vec<f64> = tum.lines().next().unwrap().split_whitespace().skip(1).take(2).map(|v| v.parse().unwrap()).collect();
        xy
    };
    let kept = first_pose(&tiny.replace("[terrain]", "[family]\nkeep_start = true\n\n[terrain]"), "kept");
    assert!((kept[0] - 1.0).abs() < 1e-3 && (kept[1] - 1.0).abs() < 1e-3, "{kept:?}");
    let drawn = first_pose(&tiny, "drawn");
    assert!((drawn[0] - 1.0).abs() + (drawn[1] - 1.0).abs() > 1e-3, "{drawn:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}
