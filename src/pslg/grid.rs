//! A sparse grid bucketing the points and the pieces of segments, so that only what shares a
//! cell is tested. Cells are about twice as wide as the mean piece is long (no wider than the
//! bounding box over the square root of the points and pieces): pieces along curves that fill
//! a small part of the box share cells with their neighbours only, and the cells that hold
//! nothing cost nothing, as they are never stored. What a cell holds is found in arrays sorted
//! by cell.
//!
//! A cell's column is `floor((x - lo.x) * inv.x)`, clamped: monotone in `x`, so whatever lies in
//! a box lies in the cells of the box's corners' columns and rows. A piece goes into the cells it
//! passes within 1% of a cell of: each column it crosses, and in it the rows between its heights
//! at the column's sides (both widened by 1% of a cell, far more than the rounding of these
//! computations, whose relative error is about 1e-16 times the number of cells across). So a
//! point on a piece, and a point where two pieces meet, lie in a cell the piece (both pieces)
//! went into.

use glam::DVec2;
use rayon::prelude::*;

use super::Piece;
use crate::morton::bounding_box;

/// The widening of a piece's cells, as a fraction of a cell.
const MARGIN: f64 = 0.01;

/// Cells along a side, at most: a cell's column and row fit in 32 bits each.
const MAX_CELLS: f64 = (1u64 << 30) as f64;

/// A cell's width over the mean length of a piece.
const CELL_PER_PIECE: f64 = 2.0;

/// At most this many (cell, piece) entries per point and piece, on average: long pieces
/// widen the cells rather than fill memory.
const ENTRIES_PER_ITEM: f64 = 8.0;

pub(super) struct Grid {
    lo: DVec2,
    /// Cells per unit length along each axis (0 for a single cell).
    inv: DVec2,
    /// A cell's width and height (0 for a single cell).
    size: DVec2,
    nx: u64,
    ny: u64,
    /// The points' cells, sorted, and the points in the same order (by cell, then index).
    point_cells: Vec<u64>,
    point_ids: Vec<u32>,
    /// The same for the pieces, a piece in every cell it passes.
    piece_cells: Vec<u64>,
    piece_ids: Vec<u32>,
    /// Where each run of one cell starts in `piece_cells`, and its end last.
    piece_runs: Vec<usize>,
    /// For each cell that holds a piece, where its points start and end in `point_cells`.
    point_runs: Vec<[u32; 2]>,
}

impl Grid {
    /// The grid of `points` (finite) and `pieces` between them.
    pub fn new(points: &[DVec2], pieces: &[Piece]) -> Grid {
        let (lo, hi) = bounding_box(points);
        let (lo, extent) = if points.is_empty() {
            (DVec2::ZERO, DVec2::ZERO)
        } else {
            (lo, hi - lo)
        };
        let side = cell_side(points, pieces, extent);
        let per = |length: f64| {
            let cells = (length / side).ceil().min(MAX_CELLS);
            if length > 0.0 && length.is_finite() && cells > 1.0 {
                (cells, cells / length, length / cells)
            } else {
                (1.0, 0.0, 0.0)
            }
        };
        let (nx, ix, sx) = per(extent.x);
        let (ny, iy, sy) = per(extent.y);
        let mut grid = Grid {
            lo,
            inv: DVec2::new(ix, iy),
            size: DVec2::new(sx, sy),
            nx: nx as u64,
            ny: ny as u64,
            point_cells: Vec::new(),
            point_ids: Vec::new(),
            piece_cells: Vec::new(),
            piece_ids: Vec::new(),
            piece_runs: Vec::new(),
            point_runs: Vec::new(),
        };
        let mut by_point: Vec<(u64, u32)> = points
            .par_iter()
            .enumerate()
            .map(|(i, &p)| (grid.cell(p), i as u32))
            .collect();
        by_point.par_sort_unstable();
        let mut by_piece = grid.piece_entries(points, pieces);
        by_piece.par_sort_unstable();
        (grid.point_cells, grid.point_ids) = by_point.into_par_iter().unzip();
        (grid.piece_cells, grid.piece_ids) = by_piece.into_par_iter().unzip();
        grid.piece_runs = crate::par::run_starts(grid.piece_cells.len(), |i| grid.piece_cells[i]);
        grid.point_runs = grid.point_runs_of_piece_cells();
        grid
    }

    /// A (cell, piece) pair for every cell each piece passes, unsorted. Pieces go in chunks,
    /// each filling one buffer: a buffer per piece would cost an allocation each.
    fn piece_entries(&self, points: &[DVec2], pieces: &[Piece]) -> Vec<(u64, u32)> {
        const CHUNK: usize = 4096;
        let chunks: Vec<Vec<(u64, u32)>> = pieces
            .par_chunks(CHUNK)
            .enumerate()
            .map(|(k, chunk)| {
                let (mut entries, mut cells) = (Vec::with_capacity(4 * chunk.len()), Vec::new());
                for (i, piece) in chunk.iter().enumerate() {
                    let [a, b] = piece.ends.map(|e| points[e as usize]);
                    self.cells_of(a, b, &mut cells);
                    let id = (k * CHUNK + i) as u32;
                    entries.extend(cells.iter().map(|&c| (c, id)));
                }
                entries
            })
            .collect();
        crate::par::concat(&chunks)
    }

