//! Bit interleaving: BMI2 `pdep` where the CPU has it (checked at run time), magic bits elsewhere.
//!
//! `unsafe` here: calling a `#[target_feature]` function is only sound once the feature has been
//! detected, and the freshly encoded pairs get their length once every slot is written.
#![allow(unsafe_code)]

use std::mem::MaybeUninit;

use glam::DVec2;
use rayon::prelude::*;

use super::key::MortonKey;

use super::quantize::Grid;
use super::sort::Pair;

const EVEN_BITS: u64 = 0x5555_5555_5555_5555;
const ODD_BITS: u64 = 0xAAAA_AAAA_AAAA_AAAA;

/// Spreads the 32 bits of `v` onto the even bit positions of a u64.
#[inline(always)]
fn spread_even(v: u32) -> u64 {
    let mut x = v as u64;
    x = (x | (x << 16)) & 0x0000_FFFF_0000_FFFF;
    x = (x | (x << 8)) & 0x00FF_00FF_00FF_00FF;
    x = (x | (x << 4)) & 0x0F0F_0F0F_0F0F_0F0F;
    x = (x | (x << 2)) & 0x3333_3333_3333_3333;
    (x | (x << 1)) & EVEN_BITS
}

/// Gathers the even bits of `v` into a u32 (inverse of [`spread_even`]).
#[inline(always)]
pub(crate) fn compact_even(v: u64) -> u32 {
    let mut x = v & EVEN_BITS;
    x = (x | (x >> 1)) & 0x3333_3333_3333_3333;
    x = (x | (x >> 2)) & 0x0F0F_0F0F_0F0F_0F0F;
    x = (x | (x >> 4)) & 0x00FF_00FF_00FF_00FF;
    x = (x | (x >> 8)) & 0x0000_FFFF_0000_FFFF;
    ((x | (x >> 16)) & 0xFFFF_FFFF) as u32
}

/// Interleaves two 32-bit coordinates, x bit above y bit (portable magic-bits version).
#[inline(always)]
pub(crate) fn interleave32(x: u32, y: u32) -> u64 {
    (spread_even(x) << 1) | spread_even(y)
}

/// The Morton key of `p` on a 2^16 grid over the box from `lo` of `size` (clamped to it): an
/// order in which walks from one point to the next stay short.
pub(crate) fn box_key(p: DVec2, lo: DVec2, size: DVec2) -> u64 {
    let size = size.max(DVec2::splat(f64::MIN_POSITIVE));
    let u = ((p - lo) / size).clamp(DVec2::ZERO, DVec2::ONE) * 65535.0;
    interleave32(u.x as u32, u.y as u32)
}

/// Points per task when encoding: large enough to amortize the task, small enough to balance.
const ENCODE_CHUNK: usize = 1 << 14;

/// The (key, index) pairs of all points, encoded in parallel straight into fresh memory (so the
/// first-touch page faults are spread over the threads too).
pub(crate) fn encode_all<K: MortonKey>(points: &[DVec2], grid: &Grid) -> Vec<Pair<K>> {
    let mut pairs: Vec<Pair<K>> = crate::par::with_capacity_huge(points.len());
    pairs.spare_capacity_mut()[..points.len()]
        .par_chunks_mut(ENCODE_CHUNK)
        .zip(points.par_chunks(ENCODE_CHUNK))
        .enumerate()
        .for_each(|(chunk, (out, pts))| {
            // Each encoder writes a slot per point: the chunks must pair up exactly.
            assert_eq!(out.len(), pts.len(), "encode chunk {chunk}");
            let first = (chunk * ENCODE_CHUNK) as u32;
            K::encode_points(pts, first, grid, out);
        });
    // SAFETY: the capacity is `points.len()` (`with_capacity_huge`). The output chunks split
    // the first `points.len()` slots as the point chunks split the points (same length, same
    // chunk size), so each output chunk has as many slots as its points (asserted per chunk,
    // in release too; `zip` stops at the shorter otherwise), and `encode_points`
    // of both key types (the trait is sealed: `u64` and `u128` in `key.rs`, calling
    // `encode_narrow`/`encode_wide` below) writes `out[i]` for every point `i`; so every slot
    // is initialised. The parallel loop has ended, so nothing writes them meanwhile.
    unsafe { pairs.set_len(points.len()) };
    pairs
}

