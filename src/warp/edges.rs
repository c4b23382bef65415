//! A graph's edges cut at the sides of the leaves they pass through: the pieces the warp of a
//! graph snaps grid vertices onto (Bern, Eppstein and Teng §5, "edges cut at quadtree sides").
//!
//! Each edge is traced down the tree from the root, into the squares whose closed boxes it
//! meets (an exact test), and clipped to each leaf it reaches. The parameters where it enters
//! and leaves a leaf are computed from the grid line of the side crossed, by one expression for
//! both leaves beside that side, and each piece starts where the one before it ends. An edge lying
//! on a side belongs to the leaf above it or to its right, as points on sides do. Edges are
//! traced in parallel, each on its own: the pieces are the same on any thread count.

use glam::DVec2;
use rayon::prelude::*;

use crate::balance::segment_meets_box;
use crate::morton::{Cell, Grid, MortonKey};
use crate::quadtree::Quadtree;

/// A piece of an edge inside one leaf: the edge's points `a + t (b - a)` for `t` in
/// `from..=to`, `0 ≤ from < to ≤ 1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EdgePiece {
    /// The leaf, as an index into the tree's leaves.
    pub leaf: u32,
    /// Where the piece starts along the edge.
    pub from: f64,
    /// Where it ends.
    pub to: f64,
}

/// The pieces of every edge, as compressed rows: edge `e`'s are `at[e]..at[e + 1]` of
/// `pieces`, in order along the edge.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EdgePieces {
    /// Where each edge's pieces start; one more entry than edges.
    pub at: Vec<usize>,
    /// The pieces.
    pub pieces: Vec<EdgePiece>,
}

impl EdgePieces {
    /// The pieces of edge `e`, in order along it.
    pub fn of(&self, e: usize) -> &[EdgePiece] {
        &self.pieces[self.at[e]..self.at[e + 1]]
    }
}

/// The closed box of a square in input coordinates, its corners from the grid's vertices: the
/// squares beside one grid line share its coordinate bit for bit.
pub fn square_box<K: MortonKey>(grid: &Grid, cell: Cell<K>) -> (DVec2, DVec2) {
    let (gx, gy) = { cell.anchor }.decode();
    let size = 1u128 << (K::AXIS_BITS - u32::from(cell.level));
    let (gx, gy) = (u128::from(gx), u128::from(gy));
    (grid.vertex(gx, gy), grid.vertex(gx + size, gy + size))
}

/// The pieces of the edges `edges` (ends indexing `points`) in the leaves of `tree` on `grid`.
/// Every edge must lie inside the root.
///
/// # Complexity
/// Per edge, O(log k) for each square on the paths down to the leaves it meets, for k squares:
/// about the number of its pieces times a few levels.
pub fn edge_pieces<K: MortonKey>(
    tree: &Quadtree<K>,
    grid: &Grid,
    points: &[DVec2],
    edges: &[[u32; 2]],
) -> EdgePieces {
    let rows: Vec<Vec<EdgePiece>> = edges
        .par_iter()
        .map(|&[a, b]| pieces_of(tree, grid, points[a as usize], points[b as usize]))
        .collect();
    let mut at = Vec::with_capacity(rows.len() + 1);
    at.push(0);
    for row in &rows {
        at.push(at.last().copied().unwrap_or(0) + row.len());
    }
    EdgePieces {
        at,
        pieces: rows.into_iter().flatten().collect(),
    }
}

/// The pieces of the edge `ab`, in order along it.
fn pieces_of<K: MortonKey>(tree: &Quadtree<K>, grid: &Grid, a: DVec2, b: DVec2) -> Vec<EdgePiece> {
    let mut pieces = Vec::new();
    let mut pending = vec![Cell::<K>::root()];
    while let Some(cell) = pending.pop() {
        let (lo, hi) = square_box(grid, cell);
        if !segment_meets_box(a, b, lo, hi) {
            continue;
        }
        if is_internal(tree, cell) {
            // In Morton order: the lower children first.
            pending.extend((0..4).rev().map(|q| cell.child(q)));
            continue;
        }
        if let Some((from, to)) = clip(a, b, lo, hi)
            && !on_top_or_right(a, b, hi)
        {
            pieces.push(EdgePiece {
                leaf: leaf_index(tree, cell),
                from,
                to,
            });
        }
    }
    pieces.sort_by(|p, q| p.from.total_cmp(&q.from));
    chained(pieces)
}

