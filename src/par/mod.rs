//! Data-parallel helpers the stages share: prefix sums for allocation ([`scan`]), filling an
//! output array whose segments belong to different input items and other parallel writes
//! ([`write`]), and fresh memory and cache hints ([`memory`]).

mod memory;
mod scan;
mod write;

pub use memory::{prefaulted_within, prefetch, with_capacity_huge};
pub use scan::{exclusive_scan_by, exclusive_scan_u32_by};
pub use write::{
    BlockScratch, DisjointWrites, SegmentWriter, SharedSlots, StreamFence, collect_indexed,
    collect_segment_pairs_by, collect_segments, collect_segments_by, collect_segments_reversed,
    collect_segments_with_capacity, concat,
};

/// Below this many items a parallel loop costs more in waking and stealing than it saves (a
/// dynamic edit's loops over the few points near it): [`filter_map`] runs it on the caller.
pub const FEW: usize = 64;

/// `items` filtered and mapped by `f`, in order: in parallel unless there are fewer than
/// [`FEW`].
pub fn filter_map<T: Sync, U: Send>(
    items: &[T],
    f: impl Fn(&T) -> Option<U> + Sync + Send,
) -> Vec<U> {
    use rayon::prelude::*;
    if items.len() < FEW {
        items.iter().filter_map(f).collect()
    } else {
        items.par_iter().filter_map(f).collect()
    }
}

/// Where each run of equal keys starts among `n` items sorted by `key`, and `n` last: the
/// segment offsets of the runs.
pub fn run_starts<K: PartialEq>(n: usize, key: impl Fn(usize) -> K + Sync) -> Vec<usize> {
    use rayon::prelude::*;
    (0..n)
        .into_par_iter()
        .filter(|&i| i == 0 || key(i) != key(i - 1))
        .chain(rayon::iter::once(n))
        .collect()
}

/// Items per task in scans and segment fills: large enough that rayon's task overhead is small.
pub const GRAIN: usize = 1 << 13;

/// Items of a fixed-size chunking, as segment offsets: `0, chunk, 2 chunk, ..., n`.
pub fn chunk_offsets(n: usize, chunk: usize) -> Vec<usize> {
    (0..n)
        .step_by(chunk.max(1))
        .chain(std::iter::once(n))
        .collect()
}
