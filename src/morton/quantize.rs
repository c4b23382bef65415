//! The root square and the fixed-point grid on it.

use glam::DVec2;

use crate::error::Error;

/// Levels kept free below the finest level the quantized points need, so that later stages
/// (separation, warping) can split a point's cell a few more times than its nearest neighbour
/// forces.
pub const GUARD_LEVELS: u32 = 4;

/// The root square in input coordinates and the map from input coordinates to grid coordinates.
///
/// Around points ([`Grid::around`]) the root's side is twice the points' extent, centred on their
/// bounding box, so every point lies in the central half of the root (the neighbourhood blocks of
/// later stages stay inside it). On a given domain ([`Grid::on_domain`]) the root shares the
/// domain's lower-left corner and larger side, and points may lie on the domain's sides.
/// Quantization keeps `axis_bits - GUARD_LEVELS` bits per axis; it is monotone, so it only orders
/// and locates points and never changes their coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    origin: DVec2,
    /// The root's width and height: equal except on a rectangle cut into near-square cells
    /// ([`Grid::on_domain_cells`]).
    side: DVec2,
    axis_bits: u32,
    scale: f64,
    /// The last cell along each axis that can hold a point.
    max_cell: [u64; 2],
    /// A given domain's upper-right corner.
    far: Option<DVec2>,
    /// The grid line of each axis whose vertices take the domain's far coordinate exactly: the
    /// root's side where the domain's side is the root's, the row moved onto a shorter domain's
    /// top side once the mesh has chosen it.
    far_line: [Option<u128>; 2],
    /// Points at or past these coordinates lie on the domain's far sides and take the last cell
    /// whatever f64 rounds (infinite unless the domain's sides are grid lines inside the root).
    far_cells: DVec2,
}

/// A rectangle cut into `columns` × `rows` cells of `level`, nearly square (see
/// [`DomainCells::for_rectangle`]): its right and top sides are grid lines of that level.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DomainCells {
    /// The level of the cells.
    pub level: u32,
    /// The rectangle's width in cells.
    pub columns: u64,
    /// The rectangle's height in cells.
    pub rows: u64,
}

/// How far a cell's width over its height may be from 1: the compact warp's swept angles stay
/// in its bounds up to this (`warp::tests::the_sweep_bounds_leaves_of_nearly_square_cells`;
/// twice as far they do not).
pub const CELL_ANISOTROPY: f64 = 1.0 / 64.0;

impl DomainCells {
    /// The fewest cells, each at most [`CELL_ANISOTROPY`] from square, that cut a rectangle of
    /// `extent`: the first count along the shorter side whose rounded count along the longer
    /// side gives cells that square. `None` when that needs more than `max_cells` along a side.
    pub fn for_rectangle(extent: DVec2, max_cells: u64) -> Option<DomainCells> {
        let (long, short) = (extent.max_element(), extent.min_element());
        if !(short > 0.0 && long.is_finite()) {
            return None;
        }
        let aspect = long / short;
        let limit = max_cells.min(1 << 62);
        (1..=limit).find_map(|few| {
            let many = (few as f64 * aspect).round();
            if many > limit as f64 {
                return Some(None);
            }
            let many = many as u64;
            let cell_aspect = aspect * few as f64 / many as f64;
            ((cell_aspect - 1.0).abs() <= CELL_ANISOTROPY).then(|| {
                let (columns, rows) = if extent.x >= extent.y {
                    (many, few)
                } else {
                    (few, many)
                };
                Some(DomainCells {
                    level: many.next_power_of_two().ilog2(),
                    columns,
                    rows,
                })
            })
        })?
    }

    /// [`DomainCells::for_rectangle`], or [`Error::ThinDomain`] where it gives none.
    ///
    /// # Errors
    /// [`Error::ThinDomain`] for a rectangle that needs more than `max_cells` along a side (or
    /// has no area).
    pub fn for_domain(extent: DVec2, max_cells: u64) -> Result<DomainCells, Error> {
        Self::for_rectangle(extent, max_cells).ok_or(Error::ThinDomain {
            width: extent.x,
            height: extent.y,
        })
    }
}

