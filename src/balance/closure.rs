//! The minimal 2:1 balanced refinement of a set of split squares, level by level.
//!
//! A full quadtree is balanced (leaves sharing a side differ in size by at most 2×) exactly when
//! every split square's four same-size edge neighbours inside the root are squares of the tree,
//! i.e. their parents are split. A split square at level `l` therefore forces its parent and the
//! parent's neighbours across the two sides it touches, all at level `l - 1`. The rule points
//! only to coarser levels, so one sweep from the finest level up reaches the least fixed point:
//! the unique smallest balanced tree containing the input, the one the sequential ripple gives.

use rayon::prelude::*;

use crate::morton::{Cell, MortonKey, Side};

/// The smallest set of split squares that contains `split`, is closed under parents, and
/// makes the quadtree balanced; in preorder.
///
/// # Complexity
/// O(k log k) work for k squares (a parallel sort per level), depth O(L log k) for L levels.
pub fn balance_closure<K: MortonKey>(split: &[Cell<K>]) -> Vec<Cell<K>> {
    let mut levels = by_level(split);
    let mut added = vec![Vec::new(); levels.len()];
    for level in (1..levels.len()).rev() {
        let forced = forced_above(&levels[level], level as u8);
        let fresh = difference_sorted(&forced, &levels[level - 1]);
        levels[level - 1] = merge_sorted(&levels[level - 1], &fresh);
        added[level - 1] = fresh;
    }
    // Only the added squares need sorting into preorder; the input usually is in preorder.
    let mut input = split.to_vec();
    if !input
        .windows(2)
        .all(|w| preorder_key(w[0]) < preorder_key(w[1]))
    {
        input.par_sort_unstable_by_key(|c| preorder_key(*c));
        input.dedup();
    }
    merge_preorder(&input, &preorder_of_levels(&added))
}

fn preorder_key<K: MortonKey>(c: Cell<K>) -> (K, u8) {
    (c.anchor, c.level)
}

/// The preorder union of two disjoint lists of squares in preorder.
fn merge_preorder<K: MortonKey>(a: &[Cell<K>], b: &[Cell<K>]) -> Vec<Cell<K>> {
    let mut out = Vec::with_capacity(a.len() + b.len());
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        if preorder_key(a[i]) < preorder_key(b[j]) {
            out.push(a[i]);
            i += 1;
        } else {
            out.push(b[j]);
            j += 1;
        }
    }
    out.extend_from_slice(&a[i..]);
    out.extend_from_slice(&b[j..]);
    out
}

/// The squares of sorted per-level anchor lists, in preorder.
pub(crate) fn preorder_of_levels<K: MortonKey>(levels: &[Vec<K>]) -> Vec<Cell<K>> {
    let mut cells = Vec::with_capacity(levels.iter().map(Vec::len).sum());
    for (level, anchors) in levels.iter().enumerate() {
        cells.extend(anchors.iter().map(|&anchor| Cell {
            anchor,
            level: level as u8,
        }));
    }
    cells.par_sort_unstable_by_key(|c| preorder_key(*c));
    cells
}

/// Sorted, distinct anchors of the squares at each level `0..=AXIS_BITS`.
pub(crate) fn by_level<K: MortonKey>(split: &[Cell<K>]) -> Vec<Vec<K>> {
    let mut sorted = split.to_vec();
    // One stable counting pass by level; each level is then sorted (a single run when the input
    // was in preorder, which the sort detects in linear time).
    radsort::sort_by_key(&mut sorted, |c| c.level);
    let mut levels = vec![Vec::new(); K::AXIS_BITS as usize + 1];
    for chunk in sorted.chunk_by(|a, b| a.level == b.level) {
        let mut anchors: Vec<K> = chunk.iter().map(|c| c.anchor).collect();
        anchors.par_sort_unstable();
        anchors.dedup();
        levels[chunk[0].level as usize] = anchors;
    }
    levels
}

/// The squares at `level - 1` that the split squares at `level` (sorted anchors) force, sorted
/// and distinct. Siblings are adjacent in the sorted list, so each family is handled once.
pub(crate) fn forced_above<K: MortonKey>(anchors: &[K], level: u8) -> Vec<K> {
    let starts: Vec<usize> = (0..anchors.len())
        .into_par_iter()
        .filter(|&i| {
            i == 0 || anchors[i - 1].cell_anchor(level - 1) != anchors[i].cell_anchor(level - 1)
        })
        .collect();
    let mut forced: Vec<K> = (0..starts.len())
        .into_par_iter()
        .flat_map_iter(|f| {
            let end = starts.get(f + 1).copied().unwrap_or(anchors.len());
            let family = anchors[starts[f]..end]
                .iter()
                .map(|&anchor| Cell { anchor, level });
            forced_by_family(family)
                .into_iter()
                .flatten()
                .map(|c| c.anchor)
        })
        .collect();
    forced.par_sort_unstable();
    forced.dedup();
    forced
}

