//! The convex hull of the input points as the domain: the Delaunay triangulation of a square
//! around the points is cut down to the triangles inside their hull.
//!
//! The square's corners (and the strips' seam ends on its sides) lie outside the hull. A hull
//! edge need not be an edge of the square's triangulation: points close inside it can make the
//! corners' triangles reach across it. Each missing hull edge is put in by flipping the edges
//! that cross it (Sloan's method); the triangles with a vertex that is not an input point are
//! then exactly those outside the hull, and go; Lawson's flips from the triangles the recovery
//! made restore the Delaunay property inside, where the hull edges bound the flips. What stays
//! is the Delaunay triangulation of the points, whose boundary is their hull.

use std::collections::{HashMap, HashSet, VecDeque};

use glam::DVec2;
use rayon::prelude::*;

use super::MIN_GAP;
use super::delaunay::{NEXT, PREV, Triangulation, beyond};
use crate::error::Error;
use crate::mesh::NONE;
use crate::par::{GRAIN, SharedSlots, exclusive_scan_u32_by};
use crate::predicates::{Orientation, orient_value, orientation};

/// A hull corner narrower than this (degrees) has its boundary edges split on concentric
/// circles around it, so that splits on its two sides do not encroach on each other forever.
pub(super) const ACUTE_CORNER_DEG: f64 = 60.0;

/// The hull of a triangulation's input vertices and what the refinement needs of it.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Hull {
    /// The hull's vertices counter-clockwise, points on its sides included (as vertex numbers
    /// of the triangulation before the cut).
    pub vertices: Vec<u32>,
}

/// The vertices of the convex hull of the triangulation's input vertices (`vertex_input` not
/// [`NONE`]), counter-clockwise from the lowest-leftmost, every point on a hull side included.
///
/// # Errors
/// [`Error::Degenerate`] when the points are collinear: their hull has no area.
pub(super) fn hull_vertices(t: &Triangulation, vertex_input: &[u32]) -> Result<Hull, Error> {
    let candidates = outside_octagon(t, vertex_input);
    let mut sorted = candidates;
    sorted.par_sort_unstable_by(|&a, &b| {
        let (p, q) = (t.vertices[a as usize], t.vertices[b as usize]);
        p.x.total_cmp(&q.x).then(p.y.total_cmp(&q.y))
    });
    let at = |v: u32| t.vertices[v as usize];
    let mut chain: Vec<u32> = Vec::with_capacity(2 * sorted.len());
    // Andrew's monotone chain, keeping collinear points: a point is dropped only on a strict
    // right turn.
    for pass in [&sorted[..], &reversed(&sorted)[..]] {
        let start = chain.len();
        for &v in pass {
            while chain.len() >= start + 2
                && orientation(
                    at(chain[chain.len() - 2]),
                    at(chain[chain.len() - 1]),
                    at(v),
                ) == Orientation::Right
            {
                chain.pop();
            }
            chain.push(v);
        }
        chain.pop();
    }
    let area2: f64 = (0..chain.len())
        .map(|k| at(chain[k]).perp_dot(at(chain[(k + 1) % chain.len()])))
        .sum();
    if chain.len() < 3 || area2 <= 0.0 || !spans_area(t, &chain) {
        let p = at(sorted[0]);
        return Err(Error::Degenerate { x: p.x, y: p.y });
    }
    Ok(Hull { vertices: chain })
}

fn reversed(v: &[u32]) -> Vec<u32> {
    v.iter().rev().copied().collect()
}

/// Whether some three hull vertices make a strict left turn: the hull is not a segment.
fn spans_area(t: &Triangulation, chain: &[u32]) -> bool {
    let at = |v: u32| t.vertices[v as usize];
    let (a, b) = (at(chain[0]), at(chain[1]));
    chain[2..]
        .iter()
        .any(|&c| orientation(a, b, at(c)) == Orientation::Left)
}

