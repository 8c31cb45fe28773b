//! A hint that a value will be read soon, so that its cache line is on its way while other
//! work goes on.
//!
//! For reads whose place the processor cannot foresee and that the code knows a few steps
//! ahead: the octree build appraising a leaf reads its triangles in the leaf's order, scattered
//! over the scene's list, and each of its steps reads records and lists that the queue names
//! a step before. On x86 the hint is SSE's `prefetcht0`, through the safe wrapper of
//! `safe_arch` (the crate under `wide`; the workspace forbids `unsafe`); elsewhere it is
//! nothing. A hint reads no value and changes no result.

/// Asks for the cache line that holds the start of `value`.
#[inline(always)]
pub fn prefetch<T>(value: &T) {
    #[cfg(all(
        any(target_arch = "x86", target_arch = "x86_64"),
        target_feature = "sse"
    ))]
    safe_arch::prefetch_t0(value);
    #[cfg(not(all(
        any(target_arch = "x86", target_arch = "x86_64"),
        target_feature = "sse"
    )))]
    let _ = value;
}
