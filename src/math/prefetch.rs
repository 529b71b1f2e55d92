//! A cache prefetch hint, for lookups whose address is known well before
//! their value is needed (an environment map's texels once its sampling
//! tables have picked a cell): the miss then overlaps the work between.

/// Asks the CPU to bring the cache line holding `x` into L1. A hint only:
/// it changes no value, and on targets without one it does nothing.
#[inline(always)]
pub fn prefetch<T>(x: &T) {
    prefetch_address(x as *const T);
}

/// [`prefetch`] of `items[i]` without a bounds check: prefetching any
/// address is harmless (an index out of range fetches a useless line), so
/// the hints on the sampling path need not pay for the checks a load
/// would (on the env-lit suite scenes those checks were 1.5-1.8% of all
/// instructions).
#[inline(always)]
pub fn prefetch_at<T>(items: &[T], i: usize) {
    // `wrapping_add` forms the address without the in-bounds requirement
    // of `add`; nothing is dereferenced.
    prefetch_address(items.as_ptr().wrapping_add(i));
}

/// The hint itself, for any address (valid or not).
#[inline(always)]
fn prefetch_address<T>(p: *const T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: SSE is part of the x86_64 baseline, and a prefetch neither
    // reads the value nor faults, whatever the address.
    unsafe {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        _mm_prefetch::<_MM_HINT_T0>(p.cast::<i8>());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}
