//! All nearest smaller values over small integer values (quadtree levels), in parallel with
//! O(n + P·V) work for P blocks and V distinct values.
//!
//! Each block is scanned with a stack on its own; an element whose stack runs empty looks its
//! answer up in a table of "nearest earlier index with value ≤ t" at the block's start, made by a
//! prefix over per-block tables. The answer is unique, so it does not depend on the blocking.

use rayon::prelude::*;

use crate::par::{chunk_offsets, collect_segments, collect_segments_reversed};

/// No such index.
pub use crate::domain::NONE;

/// Values this module accepts: quadtree levels, at most 64.
pub const VALUE_LIMIT: usize = 65;

/// Elements per block: enough to amortize the per-block table of `VALUE_LIMIT` entries.
pub(crate) const BLOCK: usize = 1 << 13;

/// For each `i`, the largest `j < i` with `values[j] < values[i]`, or [`NONE`].
///
/// # Panics
/// If a value is `VALUE_LIMIT` or more (callers pass levels, which never are).
pub fn nearest_smaller_left(values: &[u8]) -> Vec<u32> {
    nearest_smaller(values, Side::Left, Bound::Strict)
}

/// For each `i`, the smallest `j > i` with `values[j] < values[i]`, or [`NONE`].
pub fn nearest_smaller_right(values: &[u8]) -> Vec<u32> {
    nearest_smaller(values, Side::Right, Bound::Strict)
}

/// For each `i`, the smallest `j > i` with `values[j] <= values[i]`, or [`NONE`].
pub fn nearest_at_most_right(values: &[u8]) -> Vec<u32> {
    nearest_smaller(values, Side::Right, Bound::Inclusive)
}

/// Whether equal values count as smaller.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Bound {
    Strict,
    Inclusive,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Side {
    Left,
    Right,
}

fn nearest_smaller(values: &[u8], side: Side, bound: Bound) -> Vec<u32> {
    let tables = outside_tables(values, side);
    let offsets = chunk_offsets(values.len(), BLOCK);
    let block = |b: usize| {
        let range = offsets[b]..offsets[b + 1];
        scan_block(range.start, &values[range], &tables[b], side, bound)
    };
    match side {
        Side::Left => collect_segments(&offsets, block),
        // The right-hand scan runs from the block's end, so it fills the block backwards.
        Side::Right => collect_segments_reversed(&offsets, block),
    }
}

/// Per block of [`BLOCK`] values, the table `t -> smallest index after the block with value ≤ t`,
/// as `index + 1` (0 for none).
pub(crate) fn tables_after_blocks(values: &[u8]) -> Vec<[u32; VALUE_LIMIT]> {
    outside_tables(values, Side::Right)
}

/// Per block of [`BLOCK`] values, the table `t -> largest index before the block with value ≤ t`,
/// as `index + 1` (0 for none).
pub(crate) fn tables_before_blocks(values: &[u8]) -> Vec<[u32; VALUE_LIMIT]> {
    outside_tables(values, Side::Left)
}

/// Per block, the table `t -> nearest index outside the block on `side` with value ≤ t`
/// (as `index + 1`, 0 for none): a prefix (or suffix) over per-block tables.
fn outside_tables(values: &[u8], side: Side) -> Vec<[u32; VALUE_LIMIT]> {
    let inside: Vec<[u32; VALUE_LIMIT]> = values
        .par_chunks(BLOCK)
        .enumerate()
        .map(|(b, vals)| nearest_at_most(b * BLOCK, vals, side))
        .collect();
    let mut outside = vec![[0u32; VALUE_LIMIT]; inside.len()];
    let mut running = [0u32; VALUE_LIMIT];
    let mut carry = |b: usize| {
        outside[b] = running;
        for (r, &v) in running.iter_mut().zip(&inside[b]) {
            *r = merge(side, *r, v);
        }
    };
    match side {
        Side::Left => (0..inside.len()).for_each(&mut carry),
        Side::Right => (0..inside.len()).rev().for_each(&mut carry),
    }
    outside
}

/// The nearer of two table entries (`index + 1`, 0 for none) as seen from the `side` blocks.
fn merge(side: Side, a: u32, b: u32) -> u32 {
    match side {
        Side::Left => a.max(b),
        Side::Right if a == 0 || b == 0 => a.max(b),
        Side::Right => a.min(b),
    }
}

/// For one block: `t -> the index with value ≤ t nearest to the block's far `side` edge
/// (rightmost for Left, leftmost for Right), as `index + 1`, 0 for none.
fn nearest_at_most(start: usize, vals: &[u8], side: Side) -> [u32; VALUE_LIMIT] {
    let mut table = [0u32; VALUE_LIMIT];
    let mut record = |(i, &v): (usize, &u8)| table[v as usize] = (start + i + 1) as u32;
    match side {
        Side::Left => vals.iter().enumerate().for_each(&mut record),
        Side::Right => vals.iter().enumerate().rev().for_each(&mut record),
    }
    for t in 1..VALUE_LIMIT {
        table[t] = merge(side, table[t], table[t - 1]);
    }
    table
}

