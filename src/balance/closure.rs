//! The minimal 2:1 balanced refinement of a set of split squares, level by level.
//!
//! A full quadtree is balanced (leaves sharing a side differ in size by at most 2×) exactly when
//! every split square's four same-size edge neighbours inside the root are squares of the tree,
//! i.e. their parents are split. A split square at level `l` therefore forces its parent and the
//! parent's neighbours across the two sides it touches, all at level `l - 1`. The rule points
//! only to coarser levels, so one sweep from the finest level up reaches the least fixed point:
//! the unique smallest balanced tree containing the input, the one the sequential ripple gives.

use std::mem::MaybeUninit;

use rayon::prelude::*;

use crate::morton::{Cell, MortonKey, NARROW_LEVEL, Side, in_width};
use crate::par::{
    DisjointWrites, GRAIN, SegmentWriter, chunk_offsets, collect_segments_by, concat,
    exclusive_scan_by, with_capacity_huge,
};
use crate::quadtree::{HasCell, Internal, first_not_below};

/// The smallest set of split squares that contains `split`, is closed under parents, and
/// makes the quadtree balanced; in preorder.
///
/// # Complexity
/// O(k) work for k squares plus a radix sort of the few forced squares that lie outside the
/// block of the square that forces them (about one in sixteen); depth O(L log k) for L levels.
pub fn balance_closure<K: MortonKey, S: HasCell<K>>(split: &[S]) -> Vec<Cell<K>> {
    preorder_of_levels(&closed_levels(split), &[])
}

/// As [`balance_closure`], each square with the first of the sorted `keys` at or after its
/// corner (as [`crate::quadtree::with_first_points`] gives, without another pass).
pub fn balance_closure_with_points<K: MortonKey, S: HasCell<K>>(
    split: &[S],
    keys: &[K],
) -> Vec<Internal<K>> {
    preorder_of_levels(&closed_levels(split), keys)
}

/// The sorted anchors at each level of the balanced closure of `split`.
fn closed_levels<K: MortonKey, S: HasCell<K>>(split: &[S]) -> Levels<K> {
    let Levels {
        mut narrow,
        mut deep,
    } = by_level(split);
    // Up the deep levels in the key's width, into the finest narrow level, then up to the root
    // in 64 bits.
    for i in (1..deep.len()).rev() {
        if !deep[i].is_empty() {
            deep[i - 1] = with_forced(&deep[i - 1], &deep[i], (NARROW_LEVEL + 1 + i) as u8);
        }
    }
    if let Some(finest) = deep.first().filter(|list| !list.is_empty()) {
        let level = NARROW_LEVEL as u8 + 1;
        narrow[NARROW_LEVEL] = with_forced(&narrow[NARROW_LEVEL], finest, level);
    }
    for level in (1..narrow.len()).rev() {
        if !narrow[level].is_empty() {
            narrow[level - 1] = with_forced(&narrow[level - 1], &narrow[level], level as u8);
        }
    }
    Levels { narrow, deep }
}

/// The sorted, distinct anchors of the squares at each level: in 64 bits (see [`in_width`])
/// down to [`NARROW_LEVEL`], in the key's own width below it.
pub(crate) struct Levels<K> {
    /// Levels `0..=NARROW_LEVEL`.
    narrow: Vec<Vec<u64>>,
    /// Levels `NARROW_LEVEL + 1..=K::AXIS_BITS`; none for narrow keys.
    deep: Vec<Vec<K>>,
}

impl<K: MortonKey> Levels<K> {
    /// No anchors, with room for `sizes[level]` at each level `0..=K::AXIS_BITS`.
    fn with_capacities(sizes: &[usize]) -> Self {
        let (narrow, deep) = sizes.split_at(NARROW_LEVEL + 1);
        Levels {
            narrow: narrow.iter().map(|&n| with_capacity_huge(n)).collect(),
            deep: deep.iter().map(|&n| with_capacity_huge(n)).collect(),
        }
    }

    /// The number of levels, `K::AXIS_BITS + 1`.
    fn count(&self) -> usize {
        self.narrow.len() + self.deep.len()
    }

    /// The number of squares at `level`.
    fn len_at(&self, level: usize) -> usize {
        match level.checked_sub(NARROW_LEVEL + 1) {
            None => self.narrow[level].len(),
            Some(i) => self.deep[i].len(),
        }
    }

