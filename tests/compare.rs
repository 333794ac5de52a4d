//! `fitslam compare` end to end on the tiny world with a short time limit: the per-run and
//! aggregate outputs exist, summary.md has one row per strategy, summary.csv is byte-identical
//! with 1 and 2 threads, and bad input exits 1 with one line.

#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failure should stop it

mod common;
use common::assert_clear_error;

use std::path::PathBuf;
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_fitslam");

fn world() -> String {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets/worlds/tiny_test.toml").display().to_string()
}

fn scratch(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("fitslam-compare-{}-{name}", std::process::id()))
}

fn compare(out: &PathBuf, extra: &[&str]) -> Output {
    let world = world();
    let mut args = vec!["compare", "--world", &world, "--time-limit-s", "30"];
    args.extend_from_slice(extra);
    Command::new(BIN).args(&args).arg("--out").arg(out).output().expect("run fitslam")
}

#[test]
fn compare_writes_everything_and_does_not_depend_on_the_thread_count() {
    let a = scratch("j1");
    let b = scratch("j2");
    let o = compare(&a, &["--strategies", "fit,random", "--seeds", "2", "--jobs", "1"]);
    assert!(o.status.success(), "stderr: {}", String::from_utf8_lossy(&o.stderr));
    let figures = ["unexplored", "cov_trace", "coverage_distance", "cov_coverage"];
    for f in ["summary.csv".to_string(), "summary.md".to_string()]
        .into_iter()
        .chain(figures.iter().flat_map(|f| [format!("{f}.png"), format!("{f}.svg")]))
    {
        assert!(a.join(&f).is_file(), "missing {f}");
    }
    for s in ["fit", "random"] {
        for seed in [1, 2] {
            let run = a.join(s).join(format!("seed_{seed}"));
            for f in ["metrics.csv", "summary.json", "trajectory_est.tum", "trajectory_gt.tum", "map.yaml", "unexplored.png"] {
                assert!(run.join(f).is_file(), "missing {s}/seed_{seed}/{f}");
            }
        }
    }
    let csv = std::fs::read_to_string(a.join("summary.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 1 + 4, "{csv}");
    assert!(lines[0].starts_with("strategy,seed,end_reason,matched_cov_trace,time_s,t90_s,unexplored_pct,"), "{}", lines[0]);
    assert!(lines[0].contains(",t50_s,d50_m,t75_s,d75_m,t90_s,d90_m,t99_s,d99_m,"), "{}", lines[0]);
    let keys: Vec<String> = lines[1..].iter().map(|l| l.split(',').take(2).collect::<Vec<_>>().join(",")).collect();
    assert_eq!(keys, ["fit,1", "fit,2", "random,1", "random,2"]);
    // The per-run summary.json agrees with its summary.csv row.
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(a.join("random/seed_2/summary.json")).unwrap()).unwrap();
    let column = |name: &str| lines[0].split(',').position(|h| h == name).unwrap_or_else(|| panic!("no {name} column: {}", lines[0]));
    let time_s: f64 = lines[4].split(',').nth(column("time_s")).unwrap().parse().unwrap();
    assert!((json["time_s"].as_f64().unwrap() - time_s).abs() < 1e-6 * time_s.max(1.0));
    for name in ["gt_violations", "safety_stops"] {
        let value: f64 = lines[4].split(',').nth(column(name)).unwrap().parse().unwrap();
        assert_eq!(value, json[name].as_f64().unwrap(), "{name}");
    }

    let md = std::fs::read_to_string(a.join("summary.md")).unwrap();
    assert_eq!(md.lines().filter(|l| l.starts_with("| fit |")).count(), 2, "per-strategy row + milestones: {md}");
    assert_eq!(md.lines().filter(|l| l.starts_with("| random |")).count(), 3, "per-strategy row + milestones + paired test: {md}");
    assert!(md.contains("Wilcoxon signed-rank") && md.contains("Holm") && md.contains("## Coverage milestones"), "{md}");
    assert!(md.contains("p = "));
    let svg = std::fs::read_to_string(a.join("unexplored.svg")).unwrap();
    assert!(svg.contains("fit (n = 2)") && svg.contains("random (n = 2)") && svg.contains("time (s)"));
    let svg = std::fs::read_to_string(a.join("cov_coverage.svg")).unwrap();
    assert!(svg.contains("fit (n = 2)") && svg.contains("coverage first reached"));
    let svg = std::fs::read_to_string(a.join("coverage_distance.svg")).unwrap();
    assert!(svg.contains("random (n = 2)") && svg.contains("distance driven (m)"));

    let o = compare(&b, &["--strategies", "fit,random", "--seeds", "2", "--jobs", "2"]);
    assert!(o.status.success(), "stderr: {}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(csv.as_bytes(), std::fs::read(b.join("summary.csv")).unwrap().as_slice(), "jobs 1 vs 2");
    assert_eq!(std::fs::read(a.join("fit/seed_2/metrics.csv")).unwrap(), std::fs::read(b.join("fit/seed_2/metrics.csv")).unwrap());
    for d in [a, b] {
        let _ = std::fs::remove_dir_all(d);
    }
}

/// `--world-seeds`: every run in each member of the world's family, paired by world and seed;
/// still independent of the thread count, and each run is `explore --world-seed`'s.
#[test]
fn compare_across_world_seeds_pairs_by_world_and_seed() {
    let (a, b) = (scratch("w1"), scratch("w2"));
    let args = ["--strategies", "fit,random", "--seeds", "1", "--world-seeds", "3..4"];
    let o = compare(&a, &[&args[..], &["--jobs", "1"]].concat());
    assert!(o.status.success(), "stderr: {}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(a.join("summary.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert!(lines[0].starts_with("strategy,world_seed,seed,end_reason,"), "{}", lines[0]);
    let keys: Vec<String> = lines[1..].iter().map(|l| l.split(',').take(3).collect::<Vec<_>>().join(",")).collect();
    assert_eq!(keys, ["fit,3,1", "fit,4,1", "random,3,1", "random,4,1"]);
    let metrics = |dir: &PathBuf, w: u64, s: &str| std::fs::read(dir.join(format!("world_{w}/{s}/seed_1/metrics.csv"))).unwrap();
    assert_ne!(metrics(&a, 3, "fit"), metrics(&a, 4, "fit"), "two world seeds, two worlds");
    let md = std::fs::read_to_string(a.join("summary.md")).unwrap();
    assert!(md.contains("2 world seeds (3–4,") && md.contains("paired by world seed and seed"), "{md}");
    assert!(md.lines().any(|l| l.starts_with("| random |") && l.contains("(n = 2)")), "two pairs: {md}");

    let o = compare(&b, &[&args[..], &["--jobs", "2"]].concat());
    assert!(o.status.success(), "stderr: {}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(csv.as_bytes(), std::fs::read(b.join("summary.csv")).unwrap().as_slice(), "jobs 1 vs 2");

    // A world file naming its family (`world_seeds`) runs it without the flag (`--worlds` is
    // `--world`'s other spelling): the same runs.
    let family = scratch("w-family");
    std::fs::create_dir_all(&family).unwrap();
    let tiny = std::fs::read_to_string(world()).unwrap();
    let family_toml = family.join("tiny_family.toml");
    std::fs::write(&family_toml, format!("world_seeds = [3, 4]\n{tiny}")).unwrap();
    let o = Command::new(BIN)
        .args(["compare", "--worlds"])
        .arg(&family_toml)
        .args(["--time-limit-s", "30", "--strategies", "fit,random", "--seeds", "1", "--out"])
        .arg(family.join("out"))
        .output()
        .expect("run fitslam");
    assert!(o.status.success(), "stderr: {}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(csv.as_bytes(), std::fs::read(family.join("out/summary.csv")).unwrap().as_slice(), "the file's world_seeds = --world-seeds");

    let one = scratch("w-explore");
    let world = world();
    let o = Command::new(BIN)
        .args(["explore", "--world", &world, "--time-limit-s", "30", "--strategy", "random", "--seed", "1", "--world-seed", "4", "--out"])
        .arg(&one)
        .output()
        .expect("run fitslam");
    assert!(o.status.success(), "stderr: {}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(std::fs::read(one.join("metrics.csv")).unwrap(), metrics(&a, 4, "random"), "explore --world-seed 4 is the same run");
    for d in [a, b, one, family] {
        let _ = std::fs::remove_dir_all(d);
    }
}

/// With world seeds the world is the unit: `worlds.csv` (per strategy and world the geometric
/// mean over seeds), the world-level table in `summary.md` before the seed-paired one, and
/// `forest.{png,svg}`, on worlds of a family the code has no knowledge of.
#[test]
fn compare_across_world_seeds_infers_at_the_world_level() {
    let out = scratch("world-level");
    let world = world();
    let o = Command::new(BIN)
        .args(["compare", "--world", &world, "--time-limit-s", "60", "--strategies", "fit,random", "--seeds", "1"])
        .args(["--world-seeds", "3..5", "--jobs", "2", "--out"])
        .arg(&out)
        .output()
        .expect("run fitslam");
    assert!(o.status.success(), "stderr: {}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("worlds.csv, forest.png"));
    let worlds = std::fs::read_to_string(out.join("worlds.csv")).unwrap();
    let summary = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let lines: Vec<&str> = worlds.lines().collect();
    assert!(lines[0].starts_with("strategy,world_seed,runs,matched_cov_trace,time_s,t90_s,"), "{}", lines[0]);
    let keys: Vec<String> = lines[1..].iter().map(|l| l.split(',').take(3).collect::<Vec<_>>().join(",")).collect();
    assert_eq!(keys, ["fit,3,1", "fit,4,1", "fit,5,1", "random,3,1", "random,4,1", "random,5,1"]);
    // One seed per world: each world's geometric mean is its run's figure, as summary.csv prints it.
    for (w, s) in lines[1..].iter().zip(summary.lines().skip(1)) {
        let (w, s): (Vec<&str>, Vec<&str>) = (w.split(',').collect(), s.split(',').collect());
        assert_eq!(w[3], s[4], "matched_cov_trace of {} world {}", w[0], w[1]);
    }
    let md = std::fs::read_to_string(out.join("summary.md")).unwrap();
    let (world_level, paired) = (md.find("## World level").expect("world-level section"), md.find("## Each baseline").unwrap());
    assert!(world_level < paired, "the primary inference comes first");
    assert!(md.lines().any(|l| l.starts_with("| random | 3 | ")), "three comparable worlds: {md}");
    assert!(std::fs::read(out.join("forest.png")).unwrap().starts_with(b"\x89PNG"));
    assert!(std::fs::read_to_string(out.join("forest.svg")).unwrap().contains("fit / random"));
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn compare_rejects_bad_input_with_one_line() {
    let out = scratch("bad");
    for bad in ["5..2", "a..3", "1..x", "", "0..5000"] {
        assert_clear_error(&compare(&out, &["--strategies", "fit", "--seeds", "1", "--world-seeds", bad]), "--world-seeds");
    }
    assert_clear_error(&compare(&out, &["--strategies", "fit,best", "--seeds", "1"]), "best");
    assert_clear_error(&compare(&out, &["--strategies", "fit", "--seeds", "0"]), "--seeds");
    assert_clear_error(&compare(&out, &["--strategies", "fit", "--seeds", "1", "--jobs", "0"]), "--jobs");
    assert_clear_error(&compare(&out, &["--strategies", "fit", "--seeds", "1", "--jobs", "100000"]), "--jobs 100000: at most 1024");
    // An output folder that cannot be one fails before any run.
    std::fs::create_dir_all(&out).unwrap();
    let file = out.join("a_file");
    std::fs::write(&file, b"x").unwrap();
    assert_clear_error(&compare(&file, &["--strategies", "fit", "--seeds", "1"]), "cannot create the output folder");
    let o = Command::new(BIN)
        .args(["compare", "--world", "/nonexistent/w.toml", "--seeds", "1", "--out"])
        .arg(&out)
        .output()
        .expect("run fitslam");
    assert_clear_error(&o, "/nonexistent/w.toml");
    assert!(!out.join("summary.csv").exists());
}
