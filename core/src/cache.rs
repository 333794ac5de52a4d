//! Cache hints for loops whose reads are spread over arrays far larger than the caches.

/// Asks the cache for the line holding `x`, ahead of its use: a hint that never faults and changes
/// no result (a no-op off x86-64).
#[inline(always)]
pub(crate) fn prefetch<T>(x: &T) {
    #[cfg(target_arch = "x86_64")]
    safe_arch::prefetch_t0(x);
    #[cfg(not(target_arch = "x86_64"))]
    let _ = x;
}
