//! Fresh memory and cache hints: transparent huge pages for large arrays, pages touched in
//! parallel before sequential code fills them, and prefetches.

use rayon::prelude::*;

/// Arrays at least this large ask the kernel for transparent huge pages.
const HUGE_PAGE_MIN_BYTES: usize = 4 << 20;

/// An empty vector with room for `n` values. Large buffers are marked for transparent huge pages
/// before they are first touched: a 4 KiB page fault costs about 2.3 µs here, so first touch of
/// fresh memory would otherwise cost more than the stages' own work.
pub fn with_capacity_huge<T>(n: usize) -> Vec<T> {
    let v = Vec::with_capacity(n);
    let bytes = n.saturating_mul(std::mem::size_of::<T>());
    if bytes >= HUGE_PAGE_MIN_BYTES {
        advise_huge_pages(v.as_ptr() as usize, bytes);
    }
    v
}

/// An empty vector with room for `capacity` values, the pages of the first `touched` of them
/// already touched by all threads in parallel: for a buffer that is then filled by sequential
/// code, first touch would otherwise run on one core.
pub fn prefaulted_within<T: Copy + Send + Sync>(
    capacity: usize,
    touched: usize,
    fill: T,
) -> Vec<T> {
    let mut v = with_capacity_huge(capacity);
    v.par_extend(rayon::iter::repeat_n(fill, touched.min(capacity)));
    v.clear();
    v
}

/// Marks the whole huge pages inside `start..start + bytes` for transparent huge pages: the
/// buffer of a vector [`with_capacity_huge`] (its only caller) has just allocated.
#[cfg(target_os = "linux")]
#[allow(unsafe_code)]
fn advise_huge_pages(start: usize, bytes: usize) {
    const HUGE: usize = 2 << 20;
    let first = start.next_multiple_of(HUGE);
    let end = (start + bytes) / HUGE * HUGE;
    if end > first {
        // SAFETY: `start..start + bytes` is the buffer of the vector just allocated by
        // `with_capacity_huge` (its capacity holds `bytes` bytes, a non-zero size), and
        // `first..end` is the whole 2 MiB-aligned pages inside it, so the call names only
        // memory of that allocation, which no one else uses yet. MADV_HUGEPAGE only changes how
        // the kernel backs the pages, never their contents or mapping (unlike MADV_DONTNEED or
        // MADV_FREE). Failure (no THP support) is harmless and ignored.
        unsafe { libc::madvise(first as *mut libc::c_void, end - first, libc::MADV_HUGEPAGE) };
    }
}

#[cfg(not(target_os = "linux"))]
fn advise_huge_pages(_start: usize, _bytes: usize) {}

/// Asks the processor to bring the cache line at `p` in, for a read soon; a hint only.
#[inline]
pub fn prefetch<T>(p: *const T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch is a hint: it never faults and reads or changes no memory the program
    // can see, whatever the address (callers pass `wrapping_add` pointers that may lie past an
    // array); it only needs SSE, which every x86-64 target has.
    #[allow(unsafe_code)]
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(p.cast::<i8>());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}