/// The input vertices not strictly inside the octagon of the eight extreme points (Akl and
/// Toussaint): only they can be on the hull. Exact, so every hull point survives.
fn outside_octagon(t: &Triangulation, vertex_input: &[u32]) -> Vec<u32> {
    let directions = [
        DVec2::new(1.0, 0.0),
        DVec2::new(1.0, 1.0),
        DVec2::new(0.0, 1.0),
        DVec2::new(-1.0, 1.0),
        DVec2::new(-1.0, 0.0),
        DVec2::new(-1.0, -1.0),
        DVec2::new(0.0, -1.0),
        DVec2::new(1.0, -1.0),
    ];
    let inputs = || {
        (0..t.vertices.len() as u32)
            .into_par_iter()
            .filter(|&v| vertex_input[v as usize] != NONE)
    };
    // The extreme vertex in each direction, all eight in one pass; ties to the lower number,
    // so that it is the same on any thread count.
    type Extremes = [(f64, u32); 8];
    let further = |a: (f64, u32), b: (f64, u32)| match a.0.total_cmp(&b.0) {
        std::cmp::Ordering::Less => b,
        std::cmp::Ordering::Greater => a,
        std::cmp::Ordering::Equal => (a.0, a.1.min(b.1)),
    };
    let merge =
        |a: Extremes, b: Extremes| -> Extremes { std::array::from_fn(|k| further(a[k], b[k])) };
    let found = inputs()
        .fold(
            || [(f64::NEG_INFINITY, NONE); 8],
            |acc, v| {
                let p = t.vertices[v as usize];
                merge(acc, directions.map(|d| (p.dot(d), v)))
            },
        )
        .reduce(|| [(f64::NEG_INFINITY, NONE); 8], merge);
    let extreme: [DVec2; 8] = found.map(|(_, v)| t.vertices[v as usize]);
    inputs()
        .filter(|&v| {
            let p = t.vertices[v as usize];
            (0..8).any(|k| orientation(extreme[k], extreme[(k + 1) % 8], p) != Orientation::Left)
        })
        .collect()
}

/// Cuts `t` down to the hull of its input vertices: recovers the hull edges, drops every
/// triangle and vertex outside, renumbers what stays in order, and flips it Delaunay. Returns
/// the hull with the new vertex numbers; `vertex_input` follows the vertices.
pub(super) fn cut_to_hull(
    t: &mut Triangulation,
    vertex_input: &mut Vec<u32>,
) -> Result<Hull, Error> {
    let hull = hull_vertices(t, vertex_input)?;
    let mut stars = Stars::of(t);
    let mut touched = Vec::new();
    let n = hull.vertices.len();
    for k in 0..n {
        let edge = (hull.vertices[k], hull.vertices[(k + 1) % n]);
        recover_edge(t, &mut stars, edge, &mut touched)?;
    }
    let (vertex_map, triangle_map) = compact(t, vertex_input);
    let edges: Vec<(u32, usize)> = touched
        .iter()
        .map(|&old| triangle_map.of(old))
        .filter(|&new| new != NONE)
        .flat_map(|new| (0..3).map(move |i| (new, i)))
        .collect();
    t.flip_to_delaunay(edges);
    let vertices: Vec<u32> = hull.vertices.iter().map(|&v| vertex_map.of(v)).collect();
    Ok(Hull {
        vertices: peel_slivers(t, &vertices),
    })
}

/// How close to a hull side, relative to its length, a point inside makes that side bend
/// through it: closer than this, refinement would need splits of the side closer together
/// than f64 places them near the point.
const NEAR_SIDE: f64 = 1e-11;

/// Bends the boundary through every point that lies [`near_side`] a hull side: the
/// sliver triangle between the side and such a point goes, and the outline runs through the
/// point (an angle a hair above 180°). Returns the outline's vertices counter-clockwise.
fn peel_slivers(t: &mut Triangulation, hull: &[u32]) -> Vec<u32> {
    let boundary: Vec<(u32, usize)> = (0..t.corners.len() as u32)
        .into_par_iter()
        .flat_map_iter(|id| {
            let n = t.across[id as usize];
            (0..3).filter(move |&i| n[i] == NONE).map(move |i| (id, i))
        })
        .collect();
    let mut inner: HashMap<(u32, u32), (u32, usize)> = boundary
        .into_iter()
        .map(|(id, i)| {
            let c = t.corners[id as usize];
            ((c[NEXT[i]], c[PREV[i]]), (id, i))
        })
        .collect();
    let mut removed = Vec::new();
    // A vertex already on the outline stays off any other side: peeling to it would pinch the
    // domain there, or drop the corner between two sides of a spike.
    let mut on_outline: HashSet<u32> = hull.iter().copied().collect();
    let mut outline = Vec::with_capacity(hull.len());
    let mut sides: Vec<(u32, u32)> = (0..hull.len())
        .rev()
        .map(|k| (hull[k], hull[(k + 1) % hull.len()]))
        .collect();
    while let Some((a, b)) = sides.pop() {
        let Some(&(id, i)) = inner.get(&(a, b)) else {
            outline.push(a);
            continue;
        };
        let x = t.corners[id as usize][i];
        if on_outline.contains(&x)
            || !near_side(
                t.vertices[a as usize],
                t.vertices[b as usize],
                t.vertices[x as usize],
            )
        {
            outline.push(a);
            continue;
        }
        // The neighbours across x → a and b → x become the boundary a → x, x → b.
        for k in [NEXT[i], PREV[i]] {
            let n = t.across[id as usize][k];
            if n != NONE {
                let j = t.corner_facing(n, id);
                t.across[n as usize][j] = NONE;
                let c = t.corners[n as usize];
                inner.insert((c[NEXT[j]], c[PREV[j]]), (n, j));
            }
        }
        removed.push(id);
        on_outline.insert(x);
        sides.extend([(x, b), (a, x)]);
    }
    drop_triangles(t, &removed);
    outline
}

