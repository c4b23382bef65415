//! Well-separated point cells: the smallest balanced tree in which every point's leaf sits at the
//! centre of a 5×5 block of unsplit same-size leaves holding no other point (rules R1–R3 of
//! `algorithms/beg-quadtree-meshing.md` §2.2), the tree the warp needs.
//!
//! In terms of split squares the rules read:
//! * R1: a square holding two points is split (the unbalanced tree's internal squares);
//! * R2: balance (see [`super::balance_closure`]);
//! * R3b: every split square holding a point has its 8 same-size neighbours split (so the 5×5
//!   blocks around its children are squares of the tree);
//! * R3a, c, d: a point's leaf is split if its 5×5 block holds a split square, another point, or
//!   sticks out of the root.
//!
//! Every rule only adds splits, so their least fixed point is unique. The rounds are
//! incremental: a rule can only newly fire near a square split in the previous round, so each
//! round checks the neighbourhoods of the new squares alone, in parallel, and closes them under
//! balance. The result does not depend on the thread count or on the order splits are found in.

use rayon::prelude::*;

use super::closure::{by_level, difference_sorted, forced_above, merge_sorted, preorder_of_levels};
use super::{BalancedTree, linked_tree};
use crate::morton::{Cell, MortonKey};
use crate::quadtree::{Quadtree, points_in};

/// The well-separated refinement of `tree`, with links and point location.
///
/// Points must be at least a few finest-grid cells apart for their blocks to be separable; the
/// guard levels of [`crate::morton`] give 16. Squares at the finest level are never split.
///
/// # Complexity
/// Each round costs O(a log k) for a squares added plus a merge of the levels it touches, in
/// parallel. Typical inputs need 5–20 rounds; a chain of points placed so that each split forces
/// the next one takes a round per point, which makes such inputs quadratic.
pub fn separate<K: MortonKey>(tree: &Quadtree<K>, keys: &[K]) -> BalancedTree<K> {
    let mut set = SplitSet::new();
    let mut demanded: Vec<Cell<K>> = tree.internal.iter().map(|s| s.cell).collect();
    if !keys.is_empty() {
        // R3d: the root's block always sticks out of the root.
        demanded.push(Cell::root());
    }
    while !demanded.is_empty() {
        let added = set.add_closed(&demanded);
        demanded = demands_near(&set, keys, &added);
    }
    linked_tree(&set.preorder(), keys)
}

/// Split squares closed under balance, as sorted anchors per level.
struct SplitSet<K> {
    levels: Vec<Vec<K>>,
}

impl<K: MortonKey> SplitSet<K> {
    fn new() -> Self {
        SplitSet {
            levels: vec![Vec::new(); K::AXIS_BITS as usize + 1],
        }
    }

    fn contains(&self, cell: Cell<K>) -> bool {
        self.levels[cell.level as usize]
            .binary_search(&cell.anchor)
            .is_ok()
    }

    /// Adds `cells` and whatever balance then forces; returns the squares that were new.
    fn add_closed(&mut self, cells: &[Cell<K>]) -> Vec<Cell<K>> {
        let mut pending = by_level(cells);
        let mut added = Vec::new();
        for level in (0..pending.len()).rev() {
            let fresh = difference_sorted(&pending[level], &self.levels[level]);
            if fresh.is_empty() {
                continue;
            }
            self.levels[level] = merge_sorted(&self.levels[level], &fresh);
            if level > 0 {
                let forced = forced_above(&fresh, level as u8);
                pending[level - 1] = merge_sorted(&pending[level - 1], &forced);
            }
            added.extend(fresh.into_iter().map(|anchor| Cell {
                anchor,
                level: level as u8,
            }));
        }
        added
    }

    fn preorder(&self) -> Vec<Cell<K>> {
        preorder_of_levels(&self.levels)
    }

    /// Whether `cell` is a leaf of the current tree: not split, and its parent is.
    fn is_leaf(&self, cell: Cell<K>) -> bool {
        !self.contains(cell) && (cell.level == 0 || self.contains(cell.parent()))
    }
}

/// What the rules demand near the squares `added` in the last round: rings around the new split
/// squares holding points (R3b), point leaves whose block now holds a split square (R3a), and
/// the new point leaves below the new squares (R3a, c, d), with every deeper level R3c and R3d
/// force on them.
fn demands_near<K: MortonKey>(set: &SplitSet<K>, keys: &[K], added: &[Cell<K>]) -> Vec<Cell<K>> {
    let rings = added
        .par_iter()
        .filter(|&&square| holds_point(square, keys))
        .flat_map_iter(|&square| ring(square).flatten().filter(|&c| !set.contains(c)));
    // A point leaf can be near many new squares: collect each once, then check it.
    let mut leaves: Vec<Cell<K>> = added
        .par_iter()
        .flat_map_iter(|&square| point_leaves_near(set, keys, square))
        .collect();
    sorted_distinct(&mut leaves);
    let crowded = leaves
        .par_iter()
        .flat_map_iter(|&leaf| crowded_leaf(set, keys, leaf));
    let mut demanded: Vec<Cell<K>> = rings.chain(crowded).collect();
    sorted_distinct(&mut demanded);
    demanded
}

