//! What the CLI tests share.

use std::process::Output;

/// Asserts a failed run: exit code 1, no panic, exactly one line on stderr containing `needle`.
pub fn assert_clear_error(out: &Output, needle: &str) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "exit code; stderr: {stderr}");
    assert!(!stderr.contains("panicked"), "panic: {stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "one line expected: {stderr:?}");
    assert!(stderr.contains(needle), "expected {needle:?} in {stderr:?}");
}
