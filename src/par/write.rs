//! Parallel writes into one output: segments owned by items (filled in place, straight into
//! fresh memory), per-block scratch, scatters by index, and streaming stores past the caches.

use rayon::prelude::*;

use super::memory::with_capacity_huge;
use super::scan::exclusive_scan_by;
use super::{GRAIN, chunk_offsets};

/// Fills `out` in parallel, where item `i` owns `out[offsets[i]..offsets[i + 1]]`:
/// `fill(i, segment)` is called once per item with its segment. The result does not depend on
/// the thread count.
pub fn fill_segments<T, F>(offsets: &[usize], out: &mut [T], fill: F)
where
    T: Send,
    F: Fn(usize, &mut [T]) + Sync,
{
    let items = offsets.len() - 1;
    assert_eq!(
        offsets[items] - offsets[0],
        out.len(),
        "segments must cover the output"
    );
    let bounds = group_bounds(offsets);
    let mut groups: Vec<(usize, usize, &mut [T])> = Vec::with_capacity(bounds.len());
    let mut rest = out;
    for w in bounds.windows(2) {
        let (head, tail) = rest.split_at_mut(offsets[w[1]] - offsets[w[0]]);
        groups.push((w[0], w[1], head));
        rest = tail;
    }
    groups
        .into_par_iter()
        .for_each(|(first, last, mut segment)| {
            for i in first..last {
                let (head, tail) = segment.split_at_mut(offsets[i + 1] - offsets[i]);
                fill(i, head);
                segment = tail;
            }
        });
}

/// Output values per task in segment fills.
const GRAIN_OUT: usize = 1 << 15;

/// Item boundaries of the tasks of a segment fill: a task ends every `GRAIN` items and every
/// `GRAIN_OUT` output values, so that neither many small segments nor a few large ones end up in
/// one task. The boundaries depend only on `offsets`, never on the thread count.
fn group_bounds(offsets: &[usize]) -> Vec<usize> {
    let items = offsets.len() - 1;
    let (base, total) = (offsets[0], offsets[items]);
    let by_items = (0..items).step_by(GRAIN);
    let by_output = (base..total)
        .step_by(GRAIN_OUT)
        .map(|pos| offsets.partition_point(|&o| o <= pos).saturating_sub(1));
    let mut bounds: Vec<usize> = by_items.chain(by_output).chain([0, items]).collect();
    bounds.sort_unstable();
    bounds.dedup();
    bounds
}

/// Builds a vector in parallel, straight into fresh memory (the first-touch page faults are spread
/// over the threads too): item `i` owns `offsets[i]..offsets[i + 1]` and `produce(i)` yields
/// exactly that many values for it.
///
/// # Panics
/// If `produce(i)` yields fewer values than its segment holds (extra values are ignored).
pub fn collect_segments<T, I, F>(offsets: &[usize], produce: F) -> Vec<T>
where
    T: Send,
    I: Iterator<Item = T>,
    F: Fn(usize) -> I + Sync,
{
    collect_segments_in(offsets, false, 0, produce)
}

/// As [`collect_segments`], into a vector with room for at least `capacity` values; the room
/// past the values is not touched.
pub fn collect_segments_with_capacity<T, I, F>(
    offsets: &[usize],
    capacity: usize,
    produce: F,
) -> Vec<T>
where
    T: Send,
    I: Iterator<Item = T>,
    F: Fn(usize) -> I + Sync,
{
    collect_segments_in(offsets, false, capacity, produce)
}

/// As [`collect_segments`], but each segment is written from its end backwards, so producers
/// that find their values in reverse order need no buffer.
pub fn collect_segments_reversed<T, I, F>(offsets: &[usize], produce: F) -> Vec<T>
where
    T: Send,
    I: Iterator<Item = T>,
    F: Fn(usize) -> I + Sync,
{
    collect_segments_in(offsets, true, 0, produce)
}

