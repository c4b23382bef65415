//! The exact geometric predicates (Shewchuk's adaptive orientation and in-circle tests, from the
//! `robust` crate), as signs. Every exact test in the crate goes through here.

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
    let det = orient_value(a, b, c);
    if det > 0.0 {
        Orientation::Left
    } else if det < 0.0 {
        Orientation::Right
    } else {
        Orientation::On
    }
}

/// Where `d` lies relative to the circle through `a`, `b`, `c` (counter-clockwise); exact.
#[inline]
pub(crate) fn in_circle(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> InCircle {
    let det = in_circle_value(a, b, c, d);
    if det > 0.0 {
        InCircle::Inside
    } else if det < 0.0 {
        InCircle::Outside
    } else {
        InCircle::On
    }
}

/// The orientation determinant itself, positive when `a`, `b`, `c` turn counter-clockwise, with
/// the exact sign; for reports that print it.
#[inline]
pub(crate) fn orient_value(a: DVec2, b: DVec2, c: DVec2) -> f64 {
    orient2d(coord(a), coord(b), coord(c))
}

/// The in-circle determinant itself, positive when `d` lies inside the circle through `a`,
/// `b`, `c` (counter-clockwise), with the exact sign; for reports that print it. Where it is so
/// small that it may have underflowed, it is that of the points scaled by a power of two.
#[inline]
pub(crate) fn in_circle_value(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> f64 {
    let det = incircle(coord(a), coord(b), coord(c), coord(d));
    if det.abs() >= UNDERFLOW_RISK {
        return det;
    }
    let [a, b, c, d] = scaled_up([a, b, c, d]);
    incircle(coord(a), coord(b), coord(c), coord(d))
}

/// Below this magnitude an adaptive determinant may have lost its sign to underflow: the
/// exact value of four small points' nearly cocircular determinant can lie below f64's range.
const UNDERFLOW_RISK: f64 = 1e-250;

/// The points scaled by the power of two that brings their largest coordinate into [0.5, 1)
/// when it is below that: exact, and it scales an in-circle determinant by its fourth power,
/// lifting a tiny one back into f64's range.
fn scaled_up<const N: usize>(mut points: [DVec2; N]) -> [DVec2; N] {
    let largest = points
        .iter()
        .fold(0.0f64, |m, p| m.max(p.abs().max_element()));
    if largest == 0.0 || largest >= 0.5 {
        return points;
    }
    let mut exponent = -(largest.log2().floor() as i32) - 1;
    // In steps that stay within f64's range: 2^1074 itself does not.
    while exponent > 0 {
        let step = exponent.min(1000);
        let factor = 2f64.powi(step);
        for p in &mut points {
            *p *= factor;
        }
        exponent -= step;
    }
    points
}

#[cfg(test)]
mod tests {
    use super::*;

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
