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

/// The well-separated tree's split squares by brute force (rules R1–R3, see
/// [`crate::balance::separate`]), in preorder: quadratic in the points, for tests on small inputs.
pub fn separated_closure<K: MortonKey>(keys: &[K]) -> Vec<Cell<K>> {
    let unbalanced = crate::quadtree::reference::build_reference(keys);
    let mut split: Vec<Cell<K>> = unbalanced.internal.iter().map(|s| s.cell).collect();
    loop {
        split = ripple_closure(&split);
        let set: HashSet<Cell<K>> = split.iter().copied().collect();
        let mut demanded: Vec<Cell<K>> = Vec::new();
        for (i, &key) in keys.iter().enumerate() {
            let leaf = leaf_of(&set, key);
            if crowded(&set, keys, i, leaf) {
                demanded.push(leaf);
            }
        }
        for &p in &split {
            if keys.iter().any(|&k| p.contains(k)) {
                let ring = (-1..=1).flat_map(|dx| (-1..=1).map(move |dy| (dx, dy)));
                demanded.extend(
                    ring.filter_map(|(dx, dy)| p.offset(dx, dy))
                        .filter(|c| !set.contains(c)),
                );
            }
        }
        demanded.retain(|c| !set.contains(c));
        if demanded.is_empty() {
            return split;
        }
        split.extend(demanded);
    }
}

/// The leaf holding `key`: walk down while the square is split.
fn leaf_of<K: MortonKey>(split: &HashSet<Cell<K>>, key: K) -> Cell<K> {
    let mut level = 0;
    while split.contains(&Cell::containing(key, level)) {
        level += 1;
    }
    Cell::containing(key, level)
}

/// Whether point `i`'s 5×5 block around its leaf sticks out of the root, holds a split square,
/// or holds another point.
fn crowded<K: MortonKey>(split: &HashSet<Cell<K>>, keys: &[K], i: usize, leaf: Cell<K>) -> bool {
    for dx in -2..=2 {
        for dy in -2..=2 {
            let Some(square) = leaf.offset(dx, dy) else {
                return true;
            };
            if split.contains(&square) {
                return true;
            }
            let other = keys
                .iter()
                .enumerate()
                .any(|(j, &k)| j != i && square.contains(k));
            if other {
                return true;
            }
        }
    }
    false
}

/// The split squares of the [`super::Separation::Corner`] tree by brute force, in preorder:
/// quadratic in the points, for tests on small inputs. A point's leaf is split while its
/// corner block sticks out of the root, holds a split square, or shares a square with another
/// point's corner block at that level (the other point's nearest corner at most a square
/// away); every square holding a point has the parents of its corner block split.
pub fn corner_separated_closure<K: MortonKey>(keys: &[K]) -> Vec<Cell<K>> {
    corner_separated_closure_in(keys, &vec![0; keys.len()])
}

