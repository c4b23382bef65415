//! The unbalanced quadtree: every internal square has four children and every input point is
//! alone in its leaf. Built from the framework by expanding each framework edge into its path
//! of squares (BET §2), with work allocated by prefix sums.
//!
//! Internal squares are stored in preorder, leaves in Morton order. Internal squares are exactly
//! the squares holding two or more points (plus the root); they are the framework nodes and the
//! squares on the paths between them.

pub mod index;
pub mod reference;

pub use crate::morton::Cell;

use std::ops::Range;

use crate::framework::{Framework, NONE};
use crate::morton::{MortonKey, NARROW_LEVEL};
use crate::par::{
    GRAIN, SharedSlots, chunk_offsets, collect_indexed, collect_segments, collect_segments_by,
    exclusive_scan_by,
};
use index::ChildSlots;

/// A leaf and the point in it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[repr(C, packed)]
pub struct Leaf<K: Copy> {
    /// The square.
    pub cell: Cell<K>,
    /// Morton position of its point, [`NONE`] if empty.
    pub point: u32,
}

/// An internal square and where its points start.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[repr(C, packed)]
pub struct Internal<K: Copy> {
    /// The square.
    pub cell: Cell<K>,
    /// Morton position of the first point at or after its corner (inside it, unless it is empty).
    pub first: u32,
}

/// A record that names a square: the square itself, or an internal square with its first point.
///
/// Sealed: the closure's parallel writes rely on `cell` giving the same square every time.
pub trait HasCell<K: Copy>: Copy + Send + Sync + sealed::Sealed {
    /// The square.
    fn cell(&self) -> Cell<K>;
}

mod sealed {
    /// Only the crate's square records implement [`super::HasCell`].
    pub trait Sealed {}
    impl<K: Copy> Sealed for super::Cell<K> {}
    impl<K: Copy> Sealed for super::Internal<K> {}
}

impl<K: Copy + Send + Sync> HasCell<K> for Cell<K> {
    #[inline]
    fn cell(&self) -> Cell<K> {
        *self
    }
}

impl<K: Copy + Send + Sync> HasCell<K> for Internal<K> {
    #[inline]
    fn cell(&self) -> Cell<K> {
        self.cell
    }
}

/// The unbalanced quadtree as flat arrays.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Quadtree<K: Copy> {
    /// Internal squares in preorder.
    pub internal: Vec<Internal<K>>,
    /// Leaves in Morton order; they tile the root.
    pub leaves: Vec<Leaf<K>>,
}

/// Expands the framework of `keys` into the unbalanced quadtree.
///
/// # Complexity
/// O(n + k) work for k squares: one prefix sum over framework nodes, then each internal square
/// and each leaf is written once, in parallel.
pub fn expand<K: MortonKey>(fw: &Framework<K>, keys: &[K]) -> Quadtree<K> {
    from_internal(internal_squares(fw), keys)
}

/// The quadtree whose internal squares are `internal` (in preorder, closed under parents, each
/// with the first point at or after its corner), with its leaves and their points.
pub fn from_internal<K: MortonKey>(internal: Vec<Internal<K>>, keys: &[K]) -> Quadtree<K> {
    if internal.is_empty() {
        return root_leaf(internal, keys);
    }
    let leaves = leaves_of(&internal, keys, None);
    Quadtree { internal, leaves }
}

/// A quadtree with its navigation: the children of each internal square (see
/// [`index::children`]) and the leaf of each point, by Morton position.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct IndexedTree<K: Copy> {
    /// The tree.
    pub tree: Quadtree<K>,
    /// The children of each internal square by quadrant, leaves tagged [`index::LEAF`].
    pub children: Vec<[u32; 4]>,
    /// The leaf of each point.
    pub point_leaf: Vec<u32>,
}

/// As [`from_internal`], with the children and the point location written in the same pass
/// as the leaves, instead of two more passes over them.
pub fn indexed_from_internal<K: MortonKey>(
    internal: Vec<Internal<K>>,
    keys: &[K],
) -> IndexedTree<K> {
    if internal.is_empty() {
        return IndexedTree {
            tree: root_leaf(internal, keys),
            children: Vec::new(),
            point_leaf: vec![0; keys.len()],
        };
    }
    assert!(
        3 * internal.len() + 1 < index::LEAF as usize,
        "too many leaves to index"
    );
    // The leaf pass writes every slot of a valid tree; these values are for any other. Cleared
    // in parallel: a serial clear would be a serial pass, and a serial first touch of fresh
    // pages.
    let mut children = collect_indexed(internal.len(), |_| [0u32; 4]);
    let mut point_leaf = collect_indexed(keys.len(), |_| NONE);
    let leaves = leaves_of(
        &internal,
        keys,
        Some(&IndexWrites {
            children: SharedSlots::new(children.as_flattened_mut()),
            point_leaf: SharedSlots::new(&mut point_leaf),
        }),
    );
    IndexedTree {
        tree: Quadtree { internal, leaves },
        children,
        point_leaf,
    }
}

