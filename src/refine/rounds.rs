//! Off-center refinement in rounds, whose Steiner points depend only on the input near them.
//!
//! The loop of [`super::refiner`] fixes bad triangles one at a time in a global order (size
//! classes, then tiles and Morton order across the whole domain), so where a Steiner point
//! lands depends on work done far away. Here every round looks at the Delaunay triangulation
//! as it stands and, for each bad triangle, proposes its Steiner point (the off-center, or the
//! midpoint of a boundary edge it would encroach on) with the point's insertion radius, its
//! distance to the nearest vertex. Proposals are ordered: boundary splits and triangles with
//! an angle below about 14.5° first, then by the bad triangle's shortest edge (Har-Peled and
//! Üngör's order), then by position. A proposal is taken unless a smaller one conflicts with
//! it: its cavity holds a triangle that asked for it, or one lies within the other's insertion
//! radius. The proposals taken are inserted, smallest first, and the next round looks again.
//!
//! Cocircular points are told apart by a symbolic perturbation
//! ([`super::delaunay::perturbed_inside`]), so each round's triangulation is the Delaunay
//! triangulation of its points, whatever the order they came in; each proposal, and whether it
//! is taken, is decided by the triangles and proposals around it. So the mesh is a function of
//! the points and the domain alone, and a change of the input changes Steiner points only as
//! far as its effect spreads from round to round: what a dynamic mesh needs.

use glam::DVec2;
use rayon::prelude::*;

use super::delaunay::{
    Cavity, Location, NEXT, PREV, Store, Triangulation, beyond, in_circumcircle,
};
use super::delaunay::{is_wall, locate};
use super::refiner::{Bounds, Finish, badness, encroaches, steiner_point};
use super::{
    MIN_GAP, RefineDomain, RefineOptions, boundary_edges, check_gaps, check_scale, insert_in_order,
    square_around, unmet_triangles, within_budget,
};
use crate::error::Error;
use crate::mesh::{Domain, Mesh, MeshReport, NONE, StageTimes, report_of};
use crate::morton::float_morton_order;

