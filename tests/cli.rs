//! The `fitslam` command line, end to end: the documented JSON keys on the built-in asset, and one
//! clear line with a non-zero exit (never a panic) on every kind of bad input.

#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failure should stop it

mod common;
use common::assert_clear_error;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_fitslam");

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn asset(rel: &str) -> String {
    root().join("assets").join(rel).display().to_string()
}

fn run(args: &[&str]) -> Output {
    Command::new(BIN).args(args).output().expect("run fitslam")
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("fitslam-cli-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn select_json(extra: &[&str]) -> serde_json::Value {
    let map = asset("maps/jacksboro/map.yaml");
    let lm = asset("maps/jacksboro/landmarks.ply");
    let mut args = vec!["select", "--map", &map, "--landmarks", &lm, "--pose", "3,3,0", "--json"];
    args.extend_from_slice(extra);
    let out = run(&args);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).expect("valid JSON")
}

#[test]
fn select_json_has_the_documented_keys_and_a_consistent_ranking() {
    let v = select_json(&[]);
    assert_eq!(v["strategy"], "fit");
    let cands = v["candidates"].as_array().unwrap();
    assert!(cands.len() >= 3, "the asset has several frontiers");
    let chosen = v["chosen"].as_u64().unwrap() as usize;
    for c in cands {
        for key in ["x", "y", "theta_star", "rho_m", "delta_e", "u1", "path_info", "u2", "rank", "path", "dropped"] {
            assert!(c.get(key).is_some(), "missing key {key} in {c}");
        }
    }
    let best = &cands[chosen];
    assert_eq!(best["rank"], 1);
    let best_u2 = best["u2"].as_f64().unwrap();
    for c in cands.iter().filter(|c| !c["u2"].is_null()) {
        assert!(c["u2"].as_f64().unwrap() <= best_u2 + 1e-12);
    }
    // The path runs from the robot's cell to the goal cell.
    let path = best["path"].as_array().unwrap();
    let first = &path[0];
    assert!((first[0].as_f64().unwrap() - 3.0).abs() < 0.05 && (first[1].as_f64().unwrap() - 3.0).abs() < 0.05);
    let last = path.last().unwrap();
    assert!((last[0].as_f64().unwrap() - best["x"].as_f64().unwrap()).abs() < 1e-9);
}

#[test]
fn greedy_picks_the_shortest_path_and_random_is_reproducible() {
    let v = select_json(&["--strategy", "greedy"]);
    let cands = v["candidates"].as_array().unwrap();
    let chosen = v["chosen"].as_u64().unwrap() as usize;
    let rho = |c: &serde_json::Value| c["rho_m"].as_f64().unwrap_or(f64::INFINITY);
    let min = cands.iter().map(rho).fold(f64::INFINITY, f64::min);
    assert_eq!(rho(&cands[chosen]), min);
    let a = select_json(&["--strategy", "random"]);
    let b = select_json(&["--strategy", "random"]);
    assert_eq!(a["chosen"], b["chosen"]);
}

