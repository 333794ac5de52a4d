//! AFL target `las`: see `fitslam_fuzz::las`. Without afl.rs's panic hook: the loader catches the
//! LAZ decoder's panics (core/src/io/las.rs) and returns an error, so only a panic that escapes
//! the loader is a crash.
fn main() {
    afl::fuzz_nohook!(|data: &[u8]| fitslam_fuzz::las(data));
}
