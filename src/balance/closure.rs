//! The minimal 2:1 balanced refinement of a set of split squares, level by level.
//!
//! A full quadtree is balanced (leaves sharing a side differ in size by at most 2×) exactly when
//! every split square's four same-size edge neighbours inside the root are squares of the tree,
//! i.e. their parents are split. A split square at level `l` therefore forces its parent and the
//! parent's neighbours across the two sides it touches, all at level `l - 1`. The rule points
//! only to coarser levels, so one sweep from the finest level up reaches the least fixed point:
//! the unique smallest balanced tree containing the input, the one the sequential ripple gives.

use std::borrow::Cow;

use rayon::prelude::*;

use crate::morton::{Cell, MortonKey, Side, SortPairs};
use crate::par::{
    DisjointWrites, GRAIN, SegmentWriter, chunk_offsets, collect_indexed, collect_segments_by,
    concat, exclusive_scan_by,
};
use crate::quadtree::Internal;

/// The smallest set of split squares that contains `split`, is closed under parents, and
/// makes the quadtree balanced; in preorder.
///
/// # Complexity
/// O(k) work for k squares plus a radix sort of the few forced squares that lie outside the
/// block of the square that forces them (about one in sixteen); depth O(L log k) for L levels.
pub fn balance_closure<K: MortonKey>(split: &[Cell<K>]) -> Vec<Cell<K>> {
    preorder_of_levels(&closed_levels(split), &[])
}

/// As [`balance_closure`], each square with the first of the sorted `keys` at or after its
/// corner (as [`crate::quadtree::with_first_points`] gives, without another pass).
pub fn balance_closure_with_points<K: MortonKey>(
    split: &[Cell<K>],
    keys: &[K],
) -> Vec<Internal<K>> {
    preorder_of_levels(&closed_levels(split), keys)
}

/// The sorted anchors at each level of the balanced closure of `split`.
fn closed_levels<K: MortonKey>(split: &[Cell<K>]) -> Vec<Vec<K>> {
    let mut levels = by_level(split);
    for level in (1..levels.len()).rev() {
        if !levels[level].is_empty() {
            levels[level - 1] = with_forced(&levels[level - 1], &levels[level], level as u8);
        }
    }
    levels
}

/// The most squares of one level in a range of the preorder walk: enough that the binary
/// searches that start a range cost little beside it.
const WALK_RANGE: usize = 1 << 15;

/// A square the preorder walk puts out, given the first of its sorted keys at or after the
/// square's corner.
pub(crate) trait Walked<K: Copy>: Send {
    fn walked(cell: Cell<K>, first: usize) -> Self;
}

impl<K: Copy + Send> Walked<K> for Cell<K> {
    #[inline]
    fn walked(cell: Cell<K>, _: usize) -> Self {
        cell
    }
}

impl<K: Copy + Send> Walked<K> for Internal<K> {
    #[inline]
    fn walked(cell: Cell<K>, first: usize) -> Self {
        Internal {
            cell,
            first: first as u32,
        }
    }
}

/// The squares of sorted per-level anchor lists, closed under parents, in preorder: the
/// preorder is the order of (anchor, level), so ranges of anchors are walked depth first in
/// parallel, each into its own part of the output. Each square's first key at or after its
/// corner comes from a cursor that moves forward with the corners (none without keys).
pub(crate) fn preorder_of_levels<K: MortonKey, T: Walked<K>>(
    levels: &[Vec<K>],
    keys: &[K],
) -> Vec<T> {
    if levels.is_empty() {
        return Vec::new();
    }
    // Every level gives its every WALK_RANGE-th anchor: between two of these, each level has
    // at most WALK_RANGE squares, and the ranges follow wherever the squares are.
    let mut samples: Vec<K> = levels
        .iter()
        .flat_map(|list| list.iter().step_by(WALK_RANGE).skip(1).copied())
        .collect();
    samples.sort_unstable();
    samples.dedup();
    let mut bounds: Vec<Option<K>> = vec![None];
    bounds.extend(samples.into_iter().map(Some));
    bounds.push(None);
    let below = |bound: Option<K>, list: &[K]| {
        bound.map_or(list.len(), |b| list.partition_point(|&a| a < b))
    };
    let range = |r: usize| (bounds[r].unwrap_or_default(), bounds[r + 1]);
    let offsets = exclusive_scan_by(bounds.len() - 1, |r| {
        let (from, to) = range(r);
        levels
            .iter()
            .map(|list| below(to, list) - below(Some(from), list))
            .sum()
    });
    collect_segments_by(&offsets, |r, out| {
        let (from, to) = range(r);
        let mut walk = RangeWalk {
            levels,
            next: levels.iter().map(|list| below(Some(from), list)).collect(),
            from,
            to,
            keys,
            key: keys.partition_point(|&k| k < from),
            out,
        };
        if levels[0].first() == Some(&K::default()) {
            walk.visit(Cell::root());
        }
    })
}

