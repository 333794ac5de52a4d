#![no_main]
//! Any bytes given to the LAS/LAZ loader give a cloud or an error, never a panic. Seed the corpus
//! with assets/data/lidar/vegetation_1_3.las.
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = fitslam_core::io::load_cloud(data, "fuzz.las");
});
