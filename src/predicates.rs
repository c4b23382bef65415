//! The exact geometric predicates (Shewchuk's adaptive orientation and in-circle tests, from the
//! `robust` crate), as signs. Every exact test in the crate goes through here. The adaptive
//! tests are exact while no part of their expansions underflows; for points whose coordinates
//! span more of f64's range than that allows, the sign is taken from the points scaled by a
//! power of two, or from integers.

use std::cmp::Ordering;

use glam::DVec2;
use robust::{Coord, incircle, orient2d};

/// Where a point lies seen along a directed line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Orientation {
    /// On its left: the three points turn counter-clockwise.
    Left,
    /// On its right: they turn clockwise.
    Right,
    /// On the line: the points are collinear.
    On,
}

/// Where a point lies relative to a circle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum InCircle {
    /// Strictly inside.
    Inside,
    /// Strictly outside.
    Outside,
    /// On the circle.
    On,
}

#[inline]
fn coord(p: DVec2) -> Coord<f64> {
    Coord { x: p.x, y: p.y }
}

/// Where `c` lies seen along `a → b`; exact.
#[inline]
pub(crate) fn orientation(a: DVec2, b: DVec2, c: DVec2) -> Orientation {
    match orient_value(a, b, c).partial_cmp(&0.0) {
        Some(Ordering::Greater) => Orientation::Left,
        Some(Ordering::Less) => Orientation::Right,
        _ => Orientation::On,
    }
}