/// The tree of no internal square: the root as a leaf, with the point if there is one.
fn root_leaf<K: MortonKey>(internal: Vec<Internal<K>>, keys: &[K]) -> Quadtree<K> {
    let point = if keys.is_empty() { NONE } else { 0 };
    let leaves = vec![Leaf {
        cell: Cell::root(),
        point,
    }];
    Quadtree { internal, leaves }
}

/// Where the leaf pass writes the children index and the point location.
struct IndexWrites<'a> {
    children: SharedSlots<'a>,
    point_leaf: SharedSlots<'a>,
}

/// Squares in preorder with the first point at or after each one's corner: one binary search
/// per chunk, then a merge (preorder corners never decrease).
pub fn with_first_points<K: MortonKey>(cells: &[Cell<K>], keys: &[K]) -> Vec<Internal<K>> {
    let offsets = chunk_offsets(cells.len(), GRAIN);
    collect_segments(&offsets, |c| {
        let chunk = &cells[offsets[c]..offsets[c + 1]];
        let mut cursor = chunk
            .first()
            .map_or(0, |s| keys.partition_point(|k| *k < { s.anchor }));
        chunk.iter().map(move |&cell| {
            cursor = first_not_below(keys, cursor, cell.anchor);
            Internal {
                cell,
                first: cursor as u32,
            }
        })
    })
}

/// The index of the first of the sorted `keys`, from `from` on, that is not below `corner`
/// (`keys.len()` if none), for a cursor that moves a few keys at a time. A loop that stops at
/// the first such key mispredicts its exit at almost every call, as the count is mostly 0, 1 or
/// 2 at random; counting the keys below `corner` in a fixed window of the next few (sorted, so
/// they are the first of the window) does not branch on them.
#[inline]
pub(crate) fn first_not_below<K: MortonKey>(keys: &[K], from: usize, corner: K) -> usize {
    const WINDOW: usize = 4;
    let mut at = from;
    while let Some(window) = keys.get(at..at + WINDOW) {
        let below: usize = window.iter().map(|&k| usize::from(k < corner)).sum();
        at += below;
        if below < WINDOW {
            return at;
        }
    }
    at + keys[at..].iter().take_while(|&&k| k < corner).count()
}

/// The squares on every framework edge: node `u` owns the levels below its parent's down to its
/// own. In framework preorder, these paths concatenate to the preorder of internal squares.
/// The path lengths are found once; the output is allocated per chunk of nodes.
fn internal_squares<K: MortonKey>(fw: &Framework<K>) -> Vec<Internal<K>> {
    let path_len: Vec<u8> = collect_indexed(fw.len(), |u| {
        (fw.nodes[u].cell.level as i32 - fw.parent_level(u)) as u8
    });
    let chunks = chunk_offsets(fw.len(), GRAIN);
    let offsets = exclusive_scan_by(chunks.len() - 1, |c| {
        path_len[chunks[c]..chunks[c + 1]]
            .iter()
            .map(|&l| l as usize)
            .sum()
    });
    collect_segments_by(&offsets, |c, out| {
        let range = chunks[c]..chunks[c + 1];
        for (node, &len) in fw.nodes[range.clone()].iter().zip(&path_len[range]) {
            let top = node.cell.level + 1 - len;
            for level in top..=node.cell.level {
                out.push(Internal {
                    cell: Cell::containing(node.cell.anchor, level),
                    first: node.first,
                });
            }
        }
    })
}

