//! AFL target `g2o`: see `fitslam_fuzz::g2o`.
fn main() {
    afl::fuzz!(|data: &[u8]| fitslam_fuzz::g2o(data));
}