/// What split siblings force together: their parent, and the parent's neighbours across the
/// sides of the parent that they touch.
fn forced_by_family<K: MortonKey>(family: impl Iterator<Item = Cell<K>>) -> [Option<Cell<K>>; 5] {
    let mut touched = [false; 4];
    let mut parent = None;
    for cell in family {
        parent = Some(cell.parent());
        for side in touched_sides(cell) {
            touched[side as usize] = true;
        }
    }
    let Some(parent) = parent else {
        return [None; 5];
    };
    let mut out = [Some(parent), None, None, None, None];
    for side in Side::ALL {
        if touched[side as usize] {
            out[1 + side as usize] = parent.neighbour(side);
        }
    }
    out
}

/// The two sides of its parent that a square touches.
fn touched_sides<K: MortonKey>(cell: Cell<K>) -> [Side; 2] {
    let q = cell.quadrant();
    let across_x = if q & 2 == 0 { Side::West } else { Side::East };
    let across_y = if q & 1 == 0 { Side::South } else { Side::North };
    [across_x, across_y]
}

/// What one split square forces: its parent, and the parent's neighbours across the two sides
/// of the parent that the square touches (none outside the root).
pub fn forced_by<K: MortonKey>(cell: Cell<K>) -> [Option<Cell<K>>; 3] {
    let parent = cell.parent();
    let [across_x, across_y] = touched_sides(cell);
    [
        Some(parent),
        parent.neighbour(across_x),
        parent.neighbour(across_y),
    ]
}

/// The sorted union of two sorted, distinct lists.
pub(crate) fn merge_sorted<K: MortonKey>(a: &[K], b: &[K]) -> Vec<K> {
    let mut out = Vec::with_capacity(a.len() + b.len());
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        let next = a[i].min(b[j]);
        out.push(next);
        i += usize::from(a[i] == next);
        j += usize::from(b[j] == next);
    }
    out.extend_from_slice(&a[i..]);
    out.extend_from_slice(&b[j..]);
    out
}

/// The elements of sorted `a` that are not in sorted `b`.
pub(crate) fn difference_sorted<K: MortonKey>(a: &[K], b: &[K]) -> Vec<K> {
    let mut j = 0;
    a.iter()
        .copied()
        .filter(|x| {
            j += b[j..].partition_point(|y| y < x);
            b.get(j) != Some(x)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn difference_removes_the_common_ones() {
        assert_eq!(
            difference_sorted::<u64>(&[1, 2, 3, 7], &[2, 7, 9]),
            vec![1, 3]
        );
        assert_eq!(difference_sorted::<u64>(&[1], &[]), vec![1]);
    }

    #[test]
    fn merge_keeps_one_of_each() {
        assert_eq!(
            merge_sorted::<u64>(&[1, 3, 5], &[2, 3, 6]),
            vec![1, 2, 3, 5, 6]
        );
        assert_eq!(merge_sorted::<u64>(&[], &[2]), vec![2]);
    }

    #[test]
    fn input_order_does_not_matter() {
        let cells: Vec<Cell<u64>> = (0..500u64)
            .map(|i| Cell::containing(i.wrapping_mul(0x9E37_79B9_7F4A_7C15), (i % 9 + 3) as u8))
            .collect();
        let mut reversed = cells.clone();
        reversed.reverse();
        reversed.extend_from_slice(&cells[..50]);
        assert_eq!(balance_closure(&cells), balance_closure(&reversed));
        assert_eq!(
            balance_closure(&cells),
            crate::balance::reference::ripple_closure(&cells)
        );
    }

    #[test]
    fn a_deep_corner_square_forces_a_staircase() {
        // One split square at level 6 in the middle of the root forces squares at every level.
        let deep = Cell::<u64>::containing(u64::encode(1 << 31, 1 << 31), 6);
        let closed = balance_closure(&[deep]);
        for level in 0..6 {
            assert!(closed.iter().any(|c| c.level == level), "level {level}");
        }
        assert!(
            closed
                .windows(2)
                .all(|w| (w[0].anchor, w[0].level) < (w[1].anchor, w[1].level))
        );
    }
}