/// The point leaves whose rules a new split `square` may have made fire: its new children
/// holding points, and the point leaves of its size in its 5×5 block.
fn point_leaves_near<K: MortonKey>(set: &SplitSet<K>, keys: &[K], square: Cell<K>) -> Vec<Cell<K>> {
    let mut out = Vec::new();
    if holds_point(square, keys) {
        let children = (0..4).map(|q| square.child(q));
        out.extend(children.filter(|&c| !set.contains(c) && holds_point(c, keys)));
    }
    if block_may_hold_point(square, keys) {
        out.extend(
            block(square)
                .flatten()
                .filter(|&c| set.is_leaf(c) && holds_point(c, keys)),
        );
    }
    out
}

fn sorted_distinct<K: MortonKey>(cells: &mut Vec<Cell<K>>) {
    cells.par_sort_unstable_by_key(|c| (c.anchor, c.level));
    cells.dedup();
}

/// The point leaf `leaf` and the squares below it on its point's path, as far as the rules
/// force them; nothing if its block is clear.
fn crowded_leaf<K: MortonKey>(set: &SplitSet<K>, keys: &[K], leaf: Cell<K>) -> Vec<Cell<K>> {
    let touches_split = block(leaf).flatten().any(|c| set.contains(c));
    if !touches_split && !crowded_by_points(leaf, keys) {
        return Vec::new();
    }
    let key = keys[points_in(leaf, keys).start];
    let deeper = (leaf.level + 1..K::AXIS_BITS as u8)
        .map(|level| Cell::containing(key, level))
        .take_while(|&c| crowded_by_points(c, keys));
    // A finest-level square has no children to split into.
    std::iter::once(leaf)
        .chain(deeper)
        .filter(|c| (c.level as u32) < K::AXIS_BITS)
        .collect()
}

fn holds_point<K: MortonKey>(cell: Cell<K>, keys: &[K]) -> bool {
    let first = keys.partition_point(|k| *k < cell.anchor);
    keys.get(first).is_some_and(|k| cell.contains(*k))
}

/// A cheap filter: whether any point lies in the (at most 2×2) squares four times as large that
/// cover the 5×5 block around `cell`.
fn block_may_hold_point<K: MortonKey>(cell: Cell<K>, keys: &[K]) -> bool {
    if cell.level < 2 {
        return true;
    }
    let coarse = |c: Option<Cell<K>>| c.map(|c| Cell::containing(c.anchor, cell.level - 2));
    let corners = [
        coarse(cell.offset(-2, -2)),
        coarse(cell.offset(2, -2)),
        coarse(cell.offset(-2, 2)),
        coarse(cell.offset(2, 2)),
    ];
    // A corner outside the root: fall back to the full check.
    corners
        .iter()
        .any(|c| c.is_none_or(|c| holds_point(c, keys)))
}

/// Whether the 5×5 block around `cell` sticks out of the root or holds a point outside `cell`.
fn crowded_by_points<K: MortonKey>(cell: Cell<K>, keys: &[K]) -> bool {
    block(cell).any(|square| square.is_none_or(|square| holds_point(square, keys)))
}

/// The 8 same-size squares around `cell` (`None` outside the root).
fn ring<K: MortonKey>(cell: Cell<K>) -> impl Iterator<Item = Option<Cell<K>>> {
    square_offsets(1).map(move |(dx, dy)| cell.offset(dx, dy))
}

/// The 24 same-size squares of the 5×5 block around `cell` (`None` outside the root).
pub fn block<K: MortonKey>(cell: Cell<K>) -> impl Iterator<Item = Option<Cell<K>>> {
    square_offsets(2).map(move |(dx, dy)| cell.offset(dx, dy))
}

/// Offsets `(dx, dy)` with `max(|dx|, |dy|)` from 1 to `radius`.
fn square_offsets(radius: i64) -> impl Iterator<Item = (i64, i64)> {
    (-radius..=radius)
        .flat_map(move |dx| (-radius..=radius).map(move |dy| (dx, dy)))
        .filter(|&d| d != (0, 0))
}

/// Checks the well-separation rules on a tree, with hash sets: every point leaf's 5×5 block
/// lies in the root and consists of leaves of its size holding no other point, and every split
/// square holding a point has its 8 neighbours split.
pub fn check_separated<K: MortonKey>(tree: &Quadtree<K>, keys: &[K]) -> Result<(), String> {
    use crate::framework::NONE;
    use std::collections::{HashMap, HashSet};
    let split: HashSet<Cell<K>> = tree.internal.iter().map(|s| s.cell).collect();
    let leaf_point: HashMap<Cell<K>, u32> = tree.leaves.iter().map(|l| (l.cell, l.point)).collect();
    for leaf in tree.leaves.iter().filter(|l| l.point != NONE) {
        for square in block(leaf.cell) {
            let Some(square) = square else {
                return Err(format!("block of {:?} leaves the root", leaf.cell));
            };
            match leaf_point.get(&square) {
                Some(&NONE) => {}
                Some(_) => return Err(format!("block of {:?} holds another point", leaf.cell)),
                None => {
                    return Err(format!(
                        "block of {:?} has {square:?}, not a leaf",
                        leaf.cell
                    ));
                }
            }
        }
    }
    for s in &tree.internal {
        if holds_point(s.cell, keys) && ring(s.cell).flatten().any(|c| !split.contains(&c)) {
            return Err(format!(
                "split square {:?} holds a point but a neighbour is not split",
                s.cell
            ));
        }
    }
    Ok(())
}
