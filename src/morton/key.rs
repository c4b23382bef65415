//! Morton keys: the bit-interleaving of two fixed-point coordinates.
//!
//! The x bit comes before the y bit at every level (BET §2), so the quadrant digit of a cell's
//! child is `2 * xbit + ybit`: 0 = lower left, 1 = upper left, 2 = lower right, 3 = upper right.

use std::fmt::Debug;
use std::hash::Hash;
use std::mem::MaybeUninit;

use glam::DVec2;

use super::quantize::Grid;
use super::sort::{Pair, SortPairs};

/// A Morton key of `2 * AXIS_BITS` bits, naming a point of the grid or, with a level, a cell.
///
/// Implemented for `u64` (32 bits per axis) and `u128` (64 bits per axis); the pipeline picks the
/// narrow one unless the input's spread needs the wide one, and runs the same generic code on both.
pub trait MortonKey:
    Copy
    + Ord
    + Eq
    + Hash
    + Debug
    + Default
    + Send
    + Sync
    + 'static
    + std::ops::BitXor<Output = Self>
    + std::ops::BitAnd<Output = Self>
    + std::ops::BitOr<Output = Self>
    + SortPairs
    + sealed::Sealed
{
    /// Quantizes `points` on `grid`; `out[i]` gets the key of `points[i]` and index `first + i`.
    fn encode_points(
        points: &[DVec2],
        first: u32,
        grid: &Grid,
        out: &mut [MaybeUninit<Pair<Self>>],
    );

    /// Bits per axis; also the deepest level a cell can have.
    const AXIS_BITS: u32;
    /// Interleaves two grid coordinates (each below `2^AXIS_BITS`), x bit first.
    fn encode(x: u64, y: u64) -> Self;
    /// Splits a key back into its grid coordinates.
    fn decode(self) -> (u64, u64);
    /// Number of leading zero bits of the full `2 * AXIS_BITS`-bit key.
    fn leading_zeros(self) -> u32;
    /// Number of trailing zero bits (`2 * AXIS_BITS` for zero).
    fn trailing_zeros(self) -> u32;
    /// Number of one bits.
    fn count_ones(self) -> u32;
    /// The key with every bit below the cell of `level` cleared: the anchor of that cell.
    fn cell_anchor(self, level: u8) -> Self;
    /// `self - other`, modulo the key space.
    fn wrapping_sub(self, other: Self) -> Self;
    /// `self + other`, modulo the key space.
    fn wrapping_add(self, other: Self) -> Self;
    /// `2^bits`, for `bits < 2 * AXIS_BITS`.
    fn pow2(bits: u32) -> Self;
    /// The key as a u128 (lossless for both key widths).
    fn to_u128(self) -> u128;
    /// The key from a u128 that fits in `2 * AXIS_BITS` bits.
    fn from_u128(v: u128) -> Self;
    /// The 32 bits of the key from bit `bits` (below `2 * AXIS_BITS`) up, in the key's own
    /// width rather than through a u128.
    fn bits_from(self, bits: u32) -> u32;

    /// Level of the smallest cell holding both keys (their derived square); `AXIS_BITS` if equal.
    #[inline]
    fn common_level(self, other: Self) -> u8 {
        ((self ^ other).leading_zeros() / 2) as u8
    }

    /// Sum of the quadrant digits of the first `level` levels of this key: how many earlier
    /// sibling subtrees the path from the root to the cell passes by.
    #[inline]
    fn digit_sum(self, level: u8) -> u32 {
        let top = self.cell_anchor(level).to_u128();
        sum_of_digits(top as u64) + sum_of_digits((top >> 64) as u64)
    }
}

/// The sum of the 32 two-bit digits of `x`, by adding neighbouring fields in place: without a
/// popcount instruction in the baseline x86-64 target, this is cheaper than counting ones.
#[inline]
fn sum_of_digits(x: u64) -> u32 {
    // Each nibble: two digits, at most 6; each byte: four, at most 12; all: at most 96.
    let nibbles = (x & 0x3333_3333_3333_3333) + (x >> 2 & 0x3333_3333_3333_3333);
    let bytes = (nibbles & 0x0F0F_0F0F_0F0F_0F0F) + (nibbles >> 4 & 0x0F0F_0F0F_0F0F_0F0F);
    (bytes.wrapping_mul(0x0101_0101_0101_0101) >> 56) as u32
}

