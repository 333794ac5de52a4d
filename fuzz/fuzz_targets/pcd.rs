//! AFL target `pcd`: see `fitslam_fuzz::pcd`.
fn main() {
    afl::fuzz!(|data: &[u8]| fitslam_fuzz::pcd(data));
}
