//! A mesh coarsened by collapsing edges while every new triangle keeps the angle bounds.
//!
//! The warp puts a leaf's worth of triangles wherever the tree has a leaf, and 2:1 balance fills
//! the space between the points with leaves two levels finer than their spacing asks; the
//! templates' angles leave room to spare. A vertex that is no input point, on no segment and
//! not at a bend of the boundary may go: each of its edges is a candidate, the shortest first,
//! and the vertex collapses onto the other end of the first edge whose collapse leaves every
//! new triangle counter-clockwise (the exact test) with every angle within the bounds. Its star
//! is then a fan from that end, the same polygon: triangles keep their region, segments and the
//! boundary's shape stay. A vertex on the boundary collapses only along it, onto a neighbour on
//! the same straight line. A vertex inside one segment's chain of pieces (where two of its
//! pieces meet, and nothing else holds it) collapses only along the chain, onto the next
//! vertex either way: its two pieces become one edge of the fan, and the chain's other
//! vertices, each within rounding of the segment's line, stay ([`Rails`]).
//!
//! Most collapses happen inside chunks of the vertices, one chunk a task, each collapsing
//! greedily in a copy of the triangles it owns ([`chunks`]): first chunks of consecutive
//! vertices (in the mesh's numbering, or in Morton order where that numbering scatters them),
//! then chunks in a Morton order on a grid shifted off the first, for the vertices the first
//! left at their chunks' edges. The few left after both go in rounds: every vertex that may go
//! finds its edge and claims the triangles the collapse changes (its star, and the two beyond
//! the triangles it removes); it goes when its lot is the highest on every triangle it claims,
//! so that the collapses of one round change disjoint triangles and each finds its star as it
//! planned. The chunks are fixed and lots are hashes of the vertex and the round: the result is
//! the same on any thread count. The triangles that survive keep their order, and so do the
//! vertices.

mod chunks;

use std::sync::atomic::{AtomicU32, Ordering};

use glam::DVec2;
use rayon::prelude::*;

use crate::domain::{BoundaryEdge, SubSegment};
use crate::mesh::{
    Mesh, NONE, Star, corner_cosines, corner_sides, largest_coordinate, rounding_turn,
};
use crate::predicates::{Orientation, orientation};
use chunks::{Chunking, collapse_in_chunks};

/// The angle bounds the default warp coarsens to, in degrees.
pub const COARSE_ANGLE_BOUNDS: (f64, f64) = (20.0, 120.0);

/// The angle bounds the nonobtuse mesh coarsens to, in degrees: no new angle over 90° (up to
/// the rounding of the grid's vertices, as [`crate::mesh::validate_nonobtuse`] allows) nor
/// under 20°. The split's own thin triangles at points near its grid lines may stay.
pub const NONOBTUSE_COARSE_BOUNDS: (f64, f64) = (20.0, 90.0);

/// Vertices per chunk in the passes before the rounds: a fixed number, so that the result is
/// the same on any thread count; large, since a chunk's edges are left to the rounds.
const CHUNK_VERTICES: usize = 1 << 14;

/// The most rounds of collapses.
const MAX_ROUNDS: usize = 96;

/// How far inside the bounds, in cosine, a new angle must be: more than f64's error in a
/// cosine, so that the angles measured afterwards keep the bounds.
const COSINE_MARGIN: f64 = 1e-12;

/// The most, in radians, that a new angle may pass 90° in a nonobtuse coarsening, however much
/// rounding the grid's vertices could explain: the grid's right angles, rounded, pass it by far
/// less (about 2e-8 deep in a cluster), and the rounding bound, loose where leaves are small
/// beside the domain's largest coordinate (18° for leaves a millimetre wide in a domain 1.5e11
/// across), must not let truly obtuse angles in.
const PAST_RIGHT_MAX: f64 = 1e-7;

/// What the coarsening did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Coarsened {
    /// Vertices collapsed.
    pub collapses: usize,
    /// Rounds run.
    pub rounds: usize,
}

/// Coarsens `mesh` (see the module's description): every triangle made has its angles within
/// `bounds` (degrees, smallest and largest); the triangles that stay are not measured. Input
/// points, the ends of segments and where segments meet, and the boundary's bends stay, with
/// the mesh's domain, outline and regions; each segment keeps a chain of pieces from end to
/// end, fewer of them where vertices inside it went along it.
pub fn coarsen(mesh: &mut Mesh, bounds: (f64, f64)) -> Coarsened {
    coarsen_in_chunks_of(mesh, bounds, CHUNK_VERTICES)
}