/// A depth-first walk of the squares whose anchors lie in `from..to` (`to` = `None`: to the
/// end), with the next unread entry of each level at or after `from`.
struct RangeWalk<'a, 'w, K: Copy, T> {
    levels: &'a [Vec<K>],
    next: Vec<usize>,
    from: K,
    to: Option<K>,
    keys: &'a [K],
    /// The first key not below the corners walked so far.
    key: usize,
    out: &'a mut SegmentWriter<'w, T>,
}

impl<K: MortonKey, T: Walked<K>> RangeWalk<'_, '_, K, T> {
    /// Visits a square of the set that is in the range or holds its start.
    fn visit(&mut self, cell: Cell<K>) {
        if { cell.anchor } >= self.from {
            let anchor = cell.anchor;
            self.key += self.keys[self.key..]
                .iter()
                .take_while(|&&k| k < anchor)
                .count();
            self.out.push(T::walked(cell, self.key));
        }
        let level = cell.level as usize + 1;
        let Some(list) = self.levels.get(level) else {
            return;
        };
        for quadrant in 0..4 {
            let child = cell.child(quadrant);
            let anchor = child.anchor;
            if self.to.is_some_and(|to| anchor >= to) {
                return;
            }
            let present = if anchor >= self.from {
                let hit = list.get(self.next[level]) == Some(&anchor);
                self.next[level] += usize::from(hit);
                hit
            } else {
                // Before the range: only the square that holds its start is walked.
                child.contains(self.from) && list.binary_search(&anchor).is_ok()
            };
            if present {
                self.visit(child);
            }
        }
    }
}

/// Sorted, distinct anchors of the squares at each level `0..=AXIS_BITS`. In preorder (the
/// usual input, checked) each level's squares already come in order, so they are only
/// distributed, in parallel: each chunk counts its squares per level, then writes them at the
/// places those counts give.
pub(crate) fn by_level<K: MortonKey>(split: &[Cell<K>]) -> Vec<Vec<K>> {
    let key = |c: &Cell<K>| (c.anchor, c.level);
    let sorted: Cow<[Cell<K>]> = if split.par_windows(2).all(|w| key(&w[0]) < key(&w[1])) {
        Cow::Borrowed(split)
    } else {
        let mut cells = split.to_vec();
        cells.par_sort_unstable_by_key(key);
        cells.dedup();
        Cow::Owned(cells)
    };
    let level_count = K::AXIS_BITS as usize + 1;
    let chunks = chunk_offsets(sorted.len(), GRAIN);
    let counts: Vec<Vec<usize>> = (0..chunks.len() - 1)
        .into_par_iter()
        .map(|c| {
            let mut count = vec![0; level_count];
            for cell in &sorted[chunks[c]..chunks[c + 1]] {
                count[cell.level as usize] += 1;
            }
            count
        })
        .collect();
    // Where each chunk starts writing at each level, and each level's size.
    let mut starts = counts;
    let mut totals = vec![0; level_count];
    for chunk in &mut starts {
        for (start, total) in chunk.iter_mut().zip(&mut totals) {
            (*start, *total) = (*total, *total + *start);
        }
    }
    let mut levels: Vec<Vec<K>> = totals.iter().map(|&n| vec![K::default(); n]).collect();
    let slots: Vec<DisjointWrites<K>> = levels.iter_mut().map(|l| DisjointWrites::new(l)).collect();
    starts.into_par_iter().enumerate().for_each(|(c, mut at)| {
        for cell in &sorted[chunks[c]..chunks[c + 1]] {
            let level = cell.level as usize;
            // SAFETY: the chunks' ranges at each level are disjoint, from the prefix sums.
            #[allow(unsafe_code)]
            unsafe {
                slots[level].write(at[level], cell.anchor)
            };
            at[level] += 1;
        }
    });
    drop(slots);
    levels
}

