//! Which triangles of a canonical Delaunay triangulation a change of its points takes out and
//! puts in, found from the points of a window alone.
//!
//! The triangulation of a point set in a rectangle (its corners included), cocircular points
//! told apart by [`super::delaunay::perturbed_inside`], is one and the same whatever the order
//! of insertion, and a triangle belongs to it exactly when no point lies inside its
//! circumcircle. A change that takes points out and puts points in takes out the triangles
//! with a corner taken out or an added point inside their circle, and puts in those with a
//! corner put in or a removed point inside their circle.
//!
//! The window's own triangulation (its points and the domain's corners) has every triangle of
//! the whole one whose circle the window trusts (see [`Window::trusts`]), and no other
//! trusted triangle. So where the triangles a changed point touches (the star of a removed
//! corner, the triangles whose circles hold an added point), and the triangles next to them,
//! are trusted, they are the whole triangulation's: the conflict region of a point is
//! connected through edges, and a walk through trusted triangles and their trusted
//! neighbours takes the same steps in both.

use std::collections::HashSet;

use glam::DVec2;

use super::delaunay::{Location, Triangulation, beyond, in_circumcircle, locate};
use super::replay::Window;
use crate::mesh::{Domain, NONE};
use crate::morton::interleave::box_key;

/// A point by the bits of its coordinates, +0 and -0 alike.
pub(crate) fn point_bits(p: DVec2) -> [u64; 2] {
    [(p.x + 0.0).to_bits(), (p.y + 0.0).to_bits()]
}

/// The triangles a change takes out of and puts into the canonical Delaunay triangulation
/// of the points in `domain`, each by its corners counter-clockwise: `before` and `after` are
/// the points the window holds before and after the change, `removed` and `added` those of
/// them the change took out and put in. `None` where the window does not trust a triangle
/// the change touches, or one next to it: a larger window may.
pub(crate) fn local_changes(
    domain: Domain,
    window: &Window,
    before: &[DVec2],
    after: &[DVec2],
    removed: &[DVec2],
    added: &[DVec2],
) -> Option<[Vec<[DVec2; 3]>; 2]> {
    let gone = touched(domain, window, before, removed, added)?;
    let came = touched(domain, window, after, added, removed)?;
    Some([gone, came])
}

/// The triangles of the triangulation of `points` that have a corner in `leaving` or an
/// `arriving` point inside their circle; `None` where one of them, or one next to one, is not
/// trusted.
fn touched(
    domain: Domain,
    window: &Window,
    points: &[DVec2],
    leaving: &[DVec2],
    arriving: &[DVec2],
) -> Option<Vec<[DVec2; 3]>> {
    let t = triangulate(domain, window, points)?;
    let leaving: HashSet<[u64; 2]> = leaving.iter().map(|&p| point_bits(p)).collect();
    let mut found = vec![false; t.len()];
    for (id, c) in t.corners.iter().enumerate() {
        found[id] = c
            .iter()
            .any(|&v| leaving.contains(&point_bits(t.vertices[v as usize])));
    }
    let mut hint = 0;
    for &p in arriving {
        let Location::Inside(start) = locate(&t, p, hint) else {
            return None;
        };
        hint = start;
        mark_conflicts(&t, p, start, &mut found);
    }
    let corners = |id: usize| t.corners[id].map(|v| t.vertices[v as usize]);
    let mut touched = Vec::new();
    for id in (0..t.len()).filter(|&id| found[id]) {
        let neighbours = t.across[id].into_iter().map(beyond).filter(|&n| n != NONE);
        let near_trusted = neighbours
            .map(|n| corners(n as usize))
            .all(|c| window.trusts(c));
        if !window.trusts(corners(id)) || !near_trusted {
            return None;
        }
        touched.push(corners(id));
    }
    Some(touched)
}

/// Marks the triangles whose circles hold `p`, walking from `start`, which holds `p`.
fn mark_conflicts(t: &Triangulation, p: DVec2, start: u32, found: &mut [bool]) {
    let mut seen = HashSet::from([start]);
    let mut stack = vec![start];
    while let Some(id) = stack.pop() {
        found[id as usize] = true;
        for n in t.across[id as usize].map(beyond) {
            if n != NONE && !seen.contains(&n) && in_circumcircle(t, n, p) {
                seen.insert(n);
                stack.push(n);
            }
        }
    }
}

/// The canonical triangulation of `points` (inside the domain, none repeated) and the
/// domain's corners, inserted in Morton order over the window; `None` where one cannot be
/// placed.
fn triangulate(domain: Domain, window: &Window, points: &[DVec2]) -> Option<Triangulation> {
    let key = |p: DVec2| box_key(p, window.lo, window.hi - window.lo);
    let mut order: Vec<(u64, DVec2)> = points.iter().map(|&p| (key(p), p)).collect();
    order.sort_unstable_by(|a, b| {
        a.0.cmp(&b.0)
            .then(a.1.x.total_cmp(&b.1.x))
            .then(a.1.y.total_cmp(&b.1.y))
    });
    let mut t = Triangulation::rectangle(domain.lo, domain.hi);
    t.canonical = true;
    t.reserve(4 + order.len(), 0);
    t.insert_all(order.into_iter().map(|(_, p)| p)).ok()?;
    Some(t)
}
