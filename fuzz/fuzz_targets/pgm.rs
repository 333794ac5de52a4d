//! AFL target `pgm`: see `fitslam_fuzz::pgm`.
fn main() {
    afl::fuzz!(|data: &[u8]| fitslam_fuzz::pgm(data));
}