fn collect_segments_in<T, I, F>(
    offsets: &[usize],
    reversed: bool,
    capacity: usize,
    produce: F,
) -> Vec<T>
where
    T: Send,
    I: Iterator<Item = T>,
    F: Fn(usize) -> I + Sync,
{
    let total = offsets[offsets.len() - 1] - offsets[0];
    let mut out: Vec<T> = with_capacity_huge(total.max(capacity));
    fill_segments(
        offsets,
        &mut out.spare_capacity_mut()[..total],
        |i, segment| {
            let mut written = 0;
            let mut write = |(slot, value): (&mut std::mem::MaybeUninit<T>, T)| {
                slot.write(value);
                written += 1;
            };
            if reversed {
                segment
                    .iter_mut()
                    .rev()
                    .zip(produce(i))
                    .for_each(&mut write);
            } else {
                segment.iter_mut().zip(produce(i)).for_each(&mut write);
            }
            assert_eq!(written, segment.len(), "item {i} yielded too few values");
        },
    );
    // SAFETY: `total` is within the capacity (`with_capacity_huge(total.max(capacity))`), and
    // every one of the first `total` slots has been written: `fill_segments` asserts that the
    // segments cover exactly `out.spare_capacity_mut()[..total]` and hands each its own disjoint
    // part (`split_at_mut`), and each segment's count of writes was asserted equal to its
    // length. A short one panics before this line (rayon passes the panic on after every task
    // ended), and the vector is then dropped with length 0, leaking what was written.
    #[allow(unsafe_code)]
    unsafe {
        out.set_len(total)
    };
    out
}

/// Where one segment of [`collect_segments_by`] is written, front to back.
pub struct SegmentWriter<'a, T> {
    slots: &'a mut [std::mem::MaybeUninit<T>],
    written: usize,
}

impl<T> SegmentWriter<'_, T> {
    /// Writes the next value.
    ///
    /// # Panics
    /// If the segment is full.
    #[inline]
    pub fn push(&mut self, value: T) {
        self.slots[self.written].write(value);
        self.written += 1;
    }

    /// Writes `values` next, as one block copy.
    ///
    /// # Panics
    /// If the segment has too little room left.
    #[inline]
    pub fn extend_from_slice(&mut self, values: &[T])
    where
        T: Copy,
    {
        self.slots[self.written..self.written + values.len()].write_copy_of_slice(values);
        self.written += values.len();
    }

    /// How many values have been written.
    pub fn len(&self) -> usize {
        self.written
    }
}

/// Per-block outputs of bounded size in one buffer: block `b` owns `stride` slots and fills a
/// prefix of them. One huge allocation instead of a vector per block, so its pages are the
/// kernel's cheap large ones, not a heap's small ones.
pub struct BlockScratch<T> {
    buffer: Vec<std::mem::MaybeUninit<T>>,
    stride: usize,
    lens: Vec<usize>,
}

impl<T: Copy + Send + Sync> BlockScratch<T> {
    /// Runs `fill(b, state, writer)` in parallel for each block `b` and its `state` from
    /// `states`, each writing at most `stride` values (more panics).
    pub fn fill<S, I, F>(stride: usize, states: I, fill: F) -> Self
    where
        I: IndexedParallelIterator<Item = S>,
        F: Fn(usize, S, &mut SegmentWriter<T>) + Sync,
    {
        let blocks = states.len();
        let mut buffer: Vec<std::mem::MaybeUninit<T>> = with_capacity_huge(blocks * stride);
        // SAFETY: the capacity is at least `blocks * stride` (`with_capacity_huge`), and
        // `MaybeUninit` slots need no initialisation; `block` reads only the prefix each
        // block's writer counted as written.
        #[allow(unsafe_code)]
        unsafe {
            buffer.set_len(blocks * stride)
        };
        let lens = buffer
            .par_chunks_mut(stride.max(1))
            .zip(states)
            .enumerate()
            .map(|(b, (slots, state))| {
                let mut writer = SegmentWriter { slots, written: 0 };
                fill(b, state, &mut writer);
                writer.written
            })
            .collect();
        BlockScratch {
            buffer,
            stride,
            lens,
        }
    }

