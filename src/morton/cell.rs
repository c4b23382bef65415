//! Squares of the quadtree, named by the Morton key of their lower-left corner and a level.

use super::MortonKey;

/// A side of a square.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Side {
    /// x decreasing.
    West = 0,
    /// x increasing.
    East = 1,
    /// y decreasing.
    South = 2,
    /// y increasing.
    North = 3,
}

impl Side {
    /// All four, in link order.
    pub const ALL: [Side; 4] = [Side::West, Side::East, Side::South, Side::North];

    /// The side facing this one.
    pub fn opposite(self) -> Side {
        match self {
            Side::West => Side::East,
            Side::East => Side::West,
            Side::South => Side::North,
            Side::North => Side::South,
        }
    }

    fn dx(self) -> i64 {
        match self {
            Side::West => -1,
            Side::East => 1,
            _ => 0,
        }
    }

    fn dy(self) -> i64 {
        match self {
            Side::South => -1,
            Side::North => 1,
            _ => 0,
        }
    }

    /// The two child quadrants of a square that touch this side, in increasing coordinate
    /// along the side.
    pub fn children_touching(self) -> [u32; 2] {
        match self {
            Side::West => [0, 1],
            Side::East => [2, 3],
            Side::South => [0, 2],
            Side::North => [1, 3],
        }
    }
}

/// A square of the tree: the Morton key of its lower-left corner and its level (0 = root).
///
/// Packed: 9 bytes on the narrow grid instead of 16 (the leaves and squares that hold one, 13
/// instead of 24), so the arrays the trees are made of, tens of millions of entries at 1e7
/// points, take about half the memory; writing fresh memory is much of their cost. Fields are
/// read by copy: where a comparison would borrow one, write `{ cell.anchor }`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[repr(C, packed)]
pub struct Cell<K: Copy> {
    /// Morton key of the lower-left corner.
    pub anchor: K,
    /// Level; the side is `2^-level` of the root's.
    pub level: u8,
}

impl<K: MortonKey> Cell<K> {
    /// The root square.
    pub fn root() -> Self {
        Cell {
            anchor: K::default(),
            level: 0,
        }
    }

    /// The square at `level` holding key `k`.
    pub fn containing(k: K, level: u8) -> Self {
        Cell {
            anchor: k.cell_anchor(level),
            level,
        }
    }

    /// Whether key `k` lies in this square.
    pub fn contains(self, k: K) -> bool {
        k.cell_anchor(self.level) == { self.anchor }
    }

    /// The parent square (the root for the root).
    pub fn parent(self) -> Self {
        Cell::containing(self.anchor, self.level.saturating_sub(1))
    }

    /// The same-size square across `side`, or `None` outside the root.
    pub fn neighbour(self, side: Side) -> Option<Self> {
        let (anchors, inside) = self.neighbour_anchors();
        (inside & 1 << side as u8 != 0).then_some(Cell {
            anchor: anchors[side as usize],
            level: self.level,
        })
    }

    /// The anchors of the same-size squares across the four sides, in [`Side::ALL`] order, and
    /// the mask of the sides (`1 << side`) that have one inside the root; all four at once,
    /// without branches.
    ///
    /// Adds or subtracts one cell in the key's own bits (dilated arithmetic): the other axis's
    /// bits are filled with ones (or cleared) so the carry (or borrow) runs through them.
    #[inline]
    pub fn neighbour_anchors(self) -> ([K; 4], u8) {
        if self.level == 0 {
            return ([K::default(); 4], 0);
        }
        let all = u128::MAX >> (128 - 2 * K::AXIS_BITS);
        let y_bits = K::from_u128(all / 3); // 0b0101...
        let x_bits = K::from_u128(all - all / 3);
        let unit_y = K::pow2(self.span_bits());
        let unit_x = K::pow2(self.span_bits() + 1);
        let k = self.anchor;
        let (x, y) = (k & x_bits, k & y_bits);
        // Moving up, the carry runs through the other axis's bits set to ones, and wraps past
        // the top; moving down, a borrow past zero wraps.
        let east = (k | y_bits).wrapping_add(unit_x) & x_bits;
        let north = (k | x_bits).wrapping_add(unit_y) & y_bits;
        let west = x.wrapping_sub(unit_x) & x_bits;
        let south = y.wrapping_sub(unit_y) & y_bits;
        let inside = u8::from(x >= unit_x)
            | u8::from(east > x) << 1
            | u8::from(y >= unit_y) << 2
            | u8::from(north > y) << 3;
        ([west | y, east | y, south | x, north | x], inside)
    }

