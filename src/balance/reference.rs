//! Sequential oracle for balancing: split squares into a hash set and apply the forcing rule
//! until nothing changes, in no particular order (the ripple).

use std::collections::HashSet;

use crate::morton::{Cell, MortonKey};

/// The closure of `split` under the balance rule, in preorder, by naive iteration.
pub fn ripple_closure<K: MortonKey>(split: &[Cell<K>]) -> Vec<Cell<K>> {
    let mut closed: HashSet<Cell<K>> = split.iter().copied().collect();
    let mut pending: Vec<Cell<K>> = split.to_vec();
    while let Some(cell) = pending.pop() {
        if cell.level == 0 {
            continue;
        }
        for forced in forced(cell) {
            if closed.insert(forced) {
                pending.push(forced);
            }
        }
    }
    let mut out: Vec<Cell<K>> = closed.into_iter().collect();
    out.sort_by_key(|c| (c.anchor, c.level));
    out
}

/// The squares one split square forces, from coordinates: its parent, and the parent-size
/// squares beside the parent that touch the split square's sides.
fn forced<K: MortonKey>(cell: Cell<K>) -> Vec<Cell<K>> {
    let parent = cell.parent();
    let mut out = vec![parent];
    for (dx, dy) in [(-1, 0), (1, 0), (0, -1), (0, 1)] {
        // The same-size neighbour of `cell` across this side; if it lies outside the parent,
        // its parent must be split.
        if let Some(n) = cell.offset(dx, dy)
            && n.parent() != parent
        {
            out.push(n.parent());
        }
    }
    out
}
