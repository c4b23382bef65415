//! Off-center refinement one insertion at a time, in an order fixed by the triangles alone,
//! so that the mesh depends only on the points near each triangle.
//!
//! It starts from the Delaunay triangulation of the input points, the rectangle's corners and
//! the points [`super::sides`] puts on its sides, so that no triangle joins a point near a
//! side to the far corners.
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
use super::sides::side_points;
use super::{
    RefineDomain, RefineOptions, Unfinished, boundary_edges, checked_order, insert_in_order,
    square_around, unmet_triangles, within_budget,
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
    run_in_order(points, options, false).map(|run| (run.mesh, run.report))
}

/// What a run of refinement in order made: the mesh and its report, the bounds it ran under,
/// and, when asked for, the stamp of every Steiner point in insertion order.
pub(crate) struct InOrder {
    pub mesh: Mesh,
    pub report: MeshReport,
    pub bounds: Bounds,
    pub stamps: Vec<Stamp>,
    /// The points put on the rectangle's sides before refinement ([`super::sides`]).
    pub side: Vec<DVec2>,
}

/// Refinement in order of `points`, with the Steiner points' stamps when `stamps` is set.
pub(crate) fn run_in_order(
    points: &[DVec2],
    options: &RefineOptions,
    stamps: bool,
) -> Result<InOrder, Error> {
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
    let (vertex_input, side) = times.time("delaunay", || {
        let vertex_input = insert_in_order(&mut t, points, &morton.order)?;
        let side = side_points(points, domain);
        t.insert_all(side.iter().copied())
            .map_err(Error::resolution_at)?;
        Ok::<_, Error>((vertex_input, side))
    })?;
    let bounds = Bounds::new(options, domain.lo, domain.hi);
    let budget = options.budget(distinct);
    let (finish, stamps) = times.time("refine", || {
        refine_in_order(&mut t, &bounds, budget, stamps)
    })?;
    let unmet = (finish == Finish::OutOfBudget)
        .then(|| Unfinished::at_budget(unmet_triangles(&t, &bounds)));
    let mesh = times.time("mesh", || canonical_mesh(t, vertex_input, domain));
    let quality = times.time("angles", || {
        super::angle_quality(&mesh.vertices, &mesh.triangles)
    });
    let report = report_of(&mesh, distinct, morton.duplicates.count, &quality, times);
    let (mesh, report) = within_budget(mesh, report, unmet, budget)?;
    Ok(InOrder {
        mesh,
        report,
        bounds,
        stamps,
        side,
    })
}

/// The mesh refinement in order makes of `points` in `domain` when it inserts the Steiner
/// points `steiner` (with the points on the sides): their Delaunay triangulation (unique,
/// ties broken as refinement breaks them), numbered as [`refine_points_in_order`] numbers it.
pub(crate) fn canonical_delaunay(
    points: &[DVec2],
    steiner: &[DVec2],
    options: &RefineOptions,
) -> Result<Mesh, Error> {
    let RefineDomain::Rectangle(domain) = options.domain else {
        return Err(Error::InvalidOption {
            option: "domain",
            message: "a dynamic mesh needs a fixed rectangle".into(),
        });
    };
    let morton = checked_order(points, options, &mut StageTimes::default())?;
    let mut t = Triangulation::rectangle(domain.lo, domain.hi);
    t.canonical = true;
    t.reserve(4 + morton.order.len() + steiner.len(), 0);
    let vertex_input = insert_in_order(&mut t, points, &morton.order)?;
    let bounds = Bounds::new(options, domain.lo, domain.hi);
    let mut order: Vec<(u64, DVec2)> = steiner.iter().map(|&p| (place(&bounds, p), p)).collect();
    order.par_sort_unstable_by(|a, b| {
        a.0.cmp(&b.0)
            .then(a.1.x.total_cmp(&b.1.x))
            .then(a.1.y.total_cmp(&b.1.y))
    });
    t.insert_all(order.into_iter().map(|(_, p)| p))
        .map_err(Error::resolution_at)?;
    Ok(canonical_mesh(t, vertex_input, domain))
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

/// A queue key: the first word of [`rank`], then the position's x and y as ordered bits.
pub(crate) type Key = (u64, u64, u64);

/// Why a vertex was inserted: the key of the queue entry fixed, and the point its decision
/// was taken for (the off-center tested, or the midpoint of the edge split).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Cause {
    pub key: Key,
    pub decision: DVec2,
}