/// Stack scan of one block, starting from the end opposite `side`; elements with no smaller value
/// inside the block read the table of the blocks beyond. Yields the answers in scan order.
fn scan_block<'a>(
    start: usize,
    vals: &'a [u8],
    outside: &'a [u32; VALUE_LIMIT],
    side: Side,
    bound: Bound,
) -> impl Iterator<Item = u32> + 'a {
    let order: Box<dyn Iterator<Item = usize>> = match side {
        Side::Left => Box::new(0..vals.len()),
        Side::Right => Box::new((0..vals.len()).rev()),
    };
    let mut stack: Vec<u32> = Vec::with_capacity(VALUE_LIMIT);
    order.map(move |i| {
        let v = vals[i];
        let blocks = |top: u8| match bound {
            Bound::Strict => top < v,
            Bound::Inclusive => top <= v,
        };
        while stack.last().is_some_and(|&top| !blocks(vals[top as usize])) {
            stack.pop();
        }
        let answer = match (stack.last(), bound) {
            (Some(&top), _) => (start + top as usize) as u32,
            (None, Bound::Inclusive) => outside[v as usize].wrapping_sub(1),
            (None, Bound::Strict) if v == 0 => NONE,
            (None, Bound::Strict) => outside[v as usize - 1].wrapping_sub(1),
        };
        stack.push(i as u32);
        answer
    })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// The sequential stack: the oracle.
    pub(crate) fn reference_left(values: &[u8]) -> Vec<u32> {
        let mut stack: Vec<usize> = Vec::new();
        values
            .iter()
            .enumerate()
            .map(|(i, &v)| {
                while stack.last().is_some_and(|&t| values[t] >= v) {
                    stack.pop();
                }
                let answer = stack.last().map_or(NONE, |&t| t as u32);
                stack.push(i);
                answer
            })
            .collect()
    }

    fn reference_right(values: &[u8]) -> Vec<u32> {
        (0..values.len())
            .map(|i| {
                (i + 1..values.len())
                    .find(|&j| values[j] < values[i])
                    .map_or(NONE, |j| j as u32)
            })
            .collect()
    }

    fn families(n: usize) -> Vec<Vec<u8>> {
        let mut s = 0x2545_F491_4F6C_DD1Du64;
        let mut rnd = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s
        };
        vec![
            (0..n).map(|_| (rnd() % 5) as u8).collect(),
            (0..n).map(|_| (rnd() % 65) as u8).collect(),
            (0..n).map(|i| (i % 64) as u8).collect(),
            (0..n).map(|i| 64 - (i % 65) as u8).collect(),
            vec![7; n],
            (0..n).map(|i| ((i * 7) % 13) as u8).collect(),
        ]
    }

    #[test]
    fn matches_the_sequential_stack() {
        for n in [0, 1, 2, 3, 100, BLOCK - 1, BLOCK, BLOCK + 1, 5 * BLOCK + 17] {
            for values in families(n) {
                assert_eq!(
                    nearest_smaller_left(&values),
                    reference_left(&values),
                    "n={n}"
                );
                if n <= 2 * BLOCK {
                    assert_eq!(
                        nearest_smaller_right(&values),
                        reference_right(&values),
                        "n={n}"
                    );
                } else {
                    let rev: Vec<u8> = values.iter().rev().copied().collect();
                    let expect: Vec<u32> = reference_left(&rev)
                        .into_iter()
                        .rev()
                        .map(|j| {
                            if j == NONE {
                                NONE
                            } else {
                                (n - 1 - j as usize) as u32
                            }
                        })
                        .collect();
                    assert_eq!(nearest_smaller_right(&values), expect);
                }
            }
        }
    }

    #[test]
    fn inclusive_right_matches_brute_force() {
        for n in [0, 1, 7, BLOCK + 3, 3 * BLOCK + 1] {
            for values in families(n) {
                let expect: Vec<u32> = (0..n)
                    .map(|i| {
                        (i + 1..n)
                            .find(|&j| values[j] <= values[i])
                            .map_or(NONE, |j| j as u32)
                    })
                    .collect();
                assert_eq!(nearest_at_most_right(&values), expect, "n={n}");
            }
        }
    }

    #[test]
    fn same_answer_on_one_thread() {
        let values = families(4 * BLOCK + 3).remove(1);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let one = pool.install(|| nearest_smaller_left(&values));
        assert_eq!(one, nearest_smaller_left(&values));
    }
}