    /// The number of squares at `level` whose anchors are below `bound`.
    fn below(&self, level: usize, bound: K) -> usize {
        match level.checked_sub(NARROW_LEVEL + 1) {
            None => self.narrow[level].partition_point(|&a| in_width::<u64, K>(a) < bound),
            Some(i) => self.deep[i].partition_point(|&a| a < bound),
        }
    }

    /// Each level's every `step`-th anchor after its first, sorted and distinct.
    fn samples(&self, step: usize) -> Vec<K> {
        let narrow = self.narrow.iter().flat_map(|list| {
            let sampled = list.iter().step_by(step).skip(1);
            sampled.map(|&a| in_width::<u64, K>(a))
        });
        let deep = self
            .deep
            .iter()
            .flat_map(|list| list.iter().step_by(step).skip(1).copied());
        let mut samples: Vec<K> = narrow.chain(deep).collect();
        samples.sort_unstable();
        samples.dedup();
        samples
    }
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
    levels: &Levels<K>,
    keys: &[K],
) -> Vec<T> {
    // Every level gives its every WALK_RANGE-th anchor: between two of these, each level has
    // at most WALK_RANGE squares, and the ranges follow wherever the squares are.
    let mut bounds: Vec<Option<K>> = vec![None];
    bounds.extend(levels.samples(WALK_RANGE).into_iter().map(Some));
    bounds.push(None);
    let below = |bound: Option<K>, level: usize| {
        bound.map_or(levels.len_at(level), |b| levels.below(level, b))
    };
    let range = |r: usize| (bounds[r].unwrap_or_default(), bounds[r + 1]);
    let offsets = exclusive_scan_by(bounds.len() - 1, |r| {
        let (from, to) = range(r);
        (0..levels.count())
            .map(|level| below(to, level) - below(Some(from), level))
            .sum()
    });
    collect_segments_by(&offsets, |r, out| {
        let (from, to) = range(r);
        let mut walk = RangeWalk {
            levels,
            next: (0..levels.count())
                .map(|level| below(Some(from), level))
                .collect(),
            narrow_path: [0; NARROW_LEVEL + 1],
            deep_path: vec![K::default(); levels.deep.len()],
            to,
            keys,
            key: keys.partition_point(|&k| k < from),
            out,
        };
        walk.run(from);
    })
}

/// A preorder walk of the squares whose anchors lie in `from..to` (`to` = `None`: to the end).
/// From the square it is at, the walk goes down to the next unread square of the level below
/// if that is a child, and up a level if not: about two steps a square, each one comparison.
struct RangeWalk<'a, 'w, K: Copy, T> {
    levels: &'a Levels<K>,
    /// By level, the next unread square, from the first at or after `from`.
    next: Vec<usize>,
    /// The anchors of the squares on the path from the root, by level, in the widths of their
    /// levels' lists (see [`Levels`]).
    narrow_path: [u64; NARROW_LEVEL + 1],
    deep_path: Vec<K>,
    to: Option<K>,
    keys: &'a [K],
    /// The first key not below the corners walked so far.
    key: usize,
    out: &'a mut SegmentWriter<'w, T>,
}

/// Where a step of the walk goes.
enum Step {
    Down,
    Up,
    End,
}

impl<K: MortonKey, T: Walked<K>> RangeWalk<'_, '_, K, T> {
    /// Puts out the range's squares in preorder, from the path's square that holds `from`.
    fn run(&mut self, from: K) {
        let Some(mut level) = self.enter(from) else {
            return;
        };
        loop {
            match self.step(level) {
                Step::Down => level += 1,
                Step::Up if level > 0 => level -= 1,
                _ => return,
            }
        }
    }

    /// Puts the walk at the deepest square that holds `from` and lies before it (an earlier
    /// range walked it), or at the root, put out, when `from` is zero; returns its level (none
    /// without squares).
    fn enter(&mut self, from: K) -> Option<usize> {
        if self.levels.narrow[0].first() != Some(&0) {
            return None;
        }
        if from == K::default() {
            self.out.push(T::walked(Cell::root(), self.key));
            return Some(0);
        }
        let mut level = 0;
        while level + 1 < self.levels.count() {
            let anchor = from.cell_anchor(level as u8 + 1);
            if anchor == from || !self.enter_at(level + 1, anchor) {
                break;
            }
            level += 1;
        }
        Some(level)
    }

