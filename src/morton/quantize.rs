//! The root square and the fixed-point grid on it.

use glam::DVec2;

use crate::error::Error;

/// Levels kept free below the finest level the quantized points need, so that later stages
/// (separation, warping) can split a point's cell a few more times than its nearest neighbour
/// forces.
pub const GUARD_LEVELS: u32 = 4;

/// The root square in input coordinates and the map from input coordinates to grid coordinates.
///
/// The root's side is twice the points' extent, centred on their bounding box, so every point lies
/// in the central half of the root (the neighbourhood blocks of later stages stay inside it).
/// Quantization keeps `axis_bits - GUARD_LEVELS` bits per axis; it is monotone, so it only orders
/// and locates points and never changes their coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    origin: DVec2,
    side: f64,
    axis_bits: u32,
    scale: f64,
    max_cell: u64,
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
        let precision = axis_bits - GUARD_LEVELS;
        // Dividing by the side first, then scaling by a power of two (exact), works for sides
        // down to the smallest subnormal.
        let scale = (2.0f64).powi(precision as i32);
        if !(side.is_finite() && origin.is_finite()) {
            return Err(Error::CoordinateRange {
                lo: lo.into(),
                hi: hi.into(),
            });
        }
        let max_cell = (1u64 << (precision - 1) << 1).wrapping_sub(1);
        Ok(Grid {
            origin,
            side,
            axis_bits,
            scale,
            max_cell,
        })
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

    /// Side of the root square, in input coordinates.
    pub fn side(&self) -> f64 {
        self.side
    }

    /// Grid coordinates of a point: monotone in each axis, clamped into the root.
    #[inline(always)]
    pub fn quantize(&self, p: DVec2) -> (u64, u64) {
        let q = (p - self.origin) / self.side * self.scale;
        // `as` saturates: negatives go to 0, and the clamp catches rounding past the top.
        let x = (q.x as u64).min(self.max_cell);
        let y = (q.y as u64).min(self.max_cell);
        (x << GUARD_LEVELS, y << GUARD_LEVELS)
    }

    /// The input coordinates of grid vertex `(gx, gy)` (up to `2^axis_bits` on the root's top and
    /// right sides). Monotone in each coordinate, so vertices on one grid line share their
    /// coordinate bit for bit, and the root's sides are exactly `origin` and `origin + side`.
    pub fn vertex(&self, gx: u128, gy: u128) -> DVec2 {
        let unit = self.side / (2.0f64).powi(self.axis_bits as i32);
        self.origin + DVec2::new(gx as f64 * unit, gy as f64 * unit)
    }

    /// Lower-left corner and side, in input coordinates, of the cell at grid corner `(gx, gy)`
    /// and `level`.
    pub fn cell_rect(&self, gx: u64, gy: u64, level: u8) -> (DVec2, f64) {
        let unit = self.side / (2.0f64).powi(self.axis_bits as i32);
        let corner = self.origin + DVec2::new(gx as f64, gy as f64) * unit;
        (corner, self.side / (2.0f64).powi(level as i32))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let g = Grid::around(DVec2::ZERO, DVec2::new(5e-324, 0.0), 32).unwrap();
        assert_ne!(g.quantize(DVec2::ZERO), g.quantize(DVec2::new(5e-324, 0.0)));
        let g = Grid::around(DVec2::splat(1e308), DVec2::splat(1e308), 64).unwrap();
        assert!(g.side().is_finite());
    }

    #[test]
    fn single_point_grid_is_valid() {
        let g = Grid::around(DVec2::new(3.0, 3.0), DVec2::new(3.0, 3.0), 64).unwrap();
        assert!(g.side() > 0.0);
    }
}