/// Levels between the forced squares and the blocks they are marked in: a block holds
/// `4^BLOCK_DEPTH` squares, one bit each, and a square's neighbour leaves its block across one
/// side in `2^-BLOCK_DEPTH` of cases.
const BLOCK_DEPTH: u8 = 5;

// A block's bitmap is whole words, and one bit of a word mask says which it has touched.
const _: () = assert!(BLOCK_DEPTH >= 3 && BLOCK_DEPTH <= 6);

/// Words of a block's bitmap.
const BLOCK_WORDS: usize = 1 << (2 * BLOCK_DEPTH - 6);

/// The squares at `level - 1`: `existing` (sorted, distinct anchors) and those that the split
/// squares at `level` (sorted, distinct anchors) force, sorted and distinct. Each block of
/// squares at `level - 1` is a bitmap: parents and their neighbours inside the block are marked,
/// and read back in Morton order, so only the few neighbours in other blocks need a sort. Each
/// chunk of blocks then merges in the existing squares and those others that fall among its
/// blocks, so the level is written once more, not once per union.
pub(crate) fn with_forced<K: MortonKey>(existing: &[K], anchors: &[K], level: u8) -> Vec<K> {
    if anchors.is_empty() {
        return existing.to_vec();
    }
    let depth = BLOCK_DEPTH.min(level - 1);
    let block_level = level - 1 - depth;
    let block_of = |i: usize| anchors[i].cell_anchor(block_level);
    // Chunks of whole blocks: each bound moves on to the next block's start.
    let mut bounds: Vec<usize> = chunk_offsets(anchors.len(), GRAIN);
    for b in &mut bounds[1..] {
        while *b < anchors.len() && *b > 0 && block_of(*b) == block_of(*b - 1) {
            *b += 1;
        }
    }
    bounds.dedup();
    let chunks = bounds.len() - 1;
    let (inside, others): (Vec<Vec<K>>, Vec<Vec<K>>) = (0..chunks)
        .into_par_iter()
        .map(|c| forced_in_blocks(&anchors[bounds[c]..bounds[c + 1]], level, depth))
        .unzip();
    let mut others = concat(&others);
    sort_anchors(&mut others, level - 1);
    // Chunk c takes the keys from its first block's corner (the first chunk: from the start) to
    // the next chunk's (the last: to the end).
    let cut = |list: &[K], c: usize| match c {
        0 => 0,
        c if c == chunks => list.len(),
        c => {
            let corner = block_of(bounds[c]);
            list.partition_point(|&a| a < corner)
        }
    };
    let parts: Vec<Vec<K>> = (0..chunks)
        .into_par_iter()
        .map(|c| {
            let existing = &existing[cut(existing, c)..cut(existing, c + 1)];
            let others = &others[cut(&others, c)..cut(&others, c + 1)];
            match others {
                [] => merge_distinct(&inside[c], existing),
                _ => merge_distinct(&inside[c], &merge_distinct(existing, others)),
            }
        })
        .collect();
    concat(&parts)
}