    /// What block `b` wrote.
    pub fn block(&self, b: usize) -> &[T] {
        let slots = &self.buffer[b * self.stride..][..self.lens[b]];
        // SAFETY: block `b` owned `buffer[b * stride..][..stride]` (`par_chunks_mut`), and its
        // writer wrote those slots front to back, `push` and `extend_from_slice` counting each
        // written slot in `written`, which became `lens[b]`; so the first `lens[b]` slots are
        // initialised (the slicing above checks the bounds). `MaybeUninit<T>` has `T`'s layout,
        // and the slice borrows `self`, so nothing writes them meanwhile.
        #[allow(unsafe_code)]
        unsafe {
            &*(slots as *const [std::mem::MaybeUninit<T>] as *const [T])
        }
    }

    /// How many values block `b` wrote.
    pub fn len_of(&self, b: usize) -> usize {
        self.lens[b]
    }

    /// Number of blocks.
    pub fn blocks(&self) -> usize {
        self.lens.len()
    }
}

/// As [`collect_segments`], with item `i` writing its segment through `fill(i, writer)`; for
/// producers whose loops are plainer than an iterator.
///
/// # Panics
/// If an item writes fewer or more values than its segment holds.
pub fn collect_segments_by<T, F>(offsets: &[usize], fill: F) -> Vec<T>
where
    T: Send,
    F: Fn(usize, &mut SegmentWriter<T>) + Sync,
{
    let total = offsets[offsets.len() - 1] - offsets[0];
    let mut out: Vec<T> = with_capacity_huge(total);
    fill_segments(
        offsets,
        &mut out.spare_capacity_mut()[..total],
        |i, slots| {
            let len = slots.len();
            let mut writer = SegmentWriter { slots, written: 0 };
            fill(i, &mut writer);
            assert_eq!(writer.written, len, "item {i} wrote too few values");
        },
    );
    // SAFETY: as in `collect_segments_in`: `total` is the capacity asked for, the segments
    // partition the first `total` slots (`fill_segments`), and each segment's writer was
    // asserted to have written all of its slots, front to back.
    #[allow(unsafe_code)]
    unsafe {
        out.set_len(total)
    };
    out
}

/// As [`collect_segments_by`] for two outputs with the same segments: item `i` writes its
/// segment of each through `fill(i, first, second)`. Meant for few items (blocks): each is one
/// task.
///
/// # Panics
/// If an item writes fewer or more values than its segment holds, in either output.
pub fn collect_segment_pairs_by<A, B, F>(offsets: &[usize], fill: F) -> (Vec<A>, Vec<B>)
where
    A: Send,
    B: Send,
    F: Fn(usize, &mut SegmentWriter<A>, &mut SegmentWriter<B>) + Sync,
{
    let total = offsets[offsets.len() - 1] - offsets[0];
    let mut first: Vec<A> = with_capacity_huge(total);
    let mut second: Vec<B> = with_capacity_huge(total);
    let mut jobs = Vec::with_capacity(offsets.len() - 1);
    let mut rest = (
        &mut first.spare_capacity_mut()[..total],
        &mut second.spare_capacity_mut()[..total],
    );
    for (i, w) in offsets.windows(2).enumerate() {
        let (a, a_rest) = std::mem::take(&mut rest.0).split_at_mut(w[1] - w[0]);
        let (b, b_rest) = std::mem::take(&mut rest.1).split_at_mut(w[1] - w[0]);
        jobs.push((i, a, b));
        rest = (a_rest, b_rest);
    }
    jobs.into_par_iter().for_each(|(i, a, b)| {
        let len = a.len();
        let mut a = SegmentWriter {
            slots: a,
            written: 0,
        };
        let mut b = SegmentWriter {
            slots: b,
            written: 0,
        };
        fill(i, &mut a, &mut b);
        assert!(
            a.written == len && b.written == len,
            "item {i} wrote too few values"
        );
    });
    // SAFETY: both vectors have capacity `total`; the windows of `offsets` split the first
    // `total` slots of each output into disjoint segments, one per job (`split_at_mut`, which
    // panics if they do not fit), and each job's writers were asserted to have written all of
    // their slots, front to back (a short one panics before this line, and the vectors are
    // then dropped with length 0).
    #[allow(unsafe_code)]
    unsafe {
        first.set_len(total);
        second.set_len(total);
    }
    (first, second)
}

/// The parts one after another, copied in parallel into fresh memory.
pub fn concat<T: Copy + Send + Sync>(parts: &[Vec<T>]) -> Vec<T> {
    let offsets = exclusive_scan_by(parts.len(), |i| parts[i].len());
    collect_segments_by(&offsets, |i, out| out.extend_from_slice(&parts[i]))
}

