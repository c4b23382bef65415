//! The best triangulation of a small simple polygon that keeps some of its diagonals: the one
//! whose smallest angle is largest, then whose largest angle is smallest, by dynamic
//! programming over the polygon's sub-chains (O(n³) for n corners; the polygons here are a
//! leaf's corners, side midpoints and the points where edges cross its sides, a dozen or so).

use glam::DVec2;

use crate::mesh::angles_deg;
use crate::predicates::{Orientation, orientation};

/// The smallest and largest angle of a set of triangles, in degrees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Angles {
    /// Smallest angle.
    pub min: f64,
    /// Largest angle.
    pub max: f64,
}

impl Angles {
    /// Of no triangle: every angle of a triangle widens it.
    pub(crate) const NONE: Angles = Angles {
        min: f64::INFINITY,
        max: f64::NEG_INFINITY,
    };

    fn of_triangle(a: DVec2, b: DVec2, c: DVec2) -> Angles {
        let angles = angles_deg(a, b, c);
        Angles {
            min: angles.iter().copied().fold(f64::INFINITY, f64::min),
            max: angles.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        }
    }

    /// The angles of both sets together.
    pub(crate) fn and(self, other: Angles) -> Angles {
        Angles {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    /// Whether `self` is strictly better: a larger smallest angle, or the same and a smaller
    /// largest angle.
    fn beats(self, other: Angles) -> bool {
        self.min > other.min || (self.min == other.min && self.max < other.max)
    }
}

/// The triangles (corner indices, counter-clockwise) of the best triangulation of the simple
/// polygon `corners` (counter-clockwise) that has every pair in `kept` as an edge, with their
/// angles; `None` when no triangulation keeps them all (a kept pair that is no diagonal, two
/// kept pairs crossing) or the polygon is not simple enough to triangulate (corners on one
/// line). Ties go to the lowest apex index, so the result depends on the input alone.
pub(crate) fn best_triangulation(
    corners: &[DVec2],
    kept: &[[usize; 2]],
) -> Option<(Vec<[usize; 3]>, Angles)> {
    let n = corners.len();
    if n < 3 {
        return None;
    }
    let joinable = Joinable::new(corners, kept)?;
    // best[i][j]: the best triangulation of the chain i..=j closed by the pair (i, j).
    let mut best = vec![Angles::NONE; n * n];
    let mut apex = vec![usize::MAX; n * n];
    for span in 2..n {
        for i in 0..n - span {
            let j = i + span;
            if !joinable.get(i, j) {
                continue;
            }
            let mut found = None;
            for k in i + 1..j {
                if !(joinable.get(i, k) && joinable.get(k, j)) {
                    continue;
                }
                let (a, b, c) = (corners[i], corners[k], corners[j]);
                if orientation(a, b, c) != Orientation::Left {
                    continue;
                }
                let (left, right) = (best[i * n + k], best[k * n + j]);
                if (k > i + 1 && apex[i * n + k] == usize::MAX)
                    || (j > k + 1 && apex[k * n + j] == usize::MAX)
                {
                    continue;
                }
                let mut score = Angles::of_triangle(a, b, c);
                if k > i + 1 {
                    score = score.and(left);
                }
                if j > k + 1 {
                    score = score.and(right);
                }
                if found.is_none_or(|(s, _)| score.beats(s)) {
                    found = Some((score, k));
                }
            }
            if let Some((score, k)) = found {
                best[i * n + j] = score;
                apex[i * n + j] = k;
            }
        }
    }
    if apex[n - 1] == usize::MAX {
        return None;
    }
    let mut triangles = Vec::with_capacity(n - 2);
    let mut pending = vec![(0, n - 1)];
    while let Some((i, j)) = pending.pop() {
        if j < i + 2 {
            continue;
        }
        let k = apex[i * n + j];
        triangles.push([i, k, j]);
        pending.push((k, j));
        pending.push((i, k));
    }
    Some((triangles, best[n - 1]))
}

/// Which pairs of corners may be joined: the polygon's sides, and the diagonals that lie
/// inside it and cross no kept pair.
struct Joinable {
    n: usize,
    ok: Vec<bool>,
}

impl Joinable {
    fn new(corners: &[DVec2], kept: &[[usize; 2]]) -> Option<Joinable> {
        let n = corners.len();
        let mut ok = vec![false; n * n];
        for i in 0..n {
            for j in i + 1..n {
                let side = j == i + 1 || (i == 0 && j == n - 1);
                ok[i * n + j] = side
                    || (is_diagonal(corners, i, j)
                        && !kept.iter().any(|&[c, d]| interleaved([i, j], [c, d])));
            }
        }
        let joinable = Joinable { n, ok };
        kept.iter()
            .all(|&[c, d]| c != d && c < n && d < n && joinable.get(c, d))
            .then_some(joinable)
    }

    fn get(&self, i: usize, j: usize) -> bool {
        let (i, j) = (i.min(j), i.max(j));
        self.ok[i * self.n + j]
    }
}

/// Whether the chords `i j` and `c d` of a polygon cross: exactly one of `c`, `d` lies
/// strictly between `i` and `j` around it and the other strictly outside.
fn interleaved([i, j]: [usize; 2], [c, d]: [usize; 2]) -> bool {
    let (i, j) = (i.min(j), i.max(j));
    let inside = |v: usize| i < v && v < j;
    let outside = |v: usize| v < i || v > j;
    (inside(c) && outside(d)) || (inside(d) && outside(c))
}

/// Whether corners `i` and `j` (not neighbours) of the counter-clockwise polygon `corners`
/// see each other inside it: the segment leaves `i` into the polygon, meets no side it does
/// not end on and passes through no corner (exact predicates).
fn is_diagonal(corners: &[DVec2], i: usize, j: usize) -> bool {
    let n = corners.len();
    let (a, b) = (corners[i], corners[j]);
    if !in_cone(corners, i, b) || !in_cone(corners, j, a) {
        return false;
    }
    (0..n).all(|k| {
        let l = (k + 1) % n;
        if [k, l].contains(&i) || [k, l].contains(&j) {
            return true;
        }
        !segments_meet(a, b, corners[k], corners[l])
    })
}

/// Whether the direction from corner `i` towards `b` leaves into the polygon's interior.
fn in_cone(corners: &[DVec2], i: usize, b: DVec2) -> bool {
    let n = corners.len();
    let (prev, at, next) = (corners[(i + n - 1) % n], corners[i], corners[(i + 1) % n]);
    let left = |p, q, r| orientation(p, q, r) == Orientation::Left;
    let left_on = |p, q, r| orientation(p, q, r) != Orientation::Right;
    if left_on(prev, at, next) {
        left(at, b, prev) && left(b, at, next)
    } else {
        !(left_on(at, b, next) && left_on(b, at, prev))
    }
}

/// Whether the closed segments `ab` and `cd` share a point (exact).
fn segments_meet(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> bool {
    let [o1, o2, o3, o4] = [
        orientation(a, b, c),
        orientation(a, b, d),
        orientation(c, d, a),
        orientation(c, d, b),
    ];
    use Orientation::On as Collinear;
    if [o1, o2, o3, o4].iter().all(|o| *o != Collinear) {
        return o1 != o2 && o3 != o4;
    }
    let on = |p: DVec2, q: DVec2, r: DVec2| {
        r.x >= p.x.min(q.x) && r.x <= p.x.max(q.x) && r.y >= p.y.min(q.y) && r.y <= p.y.max(q.y)
    };
    (o1 == Collinear && on(a, b, c))
        || (o2 == Collinear && on(a, b, d))
        || (o3 == Collinear && on(c, d, a))
        || (o4 == Collinear && on(c, d, b))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square_with_midpoints() -> Vec<DVec2> {
        [
            [0.0, 0.0],
            [0.5, 0.0],
            [1.0, 0.0],
            [1.0, 0.5],
            [1.0, 1.0],
            [0.5, 1.0],
            [0.0, 1.0],
            [0.0, 0.5],
        ]
        .map(|[x, y]| DVec2::new(x, y))
        .to_vec()
    }

    #[test]
    fn a_square_with_four_midpoints_is_cut_into_right_isosceles_triangles() {
        let (triangles, angles) = best_triangulation(&square_with_midpoints(), &[]).unwrap();
        assert_eq!(triangles.len(), 6);
        assert!((angles.min - 45.0).abs() < 1e-9, "{angles:?}");
        assert!((angles.max - 90.0).abs() < 1e-9, "{angles:?}");
    }

    #[test]
    fn a_kept_chord_is_an_edge_and_crossing_chords_are_refused() {
        let corners = square_with_midpoints();
        let (triangles, _) = best_triangulation(&corners, &[[0, 4]]).unwrap();
        let has = |a, b| {
            triangles.iter().any(|t| {
                (0..3).any(|i| t[i] == a && t[(i + 1) % 3] == b || t[i] == b && t[(i + 1) % 3] == a)
            })
        };
        assert!(has(0, 4));
        assert!(best_triangulation(&corners, &[[0, 4], [2, 6]]).is_none());
    }

    #[test]
    fn a_reflex_corner_is_not_cut_across() {
        // An L shape: the diagonal from the reflex corner's neighbours across it is outside.
        let corners = [
            [0.0, 0.0],
            [2.0, 0.0],
            [2.0, 1.0],
            [1.0, 1.0],
            [1.0, 2.0],
            [0.0, 2.0],
        ]
        .map(|[x, y]| DVec2::new(x, y));
        let (triangles, _) = best_triangulation(&corners, &[]).unwrap();
        assert_eq!(triangles.len(), 4);
        let twice_area: f64 = triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| corners[i]);
                (b - a).perp_dot(c - a)
            })
            .sum();
        assert!((twice_area - 6.0).abs() < 1e-12);
        assert!(best_triangulation(&corners, &[[2, 4]]).is_none());
    }
}