/// Whoever runs the loop's steps: it keeps the queue, may refuse a cavity before it is
/// committed (a replay in a window refuses what it cannot trust), and hears of every insertion.
pub(crate) trait Watch {
    /// A step begins on the entry with `key` for the triangle with corners `creator`.
    fn begin(&mut self, _key: Key, _creator: [DVec2; 3]) {}
    /// Queues the entry with `key` for the triangle in `slot` with `corners`, and `edge` (3 for
    /// a bad triangle, else the corner facing the boundary edge to split).
    fn queue(&mut self, t: &Triangulation, key: Key, slot: u32, corners: [u32; 3], edge: u32);
    /// Whether the cavity just dug may be committed.
    fn allows(&mut self, _t: &Triangulation, _cavity: &Cavity) -> bool {
        true
    }
    /// Vertex `v` was inserted for `cause`; the cavity holds the triangles it made.
    fn inserted(&mut self, _t: &Triangulation, _cavity: &Cavity, _v: u32, _cause: &Cause) {}
}

/// An entry of the current round: its generation, then as [`Entry`].
type RoundEntry = Reverse<(u32, u64, u64, u64, u32, u32)>;

/// The plain loop's queue, and, when asked, the cause and time of every insertion.
struct Plain {
    /// Entries of later rounds.
    queue: BinaryHeap<Entry>,
    /// Entries of the current round.
    round: BinaryHeap<RoundEntry>,
    time: Time,
    stamps: Option<Vec<Stamp>>,
    reach: Reach,
}

/// A Steiner point with what a replay needs to tell whether a change near it moves it: its
/// cause and the time of the step that inserted it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Stamp {
    pub at: DVec2,
    pub time: Time,
    pub cause: Cause,
    /// A box around everything the step read: the circumcircles of its triangle, of the
    /// cavities it dug and of the triangles around them.
    pub reach: Reach,
}

/// A box `[lo, hi]` around circles, as `[lo.x, lo.y, hi.x, hi.y]`.
pub(crate) type Reach = [f64; 4];

/// Nothing yet.
pub(crate) const NO_REACH: Reach = [
    f64::INFINITY,
    f64::INFINITY,
    f64::NEG_INFINITY,
    f64::NEG_INFINITY,
];

/// `reach` grown to hold the circle through `c` (with a margin for its centre's rounding);
/// NaN for corners in line, which makes the box hold everything.
pub(crate) fn reach_around(reach: &mut Reach, c: [DVec2; 3]) {
    let (ab, ac) = (c[1] - c[0], c[2] - c[0]);
    let d = 2.0 * ab.perp_dot(ac);
    let (lb, lc) = (ab.length_squared(), ac.length_squared());
    let centre = c[0] + DVec2::new(ac.y * lb - ab.y * lc, ab.x * lc - ac.x * lb) / d;
    let radius = centre
        .distance(c[0])
        .max(centre.distance(c[1]))
        .max(centre.distance(c[2]));
    let r = radius * (1.0 + 1e-9) + 1e-9 * centre.abs().max_element();
    if !r.is_finite() {
        *reach = [
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::INFINITY,
        ];
        return;
    }
    *reach = [
        reach[0].min(centre.x - r),
        reach[1].min(centre.y - r),
        reach[2].max(centre.x + r),
        reach[3].max(centre.y + r),
    ];
}

