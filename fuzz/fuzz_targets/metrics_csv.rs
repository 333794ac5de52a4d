//! AFL target `metrics_csv`: see `fitslam_fuzz::metrics_csv`.
fn main() {
    afl::fuzz!(|data: &[u8]| fitslam_fuzz::metrics_csv(data));
}