/// The least area of a root square: its smallest triangles, at the wide grid's finest leaves
/// (2^-60 of the side, halved by a template, then cut 2^-40 thin by a nonobtuse strip: 2^-163
/// of the root's area), still have normal f64 areas (above 2^-1022) for orientation and sums.
const MIN_ROOT_AREA: f64 = 1e-240;

/// Whether a root square of side `side` has a finite area its mesh's areas can be measured
/// against: not above f64's range, and at least [`MIN_ROOT_AREA`].
fn side_measurable(side: f64) -> bool {
    side.is_finite() && (side * side).is_finite() && side * side >= MIN_ROOT_AREA
}

impl Grid {
    /// The grid for points with bounding box `[lo, hi]`, at `axis_bits` (32 or 64) bits per axis.
    pub fn around(lo: DVec2, hi: DVec2, axis_bits: u32) -> Result<Grid, Error> {
        let extent = (hi - lo).max_element();
        let centre = lo * 0.5 + hi * 0.5;
        // One distinct point: any positive size works, its cell is the root.
        let half = if extent > 0.0 {
            extent
        } else {
            centre.abs().max_element().clamp(1.0, f64::MAX / 4.0)
        };
        let side = 2.0 * half;
        let origin = centre - DVec2::splat(half);
        if !(side_measurable(side) && origin.is_finite()) {
            return Err(Error::CoordinateRange {
                lo: lo.into(),
                hi: hi.into(),
            });
        }
        Ok(Grid::square(origin, side, axis_bits))
    }

    /// The grid on the rectangle `[lo, hi]`: the root's lower-left corner is `lo` and its side
    /// the rectangle's larger one, so the left and bottom sides of the domain are the root's,
    /// and so is the right (top) side when the domain is at least as wide (tall) as it is tall
    /// (wide). Points on the domain's right or top side fall in the cells below that side.
    ///
    /// # Errors
    /// [`Error::CoordinateRange`] unless `[lo, hi]` is finite with a positive side.
    pub fn on_domain(lo: DVec2, hi: DVec2, axis_bits: u32) -> Result<Grid, Error> {
        let extent = hi - lo;
        let side = extent.max_element();
        if !(lo.is_finite() && hi.is_finite() && side_measurable(side)) {
            return Err(Error::CoordinateRange {
                lo: lo.into(),
                hi: hi.into(),
            });
        }
        let mut grid = Grid::square(lo, side, axis_bits);
        let full = 1u128 << axis_bits;
        grid.far = Some(hi);
        grid.max_cell = [grid.last_cell(extent.x), grid.last_cell(extent.y)];
        grid.far_line = [
            (extent.x == side).then_some(full),
            (extent.y == side).then_some(full),
        ];
        Ok(grid)
    }

    /// The grid on the rectangle `[lo, hi]`, at least as wide as tall, whose root is `2^level /
    /// columns` times as wide as the rectangle (`columns` at most `2^level`): the rectangle's
    /// right side is then the grid line of column `columns` at `level`, and its top side lies
    /// where that choice puts it.
    ///
    /// # Errors
    /// As [`Grid::on_domain`].
    pub fn on_domain_columns(
        lo: DVec2,
        hi: DVec2,
        axis_bits: u32,
        (level, columns): (u32, u64),
    ) -> Result<Grid, Error> {
        let mut grid = Grid::on_domain(lo, hi, axis_bits)?;
        let extent = hi - lo;
        if columns >= 1 << level || extent.y >= extent.x {
            return Ok(grid);
        }
        grid.side = DVec2::splat(extent.x * (2.0f64).powi(level as i32) / columns as f64);
        if !grid.side.is_finite() {
            return Err(Error::CoordinateRange {
                lo: lo.into(),
                hi: hi.into(),
            });
        }
        let line = u128::from(columns) << (axis_bits - level);
        grid.far_line[0] = Some(line);
        // Points on the right side fall in the column left of its line, whatever f64 rounds.
        let before_line = u64::try_from((line >> GUARD_LEVELS) - 1).unwrap_or(u64::MAX);
        grid.max_cell = [before_line, grid.last_cell(extent.y)];
        Ok(grid)
    }

