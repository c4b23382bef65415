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
/// `b`, `c` (counter-clockwise), with the exact sign; for reports that print it.
#[inline]
pub(crate) fn in_circle_value(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> f64 {
    incircle(coord(a), coord(b), coord(c), coord(d))
}
