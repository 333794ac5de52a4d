//! AFL target `las`: see `fitslam_fuzz::las`.
fn main() {
    afl::fuzz!(|data: &[u8]| fitslam_fuzz::las(data));
}
