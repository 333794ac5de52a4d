//! The committed experiments cannot go stale unnoticed: for every committed `plan.json` under
//! `docs/paper-experiment/` and `docs/test-worlds/`, a small slice of its runs (`fit` and the
//! plan's last strategy, in its first world, with its first two seeds when the plan has one world)
//! is run again with the plan's own command on today's code, and each row of the new
//! `summary.csv` must equal the committed row of the same strategy, world and seed, byte for byte.
//! A change that moves the missions fails here until the experiments are run again with their
//! commands (docs/experiments.md) and committed.

#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failure should stop it

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_fitslam");

/// The committed experiments' roots (per-run folders and `plan.jsonl` are not committed).
const ROOTS: [&str; 2] = ["docs/paper-experiment", "docs/test-worlds"];

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Every `plan.json` under `dir` whose folder also holds a committed `summary.csv`, sorted.
fn plans(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    let mut entries: Vec<PathBuf> = entries.map(|e| e.unwrap().path()).collect();
    entries.sort();
    for path in entries {
        if path.is_dir() {
            plans(&path, out);
        } else if path.file_name().is_some_and(|n| n == "plan.json") && path.with_file_name("summary.csv").is_file() {
            out.push(path);
        }
    }
}

/// The plan's command split into its options (`--key value`), the program and subcommand dropped.
fn options(command: &str) -> Vec<(String, String)> {
    let words: Vec<&str> = command.split_whitespace().collect();
    assert_eq!(&words[..2], ["fitslam", "compare"], "{command}");
    words[2..].chunks(2).map(|kv| (kv[0].to_string(), kv[1].to_string())).collect()
}

/// Rows of a summary.csv keyed by (strategy, world seed or "", seed).
fn rows(csv: &str) -> (String, BTreeMap<(String, String, String), String>) {
    let mut lines = csv.lines();
    let header = lines.next().unwrap().to_string();
    let columns: Vec<&str> = header.split(',').collect();
    let at = |name: &str| columns.iter().position(|c| *c == name);
    let (strategy, seed, world) = (at("strategy").unwrap(), at("seed").unwrap(), at("world_seed"));
    let keyed = lines
        .map(|line| {
            let f: Vec<&str> = line.split(',').collect();
            let w = world.map(|i| f[i].to_string()).unwrap_or_default();
            ((f[strategy].to_string(), w, f[seed].to_string()), line.to_string())
        })
        .collect();
    (header, keyed)
}

#[test]
fn a_slice_of_every_committed_experiment_reruns_to_its_committed_rows() {
    let root = repo();
    let mut found = Vec::new();
    for dir in ROOTS {
        plans(&root.join(dir), &mut found);
    }
    assert!(found.iter().any(|p| p.starts_with(root.join("docs/test-worlds"))), "no committed test-world experiment: {found:?}");
    for plan in found {
        let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&plan).unwrap()).unwrap();
        let mut args = options(json["command"].as_str().expect("plan.json names its command"));
        let strategies: Vec<String> = args.iter().find(|(k, _)| k == "--strategies").unwrap().1.split(',').map(String::from).collect();
        let last = strategies.last().unwrap();
        let slice = if last == "fit" { "fit".to_string() } else { format!("fit,{last}") };
        let family = args.iter().any(|(k, _)| k == "--world-seeds");
        for (key, value) in args.iter_mut() {
            match key.as_str() {
                "--strategies" => *value = slice.clone(),
                "--seeds" => *value = if family { "1" } else { "2" }.into(),
                "--world-seeds" => *value = value.split("..").next().unwrap().to_string(),
                _ => {}
            }
        }
        let out = std::env::temp_dir().join(format!("fitslam-reproduce-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&out);
        let o = Command::new(BIN)
            .current_dir(&root)
            .arg("compare")
            .args(args.iter().flat_map(|(k, v)| [k, v]))
            .args(["--jobs", "2", "--out"])
            .arg(&out)
            .output()
            .unwrap();
        let name = plan.parent().unwrap().strip_prefix(&root).unwrap().display().to_string();
        assert!(o.status.success(), "{name}: {}", String::from_utf8_lossy(&o.stderr));
        let (committed_header, committed) = rows(&std::fs::read_to_string(plan.with_file_name("summary.csv")).unwrap());
        let (header, rerun) = rows(&std::fs::read_to_string(out.join("summary.csv")).unwrap());
        assert_eq!(header, committed_header, "{name}: summary.csv's columns changed");
        let runs = slice.split(',').count() * if family { 1 } else { 2 };
        assert_eq!(rerun.len(), runs, "{name}: the slice's runs");
        for (key, row) in &rerun {
            let expected = committed.get(key).unwrap_or_else(|| panic!("{name}: no committed row for {key:?}"));
            assert_eq!(
                row, expected,
                "{name}, run {key:?}: today's code gives another run than the committed one; run the experiment's command again (docs/experiments.md)"
            );
        }
        std::fs::remove_dir_all(&out).unwrap();
    }
}