/// `f(0), f(1), ..., f(n - 1)` computed in parallel into fresh memory.
pub fn collect_indexed<T, F>(n: usize, f: F) -> Vec<T>
where
    T: Send,
    F: Fn(usize) -> T + Sync,
{
    let offsets = chunk_offsets(n, GRAIN);
    collect_segments(&offsets, |c| (offsets[c]..offsets[c + 1]).map(&f))
}

/// A `u32` slice that parallel tasks fill by index, for scatters whose targets are distinct
/// when the input is valid. Each store is atomic (relaxed, a plain store on x86-64), so input
/// that breaks that (a public caller's malformed tree) leaves one of the values in a slot written
/// twice, never a data race; and the stores need no `unsafe` at the call site.
pub struct SharedSlots<'a> {
    ptr: *mut u32,
    len: usize,
    _slice: std::marker::PhantomData<&'a mut [u32]>,
}

// SAFETY: the only access through the pointer is `store`, an atomic store into a slot of the
// slice borrowed mutably for `'a` (so nothing else reads or writes it meanwhile); atomic stores
// from several threads, to one slot or many, are no data race.
#[allow(unsafe_code)]
unsafe impl Sync for SharedSlots<'_> {}
// SAFETY: as for `Sync`: the slots are plain `u32`s, owned by no thread, and the pointer is only
// used for atomic stores while the borrow lasts.
#[allow(unsafe_code)]
unsafe impl Send for SharedSlots<'_> {}

impl<'a> SharedSlots<'a> {
    /// Borrows `slice` for the scatter; its contents stay as they are until written.
    pub fn new(slice: &'a mut [u32]) -> Self {
        SharedSlots {
            ptr: slice.as_mut_ptr(),
            len: slice.len(),
            _slice: std::marker::PhantomData,
        }
    }

    /// The value at `i`: as stored before the scatter, or by a store of it.
    ///
    /// # Panics
    /// If `i` is out of range.
    #[inline]
    pub fn load(&self, i: usize) -> u32 {
        assert!(i < self.len, "slot {i} of {}", self.len);
        // SAFETY: as in `store`: the slot is in the borrowed slice, and every access to it
        // while it is borrowed here is atomic.
        #[allow(unsafe_code)]
        let slot = unsafe { std::sync::atomic::AtomicU32::from_ptr(self.ptr.add(i)) };
        slot.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// Stores `value` at `i`.
    ///
    /// # Panics
    /// If `i` is out of range.
    #[inline]
    pub fn store(&self, i: usize, value: u32) {
        assert!(i < self.len, "slot {i} of {}", self.len);
        // SAFETY: `i < len` (asserted), so the pointer is in the slice, which is borrowed
        // mutably for `'a`, so valid and used by nothing else; `u32` and `AtomicU32` have the
        // same size and alignment; and while it is borrowed here every access is atomic.
        #[allow(unsafe_code)]
        let slot = unsafe { std::sync::atomic::AtomicU32::from_ptr(self.ptr.add(i)) };
        slot.store(value, std::sync::atomic::Ordering::Relaxed);
    }
}

/// A slice that parallel tasks write by index, for scatters whose targets are distinct by
/// construction (each slot has exactly one writer).
pub struct DisjointWrites<'a, T> {
    ptr: *mut T,
    len: usize,
    _slice: std::marker::PhantomData<&'a mut [T]>,
}

// SAFETY: the only accesses through the pointer are the unsafe writes, whose contract is that
// each slot has one writer while the writes last, and nothing reads the slice while it is
// borrowed here; so sharing the pointer across threads is sharing `&mut` access to disjoint
// slots of it. `T: Send` because the values are moved into it from other threads.
#[allow(unsafe_code)]
unsafe impl<T: Send> Sync for DisjointWrites<'_, T> {}
// SAFETY: as for `Sync`: it holds a `&'a mut [T]` in effect, which is `Send` for `T: Send`.
#[allow(unsafe_code)]
unsafe impl<T: Send> Send for DisjointWrites<'_, T> {}

