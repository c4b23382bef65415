//! Sorting (key, index) pairs: three interchangeable sorts, measured in `benches/morton.rs`.

use std::ops::Range;

use rayon::prelude::*;
use voracious_radix_sort::{RadixSort, Radixable};

/// A Morton key with the input index of its point.
///
/// Ordered by key, then index, so the sorted order of distinct pairs is unique whatever sort made it.
/// Packed to 8-byte alignment: a wide pair takes 24 bytes instead of 32, and the sorts move a
/// quarter less memory.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord)]
#[repr(C, packed(8))]
pub struct Pair<K> {
    /// The point's Morton key.
    pub key: K,
    /// The point's position in the input.
    pub idx: u32,
}

impl<K> Pair<K> {
    /// A pair of a key and an input index.
    #[inline(always)]
    pub fn new(key: K, idx: u32) -> Self {
        Pair { key, idx }
    }
}

impl Radixable<u64> for Pair<u64> {
    type Key = u64;
    #[inline]
    fn key(&self) -> u64 {
        self.key
    }
}

impl Radixable<u128> for Pair<u128> {
    type Key = u128;
    #[inline]
    fn key(&self) -> u128 {
        self.key
    }
}

/// The sort used to put pairs into Morton order.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SortAlgorithm {
    /// Sequential LSD radix sort (`radsort`).
    Radsort,
    /// Parallel MSD radix sort (`voracious_radix_sort`, multithreaded): the fastest measured here.
    #[default]
    Voracious,
    /// rayon's parallel pattern-defeating quicksort.
    RayonUnstable,
}

/// Key types whose pairs the three sorts can handle.
pub trait SortPairs: Sized {
    /// Sorts pairs by key, then by index.
    fn sort_pairs(pairs: &mut [Pair<Self>], algorithm: SortAlgorithm);
    /// Sorts plain keys (radix sort, multithreaded when large).
    fn sort_keys(keys: &mut [Self]);
}

macro_rules! impl_sort_pairs {
    ($k:ty) => {
        impl SortPairs for $k {
            fn sort_pairs(pairs: &mut [Pair<$k>], algorithm: SortAlgorithm) {
                match algorithm {
                    SortAlgorithm::Radsort => radsort::sort_by_key(pairs, |p| p.key),
                    SortAlgorithm::Voracious => voracious(pairs),
                    SortAlgorithm::RayonUnstable => pairs.par_sort_unstable(),
                }
                order_equal_keys_by_index(pairs);
            }

            fn sort_keys(keys: &mut [$k]) {
                // Below the parallel cut-off, the plain LSD radix sort is the quicker one: the
                // balance sorts many such lists, one per level.
                if keys.len() < PARALLEL_SORT_CUTOFF {
                    radsort::sort(keys);
                } else {
                    voracious(keys);
                }
            }
        }
    };
}
impl_sort_pairs!(u64);
impl_sort_pairs!(u128);

/// Below this, the multithreaded radix sort's set-up costs more than it saves.
const PARALLEL_SORT_CUTOFF: usize = 1 << 16;

fn voracious<T, K>(items: &mut [T])
where
    T: Radixable<K>,
    K: voracious_radix_sort::RadixKey,
{
    let threads = rayon::current_num_threads();
    if threads > 1 && items.len() >= PARALLEL_SORT_CUTOFF {
        items.voracious_mt_sort(threads);
    } else {
        items.voracious_sort();
    }
}

/// The radix sorts order only by key; runs of equal keys (duplicate points, rare) are put in
/// index order so the result is unique.
fn order_equal_keys_by_index<K: Copy + Eq + Ord + Send + Sync>(pairs: &mut [Pair<K>]) {
    for run in equal_key_runs(pairs) {
        pairs[run].sort_unstable();
    }
}

/// The maximal runs of two or more equal keys in sorted pairs, in order.
pub fn equal_key_runs<K: Copy + Eq + Send + Sync>(pairs: &[Pair<K>]) -> Vec<Range<usize>> {
    let starts: Vec<usize> = (1..pairs.len())
        .into_par_iter()
        .filter(|&i| {
            let key = |j: usize| pairs[j].key;
            key(i) == key(i - 1) && (i == 1 || key(i - 2) != key(i))
        })
        .map(|i| i - 1)
        .collect();
    starts
        .into_iter()
        .map(|start| {
            let key = pairs[start].key;
            let len = pairs[start..]
                .iter()
                .take_while(|p| { p.key } == key)
                .count();
            start..start + len
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Vec<Pair<u64>> {
        (0..200_000u32)
            .map(|i| Pair::new((i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) % 50_000, i))
            .collect()
    }

    #[test]
    fn all_sorts_agree() {
        let mut expected = sample();
        expected.sort();
        for algorithm in [
            SortAlgorithm::Radsort,
            SortAlgorithm::Voracious,
            SortAlgorithm::RayonUnstable,
        ] {
            let mut v = sample();
            u64::sort_pairs(&mut v, algorithm);
            assert_eq!(v, expected, "{algorithm:?}");
        }
    }

    #[test]
    fn wide_keys_sort() {
        let mut v: Vec<Pair<u128>> = (0..100_000u32)
            .map(|i| {
                Pair::new(
                    ((i as u128) * 0x1234_5678_9ABC_DEF1_2345) % (1u128 << 100),
                    i,
                )
            })
            .collect();
        let mut expected = v.clone();
        expected.sort();
        u128::sort_pairs(&mut v, SortAlgorithm::Voracious);
        assert_eq!(v, expected);
    }
}