/// [`corner_separated_closure`] on a square domain, `on[i]` the sides point `i` lies on
/// (bits as [`super::sides_of`] gives): its block is cut at those sides, and may stick out of
/// the root across no other.
pub fn corner_separated_closure_in<K: MortonKey>(keys: &[K], on: &[u8]) -> Vec<Cell<K>> {
    use super::separate::nearest_corner;
    use super::{ON_BOTTOM, ON_LEFT, ON_RIGHT, ON_TOP};
    let unbalanced = crate::quadtree::reference::build_reference(keys);
    let mut split: Vec<Cell<K>> = unbalanced.internal.iter().map(|s| s.cell).collect();
    let block = |cell: Cell<K>, key: K, on: u8| -> Option<Vec<Cell<K>>> {
        let (cx, cy) = nearest_corner(cell, key);
        let (x, y) = super::split_set::grid_position(cell);
        let (dx, dy) = (cx as i64 - x as i64, cy as i64 - y as i64);
        let side = 1i64 << cell.level;
        // A square beyond the root is left out if the point lies on the side it is beyond.
        let beyond_own_side = |(ox, oy): (i64, i64)| {
            let (sx, sy) = (cx as i64 + ox, cy as i64 + oy);
            (sx < 0 && on & ON_LEFT != 0)
                || (sx >= side && on & ON_RIGHT != 0)
                || (sy < 0 && on & ON_BOTTOM != 0)
                || (sy >= side && on & ON_TOP != 0)
        };
        [(-1, -1), (0, -1), (-1, 0), (0, 0)]
            .into_iter()
            .filter(|&o| !beyond_own_side(o))
            .map(|(ox, oy)| cell.offset(dx + ox, dy + oy))
            .collect()
    };
    loop {
        split = ripple_closure(&split);
        let set: HashSet<Cell<K>> = split.iter().copied().collect();
        let mut demanded: Vec<Cell<K>> = Vec::new();
        for (i, &key) in keys.iter().enumerate() {
            let leaf = leaf_of(&set, key);
            let corner = nearest_corner(leaf, key);
            let shares = keys.iter().enumerate().any(|(j, &other)| {
                let (ox, oy) = nearest_corner(Cell::containing(other, leaf.level), other);
                j != i && ox.abs_diff(corner.0) <= 1 && oy.abs_diff(corner.1) <= 1
            });
            let crowded = match block(leaf, key, on[i]) {
                None => true,
                Some(squares) => shares || squares.iter().any(|s| set.contains(s)),
            };
            if crowded && (leaf.level as u32) < K::AXIS_BITS {
                demanded.push(leaf);
            }
        }
        for &p in &split {
            for (i, &key) in keys.iter().enumerate().filter(|(_, k)| p.contains(**k)) {
                let child = Cell::containing(key, p.level + 1);
                if let Some(squares) = block(child, key, on[i]) {
                    demanded.extend(squares.iter().map(|s| s.parent()));
                }
            }
        }
        demanded.retain(|c| !set.contains(c));
        if demanded.is_empty() {
            return split;
        }
        split.extend(demanded);
    }
}

/// The crowded squares of a graph (see [`crate::balance::crowded_squares`]) by brute force:
/// from the root, depth first, every vertex and edge tried against each square's reach; in
/// preorder. Quadratic in the graph, for tests on small inputs. `None` if a square at `finest`
/// is crowded.
pub fn graph_crowded_squares<K: MortonKey>(
    grid: &crate::morton::Grid,
    points: &[glam::DVec2],
    edges: &[[u32; 2]],
    (clearance, finest): (f64, u8),
) -> Option<Vec<Cell<K>>> {
    let mut out = Vec::new();
    let mut pending = vec![Cell::<K>::root()];
    while let Some(cell) = pending.pop() {
        let (lo, hi) = crate::balance::reach(grid, cell, clearance);
        let inside = |p: glam::DVec2| p.cmpge(lo).all() && p.cmple(hi).all();
        let vertices: Vec<u32> = (0..points.len() as u32)
            .filter(|&v| inside(points[v as usize]))
            .collect();
        let met: Vec<[u32; 2]> = edges
            .iter()
            .copied()
            .filter(|&[a, b]| {
                crate::balance::segment_meets_box(points[a as usize], points[b as usize], lo, hi)
            })
            .collect();
        let strangers = met.iter().enumerate().any(|(i, e)| {
            met[i + 1..]
                .iter()
                .any(|f| !e.iter().any(|v| f.contains(v)))
        });
        let crowded = strangers
            || match vertices[..] {
                [] => false,
                [v] => met.iter().any(|e| !e.contains(&v)),
                _ => true,
            };
        if !crowded {
            continue;
        }
        if cell.level == finest {
            return None;
        }
        out.push(cell);
        pending.extend((0..4).map(|q| cell.child(q)));
    }
    out.sort_by_key(|c| (c.anchor, c.level));
    Some(out)
}