/// [`coarsen`] with chunks of `chunk_vertices` vertices in its first passes.
fn coarsen_in_chunks_of(mesh: &mut Mesh, bounds: (f64, f64), chunk_vertices: usize) -> Coarsened {
    let limits = Limits::of(bounds, mesh);
    let held = held_vertices(mesh);
    let rails = Rails::of(mesh, &held);
    let fixed = fixed_vertices(mesh, held, &rails);
    let mut corner = corners_of(mesh);
    let mut pending = vec![true; mesh.vertices.len()];
    let mut collapses = 0;
    let mut left = Vec::new();
    // One chunk leaves no vertex at an edge: the second pass is for many.
    let passes = if mesh.vertices.len() > chunk_vertices {
        2
    } else {
        1
    };
    for pass in 0..passes {
        let chunking = match pass {
            0 => first_chunking(mesh, chunk_vertices),
            _ => Chunking::morton(chunk_vertices, &mesh.vertices, 1.0 / 3.0),
        };
        let done = collapse_in_chunks(
            mesh,
            &chunking,
            (&fixed, &rails),
            &mut corner,
            limits,
            &pending,
        );
        collapses += done.collapses;
        pending.fill(false);
        for &v in &done.left {
            pending[v as usize] = true;
        }
        left = done.left;
    }
    let mut touched = left;
    let mut waiting: Vec<Plan> = Vec::new();
    // Per triangle, the highest lot of the round's collapses that touch it (0: none).
    let claims: Vec<AtomicU32> = (0..mesh.triangles.len())
        .map(|_| AtomicU32::new(0))
        .collect();
    // Per vertex, the round in which a collapse last changed its star.
    let mut changed = vec![0usize; mesh.vertices.len()];
    let mut coarsened = Coarsened {
        collapses,
        rounds: 0,
    };
    while coarsened.rounds < MAX_ROUNDS {
        coarsened.rounds += 1;
        let round = coarsened.rounds;
        // The waiting plans stand while their stars stand; the changed stars plan afresh.
        let fresh: Vec<Plan> = touched
            .par_iter()
            .filter(|&&v| !fixed[v as usize] && corner[v as usize] != NONE)
            .map_init(Scratch::default, |scratch, &v| {
                let along = |a: u32, b: u32| rails.admits(a, b);
                Plan::of(mesh, v, corner[v as usize], (limits, &along), scratch)
            })
            .flatten_iter()
            .collect();
        waiting.retain(|plan| changed[plan.centre as usize] + 1 != round);
        let mut plans = merge_by_centre(waiting, fresh);
        if plans.is_empty() {
            break;
        }
        plans
            .par_iter_mut()
            .for_each(|plan| plan.lot = lot(plan.centre, round));
        let goes = independent(&plans, &claims);
        touched = Vec::new();
        waiting = Vec::with_capacity(plans.len());
        for (plan, go) in plans.into_iter().zip(goes) {
            if !go {
                waiting.push(plan);
                continue;
            }
            plan.collapse(mesh, &mut corner);
            coarsened.collapses += 1;
            // Every vertex whose star changed: those of the triangles it changed.
            for &t in &plan.claims {
                touched.extend(mesh.triangles[t as usize]);
            }
        }
        touched.retain(|&v| v != NONE);
        for &v in &touched {
            changed[v as usize] = round;
        }
        touched.par_sort_unstable();
        touched.dedup();
        if touched.is_empty() && waiting.is_empty() {
            break;
        }
    }
    compact(mesh, &corner);
    coarsened
}

/// The share of triangles inside a chunk of consecutive indices above which the first pass
/// keeps the mesh's numbering: the warp's, in Morton order, leaves about 4 % of them at the
/// chunks' edges; the nonobtuse split's about a quarter.
const NUMBERING_HOLDS: f64 = 0.9;

/// The first pass's chunks: runs of consecutive indices where the numbering keeps them patches
/// of the plane (no sort, and the greedy order of the warp), else runs in a Morton order.
fn first_chunking(mesh: &Mesh, chunk_vertices: usize) -> Chunking {
    let by_index = Chunking::by_index(chunk_vertices);
    match by_index.holds(&mesh.triangles, NUMBERING_HOLDS) {
        true => by_index,
        false => Chunking::morton(chunk_vertices, &mesh.vertices, 0.0),
    }
}

/// Marks a triangle a collapse of the round has taken.
const TAKEN: u32 = u32::MAX;

/// Which plans go this round: a maximal set of plans claiming disjoint triangles, found in
/// steps. In each, every plan still open claims its triangles with its lot; those holding all
/// of them go and take them; the plans that claim a taken triangle close. `claims` is all 0
/// before and after.
fn independent(plans: &[Plan], claims: &[AtomicU32]) -> Vec<bool> {
    let mut goes = vec![false; plans.len()];
    let mut open: Vec<usize> = (0..plans.len()).collect();
    let claim = |i: usize, value: u32| {
        for &t in &plans[i].claims {
            claims[t as usize].store(value, Ordering::Relaxed);
        }
    };
    while !open.is_empty() {
        open.par_iter().for_each(|&i| {
            for &t in &plans[i].claims {
                claims[t as usize].fetch_max(plans[i].lot, Ordering::Relaxed);
            }
        });
        let won: Vec<usize> = open
            .par_iter()
            .copied()
            .filter(|&i| {
                let plan = &plans[i];
                (plan.claims.iter())
                    .all(|&t| claims[t as usize].load(Ordering::Relaxed) == plan.lot)
            })
            .collect();
        open.par_iter().for_each(|&i| claim(i, 0));
        won.par_iter().for_each(|&i| claim(i, TAKEN));
        for &i in &won {
            goes[i] = true;
        }
        open.retain(|&i| !goes[i]);
        open = open
            .into_par_iter()
            .filter(|&i| {
                let free = |&t: &u32| claims[t as usize].load(Ordering::Relaxed) != TAKEN;
                plans[i].claims.iter().all(free)
            })
            .collect();
    }
    (0..plans.len())
        .into_par_iter()
        .filter(|&i| goes[i])
        .for_each(|i| claim(i, 0));
    goes
}