    /// The grid on the rectangle `[lo, hi]` cut into `cells`: the root's lower-left corner is
    /// `lo`, its width `2^level / columns` times the rectangle's and its height `2^level /
    /// rows` times, so the rectangle's right and top sides are grid lines of `level` whose
    /// vertices take the rectangle's coordinates exactly, and points on those sides fall in the
    /// cells before them.
    ///
    /// # Errors
    /// As [`Grid::on_domain`]; also when `cells` counts more than `2^level` along a side.
    pub fn on_domain_cells(
        lo: DVec2,
        hi: DVec2,
        axis_bits: u32,
        cells: DomainCells,
    ) -> Result<Grid, Error> {
        let mut grid = Grid::on_domain(lo, hi, axis_bits)?;
        let extent = hi - lo;
        let range = || Error::CoordinateRange {
            lo: lo.into(),
            hi: hi.into(),
        };
        let fits = |n: u64| n >= 1 && cells.level < axis_bits && n <= 1 << cells.level;
        if !(fits(cells.columns) && fits(cells.rows)) {
            return Err(range());
        }
        let cells_of = |n: u64| n as f64 / (2.0f64).powi(cells.level as i32);
        grid.side = extent / DVec2::new(cells_of(cells.columns), cells_of(cells.rows));
        if !(grid.side.is_finite() && side_measurable(grid.side.min_element())) {
            return Err(range());
        }
        let line = |n: u64| u128::from(n) << (axis_bits - cells.level);
        grid.far_line = [Some(line(cells.columns)), Some(line(cells.rows))];
        let before = |n: u64| u64::try_from((line(n) >> GUARD_LEVELS) - 1).unwrap_or(u64::MAX);
        grid.max_cell = [before(cells.columns), before(cells.rows)];
        grid.far_cells = hi;
        Ok(grid)
    }

    fn square(origin: DVec2, side: f64, axis_bits: u32) -> Grid {
        let precision = axis_bits - GUARD_LEVELS;
        // Dividing by the side first, then scaling by a power of two (exact), works for sides
        // down to the smallest subnormal.
        let scale = (2.0f64).powi(precision as i32);
        let last = (1u64 << (precision - 1) << 1).wrapping_sub(1);
        Grid {
            origin,
            side: DVec2::splat(side),
            axis_bits,
            scale,
            max_cell: [last; 2],
            far: None,
            far_line: [None; 2],
            far_cells: DVec2::INFINITY,
        }
    }

    /// The last cell before a domain side `extent` from the origin: a point on the side belongs
    /// to it even when the side is a grid line.
    fn last_cell(&self, extent: f64) -> u64 {
        let far = extent / self.side.x * self.scale;
        (far.ceil() as u64).saturating_sub(1).min(self.max_cell[0])
    }

    /// The domain's top side in grid units (fractional), when the domain is shorter than the
    /// root: then it may cut through cells, and the mesh moves a grid row onto it.
    pub fn inner_top(&self) -> Option<f64> {
        let far = self.far?;
        let height = far.y - self.origin.y;
        if self.has_domain_cells() {
            // A cells grid's top side is a grid line: exactly its row.
            let line = self.far_line[1]?;
            return (line < 1u128 << self.axis_bits).then_some(line as f64);
        }
        (height < self.side.y)
            .then(|| height / self.side.y * self.scale * (2.0f64).powi(GUARD_LEVELS as i32))
    }

    /// Whether the domain's sides are grid lines cut into cells ([`Grid::on_domain_cells`]).
    pub fn has_domain_cells(&self) -> bool {
        self.far_cells.is_finite()
    }

    /// The grid lines (finest units) whose vertices take the domain's right and top
    /// coordinates where those sides lie inside the root: a cells grid's sides
    /// ([`Grid::on_domain_cells`]), or the right side's column and the band's row once chosen
    /// ([`Grid::on_domain_columns`], [`Grid::set_top_row`]). The mesh ends there.
    pub fn inner_lines(&self) -> [Option<u128>; 2] {
        [self.inner_right(), self.inner_top_row()]
    }

    /// Whether the root's cells are not squares (a rectangle cut into cells nearly square).
    pub fn is_anisotropic(&self) -> bool {
        self.side.x != self.side.y
    }