/// Whether `x` lies left of `a → b`, between its ends, within [`NEAR_SIDE`] of its length or
/// of `x`'s own magnitude, whichever is less: f64 resolves splits of the side near `x` to that
/// magnitude, however long the side (a side from a point near the origin to one 1e55 away
/// passes points at distance 2 that need no bend). Or within [`MIN_GAP`] of the side, however
/// finely f64 resolves there: the splits between them would be so short that the exact
/// predicates' products, and the angle test's, underflow.
fn near_side(a: DVec2, b: DVec2, x: DVec2) -> bool {
    let d = b - a;
    let reach = NEAR_SIDE * d.length().min(x.abs().max_element());
    // The distance from the determinant, each end's test from that end: measured from a far
    // end, a point near the other rounds onto it and seems to lie on the side.
    let cross = orient_value(a, b, x);
    cross > 0.0
        && (x - a).dot(d) >= 0.0
        && (x - b).dot(d) <= 0.0
        && cross <= reach.max(MIN_GAP) * d.length()
}

/// Removes the triangles `removed` (already unlinked from their neighbours), keeping the
/// order of the rest.
fn drop_triangles(t: &mut Triangulation, removed: &[u32]) {
    if removed.is_empty() {
        return;
    }
    let mut gone = vec![false; t.corners.len()];
    for &id in removed {
        gone[id as usize] = true;
    }
    let mut map = vec![NONE; t.corners.len()];
    let mut next = 0;
    for id in 0..t.corners.len() {
        if !gone[id] {
            map[id] = next as u32;
            t.corners[next] = t.corners[id];
            t.across[next] = t.across[id];
            next += 1;
        }
    }
    t.corners.truncate(next);
    t.across.truncate(next);
    for n in t.across.iter_mut().flatten() {
        if *n != NONE {
            *n = map[*n as usize];
        }
    }
}

/// A triangle around each vertex, kept current through the recovery's flips.
pub(super) struct Stars {
    triangle_of: Vec<u32>,
}

impl Stars {
    pub fn of(t: &Triangulation) -> Self {
        let mut triangle_of = vec![NONE; t.vertices.len()];
        for (id, c) in t.corners.iter().enumerate() {
            for &v in c {
                triangle_of[v as usize] = id as u32;
            }
        }
        Stars { triangle_of }
    }

    /// The triangle holding edge `a → b` counter-clockwise and the corner opposite it, if that
    /// edge exists; found by turning around `a`.
    pub fn edge(&self, t: &Triangulation, a: u32, b: u32) -> Option<(u32, usize)> {
        self.around(t, a).find_map(|(id, i)| {
            // Corner i is a; the edge a → c[NEXT[i]] is opposite corner PREV[i].
            (t.corners[id as usize][NEXT[i]] == b).then_some((id, PREV[i]))
        })
    }