/// The plans of `a` and `b` in one list by centre (each sorted by centre, none in both).
fn merge_by_centre(a: Vec<Plan>, b: Vec<Plan>) -> Vec<Plan> {
    let mut merged = Vec::with_capacity(a.len() + b.len());
    let (mut a, mut b) = (a.into_iter().peekable(), b.into_iter().peekable());
    loop {
        let take_a = match (a.peek(), b.peek()) {
            (Some(x), Some(y)) => x.centre < y.centre,
            (Some(_), None) => true,
            (None, Some(_)) => false,
            (None, None) => return merged,
        };
        merged.extend(if take_a { a.next() } else { b.next() });
    }
}

/// The cosines a new angle must lie between; a largest angle of exactly 90° is tested as the
/// nonobtuse check does.
#[derive(Clone, Copy, Debug)]
struct Limits {
    narrowest: f64,
    widest: f64,
    /// For a largest angle of 90°, [`rounding_turn`] of the domain: angles up to 90° pass, and
    /// past it by what rounding the grid's vertices explains (that over the triangle's
    /// shortest edge, in radians, the figure the nonobtuse check allows) up to
    /// [`PAST_RIGHT_MAX`]. The grid's right angles are right only before their corners are
    /// rounded to f64.
    rounding_turn: Option<f64>,
}

impl Limits {
    fn of((smallest, largest): (f64, f64), mesh: &Mesh) -> Limits {
        let nonobtuse = largest == 90.0;
        Limits {
            narrowest: smallest.to_radians().cos() - COSINE_MARGIN,
            // A cosine of -1 bounds nothing: the test of right angles does.
            widest: match nonobtuse {
                true => -1.0,
                false => largest.to_radians().cos() + COSINE_MARGIN,
            },
            rounding_turn: nonobtuse.then(|| rounding_turn(largest_coordinate(&mesh.domain))),
        }
    }

    /// Whether the triangle `a, b, c` is counter-clockwise with every angle within the limits.
    fn admit(self, a: DVec2, b: DVec2, c: DVec2) -> bool {
        let sides = corner_sides(a, b, c);
        let mut shortest_squared = None;
        // The angles first: they refuse most candidates.
        for (u, v) in sides {
            let (dot, cross) = (u.dot(v), u.perp_dot(v));
            let norm = dot * dot + cross * cross;
            if !norm.is_normal() {
                // Out of f64's normal range (or NaN) the cosines decide, scaled.
                return self.admit_by_cosines(a, b, c);
            }
            if !self.admit_cosine(dot, norm) {
                return false;
            }
            let Some(turn) = self.rounding_turn.filter(|_| dot < 0.0) else {
                continue;
            };
            // An angle 90° + δ has the cosine −sin δ, and δ may be `turn / shortest` up to
            // PAST_RIGHT_MAX; there sin δ and δ differ by far less than the check's slack.
            // Squared: dot² ≤ δ² · norm.
            // Each corner's first side is one edge, once.
            let shortest = *shortest_squared.get_or_insert_with(|| {
                sides
                    .iter()
                    .map(|(u, _)| u.length_squared())
                    .fold(f64::INFINITY, f64::min)
            });
            let past_squared = (turn * turn / shortest).min(PAST_RIGHT_MAX * PAST_RIGHT_MAX);
            let (past, allowed) = (dot * dot, past_squared * norm);
            if !(past.is_normal() && allowed.is_normal()) {
                return self.admit_by_cosines(a, b, c);
            }
            if past > allowed {
                return false;
            }
        }
        orientation(a, b, c) == Orientation::Left
    }

    /// Whether the angle whose sides have dot product `dot` and `dot² + cross² = norm` has its
    /// cosine, `dot / √norm`, within the limits: compared squared, with no root taken.
    #[inline]
    fn admit_cosine(self, dot: f64, norm: f64) -> bool {
        let square = dot * dot;
        let below = |limit: f64| match limit >= 0.0 {
            true => dot <= 0.0 || square <= limit * limit * norm,
            false => dot < 0.0 && square >= limit * limit * norm,
        };
        let above = |limit: f64| match limit <= 0.0 {
            true => dot >= 0.0 || square <= limit * limit * norm,
            false => dot > 0.0 && square >= limit * limit * norm,
        };
        below(self.narrowest) && above(self.widest)
    }

    /// [`Limits::admit`] by the cosines themselves, which scale sides whose products leave
    /// f64's range.
    fn admit_by_cosines(self, a: DVec2, b: DVec2, c: DVec2) -> bool {
        // A NaN refuses.
        let shortest = a.distance(b).min(b.distance(c)).min(c.distance(a));
        let past_right = |cos: f64| {
            self.rounding_turn
                .is_some_and(|turn| cos < -(turn / shortest).min(PAST_RIGHT_MAX))
        };
        corner_cosines(a, b, c)
            .iter()
            .all(|&cos| cos <= self.narrowest && cos >= self.widest && !past_right(cos))
            && orientation(a, b, c) == Orientation::Left
    }
}

/// Per vertex, whether it must stay: one `held` ([`held_vertices`]), or a vertex of a
/// segment's pieces that does not lie on a rail (see [`Rails`]).
fn fixed_vertices(mesh: &Mesh, held: Vec<bool>, rails: &Rails) -> Vec<bool> {
    let mut fixed = held;
    for piece in &mesh.segments {
        for v in piece.vertices {
            if rails.segment_at(v) == NONE {
                fixed[v as usize] = true;
            }
        }
    }
    fixed
}