/// For sorted squares at `level` in whole blocks (squares `depth` levels above their parents):
/// the squares they force inside those blocks, sorted and distinct, and those they force in
/// other blocks, unsorted and possibly repeated.
///
/// Which sides a square touches is close to random, so the marking selects instead of
/// branching on it; only a neighbour outside the block takes a branch.
fn forced_in_blocks<K: MortonKey>(anchors: &[K], level: u8, depth: u8) -> (Vec<K>, Vec<K>) {
    let below = 2 * (K::AXIS_BITS - level as u32);
    let child_bits = 2 * (u32::from(depth) + 1);
    let y_bits = 0x5555_5555 & ((1u32 << (2 * depth)) - 1);
    let x_bits = y_bits << 1;
    let mut block = Bitmap::default();
    let mut inside: Vec<K> = Vec::with_capacity(anchors.len());
    let mut others: Vec<K> = Vec::new();
    let Some(&first) = anchors.first() else {
        return (inside, others);
    };
    // A square's digits down to `level`: the lowest `child_bits` of them place it in its
    // block, and the rest name the block.
    let mut block_digits = first.to_u128() >> below >> child_bits;
    for &anchor in anchors {
        let digits = anchor.to_u128() >> below;
        if digits >> child_bits != block_digits {
            block.read(block_digits << (child_bits - 2), below + 2, &mut inside);
            block_digits = digits >> child_bits;
        }
        let in_block = digits as u32 & ((1 << child_bits) - 1);
        let (parent, quadrant) = (in_block >> 2, in_block & 3);
        let (x, y) = (parent & x_bits, parent & y_bits);
        // East or west by the square's x bit, north or south by its y bit; a carry or borrow
        // out of the block's bits means the neighbour is in another block.
        let east = ((parent | y_bits) + 2) & x_bits;
        let north = ((parent | x_bits) + 1) & y_bits;
        let west = x.wrapping_sub(2) & x_bits;
        let south = y.wrapping_sub(1) & y_bits;
        let to_east = quadrant & 2 != 0;
        let to_north = quadrant & 1 != 0;
        let (across_x, in_x) = if to_east {
            (east, east > x)
        } else {
            (west, x != 0)
        };
        let (across_y, in_y) = if to_north {
            (north, north > y)
        } else {
            (south, y != 0)
        };
        block.mark(parent, true);
        block.mark(across_x | y, in_x);
        block.mark(across_y | x, in_y);
        if !(in_x && in_y) {
            let cell = Cell { anchor, level };
            let (beside, in_root) = cell.parent().neighbour_anchors();
            for (side, in_block) in touched_sides(cell).into_iter().zip([in_x, in_y]) {
                if !in_block && in_root & 1 << side as u8 != 0 {
                    others.push(beside[side as usize]);
                }
            }
        }
    }
    block.read(block_digits << (child_bits - 2), below + 2, &mut inside);
    (inside, others)
}

/// One bit for each square of a block, and which of its words have any set, so a block with few
/// squares is read back in few steps.
struct Bitmap {
    words: [u64; BLOCK_WORDS],
    touched: u64,
}

impl Default for Bitmap {
    fn default() -> Self {
        Bitmap {
            words: [0; BLOCK_WORDS],
            touched: 0,
        }
    }
}

impl Bitmap {
    /// Sets bit `at` when `set`.
    #[inline]
    fn mark(&mut self, at: u32, set: bool) {
        let word = at as usize / 64;
        self.words[word] |= u64::from(set) << (at % 64);
        self.touched |= u64::from(set) << word;
    }

    /// Appends the squares marked, in Morton order, and clears the bitmap. A square's anchor is
    /// `corner` (the block's digits, shifted to leave room for the square's own) with its bit's
    /// index, shifted up by `span_bits`, the bits below a square of its level.
    fn read<K: MortonKey>(&mut self, corner: u128, span_bits: u32, out: &mut Vec<K>) {
        let mut touched = std::mem::take(&mut self.touched);
        while touched != 0 {
            let w = touched.trailing_zeros() as usize;
            touched &= touched - 1;
            let mut rest = std::mem::take(&mut self.words[w]);
            while rest != 0 {
                let digits = corner | (w as u128) << 6 | u128::from(rest.trailing_zeros());
                // The root's one square has no digits (and a shift as wide as the key).
                out.push(K::from_u128(digits.checked_shl(span_bits).unwrap_or(0)));
                rest &= rest - 1;
            }
        }
    }
}

/// The two sides of its parent that a square touches.
fn touched_sides<K: MortonKey>(cell: Cell<K>) -> [Side; 2] {
    let q = cell.quadrant();
    let across_x = if q & 2 == 0 { Side::West } else { Side::East };
    let across_y = if q & 1 == 0 { Side::South } else { Side::North };
    [across_x, across_y]
}

/// What one split square forces: its parent, and the parent's neighbours across the two sides
/// of the parent that the square touches (none outside the root).
pub fn forced_by<K: MortonKey>(cell: Cell<K>) -> [Option<Cell<K>>; 3] {
    let parent = cell.parent();
    let [across_x, across_y] = touched_sides(cell);
    [
        Some(parent),
        parent.neighbour(across_x),
        parent.neighbour(across_y),
    ]
}