    /// The triangles around vertex `a`, each with `a`'s corner in it, turning one way; for a
    /// vertex on the square's boundary, from the triangle at one end of its open fan.
    pub fn around<'t>(
        &self,
        t: &'t Triangulation,
        a: u32,
    ) -> impl Iterator<Item = (u32, usize)> + 't {
        let corner = move |id: u32| {
            let c = t.corners.get(id as usize)?;
            (0..3).find(|&i| c[i] == a)
        };
        // A vertex in no triangle (which a broken triangulation would show) has an empty star.
        let mut first = self.triangle_of[a as usize];
        // Turn the other way to the end of the fan, if it has one.
        let mut back = first;
        for _ in 0..t.corners.len() {
            let Some(i) = corner(back) else { break };
            back = beyond(t.across[back as usize][NEXT[i]]);
            if back == NONE || back == self.triangle_of[a as usize] {
                break;
            }
            first = back;
        }
        let mut next = (first != NONE).then_some(first);
        std::iter::from_fn(move || {
            let id = next?;
            let i = corner(id)?;
            let after = beyond(t.across[id as usize][PREV[i]]);
            next = (after != first && after != NONE).then_some(after);
            Some((id, i))
        })
        .take(t.corners.len())
    }

    /// Points each corner of the given triangles at one that holds it.
    fn note(&mut self, t: &Triangulation, ids: [u32; 2]) {
        for id in ids {
            for v in t.corners[id as usize] {
                self.triangle_of[v as usize] = id;
            }
        }
    }
}

/// Makes `u → v` an edge by flipping the edges that cross it, queueing each one that cannot
/// be flipped yet (its quadrilateral is not convex) behind the others (Sloan): some crossing
/// edge can always be flipped, so the crossings run out. No vertex lies on the open segment.
pub(super) fn recover_edge(
    t: &mut Triangulation,
    stars: &mut Stars,
    (u, v): (u32, u32),
    touched: &mut Vec<u32>,
) -> Result<(), Error> {
    if stars.edge(t, u, v).is_some() || stars.edge(t, v, u).is_some() {
        return Ok(());
    }
    let (pu, pv) = (t.vertices[u as usize], t.vertices[v as usize]);
    let stuck = || Error::Degenerate { x: pu.x, y: pu.y };
    let mut crossing: VecDeque<(u32, u32)> = crossing_edges(t, stars, (u, v), pu, pv)
        .ok_or_else(stuck)?
        .into();
    let mut stalls = 0;
    while let Some((a, b)) = crossing.pop_front() {
        let (id, i) = stars.edge(t, a, b).ok_or_else(stuck)?;
        let other = beyond(t.across[id as usize][i]);
        // An edge the segment crosses always has a triangle beyond it; if rounding-free
        // predicates ever say otherwise (points spanning dozens of orders of magnitude), the
        // edge cannot be put in, which is an error, not a panic.
        if other == NONE {
            return Err(stuck());
        }
        let j = t.linked_corner(other, id).ok_or_else(stuck)?;
        let (c, w) = (t.corners[id as usize][i], t.corners[other as usize][j]);
        let [pa, pb, pc, pw] = [a, b, c, w].map(|x| t.vertices[x as usize]);
        // The quadrilateral is strictly convex when c → w separates a from b.
        if !separates((pc, pw), pa, pb) {
            crossing.push_back((a, b));
            stalls += 1;
            if stalls > crossing.len() {
                return Err(stuck());
            }
            continue;
        }
        stalls = 0;
        t.flip(id, i, other, j);
        stars.note(t, [id, other]);
        touched.extend([id, other]);
        let ends_apart = ![u, v].contains(&c) && ![u, v].contains(&w);
        if ends_apart && separates((pu, pv), pc, pw) {
            crossing.push_back((c, w));
        }
    }
    Ok(())
}

/// Whether the line through `line` has `p` and `q` strictly on opposite sides.
fn separates((a, b): (DVec2, DVec2), p: DVec2, q: DVec2) -> bool {
    use Orientation::{Left, Right};
    matches!(
        (orientation(a, b, p), orientation(a, b, q)),
        (Left, Right) | (Right, Left)
    )
}

/// The edges the segment `u → v` crosses, in order from `u`, each in the direction of the
/// triangle on `u`'s side; `None` if the walk finds no way through.
fn crossing_edges(
    t: &Triangulation,
    stars: &Stars,
    (u, v): (u32, u32),
    pu: DVec2,
    pv: DVec2,
) -> Option<Vec<(u32, u32)>> {
    let side = |x: u32| orientation(pu, pv, t.vertices[x as usize]);
    // The triangle of u's star whose far edge the segment leaves by.
    let (mut id, corner) = stars.around(t, u).find(|&(id, i)| {
        let c = t.corners[id as usize];
        side(c[NEXT[i]]) == Orientation::Right && side(c[PREV[i]]) == Orientation::Left
    })?;
    let mut edge = corner;
    let mut out = Vec::new();
    for _ in 0..t.corners.len() {
        let c = t.corners[id as usize];
        let a = c[NEXT[edge]];
        out.push((a, c[PREV[edge]]));
        let next = t.across[id as usize][edge];
        if next == NONE {
            return None;
        }
        let j = t.linked_corner(next, id)?;
        let far = t.corners[next as usize][j];
        if far == v {
            return Some(out);
        }
        // In `next`, corner j is `far`, PREV[j] is a and NEXT[j] is b: the segment leaves by
        // the edge from `far` to whichever of a, b lies on the other side of the line.
        edge = if side(far) == side(a) {
            PREV[j]
        } else {
            NEXT[j]
        };
        id = next;
    }
    None
}