    /// How many cells hold a piece.
    pub fn piece_cell_count(&self) -> usize {
        self.piece_runs.len() - 1
    }

    /// The pieces in the `k`-th cell that holds any, in index order.
    pub fn pieces_in(&self, k: usize) -> &[u32] {
        &self.piece_ids[self.piece_runs[k]..self.piece_runs[k + 1]]
    }

    /// The points in the `k`-th cell that holds a piece, in index order.
    pub fn points_in_cell_of(&self, k: usize) -> &[u32] {
        let [start, end] = self.point_runs[k];
        &self.point_ids[start as usize..end as usize]
    }

    /// Where the points of each cell that holds a piece lie in `point_cells`: both lists are
    /// sorted, so each chunk of cells searches for its first and then walks.
    fn point_runs_of_piece_cells(&self) -> Vec<[u32; 2]> {
        const CHUNK: usize = 1024;
        let cells = self.piece_cell_count();
        let cell = |k: usize| self.piece_cells[self.piece_runs[k]];
        let chunks: Vec<Vec<[u32; 2]>> = (0..cells.div_ceil(CHUNK))
            .into_par_iter()
            .map(|c| {
                let ks = c * CHUNK..((c + 1) * CHUNK).min(cells);
                let mut at = self.point_cells.partition_point(|&p| p < cell(ks.start));
                ks.map(|k| {
                    let cell = cell(k);
                    while at < self.point_cells.len() && self.point_cells[at] < cell {
                        at += 1;
                    }
                    let start = at;
                    while at < self.point_cells.len() && self.point_cells[at] == cell {
                        at += 1;
                    }
                    [start as u32, at as u32]
                })
                .collect()
            })
            .collect();
        crate::par::concat(&chunks)
    }

    fn column(&self, x: f64) -> u64 {
        index((x - self.lo.x) * self.inv.x, self.nx)
    }

    fn row(&self, y: f64) -> u64 {
        index((y - self.lo.y) * self.inv.y, self.ny)
    }

    fn cell(&self, p: DVec2) -> u64 {
        key(self.column(p.x), self.row(p.y))
    }

    /// The cells the piece from `a` to `b` passes within [`MARGIN`] of a cell of, each once.
    pub fn cells_of(&self, a: DVec2, b: DVec2, out: &mut Vec<u64>) {
        out.clear();
        let (min, max) = (a.min(b), a.max(b));
        let margin = self.size * MARGIN;
        let (c0, c1) = (self.column(min.x - margin.x), self.column(max.x + margin.x));
        let (r0, r1) = (self.row(min.y - margin.y), self.row(max.y + margin.y));
        let mut push_rows = |c: u64, r0: u64, r1: u64| {
            out.extend((r0..=r1).map(|r| key(c, r)));
        };
        if c1 - c0 <= 1 {
            for c in c0..=c1 {
                push_rows(c, r0, r1);
            }
            return;
        }
        // At least three columns, so b.x - a.x spans more than a cell.
        let slope = (b.y - a.y) / (b.x - a.x);
        let y_at = |x: f64| a.y + (x - a.x) * slope;
        for c in c0..=c1 {
            let side = |k: f64| self.lo.x + k * self.size.x;
            let xl = side(c as f64 - MARGIN).clamp(min.x, max.x);
            let xr = side(c as f64 + 1.0 + MARGIN).clamp(min.x, max.x);
            let (ya, yb) = (y_at(xl), y_at(xr));
            let lo = self.row(ya.min(yb) - margin.y).max(r0);
            let hi = self.row(ya.max(yb) + margin.y).min(r1);
            push_rows(c, lo, hi.max(lo));
        }
    }
}

/// The side of a cell: [`CELL_PER_PIECE`] mean piece lengths, at most the box's larger side
/// over the square root of the points and pieces, at least what keeps the (cell, piece)
/// entries to [`ENTRIES_PER_ITEM`] per item and the cells along a side to [`MAX_CELLS`].
fn cell_side(points: &[DVec2], pieces: &[Piece], extent: DVec2) -> f64 {
    let items = (points.len() + pieces.len()).max(1) as f64;
    let larger = extent.max_element();
    // Lengths along the longer axis: no squares to underflow at 1e-300 or overflow at 1e300.
    let total: f64 = pieces
        .par_iter()
        .map(|p| {
            (points[p.ends[0] as usize] - points[p.ends[1] as usize])
                .abs()
                .max_element()
        })
        .sum();
    let mean = total / pieces.len().max(1) as f64;
    let fine = if pieces.is_empty() {
        f64::INFINITY
    } else {
        CELL_PER_PIECE * mean
    };
    fine.min(larger / items.sqrt())
        .max(total / (ENTRIES_PER_ITEM * items))
        .max(larger / MAX_CELLS)
}

