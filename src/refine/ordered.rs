//! Off-center refinement one insertion at a time, in an order fixed by the triangles alone,
//! so that the mesh depends only on the points near each triangle.
//!
//! The loop of [`super::refiner`] fixes bad triangles in a global order (size classes, then
//! tiles and Morton order across the whole domain, the newest first), so where a Steiner point
//! lands depends on work done far away. Here every bad triangle and every encroached boundary
//! edge waits in one priority queue under a key computed from its own corners:
//! - triangles with an angle below about 14.5° (see [`very_thin`]), the largest circumcircle
//!   first: along curves of points, the first triangulation is a fan of slivers whose
//!   circumcircles span the curve, and breaking the largest first keeps each insertion's
//!   cavity small (1e5 points on a parabola: 2.3 s, against 111 s by the shortest edge);
//! - then boundary splits, the shortest edge first;
//! - then the other bad triangles by their shortest edge, as Har-Peled and Üngör order them;
//! - sizes in classes of a factor √2, and within a class the Morton order of the Steiner
//!   point, so that consecutive fixes touch nearby memory; ties by the exact position.
//!
//! The smallest live entry is fixed next: its off-center (or circumcenter) is inserted, or,
//! where that would lie beyond the boundary or encroach on boundary edges, the first of those
//! edges in order of their midpoints is split. Cocircular points are told apart by a
//! symbolic perturbation ([`super::delaunay::perturbed_inside`]), so the triangulation at
//! each step is the Delaunay triangulation of the points so far whatever their order, and
//! each triangle is turned to start at its least corner before its key is taken. So the mesh
//! is a function of the points and the domain alone, and two fixes interact only where their
//! triangles meet, and then in key order: what a dynamic mesh needs.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use glam::DVec2;

use super::delaunay::{
    Cavity, Location, NEXT, PREV, Store, Triangulation, beyond, is_wall, locate,
};
use super::refiner::{
    Bounds, Finish, badness, encroaches, midpoint, place, resolvable_steiner_point, split_point,
    steiner_point,
};
use super::{
    RefineDomain, RefineOptions, boundary_edges, checked_order, insert_in_order, square_around,
    unmet_triangles, within_budget,
};
use crate::error::Error;
use crate::mesh::{Domain, Mesh, MeshReport, NONE, StageTimes, report_of};
use rayon::prelude::*;

/// The refined Delaunay mesh of `points` in a rectangle, made in the order the module gives,
/// with its report. The same points in any order give the same triangles, and the same input
/// the same bytes on any number of threads: the input points are numbered in input order
/// after the rectangle's corners, then the Steiner points in (x, y) order; triangles start at
/// their smallest vertex and are sorted. Refinement runs on one thread: where the mesh need not
/// depend only on the points near each triangle, [`super::refine_points`] is faster.
///
/// # Errors
/// As [`super::refine_points`]; [`Error::InvalidOption`] for the convex hull as the domain.
pub fn refine_points_in_order(
    points: &[DVec2],
    options: &RefineOptions,
) -> Result<(Mesh, MeshReport), Error> {
    let mut times = StageTimes::default();
    let morton = checked_order(points, options, &mut times)?;
    let domain = match options.domain {
        RefineDomain::Rectangle(d) => d,
        RefineDomain::Square => square_around(points),
        RefineDomain::ConvexHull => {
            return Err(Error::InvalidOption {
                option: "domain",
                message: "refinement in order meshes a rectangle, not the convex hull".into(),
            });
        }
    };
    let distinct = morton.order.len();
    let mut t = Triangulation::rectangle(domain.lo, domain.hi);
    t.canonical = true;
    t.reserve(2 * options.expected_vertices(distinct), distinct + 4);
    let vertex_input = times.time("delaunay", || {
        insert_in_order(&mut t, points, &morton.order)
    })?;
    let bounds = Bounds::new(options, domain.lo, domain.hi);
    let budget = options.budget(distinct);
    let finish = times.time("refine", || refine_in_order(&mut t, &bounds, budget))?;
    let unmet = (finish == Finish::OutOfBudget).then(|| unmet_triangles(&t, &bounds));
    let mesh = times.time("mesh", || canonical_mesh(t, vertex_input, domain));
    let quality = times.time("angles", || {
        super::angle_quality(&mesh.vertices, &mesh.triangles)
    });
    let report = report_of(&mesh, distinct, morton.duplicates.count, &quality, times);
    within_budget(mesh, report, unmet, budget)
}

