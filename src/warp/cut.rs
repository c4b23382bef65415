//! The leaves a given domain keeps: those below the grid row that the band along a short
//! domain's top side moves onto that side (see [`crate::balance::Band`]), or inside a cells
//! grid's sides.

use rayon::prelude::*;

use glam::DVec2;

use crate::balance::{BalancedTree, Links};
use crate::error::Error;
use crate::mesh::NONE;
use crate::morton::{Grid, MortonKey, Side};
use crate::par::{collect_indexed, exclusive_scan_u32_by};
use crate::quadtree::{Leaf, Quadtree};

/// The leaves of `tree` inside the domain of `grid`: [`leaves_below`] its sides inside the root
/// ([`Grid::inner_lines`]), if any; `tree` itself otherwise. `order[i]` is the input index of
/// the `i`-th point of `points` in Morton order.
///
/// # Errors
/// [`Error::Unresolvable`] naming a point left without a leaf, which separation rules out.
pub fn leaves_in_domain<K: MortonKey>(
    tree: BalancedTree<K>,
    grid: &Grid,
    (order, points): (&[u32], &[DVec2]),
) -> Result<BalancedTree<K>, Error> {
    let [right, top] = grid.inner_lines();
    if right.is_none() && top.is_none() {
        return Ok(tree);
    }
    leaves_below(tree, top.unwrap_or(u128::MAX), right).map_err(|p| {
        let index = order[p];
        super::unresolvable(points[index as usize], index)
    })
}

/// The leaves of `tree` whose tops lie at or below the finest-unit row `row` and, if given,
/// whose right sides lie at or left of the finest-unit column `right`, in their order, with
/// links across the row and column removed: they are then the mesh's boundary. A point whose leaf
/// lies above the row (it is on the domain's top side, in the band's crossing row when the row
/// is that row's bottom) moves to the leaf of the same size below, whose top side it lies on.
///
/// No leaf straddles `row`, as the band's leaves line it; so two smaller neighbours of a kept
/// leaf are both kept, as they share the coordinate the cut decides on. A kept west or east pair
/// stays consecutive, and a kept south or north pair's second leaf stays the first's east
/// neighbour, as [`crate::balance::across`] needs.
///
/// # Errors
/// The Morton position of a point left without a leaf, which separation rules out.
pub fn leaves_below<K: MortonKey>(
    tree: BalancedTree<K>,
    row: u128,
    right: Option<u128>,
) -> Result<BalancedTree<K>, usize> {
    let leaves = &tree.tree.leaves;
    let column = right.unwrap_or(u128::MAX);
    let kept: Vec<bool> = leaves
        .par_iter()
        .map(|l| {
            let (x, y, size) = square_of(l);
            y + size <= row && x + size <= column
        })
        .collect();
    let index = exclusive_scan_u32_by(leaves.len(), |j| usize::from(kept[j]))
        .expect("fewer leaves than 32-bit indices");
    let renumber = |j: u32| {
        if j != NONE && kept[j as usize] {
            index[j as usize]
        } else {
            NONE
        }
    };
    let old_of: Vec<u32> = (0..leaves.len() as u32)
        .into_par_iter()
        .filter(|&j| kept[j as usize])
        .collect();
    let mut new_leaves: Vec<Leaf<K>> =
        collect_indexed(old_of.len(), |j| leaves[old_of[j] as usize]);
    let links = collect_indexed(old_of.len(), |j| {
        let old = old_of[j] as usize;
        Links::new(Side::ALL.map(|side| tree.across(old, side).map(renumber)))
    });
    let point_leaf: Vec<u32> = tree
        .point_leaf
        .par_iter()
        .map(|&j| {
            let below = if kept[j as usize] {
                j
            } else {
                tree.across(j as usize, Side::South)[0]
            };
            renumber(below)
        })
        .collect();
    for (p, &j) in point_leaf.iter().enumerate() {
        if j == NONE {
            return Err(p);
        }
        new_leaves[j as usize].point = p as u32;
    }
    Ok(BalancedTree {
        tree: Quadtree {
            leaves: new_leaves,
            internal: Vec::new(),
        },
        links,
        point_leaf,
    })
}

/// A leaf's lower-left corner and side, in finest units.
fn square_of<K: MortonKey>(leaf: &Leaf<K>) -> (u128, u128, u128) {
    let (x, y) = leaf.cell.anchor.decode();
    let size = 1u128 << (K::AXIS_BITS - leaf.cell.level as u32);
    (u128::from(x), u128::from(y), size)
}