/// The refined Delaunay mesh of `points` in a rectangle, made in rounds as the module says,
/// with its report. Where points lie along curves, a round can take only the few proposals
/// that no huge circumcircle of the first triangulation joins: a thousand points on a
/// parabola take 0.8 s, against 6 ms for [`super::refine_points`]. The same points give the same mesh, byte for byte, in any order and on
/// any number of threads: the input points are numbered in input order after the rectangle's
/// corners, then the Steiner points in (x, y) order; triangles start at their smallest vertex
/// and are sorted.
///
/// # Errors
/// As [`super::refine_points`]; [`Error::InvalidOption`] for the convex hull as the domain.
pub fn refine_points_in_rounds(
    points: &[DVec2],
    options: &RefineOptions,
) -> Result<(Mesh, MeshReport), Error> {
    options.check()?;
    let mut times = StageTimes::default();
    let morton = times.time("morton", || float_morton_order(points))?;
    check_scale(points)?;
    check_gaps(points, &morton.order)?;
    let domain = match options.domain {
        RefineDomain::Rectangle(d) => {
            d.check_holds(points)?;
            d
        }
        RefineDomain::Square => square_around(points),
        RefineDomain::ConvexHull => {
            return Err(Error::InvalidOption {
                option: "domain",
                message: "refinement in rounds meshes a rectangle, not the convex hull".into(),
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
    let finish = times.time("refine", || refine_in_rounds(&mut t, &bounds, budget))?;
    let unmet = (finish == Finish::OutOfBudget).then(|| unmet_triangles(&t, &bounds));
    let mesh = times.time("mesh", || canonical_mesh(t, vertex_input, domain));
    let quality = times.time("angles", || {
        super::angle_quality(&mesh.vertices, &mesh.triangles)
    });
    let report = report_of(&mesh, distinct, morton.duplicates.count, &quality, times);
    within_budget(mesh, report, unmet, budget)
}

/// A Steiner point a round may insert.
#[derive(Clone, Copy, Debug)]
struct Proposal {
    /// Its distance to the nearest vertex.
    radius: f64,
    /// What orders proposals: the shortest edge of the bad triangle, or half the boundary
    /// edge a split halves.
    size: f64,
    /// Whether it splits a boundary edge or fixes a very thin triangle (see [`very_thin`]):
    /// those go first.
    urgent: bool,
    at: DVec2,
    /// The triangle it lies in (on its boundary edge, for a split).
    located: u32,
    /// Whether it splits a boundary edge.
    split: bool,
}

impl Proposal {
    /// Urgent ones first, then smaller sizes, then (x, y): a total order on distinct points.
    fn cmp(&self, other: &Proposal) -> std::cmp::Ordering {
        other
            .urgent
            .cmp(&self.urgent)
            .then(self.size.total_cmp(&other.size))
            .then(self.at.x.total_cmp(&other.at.x))
            .then(self.at.y.total_cmp(&other.at.y))
    }
}

/// A proposal with the triangles its insertion would replace.
struct Reached {
    proposal: Proposal,
    cavity: Vec<u32>,
}

/// A round's proposals, smallest first, and the triangles that asked for them: (triangle,
/// proposal) pairs in triangle order.
struct Round {
    reached: Vec<Reached>,
    asked: Vec<(u32, u32)>,
}

/// Refines `t` in rounds until no triangle is bad, or past `budget` vertices.
fn refine_in_rounds(
    t: &mut Triangulation,
    bounds: &Bounds,
    budget: usize,
) -> Result<Finish, Error> {
    if bounds.unbounded() {
        return Ok(Finish::Done);
    }
    let mut candidates: Vec<u32> = (0..t.len() as u32).collect();
    let mut cavity = Cavity::default();
    let mut slots = [SlotIndex::default(), SlotIndex::default()];
    loop {
        candidates.par_sort_unstable();
        candidates.dedup();
        turn_to_least_corner(t, &candidates);
        let Round { reached, asked } = proposals(t, bounds, &candidates)?;
        if reached.is_empty() {
            return Ok(Finish::Done);
        }
        let taken = untouched_by_smaller(t, &reached, &asked, &mut slots);
        // Every bad triangle left asked for a proposal this round or is new: the next round
        // looks at those only.
        candidates.clear();
        candidates.extend(asked.iter().map(|&(triangle, _)| triangle));
        for (r, _) in reached.iter().zip(&taken).filter(|(_, taken)| **taken) {
            if t.vertices.len() > budget {
                return Ok(Finish::OutOfBudget);
            }
            if insert(t, bounds, &mut cavity, &r.proposal)? {
                candidates.extend_from_slice(cavity.created());
            }
        }
    }
}

/// Inserts a proposal taken this round, unless an off-center now lies in the lens of a
/// boundary edge that an earlier insertion of the round made: it then waits for the next.
/// Returns whether it was inserted.
fn insert(
    t: &mut Triangulation,
    bounds: &Bounds,
    cavity: &mut Cavity,
    proposal: &Proposal,
) -> Result<bool, Error> {
    let at = proposal.at;
    let Location::Inside(start) = locate(t, at, proposal.located) else {
        return Err(Error::RefinementResolution { x: at.x, y: at.y });
    };
    cavity.dig(t, at, start);
    let encroaching = !proposal.split
        && cavity.rim().iter().any(|e| {
            is_wall(e.outer) && bounds.splits(e.outer) && encroaches(t, bounds, at, (e.a, e.b))
        });
    if encroaching {
        cavity.abandon(t);
        return Ok(false);
    }
    cavity.commit(t, at, None);
    Ok(true)
}

/// The proposals of the bad triangles among `candidates` (and of the boundary edges their
/// corners encroach on), each once, smallest first.
fn proposals(t: &Triangulation, bounds: &Bounds, candidates: &[u32]) -> Result<Round, Error> {
    let found: Vec<(u32, Result<Vec<Reached>, Error>)> = candidates
        .par_iter()
        .map(|&id| (id, proposals_of(t, bounds, id)))
        .collect();
    let mut all: Vec<(Reached, u32)> = Vec::new();
    for (id, f) in found {
        all.extend(f?.into_iter().map(|r| (r, id)));
    }
    all.par_sort_unstable_by(|a, b| a.0.proposal.cmp(&b.0.proposal).then(a.1.cmp(&b.1)));
    let mut reached: Vec<Reached> = Vec::with_capacity(all.len());
    let mut asked = Vec::with_capacity(all.len());
    for (r, id) in all {
        if reached
            .last()
            .is_none_or(|last| last.proposal.at != r.proposal.at)
        {
            reached.push(r);
        }
        asked.push((id, reached.len() as u32 - 1));
    }
    asked.par_sort_unstable();
    Ok(Round { reached, asked })
}

/// What triangle `id` asks for: the splits of boundary edges its corners encroach on, and, if
/// it is bad, its off-center or, where that would encroach on boundary edges or lie beyond
/// one, their splits.
fn proposals_of(t: &Triangulation, bounds: &Bounds, id: u32) -> Result<Vec<Reached>, Error> {
    let mut out = Vec::new();
    let tri = t.triangle(id);
    for i in 0..3 {
        let (a, b) = tri.edge(i);
        if is_wall(tri.n[i])
            && bounds.splits(tri.n[i])
            && encroaches(t, bounds, t.point(tri.v[i]), (a, b))
        {
            out.push(split_of(t, bounds, id, i)?);
        }
    }
    let Some((corner, shortest2)) = badness(t, bounds, id) else {
        return Ok(out);
    };
    let p = steiner_point(t, bounds, id, corner);
    if !p.is_finite() || shortest2 < MIN_GAP * MIN_GAP {
        let c = tri.v.map(|v| t.point(v));
        let at = (c[0] + c[1] + c[2]) / 3.0;
        return Err(Error::RefinementResolution { x: at.x, y: at.y });
    }
    match locate(t, p, id) {
        Location::Outside { triangle, edge } => {
            if bounds.splits(t.across[triangle as usize][edge]) {
                out.push(split_of(t, bounds, triangle, edge)?);
            }
        }
        Location::Inside(located) => {
            let (mut reached, walls) = reach(t, bounds, p, located);
            reached.proposal.size = shortest2.sqrt();
            reached.proposal.urgent = very_thin(tri.v.map(|v| t.point(v)), corner);
            if walls.is_empty() {
                out.push(reached);
            }
            for (triangle, edge) in walls {
                out.push(split_of(t, bounds, triangle, edge)?);
            }
        }
        Location::Vertex(_) | Location::Foreign => {
            return Err(Error::RefinementResolution { x: p.x, y: p.y });
        }
    }
    Ok(out)
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

/// Turns each candidate triangle to start at its least corner in (x, y) order, so that what
/// is computed from its corners in turn (its shortest edge among equal ones, its
/// circumcenter's rounding) depends on the triangle alone, not on how insertions left it.
fn turn_to_least_corner(t: &mut Triangulation, candidates: &[u32]) {
    for &id in candidates {
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
}

/// The split of the boundary edge opposite corner `edge` of `triangle` at its midpoint, which
/// keeps an axis-parallel side's coordinate bit for bit.
fn split_of(
    t: &Triangulation,
    bounds: &Bounds,
    triangle: u32,
    edge: usize,
) -> Result<Reached, Error> {
    let (a, b) = t.triangle(triangle).edge(edge);
    let (pa, pb) = (t.point(a), t.point(b));
    let mut m = pa * 0.5 + pb * 0.5;
    if pa.x == pb.x {
        m.x = pa.x;
    } else if pa.y == pb.y {
        m.y = pa.y;
    }
    if m == pa || m == pb || m.distance(pa).min(m.distance(pb)) < MIN_GAP {
        return Err(Error::RefinementResolution { x: m.x, y: m.y });
    }
    let (mut reached, _) = reach(t, bounds, m, triangle);
    reached.proposal.split = true;
    reached.proposal.urgent = true;
    reached.proposal.size = pa.distance(pb) / 2.0;
    Ok(reached)
}

/// The cavity of `p` (in triangle `start`), its distance to the nearest vertex (one of the
/// cavity's rim), and the boundary edges of the rim it encroaches on.
fn reach(t: &Triangulation, bounds: &Bounds, p: DVec2, start: u32) -> (Reached, Vec<(u32, usize)>) {
    let mut cavity = vec![start];
    let mut walls = Vec::new();
    let mut nearest2 = f64::INFINITY;
    let mut k = 0;
    while k < cavity.len() {
        let c = cavity[k];
        k += 1;
        let tri = t.triangle(c);
        for i in 0..3 {
            let (a, b) = tri.edge(i);
            let o = tri.n[i];
            if !is_wall(o) {
                let o = beyond(o);
                if cavity.contains(&o) {
                    continue;
                }
                if in_circumcircle(t, o, p) {
                    cavity.push(o);
                    continue;
                }
            } else if bounds.splits(o) && encroaches(t, bounds, p, (a, b)) {
                walls.push((c, i));
            }
            nearest2 = nearest2
                .min(p.distance_squared(t.point(a)))
                .min(p.distance_squared(t.point(b)));
        }
    }
    let proposal = Proposal {
        radius: nearest2.sqrt(),
        size: nearest2.sqrt(),
        urgent: false,
        at: p,
        located: start,
        split: false,
    };
    (Reached { proposal, cavity }, walls)
}

/// Which of the proposals (sorted, smallest first) no smaller one conflicts with: none would
/// replace a triangle that asked for it, and none lies within the larger radius of the two.
/// So each proposal taken is the one a smallest-first loop would insert next around it.
fn untouched_by_smaller(
    t: &Triangulation,
    reached: &[Reached],
    asked: &[(u32, u32)],
    slots: &mut [SlotIndex; 2],
) -> Vec<bool> {
    let mut located: Vec<(u32, u32)> = reached
        .iter()
        .enumerate()
        .map(|(i, r)| (r.proposal.located, i as u32))
        .collect();
    located.par_sort_unstable();
    let [asked_by, located_in] = slots;
    asked_by.index(asked, t.len());
    located_in.index(&located, t.len());
    let (asked_by, located_in) = (&*asked_by, &*located_in);
    let blocked: Vec<u32> = (0..reached.len())
        .into_par_iter()
        .flat_map_iter(|i| {
            let replaced = reached[i].cavity.iter().flat_map(move |&c| {
                asked_by
                    .pairs(asked, c)
                    .iter()
                    .map(|&(_, j)| j)
                    .filter(move |&j| j as usize > i)
            });
            replaced.chain(within_radius(t, reached, (&located, located_in), i))
        })
        .collect();
    slots[0].clear(asked);
    slots[1].clear(&located);
    let mut taken = vec![true; reached.len()];
    for i in blocked {
        taken[i as usize] = false;
    }
    taken
}

/// For (triangle, proposal) pairs sorted by triangle, where each triangle's pairs start: one
/// entry per triangle slot, kept between rounds and cleared after each.
#[derive(Default)]
struct SlotIndex {
    first: Vec<u32>,
}

impl SlotIndex {
    fn index(&mut self, pairs: &[(u32, u32)], slots: usize) {
        if self.first.len() < slots {
            self.first.resize(slots, NONE);
        }
        for (k, &(c, _)) in pairs.iter().enumerate().rev() {
            self.first[c as usize] = k as u32;
        }
    }

    fn clear(&mut self, pairs: &[(u32, u32)]) {
        for &(c, _) in pairs {
            self.first[c as usize] = NONE;
        }
    }

    /// The pairs of triangle `c`.
    fn pairs<'p>(&self, pairs: &'p [(u32, u32)], c: u32) -> &'p [(u32, u32)] {
        let first = self.first[c as usize];
        if first == NONE {
            return &[];
        }
        let first = first as usize;
        let len = pairs[first..]
            .iter()
            .take_while(|&&(tri, _)| tri == c)
            .count();
        &pairs[first..first + len]
    }
}

/// The larger of each pair of proposal `i` and a proposal within its radius of it, found by
/// walking the triangles that meet the open disk of that radius.
fn within_radius(
    t: &Triangulation,
    reached: &[Reached],
    (located, index): (&[(u32, u32)], &SlotIndex),
    i: usize,
) -> Vec<u32> {
    let p = reached[i].proposal;
    let r2 = p.radius * p.radius;
    let mut seen = vec![p.located];
    let mut out = Vec::new();
    let mut k = 0;
    while k < seen.len() {
        let c = seen[k];
        k += 1;
        for &(_, j) in index.pairs(located, c) {
            if j as usize != i && reached[j as usize].proposal.at.distance_squared(p.at) < r2 {
                out.push(j.max(i as u32));
            }
        }
        let tri = t.triangle(c);
        for e in 0..3 {
            let o = tri.n[e];
            if is_wall(o) || seen.contains(&beyond(o)) {
                continue;
            }
            let (a, b) = tri.edge(e);
            if distance2_to_segment(p.at, t.point(a), t.point(b)) < r2 {
                seen.push(beyond(o));
            }
        }
    }
    out
}

fn distance2_to_segment(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    let d = b - a;
    let s = ((p - a).dot(d) / d.length_squared()).clamp(0.0, 1.0);
    p.distance_squared(a + d * s)
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
