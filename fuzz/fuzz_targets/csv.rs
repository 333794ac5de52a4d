//! AFL target `csv`: see `fitslam_fuzz::csv`.
fn main() {
    afl::fuzz!(|data: &[u8]| fitslam_fuzz::csv(data));
}
