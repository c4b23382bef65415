//! 2:1 balance, cross links and point location (BET §3), built level by level in parallel.
//!
//! Unlike BET's sorting construction, which may over-refine by up to 4×, the balanced tree here
//! is the minimal one: exactly the tree the sequential ripple algorithm gives.

mod closure;
mod graph;
mod incremental;
mod links;
pub mod reference;
mod separate;
mod slack;
mod split_set;

use std::collections::HashSet;

pub use closure::{balance_closure, balance_closure_with_points, forced_by};
pub use graph::{
    CLEARANCE, Conflict, GraphFeatures, TooCrowded, crowded_squares, reach, segment_meets_box,
    shares_an_end,
};
pub use incremental::{GridRect, SeparatedPoints};
use links::cross_links_by;
pub use links::{Links, across, cross_links, point_leaves};
pub use separate::{
    Band, BandError, DomainSides, ON_BOTTOM, ON_LEFT, ON_RIGHT, ON_TOP, Separation, block,
    check_corner_separated, check_corner_separated_in, check_separated, check_separated_in,
    coarsest_band_level, nearest_corner, separate, separate_in, separate_with, sides_of,
    upper_halves,
};

use crate::framework::NONE;
use crate::morton::{Cell, MortonKey, Side};
use crate::quadtree::{IndexedTree, Internal, Quadtree, indexed_from_internal, with_first_points};

/// A balanced quadtree with cross links and point location.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BalancedTree<K: Copy> {
    /// The tree: internal squares in preorder, leaves in Morton order with their points.
    pub tree: Quadtree<K>,
    /// The neighbours of each leaf across each side.
    pub links: Vec<Links>,
    /// The leaf of each point, by Morton position.
    pub point_leaf: Vec<u32>,
}

/// The minimal balanced refinement of `tree`, with cross links and point location.
///
/// # Complexity
/// O(k log k) work for k output squares; the sweep has one parallel step per level.
pub fn balance<K: MortonKey>(tree: &Quadtree<K>, keys: &[K]) -> BalancedTree<K> {
    linked_from_internal(balance_closure_with_points(&tree.internal, keys), keys)
}

/// The tree with split squares `split` (in preorder, balanced), its links and point location.
pub fn linked_tree<K: MortonKey>(split: &[Cell<K>], keys: &[K]) -> BalancedTree<K> {
    linked_from_internal(with_first_points(split, keys), keys)
}

/// As [`linked_tree`], from the split squares with their first points.
fn linked_from_internal<K: MortonKey>(internal: Vec<Internal<K>>, keys: &[K]) -> BalancedTree<K> {
    let IndexedTree {
        tree,
        children,
        point_leaf,
    } = indexed_from_internal(internal, keys);
    let links = cross_links_by(&tree, &children);
    BalancedTree {
        tree,
        links,
        point_leaf,
    }
}

impl<K: MortonKey> BalancedTree<K> {
    /// The leaves across `side` of `leaf` (see [`across`]).
    #[inline]
    pub fn across(&self, leaf: usize, side: Side) -> [u32; 2] {
        across(&self.links, leaf, side)
    }

    /// Checks the tree, its balance, its links and its point location; returns what is wrong.
    pub fn check(&self, keys: &[K]) -> Result<(), String> {
        self.tree.check(keys)?;
        check_balance(&self.tree)?;
        self.check_links()?;
        self.check_point_leaves(keys)
    }

    fn check_links(&self) -> Result<(), String> {
        let leaves = self.tree.leaves.len();
        if self.links.len() != leaves {
            return Err("one set of links per leaf expected".into());
        }
        // Every slot names a leaf (or none) before any is followed.
        for (j, links) in self.links.iter().enumerate() {
            if let Some(side) = links.side_out_of(leaves) {
                return Err(format!("leaf {j} links past the leaves across {side:?}"));
            }
        }
        for j in 0..self.links.len() {
            for side in Side::ALL {
                self.check_side(j, side, self.across(j, side))?;
            }
        }
        Ok(())
    }

    /// One side of leaf `j`: the linked leaves are the ones across it, and link back.
    fn check_side(&self, j: usize, side: Side, pair: [u32; 2]) -> Result<(), String> {
        let leaves = &self.tree.leaves;
        let cell = leaves[j].cell;
        let expected: Vec<Cell<K>> = match cell.neighbour(side) {
            None => Vec::new(),
            Some(beyond) => {
                let holder = leaves.partition_point(|l| { l.cell.anchor } <= { beyond.anchor }) - 1;
                if leaves[holder].cell.level <= beyond.level {
                    vec![leaves[holder].cell]
                } else {
                    side.opposite()
                        .children_touching()
                        .map(|q| beyond.child(q))
                        .to_vec()
                }
            }
        };
        let Some(linked) = pair
            .iter()
            .filter(|&&i| i != NONE)
            .map(|&i| leaves.get(i as usize).map(|l| l.cell))
            .collect::<Option<Vec<Cell<K>>>>()
        else {
            return Err(format!(
                "leaf {j} links {pair:?} across {side:?}, past the leaves"
            ));
        };
        if linked != expected {
            return Err(format!(
                "leaf {j} {cell:?} links {linked:?} across {side:?}, expected {expected:?}"
            ));
        }
        for &i in pair.iter().filter(|&&i| i != NONE) {
            let back = self.across(i as usize, side.opposite());
            if !back.contains(&(j as u32)) {
                return Err(format!(
                    "leaf {i} does not link back to {j} across {:?}",
                    side.opposite()
                ));
            }
        }
        Ok(())
    }

    fn check_point_leaves(&self, keys: &[K]) -> Result<(), String> {
        if self.point_leaf.len() != keys.len() {
            return Err(format!(
                "{} points located, {} expected",
                self.point_leaf.len(),
                keys.len()
            ));
        }
        for (p, &j) in self.point_leaf.iter().enumerate() {
            let Some(&leaf) = self.tree.leaves.get(j as usize) else {
                return Err(format!("point {p} located in leaf {j}, of none"));
            };
            if leaf.point != p as u32 || !leaf.cell.contains(keys[p]) {
                return Err(format!("point {p} located in leaf {j} {leaf:?}"));
            }
        }
        Ok(())
    }
}

/// Balance by the rule: every split square's same-size edge neighbours inside the root are
/// squares of the tree (their parents are split).
pub fn check_balance<K: MortonKey>(tree: &Quadtree<K>) -> Result<(), String> {
    let split: HashSet<Cell<K>> = tree.internal.iter().map(|s| s.cell).collect();
    for s in &tree.internal {
        let cell = s.cell;
        for side in Side::ALL {
            let Some(n) = cell.neighbour(side) else {
                continue;
            };
            if n.level > 0 && !split.contains(&n.parent()) {
                return Err(format!(
                    "split square {cell:?} has no same-size neighbour across {side:?}"
                ));
            }
        }
    }
    Ok(())
}
