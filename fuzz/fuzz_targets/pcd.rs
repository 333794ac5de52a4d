#![no_main]
//! Any bytes given to the PCD loader (ascii, binary, binary_compressed/LZF) give a cloud or an
//! error, never a panic.
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = fitslam_core::io::pcd::load_pcd(data, "fuzz.pcd");
});