/// An f64 as a u64 in the same order (total order, negatives first).
fn ordered(v: f64) -> u64 {
    let bits = v.to_bits();
    if bits >> 63 == 0 {
        bits | 1 << 63
    } else {
        !bits
    }
}

/// What waits in the queue, 32 bytes: its key (urgency and size in one word, see
/// [`rank`], then x, y), the triangle's slot, and its newest corner with, in the top two bits,
/// the corner facing the boundary edge a split halves (3 for a bad triangle). A slot reused
/// holds a triangle with a newer vertex (every triangle an insertion makes has it), so the
/// newest corner tells whether the slot still holds the triangle queued.
type Entry = Reverse<(u64, u64, u64, u32, u32)>;

/// The first word of a key: urgent entries first, then by size class (a factor of √2 each),
/// then by the Morton key of the position (its top 45 bits), so that consecutive fixes touch
/// nearby memory; ties go on to the exact position.
fn rank(bounds: &Bounds, urgent: bool, size: f64, at: DVec2) -> u64 {
    let class = (2.0 * size.abs().log2()).floor().clamp(-4000.0, 4000.0) as i64;
    let class = if size < 0.0 { -class } else { class };
    let class = (class + 8192) as u64 & 0x3FFF;
    (u64::from(!urgent) << 63) | (class << 49) | (place(bounds, at) >> 15)
}

/// The entry for the triangle in `slot` with corners `corners`, and `edge`.
fn entry(key: (u64, u64, u64), slot: u32, corners: [u32; 3], edge: u32) -> Entry {
    debug_assert!(newest(corners) < 1 << 30);
    Reverse((key.0, key.1, key.2, slot, newest(corners) | edge << 30))
}

fn newest(corners: [u32; 3]) -> u32 {
    corners[0].max(corners[1]).max(corners[2])
}

/// Refines `t` one insertion at a time in the order the module gives, until nothing is bad,
/// or past `budget` vertices.
fn refine_in_order(t: &mut Triangulation, bounds: &Bounds, budget: usize) -> Result<Finish, Error> {
    if bounds.unbounded() {
        return Ok(Finish::Done);
    }
    let mut queue = BinaryHeap::new();
    for id in 0..t.len() as u32 {
        queue_triangle(t, bounds, id, &mut queue);
    }
    let mut cavity = Cavity::default();
    while let Some(Reverse((_, _, _, slot, stamp))) = queue.pop() {
        let edge = stamp >> 30;
        if newest(t.corners[slot as usize]) != stamp & ((1 << 30) - 1) {
            continue;
        }
        if t.vertices.len() > budget {
            return Ok(Finish::OutOfBudget);
        }
        if edge < 3 {
            split(t, bounds, &mut cavity, slot, edge as usize, &mut queue)?;
        } else {
            fix(t, bounds, &mut cavity, slot, &mut queue)?;
        }
    }
    Ok(Finish::Done)
}

/// Turns triangle `id` to start at its least corner (so that its key and Steiner point depend
/// on it alone) and queues it if it is bad, and the boundary edges its corners encroach on.
fn queue_triangle(t: &mut Triangulation, bounds: &Bounds, id: u32, queue: &mut BinaryHeap<Entry>) {
    turn_to_least_corner(t, id);
    let tri = t.triangle(id);
    for i in 0..3 {
        let (a, b) = tri.edge(i);
        if is_wall(tri.n[i])
            && bounds.splits(tri.n[i])
            && encroaches(t, bounds, t.point(tri.v[i]), (a, b))
        {
            let (pa, pb) = (t.point(a), t.point(b));
            let m = midpoint(pa, pb);
            let key = (
                rank(bounds, true, pa.distance(pb) / 2.0, m),
                ordered(m.x),
                ordered(m.y),
            );
            queue.push(entry(key, id, tri.v, i as u32));
        }
    }
    if let Some((corner, shortest2)) = badness(t, bounds, id) {
        let p = steiner_point(t, bounds, id, corner);
        let c = tri.v.map(|v| t.point(v));
        let urgent = very_thin(c, corner);
        let size = if urgent {
            -circumradius(c)
        } else {
            shortest2.sqrt()
        };
        let key = (rank(bounds, urgent, size, p), ordered(p.x), ordered(p.y));
        queue.push(entry(key, id, tri.v, 3));
    }
}

