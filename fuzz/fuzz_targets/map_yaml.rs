//! AFL target `map_yaml`: see `fitslam_fuzz::map_yaml`.
fn main() {
    afl::fuzz!(|data: &[u8]| fitslam_fuzz::map_yaml(data));
}