#[test]
fn table_output_names_the_goal() {
    let map = asset("maps/jacksboro/map.yaml");
    let lm = asset("maps/jacksboro/landmarks.csv");
    let out = run(&["select", "--map", &map, "--landmarks", &lm, "--pose", "3,3,0"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("chosen") && text.contains("goal: ("), "{text}");
}

#[test]
fn bad_inputs_print_one_clear_line_and_exit_non_zero() {
    let dir = scratch("bad");
    let write = |name: &str, bytes: &[u8]| -> String {
        let p = dir.join(name);
        std::fs::write(&p, bytes).unwrap();
        p.display().to_string()
    };
    let good_map = asset("maps/jacksboro/map.yaml");
    let good_lm = asset("maps/jacksboro/landmarks.ply");
    let select = |map: &str, lm: &str, pose: &str| run(&["select", "--map", map, "--landmarks", lm, "--pose", pose]);

    // Truncated PGM.
    let pgm = std::fs::read(Path::new(&asset("maps/jacksboro/map.pgm"))).unwrap();
    write("trunc.pgm", &pgm[..pgm.len() / 2]);
    let yaml = write(
        "trunc.yaml",
        b"image: trunc.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n",
    );
    assert_clear_error(&select(&yaml, &good_lm, "3,3,0"), "trunc.pgm");

    // YAML without `image`.
    let yaml = write("noimage.yaml", b"resolution: 0.05\norigin: [0, 0, 0]\n");
    assert_clear_error(&select(&yaml, &good_lm, "3,3,0"), "image");

    // PCD with a wrong point count.
    let pcd = write(
        "wrong.pcd",
        b"VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 3\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 3\nDATA ascii\n1 2 3\n4 5 6\n",
    );
    assert_clear_error(&select(&good_map, &pcd, "3,3,0"), "wrong.pcd");

    // PLY with a missing vertex property.
    let ply = write("noz.ply", b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nend_header\n1 2\n3 4\n");
    assert_clear_error(&select(&good_map, &ply, "3,3,0"), "'z'");

    // NaN coordinates.
    let csv = write("nan.csv", b"x,y,z\n1,2,3\nnan,2,3\n");
    assert_clear_error(&select(&good_map, &csv, "3,3,0"), "nan.csv");

    // A pose outside the map, and a pose that is not a pose.
    assert_clear_error(&select(&good_map, &good_lm, "-50,3,0"), "outside the map");
    assert_clear_error(&select(&good_map, &good_lm, "3,nan,0"), "--pose");
    assert_clear_error(&select(&good_map, &good_lm, "3,3"), "--pose");
    // A boundary the map does not reach (it ranked 0 candidates with exit 0).
    let out = run(&["select", "--map", &good_map, "--landmarks", &good_lm, "--pose", "3,3,0", "--boundary", "100,100,200,200"]);
    assert_clear_error(&out, "--boundary \"100,100,200,200\" does not overlap the map");

    // Missing files, unknown extensions, bad parameter files.
    assert_clear_error(&select("/nonexistent/map.yaml", &good_lm, "3,3,0"), "cannot read");
    let txt = write("cloud.txt", b"1 2 3\n");
    assert_clear_error(&select(&good_map, &txt, "3,3,0"), "cloud.txt");
    let params = write("bad.toml", b"[u1]\nalpah = 0.3\n");
    let out = run(&["select", "--map", &good_map, "--landmarks", &good_lm, "--pose", "3,3,0", "--params", &params]);
    assert_clear_error(&out, "alpah");
    // Values with no useful bound on their work (1e-9 rad between rays asked for 6e9 rays and
    // aborted; a 1e-9 m waypoint spacing hung), and a waypoint spacing under this map's cells.
    for (name, text, needle) in [
        ("rays.toml", &b"[u1]\ndelta_theta_rad = 1e-9\n"[..], "rays.toml: u1.delta_theta_rad must be"),
        ("waypoints.toml", b"[u2]\nwaypoint_spacing_m = 1e-9\n", "waypoints.toml: u2.waypoint_spacing_m"),
        ("radius.toml", b"[robot]\nradius_m = 1e6\n", "radius.toml: robot.radius_m"),
    ] {
        let params = write(name, text);
        let out = run(&["select", "--map", &good_map, "--landmarks", &good_lm, "--pose", "3,3,0", "--params", &params]);
        assert_clear_error(&out, needle);
    }

    // Traversability with a malformed cloud.
    let out = run(&["traversability", "--cloud", &ply, "--out", &dir.join("t.yaml").display().to_string()]);
    assert_clear_error(&out, "noz.ply");
    // A patch and one point 288 m away asked for 33 M cells (7.4 GB); identical points make a
    // map with no known cell, and say so.
    let mut far = String::from("x,y,z\n");
    for k in 0..400 {
        far.push_str(&format!("{},{},0\n", 0.05 * f64::from(k % 20), 0.05 * f64::from(k / 20)));
    }
    far.push_str("288,288,0\n");
    let far = write("far.csv", far.as_bytes());
    let out = run(&["traversability", "--cloud", &far, "--out", &dir.join("far.yaml").display().to_string()]);
    assert_clear_error(&out, "far.csv: a 5779 × 5779 grid exceeds the limit of 8388608 cells");
    let one = write("one.csv", b"x,y,z\n1,1,0\n1,1,0\n1,1,0\n");
    let out = run(&["traversability", "--cloud", &one, "--out", &dir.join("one.yaml").display().to_string()]);
    assert!(out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.lines().count() == 1 && stderr.contains("warning: ") && stderr.contains("one.csv: no cell is known"), "{stderr}");
    // A spread ratio no disc of points can reach.
    let params = write("spread.toml", b"[traversability]\nmin_spread_ratio = 5\n");
    assert_clear_error(
        &run(&["params", "--params", &params]),
        "spread.toml: traversability.min_spread_ratio must be ≤ 1/√2 ≈ 0.707 (got 5)",
    );
    // build-asset: every option checked up front (--size-m 10000 aborted allocating 320 GB,
    // --lidar-range-m 1e9 hung, --lidar-range-m 0 made an empty scene).
    let dem = asset("data/terrain/jacksboro_fault_dem.png");
    let asset_out = dir.join("asset").display().to_string();
    for (flag, value, needle) in [
        ("--size-m", "10000", "--size-m 10000: must be in (0, 500] m"),
        ("--size-m", "nan", "--size-m NaN"),
        ("--lidar-range-m", "1e9", "--lidar-range-m 1e9: must be in (0, 100] m"),
        ("--lidar-range-m", "0", "--lidar-range-m 0"),
        ("--crop-fraction", "0", "--crop-fraction 0"),
        ("--dem-pixel-m", "0,93", "--dem-pixel-m \"0,93\": both pixel sizes must be > 0 m"),
        ("--viewpoints", "3;4", "--viewpoints \"3\""),
        ("--viewpoints", "100,100", "--viewpoints: the start 100,100 is outside the 20 m world"),
    ] {
        assert_clear_error(&run(&["build-asset", "--dem", &dem, flag, value, "--out", &asset_out]), needle);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn traversability_writes_a_map_server_map_that_select_can_read() {
    let dir = scratch("trav");
    let out_yaml = dir.join("plane.yaml");
    let out = run(&["traversability", "--cloud", &asset("data/lidar/plane.ply"), "--out", &out_yaml.display().to_string()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    for f in ["plane.yaml", "plane.pgm", "plane_score.png"] {
        assert!(dir.join(f).exists(), "{f} not written");
    }
    let yaml = std::fs::read_to_string(&out_yaml).unwrap();
    assert!(yaml.contains("image: plane.pgm") && yaml.contains("resolution: 0.05"), "{yaml}");
    assert!(out.stderr.is_empty(), "a dense scan gives no warning: {}", String::from_utf8_lossy(&out.stderr));

    // A cloud sampled every 0.5 m (airborne-like) at the rover's defaults: the map is still
    // written, with one warning that names the file and parameters that give the discs points.
    let sparse = dir.join("sparse.csv");
    let text: String =
        (0..30).flat_map(|i| (0..30).map(move |j| format!("{},{},{}\n", 0.5 * i as f64, 0.5 * j as f64, 0.02 * i as f64))).collect();
    std::fs::write(&sparse, text).unwrap();
    let out = run(&["traversability", "--cloud", sparse.to_str().unwrap(), "--out", &dir.join("sparse.yaml").display().to_string()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(stderr.starts_with("warning: ") && stderr.contains("sparse.csv"), "{stderr}");
    let number_after = |key: &str| -> f64 {
        let rest = &stderr[stderr.find(key).unwrap_or_else(|| panic!("{key:?} in {stderr}")) + key.len()..];
        rest.split_whitespace().next().unwrap().trim_end_matches('.').parse().unwrap()
    };
    // Spacing 0.5 m (ρ = 4 points/m²), within the estimator's edge effects on a 30 × 30 patch;
    // 4 × min_points = 20 points in the disc at r = √(20 / 4π) = 1.26 m, cells r / 2.
    assert!((number_after("about ") - 0.5).abs() < 0.05, "{stderr}");
    let radius_m = number_after("disc_radius_m = ");
    assert!((radius_m - 1.26).abs() < 0.13, "{stderr}");
    assert!((number_after("resolution_m = ") - radius_m / 2.0).abs() <= 0.006, "{stderr}");

    // Points every 9 cm: about 8.7 in a 0.15 m disc, more than min_points (5): no warning.
    let fair = dir.join("fair.csv");
    let text: String = (0..34).flat_map(|i| (0..34).map(move |j| format!("{},{},0\n", 0.09 * i as f64, 0.09 * j as f64))).collect();
    std::fs::write(&fair, text).unwrap();
    let out = run(&["traversability", "--cloud", fair.to_str().unwrap(), "--out", &dir.join("fair.yaml").display().to_string()]);
    assert!(out.status.success() && out.stderr.is_empty(), "{}", String::from_utf8_lossy(&out.stderr));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn optimize_reports_the_documented_keys_and_writes_landmark_graphs() {
    let out = run(&["optimize", "--g2o", &asset("data/slam/intel.g2o"), "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("valid JSON");
    let (initial, last) = (v["initial_chi2"].as_f64().unwrap(), v["final_chi2"].as_f64().unwrap());
    assert!(last < initial, "{v}");
    assert!(v["iterations"].as_u64().unwrap() > 0 && v["time_ms"].as_f64().unwrap() >= 0.0);
    assert_eq!(v["last_marginal"].as_array().unwrap().len(), 9, "SE(2): 3 × 3");

    // A 2D landmark graph (two poses, one landmark seen from both, consistent): χ² reaches 0 and
    // the optimised landmark is written back.
    let dir = scratch("optimize");
    let input = dir.join("landmarks.g2o");
    std::fs::write(
        &input,
        "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 2 0 1.5707963267948966\nVERTEX_XY 5 2.5 2.5\n\
         EDGE_SE2 0 1 2 0 1.5707963267948966 100 0 0 100 0 100\nEDGE_SE2_XY 0 5 2 3 4 0 25\nEDGE_SE2_XY 1 5 3 0 9 1 16\n",
    )
    .unwrap();
    let output = dir.join("out.g2o");
    let out = run(&["optimize", "--g2o", input.to_str().unwrap(), "--out", output.to_str().unwrap(), "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("valid JSON");
    assert!((v["initial_chi2"].as_f64().unwrap() - 14.0).abs() < 1e-9, "{v}");
    assert!(v["final_chi2"].as_f64().unwrap() < 1e-12, "{v}");
    let written = std::fs::read_to_string(&output).unwrap();
    let xy: Vec<f64> =
        written.lines().find(|l| l.starts_with("VERTEX_XY 5 ")).unwrap().split_whitespace().skip(2).map(|t| t.parse().unwrap()).collect();
    assert!((xy[0] - 2.0).abs() < 1e-6 && (xy[1] - 3.0).abs() < 1e-6, "{written}");

    // An edge onto the wrong kind of vertex: one line naming the file and the problem.
    std::fs::write(&input, "VERTEX_SE2 0 0 0 0\nVERTEX_XY 1 2 3\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n").unwrap();
    assert_clear_error(
        &run(&["optimize", "--g2o", input.to_str().unwrap()]),
        "landmarks.g2o: edge 0 (0-based): vertex 1 is a 2D point, the edge needs a SE2 pose",
    );

    // Two disconnected parts, one anchored: the optimisation runs, the marginal cannot exist;
    // the one line says what was reached and how to skip the marginal.
    std::fs::write(&input, "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_SE2 2 5 0 0\nVERTEX_SE2 3 6 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\nEDGE_SE2 2 3 1 0.1 0 1 0 0 1 0 1\n").unwrap();
    assert_clear_error(&run(&["optimize", "--g2o", input.to_str().unwrap()]), "after optimising χ² 0.01");
    let out = run(&["optimize", "--g2o", input.to_str().unwrap(), "--no-marginal", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));

    // A singular information matrix: the reason once, after the line.
    std::fs::write(&input, "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 0 0 0 0 0 0\n").unwrap();
    let out = run(&["optimize", "--g2o", input.to_str().unwrap()]);
    assert_clear_error(&out, "landmarks.g2o: line 3: information matrix: noise matrix is not positive definite (pivot 0)");
    assert_eq!(String::from_utf8_lossy(&out.stderr).matches("not positive definite").count(), 1);

    // A measurement too large to evaluate: the file and the failure on one line.
    std::fs::write(&input, "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1e308 0 0 1 0 0 1 0 1\n").unwrap();
    assert_clear_error(
        &run(&["optimize", "--g2o", input.to_str().unwrap()]),
        "landmarks.g2o: optimisation failed: the initial χ² is not finite",
    );
}

/// By default `optimize` damps as GTSAM does and so reaches GTSAM's minimum on MIT from the
/// composed odometry (770.238983900, scripts/compare_gtsam.py, docs/benchmarks.md), where Nielsen's
/// schedule is still at χ² ≈ 1.2e5 after 100 iterations.
#[test]
fn optimize_reaches_gtsams_minimum_on_mit_by_default() {
    let out = run(&["optimize", "--g2o", &asset("data/slam/MIT.g2o"), "--json"]);
    assert!(out.status.success() && out.stderr.is_empty(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let chi2 = v["final_chi2"].as_f64().unwrap();
    assert!((chi2 / 770.2389839 - 1.0).abs() < 1e-6, "{v}");
    let nielsen = run(&["optimize", "--g2o", &asset("data/slam/MIT.g2o"), "--lambda-schedule", "nielsen", "--json"]);
    assert!(String::from_utf8_lossy(&nielsen.stderr).contains("no convergence after 100 iterations"));
}

/// Lines with tags the reader does not know are skipped, as g2o and GTSAM skip them, and named in
/// one warning; a file saved with a byte-order mark reads as without.
#[test]
fn optimize_skips_unknown_tags_with_a_warning_and_reads_past_a_byte_order_mark() {
    let dir = scratch("optimize-tags");
    let graph = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1.2 0 0 1 0 0 1 0 1\n";
    let plain = dir.join("plain.g2o");
    std::fs::write(&plain, graph).unwrap();
    let extra = dir.join("extra.g2o");
    std::fs::write(
        &extra,
        format!(
            "\u{feff}TUTORIAL_PARAMS_SE2_OFFSET 0 0 0 0\n{graph}EDGE_SE2_PRIOR 1 0 0 0 1 0 0 1 0 1\nEDGE_SE2_PRIOR 0 0 0 0 1 0 0 1 0 1\n"
        ),
    )
    .unwrap();
    let (a, b) =
        (run(&["optimize", "--g2o", plain.to_str().unwrap(), "--json"]), run(&["optimize", "--g2o", extra.to_str().unwrap(), "--json"]));
    assert!(a.status.success() && b.status.success(), "{}", String::from_utf8_lossy(&b.stderr));
    let chi2 = |o: &Output| {
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        (v["initial_chi2"].as_f64().unwrap(), v["final_chi2"].as_f64().unwrap())
    };
    assert_eq!(chi2(&a), chi2(&b));
    assert!((chi2(&a).0 - 0.04).abs() < 1e-12, "{:?}", chi2(&a));
    assert!(a.stderr.is_empty(), "{}", String::from_utf8_lossy(&a.stderr));
    let warning = String::from_utf8_lossy(&b.stderr);
    assert_eq!(warning.lines().count(), 1, "{warning}");
    assert!(
        warning.contains("extra.g2o: skipped lines with tags it does not read: TUTORIAL_PARAMS_SE2_OFFSET × 1 (first on line 1), EDGE_SE2_PRIOR × 2 (first on line 5)"),
        "{warning}"
    );
}

/// A reader that stops early closes the pipe: the tool ends quietly instead of panicking.
#[test]
fn a_closed_stdout_ends_the_tool_quietly() {
    use std::io::Read as _;
    let (map, lm) = (asset("maps/jacksboro/map.yaml"), asset("maps/jacksboro/landmarks.ply"));
    let mut child = Command::new(BIN)
        .args(["select", "--map", &map, "--landmarks", &lm, "--pose", "3,3,0", "--json"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut first = [0u8; 16];
    child.stdout.take().unwrap().read_exact(&mut first).unwrap();
    // stdout is closed here: the JSON (≈ 90 kB) is more than a pipe holds, so a write fails.
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(out.status.success(), "{:?}: {stderr}", out.status);
}

/// `fitslam --help` describes every subcommand with its own line (a doc comment attached to the
/// wrong variant once described `traversability` under `params` and left it blank).
#[test]
fn help_describes_each_subcommand() {
    let out = run(&["--help"]);
    assert!(out.status.success());
    let help = String::from_utf8_lossy(&out.stdout);
    let line = |cmd: &str| {
        help.lines().find(|l| l.split_whitespace().next() == Some(cmd)).unwrap_or_else(|| panic!("{cmd} missing: {help}")).to_owned()
    };
    for (cmd, words) in [
        ("params", "default parameters"),
        ("select", "next goal"),
        ("traversability", "traversability map"),
        ("build-asset", "DEM"),
        ("optimize", "pose graph"),
        ("explore", "mission"),
        ("compare", "strategy"),
    ] {
        let l = line(cmd);
        assert!(l.contains(words), "{cmd}: {l:?}");
    }
    assert!(!line("params").contains("cloud"), "params describes another command: {help}");
}

/// A world whose start the robot does not fit: one line naming the file, the start and the
/// robot radius, before any mission runs.
#[test]
fn explore_refuses_a_start_the_robot_does_not_fit() {
    let tiny = std::fs::read_to_string(asset("worlds/tiny_test.toml")).unwrap();
    let dir = scratch("start");
    let world = dir.join("tight.toml");
    std::fs::write(&world, tiny.replace("start = [1.0, 1.0, 0.0]", "start = [2.3, 2.6, 0.0]")).unwrap();
    let out_dir = dir.join("out");
    let out = run(&["explore", "--world", world.to_str().unwrap(), "--localisation", "ground-truth", "--out", out_dir.to_str().unwrap()]);
    assert_clear_error(&out, "tight.toml: start (2.30, 2.60): untraversable ground");
    assert!(String::from_utf8_lossy(&out.stderr).contains("robot radius 0.25 m"));
    assert!(!out_dir.join("metrics.csv").exists());
}

/// `optimize --incremental` replays the graph through iSAM2 (one update per vertex) and reports
/// the documented keys; its χ² is the full graph's at the replay's final estimate, no lower than
/// the batch optimum of the same problem (the first pose held by the same 1e-3 prior) and close
/// to it; the newest pose's marginal is a symmetric 6×6 with a positive diagonal.
#[test]
fn optimize_incremental_replays_a_3d_graph() {
    let out = run(&["optimize", "--incremental", "--g2o", &asset("data/slam/smallGrid3D.g2o"), "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for key in ["final_chi2", "total_ms", "max_update_ms", "steps", "last_marginal"] {
        assert!(!v[key].is_null(), "{key} missing: {v}");
    }
    assert_eq!(v["steps"], 125, "one update per vertex: {v}");
    let batch = run(&["optimize", "--prior-sigma", "1e-3", "--g2o", &asset("data/slam/smallGrid3D.g2o"), "--json"]);
    let b: serde_json::Value = serde_json::from_slice(&batch.stdout).unwrap();
    let (incr, opt) = (v["final_chi2"].as_f64().unwrap(), b["final_chi2"].as_f64().unwrap());
    assert!(incr >= opt * (1.0 - 1e-9) && incr <= opt * 1.01, "iSAM2 χ² {incr} vs batch {opt}");
    let m: Vec<f64> = v["last_marginal"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
    assert_eq!(m.len(), 36);
    for i in 0..6 {
        assert!(m[i * 6 + i] > 0.0);
        for j in 0..6 {
            assert!((m[i * 6 + j] - m[j * 6 + i]).abs() <= 1e-9 * m[i * 6 + i].abs().max(1e-12), "not symmetric at {i},{j}");
        }
    }
}
