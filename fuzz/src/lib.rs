//! What each fuzz target does with its input, in one place.
//!
//! Each function hands arbitrary bytes to a public `fitslam-core` loader and drops the result:
//! hostile input must give a value or a typed error, never a panic, a hang or an allocation out
//! of proportion to the input. The AFL binaries in `fuzz_targets/` call these functions, and so
//! does the corpus replay in `core/tests/fuzz_corpus.rs`, which includes this file by `#[path]`
//! (the fuzz crate is not a workspace member, so the normal test run needs neither cargo-afl nor
//! AFL++). This file therefore uses nothing but `fitslam_core` and `std`.

use fitslam_core::bag::{Bag, BagTopics};
use fitslam_core::io::{MapMode, MapThresholds, MapYaml};
use fitslam_core::slam::{Gauge, Se2Residual, g2o::read_g2o};

/// A fuzz target: takes any bytes, must not panic, hang or exhaust memory.
pub type Target = fn(&[u8]);

/// Every target by name: the name is the AFL binary's and the corpus directory's
/// (`fuzz/corpus/<name>/`).
pub const TARGETS: [(&str, Target); 9] = [
    ("ply", ply),
    ("pcd", pcd),
    ("csv", csv),
    ("map_yaml", map_yaml),
    ("pgm", pgm),
    ("las", las),
    ("g2o", g2o),
    ("bag", bag),
    ("metrics_csv", metrics_csv),
];

/// PLY, ascii and binary of either byte order.
pub fn ply(data: &[u8]) {
    let _ = fitslam_core::io::ply::load_ply(data, "fuzz.ply");
}

/// PCD: ascii, binary and binary_compressed (LZF).
pub fn pcd(data: &[u8]) {
    let _ = fitslam_core::io::pcd::load_pcd(data, "fuzz.pcd");
}

/// CSV point clouds and landmark sets.
pub fn csv(data: &[u8]) {
    let _ = fitslam_core::io::csv::load_csv(data, "fuzz.csv");
}

/// The map_server YAML, read alone and with a fixed 2 × 2 PGM as its image.
pub fn map_yaml(data: &[u8]) {
    const PGM: &[u8] = b"P5\n2 2\n255\n\x00\xcd\xfe\xff";
    if let Ok(yaml) = MapYaml::parse(data, "fuzz.yaml") {
        let _ = yaml.thresholds();
    }
    let _ = fitslam_core::io::load_map(data, "fuzz.yaml", PGM, "fuzz.pgm");
}

/// A map image (PGM P2/P5 or PNG, chosen by content) in every map mode.
pub fn pgm(data: &[u8]) {
    for mode in [MapMode::Trinary, MapMode::Scale, MapMode::Raw] {
        let t = MapThresholds { mode, ..MapThresholds::default() };
        let _ = fitslam_core::io::load_map_image(data, "fuzz.pgm", 0.05, [0.0, 0.0], &t);
    }
}

/// LAS, and LAZ (the `laz` feature of fitslam-core is on by default), chosen by content.
pub fn las(data: &[u8]) {
    let _ = fitslam_core::io::load_cloud(data, "fuzz.las");
}

/// A g2o file, and the optimisation problem built from what it reads.
pub fn g2o(data: &[u8]) {
    if let Ok(file) = read_g2o(data) {
        let _ = file.to_problem(Gauge::FixFirst, Se2Residual::Log);
    }
}

/// A rosbag2 MCAP file; a bag that parses is asked for its topics, its decision instants and the
/// inputs at its start and end.
pub fn bag(data: &[u8]) {
    if let Ok(bag) = Bag::parse(data, "fuzz.mcap") {
        let topics = BagTopics::default();
        let _ = bag.topics();
        let _ = bag.decision_instants(&topics);
        let _ = bag.snapshot(&topics, 0.0);
        let _ = bag.snapshot(&topics, bag.duration_s());
    }
}

/// A mission's `metrics.csv`, as `fitslam collect` reads it back.
pub fn metrics_csv(data: &[u8]) {
    let _ = fitslam_core::sim::read_metrics_csv(data);
}