/// The finest level whose squares' anchors fit in 64 bits: a wide key's anchor at this level or
/// a coarser one has its low 64 bits zero. Trees of wide keys rarely go deeper (1e6 Kuzmin
/// points: a few hundred of a million squares), so the balance works on them in 64 bits down to
/// here: its closure and walk read half the memory, and its leaves are tiled in one register.
pub(crate) const NARROW_LEVEL: usize = u64::AXIS_BITS as usize;

/// The anchor of a square no finer than either width's finest level, in the other width: the
/// same digits at the other width's top. From a wider key to a narrower one, any key: the digits
/// of its square at the narrower width's finest level.
#[inline]
pub fn in_width<I: MortonKey, O: MortonKey>(anchor: I) -> O {
    let bits = anchor.to_u128();
    O::from_u128(if O::AXIS_BITS >= I::AXIS_BITS {
        bits << (2 * (O::AXIS_BITS - I::AXIS_BITS))
    } else {
        bits >> (2 * (I::AXIS_BITS - O::AXIS_BITS))
    })
}

mod sealed {
    /// Only the crate's key types implement [`super::MortonKey`]: unsafe code relies on their
    /// `encode_points` writing every slot.
    pub trait Sealed {}
    impl Sealed for u64 {}
    impl Sealed for u128 {}
}

impl MortonKey for u64 {
    const AXIS_BITS: u32 = 32;
    fn encode_points(
        points: &[DVec2],
        first: u32,
        grid: &Grid,
        out: &mut [MaybeUninit<Pair<Self>>],
    ) {
        crate::morton::interleave::encode_narrow(points, first, grid, out);
    }
    #[inline]
    fn encode(x: u64, y: u64) -> Self {
        crate::morton::interleave::interleave32(x as u32, y as u32)
    }
    #[inline]
    fn decode(self) -> (u64, u64) {
        (
            crate::morton::interleave::compact_even(self >> 1) as u64,
            crate::morton::interleave::compact_even(self) as u64,
        )
    }
    #[inline]
    fn leading_zeros(self) -> u32 {
        u64::leading_zeros(self)
    }
    #[inline]
    fn trailing_zeros(self) -> u32 {
        u64::trailing_zeros(self)
    }
    #[inline]
    fn count_ones(self) -> u32 {
        u64::count_ones(self)
    }
    #[inline]
    fn cell_anchor(self, level: u8) -> Self {
        let low = 2 * (Self::AXIS_BITS - level as u32);
        if low >= 64 { 0 } else { (self >> low) << low }
    }
    #[inline]
    fn wrapping_sub(self, other: Self) -> Self {
        u64::wrapping_sub(self, other)
    }
    #[inline]
    fn wrapping_add(self, other: Self) -> Self {
        u64::wrapping_add(self, other)
    }
    #[inline]
    fn pow2(bits: u32) -> Self {
        1 << bits
    }
    #[inline]
    fn to_u128(self) -> u128 {
        self as u128
    }
    #[inline]
    fn bits_from(self, bits: u32) -> u32 {
        (self >> bits) as u32
    }
    #[inline]
    fn from_u128(v: u128) -> Self {
        v as u64
    }
}