/// Whether the running CPU has BMI2 (`pdep`). The standard library caches the answer.
#[inline]
pub fn has_pdep() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("bmi2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Quantizes `points` on `grid` and writes their narrow keys.
/// `out[i]` gets the key of `points[i]` and the index `first + i`; every slot is written.
pub(crate) fn encode_narrow(
    points: &[DVec2],
    first: u32,
    grid: &Grid,
    out: &mut [MaybeUninit<Pair<u64>>],
) {
    #[cfg(target_arch = "x86_64")]
    if has_pdep() {
        // SAFETY: the only requirement of a `#[target_feature(enable = "bmi2")]` function is
        // that the CPU has BMI2, which `has_pdep` detected just above.
        unsafe { encode_narrow_bmi2(points, first, grid, out) };
        return;
    }
    encode_portable(points, first, grid, out);
}

/// The portable encoder of either key width (magic bits).
fn encode_portable<K: MortonKey>(
    points: &[DVec2],
    first: u32,
    grid: &Grid,
    out: &mut [MaybeUninit<Pair<K>>],
) {
    for (i, (p, k)) in points.iter().zip(out.iter_mut()).enumerate() {
        let (x, y) = grid.quantize(*p);
        k.write(Pair::new(K::encode(x, y), first + i as u32));
    }
}

/// Quantizes `points` on `grid` and writes their wide keys.
/// `out[i]` gets the key of `points[i]` and the index `first + i`; every slot is written.
pub(crate) fn encode_wide(
    points: &[DVec2],
    first: u32,
    grid: &Grid,
    out: &mut [MaybeUninit<Pair<u128>>],
) {
    #[cfg(target_arch = "x86_64")]
    if has_pdep() {
        // SAFETY: as in `encode_narrow`: BMI2 was detected by `has_pdep` just above.
        unsafe { encode_wide_bmi2(points, first, grid, out) };
        return;
    }
    encode_portable(points, first, grid, out);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "bmi2")]
fn encode_narrow_bmi2(
    points: &[DVec2],
    first: u32,
    grid: &Grid,
    out: &mut [MaybeUninit<Pair<u64>>],
) {
    use std::arch::x86_64::_pdep_u64;
    for (i, (p, k)) in points.iter().zip(out.iter_mut()).enumerate() {
        let (x, y) = grid.quantize(*p);
        k.write(Pair::new(
            _pdep_u64(x, ODD_BITS) | _pdep_u64(y, EVEN_BITS),
            first + i as u32,
        ));
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "bmi2")]
fn encode_wide_bmi2(
    points: &[DVec2],
    first: u32,
    grid: &Grid,
    out: &mut [MaybeUninit<Pair<u128>>],
) {
    use std::arch::x86_64::_pdep_u64;
    for (i, (p, k)) in points.iter().zip(out.iter_mut()).enumerate() {
        let (x, y) = grid.quantize(*p);
        let low = _pdep_u64(x & 0xFFFF_FFFF, ODD_BITS) | _pdep_u64(y & 0xFFFF_FFFF, EVEN_BITS);
        let high = _pdep_u64(x >> 32, ODD_BITS) | _pdep_u64(y >> 32, EVEN_BITS);
        k.write(Pair::new(
            ((high as u128) << 64) | low as u128,
            first + i as u32,
        ));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_and_compact_are_inverse() {
        for v in [0u32, 1, 2, 0xFFFF_FFFF, 0xDEAD_BEEF, 0x8000_0001] {
            assert_eq!(compact_even(spread_even(v)), v);
        }
    }

    fn portable<K: MortonKey>(pts: &[DVec2], grid: &Grid) -> Vec<Pair<K>> {
        let mut out = vec![MaybeUninit::uninit(); pts.len()];
        encode_portable(pts, 0, grid, &mut out);
        out.into_iter().map(|p| read_written(&p)).collect()
    }

    /// Reads back a slot the encoder wrote (Pair is Copy and every slot was written).
    fn read_written<K: Copy>(slot: &MaybeUninit<Pair<K>>) -> Pair<K> {
        // SAFETY: `encode_portable` wrote every slot of `out`, which has as many slots as there
        // are points.
        #[allow(unsafe_code)]
        unsafe {
            slot.assume_init()
        }
    }

    #[test]
    fn the_fast_and_portable_encoders_agree() {
        let pts: Vec<DVec2> = (0..5000)
            .map(|i| DVec2::new((i as f64 * 0.618).fract(), (i as f64 * 0.377).fract()))
            .collect();
        let grid = Grid::for_test(32);
        assert_eq!(encode_all::<u64>(&pts, &grid), portable::<u64>(&pts, &grid));
        let grid = Grid::for_test(64);
        assert_eq!(
            encode_all::<u128>(&pts, &grid),
            portable::<u128>(&pts, &grid)
        );
    }

    #[test]
    fn pdep_agrees_with_magic_bits() {
        let grid = Grid::for_test(32);
        let pts: Vec<DVec2> = (0..1000)
            .map(|i| DVec2::new((i as f64 * 0.618).fract(), (i as f64 * 0.377).fract()))
            .collect();
        let a: Vec<Pair<u64>> = encode_all(&pts, &grid);
        for (i, (p, k)) in pts.iter().zip(&a).enumerate() {
            let (x, y) = grid.quantize(*p);
            assert_eq!(k.key, interleave32(x as u32, y as u32));
            assert_eq!(k.idx, i as u32);
        }
        let grid = Grid::for_test(64);
        let w: Vec<Pair<u128>> = encode_all(&pts, &grid);
        for (p, k) in pts.iter().zip(&w) {
            let (x, y) = grid.quantize(*p);
            assert_eq!(<u128 as crate::morton::MortonKey>::decode(k.key), (x, y));
        }
    }
}
