//! Points on the rectangle's sides, put in with the input before refinement in order, so that
//! the first triangulation has no triangle from a point near a side to the far corners.
//!
//! Without them, the Delaunay triangulation of the input points and the rectangle's corners
//! joins the points nearest each side to its far corners, in triangles whose circles span
//! the domain; every fix that reads them reaches across it, and a dynamic mesh must replay
//! the whole domain for an edit there. So each side is cut, between its corners and the
//! input points on it, into halves, quarters and so on: a piece is halved while an input
//! point lies inside its diametral circle. Refinement would split those pieces anyway (an
//! input point inside a boundary edge's diametral circle encroaches on it); done first, the
//! sides' points depend on the input points near them alone.
//!
//! A piece's circle holds those of its halves, so the pieces halved are those whose circles,
//! and their ancestors' circles, hold an input point; one point changes only the pieces
//! along one chain per side, those whose circles hold it and no other point
//! ([`side_changes`]).

use glam::DVec2;

use crate::mesh::Domain;

/// Whether `q` lies inside the circle with diameter `ab`.
fn inside_diametral_circle(a: DVec2, b: DVec2, q: DVec2) -> bool {
    (q - a).dot(q - b) < 0.0
}

/// The rectangle's sides counter-clockwise from `lo`: each from one corner to the next.
fn sides(domain: Domain) -> [(DVec2, DVec2); 4] {
    let (lo, hi) = (domain.lo, domain.hi);
    let c = [lo, DVec2::new(hi.x, lo.y), hi, DVec2::new(lo.x, hi.y)];
    [(c[0], c[1]), (c[1], c[2]), (c[2], c[3]), (c[3], c[0])]
}

/// Where `p` lies along side `(a, b)`, from 0 at `a` to 1 at `b`, if it lies on the side's
/// line strictly between its corners.
fn along_side((a, b): (DVec2, DVec2), p: DVec2) -> Option<f64> {
    let on_line = if a.x == b.x { p.x == a.x } else { p.y == a.y };
    let t = if a.x == b.x {
        (p.y - a.y) / (b.y - a.y)
    } else {
        (p.x - a.x) / (b.x - a.x)
    };
    (on_line && t > 0.0 && t < 1.0).then_some(t)
}

/// Whether `p` lies on a side of the rectangle between its corners: then the pieces of that
/// side, and its points, depend on it.
pub(crate) fn on_a_side(domain: Domain, p: DVec2) -> bool {
    sides(domain)
        .into_iter()
        .any(|side| along_side(side, p).is_some())
}

/// The ends of the pieces side `(a, b)` starts from: its corners and the points on it, in
/// order along it.
fn first_pieces(side: (DVec2, DVec2), points: &[DVec2]) -> Vec<DVec2> {
    let mut on: Vec<(f64, DVec2)> = points
        .iter()
        .filter_map(|&p| along_side(side, p).map(|t| (t, p)))
        .collect();
    on.sort_by(|x, y| x.0.total_cmp(&y.0));
    on.dedup_by(|x, y| x.1 == y.1);
    std::iter::once(side.0)
        .chain(on.into_iter().map(|(_, p)| p))
        .chain(std::iter::once(side.1))
        .collect()
}

/// The points on the rectangle's sides for input `points` (which lie in it): the midpoints
/// of the pieces halved, as the module says.
pub(crate) fn side_points(points: &[DVec2], domain: Domain) -> Vec<DVec2> {
    let mut out = Vec::new();
    for side in sides(domain) {
        let ends = first_pieces(side, points);
        for piece in ends.windows(2) {
            halve(piece[0], piece[1], points.to_vec(), &mut out);
        }
    }
    out
}

/// Halves the piece `ab` if one of `candidates` (points inside its ancestors' circles) lies
/// inside its circle, and its halves in turn.
fn halve(a: DVec2, b: DVec2, mut candidates: Vec<DVec2>, out: &mut Vec<DVec2>) {
    candidates.retain(|&q| inside_diametral_circle(a, b, q));
    let m = (a + b) / 2.0;
    if candidates.is_empty() || m == a || m == b {
        return;
    }
    out.push(m);
    halve(a, m, candidates.clone(), out);
    halve(m, b, candidates, out);
}

/// The side points that `p` alone decides, for a point `p` not on a side: the midpoints of
/// the pieces whose circles, and their ancestors', hold `p` and no other input point.
/// `other_inside(chain)` tells whether some input point other than `p` lies inside the
/// circles of all the pieces of `chain` (a piece and its ancestors, as `(a, b)`). `ends`
/// holds, per side, its corners and the input points on it in order along it.
pub(crate) fn side_changes(
    p: DVec2,
    ends: &[Vec<DVec2>; 4],
    mut other_inside: impl FnMut(&[(DVec2, DVec2)]) -> bool,
) -> Vec<DVec2> {
    let mut changed = Vec::new();
    for ends in ends {
        for piece in ends.windows(2) {
            let (a, b) = (piece[0], piece[1]);
            if inside_diametral_circle(a, b, p) {
                let mut chain = vec![(a, b)];
                follow(p, &mut chain, &mut other_inside, &mut changed);
            }
        }
    }
    changed
}