    /// Makes `anchor`'s square at `level` the path's square there; whether it is one of the
    /// set.
    fn enter_at(&mut self, level: usize, anchor: K) -> bool {
        match level.checked_sub(NARROW_LEVEL + 1) {
            None => {
                let narrow: u64 = in_width(anchor);
                self.narrow_path[level] = narrow;
                self.levels.narrow[level].binary_search(&narrow).is_ok()
            }
            Some(i) => {
                self.deep_path[i] = anchor;
                self.levels.deep[i].binary_search(&anchor).is_ok()
            }
        }
    }

    /// From the path's square at `level`: down to the next unread square of the level below if
    /// that is its child (and in the range), up if not.
    #[inline]
    fn step(&mut self, level: usize) -> Step {
        let below = level + 1;
        // A square of the finest level, given as split, has no level below (`next` has an
        // entry for each level, so every level below that has one has its list).
        let Some(&next) = self.next.get(below) else {
            return Step::Up;
        };
        match below.checked_sub(NARROW_LEVEL + 1) {
            None => {
                let parent = self.narrow_path[level];
                let Some(child) = child_at(&self.levels.narrow[below], next, parent, level) else {
                    return Step::Up;
                };
                self.narrow_path[below] = child;
                self.emit(in_width(child), below)
            }
            Some(i) => {
                let parent = match i.checked_sub(1) {
                    None => in_width(self.narrow_path[level]),
                    Some(j) => self.deep_path[j],
                };
                let Some(child) = child_at(&self.levels.deep[i], next, parent, level) else {
                    return Step::Up;
                };
                self.deep_path[i] = child;
                self.emit(child, below)
            }
        }
    }

    /// Puts out the next unread square of `level`, at `corner`, unless the range ends before it.
    #[inline]
    fn emit(&mut self, corner: K, level: usize) -> Step {
        if self.to.is_some_and(|to| corner >= to) {
            return Step::End;
        }
        self.next[level] += 1;
        self.key = first_not_below(self.keys, self.key, corner);
        let cell = Cell {
            anchor: corner,
            level: level as u8,
        };
        self.out.push(T::walked(cell, self.key));
        Step::Down
    }
}

/// The square at `next` of a level's sorted `list`, if it is a child of `parent`, the anchor of
/// a square at `parent_level`, in the list's width.
#[inline]
fn child_at<N: MortonKey>(list: &[N], next: usize, parent: N, parent_level: usize) -> Option<N> {
    let child = *list.get(next)?;
    (child.cell_anchor(parent_level as u8) == parent).then_some(child)
}

/// Sorted, distinct anchors of the squares at each level `0..=AXIS_BITS`. In preorder (the
/// usual input, checked) each level's squares already come in order, so they are only
/// distributed, in parallel: each chunk counts its squares per level, then writes them at the
/// places those counts give.
pub(crate) fn by_level<K: MortonKey, S: HasCell<K>>(split: &[S]) -> Levels<K> {
    let chunks = chunk_offsets(split.len(), GRAIN);
    if let Some(counts) = counts_if_sorted(split, &chunks) {
        return distributed(split, &chunks, counts);
    }
    let mut squares = split.to_vec();
    squares.par_sort_unstable_by_key(|s| preorder_key(s));
    squares.dedup_by_key(|s| preorder_key(s));
    let chunks = chunk_offsets(squares.len(), GRAIN);
    let counts = counts_if_sorted(&squares, &chunks).expect("sorted and distinct");
    distributed(&squares, &chunks, counts)
}

/// A square's place in preorder.
fn preorder_key<K: MortonKey, S: HasCell<K>>(square: &S) -> (K, u8) {
    let cell = square.cell();
    (cell.anchor, cell.level)
}

/// The squares of each chunk at each level, if `split` is in strict preorder: one pass checks
/// the order and counts.
fn counts_if_sorted<K: MortonKey, S: HasCell<K>>(
    split: &[S],
    chunks: &[usize],
) -> Option<Vec<Vec<usize>>> {
    (0..chunks.len() - 1)
        .into_par_iter()
        .map(|c| {
            let mut count = vec![0; K::AXIS_BITS as usize + 1];
            let chunk = &split[chunks[c]..chunks[c + 1]];
            let mut last = None;
            for square in chunk {
                let key = preorder_key(square);
                if last.is_some_and(|last| last >= key) {
                    return None;
                }
                last = Some(key);
                count[key.1 as usize] += 1;
            }
            // The order across the chunk's end.
            let next = split.get(chunks[c + 1]).map(preorder_key);
            match (last, next) {
                (Some(last), Some(next)) if last >= next => None,
                _ => Some(count),
            }
        })
        .collect()
}

