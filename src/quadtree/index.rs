//! Navigation in a quadtree stored as flat arrays: the parent of every internal square and the
//! four children of each, found by gathers in parallel (no scatter, no search).

use crate::framework::{NONE, nearest_at_most_right, nearest_smaller_left};
use crate::morton::{Cell, MortonKey};
use crate::par::collect_indexed;

use super::{Quadtree, leaves_before};

/// Tag of a child entry that is a leaf index rather than an internal-square index.
pub const LEAF: u32 = 1 << 31;

/// Parents and children of the internal squares of a tree.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TreeIndex {
    /// Parent (internal index) of each internal square; [`NONE`] for the root.
    pub parent: Vec<u32>,
    /// Children of each internal square by quadrant: an internal index, or a leaf index tagged
    /// with [`LEAF`].
    pub children: Vec<[u32; 4]>,
}

impl TreeIndex {
    /// The index of a tree with at least one internal square and fewer than 2^31 leaves.
    ///
    /// In preorder, an internal square's parent is the nearest earlier square of a smaller level,
    /// and its next sibling the nearest later square of no greater level. A leaf child's index
    /// follows from the number of internal squares before it ([`leaves_before`]).
    ///
    /// # Panics
    /// If the tree has 2^31 leaves or more.
    pub fn new<K: MortonKey>(tree: &Quadtree<K>) -> Self {
        assert!(
            tree.leaves.len() < LEAF as usize,
            "too many leaves to index"
        );
        let levels: Vec<u8> = collect_indexed(tree.internal.len(), |i| tree.internal[i].cell.level);
        let parent = nearest_smaller_left(&levels);
        let after = nearest_at_most_right(&levels);
        let children = collect_indexed(tree.internal.len(), |i| children_of(tree, &after, i));
        TreeIndex { parent, children }
    }
}

/// The children of internal square `i`: consecutive internal children are linked by `after`.
fn children_of<K: MortonKey>(tree: &Quadtree<K>, after: &[u32], i: usize) -> [u32; 4] {
    let internal = &tree.internal;
    let mut next = i + 1;
    let cell = internal[i].cell;
    [0, 1, 2, 3].map(|q| {
        let child = cell.child(q);
        if internal.get(next).is_some_and(|s| { s.cell } == child) {
            let here = next as u32;
            next = match after[next] {
                NONE => internal.len(),
                a => a as usize,
            };
            here
        } else {
            LEAF | leaves_before(next, child) as u32
        }
    })
}

/// The quadrant of the ancestor of `cell` at `level` within its parent (`level >= 1`).
pub fn quadrant_at<K: MortonKey>(cell: Cell<K>, level: u8) -> u32 {
    Cell::containing(cell.anchor, level).quadrant()
}