/// Per vertex, whether it must stay whatever the segments: an input point, or a vertex where
/// the boundary meets itself (its triangles are two fans, and a star walks one).
fn held_vertices(mesh: &Mesh) -> Vec<bool> {
    let mut held: Vec<bool> = mesh.vertex_input.par_iter().map(|&i| i != NONE).collect();
    let mut boundary_edges = vec![0u8; mesh.vertices.len()];
    for edge in &mesh.boundary {
        for v in edge.vertices {
            let count = &mut boundary_edges[v as usize];
            *count = count.saturating_add(1);
            if *count > 2 {
                held[v as usize] = true;
            }
        }
    }
    held
}

/// The segments' chains of pieces, for the vertices inside them that may go: a vertex where
/// two pieces of one segment meet, and nothing else, collapses only along that segment, onto
/// the next vertex of its chain either way. Its star is then a fan from there: the two pieces
/// become one edge, which the fan has, and the chain's other vertices stay where they were,
/// within rounding of the segment's line.
struct Rails {
    /// Per vertex, the segment whose chain it lies inside and may go along, or [`NONE`]
    /// (empty without segments).
    segment: Vec<u32>,
    /// The other vertices of the chains, `(segment, vertex)` sorted: their ends, and those
    /// held for another reason.
    stops: Vec<(u32, u32)>,
}

impl Rails {
    /// The rails of `mesh`'s segments, none through a vertex `held`.
    fn of(mesh: &Mesh, held: &[bool]) -> Rails {
        if mesh.segments.is_empty() {
            return Rails {
                segment: Vec::new(),
                stops: Vec::new(),
            };
        }
        // Per vertex: how many pieces meet there, and the first one's segment and marker.
        let mut pieces = vec![(0u32, NONE, 0i32); mesh.vertices.len()];
        let mut mixed = vec![false; mesh.vertices.len()];
        for piece in &mesh.segments {
            for v in piece.vertices {
                let (count, segment, marker) = &mut pieces[v as usize];
                if *count == 0 {
                    (*segment, *marker) = (piece.segment, piece.marker);
                } else if (*segment, *marker) != (piece.segment, piece.marker) {
                    mixed[v as usize] = true;
                }
                *count += 1;
            }
        }
        let segment: Vec<u32> = (0..mesh.vertices.len())
            .map(|v| match pieces[v] {
                (2, s, _) if !mixed[v] && !held[v] => s,
                _ => NONE,
            })
            .collect();
        let mut stops: Vec<(u32, u32)> = (mesh.segments.iter())
            .flat_map(|piece| piece.vertices.map(|v| (piece.segment, v)))
            .filter(|&(_, v)| segment[v as usize] == NONE)
            .collect();
        stops.sort_unstable();
        stops.dedup();
        Rails { segment, stops }
    }

    /// The segment vertex `v` may go along, or [`NONE`].
    fn segment_at(&self, v: u32) -> u32 {
        self.segment.get(v as usize).copied().unwrap_or(NONE)
    }

    /// Whether `v` lies on a rail (`None` if not), and if so, whether `w` lies on the same.
    fn admits(&self, v: u32, w: u32) -> Option<bool> {
        let s = self.segment_at(v);
        if s == NONE {
            return None;
        }
        Some(self.segment_at(w) == s || self.stops.binary_search(&(s, w)).is_ok())
    }
}

/// Per vertex, a triangle it is a corner of, or [`NONE`].
fn corners_of(mesh: &Mesh) -> Vec<u32> {
    let mut corner = vec![NONE; mesh.vertices.len()];
    for (t, corners) in mesh.triangles.iter().enumerate() {
        for &v in corners {
            corner[v as usize] = t as u32;
        }
    }
    corner
}

/// Vertex `v`'s lot in round `round`, below [`TAKEN`] and never 0.
fn lot(v: u32, round: usize) -> u32 {
    (super::lot(v, round) >> 33) as u32 | 1
}

/// A collapse a vertex wants: the vertex, the neighbour it goes onto, the triangles it
/// changes (its star's, then those beyond the ones it removes), how many of them are its star's,
/// and its lot in the round.
#[derive(Clone, Debug)]
struct Plan {
    centre: u32,
    target: u32,
    claims: Vec<u32>,
    star: u32,
    lot: u32,
}

/// Buffers a thread reuses while planning.
#[derive(Default)]
struct Scratch {
    star: Star,
    candidates: Vec<(f64, u32)>,
}

impl Plan {
    /// The collapse of `v` (a corner of triangle `start`), if one keeps `limits`: onto its
    /// nearest neighbour that does (ties to the lower index); along its segment if `along`
    /// says it lies on a rail (`along(v, w)`: `None` for no rail, else whether `w` is on
    /// it), else along the boundary if `v` is on it.
    fn of(
        mesh: &Mesh,
        v: u32,
        start: u32,
        (limits, along): (Limits, &dyn Fn(u32, u32) -> Option<bool>),
        scratch: &mut Scratch,
    ) -> Option<Plan> {
        let Scratch { star, candidates } = scratch;
        star.refill(mesh, v, start)?;
        let at = mesh.vertices[v as usize];
        let distance = |w: u32| (mesh.vertices[w as usize].distance_squared(at), w);
        candidates.clear();
        if along(v, v).is_some() {
            // The chain's next vertices either way, both in the star, or no collapse.
            let on_rail = |&&w: &&u32| along(v, w) == Some(true);
            candidates.extend(star.neighbours.iter().filter(on_rail).map(|&w| distance(w)));
            if candidates.len() != 2 || star.triangles.len() < 2 {
                return None;
            }
        } else if star.closed {
            candidates.extend(star.neighbours.iter().map(|&w| distance(w)));
        } else {
            let (first, last) = (star.neighbours[0], *star.neighbours.last()?);
            let [a, b] = [first, last].map(|w| mesh.vertices[w as usize]);
            if star.triangles.len() < 2 || orientation(a, at, b) != Orientation::On {
                return None;
            }
            candidates.extend([distance(first), distance(last)]);
        }
        candidates.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let target = candidates
            .iter()
            .map(|&(_, w)| w)
            .find(|&u| star.collapses_onto(&mesh.vertices, u, limits))?;
        let mut claims = star.triangles.clone();
        for &t in &star.triangles {
            let corners = mesh.triangles[t as usize];
            if corners.contains(&target) {
                let i = corners.iter().position(|&c| c == v)?;
                let outer = mesh.neighbours[t as usize][i];
                if outer != NONE {
                    claims.push(outer);
                }
            }
        }
        Some(Plan {
            centre: v,
            target,
            claims,
            star: star.triangles.len() as u32,
            lot: 0,
        })
    }

