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
    let slot = |parent: u32, child: Cell<K>| 4 * parent as usize + child.quadrant() as usize;
    let chunks = chunk_offsets(internal.len(), GRAIN);
    (0..chunks.len() - 1).into_par_iter().for_each(|c| {
        let mut path = path_to(tree, chunks[c]);
        for (i, gap) in with_gap_leaves(internal, chunks[c]..chunks[c + 1]) {
            let cell = internal[i].cell;
            if cell.level > 0 {
                let parent = path[cell.level as usize - 1];
                // A square has one parent, so its slot has one writer.
                slots.store(slot(parent, cell), i as u32);
            }
            path[cell.level as usize] = i as u32;
            for j in gap {
                let leaf = tree.leaves[j].cell;
                let parent = path[leaf.level as usize - 1];
                slots.store(slot(parent, leaf), LEAF | j as u32);
            }
        }
    });
    children
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
