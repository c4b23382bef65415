//! Navigation in a quadtree stored as flat arrays: the four children of every internal square,
//! and the path from the root down to any internal square.

use rayon::prelude::*;

use std::ops::Range;

use crate::morton::{Cell, MortonKey};
use crate::par::{GRAIN, SharedSlots, chunk_offsets, collect_indexed};

use super::{Internal, Quadtree, with_gap_leaves};

/// Tag of a child entry that is a leaf index rather than an internal-square index.
pub const LEAF: u32 = 1 << 31;

/// The children of each internal square by quadrant: an internal index, or a leaf index tagged
/// with [`LEAF`]. Needs at least one internal square and fewer than 2^31 leaves.
///
/// In preorder, the parent of an internal square, or of a leaf after it, is the square one
/// level up on the current path from the root; each chunk of squares keeps that path and writes
/// every child into its parent's slot. Each slot has one child, so the writes never meet.
///
/// # Panics
/// If the tree has 2^31 leaves or more.
pub fn children<K: MortonKey>(tree: &Quadtree<K>) -> Vec<[u32; 4]> {
    assert!(
        tree.leaves.len() < LEAF as usize,
        "too many leaves to index"
    );
    let internal = &tree.internal;
    let mut children = collect_indexed(internal.len(), |_| [0u32; 4]);
    let slots = SharedSlots::new(children.as_flattened_mut());
    let chunks = chunk_offsets(internal.len(), GRAIN);
    (0..chunks.len() - 1).into_par_iter().for_each(|c| {
        let mut parents = ChildSlots::for_scan(internal, chunks[c]..chunks[c + 1], &slots);
        for (i, gap) in with_gap_leaves(internal, chunks[c]..chunks[c + 1]) {
            parents.square(i, internal[i].cell);
            for j in gap {
                parents.leaf(j, tree.leaves[j].cell);
            }
        }
    });
    children
}

/// A preorder scan's writer of the children index: the parent of an internal square, or of a
/// leaf after it, is the square one level up on the current path from the root, which this
/// keeps; each child goes into its parent's slot. Each slot has one child, so the writes of
/// scans over different chunks never meet.
pub(crate) struct ChildSlots<'s, 'a> {
    path: Vec<u32>,
    slots: &'s SharedSlots<'a>,
}

impl<'s, 'a> ChildSlots<'s, 'a> {
    /// For a scan of the internal squares `range` and the leaves after each. Of the path from
    /// the root, only the levels the scan climbs to are looked up: a chunk of squares climbs a
    /// few levels above its first, while a deep tree has dozens, each a binary search among all
    /// squares.
    pub(crate) fn for_scan<K: MortonKey>(
        internal: &[Internal<K>],
        range: Range<usize>,
        slots: &'s SharedSlots<'a>,
    ) -> Self {
        ChildSlots {
            path: path_in(internal, range.start, highest_parent(internal, range)),
            slots,
        }
    }

    /// Internal square `i`, `cell`, is next in preorder.
    #[inline]
    pub(crate) fn square<K: MortonKey>(&mut self, i: usize, cell: Cell<K>) {
        if cell.level > 0 {
            self.store(cell, i as u32);
        }
        self.path[cell.level as usize] = i as u32;
    }

    /// Leaf `j`, `cell`, is next, in the gap after the last square.
    #[inline]
    pub(crate) fn leaf<K: MortonKey>(&self, j: usize, cell: Cell<K>) {
        self.store(cell, LEAF | j as u32);
    }

    fn store<K: MortonKey>(&self, cell: Cell<K>, entry: u32) {
        let parent = self.path[cell.level as usize - 1] as usize;
        self.slots
            .store(4 * parent + cell.quadrant() as usize, entry);
    }
}

/// The coarsest level of a parent in a scan of the internal squares `range` and the leaves
/// after each: a leaf in the gap before the next square lies in that square's parent, so its
/// own parent is no coarser; the coarsest parent is one level above the coarsest square in the
/// range and the one after it (the root's level after the last square).
fn highest_parent<K: MortonKey>(internal: &[Internal<K>], range: Range<usize>) -> u8 {
    let next = internal.get(range.end).map_or(0, |s| s.cell.level);
    let coarsest = internal[range].iter().map(|s| s.cell.level).min();
    coarsest
        .map_or(next, |level| level.min(next))
        .saturating_sub(1)
}

/// The internal squares from the root down to the parent of internal square `i`, by level, with
/// room below for a path down to the finest level.
pub fn path_to<K: MortonKey>(tree: &Quadtree<K>, i: usize) -> Vec<u32> {
    path_in(&tree.internal, i, 0)
}

/// As [`path_to`], in the internal squares alone (in preorder), from level `top` down (zero
/// above it).
fn path_in<K: MortonKey>(internal: &[Internal<K>], i: usize, top: u8) -> Vec<u32> {
    let cell = internal[i].cell;
    let mut path = vec![0u32; K::AXIS_BITS as usize + 1];
    for level in top..cell.level {
        let ancestor = Cell::containing(cell.anchor, level);
        path[level as usize] = index_in_preorder(&internal[..i], ancestor) as u32;
    }
    path
}

/// The index of `square` among `internal` (in preorder), which holds it. Rare beside the
/// scans that need it, so kept out of their loops.
#[cold]
fn index_in_preorder<K: MortonKey>(internal: &[Internal<K>], square: Cell<K>) -> usize {
    // Preorder is the order of (corner, level).
    let key = (square.anchor, square.level);
    internal.partition_point(|s| ({ s.cell.anchor }, s.cell.level) < key)
}