    /// The same-size square `dx` columns right and `dy` rows up, or `None` outside the root.
    pub fn offset(self, dx: i64, dy: i64) -> Option<Self> {
        let side = 1i128 << (K::AXIS_BITS - self.level as u32);
        let limit = 1i128 << K::AXIS_BITS;
        let (x, y) = self.anchor.decode();
        let nx = x as i128 + dx as i128 * side;
        let ny = y as i128 + dy as i128 * side;
        let inside = (0..limit).contains(&nx) && (0..limit).contains(&ny);
        inside.then(|| Cell {
            anchor: K::encode(nx as u64, ny as u64),
            level: self.level,
        })
    }

    /// The same-size square across `side` by decoding and re-encoding the coordinates (slow;
    /// an independent check of [`Cell::neighbour`]).
    pub fn neighbour_by_coordinates(self, side: Side) -> Option<Self> {
        self.offset(side.dx(), side.dy())
    }

    /// Child `quadrant` (`2 * xbit + ybit`) of a square above the finest level.
    pub fn child(self, quadrant: u32) -> Self {
        let shift = 2 * (K::AXIS_BITS - self.level as u32 - 1);
        let offset = K::from_u128((quadrant as u128) << shift);
        Cell {
            anchor: self.anchor.wrapping_add(offset),
            level: self.level + 1,
        }
    }

    /// Which quadrant of its parent this square is (`2 * xbit + ybit`); 0 for the root.
    pub fn quadrant(self) -> u32 {
        if self.level == 0 {
            return 0;
        }
        self.anchor.bits_from(self.span_bits()) & 3
    }

    /// log2 of the number of grid keys the square spans.
    pub fn span_bits(self) -> u32 {
        2 * (K::AXIS_BITS - self.level as u32)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_all_sides<K: MortonKey>(cells: impl Iterator<Item = Cell<K>>) {
        for cell in cells {
            for side in Side::ALL {
                assert_eq!(
                    cell.neighbour(side),
                    cell.neighbour_by_coordinates(side),
                    "{cell:?} {side:?}"
                );
            }
        }
    }

    #[test]
    fn dilated_neighbours_match_coordinates() {
        let narrow = (0..2000u64).flat_map(|i| {
            let k = i.wrapping_mul(0x9E37_79B9_7F4A_7C15);
            (0..=32u8).map(move |level| Cell::containing(k, level))
        });
        check_all_sides(narrow);
        let wide = (0..2000u128).flat_map(|i| {
            let k = i.wrapping_mul(0x9E37_79B9_7F4A_7C15_F39C_C060_5CED_C835);
            (0..=64u8).map(move |level| Cell::containing(k, level))
        });
        check_all_sides(wide);
        // Squares on the root's edges and corners.
        check_all_sides(
            [0u64, u64::MAX, 0xAAAA_AAAA_AAAA_AAAA, 0x5555_5555_5555_5555]
                .into_iter()
                .flat_map(|k| (0..=32u8).map(move |l| Cell::containing(k, l))),
        );
        check_all_sides(
            [0u128, u128::MAX]
                .into_iter()
                .flat_map(|k| (0..=64u8).map(move |l| Cell::containing(k, l))),
        );
    }
}