/// Sorts anchors of squares at `level` and drops repeats. Their low bits are zero, so wide
/// keys down to level 32 sort as 64-bit numbers, in half the radix passes.
fn sort_anchors<K: MortonKey>(anchors: &mut Vec<K>, level: u8) {
    if K::AXIS_BITS > 32 && (1..=32).contains(&level) {
        let shift = 2 * (K::AXIS_BITS - level as u32);
        let mut narrow: Vec<u64> =
            collect_indexed(anchors.len(), |i| (anchors[i].to_u128() >> shift) as u64);
        u64::sort_keys(&mut narrow);
        narrow.dedup();
        *anchors = collect_indexed(narrow.len(), |i| {
            K::from_u128(u128::from(narrow[i]) << shift)
        });
    } else {
        K::sort_keys(anchors);
        anchors.dedup();
    }
}

/// The sorted union of two sorted, distinct lists.
fn merge_distinct<K: MortonKey>(a: &[K], b: &[K]) -> Vec<K> {
    let mut out = Vec::with_capacity(a.len() + b.len());
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        let next = a[i].min(b[j]);
        out.push(next);
        i += usize::from(a[i] == next);
        j += usize::from(b[j] == next);
    }
    out.extend_from_slice(&a[i..]);
    out.extend_from_slice(&b[j..]);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn anchors_sort_alike_narrowed_or_not() {
        let key = |i: u64| {
            let hi = i.wrapping_mul(0x9E37_79B9_7F4A_7C15);
            u128::from(hi) << 64 | u128::from(hi.rotate_left(29) ^ i)
        };
        for level in [0u8, 1, 7, 20, 32, 33, 50, 64] {
            // Both sides of the parallel sort's cut-off, with repeats.
            for n in [3000u64, 70_000] {
                let mut anchors: Vec<u128> = (0..n)
                    .map(|i| Cell::<u128>::containing(key(i % (n - 100)), level).anchor)
                    .collect();
                let mut expected = anchors.clone();
                expected.sort_unstable();
                expected.dedup();
                sort_anchors(&mut anchors, level);
                assert_eq!(anchors, expected, "level {level}, {n} keys");
            }
        }
    }

    #[test]
    fn merging_keeps_one_of_each() {
        assert_eq!(
            merge_distinct::<u64>(&[1, 3, 5], &[2, 3, 6]),
            vec![1, 2, 3, 5, 6]
        );
        assert_eq!(merge_distinct::<u64>(&[], &[2]), vec![2]);
        assert_eq!(merge_distinct::<u64>(&[4], &[]), vec![4]);
        assert_eq!(merge_distinct::<u64>(&[], &[]), Vec::<u64>::new());
    }

    #[test]
    fn the_walk_gives_the_preorder_across_many_ranges() {
        // Random squares at levels 9 to 14 and all their ancestors: the finest level alone spans
        // several walk ranges.
        let mut cells: Vec<Cell<u64>> = (0..120_000u64)
            .flat_map(|i| {
                let key = i.wrapping_mul(0x9E37_79B9_7F4A_7C15).rotate_left(17);
                let level = 9 + (i % 6) as u8;
                (0..=level).map(move |l| Cell::containing(key, l))
            })
            .collect();
        cells.sort_unstable_by_key(|c| (c.anchor, c.level));
        cells.dedup();
        let levels = by_level(&cells);
        assert!(levels.iter().map(Vec::len).max().unwrap() > 2 * WALK_RANGE);
        assert_eq!(preorder_of_levels::<u64, Cell<u64>>(&levels, &[]), cells);
        // With keys, each square gets the first at or after its corner.
        let keys: Vec<u64> = (0..50_000u64)
            .map(|i| i.wrapping_mul(0xD1B5_4A32_D192_ED03))
            .collect::<std::collections::BTreeSet<_>>()
            .into_iter()
            .collect();
        let with_points: Vec<Internal<u64>> = preorder_of_levels(&levels, &keys);
        assert_eq!(
            with_points,
            crate::quadtree::with_first_points(&cells, &keys)
        );
    }

    /// What `with_forced` must give: the existing squares, and each square's parent and the
    /// parent's neighbours across the sides the square touches, sorted and distinct.
    fn forced_one_by_one<K: MortonKey>(existing: &[K], anchors: &[K], level: u8) -> Vec<K> {
        let mut forced: Vec<K> = anchors
            .iter()
            .flat_map(|&anchor| forced_by(Cell { anchor, level }))
            .flatten()
            .map(|c| c.anchor)
            .chain(existing.iter().copied())
            .collect();
        forced.sort_unstable();
        forced.dedup();
        forced
    }

    fn forced_alike_at_every_level<K: MortonKey>(key: impl Fn(u64) -> K) {
        for level in 1..=K::AXIS_BITS as u8 {
            // Scattered squares (neighbours in their own blocks and in others), runs of
            // consecutive squares (filled blocks), and the root's corners and sides (none
            // beyond), in more chunks than one.
            let mut anchors: Vec<K> = (0..30_000u64)
                .map(|i| Cell::containing(key(i), level).anchor)
                .chain((0..20u64).flat_map(|r| {
                    let base = Cell::containing(key(r * 1000 + 1), level).anchor.to_u128();
                    let step = 1u128 << (2 * (K::AXIS_BITS - level as u32));
                    let last = u128::MAX >> (128 - 2 * K::AXIS_BITS);
                    (0..600u128)
                        .map_while(move |j| {
                            let anchor = j.checked_mul(step).and_then(|d| base.checked_add(d));
                            anchor.filter(|&a| a <= last)
                        })
                        .map(K::from_u128)
                }))
                .chain((0..4000u64).map(|i| {
                    let side = 1u64 << (K::AXIS_BITS - level as u32).min(63);
                    let last = (1u128 << K::AXIS_BITS) - 1;
                    let along = (u128::from(i) * u128::from(side)).min(last) as u64;
                    let edge = last as u64;
                    let (x, y) =
                        [(along, 0), (0, along), (along, edge), (edge, along)][i as usize % 4];
                    Cell::containing(K::encode(x, y), level).anchor
                }))
                .collect();
            anchors.sort_unstable();
            anchors.dedup();
            // Squares already at the level above: some forced again, some not, before, among
            // and after the forced ones.
            let mut existing: Vec<K> = (0..9000u64)
                .map(|i| Cell::containing(key(i * 7 + 3), level - 1).anchor)
                .chain([K::default()])
                .collect();
            existing.sort_unstable();
            existing.dedup();
            for existing in [&existing[..], &[]] {
                assert_eq!(
                    with_forced(existing, &anchors, level),
                    forced_one_by_one(existing, &anchors, level),
                    "level {level}"
                );
            }
        }
    }

    #[test]
    fn blocks_force_what_squares_force_one_by_one() {
        forced_alike_at_every_level(|i| {
            (i % 20_000)
                .wrapping_mul(0x9E37_79B9_7F4A_7C15)
                .rotate_left(31)
                ^ i
        });
        forced_alike_at_every_level(|i| {
            let hi = i.wrapping_mul(0x9E37_79B9_7F4A_7C15);
            (u128::from(hi) << 64 | u128::from(hi.rotate_left(29))) ^ u128::from(i) << 60
        });
    }

    #[test]
    fn input_order_does_not_matter() {
        let cells: Vec<Cell<u64>> = (0..500u64)
            .map(|i| Cell::containing(i.wrapping_mul(0x9E37_79B9_7F4A_7C15), (i % 9 + 3) as u8))
            .collect();
        let mut reversed = cells.clone();
        reversed.reverse();
        reversed.extend_from_slice(&cells[..50]);
        assert_eq!(balance_closure(&cells), balance_closure(&reversed));
        assert_eq!(
            balance_closure(&cells),
            crate::balance::reference::ripple_closure(&cells)
        );
    }

    #[test]
    fn a_deep_corner_square_forces_a_staircase() {
        // One split square at level 6 in the middle of the root forces squares at every level.
        let deep = Cell::<u64>::containing(u64::encode(1 << 31, 1 << 31), 6);
        let closed = balance_closure(&[deep]);
        for level in 0..6 {
            assert!(closed.iter().any(|c| c.level == level), "level {level}");
        }
        assert!(
            closed
                .windows(2)
                .all(|w| (w[0].anchor, w[0].level) < (w[1].anchor, w[1].level))
        );
    }
}
