#![no_main]
//! Any bytes given to the CSV loader give a cloud or an error, never a panic.
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = fitslam_core::io::csv::load_csv(data, "fuzz.csv");
});