/// Drops every triangle with a vertex that is not an input point and every such vertex (no
/// triangle left uses one), keeping the order of the rest. Returns the renumbering of vertices
/// and of triangles. The dropped ones are few (the square's corners, the seams' ends and the
/// triangles at them).
fn compact(t: &mut Triangulation, vertex_input: &mut Vec<u32>) -> (Renumbering, Renumbering) {
    let keep: Vec<bool> = touches_no_added_vertex(t, vertex_input);
    compact_keeping(t, vertex_input, &keep)
}

/// Per triangle, whether all its corners are input points (not the square's corners or the
/// strips' seam ends).
pub(super) fn touches_no_added_vertex(t: &Triangulation, vertex_input: &[u32]) -> Vec<bool> {
    t.corners
        .par_iter()
        .map(|c| c.iter().all(|&v| vertex_input[v as usize] != NONE))
        .collect()
}

/// Drops the triangles not kept and every vertex no kept triangle uses, keeping the order of
/// the rest (regions follow the triangles, segment marks the links). Returns the renumbering
/// of vertices and of triangles; links to dropped triangles become boundary.
pub(super) fn compact_keeping(
    t: &mut Triangulation,
    vertex_input: &mut Vec<u32>,
    keep: &[bool],
) -> (Renumbering, Renumbering) {
    let mut used = vec![0u32; t.vertices.len()];
    let slots = SharedSlots::new(&mut used);
    (t.corners.par_iter().zip(keep))
        .filter(|(_, k)| **k)
        .for_each(|(c, _)| c.iter().for_each(|&v| slots.store(v as usize, 1)));
    let vertex_map = Renumbering::keeping(used.len(), |v| used[v] != 0);
    let triangle_map = Renumbering::keeping(keep.len(), |id| keep[id]);
    vertex_map.keep_in(&mut t.vertices, |&p| p);
    vertex_map.keep_in(vertex_input, |&i| i);
    triangle_map.keep_in(&mut t.corners, |c| c.map(|v| vertex_map.of(v)));
    triangle_map.keep_in(&mut t.across, |n| {
        n.map(|link| match beyond(link) {
            NONE => NONE,
            u => match triangle_map.of(u) {
                NONE => NONE,
                m => m | (link & super::delaunay::SEGMENT),
            },
        })
    });
    if !t.regions.is_empty() {
        triangle_map.keep_in(&mut t.regions, |&r| r);
    }
    (vertex_map, triangle_map)
}

/// The new numbers of items once some of them are removed, keeping the order of the rest: the
/// count of kept items before each, computed in parallel.
pub(super) struct Renumbering {
    /// The count of kept items before each item, and the count of all kept last.
    before: Vec<u32>,
}

impl Renumbering {
    /// The numbering of the items of `0..len` that `kept` takes.
    fn keeping(len: usize, kept: impl Fn(usize) -> bool + Sync) -> Self {
        let before = exclusive_scan_u32_by(len, |i| usize::from(kept(i)))
            .expect("fewer items than 32-bit indices");
        Renumbering { before }
    }

    /// The new number of `i`, or [`NONE`] if it was removed.
    #[inline]
    pub fn of(&self, i: u32) -> u32 {
        let (at, next) = (self.before[i as usize], self.before[i as usize + 1]);
        if next > at { at } else { NONE }
    }

