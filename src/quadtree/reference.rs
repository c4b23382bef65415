//! A deliberately simple sequential top-down builder: the oracle the parallel stages are tested
//! against. It splits squares by comparing grid coordinates, never Morton keys, so it shares no
//! logic with the fast path beyond decoding a key into its coordinates.

use super::{Cell, Internal, Leaf, Quadtree};
use crate::framework::NONE;
use crate::morton::MortonKey;

/// Builds the unbalanced quadtree of strictly increasing keys by recursive splitting.
pub fn build_reference<K: MortonKey>(keys: &[K]) -> Quadtree<K> {
    let coords: Vec<(u64, u64)> = keys.iter().map(|k| k.decode()).collect();
    let mut tree = Quadtree {
        internal: Vec::new(),
        leaves: Vec::new(),
    };
    let all: Vec<usize> = (0..keys.len()).collect();
    split(&coords, (0, 0), 0, all, &mut tree);
    tree
}

fn split<K: MortonKey>(
    coords: &[(u64, u64)],
    corner: (u64, u64),
    level: u8,
    inside: Vec<usize>,
    tree: &mut Quadtree<K>,
) {
    let cell = Cell {
        anchor: K::encode(corner.0, corner.1),
        level,
    };
    if inside.len() < 2 {
        let point = inside.first().map_or(NONE, |&p| p as u32);
        tree.leaves.push(Leaf { cell, point });
        return;
    }
    let first = *inside.iter().min().expect("two or more points") as u32;
    tree.internal.push(Internal { cell, first });
    let half = 1u64 << (K::AXIS_BITS - 1 - level as u32);
    // Quadrant order of the Morton keys: x bit above y bit.
    for (dx, dy) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
        let child = (corner.0 + dx * half, corner.1 + dy * half);
        let within = |&&p: &&usize| {
            let (x, y) = coords[p];
            x >= child.0 && x - child.0 < half && y >= child.1 && y - child.1 < half
        };
        let sub: Vec<usize> = inside.iter().filter(within).copied().collect();
        split(coords, child, level + 1, sub, tree);
    }
}