/// The squares of `sorted`, in strict preorder, written to their levels in parallel: each of
/// `chunks` writes its squares at the places its `counts` give.
fn distributed<K: MortonKey, S: HasCell<K>>(
    sorted: &[S],
    chunks: &[usize],
    counts: Vec<Vec<usize>>,
) -> Levels<K> {
    let level_count = K::AXIS_BITS as usize + 1;
    // Where each chunk starts writing at each level, and each level's size.
    let mut starts = counts;
    let mut totals = vec![0; level_count];
    for chunk in &mut starts {
        for (start, total) in chunk.iter_mut().zip(&mut totals) {
            (*start, *total) = (*total, *total + *start);
        }
    }
    // Written in parallel without being cleared first: clearing is a serial pass, and on fresh
    // memory a serial first touch of every page.
    // Where each chunk must end at each level: the next chunk's starts, or the totals.
    let ends: Vec<Vec<usize>> = (starts.iter().skip(1).cloned())
        .chain(std::iter::once(totals.clone()))
        .collect();
    let mut levels = Levels::<K>::with_capacities(&totals);
    let (narrow_totals, deep_totals) = totals.split_at(NARROW_LEVEL + 1);
    let narrow = room_writers(&mut levels.narrow, narrow_totals);
    let deep = room_writers(&mut levels.deep, deep_totals);
    starts.into_par_iter().enumerate().for_each(|(c, mut at)| {
        for square in &sorted[chunks[c]..chunks[c + 1]] {
            let cell = square.cell();
            let level = cell.level as usize;
            // SAFETY: `at[level]` is in the writer's slice (`write` asserts it). One writer per
            // slot: chunk `c` writes at each level the slots from `starts[c][level]` on, one per
            // square of that level in its range, and it has exactly `counts[c][level]` of them
            // (counted by `counts_if_sorted` over the same chunks of the same `sorted`); the
            // starts are the exclusive prefix sums of those counts, so the chunks' ranges at a
            // level are disjoint. `MaybeUninit` has nothing to drop.
            #[allow(unsafe_code)]
            unsafe {
                match level.checked_sub(NARROW_LEVEL + 1) {
                    None => narrow[level].write(at[level], MaybeUninit::new(in_width(cell.anchor))),
                    Some(i) => deep[i].write(at[level], MaybeUninit::new(cell.anchor)),
                }
            };
            at[level] += 1;
        }
        // Every slot below the totals is written: each chunk filled its ranges to the end.
        assert_eq!(at, ends[c], "chunk {c} wrote other than it counted");
    });
    drop((narrow, deep));
    // SAFETY: the lists are fresh (length 0) with capacity `totals[level]` at least
    // (`with_capacities`), and the chunks' ranges at each level, from the prefix sums of their
    // own counts of the same squares, cover the level's first `totals[level]` slots, all written
    // above: each chunk was asserted to end its ranges where the next begins (a panicking
    // chunk would have ended the join before this line); the writers, which borrowed the
    // lists, are dropped.
    #[allow(unsafe_code)]
    unsafe {
        assume_written(&mut levels.narrow, narrow_totals);
        assume_written(&mut levels.deep, deep_totals);
    }
    levels
}

/// Writers of the first `lens[i]` slots of the room of each of `lists`.
fn room_writers<'a, T>(
    lists: &'a mut [Vec<T>],
    lens: &[usize],
) -> Vec<DisjointWrites<'a, MaybeUninit<T>>> {
    let lists = lists.iter_mut().zip(lens);
    lists
        .map(|(list, &n)| DisjointWrites::new(&mut list.spare_capacity_mut()[..n]))
        .collect()
}

