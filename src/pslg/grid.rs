//! A uniform grid over the points' bounding box bucketing the points and the pieces of
//! segments, so that only what shares a cell is tested.
//!
//! A cell's column is `floor((x - lo.x) * inv.x)`, clamped: monotone in `x`, so whatever lies in
//! a box lies in the cells of the box's corners' columns and rows. A piece goes into the cells it
//! passes within 1% of a cell of: each column it crosses, and in it the rows between its heights
//! at the column's sides (both widened by 1% of a cell, far more than the rounding of these
//! computations, whose relative error is about 1e-16 times the number of cells across). So a
//! point on a piece, and a point where two pieces meet, lie in a cell the piece (both pieces)
//! went into.

use glam::DVec2;

use super::Piece;

/// The widening of a piece's cells, as a fraction of a cell.
const MARGIN: f64 = 0.01;

/// Cells along a side, at most.
const MAX_CELLS: f64 = 2048.0;

/// Cells along the only side of a flat bounding box, at most.
const MAX_CELLS_FLAT: f64 = 65536.0;

pub(super) struct Grid {
    lo: DVec2,
    /// Cells per unit length along each axis (0 for a single cell).
    inv: DVec2,
    /// A cell's width and height (0 for a single cell).
    size: DVec2,
    nx: usize,
    ny: usize,
    point_start: Vec<u32>,
    point_ids: Vec<u32>,
    piece_start: Vec<u32>,
    piece_ids: Vec<u32>,
}

impl Grid {
    /// About one cell per piece over the bounding box of `points` (finite).
    pub fn new(points: &[DVec2], pieces: &[Piece]) -> Grid {
        let (lo, hi) = points
            .iter()
            .fold((DVec2::INFINITY, DVec2::NEG_INFINITY), |(lo, hi), &p| {
                (lo.min(p), hi.max(p))
            });
        let lo = if points.is_empty() { DVec2::ZERO } else { lo };
        let extent = if points.is_empty() {
            DVec2::ZERO
        } else {
            hi - lo
        };
        let target = (pieces.len() as f64).max(1.0);
        let (nx, ny) = match (extent.x > 0.0, extent.y > 0.0) {
            (true, true) => {
                let nx = (target * extent.x / extent.y)
                    .sqrt()
                    .ceil()
                    .clamp(1.0, MAX_CELLS);
                let ny = (target / nx).ceil().clamp(1.0, MAX_CELLS);
                (nx, ny)
            }
            (true, false) => (target.min(MAX_CELLS_FLAT), 1.0),
            (false, true) => (1.0, target.min(MAX_CELLS_FLAT)),
            (false, false) => (1.0, 1.0),
        };
        let per = |cells: f64, length: f64| {
            if cells > 1.0 && length.is_finite() {
                (cells / length, length / cells)
            } else {
                (0.0, 0.0)
            }
        };
        let (ix, sx) = per(nx, extent.x);
        let (iy, sy) = per(ny, extent.y);
        let mut grid = Grid {
            lo,
            inv: DVec2::new(ix, iy),
            size: DVec2::new(sx, sy),
            nx: if ix > 0.0 { nx as usize } else { 1 },
            ny: if iy > 0.0 { ny as usize } else { 1 },
            point_start: Vec::new(),
            point_ids: Vec::new(),
            piece_start: Vec::new(),
            piece_ids: Vec::new(),
        };
        let point_cells: Vec<(u32, u32)> = points
            .iter()
            .enumerate()
            .map(|(i, &p)| (grid.cell(p), i as u32))
            .collect();
        let mut piece_cells = Vec::with_capacity(pieces.len() * 2);
        let mut cells = Vec::new();
        for (i, piece) in pieces.iter().enumerate() {
            let [a, b] = piece.ends.map(|e| points[e as usize]);
            grid.cells_of(a, b, &mut cells);
            piece_cells.extend(cells.iter().map(|&c| (c, i as u32)));
        }
        let cell_count = grid.cell_count();
        (grid.point_start, grid.point_ids) = bucket(cell_count, &point_cells);
        (grid.piece_start, grid.piece_ids) = bucket(cell_count, &piece_cells);
        grid
    }

    pub fn cell_count(&self) -> usize {
        self.nx * self.ny
    }

    pub fn points_in(&self, cell: u32) -> &[u32] {
        let c = cell as usize;
        &self.point_ids[self.point_start[c] as usize..self.point_start[c + 1] as usize]
    }

    pub fn pieces_in(&self, cell: usize) -> &[u32] {
        &self.piece_ids[self.piece_start[cell] as usize..self.piece_start[cell + 1] as usize]
    }

    fn column(&self, x: f64) -> usize {
        index((x - self.lo.x) * self.inv.x, self.nx)
    }

    fn row(&self, y: f64) -> usize {
        index((y - self.lo.y) * self.inv.y, self.ny)
    }

    fn cell(&self, p: DVec2) -> u32 {
        (self.row(p.y) * self.nx + self.column(p.x)) as u32
    }

    /// The cells the piece from `a` to `b` passes within [`MARGIN`] of a cell of, each once.
    pub fn cells_of(&self, a: DVec2, b: DVec2, out: &mut Vec<u32>) {
        out.clear();
        let (min, max) = (a.min(b), a.max(b));
        let margin = self.size * MARGIN;
        let (c0, c1) = (self.column(min.x - margin.x), self.column(max.x + margin.x));
        let (r0, r1) = (self.row(min.y - margin.y), self.row(max.y + margin.y));
        let mut push_rows = |c: usize, r0: usize, r1: usize| {
            out.extend((r0..=r1).map(|r| (r * self.nx + c) as u32));
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

/// `floor(t)` clamped to `0..cells` (NaN to 0).
fn index(t: f64, cells: usize) -> usize {
    (t.floor().max(0.0) as usize).min(cells - 1)
}

/// Counting sort of `(cell, id)` pairs by cell, ids in their order within a cell.
fn bucket(cells: usize, pairs: &[(u32, u32)]) -> (Vec<u32>, Vec<u32>) {
    let mut start = vec![0u32; cells + 1];
    for &(c, _) in pairs {
        start[c as usize + 1] += 1;
    }
    for i in 0..cells {
        start[i + 1] += start[i];
    }
    let mut next = start.clone();
    let mut ids = vec![0u32; pairs.len()];
    for &(c, id) in pairs {
        ids[next[c as usize] as usize] = id;
        next[c as usize] += 1;
    }
    (start, ids)
}
