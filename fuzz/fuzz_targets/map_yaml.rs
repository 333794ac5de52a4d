#![no_main]
//! Any YAML bytes give a map or an error, never a panic (with a fixed 2 × 2 PGM as the image).
use libfuzzer_sys::fuzz_target;

const PGM: &[u8] = b"P5\n2 2\n255\n\x00\xcd\xfe\xff";

fuzz_target!(|data: &[u8]| {
    if let Ok(yaml) = fitslam_core::io::MapYaml::parse(data, "fuzz.yaml") {
        let _ = yaml.thresholds();
    }
    let _ = fitslam_core::io::load_map(data, "fuzz.yaml", PGM, "fuzz.pgm");
});
