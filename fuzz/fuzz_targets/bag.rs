//! AFL target `bag`: see `fitslam_fuzz::bag`.
fn main() {
    afl::fuzz!(|data: &[u8]| fitslam_fuzz::bag(data));
}