/// Where `d` lies relative to the circle through `a`, `b`, `c` (counter-clockwise); exact.
#[inline]
pub(crate) fn in_circle(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> InCircle {
    match in_circle_value(a, b, c, d).partial_cmp(&0.0) {
        Some(Ordering::Greater) => InCircle::Inside,
        Some(Ordering::Less) => InCircle::Outside,
        _ => InCircle::On,
    }
}

/// The orientation determinant itself, positive when `a`, `b`, `c` turn counter-clockwise: its
/// sign exact, its magnitude the adaptive test's (areas are summed from it).
#[inline]
pub(crate) fn orient_value(a: DVec2, b: DVec2, c: DVec2) -> f64 {
    let det = orient2d(coord(a), coord(b), coord(c));
    if within_exact_range(&[a, b, c]) {
        return det;
    }
    let sign = match rescaled_within_exact_range([a, b, c]) {
        Some([a, b, c]) => sign_of(orient2d(coord(a), coord(b), coord(c))),
        None => exact::orientation_sign(a, b, c),
    };
    with_sign(det, sign)
}

/// The in-circle determinant itself, positive when `d` lies inside the circle through `a`,
/// `b`, `c` (counter-clockwise): its sign exact, its magnitude the adaptive test's; for
/// reports that print it.
#[inline]
pub(crate) fn in_circle_value(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> f64 {
    let det = incircle(coord(a), coord(b), coord(c), coord(d));
    if within_exact_range(&[a, b, c, d]) {
        return det;
    }
    let sign = match rescaled_within_exact_range([a, b, c, d]) {
        Some([a, b, c, d]) => sign_of(incircle(coord(a), coord(b), coord(c), coord(d))),
        None => exact::in_circle_sign(a, b, c, d),
    };
    with_sign(det, sign)
}

fn sign_of(v: f64) -> Ordering {
    v.partial_cmp(&0.0).unwrap_or(Ordering::Equal)
}

/// The magnitudes between which every coordinate (or 0) keeps the adaptive predicates exact:
/// a nonzero difference of such coordinates is a multiple of 2^-202 and below 2^151, so every
/// product of up to four of them, and every part of one the adaptive sums keep, is a multiple
/// of 2^-808 and below 2^610, inside f64's normal range. Outside it, parts can underflow (a
/// coordinate of 1e-300 squared) and the sign comes out wrong.
const EXACT_LOW: f64 = f64::from_bits((1023 - 150) << 52); // 2^-150
const EXACT_HIGH: f64 = f64::from_bits((1023 + 150) << 52); // 2^150

fn within_exact_range(points: &[DVec2]) -> bool {
    points.iter().all(|p| {
        [p.x, p.y]
            .into_iter()
            .all(|v| v == 0.0 || (EXACT_LOW..=EXACT_HIGH).contains(&v.abs()))
    })
}

/// The points scaled by the power of two that brings their largest coordinate into
/// [0.5, 1), when that is exact (no coordinate loses a bit) and puts them all within the exact
/// range; a power of two scales an orientation determinant by its square and an in-circle
/// determinant by its fourth power, signs unchanged. Tiny shapes (a sliver 1e-35 wide at
/// 1e-218) come back into range this way.
fn rescaled_within_exact_range<const N: usize>(points: [DVec2; N]) -> Option<[DVec2; N]> {
    let largest = points
        .iter()
        .fold(0.0f64, |m, p| m.max(p.abs().max_element()));
    if largest == 0.0 {
        return None;
    }
    let exponent = -(largest.log2().floor() as i32) - 1;
    let scaled = points.map(|p| times_power_of_two(p, exponent));
    let exact = scaled
        .iter()
        .zip(&points)
        .all(|(s, p)| times_power_of_two(*s, -exponent) == *p);
    (exact && within_exact_range(&scaled)).then_some(scaled)
}

/// `p · 2^exponent`, in steps that stay within f64's range (2^1074 itself does not).
fn times_power_of_two(mut p: DVec2, mut exponent: i32) -> DVec2 {
    while exponent != 0 {
        let step = exponent.clamp(-1000, 1000);
        p *= 2f64.powi(step);
        exponent -= step;
    }
    p
}

/// `approximate` where its sign is `sign`, else the smallest value of that sign: the
/// magnitude is only for reports, the sign is exact.
fn with_sign(approximate: f64, sign: Ordering) -> f64 {
    let tiny = f64::from_bits(1);
    match sign {
        Ordering::Equal => 0.0,
        Ordering::Greater if approximate > 0.0 => approximate,
        Ordering::Greater => tiny,
        Ordering::Less if approximate < 0.0 => approximate,
        Ordering::Less => -tiny,
    }
}

/// The determinants in integers, for points whose coordinates span more of f64's range than
/// the adaptive predicates keep exact (1e40 beside 1e-306): every f64 is an integer times a
/// power of two, so after scaling all coordinates by the smallest power among them, the
/// determinants are integer polynomials, evaluated without rounding. Slow, and rare.
mod exact {
    use glam::DVec2;
    use num_bigint::BigInt;
    use std::cmp::Ordering;

    /// The sign of `d`'s in-circle determinant against `a`, `b`, `c`.
    pub(super) fn in_circle_sign(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> Ordering {
        let [ax, ay, bx, by, cx, cy, dx, dy] = integers([a.x, a.y, b.x, b.y, c.x, c.y, d.x, d.y]);
        let (adx, ady) = (ax - &dx, ay - &dy);
        let (bdx, bdy) = (bx - &dx, by - &dy);
        let (cdx, cdy) = (cx - &dx, cy - dy);
        let lift = |x: &BigInt, y: &BigInt| x * x + y * y;
        let det = lift(&adx, &ady) * (&bdx * &cdy - &cdx * &bdy)
            + lift(&bdx, &bdy) * (&cdx * &ady - &adx * &cdy)
            + lift(&cdx, &cdy) * (&adx * &bdy - &bdx * &ady);
        det.sign().cmp_zero()
    }

    /// The sign of the orientation determinant of `a`, `b`, `c`.
    pub(super) fn orientation_sign(a: DVec2, b: DVec2, c: DVec2) -> Ordering {
        let [ax, ay, bx, by, cx, cy] = integers([a.x, a.y, b.x, b.y, c.x, c.y]);
        let det = (ax - &cx) * (by - &cy) - (ay - &cy) * (bx - cx);
        det.sign().cmp_zero()
    }

    trait SignOrdering {
        fn cmp_zero(self) -> Ordering;
    }

    impl SignOrdering for num_bigint::Sign {
        fn cmp_zero(self) -> Ordering {
            match self {
                num_bigint::Sign::Minus => Ordering::Less,
                num_bigint::Sign::NoSign => Ordering::Equal,
                num_bigint::Sign::Plus => Ordering::Greater,
            }
        }
    }

    /// The values as integers times one common power of two (which the determinants' signs
    /// ignore).
    fn integers<const N: usize>(values: [f64; N]) -> [BigInt; N] {
        let parts = values.map(mantissa_exponent);
        let least = parts.iter().map(|&(_, e)| e).min().unwrap_or(0);
        parts.map(|(m, e)| BigInt::from(m) << (e - least) as usize)
    }

    /// `v` as `m · 2^e` with an integer `m`; finite `v` only.
    fn mantissa_exponent(v: f64) -> (i64, i32) {
        let bits = v.to_bits();
        let field = ((bits >> 52) & 0x7FF) as i32;
        let fraction = (bits & ((1 << 52) - 1)) as i64;
        let (m, e) = if field == 0 {
            (fraction, -1074)
        } else {
            (fraction | 1 << 52, field - 1075)
        };
        (if bits >> 63 == 1 { -m } else { m }, e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_product_below_f64s_range_keeps_the_orientations_sign() {
        // b.y · c.x is 2^-1060 + 2^-1112: its tail is below f64's range, and the adaptive
        // test, losing it, calls the points collinear; exactly, c lies 2^-1112 to the right.
        let a = DVec2::ZERO;
        let b = DVec2::new(1.0, (1.0 + f64::EPSILON) * 2f64.powi(-1000));
        let c = DVec2::new(2f64.powi(-60), 2f64.powi(-1060));
        assert_eq!(orientation(a, b, c), Orientation::Right);
        assert_eq!(orientation(b, a, c), Orientation::Left);
        let on_line = DVec2::new(2f64.powi(-60), 2f64.powi(-1060));
        assert_eq!(
            orientation(a, DVec2::new(1.0, 2f64.powi(-1000)), on_line),
            Orientation::On
        );
    }

    #[test]
    fn a_point_one_step_off_a_flat_rectangles_circle_is_told_apart() {
        // A rectangle 1 by 1e-200: its in-circle products lie near 1e-416, and no power of
        // two brings both its sides into the range where the adaptive test is exact.
        let h = 1e-200;
        let (a, b, c) = (DVec2::ZERO, DVec2::new(1.0, 0.0), DVec2::new(1.0, h));
        let above = DVec2::new(0.0, f64::from_bits(h.to_bits() + 1));
        let below = DVec2::new(0.0, f64::from_bits(h.to_bits() - 1));
        assert_eq!(in_circle(a, b, c, DVec2::new(0.0, h)), InCircle::On);
        assert_eq!(in_circle(a, b, c, above), InCircle::Outside);
        assert_eq!(in_circle(a, b, c, below), InCircle::Inside);
        // The same beside a far point: 1e40 and 1e-200 in one test.
        let far = DVec2::new(1e40, 0.0);
        assert_eq!(
            in_circle(a, far, DVec2::new(1e40, h), above),
            InCircle::Outside
        );
        assert_eq!(
            in_circle(a, far, DVec2::new(1e40, h), below),
            InCircle::Inside
        );
    }

    #[test]
    fn a_nearly_cocircular_determinant_below_f64s_range_keeps_its_sign() {
        // Four corners of a rectangle 5e-23 by 1.8e-35, one a step of 2e-234 off: the exact
        // determinant is -4e-326.
        let a = DVec2::new(-1.530_173_323_455_523_2e-19, -1.805_774_942_692_359e-35);
        let b = DVec2::new(-1.529_658_460_291_507_4e-19, -1.805_774_942_692_359e-35);
        let c = DVec2::new(-1.529_658_460_291_507_4e-19, 1.699_710_172_823_173_9e-218);
        let d = DVec2::new(-1.530_173_323_455_523_2e-19, 1.699_710_172_823_174e-218);
        assert_eq!(orientation(a, b, c), Orientation::Left);
        assert_eq!(in_circle(a, b, c, d), InCircle::Outside);
        assert_eq!(
            in_circle(a * 4.0, b * 4.0, c * 4.0, d * 4.0),
            InCircle::Outside
        );
    }
}