impl MortonKey for u128 {
    const AXIS_BITS: u32 = 64;
    fn encode_points(
        points: &[DVec2],
        first: u32,
        grid: &Grid,
        out: &mut [MaybeUninit<Pair<Self>>],
    ) {
        crate::morton::interleave::encode_wide(points, first, grid, out);
    }
    #[inline]
    fn encode(x: u64, y: u64) -> Self {
        use crate::morton::interleave::interleave32;
        let low = interleave32(x as u32, y as u32) as u128;
        let high = interleave32((x >> 32) as u32, (y >> 32) as u32) as u128;
        (high << 64) | low
    }
    #[inline]
    fn decode(self) -> (u64, u64) {
        let (xl, yl) = (self as u64).decode();
        let (xh, yh) = ((self >> 64) as u64).decode();
        ((xh << 32) | xl, (yh << 32) | yl)
    }
    #[inline]
    fn leading_zeros(self) -> u32 {
        u128::leading_zeros(self)
    }
    #[inline]
    fn trailing_zeros(self) -> u32 {
        u128::trailing_zeros(self)
    }
    #[inline]
    fn count_ones(self) -> u32 {
        u128::count_ones(self)
    }
    #[inline]
    fn cell_anchor(self, level: u8) -> Self {
        let low = 2 * (Self::AXIS_BITS - level as u32);
        if low >= 128 { 0 } else { (self >> low) << low }
    }
    #[inline]
    fn wrapping_sub(self, other: Self) -> Self {
        u128::wrapping_sub(self, other)
    }
    #[inline]
    fn wrapping_add(self, other: Self) -> Self {
        u128::wrapping_add(self, other)
    }
    #[inline]
    fn pow2(bits: u32) -> Self {
        1 << bits
    }
    #[inline]
    fn to_u128(self) -> u128 {
        self
    }
    #[inline]
    fn bits_from(self, bits: u32) -> u32 {
        (self >> bits) as u32
    }
    #[inline]
    fn from_u128(v: u128) -> Self {
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::morton::Cell;

    #[test]
    fn encode_decode_round_trip() {
        for &(x, y) in &[
            (0u64, 0u64),
            (1, 0),
            (0, 1),
            (0xFFFF_FFFF, 0x1234_5678),
            (7, 9),
        ] {
            assert_eq!(u64::encode(x, y).decode(), (x, y));
        }
        for &(x, y) in &[
            (u64::MAX, 0u64),
            (0x8000_0000_0000_0001, 0x7FFF_FFFF_0000_0003),
        ] {
            assert_eq!(u128::encode(x, y).decode(), (x, y));
        }
    }

    #[test]
    fn x_bit_is_the_upper_bit_of_each_pair() {
        assert_eq!(u64::encode(1, 0), 0b10);
        assert_eq!(u64::encode(0, 1), 0b01);
        assert_eq!(u64::encode(1 << 31, 0), 1 << 63);
        assert_eq!(u128::encode(1 << 63, 0), 1 << 127);
    }

    #[test]
    fn common_level_and_digit_sum() {
        let a = u64::encode(0, 0);
        let b = u64::encode(1 << 31, 0);
        assert_eq!(a.common_level(b), 0);
        let c = u64::encode(1 << 30, 1 << 30);
        assert_eq!(a.common_level(c), 1);
        assert_eq!(a.common_level(a), 32);
        // Quadrant 3 at level 1, quadrant 2 at level 2.
        let k = u64::encode((1 << 31) | (1 << 30), 1 << 31);
        assert_eq!(k.digit_sum(1), 3);
        assert_eq!(k.digit_sum(2), 5);
        assert_eq!(k.digit_sum(0), 0);
        // Against the digits one by one, for both widths and all levels.
        for i in 0..2000u64 {
            let narrow = i.wrapping_mul(0x9E37_79B9_7F4A_7C15) | (u64::from(i % 7 == 0) * u64::MAX);
            let wide = u128::from(narrow) << 64 | u128::from(narrow.rotate_left(23));
            digit_sums_match_the_digits(narrow);
            digit_sums_match_the_digits(wide);
        }
    }

    #[test]
    fn anchors_keep_their_digits_across_widths() {
        for i in 0..500u64 {
            let x = i.wrapping_mul(0x9E37_79B9_7F4A_7C15);
            let wide = u128::from(x) << 64 | u128::from(x.rotate_left(13));
            for level in [0u8, 1, 17, 31, 32] {
                let square = Cell::containing(wide, level);
                let narrow: u64 = in_width(square.anchor);
                assert_eq!(Cell::containing(narrow, level), Cell::containing(x, level));
                assert_eq!(in_width::<u64, u128>(narrow), { square.anchor });
            }
            // Finer than 32: the digits down to level 32.
            assert_eq!(in_width::<u128, u64>(wide), x);
            assert_eq!(in_width::<u64, u64>(x), x);
        }
    }

    fn digit_sums_match_the_digits<K: MortonKey>(key: K) {
        for level in 0..=K::AXIS_BITS as u8 {
            let digits = (1..=level).map(|l| Cell::containing(key, l).quadrant());
            assert_eq!(key.digit_sum(level), digits.sum::<u32>(), "{key:?} {level}");
        }
    }
}
