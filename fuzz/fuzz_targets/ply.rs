//! AFL target `ply`: see `fitslam_fuzz::ply`.
fn main() {
    afl::fuzz!(|data: &[u8]| fitslam_fuzz::ply(data));
}