/// Sets the length of each of `lists` to `lens[i]`.
///
/// # Safety
/// Each list is empty, has capacity for `lens[i]` values, and the first `lens[i]` slots of
/// its room (`spare_capacity_mut`) are initialised.
#[allow(unsafe_code)]
unsafe fn assume_written<T>(lists: &mut [Vec<T>], lens: &[usize]) {
    for (list, &n) in lists.iter_mut().zip(lens) {
        // SAFETY: `n` is within the capacity and the first `n` slots are initialised (the
        // caller's contract).
        unsafe { list.set_len(n) };
    }
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
/// squares at `level` (sorted, distinct anchors) force, sorted and distinct, in the width of the
/// existing ones (see [`in_width`]). Each block of
/// squares at `level - 1` is a bitmap: parents and their neighbours inside the block are marked,
/// and read back in Morton order, so only the few neighbours in other blocks need a sort. Each
/// chunk of blocks then merges in the existing squares and those others that fall among its
/// blocks, so the level is written once more, not once per union.
pub(crate) fn with_forced<I: MortonKey, O: MortonKey>(
    existing: &[O],
    anchors: &[I],
    level: u8,
) -> Vec<O> {
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
    let (inside, others): (Vec<Vec<O>>, Vec<Vec<O>>) = (0..chunks)
        .into_par_iter()
        .map(|c| forced_in_blocks(&anchors[bounds[c]..bounds[c + 1]], level, depth))
        .unzip();
    let mut others = concat(&others);
    O::sort_keys(&mut others);
    others.dedup();
    // Chunk c takes the keys from its first block's corner (the first chunk: from the start) to
    // the next chunk's (the last: to the end).
    let cut = |list: &[O], c: usize| match c {
        0 => 0,
        c if c == chunks => list.len(),
        c => {
            let corner = in_width(block_of(bounds[c]));
            list.partition_point(|&a| a < corner)
        }
    };
    let parts: Vec<Vec<O>> = (0..chunks)
        .into_par_iter()
        .map(|c| {
            let existing = &existing[cut(existing, c)..cut(existing, c + 1)];
            let others = &others[cut(&others, c)..cut(&others, c + 1)];
            merge_distinct_with_few(&inside[c], existing, others)
        })
        .collect();
    concat(&parts)
}

/// For sorted squares at `level` in whole blocks (squares `depth` levels above their parents):
/// the squares they force inside those blocks, sorted and distinct, and those they force in
/// other blocks, unsorted and possibly repeated; those in the width `O`.
///
/// Which sides a square touches is close to random, so the marking selects instead of
/// branching on it; only a neighbour outside the block takes a branch.
fn forced_in_blocks<I: MortonKey, O: MortonKey>(
    anchors: &[I],
    level: u8,
    depth: u8,
) -> (Vec<O>, Vec<O>) {
    let below = 2 * (I::AXIS_BITS - level as u32);
    // The bits below a forced square (at `level - 1`), in the output's width.
    let forced_span = 2 * (O::AXIS_BITS + 1 - level as u32);
    let child_bits = 2 * (u32::from(depth) + 1);
    let y_bits = 0x5555_5555 & ((1u32 << (2 * depth)) - 1);
    let x_bits = y_bits << 1;
    let mut block = Bitmap::default();
    let mut inside: Vec<O> = Vec::with_capacity(anchors.len());
    let mut others: Vec<O> = Vec::new();
    let Some(&first) = anchors.first() else {
        return (inside, others);
    };
    // A square's digits down to `level`: the lowest `child_bits` of them place it in its
    // block, and the rest name the block.
    let mut block_digits = first.to_u128() >> below >> child_bits;
    for &anchor in anchors {
        let digits = anchor.to_u128() >> below;
        if digits >> child_bits != block_digits {
            block.read(block_digits << (child_bits - 2), forced_span, &mut inside);
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
                    others.push(in_width(beside[side as usize]));
                }
            }
        }
    }
    block.read(block_digits << (child_bits - 2), forced_span, &mut inside);
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

/// Appends the sorted union of two sorted, distinct lists to `out`.
fn merge_distinct_into<K: MortonKey>(out: &mut Vec<K>, a: &[K], b: &[K]) {
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        let next = a[i].min(b[j]);
        out.push(next);
        i += usize::from(a[i] == next);
        j += usize::from(b[j] == next);
    }
    out.extend_from_slice(&a[i..]);
    out.extend_from_slice(&b[j..]);
}