    /// The grid line of a domain's right side when that lies inside the root (finest units).
    pub fn inner_right(&self) -> Option<u128> {
        self.far_line[0].filter(|&line| line < 1u128 << self.axis_bits)
    }

    /// The domain given to [`Grid::on_domain`], if any.
    pub fn given_domain(&self) -> Option<(DVec2, DVec2)> {
        self.far.map(|far| (self.origin, far))
    }

    /// The grid row moved onto a short domain's top side, once chosen.
    pub fn inner_top_row(&self) -> Option<u128> {
        self.inner_top().and(self.far_line[1])
    }

    /// Makes the vertices of grid row `row` lie on the domain's top side.
    pub fn set_top_row(&mut self, row: u128) {
        self.far_line[1] = Some(row);
    }

    /// The region the mesh covers: the given domain, or the root square.
    pub fn domain(&self) -> (DVec2, DVec2) {
        let full = 1u128 << self.axis_bits;
        (self.origin, self.far.unwrap_or(self.vertex(full, full)))
    }

    /// A grid on the unit square with the given bits per axis (for tests and benches).
    pub fn for_test(axis_bits: u32) -> Grid {
        Grid::around(DVec2::new(0.25, 0.25), DVec2::new(0.75, 0.75), axis_bits)
            .expect("unit grid is valid")
    }

    /// Bits per axis of the grid coordinates.
    pub fn axis_bits(&self) -> u32 {
        self.axis_bits
    }

    /// Lower-left corner of the root square, in input coordinates.
    pub fn origin(&self) -> DVec2 {
        self.origin
    }

    /// Side of the root square, in input coordinates: its width (see [`Grid::sides`]).
    pub fn side(&self) -> f64 {
        self.side.x
    }

    /// The root's width and height, in input coordinates: equal but on a cells grid.
    pub fn sides(&self) -> DVec2 {
        self.side
    }

    /// Grid coordinates of a point: monotone in each axis, clamped into the root.
    #[inline(always)]
    pub fn quantize(&self, p: DVec2) -> (u64, u64) {
        let q = (p - self.origin) / self.side * self.scale;
        // `as` saturates: negatives go to 0, and the clamp catches rounding past the top; a
        // point on a far side that is a grid line takes the last cell even when f64 rounds
        // it short.
        let last = |q: f64, at_far: bool, max: u64| if at_far { max } else { (q as u64).min(max) };
        let x = last(q.x, p.x >= self.far_cells.x, self.max_cell[0]);
        let y = last(q.y, p.y >= self.far_cells.y, self.max_cell[1]);
        (x << GUARD_LEVELS, y << GUARD_LEVELS)
    }

    /// The input coordinates of grid vertex `(gx, gy)` (up to `2^axis_bits` on the root's top and
    /// right sides). Monotone in each coordinate, so vertices on one grid line share their
    /// coordinate bit for bit; the root's sides are exactly `origin` and `origin + side`, and a
    /// domain's right and top sides exactly its own coordinates.
    #[inline]
    pub fn vertex(&self, gx: u128, gy: u128) -> DVec2 {
        DVec2::new(self.x_of(gx), self.y_of(gy))
    }

    /// The x coordinate of the grid's vertical line `gx` ([`Grid::vertex`]'s).
    #[inline]
    pub fn x_of(&self, gx: u128) -> f64 {
        match self.far {
            Some(far) if self.far_line[0] == Some(gx) => far.x,
            _ => self.origin.x + grid_to_f64(gx) * (self.side.x / power_of_two(self.axis_bits)),
        }
    }

    /// The y coordinate of the grid's horizontal line `gy` ([`Grid::vertex`]'s).
    #[inline]
    pub fn y_of(&self, gy: u128) -> f64 {
        match self.far {
            Some(far) if self.far_line[1] == Some(gy) => far.y,
            _ => self.origin.y + grid_to_f64(gy) * (self.side.y / power_of_two(self.axis_bits)),
        }
    }