/// A cell's key from its column and row: cells sort by row, then column.
fn key(column: u64, row: u64) -> u64 {
    (row << 32) | column
}

/// `floor(t)` clamped to `0..cells` (NaN to 0).
fn index(t: f64, cells: u64) -> u64 {
    (t.floor().max(0.0) as u64).min(cells - 1)
}

#[cfg(test)]
mod tests {
    use rand::{Rng, SeedableRng};
    use rand_xoshiro::Xoshiro256PlusPlus;

    use super::*;
    use crate::predicates::{Orientation, orientation};

    /// The cells holding each piece, and the cell of each point, read back from the grid.
    fn cells_read_back(grid: &Grid, pieces: usize, points: usize) -> (Vec<Vec<u64>>, Vec<u64>) {
        let mut of_piece = vec![Vec::new(); pieces];
        let mut of_point = vec![u64::MAX; points];
        for k in 0..grid.piece_cell_count() {
            let cell = grid.piece_cells[grid.piece_runs[k]];
            for &i in grid.pieces_in(k) {
                of_piece[i as usize].push(cell);
            }
            for &q in grid.points_in_cell_of(k) {
                of_point[q as usize] = cell;
            }
        }
        (of_piece, of_point)
    }

    /// Short pieces on a lattice crowded into a corner, long ones across the box, lattice
    /// points on some of them: what meets shares a cell.
    #[test]
    fn what_meets_shares_a_cell_and_long_pieces_widen_the_cells() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(3);
        let mut points = Vec::new();
        let mut pieces = Vec::new();
        let lattice = |rng: &mut Xoshiro256PlusPlus, n: u32| {
            DVec2::new(rng.random_range(0..n) as f64, rng.random_range(0..n) as f64) / 64.0
        };
        for k in 0..3000u32 {
            let n = if k % 10 == 0 { 4096 } else { 256 };
            points.push(lattice(&mut rng, n));
            points.push(lattice(&mut rng, n));
            if points[2 * k as usize] != points[2 * k as usize + 1] {
                pieces.push(Piece {
                    ends: [2 * k, 2 * k + 1],
                    origin: k,
                });
            }
        }
        let grid = Grid::new(&points, &pieces);
        let (of_piece, of_point) = cells_read_back(&grid, pieces.len(), points.len());
        let shares = |i: usize, cell: u64| of_piece[i].contains(&cell);
        let mut met = 0;
        for (i, piece) in pieces.iter().enumerate() {
            let [a, b] = piece.ends.map(|e| points[e as usize]);
            for (q, &p) in points.iter().enumerate() {
                if orientation(a, b, p) == Orientation::On
                    && super::super::strictly_between(a, b, p)
                {
                    met += 1;
                    assert!(shares(i, of_point[q]), "point {q} on piece {i}");
                }
            }
            for (j, other) in pieces.iter().enumerate().skip(i + 1) {
                if super::super::meet(&points, *piece, *other).is_some() {
                    met += 1;
                    assert!(
                        of_piece[i].iter().any(|&c| shares(j, c)),
                        "pieces {i} and {j} meet"
                    );
                }
            }
        }
        assert!(met > 1000, "{met}");
        let entries = grid.piece_ids.len() as f64;
        let items = (points.len() + pieces.len()) as f64;
        assert!(entries <= 2.0 * ENTRIES_PER_ITEM * items + 3.0 * pieces.len() as f64);
    }

    #[test]
    fn tiny_and_huge_boxes_keep_the_entries_bounded() {
        for scale in [1e-300, 1e300, 1.0] {
            let points: Vec<DVec2> = (0..400)
                .map(|k| DVec2::new((k % 20) as f64, (k / 20) as f64) * scale)
                .collect();
            // Every point joined to the far corner.
            let pieces: Vec<Piece> = (0..399)
                .map(|k| Piece {
                    ends: [k, 399],
                    origin: k,
                })
                .collect();
            let grid = Grid::new(&points, &pieces);
            let items = (points.len() + pieces.len()) as f64;
            let entries = grid.piece_ids.len() as f64;
            assert!(
                entries <= 2.0 * ENTRIES_PER_ITEM * items + 3.0 * pieces.len() as f64,
                "{scale}: {entries}"
            );
            let (of_piece, of_point) = cells_read_back(&grid, pieces.len(), points.len());
            // Each piece's cells hold both its ends.
            for (i, piece) in pieces.iter().enumerate() {
                for e in piece.ends {
                    assert!(of_piece[i].contains(&of_point[e as usize]), "{scale}: {i}");
                }
            }
        }
    }
}
