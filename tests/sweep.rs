//! `fitslam plan` / `run` / `collect` end to end: a plan run in two halves (the first with
//! `--indices`, the second as Ray tasks on a local cluster of a head and two worker nodes through
//! `scripts/ray-compare`), one run killed mid-way and retried, collects to the same bytes as
//! `compare --jobs 2` on the same options; bad input (another code version, a missing world file,
//! a corrupt output folder, an edited plan) exits 1 with one line and leaves nothing half-written.
//!
//! The Ray half needs the pinned Python environment of `scripts/sweep-venv` (target/sweep-venv or
//! `FITSLAM_SWEEP_VENV`) and `unshare` (root) for a private network namespace; without either the
//! test FAILS and says so.

#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failure should stop it

mod common;
use common::assert_clear_error;

use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_fitslam");

fn asset(name: &str) -> String {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets/worlds").join(name).display().to_string()
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fitslam-sweep-{}-{name}", std::process::id()));
    std::fs::remove_dir_all(&d).ok();
    d
}

fn fitslam(args: &[&str]) -> Output {
    Command::new(BIN).args(args).output().expect("run fitslam")
}

fn ok(o: &Output) {
    assert!(o.status.success(), "stderr: {}", String::from_utf8_lossy(&o.stderr));
}

/// The report's files, which must be byte-identical between two folders.
const REPORT: [&str; 10] = [
    "summary.csv",
    "summary.md",
    "unexplored.svg",
    "unexplored.png",
    "cov_trace.svg",
    "cov_trace.png",
    "coverage_distance.svg",
    "coverage_distance.png",
    "cov_coverage.svg",
    "cov_coverage.png",
];

fn same_report(a: &Path, b: &Path) {
    for f in REPORT {
        assert!(std::fs::read(a.join(f)).unwrap() == std::fs::read(b.join(f)).unwrap(), "{f} differs between {a:?} and {b:?}");
    }
}

#[test]
fn a_plan_run_in_halves_with_a_killed_run_collects_to_compares_bytes() {
    let world = asset("paper_unstructured_20m.toml");
    let options = ["--world", &world, "--time-limit-s", "60", "--strategies", "fit,random", "--seeds", "2"];
    let (cmp, plan) = (scratch("compare"), scratch("plan"));
    let with_out = |cmd: &str, out: &Path, extra: &[&str]| {
        let mut a = vec![cmd];
        a.extend_from_slice(&options);
        a.extend_from_slice(&["--out", out.to_str().unwrap()]);
        a.extend_from_slice(extra);
        fitslam(&a)
    };
    ok(&with_out("compare", &cmp, &["--jobs", "2"]));
    ok(&with_out("plan", &plan, &[]));
    let dir = plan.to_str().unwrap();
    let lines = std::fs::read_to_string(plan.join("plan.jsonl")).unwrap().lines().count();
    assert_eq!(lines, 4);
    // Nothing to collect yet: says which entry is missing.
    assert_clear_error(&fitslam(&["collect", dir]), "the first: 0");
    ok(&fitslam(&["run", dir, "--indices", "0..1"]));
    // Entry 2, killed while its mission runs: only its .partial folder is left.
    let mut child = Command::new(BIN).args(["run", dir, "--index", "2"]).spawn().unwrap();
    let t0 = Instant::now();
    let started = loop {
        let partial = std::fs::read_dir(plan.join(".partial")).map(|d| d.count() > 0).unwrap_or(false);
        if partial || t0.elapsed() > Duration::from_secs(60) {
            break partial;
        }
        std::thread::sleep(Duration::from_millis(2));
    };
    std::thread::sleep(Duration::from_millis(50));
    child.kill().unwrap();
    let status = child.wait().unwrap();
    assert!(started && !status.success(), "the run was killed mid-way");
    assert!(!plan.join("fit").join("seed_3").exists() && !plan.join("random").join("seed_1").exists(), "no half-written output");
    assert!(std::fs::read_dir(plan.join(".partial")).unwrap().count() > 0);
    // Retried with the rest, as Ray tasks on two worker nodes; it collects at the end.
    let pending = fitslam(&["run", dir, "--pending"]);
    ok(&pending);
    assert_eq!(String::from_utf8_lossy(&pending.stdout), "2\n3\n");
    ray_compare_on_a_local_cluster(&plan);
    same_report(&cmp, &plan);
    // A second pass over everything runs nothing.
    let again = fitslam(&["run", dir]);
    ok(&again);
    assert!(String::from_utf8_lossy(&again.stdout).contains("0 run"), "{}", String::from_utf8_lossy(&again.stdout));
    ok(&fitslam(&["collect", dir]));
    same_report(&cmp, &plan);
    // `compare` over a folder whose runs are done keeps them and writes the same report.
    ok(&with_out("compare", &plan, &["--jobs", "1"]));
    same_report(&cmp, &plan);
    std::fs::remove_dir_all(&cmp).ok();
    std::fs::remove_dir_all(&plan).ok();
}