/// Leaves in Morton order. The leaves before internal square `i` (in preorder) number
/// `3 (i - level_i) + digit_sum_i`: each of the `i - level_i` internal squares that are not
/// ancestors of `i` closes a subtree with three more leaves than internal squares, and the path
/// from the root to `i` passes `digit_sum_i` earlier sibling subtrees. The leaves between two
/// consecutive internal squares tile the key interval between their corners.
///
/// With `index`, each square is written into its parent's child slot as
/// [`index::children`] does, and each point's leaf too.
fn leaves_of<K: MortonKey>(
    internal: &[Internal<K>],
    keys: &[K],
    index: Option<&IndexWrites>,
) -> Vec<Leaf<K>> {
    // Leaf counts come from the formula at each end, so only chunk ends need a table.
    let chunks = chunk_offsets(internal.len(), GRAIN);
    collect_segments_by(&leaf_starts(internal, &chunks), |c, out| {
        let mut parents = index
            .map(|index| ChildSlots::for_scan(internal, chunks[c]..chunks[c + 1], &index.children));
        for (i, gap) in with_gap_leaves(internal, chunks[c]..chunks[c + 1]) {
            if let Some(parents) = &mut parents {
                parents.square(i, internal[i].cell);
            }
            let mut put = |j: usize, leaf: Leaf<K>| {
                if let (Some(parents), Some(index)) = (&parents, index) {
                    parents.leaf(j, leaf.cell);
                    if leaf.point != NONE {
                        // Each point is in one leaf, so its slot has one writer.
                        index.point_leaf.store(leaf.point as usize, j as u32);
                    }
                }
                out.push(leaf);
            };
            let end = internal.get(i + 1).map(|s| s.cell.anchor);
            // Each arm with its own constant shift: a variable 128-bit shift per leaf costs more.
            match narrow_window(internal[i].cell, end) {
                Some(NarrowWindow::Top) => {
                    let shift = 2 * (K::AXIS_BITS - u64::AXIS_BITS);
                    let mut tiles = GapTiles::<u64, K>::new(&internal[i], end, keys, 0, shift);
                    gap.for_each(|j| put(j, tiles.next_leaf()));
                }
                Some(NarrowWindow::Within(base)) => {
                    let mut tiles = GapTiles::<u64, K>::new(&internal[i], end, keys, base, 0);
                    gap.for_each(|j| put(j, tiles.next_leaf()));
                }
                None => {
                    let mut tiles = GapTiles::<K, K>::new(&internal[i], end, keys, 0, 0);
                    gap.for_each(|j| put(j, tiles.next_leaf()));
                }
            }
        }
    })
}

/// A 64-bit window of a wide key space that holds a gap (see [`GapTiles`]).
enum NarrowWindow {
    /// The top 64 bits.
    Top,
    /// The low 64 bits of the square of level 32 with this anchor.
    Within(u128),
}

/// The 64-bit window that holds the gap after square `from` up to `end`, for wide keys. A gap's
/// leaves are children of the square or of its ancestors, and so is the next square, so above
/// level 32 all are anchored in the top 64 bits. From level 32 down, a gap that ends inside the
/// same square of level 32 lies in that square.
fn narrow_window<K: MortonKey>(from: Cell<K>, end: Option<K>) -> Option<NarrowWindow> {
    if K::AXIS_BITS <= u64::AXIS_BITS {
        return None;
    }
    let narrow_level = NARROW_LEVEL as u8;
    if from.level < narrow_level {
        return Some(NarrowWindow::Top);
    }
    let square = from.anchor.cell_anchor(narrow_level);
    end.filter(|e| e.cell_anchor(narrow_level) == square)
        .map(|_| NarrowWindow::Within(square.to_u128()))
}

/// Where the leaves after each of the internal squares `at` start (see [`with_gap_leaves`]).
pub(crate) fn leaf_starts<K: MortonKey>(internal: &[Internal<K>], at: &[usize]) -> Vec<usize> {
    at.iter().map(|&i| leaves_at(internal, i)).collect()
}

/// The internal squares of `range` (preorder indices), each with the leaves that follow it up
/// to the next internal square: children of it or of its ancestors, in Morton order.
pub(crate) fn with_gap_leaves<K: MortonKey>(
    internal: &[Internal<K>],
    range: Range<usize>,
) -> impl Iterator<Item = (usize, Range<usize>)> + '_ {
    let mut first = leaves_at(internal, range.start);
    range.map(move |i| {
        let end = leaves_at(internal, i + 1);
        // In a full quadtree the gaps follow one another, so each leaf is in one of them: the
        // children index and the links, which scatter by leaf, rely on it.
        assert!(first <= end, "internal squares out of preorder");
        let gap = first..end;
        first = end;
        (i, gap)
    })
}