/// Splits the boundary edge opposite corner `edge` of triangle `slot` at its midpoint.
fn split(
    t: &mut Triangulation,
    bounds: &Bounds,
    cavity: &mut Cavity,
    slot: u32,
    edge: usize,
    queue: &mut BinaryHeap<Entry>,
) -> Result<(), Error> {
    let (a, b) = t.triangle(slot).edge(edge);
    let m = split_point(t.point(a), t.point(b), (false, false))?;
    cavity.dig(t, m, slot);
    cavity.commit(t, m, None);
    queue_created(t, bounds, cavity, queue);
    Ok(())
}

/// Inserts the Steiner point of bad triangle `slot`, or, where it would lie beyond the
/// boundary or encroach on boundary edges, splits the first of those edges in (x, y) order
/// of their midpoints and queues the triangle again.
fn fix(
    t: &mut Triangulation,
    bounds: &Bounds,
    cavity: &mut Cavity,
    slot: u32,
    queue: &mut BinaryHeap<Entry>,
) -> Result<(), Error> {
    let Some(bad) = badness(t, bounds, slot) else {
        return Ok(());
    };
    let p = resolvable_steiner_point(t, bounds, slot, bad)?;
    let wall = match locate(t, p, slot) {
        Location::Outside { triangle, edge } => {
            if !bounds.splits(t.across[triangle as usize][edge]) {
                return Ok(());
            }
            (triangle, edge)
        }
        Location::Inside(start) => {
            cavity.dig(t, p, start);
            let first = cavity
                .rim()
                .iter()
                .filter(|e| {
                    is_wall(e.outer)
                        && bounds.splits(e.outer)
                        && encroaches(t, bounds, p, (e.a, e.b))
                })
                .map(|e| {
                    (
                        midpoint(t.point(e.a), t.point(e.b)),
                        e.inner,
                        e.corner as usize,
                    )
                })
                .min_by(|x, y| (x.0.x, x.0.y).partial_cmp(&(y.0.x, y.0.y)).expect("finite"));
            match first {
                None => {
                    cavity.commit(t, p, None);
                    queue_created(t, bounds, cavity, queue);
                    return Ok(());
                }
                Some((_, triangle, edge)) => {
                    cavity.abandon(t);
                    (triangle, edge)
                }
            }
        }
        Location::Vertex(_) | Location::Foreign => {
            return Err(Error::RefinementResolution { x: p.x, y: p.y });
        }
    };
    let corners = t.corners[slot as usize];
    split(t, bounds, cavity, wall.0, wall.1, queue)?;
    if t.corners[slot as usize] == corners {
        queue_triangle(t, bounds, slot, queue);
    }
    Ok(())
}

/// Queues what the last insertion made.
fn queue_created(
    t: &mut Triangulation,
    bounds: &Bounds,
    cavity: &Cavity,
    queue: &mut BinaryHeap<Entry>,
) {
    for &id in cavity.created() {
        queue_triangle(t, bounds, id, queue);
    }
}

/// Whether the triangle with these corners has its smallest angle, at `corner`, below
/// arcsin(1/4), about 14.5°. Such triangles are fixed before the merely bad ones: along
/// curves of points, the first triangulation is full of slivers between distant parts of the
/// curve, and fixing the smallest triangles first there lays rows of off-centers of one size
/// across the gaps instead of graded ones (3.5 times the triangles on a spiral).
fn very_thin(v: [DVec2; 3], corner: usize) -> bool {
    let (p, q) = (v[NEXT[corner]], v[PREV[corner]]);
    let apex = v[corner];
    let area2 = (q - p).perp_dot(apex - p);
    16.0 * area2 * area2 < apex.distance_squared(p) * apex.distance_squared(q)
}