/// `reach` grown to hold the circumcircles of the cavity just dug and of the triangles
/// beyond its rim.
pub(crate) fn reach_of_cavity(reach: &mut Reach, t: &Triangulation, cavity: &Cavity) {
    let corners = |id: u32| t.corners[id as usize].map(|v| t.point(v));
    for &id in cavity.dug() {
        reach_around(reach, corners(id));
    }
    for e in cavity.rim() {
        if !is_wall(e.outer) {
            reach_around(reach, corners(beyond(e.outer)));
        }
    }
}

/// When a step runs, in the loop's order: the key of the entry that began its round (every
/// entry the round makes with a smaller key is fixed before any other, and the round's
/// entry itself, queued again after splitting the boundary, comes back in a next pass), the
/// pass, and the generation within the round (an entry made by a step of generation g is of
/// g + 1). The loop fixes entries in the order of (time, key), and what it fixes in a round
/// is made by the round: so where a change reaches, a replay can tell when each step ran.
pub(crate) type Time = (Key, u32, u32);

/// The time of an entry with `key` queued by a step at `now`.
pub(crate) fn time_of(now: Time, key: Key) -> Time {
    let (round, pass, generation) = now;
    match key.cmp(&round) {
        std::cmp::Ordering::Less => (round, pass, generation + 1),
        std::cmp::Ordering::Equal => (round, pass + 1, 0),
        std::cmp::Ordering::Greater => (key, 0, 0),
    }
}

impl Watch for Plain {
    fn begin(&mut self, _key: Key, creator: [DVec2; 3]) {
        if self.stamps.is_some() {
            self.reach = NO_REACH;
            reach_around(&mut self.reach, creator);
        }
    }

    fn queue(&mut self, _t: &Triangulation, key: Key, slot: u32, corners: [u32; 3], edge: u32) {
        if key < self.time.0 {
            let stamp = newest(corners) | edge << 30;
            let generation = self.time.2 + 1;
            self.round
                .push(Reverse((generation, key.0, key.1, key.2, slot, stamp)));
        } else {
            self.queue.push(entry(key, slot, corners, edge));
        }
    }

    fn allows(&mut self, t: &Triangulation, cavity: &Cavity) -> bool {
        if self.stamps.is_some() {
            reach_of_cavity(&mut self.reach, t, cavity);
        }
        true
    }

    fn inserted(&mut self, t: &Triangulation, _cavity: &Cavity, v: u32, cause: &Cause) {
        if let Some(stamps) = &mut self.stamps {
            stamps.push(Stamp {
                at: t.vertices[v as usize],
                time: self.time,
                cause: *cause,
                reach: self.reach,
            });
        }
    }
}

/// Refines `t` one insertion at a time in the order the module gives, until nothing is bad,
/// or past `budget` vertices; with `stamps`, returns every insertion's stamp in order.
fn refine_in_order(
    t: &mut Triangulation,
    bounds: &Bounds,
    budget: usize,
    stamps: bool,
) -> Result<(Finish, Vec<Stamp>), Error> {
    let mut plain = Plain {
        queue: BinaryHeap::new(),
        round: BinaryHeap::new(),
        time: ((0, 0, 0), 0, 0),
        stamps: stamps.then(Vec::new),
        reach: NO_REACH,
    };
    if bounds.unbounded() {
        return Ok((Finish::Done, Vec::new()));
    }
    for id in 0..t.len() as u32 {
        queue_triangle(t, bounds, id, &mut plain);
    }
    let mut cavity = Cavity::default();
    loop {
        let (generation, key, slot, stamp) = match plain.round.pop() {
            Some(Reverse((g, k0, k1, k2, slot, stamp))) => (Some(g), (k0, k1, k2), slot, stamp),
            None => match plain.queue.pop() {
                Some(Reverse((k0, k1, k2, slot, stamp))) => (None, (k0, k1, k2), slot, stamp),
                None => break,
            },
        };
        if newest(t.corners[slot as usize]) != stamp & ((1 << 30) - 1) {
            continue;
        }
        if t.vertices.len() > budget {
            return Ok((Finish::OutOfBudget, plain.stamps.unwrap_or_default()));
        }
        plain.time = match generation {
            Some(g) => (plain.time.0, plain.time.1, g),
            None => time_of(plain.time, key),
        };
        step(t, bounds, &mut cavity, slot, stamp >> 30, key, &mut plain)?;
    }
    Ok((Finish::Done, plain.stamps.unwrap_or_default()))
}