/// Where the leaves after internal square `i` start; for `i` = the count, the leaf count.
fn leaves_at<K: MortonKey>(internal: &[Internal<K>], i: usize) -> usize {
    match internal.get(i) {
        Some(s) => leaves_before(i, s.cell),
        None => 3 * internal.len() + 1,
    }
}

/// The number of leaves before a square of a full quadtree in Morton order, given the number of
/// internal squares before it in preorder.
pub fn leaves_before<K: MortonKey>(internal_before: usize, cell: Cell<K>) -> usize {
    3 * (internal_before - cell.level as usize) + cell.anchor.digit_sum(cell.level) as usize
}

/// The leaves covering keys from an internal square's corner up to `end` (the next internal
/// square's corner, or the end of the key space), largest aligned squares first, the first one
/// a child of that square. Points are assigned by merging with the sorted keys.
///
/// The tiling runs in a window of the key space: key `base + (w << shift)` for `w` of the width
/// `G`, which may be narrower than the keys' when the whole gap lies in such a window.
struct GapTiles<'a, G: Copy, K> {
    x: G,
    /// Where the gap ends; the end of the key space is 0, so `end - x` wraps to the right span.
    end: G,
    cursor: usize,
    /// The coarsest level the next leaf may have, in the window's levels: the first leaf is a
    /// child of the square the gap follows, later ones may be larger.
    coarsest: u8,
    keys: &'a [K],
    base: u128,
    shift: u32,
    /// The level of a square of the window's level 0.
    level_offset: u8,
}

impl<'a, G: MortonKey, K: MortonKey> GapTiles<'a, G, K> {
    /// The gap after `from`, up to `end`, in the window `base`, `shift`: it must hold `from`'s
    /// children, `end` (none: the end of the key space, only for windows that reach it) and every
    /// leaf between.
    fn new(from: &Internal<K>, end: Option<K>, keys: &'a [K], base: u128, shift: u32) -> Self {
        let in_window = |k: K| G::from_u128(window_offset(k, base, shift));
        let level_offset = (K::AXIS_BITS - G::AXIS_BITS - shift / 2) as u8;
        GapTiles {
            x: in_window(from.cell.anchor),
            end: end.map_or(G::default(), in_window),
            cursor: from.first as usize,
            coarsest: from.cell.level + 1 - level_offset,
            keys,
            base,
            shift,
            level_offset,
        }
    }

    /// Key `k` in the window's width, if it lies in the window.
    #[inline]
    fn in_window(&self, k: K) -> Option<G> {
        let w = window_offset(k, self.base, self.shift);
        let most = u128::MAX >> (128 - 2 * G::AXIS_BITS);
        (w <= most).then(|| G::from_u128(w))
    }
}

/// Key `k`'s place in the window `base`, `shift`: below `2^(2 G::AXIS_BITS)` when it lies in a
/// window of width `G`.
#[inline]
fn window_offset<K: MortonKey>(k: K, base: u128, shift: u32) -> u128 {
    k.to_u128().wrapping_sub(base) >> shift
}

impl<G: MortonKey, K: MortonKey> GapTiles<'_, G, K> {
    /// The next leaf of the gap; the caller knows how many there are.
    fn next_leaf(&mut self) -> Leaf<K> {
        let key_bits = 2 * G::AXIS_BITS;
        let span = self.end.wrapping_sub(self.x);
        let span_bits = if span == G::default() {
            key_bits
        } else {
            key_bits - 1 - span.leading_zeros()
        };
        let align_bits = self.x.trailing_zeros().min(key_bits);
        // A leaf is never the root here, so its size fits in a key.
        let half_bits = (span_bits / 2)
            .min(align_bits / 2)
            .min(G::AXIS_BITS - self.coarsest as u32);
        let size = G::pow2(2 * half_bits);
        // About half the leaves hold a point, at random: a select, not a branch.
        let holds = self.keys.get(self.cursor).is_some_and(|&k| {
            self.in_window(k)
                .is_some_and(|w| w.wrapping_sub(self.x) < size)
        });
        let point = if holds { self.cursor as u32 } else { NONE };
        self.cursor += holds as usize;
        let cell = Cell {
            anchor: K::from_u128(self.base | self.x.to_u128() << self.shift),
            level: (G::AXIS_BITS - half_bits) as u8 + self.level_offset,
        };
        self.x = self.x.wrapping_add(size);
        self.coarsest = 0;
        Leaf { cell, point }
    }
}