    /// Keeps the kept ones of `items` (one per number), in order, each as `renew` maps it, in
    /// place: each chunk packs its own in parallel, then the chunks move down one after
    /// another. No fresh memory is touched, and the vector keeps its capacity, which refinement
    /// fills later.
    fn keep_in<T: Copy + Send + Sync>(&self, items: &mut Vec<T>, renew: impl Fn(&T) -> T + Sync) {
        let len = items.len();
        items
            .par_chunks_mut(GRAIN)
            .enumerate()
            .for_each(|(c, chunk)| {
                let mut write = 0;
                for k in 0..chunk.len() {
                    if self.of((c * GRAIN + k) as u32) != NONE {
                        chunk[write] = renew(&chunk[k]);
                        write += 1;
                    }
                }
            });
        for start in (0..len).step_by(GRAIN) {
            let end = (start + GRAIN).min(len);
            let (to, count) = (self.before[start], self.before[end] - self.before[start]);
            items.copy_within(start..start + count as usize, to as usize);
        }
        items.truncate(self.before[len] as usize);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renumbering_skips_the_removed_numbers() {
        let len = 3 * crate::par::GRAIN + 17;
        let gone: Vec<u32> = vec![0, 1, 5, 4095, 4096, 9000, len as u32 - 1];
        let map = Renumbering::keeping(len, |i| !gone.contains(&(i as u32)));
        let mut next = 0;
        for i in 0..len as u32 {
            if gone.contains(&i) {
                assert_eq!(map.of(i), NONE, "{i}");
            } else {
                assert_eq!(map.of(i), next, "{i}");
                next += 1;
            }
        }
        let mut items: Vec<u32> = (0..len as u32).collect();
        map.keep_in(&mut items, |&i| i);
        assert_eq!(items.len(), len - gone.len());
        assert!(
            items
                .iter()
                .enumerate()
                .all(|(k, &i)| map.of(i) == k as u32)
        );
    }

    #[test]
    fn a_point_near_the_end_of_a_long_side_is_measured_from_that_end() {
        // From the far end, the point rounds onto the near one and seems on the side; it lies
        // 2.9e-17 inside, 1e10 times further than NEAR_SIDE of its magnitude.
        let far = DVec2::new(-5.630_506_713_171_445e49, -5.630_506_717_317_518e49);
        let near = DVec2::new(7.738_694_5e-317, 1.295_163e-318);
        let x = DVec2::new(-3.988_095_257_061_079_7e-16, -3.571_761_622_850_442e-16);
        assert!(!near_side(far, near, x));
        // 1e-40 inside, it is near.
        let (far, near) = (DVec2::new(-1e50, 0.0), DVec2::ZERO);
        assert!(near_side(far, near, DVec2::new(-1e-16, 1e-40)));
        assert!(!near_side(far, near, DVec2::new(1e-16, 1e-40)));
    }

    #[test]
    fn the_hull_keeps_collinear_points_and_refuses_a_line() {
        let mut t = Triangulation::rectangle(DVec2::splat(-10.0), DVec2::splat(10.0));
        let mut cavity = super::super::delaunay::Cavity::default();
        let points = [
            (0.0, 0.0),
            (1.0, 0.0),
            (2.0, 0.0),
            (2.0, 2.0),
            (1.0, 1.0),
            (0.0, 2.0),
        ];
        for (x, y) in points {
            cavity.insert(&mut t, DVec2::new(x, y), 0).unwrap();
        }
        let mut vertex_input: Vec<u32> = (0..t.vertices.len() as u32)
            .map(|v| if v < 4 { NONE } else { v - 4 })
            .collect();
        let hull = cut_to_hull(&mut t, &mut vertex_input).unwrap();
        let at: Vec<u32> = hull
            .vertices
            .iter()
            .map(|&v| vertex_input[v as usize])
            .collect();
        // Counter-clockwise from the lowest-leftmost; (1, 0) on the bottom side stays; (1, 1)
        // is inside.
        assert_eq!(at, [0, 1, 2, 3, 5]);
        assert_eq!(t.vertices.len(), 6);
        let area: f64 = t
            .corners
            .iter()
            .map(|c| {
                let [a, b, c] = c.map(|v| t.vertices[v as usize]);
                0.5 * (b - a).perp_dot(c - a)
            })
            .sum();
        assert_eq!(area, 4.0);

        let mut line = Triangulation::rectangle(DVec2::splat(-10.0), DVec2::splat(10.0));
        for x in [0.0, 1.0, 3.0] {
            cavity.insert(&mut line, DVec2::new(x, x), 0).unwrap();
        }
        let mut inputs = vec![NONE, NONE, NONE, NONE, 0, 1, 2];
        assert!(matches!(
            cut_to_hull(&mut line, &mut inputs),
            Err(Error::Degenerate { .. })
        ));
    }
}