impl<'a, T> DisjointWrites<'a, T> {
    /// Writes into `slice`, which stays borrowed while the writes last.
    pub fn new(slice: &'a mut [T]) -> Self {
        DisjointWrites {
            ptr: slice.as_mut_ptr(),
            len: slice.len(),
            _slice: std::marker::PhantomData,
        }
    }

    /// Writes `value` at `i`.
    ///
    /// # Safety
    /// No other call, on any thread, writes slot `i` while these writes last.
    ///
    /// # Panics
    /// If `i` is out of bounds.
    #[inline]
    #[allow(unsafe_code)]
    pub unsafe fn write(&self, i: usize, value: T) {
        assert!(i < self.len, "slot {i} of {}", self.len);
        // SAFETY: in bounds (`i < len`, asserted); no other writer of this slot (the caller's
        // contract), and the slice is borrowed mutably for our lifetime, so nobody reads it
        // meanwhile. The slot holds a valid `T` (it is in a `&mut [T]`), which the assignment
        // drops.
        unsafe { *self.ptr.add(i) = value };
    }
}

impl<T> DisjointWrites<'_, T> {
    /// Writes `words` as the value at `i`, past the caches where it can: by a streaming store
    /// on x86-64 when the slot is 16-byte aligned. A large array written once, slot by slot, is
    /// then not read into the cache line by line before each line is overwritten.
    ///
    /// # Safety
    /// As [`Self::write`], and:
    /// - any four words are a valid `T` (16 bytes, as the links are);
    /// - the writing thread calls [`stream_fence`] (or drops a [`StreamFence`]) before the
    ///   slot is read or freed, on any thread.
    ///
    /// # Panics
    /// If `i` is out of bounds.
    #[inline]
    #[allow(unsafe_code)]
    pub unsafe fn write_words_streaming(&self, i: usize, words: [u32; 4]) {
        const { assert!(size_of::<T>() == 16) };
        assert!(i < self.len, "slot {i} of {}", self.len);
        // SAFETY: `i < len` (asserted), so the offset stays in the borrowed slice.
        let slot = unsafe { self.ptr.add(i) };
        #[cfg(target_arch = "x86_64")]
        if (slot as usize).is_multiple_of(16) {
            use std::arch::x86_64::{__m128i, _mm_stream_si128};
            // SAFETY: the slot is in bounds, 16-byte aligned (checked just above), 16 bytes (the
            // const assertion) and has no other writer (the caller's contract); four words have
            // no padding, so they are a whole vector and, by the caller's contract, a valid `T`.
            // The store is weakly ordered: the caller's fence (`stream_fence`) orders it before
            // the slot is read. SSE2, for the intrinsic, is part of every x86-64 target.
            unsafe {
                let bits = std::mem::transmute::<[u32; 4], __m128i>(words);
                _mm_stream_si128(slot.cast::<__m128i>(), bits);
            }
            return;
        }
        // SAFETY: in bounds and ours, as above; the words are a valid `T` (the caller's
        // contract); `write_unaligned` since `T` may be less aligned than the words.
        unsafe { slot.cast::<[u32; 4]>().write_unaligned(words) };
    }
}

/// Orders this thread's [`DisjointWrites::write_words_streaming`] stores before its later
/// ones, so that whoever synchronises with it afterwards (a rayon join) sees them.
#[inline]
pub fn stream_fence() {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a store fence touches no memory and has no preconditions beyond SSE, which is
    // part of every x86-64 target.
    #[allow(unsafe_code)]
    unsafe {
        std::arch::x86_64::_mm_sfence()
    };
}

/// Calls [`stream_fence`] when dropped, so that a task's streaming stores are fenced however
/// it ends, a panic included.
pub struct StreamFence;

impl Drop for StreamFence {
    fn drop(&mut self) {
        stream_fence();
    }
}

#[cfg(test)]
mod tests {
    use std::mem::MaybeUninit;

    use super::*;
    use crate::par::exclusive_scan_by;