    /// The triangles of the vertex's star.
    fn star(&self) -> &[u32] {
        &self.claims[..self.star as usize]
    }

    /// Collapses the vertex onto its target: the triangles with both go, the others take the
    /// target for the vertex, and the links and `corner` follow.
    fn collapse(&self, mesh: &mut Mesh, corner: &mut [u32]) {
        let (v, u) = (self.centre, self.target);
        let dying: Vec<u32> = self
            .star()
            .iter()
            .copied()
            .filter(|&t| mesh.triangles[t as usize].contains(&u))
            .collect();
        for &d in &dying {
            let corners = mesh.triangles[d as usize];
            let i = corners
                .iter()
                .position(|&c| c == v)
                .expect("a star's triangle");
            let outer = mesh.neighbours[d as usize][i];
            // The triangle sharing the dying one's other edge at `v`, which takes its place
            // beside `outer`.
            let (kept, beside) = match corners[(i + 1) % 3] == u {
                true => (
                    corners[(i + 2) % 3],
                    mesh.neighbours[d as usize][(i + 1) % 3],
                ),
                false => (
                    corners[(i + 1) % 3],
                    mesh.neighbours[d as usize][(i + 2) % 3],
                ),
            };
            relink(mesh, beside, d, outer);
            relink(mesh, outer, d, beside);
            if beside != NONE {
                corner[kept as usize] = beside;
                corner[u as usize] = beside;
            }
        }
        for &t in self.star() {
            if dying.contains(&t) {
                mesh.triangles[t as usize] = [NONE; 3];
                mesh.neighbours[t as usize] = [NONE; 3];
            } else {
                for c in &mut mesh.triangles[t as usize] {
                    if *c == v {
                        *c = u;
                    }
                }
            }
        }
        corner[v as usize] = NONE;
    }
}

/// Points triangle `t`'s link to `from` at `to` instead (nothing for `t` [`NONE`]).
fn relink(mesh: &mut Mesh, t: u32, from: u32, to: u32) {
    if t == NONE {
        return;
    }
    for link in &mut mesh.neighbours[t as usize] {
        if *link == from {
            *link = to;
        }
    }
}

impl Star {
    /// Whether moving the centre onto neighbour `u` leaves every triangle not at `u`
    /// admitted by `limits`.
    fn collapses_onto(&self, vertices: &[DVec2], u: u32, limits: Limits) -> bool {
        let at = vertices[u as usize];
        self.edges()
            .filter(|&(a, b)| a != u && b != u)
            .all(|(a, b)| limits.admit(at, vertices[a as usize], vertices[b as usize]))
    }
}

/// The segment pieces with the collapsed vertices (`corner` [`NONE`]) left out: each went
/// along its chain, inside it, so the pieces on either side of it become one.
fn joined_pieces(pieces: &[SubSegment], corner: &[u32]) -> Vec<SubSegment> {
    let alive = |v: u32| corner[v as usize] != NONE;
    let mut joined = Vec::with_capacity(pieces.len());
    let mut from = NONE;
    for piece in pieces {
        let [a, b] = piece.vertices;
        if alive(a) {
            from = a;
        }
        if alive(b) {
            joined.push(SubSegment {
                vertices: [from, b],
                ..*piece
            });
        }
    }
    joined
}

/// Drops the collapsed vertices (`corner` [`NONE`]) and dead triangles, keeping the order of
/// the rest, and joins the boundary edges at the collapsed vertices.
fn compact(mesh: &mut Mesh, corner: &[u32]) {
    let vertex_map = survivors_map(corner.iter().map(|&c| c != NONE));
    let triangle_map = survivors_map(mesh.triangles.iter().map(|t| t[0] != NONE));
    let renumber = |map: &[u32], x: u32| if x == NONE { NONE } else { map[x as usize] };
    mesh.boundary = joined_boundary(&mesh.boundary, corner);
    for edge in &mut mesh.boundary {
        edge.vertices = edge.vertices.map(|v| renumber(&vertex_map, v));
    }
    mesh.segments = joined_pieces(&mesh.segments, corner);
    for piece in &mut mesh.segments {
        piece.vertices = piece.vertices.map(|v| renumber(&vertex_map, v));
    }
    let alive = |t: usize| triangle_map[t] != NONE;
    if !mesh.triangle_regions.is_empty() {
        mesh.triangle_regions = keep(&mesh.triangle_regions, alive);
    }
    mesh.triangles = keep(&mesh.triangles, alive);
    mesh.neighbours = keep(&mesh.neighbours, alive);
    mesh.triangles
        .par_iter_mut()
        .for_each(|t| *t = t.map(|v| renumber(&vertex_map, v)));
    mesh.neighbours
        .par_iter_mut()
        .for_each(|n| *n = n.map(|t| renumber(&triangle_map, t)));
    let kept = |v: usize| vertex_map[v] != NONE;
    mesh.vertices = keep(&mesh.vertices, kept);
    mesh.vertex_input = keep(&mesh.vertex_input, kept);
}

