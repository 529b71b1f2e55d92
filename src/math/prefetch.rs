//! A cache prefetch hint, for lookups whose address is known well before
//! their value is needed (an environment map's texels once its sampling
//! tables have picked a cell): the miss then overlaps the work between.

/// Asks the CPU to bring the cache line holding `x` into L1. A hint only:
/// it changes no value, and on targets without one it does nothing.
#[inline(always)]
pub fn prefetch<T>(x: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: SSE is part of the x86_64 baseline, and a prefetch neither
    // reads the value nor faults, whatever the address.
    unsafe {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        _mm_prefetch::<_MM_HINT_T0>((x as *const T).cast::<i8>());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = x;
}