    /// Lower-left corner and side, in input coordinates, of the cell at grid corner `(gx, gy)`
    /// and `level`.
    pub fn cell_rect(&self, gx: u64, gy: u64, level: u8) -> (DVec2, DVec2) {
        let unit = self.side / power_of_two(self.axis_bits);
        let corner = self.origin + DVec2::new(gx as f64, gy as f64) * unit;
        (corner, self.side / (2.0f64).powi(level as i32))
    }
}

/// `2^n` exactly, from its bits (`powi` is a loop in a library call, and the warp asks for
/// grid vertices by the tens of millions).
#[inline]
fn power_of_two(n: u32) -> f64 {
    debug_assert!(n <= 1023);
    f64::from_bits((1023 + u64::from(n)) << 52)
}

/// A grid coordinate as f64, rounded as `as f64` rounds it: through `i64` where it fits, which
/// the hardware converts in one instruction (from `u128` it is a software routine).
#[inline]
fn grid_to_f64(v: u128) -> f64 {
    match i64::try_from(v) {
        Ok(v) => v as f64,
        Err(_) => v as f64,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fast_conversions_round_as_the_library_ones() {
        for n in 0..=1023 {
            assert_eq!(power_of_two(n), 2f64.powi(n as i32), "2^{n}");
        }
        let mut values = vec![0u128, 1, (1 << 53) + 1, (1 << 54) + 3, u64::MAX as u128];
        values.extend([u64::MAX as u128 + 1, 1u128 << 64 | 1, u128::MAX]);
        // Values that round at every bit position, on both sides of a tie.
        for shift in 0..120 {
            let v = (1u128 << 60 | 0b1011) << shift >> 3;
            values.extend([v, v + 1, v.saturating_sub(1)]);
        }
        for v in values {
            assert_eq!(grid_to_f64(v).to_bits(), (v as f64).to_bits(), "{v}");
        }
    }

    #[test]
    fn points_land_in_the_central_half() {
        let g = Grid::around(DVec2::new(-3.0, 10.0), DVec2::new(5.0, 12.0), 32).unwrap();
        let quarter = 1u64 << 30;
        for p in [
            DVec2::new(-3.0, 10.0),
            DVec2::new(5.0, 12.0),
            DVec2::new(1.0, 11.0),
        ] {
            let (x, y) = g.quantize(p);
            assert!(x >= quarter && x <= 3 * quarter, "{x}");
            assert!(y >= quarter && y <= 3 * quarter, "{y}");
        }
    }

    #[test]
    fn quantization_is_monotone() {
        let g = Grid::around(DVec2::ZERO, DVec2::ONE, 32).unwrap();
        let mut last = 0;
        for i in 0..10_000 {
            let (x, _) = g.quantize(DVec2::new(i as f64 / 10_000.0, 0.5));
            assert!(x >= last);
            last = x;
        }
    }

    #[test]
    fn overflowing_range_is_an_error() {
        let r = Grid::around(DVec2::new(-1e308, 0.0), DVec2::new(1e308, 0.0), 32);
        assert!(matches!(r, Err(Error::CoordinateRange { .. })));
    }

    #[test]
    fn tiny_and_huge_extents_work() {
        let g = Grid::around(DVec2::ZERO, DVec2::new(1e-110, 0.0), 32).unwrap();
        assert_ne!(g.quantize(DVec2::ZERO), g.quantize(DVec2::new(1e-110, 0.0)));
        // A square whose area underflows toward f64's smallest normal number is refused: the
        // areas of its smallest triangles could not be computed.
        let r = Grid::around(DVec2::ZERO, DVec2::new(1e-150, 0.0), 32);
        assert!(matches!(r, Err(Error::CoordinateRange { .. })));
        let g = Grid::around(DVec2::splat(1e150), DVec2::splat(1e150), 64).unwrap();
        assert!((g.side() * g.side()).is_finite());
        // A square whose area overflows f64 is refused: nothing could measure the mesh's areas.
        let r = Grid::around(DVec2::splat(1e308), DVec2::splat(1e308), 64);
        assert!(matches!(r, Err(Error::CoordinateRange { .. })));
    }

    #[test]
    fn single_point_grid_is_valid() {
        let g = Grid::around(DVec2::new(3.0, 3.0), DVec2::new(3.0, 3.0), 64).unwrap();
        assert!(g.side() > 0.0);
    }
}