/// The new index of each element whose flag is set, [`NONE`] for the others.
fn survivors_map(alive: impl Iterator<Item = bool>) -> Vec<u32> {
    let mut next = 0u32;
    alive
        .map(|a| match a {
            true => {
                next += 1;
                next - 1
            }
            false => NONE,
        })
        .collect()
}

/// The elements of `items` whose index `keep` admits, in order.
fn keep<T: Copy + Send + Sync>(items: &[T], wanted: impl Fn(usize) -> bool + Sync) -> Vec<T> {
    items
        .par_iter()
        .enumerate()
        .filter(|&(i, _)| wanted(i))
        .map(|(_, &x)| x)
        .collect()
}

/// The boundary edges with those at collapsed vertices joined: an edge from a vertex that
/// stays runs on through the vertices that went, in the order of the edges that start at a
/// vertex that stays.
fn joined_boundary(boundary: &[BoundaryEdge], corner: &[u32]) -> Vec<BoundaryEdge> {
    let mut next = vec![NONE; corner.len()];
    for edge in boundary {
        next[edge.vertices[0] as usize] = edge.vertices[1];
    }
    boundary
        .iter()
        .filter(|edge| corner[edge.vertices[0] as usize] != NONE)
        .map(|edge| {
            let mut end = edge.vertices[1];
            while corner[end as usize] == NONE {
                end = next[end as usize];
            }
            BoundaryEdge {
                vertices: [edge.vertices[0], end],
                marker: edge.marker,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domain::SubSegment;
    use crate::mesh::angles_deg;
    use crate::mesh::fixtures::mesh_of;

    /// The `n`×`n` grid of unit squares, each cut by a diagonal, its four corners input points
    /// and the vertex at `(1, 1)` a fifth.
    fn grid(n: u32) -> Mesh {
        let index = |i: u32, j: u32| j * (n + 1) + i;
        let vertices = (0..=n)
            .flat_map(|j| (0..=n).map(move |i| DVec2::new(i as f64, j as f64)))
            .collect();
        let mut triangles = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let [a, b, c, d] = [
                    index(i, j),
                    index(i + 1, j),
                    index(i + 1, j + 1),
                    index(i, j + 1),
                ];
                triangles.extend([[a, b, c], [a, c, d]]);
            }
        }
        let inputs = [
            index(0, 0),
            index(n, 0),
            index(n, n),
            index(0, n),
            index(1, 1),
        ];
        mesh_of(vertices, &inputs, triangles)
    }

    /// Checks what a coarsening keeps: counter-clockwise triangles within `bounds`, linked to
    /// one another both ways, covering the area they covered, each input point a vertex at
    /// its place, every vertex in a triangle, and boundary edges that are triangles' free
    /// edges.
    fn check(before: &Mesh, after: &Mesh, bounds: (f64, f64)) {
        let area = |m: &Mesh| -> f64 {
            m.triangles
                .iter()
                .map(|t| {
                    let [a, b, c] = t.map(|v| m.vertices[v as usize]);
                    (b - a).perp_dot(c - a) / 2.0
                })
                .sum()
        };
        assert_eq!(area(before), area(after));
        check_links_and_bounds(before, after, bounds);
    }

    /// [`check`] but for the area, which floating-point coordinates round apart when summed in
    /// another order (`Mesh::validate` checks it within rounding).
    fn check_links_and_bounds(before: &Mesh, after: &Mesh, bounds: (f64, f64)) {
        let mut used = vec![false; after.vertices.len()];
        for (t, corners) in after.triangles.iter().enumerate() {
            let [a, b, c] = corners.map(|v| after.vertices[v as usize]);
            assert_eq!(orientation(a, b, c), Orientation::Left);
            for angle in angles_deg(a, b, c) {
                assert!(
                    angle >= bounds.0 - 1e-9 && angle <= bounds.1 + 1e-9,
                    "{angle}"
                );
            }
            for (i, &across) in after.neighbours[t].iter().enumerate() {
                let [p, q] = crate::mesh::opposite_edge(*corners, i);
                match across {
                    NONE => assert!(after.boundary.iter().any(|e| e.vertices == [p, q])),
                    _ => {
                        let other = after.triangles[across as usize];
                        assert!((0..3).any(|k| crate::mesh::opposite_edge(other, k) == [q, p]));
                    }
                }
            }
            for v in corners {
                used[*v as usize] = true;
            }
        }
        assert!(used.iter().all(|&u| u));
        let inputs = |m: &Mesh| -> Vec<(u32, DVec2)> {
            let mut kept: Vec<(u32, DVec2)> = (m.vertex_input.iter().zip(&m.vertices))
                .filter(|(i, _)| **i != NONE)
                .map(|(&i, &p)| (i, p))
                .collect();
            kept.sort_by_key(|&(i, _)| i);
            kept
        };
        assert_eq!(inputs(before), inputs(after));
        let free_edges: usize = after
            .neighbours
            .iter()
            .flatten()
            .filter(|&&t| t == NONE)
            .count();
        assert_eq!(free_edges, after.boundary.len());
    }

    #[test]
    fn a_fine_grid_coarsens_within_the_bounds_with_its_sides_straight() {
        let before = grid(8);
        let mut after = before.clone();
        let coarsened = coarsen(&mut after, COARSE_ANGLE_BOUNDS);
        assert!(coarsened.collapses > 40, "{coarsened:?}");
        assert_eq!(
            after.vertices.len(),
            before.vertices.len() - coarsened.collapses
        );
        assert!(after.triangles.len() < before.triangles.len() / 3);
        check(&before, &after, COARSE_ANGLE_BOUNDS);
        for edge in &after.boundary {
            let [a, b] = edge.vertices.map(|v| after.vertices[v as usize]);
            let on_a_side = |p: DVec2, q: DVec2| {
                (p.x == q.x && (p.x == 0.0 || p.x == 8.0))
                    || (p.y == q.y && (p.y == 0.0 || p.y == 8.0))
            };
            assert!(on_a_side(a, b), "{a} – {b}");
        }
    }

    #[test]
    fn right_angles_pass_the_nonobtuse_limits_within_rounding_and_obtuse_ones_fail() {
        let limits = Limits::of(NONOBTUSE_COARSE_BOUNDS, &grid(8));
        let (a, b, c) = (
            DVec2::new(0.1, 0.7),
            DVec2::new(0.4, 0.7),
            DVec2::new(0.1, 0.9),
        );
        assert!(limits.admit(a, b, c));
        // A step of rounding past 90°, as the grid's rounded corners make, passes; a billionth
        // of a radian does not, nor a triangle turning clockwise or with an angle under 20°.
        let rounded = DVec2::new(f64::from_bits(c.x.to_bits() - 1), c.y);
        assert!(limits.admit(a, b, rounded));
        assert!(!limits.admit(a, b, DVec2::new(c.x - 2e-10, c.y)));
        assert!(!limits.admit(a, c, b));
        assert!(!limits.admit(a, DVec2::new(0.9, 0.7), c));
        // An angle of 117°: within the warp's limits, not the nonobtuse ones.
        assert!(Limits::of(COARSE_ANGLE_BOUNDS, &grid(8)).admit(a, b, DVec2::new(0.0, 0.9)));
        assert!(!limits.admit(a, b, DVec2::new(0.0, 0.9)));
    }

    /// Coarsens `mesh` with chunks of `chunk_vertices` on a pool of `threads` threads.
    fn coarsened_on(mesh: &Mesh, chunk_vertices: usize, threads: usize) -> (Mesh, Coarsened) {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("a thread pool");
        let mut after = mesh.clone();
        let coarsened =
            pool.install(|| coarsen_in_chunks_of(&mut after, COARSE_ANGLE_BOUNDS, chunk_vertices));
        (after, coarsened)
    }

    #[test]
    fn small_chunks_their_edges_and_the_rounds_coarsen_as_well_as_one_chunk() {
        let before = grid(40);
        let (whole, in_one) = coarsened_on(&before, usize::MAX, 1);
        check(&before, &whole, COARSE_ANGLE_BOUNDS);
        assert_eq!(in_one.rounds, 1, "one chunk leaves nothing to the rounds");
        for chunk_vertices in [50, 200, 777] {
            let (after, coarsened) = coarsened_on(&before, chunk_vertices, 1);
            check(&before, &after, COARSE_ANGLE_BOUNDS);
            assert!(coarsened.rounds > 1, "{chunk_vertices}: {coarsened:?}");
            // The chunks' order of collapses is not one chunk's, and the rounds, which take the
            // more collapses the smaller the chunks, collapse less than a greedy pass: the
            // count stays within 10 %.
            let (one, many) = (in_one.collapses as f64, coarsened.collapses as f64);
            assert!(many > 0.9 * one, "{chunk_vertices}: {many} against {one}");
            for threads in [2, 3] {
                assert_eq!(coarsened_on(&before, chunk_vertices, threads).0, after);
            }
        }
    }

    #[test]
    fn the_compact_warp_of_clustered_points_in_small_chunks_coarsens_valid() {
        use crate::generate::{Distribution2d, points};
        let pts = points(Distribution2d::Cluster, 500, 3);
        let options = crate::Options::default().compact_warp();
        let (before, _) =
            crate::mesh(&crate::Input::points(pts.clone()), &options).expect("meshed");
        let (whole, _) = coarsened_on(&before, usize::MAX, 1);
        let (after, coarsened) = coarsened_on(&before, 1000, 2);
        check_links_and_bounds(&before, &after, COARSE_ANGLE_BOUNDS);
        let bounds = crate::mesh::AngleBounds {
            min_deg: COARSE_ANGLE_BOUNDS.0,
            max_deg: COARSE_ANGLE_BOUNDS.1,
        };
        after.validate(&pts, bounds).expect("a valid mesh");
        assert!(coarsened.rounds > 1, "{coarsened:?}");
        assert!(after.triangles.len() * 3 < before.triangles.len());
        assert!(after.triangles.len() < whole.triangles.len() * 11 / 10);
        assert_eq!(coarsened_on(&before, 1000, 1).0, after);
    }

    #[test]
    fn a_scattered_numbering_is_chunked_in_morton_order() {
        let mesh = grid(40);
        let n = mesh.vertices.len() as u32;
        // 7919 is prime and 41² is not its multiple: a permutation that scatters neighbours.
        let new_index = |v: u32| (v as u64 * 7919 % n as u64) as u32;
        let mut scattered = mesh.clone();
        for (v, &p) in mesh.vertices.iter().enumerate() {
            scattered.vertices[new_index(v as u32) as usize] = p;
        }
        for t in &mut scattered.triangles {
            *t = t.map(new_index);
        }
        let by_index = Chunking::by_index(200);
        assert!(by_index.holds(&mesh.triangles, 0.7));
        assert!(!by_index.holds(&scattered.triangles, 0.1));
        let morton = Chunking::morton(200, &scattered.vertices, 0.0);
        assert!(morton.holds(&scattered.triangles, 0.7));
        // The first pass keeps the row-major numbering, and orders the scattered one.
        assert!(first_chunking(&mesh, 200).holds(&mesh.triangles, 0.7));
        let first = first_chunking(&scattered, 200);
        assert!(first.holds(&scattered.triangles, 0.7));
    }

    #[test]
    fn nothing_collapses_where_every_collapse_breaks_the_bounds() {
        // Every triangle of the grid has a right angle; with a largest angle of 80° allowed,
        // any collapse would make triangles as wide as the ones there.
        let mut mesh = grid(3);
        let before = mesh.clone();
        assert_eq!(coarsen(&mut mesh, (20.0, 80.0)).collapses, 0);
        assert_eq!(mesh, before);
    }

    #[test]
    fn a_vertex_inside_a_segments_chain_goes_along_it_and_its_ends_stay() {
        let mut before = grid(6);
        // Segment 0 runs from vertex 15 through 16 to 17, segment 1 on from 17 to 19: 16 lies
        // inside one chain, 17 and 18 where the chains meet and inside the second.
        let piece = |vertices, segment, marker| SubSegment {
            vertices,
            segment,
            marker,
        };
        before.segments = vec![
            piece([15, 16], 0, 3),
            piece([16, 17], 0, 3),
            piece([17, 18], 1, 5),
            piece([18, 19], 1, 5),
        ];
        let mut after = before.clone();
        coarsen(&mut after, COARSE_ANGLE_BOUNDS);
        check(&before, &after, COARSE_ANGLE_BOUNDS);
        let at = |m: &Mesh, v: u32| m.vertices[v as usize];
        let pieces: Vec<([DVec2; 2], u32, i32)> = (after.segments.iter())
            .map(|p| (p.vertices.map(|v| at(&after, v)), p.segment, p.marker))
            .collect();
        let expected: Vec<([DVec2; 2], u32, i32)> = [([15, 17], 0, 3), ([17, 19], 1, 5)]
            .map(|(ends, s, m)| (ends.map(|v| at(&before, v)), s, m))
            .to_vec();
        assert_eq!(pieces, expected);
        // Each piece is an edge of the mesh.
        for p in &after.segments {
            let [a, b] = p.vertices;
            assert!(
                after
                    .triangles
                    .iter()
                    .any(|t| t.contains(&a) && t.contains(&b))
            );
        }
        for v in [16, 18] {
            assert!(!after.vertices.contains(&before.vertices[v]));
        }
    }

    #[test]
    fn a_rail_admits_only_its_own_chain() {
        let mut mesh = grid(6);
        mesh.segments = [[15, 16], [16, 17], [17, 24]]
            .map(|vertices| SubSegment {
                vertices,
                segment: 0,
                marker: 0,
            })
            .to_vec();
        let rails = Rails::of(&mesh, &held_vertices(&mesh));
        assert_eq!(rails.admits(16, 15), Some(true));
        assert_eq!(rails.admits(16, 17), Some(true));
        assert_eq!(rails.admits(16, 9), Some(false));
        assert_eq!(rails.admits(17, 24), Some(true));
        // Ends and free vertices lie on no rail.
        assert_eq!(rails.admits(15, 16), None);
        assert_eq!(rails.admits(24, 17), None);
        assert_eq!(rails.admits(9, 16), None);
        let plain = grid(2);
        assert!(Rails::of(&plain, &held_vertices(&plain)).segment.is_empty());
    }

    #[test]
    fn the_collapses_of_a_round_claim_disjoint_triangles_and_leave_none_out() {
        let plan = |centre: u32, claims: &[u32]| Plan {
            centre,
            target: 0,
            claims: claims.to_vec(),
            star: claims.len() as u32,
            lot: lot(centre, 3),
        };
        let plans: Vec<Plan> = (0..200)
            .map(|k| plan(k, &[k % 37, (k * 7) % 41 + 40, (k * 13) % 29 + 90]))
            .collect();
        let claims: Vec<AtomicU32> = (0..200).map(|_| AtomicU32::new(0)).collect();
        let goes = independent(&plans, &claims);
        assert!(claims.iter().all(|c| c.load(Ordering::Relaxed) == 0));
        let mut owner = vec![None; 200];
        for (i, plan) in plans.iter().enumerate().filter(|&(i, _)| goes[i]) {
            for &t in &plan.claims {
                assert_eq!(owner[t as usize], None, "two collapses claim {t}");
                owner[t as usize] = Some(i);
            }
        }
        for (i, plan) in plans.iter().enumerate().filter(|&(i, _)| !goes[i]) {
            assert!(
                plan.claims.iter().any(|&t| owner[t as usize].is_some()),
                "plan {i} waits though nothing it claims is taken"
            );
        }
    }
}
