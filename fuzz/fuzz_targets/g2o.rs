#![no_main]
//! Any bytes given to the g2o reader give a graph or an error, and any graph it reads gives a
//! problem or an error: never a panic.
use fitslam_core::slam::{Gauge, Se2Residual, g2o::read_g2o};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(file) = read_g2o(data) {
        let _ = file.to_problem(Gauge::FixFirst, Se2Residual::Log);
    }
});