/// The radius of the circle through `c`.
fn circumradius(c: [DVec2; 3]) -> f64 {
    let (a, b, d) = (
        c[0].distance(c[1]),
        c[1].distance(c[2]),
        c[2].distance(c[0]),
    );
    a * b * d / (2.0 * (c[1] - c[0]).perp_dot(c[2] - c[0]).abs())
}

/// Turns triangle `id` to start at its least corner in (x, y) order, so that what
/// is computed from its corners in turn (its shortest edge among equal ones, its
/// circumcenter's rounding) depends on the triangle alone, not on how insertions left it.
fn turn_to_least_corner(t: &mut Triangulation, id: u32) {
    let c = t.corners[id as usize].map(|v| t.vertices[v as usize]);
    let least = (0..3)
        .min_by(|&i, &j| {
            (c[i].x, c[i].y)
                .partial_cmp(&(c[j].x, c[j].y))
                .expect("finite")
        })
        .expect("three corners");
    let at = [least, NEXT[least], PREV[least]];
    let (corners, across) = (t.corners[id as usize], t.across[id as usize]);
    t.corners[id as usize] = at.map(|i| corners[i]);
    t.across[id as usize] = at.map(|i| across[i]);
}

/// The mesh of the refined triangulation, numbered by the points alone: the rectangle's
/// corners, the other input points in input order, the Steiner points in (x, y) order; each
/// triangle from its smallest vertex, the triangles sorted.
fn canonical_mesh(t: Triangulation, mut vertex_input: Vec<u32>, domain: Domain) -> Mesh {
    let Triangulation {
        vertices,
        corners,
        across,
        ..
    } = t;
    vertex_input.resize(vertices.len(), NONE);
    let mut order: Vec<u32> = (4..vertices.len() as u32).collect();
    order.par_sort_unstable_by(|&a, &b| {
        let (ia, pa) = (vertex_input[a as usize], vertices[a as usize]);
        let (ib, pb) = (vertex_input[b as usize], vertices[b as usize]);
        ia.cmp(&ib)
            .then(pa.x.total_cmp(&pb.x))
            .then(pa.y.total_cmp(&pb.y))
    });
    let mut new_vertex: Vec<u32> = (0..vertices.len() as u32).collect();
    for (k, &v) in order.iter().enumerate() {
        new_vertex[v as usize] = 4 + k as u32;
    }
    let renumbered: Vec<DVec2> = (0..4)
        .map(|v| vertices[v])
        .chain(order.iter().map(|&v| vertices[v as usize]))
        .collect();
    let inputs: Vec<u32> = (0..4)
        .map(|v| vertex_input[v])
        .chain(order.iter().map(|&v| vertex_input[v as usize]))
        .collect();
    // Each triangle from its smallest corner, with its links turned alike.
    let turned: Vec<([u32; 3], [u32; 3])> = corners
        .par_iter()
        .zip(&across)
        .map(|(c, n)| {
            let c = c.map(|v| new_vertex[v as usize]);
            let first = (0..3).min_by_key(|&i| c[i]).expect("three corners");
            let at = [first, NEXT[first], PREV[first]];
            (at.map(|i| c[i]), at.map(|i| n[i]))
        })
        .collect();
    let mut triangle_order: Vec<u32> = (0..turned.len() as u32).collect();
    triangle_order.par_sort_unstable_by_key(|&k| turned[k as usize].0);
    let mut new_triangle = vec![0u32; turned.len()];
    for (k, &old) in triangle_order.iter().enumerate() {
        new_triangle[old as usize] = k as u32;
    }
    let (triangles, neighbours): (Vec<[u32; 3]>, Vec<[u32; 3]>) = triangle_order
        .par_iter()
        .map(|&old| {
            let (c, n) = turned[old as usize];
            (
                c,
                n.map(|x| {
                    if x == NONE {
                        NONE
                    } else {
                        new_triangle[beyond(x) as usize]
                    }
                }),
            )
        })
        .unzip();
    let boundary = boundary_edges(&triangles, &neighbours, &renumbered, Some(domain));
    Mesh {
        vertices: renumbered,
        vertex_input: inputs,
        triangles,
        neighbours,
        boundary,
        domain,
        ..Mesh::default()
    }
}