/// The sorted union of three sorted, distinct lists, the last of them short beside the others:
/// one pass that merges the first two without branching and takes the few in as they come.
fn merge_distinct_with_few<K: MortonKey>(a: &[K], b: &[K], few: &[K]) -> Vec<K> {
    let mut out = Vec::with_capacity(a.len() + b.len() + few.len());
    let (mut i, mut j, mut f) = (0, 0, 0);
    while i < a.len() && j < b.len() {
        let next = a[i].min(b[j]);
        while f < few.len() && few[f] <= next {
            if few[f] < next {
                out.push(few[f]);
            }
            f += 1;
        }
        out.push(next);
        i += usize::from(a[i] == next);
        j += usize::from(b[j] == next);
    }
    let rest = if i < a.len() { &a[i..] } else { &b[j..] };
    merge_distinct_into(&mut out, rest, &few[f..]);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn merging_keeps_one_of_each() {
        let few = [0u64, 3, 4, 9, 12];
        let lists: [&[u64]; 4] = [&[1, 3, 5, 9], &[2, 3, 6], &[], &[7, 8, 9, 10, 11]];
        for a in lists {
            for b in lists {
                for f in 0..=few.len() {
                    let few = &few[..f];
                    let union: std::collections::BTreeSet<u64> =
                        a.iter().chain(b).chain(few).copied().collect();
                    let expected: Vec<u64> = union.into_iter().collect();
                    let merged = merge_distinct_with_few(a, b, few);
                    assert_eq!(merged, expected, "{a:?} {b:?} {few:?}");
                }
            }
        }
    }

    #[test]
    fn the_walk_gives_the_preorder_across_many_ranges() {
        let narrow = |i: u64| i.wrapping_mul(0x9E37_79B9_7F4A_7C15).rotate_left(17);
        walk_gives_the_preorder(narrow, 9);
        // Wide keys with squares on both sides of the narrow levels' end.
        let wide = |i: u64| u128::from(narrow(i)) << 64 | u128::from(narrow(i ^ 0x5555));
        walk_gives_the_preorder(wide, NARROW_LEVEL as u8 - 3);
    }

    /// Random squares at levels `coarsest..coarsest + 6` and all their ancestors, walked in
    /// preorder: the coarsest of those levels alone spans several walk ranges.
    fn walk_gives_the_preorder<K: MortonKey>(key: impl Fn(u64) -> K, coarsest: u8) {
        let mut cells: Vec<Cell<K>> = (0..120_000u64)
            .flat_map(|i| {
                let level = coarsest + (i % 6) as u8;
                let key = key(i);
                (0..=level).map(move |l| Cell::containing(key, l))
            })
            .collect();
        cells.sort_unstable_by_key(|c| (c.anchor, c.level));
        cells.dedup();
        let levels = by_level(&cells);
        let widest = (0..levels.count()).map(|l| levels.len_at(l)).max();
        assert!(widest.unwrap() > 2 * WALK_RANGE);
        assert_eq!(preorder_of_levels::<K, Cell<K>>(&levels, &[]), cells);
        // With keys, each square gets the first at or after its corner.
        let keys: Vec<K> = (0..50_000u64)
            .map(|i| key(i.wrapping_mul(0xD1B5_4A32_D192_ED03)))
            .collect::<std::collections::BTreeSet<_>>()
            .into_iter()
            .collect();
        let with_points: Vec<Internal<K>> = preorder_of_levels(&levels, &keys);
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
                let expected = forced_one_by_one(existing, &anchors, level);
                assert_eq!(
                    with_forced(existing, &anchors, level),
                    expected,
                    "level {level}"
                );
                if K::AXIS_BITS > u64::AXIS_BITS && level as usize <= NARROW_LEVEL + 1 {
                    // As the closure forces wide keys' squares at the narrow levels: from 64-bit
                    // anchors above level 33, from wide ones at it, into 64 bits.
                    let narrow: Vec<u64> = existing.iter().map(|&a| in_width(a)).collect();
                    let forced = if level as usize <= NARROW_LEVEL {
                        let anchors: Vec<u64> = anchors.iter().map(|&a| in_width(a)).collect();
                        with_forced(&narrow, &anchors, level)
                    } else {
                        with_forced(&narrow, &anchors, level)
                    };
                    let forced: Vec<K> = forced.into_iter().map(in_width).collect();
                    assert_eq!(forced, expected, "level {level}, forced in 64 bits");
                }
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
    fn squares_of_the_finest_level_given_as_split_are_walked() {
        let finest = |x, y| Cell::<u64>::containing(u64::encode(x, y), u64::AXIS_BITS as u8);
        let split = [finest(5, 7), finest(5, 8), finest(1 << 31, 3)];
        let closed = balance_closure(&split);
        assert_eq!(closed, crate::balance::reference::ripple_closure(&split));
        assert!(split.iter().all(|s| closed.contains(s)));
        let wide = |x, y| Cell::<u128>::containing(u128::encode(x, y), u128::AXIS_BITS as u8);
        let split = [wide(5, 7), wide(u64::MAX, 1 << 40)];
        let closed = balance_closure(&split);
        assert_eq!(closed, crate::balance::reference::ripple_closure(&split));
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
