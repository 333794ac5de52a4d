#![no_main]
//! Any image bytes (PGM P2/P5 or PNG, chosen by content) give a grid or an error, never a panic,
//! in every map mode.
use fitslam_core::io::{load_map_image, MapMode, MapThresholds};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    for mode in [MapMode::Trinary, MapMode::Scale, MapMode::Raw] {
        let t = MapThresholds { mode, ..MapThresholds::default() };
        let _ = load_map_image(data, "fuzz.pgm", 0.05, [0.0, 0.0], &t);
    }
});