/// Fixes the live entry for the triangle in `slot` with `key`: splits the boundary edge facing
/// corner `edge`, or, for 3, fixes the bad triangle.
pub(crate) fn step<W: Watch>(
    t: &mut Triangulation,
    bounds: &Bounds,
    cavity: &mut Cavity,
    slot: u32,
    edge: u32,
    key: Key,
    watch: &mut W,
) -> Result<(), Error> {
    watch.begin(key, t.corners[slot as usize].map(|v| t.point(v)));
    if edge < 3 {
        split(t, bounds, cavity, slot, edge as usize, None, key, watch).map(|_| ())
    } else {
        fix(t, bounds, cavity, slot, key, watch)
    }
}

/// Turns triangle `id` to start at its least corner (so that its key and Steiner point depend
/// on it alone) and queues it if it is bad, and the boundary edges its corners encroach on.
pub(crate) fn queue_triangle<W: Watch>(
    t: &mut Triangulation,
    bounds: &Bounds,
    id: u32,
    watch: &mut W,
) {
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
            watch.queue(t, key, id, tri.v, i as u32);
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
        watch.queue(t, key, id, tri.v, 3);
    }
}

/// Splits the boundary edge opposite corner `edge` of triangle `slot` at its midpoint, for
/// the entry with `key` that decided on `decision` (the midpoint itself where none is given).
/// Returns whether the watch let it happen.
#[allow(clippy::too_many_arguments)]
fn split<W: Watch>(
    t: &mut Triangulation,
    bounds: &Bounds,
    cavity: &mut Cavity,
    slot: u32,
    edge: usize,
    decision: Option<DVec2>,
    key: Key,
    watch: &mut W,
) -> Result<bool, Error> {
    let (a, b) = t.triangle(slot).edge(edge);
    let m = split_point(t.point(a), t.point(b), (false, false))?;
    cavity.dig(t, m, slot);
    if !watch.allows(t, cavity) {
        cavity.abandon(t);
        return Ok(false);
    }
    let v = cavity.commit(t, m, None);
    let cause = Cause {
        key,
        decision: decision.unwrap_or(m),
    };
    watch.inserted(t, cavity, v, &cause);
    queue_created(t, bounds, cavity, watch);
    Ok(true)
}

/// Inserts the Steiner point of bad triangle `slot`, or, where it would lie beyond the
/// boundary or encroach on boundary edges, splits the first of those edges in (x, y) order
/// of their midpoints and queues the triangle again.
fn fix<W: Watch>(
    t: &mut Triangulation,
    bounds: &Bounds,
    cavity: &mut Cavity,
    slot: u32,
    key: Key,
    watch: &mut W,
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
            if !watch.allows(t, cavity) {
                cavity.abandon(t);
                return Ok(());
            }
            match first {
                None => {
                    let v = cavity.commit(t, p, None);
                    let cause = Cause { key, decision: p };
                    watch.inserted(t, cavity, v, &cause);
                    queue_created(t, bounds, cavity, watch);
                    return Ok(());
                }
                Some((_, triangle, edge)) => {
                    cavity.abandon(t);
                    (triangle, edge)
                }
            }
        }
        Location::Vertex(_) | Location::Foreign => {
            return Err(Error::resolution_at(p));
        }
    };
    let corners = t.corners[slot as usize];
    let split = split(t, bounds, cavity, wall.0, wall.1, Some(p), key, watch)?;
    if split && t.corners[slot as usize] == corners {
        queue_triangle(t, bounds, slot, watch);
    }
    Ok(())
}

/// Queues what the last insertion made.
fn queue_created<W: Watch>(t: &mut Triangulation, bounds: &Bounds, cavity: &Cavity, watch: &mut W) {
    for &id in cavity.created() {
        queue_triangle(t, bounds, id, watch);
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
