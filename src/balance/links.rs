//! Cross links between leaves that share a side, and the leaf of every point.
//!
//! A leaf's neighbour across a side is found as in a pointer quadtree: climb while the path to
//! the leaf runs along that side, step to the sibling across it, and descend mirrored. The climb
//! is O(1) levels on average (each level is on the side with probability 1/2).

use rayon::prelude::*;

use crate::framework::NONE;
use crate::morton::{Cell, MortonKey, Side};
use crate::par::{collect_indexed, collect_segments};
use crate::quadtree::index::{LEAF, TreeIndex, quadrant_at};
use crate::quadtree::{Quadtree, gap_offsets};

/// A leaf's neighbours across its four sides (in [`Side::ALL`] order), two slots per side: one
/// leaf of the same or twice the size and [`NONE`], or the two half-size leaves in increasing
/// coordinate along the side, or two [`NONE`] on the root's boundary.
pub type Links = [u32; 8];

/// The cross links of every leaf of a balanced tree.
///
/// # Complexity
/// O(k) expected work, O(k · depth) at worst; leaves in parallel.
pub fn cross_links<K: MortonKey>(tree: &Quadtree<K>) -> Vec<Links> {
    if tree.internal.is_empty() {
        return vec![[NONE; 8]; tree.leaves.len()];
    }
    let index = &TreeIndex::new(tree);
    // The same-size neighbours of internal squares, by climbing; a leaf's then take O(1).
    let beside = &collect_indexed(tree.internal.len(), |i| {
        let cell = tree.internal[i].cell;
        Side::ALL.map(|side| match index.parent[i] {
            NONE => NONE,
            parent => same_size(index, cell, parent, side),
        })
    });
    let offsets = gap_offsets(&tree.internal);
    collect_segments(&offsets, |i| {
        // Leaves after internal square `i` are children of `i` or of its ancestors, in turn.
        let mut parent = i as u32;
        tree.leaves[offsets[i]..offsets[i + 1]]
            .iter()
            .map(move |leaf| {
                while tree.internal[parent as usize].cell.level + 1 > leaf.cell.level {
                    parent = index.parent[parent as usize];
                }
                let q = leaf.cell.quadrant();
                let mut links = [NONE; 8];
                for side in Side::ALL {
                    let entry = if on_side(q, side) {
                        match beside[parent as usize][side as usize] {
                            e if e == NONE || e & LEAF != 0 => e,
                            e => index.children[e as usize][mirror(q, side) as usize],
                        }
                    } else {
                        index.children[parent as usize][mirror(q, side) as usize]
                    };
                    let pair = leaves_facing(index, entry, side);
                    links[2 * side as usize..2 * side as usize + 2].copy_from_slice(&pair);
                }
                links
            })
    })
}

/// The entry of the same-size square across `side` of `cell` (whose parent is internal square
/// `parent`): an internal index, a leaf index tagged [`LEAF`] for a leaf that covers it (of the
/// same or a larger size), or [`NONE`] outside the root. Climb while the path runs along the
/// side, step across, descend mirrored.
fn same_size<K: MortonKey>(index: &TreeIndex, cell: Cell<K>, parent: u32, side: Side) -> u32 {
    let mut level = cell.level;
    let mut node = parent as usize;
    while on_side(quadrant_at(cell, level), side) {
        if level == 1 {
            return NONE;
        }
        node = index.parent[node] as usize;
        level -= 1;
    }
    let mut entry = index.children[node][mirror(quadrant_at(cell, level), side) as usize];
    for deeper in level + 1..=cell.level {
        if entry & LEAF != 0 {
            return entry;
        }
        entry = index.children[entry as usize][mirror(quadrant_at(cell, deeper), side) as usize];
    }
    entry
}

/// The leaves across `side` given the entry of the same-size square there: that leaf, or, if
/// the square is split, its two children facing us (leaves, by balance).
fn leaves_facing(index: &TreeIndex, entry: u32, side: Side) -> [u32; 2] {
    if entry == NONE {
        return [NONE; 2];
    }
    if entry & LEAF != 0 {
        return [entry & !LEAF, NONE];
    }
    let facing = side.opposite().children_touching();
    facing.map(|q| match index.children[entry as usize][q as usize] {
        e if e & LEAF != 0 => e & !LEAF,
        _ => NONE,
    })
}

/// Whether a child in quadrant `q` touches its parent's `side`.
fn on_side(q: u32, side: Side) -> bool {
    match side {
        Side::West => q & 2 == 0,
        Side::East => q & 2 != 0,
        Side::South => q & 1 == 0,
        Side::North => q & 1 != 0,
    }
}

/// The quadrant across `side` from quadrant `q`, within the same parent or the next one.
fn mirror(q: u32, side: Side) -> u32 {
    match side {
        Side::West | Side::East => q ^ 2,
        Side::South | Side::North => q ^ 1,
    }
}

/// The leaf of each point, by Morton position: points and leaves are both in Morton order.
pub fn point_leaves<K: MortonKey>(tree: &Quadtree<K>) -> Vec<u32> {
    let leaves = &tree.leaves;
    (0..leaves.len() as u32)
        .into_par_iter()
        .filter(|&j| leaves[j as usize].point != NONE)
        .collect()
}