impl<K: MortonKey> Quadtree<K> {
    /// Checks that this is the unbalanced quadtree of the keys: [`Quadtree::check`], and every
    /// internal square holds two or more points (none is split without need).
    pub fn check_unbalanced(&self, keys: &[K]) -> Result<(), String> {
        self.check(keys)?;
        for (i, s) in self.internal.iter().enumerate() {
            let held = points_in(s.cell, keys).len();
            if held < 2 {
                let cell = s.cell;
                return Err(format!("internal square {i} {cell:?} holds {held} points"));
            }
        }
        Ok(())
    }

    /// Checks the tree against the keys it was built from; returns what is wrong.
    ///
    /// Internal squares are in strict preorder and have internal parents; leaves tile the root
    /// in Morton order, have internal parents, and hold exactly the point recorded for them (at
    /// most one).
    pub fn check(&self, keys: &[K]) -> Result<(), String> {
        let internal: std::collections::HashSet<Cell<K>> =
            self.internal.iter().map(|s| s.cell).collect();
        if internal.len() != self.internal.len() {
            return Err("an internal square appears twice".into());
        }
        self.check_internal(&internal, keys)?;
        self.check_leaves(&internal, keys)
    }

    fn check_internal(
        &self,
        internal: &std::collections::HashSet<Cell<K>>,
        keys: &[K],
    ) -> Result<(), String> {
        for (i, s) in self.internal.iter().enumerate() {
            let cell = s.cell;
            let held = points_in(cell, keys);
            if held.start != s.first as usize {
                return Err(format!("internal square {i} has a wrong first point"));
            }
            if cell.level > 0 && !internal.contains(&cell.parent()) {
                return Err(format!("internal square {i} has no internal parent"));
            }
            if i > 0
                && (
                    self.internal[i - 1].cell.anchor,
                    self.internal[i - 1].cell.level,
                ) >= (cell.anchor, cell.level)
            {
                return Err(format!(
                    "internal squares {} and {i} out of preorder",
                    i - 1
                ));
            }
        }
        Ok(())
    }

    fn check_leaves(
        &self,
        internal: &std::collections::HashSet<Cell<K>>,
        keys: &[K],
    ) -> Result<(), String> {
        let mut next = 0u128;
        let mut located = 0usize;
        for (j, leaf) in self.leaves.iter().enumerate() {
            let cell = leaf.cell;
            if cell.anchor.to_u128() != next {
                return Err(format!("leaf {j} leaves a gap or overlaps"));
            }
            next = next.wrapping_add(1u128.checked_shl(cell.span_bits()).unwrap_or(0));
            if internal.contains(&cell) || (cell.level > 0 && !internal.contains(&cell.parent())) {
                return Err(format!(
                    "leaf {j} {cell:?} is internal or has no internal parent"
                ));
            }
            let held = points_in(cell, keys);
            let expected = if held.is_empty() {
                NONE
            } else {
                held.start as u32
            };
            if held.len() > 1 || leaf.point != expected {
                let point = leaf.point;
                return Err(format!("leaf {j} holds {held:?} but records {point}"));
            }
            located += held.len();
        }
        let full = if K::AXIS_BITS == 64 {
            0
        } else {
            1u128 << (2 * K::AXIS_BITS)
        };
        if next != full || located != keys.len() {
            return Err(format!(
                "leaves cover up to {next:#x} and hold {located} of {} points",
                keys.len()
            ));
        }
        Ok(())
    }
}

/// The Morton positions of the keys inside a square.
pub fn points_in<K: MortonKey>(cell: Cell<K>, keys: &[K]) -> std::ops::Range<usize> {
    let start = keys.partition_point(|k| k.cell_anchor(cell.level) < { cell.anchor });
    let end = start + keys[start..].partition_point(|k| cell.contains(*k));
    start..end
}

#[cfg(test)]
mod tests {
    use super::first_not_below;

    #[test]
    fn the_cursor_finds_the_first_key_not_below_the_corner() {
        // Runs of every length across the window, up to the end of the keys.
        let keys: Vec<u64> = (0..40u64).map(|k| 3 * k).collect();
        for from in 0..=keys.len() {
            for corner in 0..130u64 {
                let expected = keys.partition_point(|&k| k < corner).max(from);
                assert_eq!(
                    first_not_below(&keys, from, corner),
                    expected,
                    "from {from}, corner {corner}"
                );
            }
        }
        assert_eq!(first_not_below::<u128>(&[], 0, 5), 0);
    }
}