/// For the last piece of `chain`, whose circle and its ancestors' hold `p`: notes its
/// midpoint if no other point is inside them all, and goes on into the halves that hold `p`.
fn follow(
    p: DVec2,
    chain: &mut Vec<(DVec2, DVec2)>,
    other_inside: &mut impl FnMut(&[(DVec2, DVec2)]) -> bool,
    changed: &mut Vec<DVec2>,
) {
    let (a, b) = *chain.last().expect("a piece");
    let m = (a + b) / 2.0;
    if m == a || m == b {
        return;
    }
    if !other_inside(chain) {
        changed.push(m);
    }
    for (x, y) in [(a, m), (m, b)] {
        if inside_diametral_circle(x, y, p) {
            chain.push((x, y));
            follow(p, chain, other_inside, changed);
            chain.pop();
        }
    }
}

/// Whether `q` lies inside the circles of all the pieces of `chain`.
pub(crate) fn inside_chain(chain: &[(DVec2, DVec2)], q: DVec2) -> bool {
    chain.iter().all(|&(a, b)| inside_diametral_circle(a, b, q))
}

/// The corners of side `k` and the points of `on_side` (points on it) in order along it.
pub(crate) fn side_ends(domain: Domain, k: usize, on_side: &[DVec2]) -> Vec<DVec2> {
    first_pieces(sides(domain)[k], on_side)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit() -> Domain {
        Domain {
            lo: DVec2::ZERO,
            hi: DVec2::ONE,
        }
    }

    #[test]
    fn a_point_near_a_side_halves_the_pieces_down_to_its_distance() {
        let p = DVec2::new(0.3, 0.01);
        let side = side_points(&[p], unit());
        // Along the bottom, the pieces whose circles hold it, down to a side of 1/64; no other
        // side's circle holds it.
        let bottom: Vec<f64> = side.iter().map(|q| q.x).collect();
        assert!(side.iter().all(|q| q.y == 0.0));
        assert_eq!(bottom, vec![0.5, 0.25, 0.375, 0.3125, 0.28125, 0.296875]);
    }

    #[test]
    fn points_on_a_side_end_its_pieces() {
        let on = DVec2::new(0.5, 0.0);
        let near = DVec2::new(0.52, 0.001);
        let side = side_points(&[on, near], unit());
        // The bottom's pieces start at 0, 0.5 and 1: 0.5 itself is never a side point.
        assert!(!side.contains(&on));
        assert!(side.contains(&DVec2::new(0.75, 0.0)));
        assert!(!side.contains(&DVec2::new(0.25, 0.0)));
        assert!(on_a_side(unit(), on) && !on_a_side(unit(), near));
        assert!(!on_a_side(unit(), DVec2::ZERO));
    }

    #[test]
    fn the_changes_of_one_point_are_the_difference_of_the_side_points() {
        let domain = unit();
        let points: Vec<DVec2> = (0..60)
            .map(|k| {
                let t = k as f64;
                DVec2::new((t * 0.618_034).fract(), (t * 0.414_214).fract().powi(3))
            })
            .filter(|p| p.x > 0.0 && p.y > 0.0)
            .collect();
        for (i, &p) in points.iter().enumerate() {
            let others: Vec<DVec2> = points
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != i)
                .map(|(_, &q)| q)
                .collect();
            let mut with = side_points(&points, domain);
            let mut without = side_points(&others, domain);
            let key = |q: &DVec2| (q.x.to_bits(), q.y.to_bits());
            with.sort_by_key(key);
            without.sort_by_key(key);
            let mut expected: Vec<DVec2> = with
                .iter()
                .filter(|q| without.binary_search_by_key(&key(q), key).is_err())
                .copied()
                .collect();
            assert!(
                without
                    .iter()
                    .all(|q| with.binary_search_by_key(&key(q), key).is_ok())
            );
            let ends = std::array::from_fn(|k| side_ends(domain, k, &[]));
            let other = |chain: &[(DVec2, DVec2)]| others.iter().any(|&q| inside_chain(chain, q));
            let mut changed = side_changes(p, &ends, other);
            changed.sort_by_key(key);
            expected.sort_by_key(key);
            assert_eq!(changed, expected, "point {i} at {p:?}");
        }
    }
}
