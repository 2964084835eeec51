//! Cache hints for loops whose next items are known ahead but sit far apart in memory.

/// Ask the processor to start loading the cache line holding `item`, without waiting for
/// it: a hint that never faults and changes nothing else. A plain load of something ahead
/// would stall the loop until it arrives, and a miss costs hundreds of cycles. On
/// processors without the instruction it does nothing.
#[inline]
pub(crate) fn prefetch<T>(item: &T) {
    #[cfg(all(any(target_arch = "x86", target_arch = "x86_64"), target_feature = "sse"))]
    safe_arch::prefetch_t0(item);
    #[cfg(not(all(any(target_arch = "x86", target_arch = "x86_64"), target_feature = "sse")))]
    let _ = item;
}
