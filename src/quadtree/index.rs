//! Navigation in a quadtree stored as flat arrays: the four children of every internal square,
//! and the path from the root down to any internal square.

use rayon::prelude::*;

use crate::morton::{Cell, MortonKey};
use crate::par::{GRAIN, SharedSlots, chunk_offsets};

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
    let mut children = vec![[0u32; 4]; internal.len()];
    let slots = SharedSlots::new(children.as_flattened_mut());
    let chunks = chunk_offsets(internal.len(), GRAIN);
    (0..chunks.len() - 1).into_par_iter().for_each(|c| {
        let mut parents = ChildSlots::starting_at(internal, chunks[c], &slots);
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
    /// For a scan that starts at internal square `i`.
    pub(crate) fn starting_at<K: MortonKey>(
        internal: &[Internal<K>],
        i: usize,
        slots: &'s SharedSlots<'a>,
    ) -> Self {
        ChildSlots {
            path: path_in(internal, i),
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

/// The internal squares from the root down to the parent of internal square `i`, by level, with
/// room below for a path down to the finest level.
pub fn path_to<K: MortonKey>(tree: &Quadtree<K>, i: usize) -> Vec<u32> {
    path_in(&tree.internal, i)
}

/// As [`path_to`], in the internal squares alone (in preorder).
pub(crate) fn path_in<K: MortonKey>(internal: &[Internal<K>], i: usize) -> Vec<u32> {
    let cell = internal[i].cell;
    let mut path = vec![0u32; K::AXIS_BITS as usize + 1];
    for level in 0..cell.level {
        let ancestor = Cell::containing(cell.anchor, level);
        // Preorder is the order of (corner, level).
        path[level as usize] = internal[..i]
            .partition_point(|s| ({ s.cell.anchor }, s.cell.level) < ({ ancestor.anchor }, level))
            as u32;
    }
    path
}