/// The pieces, sorted along the edge, each started where the one before ends. Two leaves' clips
/// meet exactly at a side crossed away from its ends; at a grid vertex the edge passes through,
/// the two sides' parameters may differ by rounding, leaving a gap or an overlap of an ulp, or a
/// piece that long in a leaf it only grazes. Chaining closes the gap, and a piece it leaves
/// with no length goes.
fn chained(pieces: Vec<EdgePiece>) -> Vec<EdgePiece> {
    let mut out: Vec<EdgePiece> = Vec::with_capacity(pieces.len());
    for mut piece in pieces {
        if let Some(last) = out.last() {
            piece.from = last.to;
        }
        if piece.from < piece.to {
            out.push(piece);
        }
    }
    if let Some(first) = out.first_mut() {
        first.from = 0.0;
    }
    if let Some(last) = out.last_mut() {
        last.to = 1.0;
    }
    out
}

/// The leaf whose closed square holds `p` (the first in Morton order where several do), if the
/// root's does.
pub fn leaf_at<K: MortonKey>(tree: &Quadtree<K>, grid: &Grid, p: DVec2) -> Option<u32> {
    let inside = |cell: Cell<K>| {
        let (lo, hi) = square_box(grid, cell);
        lo.x <= p.x && p.x <= hi.x && lo.y <= p.y && p.y <= hi.y
    };
    let mut cell = Cell::<K>::root();
    if !inside(cell) {
        return None;
    }
    while is_internal(tree, cell) {
        cell = (0..4).map(|q| cell.child(q)).find(|&c| inside(c))?;
    }
    Some(leaf_index(tree, cell))
}

fn is_internal<K: MortonKey>(tree: &Quadtree<K>, cell: Cell<K>) -> bool {
    let key = (cell.anchor, cell.level);
    let at = tree
        .internal
        .partition_point(|s| ({ s.cell.anchor }, s.cell.level) < key);
    tree.internal.get(at).is_some_and(|s| { s.cell } == cell)
}

fn leaf_index<K: MortonKey>(tree: &Quadtree<K>, cell: Cell<K>) -> u32 {
    let at = tree
        .leaves
        .partition_point(|l| { l.cell.anchor } <= { cell.anchor })
        - 1;
    debug_assert!(
        { tree.leaves[at].cell } == cell,
        "a square of the tree is a leaf"
    );
    at as u32
}

/// Whether the edge lies on the box's top or right side: it then belongs to the leaf beyond.
fn on_top_or_right(a: DVec2, b: DVec2, hi: DVec2) -> bool {
    (a.y == hi.y && b.y == hi.y) || (a.x == hi.x && b.x == hi.x)
}

/// The part of the edge `ab` in the closed box `[lo, hi]`, as parameters along it, if it has a
/// length (Liang and Barsky's clipping). Each side's parameter comes from that side's own
/// coordinate alone.
fn clip(a: DVec2, b: DVec2, lo: DVec2, hi: DVec2) -> Option<(f64, f64)> {
    let (mut from, mut to) = (0.0f64, 1.0f64);
    for axis in 0..2 {
        let (start, delta) = (a[axis], b[axis] - a[axis]);
        if delta == 0.0 {
            if start < lo[axis] || start > hi[axis] {
                return None;
            }
            continue;
        }
        let (t_lo, t_hi) = ((lo[axis] - start) / delta, (hi[axis] - start) / delta);
        let (enter, leave) = if delta > 0.0 {
            (t_lo, t_hi)
        } else {
            (t_hi, t_lo)
        };
        from = from.max(enter);
        to = to.min(leave);
    }
    (from < to).then_some((from, to))
}