    #[test]
    #[allow(unsafe_code)]
    fn streaming_writes_land_where_plain_ones_do() {
        /// Writes four-word slots `shift` bytes (a multiple of 4) into a 16-byte aligned buffer.
        fn check(shift: usize) {
            let n = 3 * GRAIN + 5;
            let words = |i: usize| [i as u32, !(i as u32), 7, i as u32 * 3];
            let mut backing = vec![0u128; n + 1];
            let start = backing.as_mut_ptr().cast::<u32>().wrapping_add(shift / 4);
            // SAFETY: `n` slots of four words fit in the backing store from `start`, which is
            // aligned for words, and nothing else uses the store meanwhile.
            let slots: &mut [MaybeUninit<[u32; 4]>] =
                unsafe { std::slice::from_raw_parts_mut(start.cast(), n) };
            {
                let writes = DisjointWrites::new(slots);
                chunk_offsets(n, GRAIN).par_windows(2).for_each(|w| {
                    let _fence = StreamFence;
                    // Backwards, so that the writes are not a plain sequential stream.
                    for i in (w[0]..w[1]).rev() {
                        // SAFETY: each slot is written by the one chunk that holds it; any
                        // words are a valid `MaybeUninit<[u32; 4]>`; the chunk fences before
                        // it ends.
                        unsafe { writes.write_words_streaming(i, words(i)) };
                    }
                });
            }
            // SAFETY: as above; every slot of the `n` was written, once, by the chunk that holds
            // it (`chunk_offsets` covers `0..n`), and each chunk fenced before the join
            // returned; `writes` is dropped, so nothing writes them meanwhile.
            let written: &[[u32; 4]] = unsafe { std::slice::from_raw_parts(start.cast(), n) };
            for (i, &v) in written.iter().enumerate() {
                assert_eq!(v, words(i), "slot {i}");
            }
        }
        check(0);
        check(4);
        check(12);
    }

    #[test]
    fn collected_segments_hold_their_owners_values() {
        let offsets = chunk_offsets(3 * GRAIN + 5, 7);
        let v = collect_segments(&offsets, |i| {
            (offsets[i]..offsets[i + 1]).map(move |j| (i, j))
        });
        assert_eq!(v.len(), 3 * GRAIN + 5);
        assert!(
            v.iter()
                .enumerate()
                .all(|(j, &(i, jj))| j == jj && offsets[i] <= j && j < offsets[i + 1])
        );
    }

    #[test]
    #[should_panic(expected = "too few")]
    fn short_segments_are_refused() {
        let offsets = vec![0, 3, 6];
        let _ = collect_segments(&offsets, |i| {
            (0..if i == 0 { 3 } else { 2 }).map(|x| x as u8)
        });
    }

    #[test]
    fn block_scratch_keeps_what_each_block_wrote() {
        let states: Vec<usize> = (0..37).map(|b| b * 7 % 11).collect();
        let scratch = BlockScratch::fill(10, states.par_iter(), |b, &count, out| {
            (0..count).for_each(|k| out.push((b, k)))
        });
        assert_eq!(scratch.blocks(), 37);
        for (b, &count) in states.iter().enumerate() {
            let expect: Vec<(usize, usize)> = (0..count).map(|k| (b, k)).collect();
            assert_eq!(scratch.block(b), &expect[..]);
            assert_eq!(scratch.len_of(b), count);
        }
    }

    #[test]
    // A block's writer is its stride of slots: the fifth value of a stride of three is out of
    // its bounds (a checked index, never a write past the block).
    #[should_panic(expected = "index out of bounds")]
    fn block_scratch_refuses_a_block_past_its_stride() {
        let _ = BlockScratch::fill(3, (0..2usize).into_par_iter(), |_, _, out| {
            (0..4u8).for_each(|k| out.push(k))
        });
    }

    #[test]
    fn segments_are_filled_by_their_owner() {
        let counts: Vec<u32> = (0..3 * GRAIN + 5).map(|i| (i % 4) as u32).collect();
        let offsets = exclusive_scan_by(counts.len(), |i| counts[i] as usize);
        let mut out = vec![usize::MAX; offsets[counts.len()]];
        fill_segments(&offsets, &mut out, |i, seg| {
            seg.iter_mut().for_each(|x| *x = i)
        });
        for (i, w) in offsets.windows(2).enumerate() {
            assert!(out[w[0]..w[1]].iter().all(|&x| x == i));
        }
    }
}
