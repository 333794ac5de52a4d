//! Replays the fuzz corpus (`fuzz/corpus/<target>/`, kept by `scripts/fuzz`) and the fixed crash
//! inputs (`fuzz/crashes/<target>/`) through the fuzz targets, so every input AFL found
//! interesting, and every one that once crashed a loader, stays a regression test in the normal
//! test run.
//!
//! The targets are `fuzz/src/lib.rs` itself, included by path: one definition of what each target
//! does, shared with the AFL binaries, while this workspace crate never builds the fuzz crate (which
//! needs cargo-afl and AFL++).

// A test harness: a corpus file that cannot be read is a failed test.
#![allow(clippy::unwrap_used)]

#[path = "../../fuzz/src/lib.rs"]
mod targets;

use std::path::{Path, PathBuf};

fn fuzz_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz")
}

/// The regular files of `dir`, sorted; none when it does not exist.
fn files_in(dir: &Path) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut files: Vec<PathBuf> = entries.map(|e| e.unwrap().path()).filter(|p| p.is_file()).collect();
    files.sort();
    files
}

/// Runs every input of `target`; a panic names the file. Fails on an empty corpus, so that a
/// missing directory cannot pass as "no failures".
fn replay(name: &str) {
    let (_, target) = targets::TARGETS.iter().find(|(n, _)| *n == name).unwrap();
    let corpus = files_in(&fuzz_dir().join("corpus").join(name));
    assert!(!corpus.is_empty(), "fuzz/corpus/{name}/ is missing or empty: run scripts/fuzz (or restore it from git)");
    let crashes = files_in(&fuzz_dir().join("crashes").join(name));
    for file in corpus.iter().chain(&crashes) {
        let data = std::fs::read(file).unwrap();
        let run = std::panic::catch_unwind(|| target(&data));
        assert!(run.is_ok(), "fuzz target {name} panics on {}", file.display());
    }
}

/// Every target has a test below; a target added to `TARGETS` without one fails here.
#[test]
fn every_target_is_replayed() {
    let names: Vec<&str> = targets::TARGETS.iter().map(|(n, _)| *n).collect();
    assert_eq!(names, ["ply", "pcd", "csv", "map_yaml", "pgm", "las", "g2o", "bag", "metrics_csv"]);
}

#[test]
fn ply() {
    replay("ply");
}

#[test]
fn pcd() {
    replay("pcd");
}

#[test]
fn csv() {
    replay("csv");
}

#[test]
fn map_yaml() {
    replay("map_yaml");
}

#[test]
fn pgm() {
    replay("pgm");
}

#[test]
fn las() {
    replay("las");
}

#[test]
fn g2o() {
    replay("g2o");
}

#[test]
fn bag() {
    replay("bag");
}

#[test]
fn metrics_csv() {
    replay("metrics_csv");
}