/// `scripts/ray-compare PLAN --address …` on a Ray cluster of a head and two worker nodes on
/// 127.0.0.1, inside a private network and PID namespace (tests/sweep/ray_cluster.sh).
fn ray_compare_on_a_local_cluster(plan: &Path) {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let venv = std::env::var_os("FITSLAM_SWEEP_VENV").map_or_else(|| root.join("target/sweep-venv"), PathBuf::from);
    assert!(
        venv.join("bin/ray").exists(),
        "no Ray environment at {venv:?}: run scripts/sweep-venv (the README's test command does) or set FITSLAM_SWEEP_VENV"
    );
    let out = Command::new("unshare")
        .args(["-n", "-p", "-f", "--mount-proc", "bash"])
        .arg(root.join("tests/sweep/ray_cluster.sh"))
        .args([venv.as_os_str(), plan.as_os_str(), BIN.as_ref()])
        .output()
        .expect("unshare (this test needs `unshare -n -p`, i.e. root)");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "ray-compare on a local cluster failed:\n{stderr}");
    assert!(stderr.contains("ray cluster: 3 nodes") && stderr.contains("2/2 entries (0 failed)"), "{stderr}");
    assert!(String::from_utf8_lossy(&out.stdout).contains("4 runs; summary.md"), "{}", String::from_utf8_lossy(&out.stdout));
}

/// Rewrites line `k` of `plan.jsonl` with `edit` applied, and its hash made right again (as the
/// plan computes it: SHA-256 of the JSON with the hash empty, keys sorted).
fn edit_entry(plan: &Path, k: usize, edit: impl Fn(&mut serde_json::Value)) {
    let path = plan.join("plan.jsonl");
    let text = std::fs::read_to_string(&path).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let mut v: serde_json::Value = serde_json::from_str(&lines[k]).unwrap();
    edit(&mut v);
    v["hash"] = "".into();
    let digest: String = Sha256::digest(serde_json::to_vec(&v).unwrap()).iter().map(|b| format!("{b:02x}")).collect();
    v["hash"] = digest.into();
    lines[k] = serde_json::to_string(&v).unwrap();
    std::fs::write(&path, lines.join("\n") + "\n").unwrap();
}

#[test]
fn bad_plans_and_folders_give_one_line_and_leave_nothing_half_written() {
    let root = scratch("bad");
    std::fs::create_dir_all(&root).unwrap();
    let world = root.join("tiny.toml");
    std::fs::copy(asset("tiny_test.toml"), &world).unwrap();
    let plan = root.join("plan");
    let dir = plan.to_str().unwrap();
    let w = world.to_str().unwrap();
    ok(&fitslam(&["plan", "--world", w, "--time-limit-s", "20", "--strategies", "fit", "--seeds", "3", "--out", dir]));

    // Another code version.
    edit_entry(&plan, 0, |v| v["code"] = "fitslam 0.0.0 0123456789ab".into());
    assert_clear_error(&fitslam(&["run", dir, "--index", "0"]), "planned by fitslam 0.0.0 0123456789ab");
    assert_clear_error(&fitslam(&["run", dir, "--pending"]), "planned by fitslam 0.0.0 0123456789ab");
    assert!(!plan.join("fit/seed_1").exists());
    // An edited entry whose hash no longer matches.
    let path = plan.join("plan.jsonl");
    let text = std::fs::read_to_string(&path).unwrap();
    std::fs::write(&path, text.replacen("\"seed\":2", "\"seed\":7", 1)).unwrap();
    assert_clear_error(&fitslam(&["run", dir, "--index", "1"]), "line 2: its hash does not match");
    std::fs::write(&path, text).unwrap();
    // Out of range.
    assert_clear_error(&fitslam(&["run", dir, "--indices", "1..3"]), "--indices");
    // A corrupt output folder (no entry.json): refused, left as it is.
    std::fs::create_dir_all(plan.join("fit/seed_3")).unwrap();
    std::fs::write(plan.join("fit/seed_3/metrics.csv"), "garbage").unwrap();
    assert_clear_error(&fitslam(&["run", dir, "--index", "2"]), "without its entry.json");
    assert_clear_error(&fitslam(&["collect", dir]), "without its entry.json");
    std::fs::remove_dir_all(plan.join("fit/seed_3")).unwrap();
    // The world file changed, then gone.
    std::fs::write(&world, std::fs::read_to_string(&world).unwrap() + "\n# changed\n").unwrap();
    assert_clear_error(&fitslam(&["run", dir, "--index", "1"]), "changed since the plan was made");
    std::fs::remove_file(&world).unwrap();
    assert_clear_error(&fitslam(&["run", dir, "--index", "1"]), "cannot read");
    assert!(!plan.join("fit/seed_2").exists() && !plan.join(".partial").exists(), "nothing half-written");
    // A folder holding another plan.
    std::fs::copy(asset("tiny_test.toml"), &world).unwrap();
    assert_clear_error(
        &fitslam(&["plan", "--world", w, "--time-limit-s", "20", "--strategies", "greedy", "--seeds", "3", "--out", dir]),
        "holds another plan",
    );
    // `compare` replaces the plan it finds (and runs the new one), but refuses a run folder of
    // another plan.
    let compare = |strategy: &str| {
        fitslam(&["compare", "--world", w, "--time-limit-s", "20", "--strategies", strategy, "--seeds", "1", "--jobs", "1", "--out", dir])
    };
    ok(&compare("greedy"));
    assert!(std::fs::read_to_string(plan.join("plan.jsonl")).unwrap().contains("\"strategy\":\"greedy\""));
    std::fs::create_dir_all(plan.join("fit/seed_1")).unwrap();
    std::fs::write(plan.join("fit/seed_1/entry.json"), std::fs::read(plan.join("greedy/seed_1/entry.json")).unwrap()).unwrap();
    assert_clear_error(&compare("fit"), "made by another plan entry");
    std::fs::remove_dir_all(&root).ok();
}
