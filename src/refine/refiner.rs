//! The refinement loop: bad triangles are fixed one at a time, smallest size class first, within
//! a class the worst-shaped first, and the bad triangles an insertion makes right after it, while
//! their memory is in cache.
//!
//! The loop runs on a [`Store`]: a whole triangulation, or one tile of it that is refined
//! alongside others. A tile sets aside, as deferred, the work that would reach beyond it.

use std::sync::Arc;

use glam::DVec2;
use rayon::prelude::*;

use super::delaunay::{
    Cavity, Location, MARK, NEXT, PREV, SEGMENT, Split, Store, Triangulation, beyond, is_wall,
    locate,
};
use super::hull::ACUTE_CORNER_DEG;
use super::queue::{Queued, SizeQueue};
use super::segments::Walls;
use super::{MIN_GAP, RefineOptions};
use crate::error::Error;
use crate::mesh::NONE;
use crate::morton::interleave::interleave32;
use crate::predicates::{InCircle, Orientation, in_circle, orient_value, orientation};

/// An encroached boundary edge as it was when queued: the edge opposite `corner` of `triangle`,
/// live while that slot still has these ends there.
#[derive(Clone, Copy, Debug)]
pub(super) struct Encroached {
    pub triangle: u32,
    pub corner: u8,
    pub ends: (u32, u32),
}

/// A bad triangle waiting outside any queue, with its size class.
#[derive(Clone, Copy, Debug)]
pub(super) struct Pending {
    pub class: u32,
    pub entry: Queued,
}

/// What inspecting a triangle found.
struct Inspection {
    bad: Option<Pending>,
    encroached: [Option<Encroached>; 3],
}

/// The quality bounds and the frame of the Morton keys, fixed for a whole refinement.
#[derive(Clone, Debug)]
pub(crate) struct Bounds {
    /// sin² of the angle bound.
    pub(super) sin2: f64,
    /// Twice the area bound (cross products give twice the area).
    max_area2: f64,
    /// Off-centers lie this many shortest-edge lengths from the edge's midpoint.
    offset: f64,
    /// cos² of twice the angle bound (0 without a bound): a point sees an edge it encroaches on
    /// at an angle whose cosine, negative, has at least this square.
    lens: f64,
    /// The domain's lower-left corner and the scale that maps it onto 32-bit grid coordinates.
    origin: DVec2,
    scale: f64,
    /// The domain's corners narrower than [`ACUTE_CORNER_DEG`], at most two in a convex
    /// domain. Boundary edges from them are split on concentric circles around them, and a
    /// triangle whose smallest angle lies in one narrower than the bound is left as it is (no
    /// triangle there can meet it).
    acute: [AcuteCorner; 2],
    /// The segments of a planar straight-line graph and the corners between them.
    walls: Option<Arc<Walls>>,
    /// Twice the area bound of each region, where regions bound it.
    region_area2: Arc<[f64]>,
    /// Whether boundary edges may be split.
    boundary_steiner: bool,
}

/// A domain corner narrower than [`ACUTE_CORNER_DEG`].
#[derive(Clone, Copy, Debug)]
struct AcuteCorner {
    /// Its vertex, or [`NONE`] for no corner.
    vertex: u32,
    /// Whether it is narrower than the angle bound.
    narrow: bool,
    /// Its position and the far ends of its two sides.
    at: DVec2,
    ends: [DVec2; 2],
}

impl AcuteCorner {
    const NONE: AcuteCorner = AcuteCorner {
        vertex: NONE,
        narrow: false,
        at: DVec2::ZERO,
        ends: [DVec2::ZERO; 2],
    };
}

impl Bounds {
    /// The bounds of `options` on the triangulation of `domain` = `[lo, hi]`.
    pub fn new(options: &RefineOptions, lo: DVec2, hi: DVec2) -> Self {
        let angle = options.min_angle_deg.to_radians();
        // The off-center's triangle on the shortest edge is isosceles with apex angle equal to
        // the bound at height cot(A/2)/2 edge lengths; a little less leaves it strictly better.
        let offset = if angle > 0.0 {
            off_center_margin(options.min_angle_deg) * 0.5 / (angle / 2.0).tan()
        } else {
            f64::INFINITY
        };
        let side = (hi - lo).max_element();
        Bounds {
            sin2: angle.sin().powi(2),
            max_area2: options.max_area.map_or(f64::INFINITY, |a| 2.0 * a),
            offset,
            lens: if angle > 0.0 {
                (2.0 * angle).cos().powi(2)
            } else {
                0.0
            },
            origin: lo,
            scale: 2f64.powi(32) / side * (1.0 - f64::EPSILON),
            acute: [AcuteCorner::NONE; 2],
            walls: None,
            region_area2: Arc::from([]),
            boundary_steiner: true,
        }
    }

    /// These bounds with a planar straight-line graph's segments and corners, its regions'
    /// area bounds (`None` for unbounded) and whether boundary edges may be split.
    pub fn with_walls(
        mut self,
        walls: Walls,
        region_areas: &[Option<f64>],
        boundary_steiner: bool,
    ) -> Self {
        self.walls = Some(Arc::new(walls));
        self.region_area2 = region_areas
            .iter()
            .map(|a| a.map_or(f64::INFINITY, |a| 2.0 * a))
            .collect();
        self.boundary_steiner = boundary_steiner;
        self
    }

    /// The segments of the graph being refined, if it is one.
    pub fn walls(&self) -> Option<&Walls> {
        self.walls.as_deref()
    }

    /// Twice the largest area allowed in region `r`.
    #[inline]
    fn max_area2_in(&self, r: u32) -> f64 {
        match self.region_area2.get(r as usize) {
            Some(&a) => a.min(self.max_area2),
            None => self.max_area2,
        }
    }

    /// Whether a wall link may be split: a segment always, the boundary unless forbidden.
    #[inline]
    pub fn splits(&self, link: u32) -> bool {
        link != NONE || self.boundary_steiner
    }

    /// Whether vertex `v` is a corner between walls narrower than [`ACUTE_CORNER_DEG`].
    #[inline]
    fn is_acute(&self, v: u32) -> bool {
        match &self.walls {
            Some(w) => w.is_acute(v),
            None => self.acute_corner(v).is_some(),
        }
    }

    /// These bounds with the domain's corners, counter-clockwise: vertex numbers, positions
    /// and interior angles, degrees.
    pub fn with_corners(mut self, corners: &[(u32, DVec2, f64)]) -> Self {
        let n = corners.len();
        let mut acute = (0..n).filter(|&k| corners[k].2 < ACUTE_CORNER_DEG);
        for slot in 0..2 {
            if let Some(k) = acute.next() {
                let (vertex, at, angle) = corners[k];
                let (next, prev) = (corners[(k + 1) % n].1, corners[(k + n - 1) % n].1);
                self.acute[slot] = AcuteCorner {
                    vertex,
                    narrow: angle.to_radians().sin().powi(2) < self.sin2,
                    at,
                    ends: [next, prev],
                };
            }
        }
        self
    }

    /// Whether `p` and `q` lie on the two sides of a domain corner narrower than the bound and
    /// `apex` no further from it (Shewchuk's rule): a triangle whose shortest edge spans such a
    /// corner between it and the corner cannot be made better, and splitting it would only
    /// shrink the splits on the sides towards the corner.
    #[inline]
    fn spans_narrow_corner(&self, p: DVec2, q: DVec2, apex: DVec2) -> bool {
        self.acute.iter().any(|corner| {
            if corner.vertex == NONE || !corner.narrow {
                return false;
            }
            let (c, [e, f]) = (corner.at, corner.ends);
            // On a side: within 1e-9 radians of it, and within a thousandth of the corner's
            // own angle, so that a corner far narrower than 1e-9 (a point 1e55 away) does not
            // take every point far from it for one on both its sides; and no further out than
            // its far end, beyond which a corner of nearly 180° can continue it in line. The
            // angles come from the determinants, which differences to a far corner would lose:
            // from there, points near each other round to one direction.
            let (a, b) = (e - c, f - c);
            let sin_corner = orient_value(c, e, f).abs() / (a.length() * b.length());
            let tolerance = 1e-9f64.min(1e-3 * sin_corner);
            let on = |x: DVec2, end: DVec2| {
                let d = end - c;
                orient_value(c, end, x).abs() <= tolerance * x.distance(c) * d.length()
                    && (x - c).dot(d) > 0.0
                    && (x - end).dot(d) <= 0.0
            };
            let spans = (on(p, e) && on(q, f)) || (on(p, f) && on(q, e));
            spans && apex.distance(c) <= 1.001 * p.distance(c).max(q.distance(c))
        })
    }

    /// The acute domain corner at vertex `v`, if it is one.
    #[inline]
    fn acute_corner(&self, v: u32) -> Option<&AcuteCorner> {
        self.acute.iter().find(|c| c.vertex == v && v != NONE)
    }

    /// Whether vertex `v` is a domain corner narrower than the angle bound: no refinement can
    /// make the angles there larger.
    #[inline]
    fn in_narrow_corner(&self, v: u32) -> bool {
        self.acute[0].vertex != NONE && self.acute_corner(v).is_some_and(|c| c.narrow)
    }

    /// Whether no triangle can be bad: the Delaunay triangulation is the mesh.
    pub fn unbounded(&self) -> bool {
        self.sin2 == 0.0
            && self.max_area2 == f64::INFINITY
            && self.region_area2.iter().all(|a| *a == f64::INFINITY)
    }
}

/// The queues and scratch space of a refinement loop, kept between the tiles one thread works
/// through.
#[derive(Debug)]
pub(super) struct Work {
    bad: SizeQueue,
    encroached: Vec<Encroached>,
    cavity: Cavity,
    /// Bad triangles and boundary edges set aside for a later pass.
    pub deferred: Vec<Pending>,
    pub deferred_edges: Vec<Encroached>,
    /// Points inserted.
    pub inserted: usize,
}

impl Work {
    pub fn new() -> Self {
        Work {
            bad: SizeQueue::new(),
            encroached: Vec::new(),
            cavity: Cavity::default(),
            deferred: Vec::new(),
            deferred_edges: Vec::new(),
            inserted: 0,
        }
    }

    /// Queues bad triangles and encroached edges found elsewhere, in this order.
    pub fn queue_all(&mut self, bad: &[Pending], edges: &[Encroached]) {
        for p in bad {
            self.bad.push(p.class as usize, p.entry);
        }
        self.encroached.extend_from_slice(edges);
    }
}

/// How a refinement loop ended without an error.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Finish {
    /// Nothing is left to do, or what is left was set aside.
    Done,
    /// The whole triangulation reached its vertex budget with work left.
    OutOfBudget,
}

/// The refinement loop's state.
pub(super) struct Refiner<'w, S: Store> {
    s: S,
    work: &'w mut Work,
    bounds: &'w Bounds,
    budget: usize,
    /// Bad triangles of larger size classes are set aside, not fixed.
    class_limit: usize,
    /// Where set: vertices numbered from this on that lie on no wall are free, and those inside
    /// a wall's diametral circle go before it is split.
    free_from: Option<u32>,
    /// Deletions still allowed: as many as the vertex budget, so that deletions and insertions
    /// cannot take turns without end.
    deletions_left: usize,
}

impl<'w, S: Store> Refiner<'w, S> {
    pub fn new(s: S, work: &'w mut Work, bounds: &'w Bounds, budget: usize) -> Self {
        Refiner {
            s,
            work,
            bounds,
            budget,
            class_limit: usize::MAX,
            free_from: None,
            deletions_left: budget,
        }
    }

    /// Deletes, before a wall is split, the free vertices (numbered from `first` on, on no
    /// wall) that lie inside its diametral circle as the apex of its triangle, one after
    /// another, as Chew's refinement and Triangle do: the split point replaces them, and the
    /// mesh keeps fewer vertices next to the walls. Only a whole triangulation deletes.
    pub fn deleting_free_vertices_from(mut self, first: u32) -> Self {
        debug_assert!(S::WHOLE);
        self.free_from = Some(first);
        self
    }

    /// Sets aside bad triangles whose size class is above `limit`.
    pub fn up_to_class(mut self, limit: usize) -> Self {
        self.class_limit = limit;
        self
    }

    /// Fixes bad triangles and encroached boundary edges until none is left, or, in a store
    /// without room for more, sets the rest aside.
    pub fn run(mut self) -> Result<Finish, Error> {
        loop {
            if S::WHOLE && self.s.vertex_count() > self.budget {
                return Ok(Finish::OutOfBudget);
            }
            if !self.s.room() {
                self.defer_all();
                return Ok(Finish::Done);
            }
            if let Some(e) = self.work.encroached.pop() {
                if self.is_live(&e) {
                    self.split_wall(e)?;
                }
                continue;
            }
            let Some((class, q)) = self.work.bad.pop() else {
                return Ok(Finish::Done);
            };
            if class > self.class_limit {
                // The queue gives the smallest class first: all that is left is too large.
                self.defer(class, q);
                self.defer_all();
                return Ok(Finish::Done);
            }
            if self.is_current(&q) {
                self.fix(class, q)?;
            }
        }
    }

    fn defer_all(&mut self) {
        while let Some((class, entry)) = self.work.bad.pop() {
            self.work.deferred.push(Pending {
                class: class as u32,
                entry,
            });
        }
        self.work.deferred_edges.append(&mut self.work.encroached);
    }

    /// Inserts the off-center (or circumcenter) of a bad triangle, unless it would encroach on
    /// boundary edges: then those are queued for splitting and the triangle waits again.
    fn fix(&mut self, class: usize, q: Queued) -> Result<(), Error> {
        let Some((corner, shortest2)) = badness(&self.s, self.bounds, q.triangle) else {
            return Ok(());
        };
        if class != SizeQueue::class_of(shortest2) {
            // A vertex deletion's triangle reused a slot and has the largest corner of one it
            // held before: queue it as what it is.
            let found = inspection(&self.s, self.bounds, q.triangle);
            self.queue(found);
            return Ok(());
        }
        let p = resolvable_steiner_point(&self.s, self.bounds, q.triangle, (corner, shortest2))?;
        // The triangle waits for the boundary edges it encroaches on to be split. A tile may
        // have to set those splits aside; the triangle then waits for a later pass too, rather
        // than find them unsplit again and again.
        let requeue = |r: &mut Self| {
            if S::WHOLE {
                r.work.bad.push(class, q);
            } else {
                r.defer(class, q);
            }
        };
        match locate(&self.s, p, q.triangle) {
            Location::Outside { triangle, edge } => {
                // The point lies beyond a segment, or rounding put a circumcenter just past the
                // boundary: split the wall it crossed, where that is allowed.
                let tri = self.s.triangle(triangle);
                if !self.bounds.splits(tri.n[edge]) {
                    return Ok(());
                }
                let ends = tri.edge(edge);
                self.work.encroached.push(Encroached {
                    triangle,
                    corner: edge as u8,
                    ends,
                });
                requeue(self);
                Ok(())
            }
            Location::Vertex(_) => Err(Error::resolution_at(p)),
            Location::Foreign => {
                self.defer(class, q);
                Ok(())
            }
            Location::Inside(t) => {
                if !self.work.cavity.dig(&mut self.s, p, t) {
                    self.defer(class, q);
                    return Ok(());
                }
                if !self.work.cavity.is_disk() {
                    // A vertex within rounding of the point lies inside its cavity.
                    self.work.cavity.abandon(&mut self.s);
                    return Err(Error::resolution_at(p));
                }
                let before = self.work.encroached.len();
                let walls = self
                    .work
                    .cavity
                    .rim()
                    .iter()
                    .filter(|e| is_wall(e.outer) && self.bounds.splits(e.outer));
                for e in walls {
                    if encroaches(&self.s, self.bounds, p, (e.a, e.b)) {
                        self.work.encroached.push(Encroached {
                            triangle: e.inner,
                            corner: e.corner,
                            ends: (e.a, e.b),
                        });
                    }
                }
                if self.work.encroached.len() > before {
                    self.work.cavity.abandon(&mut self.s);
                    requeue(self);
                    return Ok(());
                }
                self.work.cavity.commit(&mut self.s, p, None);
                self.inspect_created();
                Ok(())
            }
        }
    }

    fn defer(&mut self, class: usize, entry: Queued) {
        self.work.deferred.push(Pending {
            class: class as u32,
            entry,
        });
    }

    /// Queues what the last insertion made: its bad triangles, its encroached boundary edges.
    fn inspect_created(&mut self) {
        self.work.inserted += 1;
        for k in 0..self.work.cavity.created().len() {
            let found = inspection(&self.s, self.bounds, self.work.cavity.created()[k]);
            self.queue(found);
        }
    }

    fn queue(&mut self, found: Inspection) {
        if let Some(p) = found.bad {
            self.work.bad.push(p.class as usize, p.entry);
        }
        self.work
            .encroached
            .extend(found.encroached.into_iter().flatten());
    }

    /// Whether the entry's triangle is still in its slot.
    fn is_current(&self, q: &Queued) -> bool {
        is_current(&self.s, q)
    }

    fn is_live(&self, e: &Encroached) -> bool {
        is_live(&self.s, e)
    }

    /// Splits a wall (a boundary edge or a segment): at its midpoint, which on an
    /// axis-parallel edge keeps the side's constant coordinate bit for bit; or, on an edge from
    /// an acute corner between walls, where a circle around the corner of a power-of-two radius
    /// meets it nearest the midpoint (Ruppert's concentric shells), so that the splits on the
    /// corner's two sides stay at equal distances from it and stop encroaching on each other.
    fn split_wall(&mut self, e: Encroached) -> Result<(), Error> {
        let (a, b) = (self.s.point(e.ends.0), self.s.point(e.ends.1));
        let acute = |v: u32| self.bounds.is_acute(v);
        let acute = (acute(e.ends.0), acute(e.ends.1));
        let e = match self.free_from {
            Some(first) if acute == (false, false) => self.clear_diametral_circle(e, first),
            _ => e,
        };
        let m = split_point(a, b, acute)?;
        let interior = self.s.across(e.triangle)[e.corner as usize] != NONE;
        let through = interior.then_some(e.ends);
        if !self
            .work
            .cavity
            .dig_through(&mut self.s, m, e.triangle, through)
        {
            self.work.deferred_edges.push(e);
            return Ok(());
        }
        if !self.fan_fits(m, &e, interior) {
            // Rounding put the split point off its segment far enough that the fan from it
            // would not be a constrained Delaunay triangulation of the cavity: f64 cannot
            // split this segment here.
            self.work.cavity.abandon(&mut self.s);
            return Err(Error::resolution_at(m));
        }
        let segment = self.segment_between(e.ends);
        let split = Split {
            ends: e.ends,
            interior,
        };
        let v = self.work.cavity.commit(&mut self.s, m, Some(split));
        self.s.set_segment_of(v, segment);
        self.inspect_created();
        Ok(())
    }

    /// Whether the fan from `m`, splitting the wall `e`, triangulates the cavity dug for it
    /// and keeps it Delaunay: the cavity is a disk, `m` sees its whole rim, and the triangles
    /// on the wall, which join the cavity without the circle test, have `m` in their
    /// circumcircles. A split point rounded off its segment can fail the last where they are
    /// thin: a new edge across from it would then not be locally Delaunay, and could not be
    /// flipped without putting a sliver between the segment's halves.
    fn fan_fits(&self, m: DVec2, e: &Encroached, interior: bool) -> bool {
        let beside = interior.then(|| beyond(self.s.across(e.triangle)[e.corner as usize]));
        self.work.cavity.is_disk()
            && self.sees_whole_rim(m, e.ends)
            && std::iter::once(e.triangle)
                .chain(beside)
                .all(|t| self.circle_holds(t, m))
    }

    /// Whether `m` lies inside or on the circumcircle of triangle `t`.
    fn circle_holds(&self, t: u32, m: DVec2) -> bool {
        let [a, b, c] = self.s.corners(t).map(|v| self.s.point(v));
        in_circle(a, b, c, m) != InCircle::Outside
    }

    /// Deletes the apex of wall `e`'s triangle while it is a free vertex (numbered from `first`
    /// on, on no wall) inside the wall's diametral circle; returns the wall's entry in the
    /// triangulation after.
    fn clear_diametral_circle(&mut self, mut e: Encroached, first: u32) -> Encroached {
        let (a, b) = (self.s.point(e.ends.0), self.s.point(e.ends.1));
        // A bound on the deletions in a row: each makes the wall's triangle larger.
        for _ in 0..MAX_DELETIONS_PER_SPLIT.min(self.deletions_left) {
            let v = self.s.corners(e.triangle)[e.corner as usize];
            let q = self.s.point(v);
            if v < first || self.s.segment_of(v) != NONE || (q - a).dot(q - b) >= 0.0 {
                break;
            }
            let Some(made) = self.delete_vertex(e.triangle, e.corner as usize) else {
                break;
            };
            self.deletions_left -= 1;
            let Some(wall) = made.iter().find_map(|&t| {
                let tri = self.s.triangle(t);
                (0..3)
                    .find(|&i| tri.edge(i) == e.ends)
                    .map(|i| (t, i as u8))
            }) else {
                unreachable!("the wall's side of the deleted vertex's star is a new triangle's");
            };
            (e.triangle, e.corner) = wall;
            for &t in &made {
                let found = inspection(&self.s, self.bounds, t);
                self.queue(found);
            }
        }
        e
    }

    /// Deletes the vertex at corner `k0` of triangle `t0` as [`fill_star`] empties it, freeing
    /// the two slots and the vertex left over. Returns the new triangles, or `None` with
    /// nothing changed.
    fn delete_vertex(&mut self, t0: u32, k0: usize) -> Option<Vec<u32>> {
        let emptied = fill_star(&mut self.s, t0, k0)?;
        for &spare in &emptied.spare {
            self.s.free_triangle(spare);
        }
        self.s.free_vertex(emptied.vertex);
        Some(emptied.made)
    }

    /// Whether `m`, splitting the wall `ends`, lies strictly left of every edge of the cavity's
    /// rim that stays (all but the boundary edges it lies on or splits): the fan from it is then
    /// a triangulation of the cavity.
    fn sees_whole_rim(&self, m: DVec2, ends: (u32, u32)) -> bool {
        self.work.cavity.rim().iter().all(|e| {
            let side = orientation(self.s.point(e.a), self.s.point(e.b), m);
            side == Orientation::Left
                || (e.outer == NONE && ((e.a, e.b) == ends || side == Orientation::On))
        })
    }

    /// The input segment the wall between `a` and `b` lies on ([`NONE`] for a hull side).
    fn segment_between(&self, (a, b): (u32, u32)) -> u32 {
        self.bounds
            .walls
            .as_ref()
            .map_or(NONE, |w| w.segment_of_edge(|v| self.s.segment_of(v), a, b))
    }
}

/// Üngör's off-center of triangle `id` whose shortest edge is opposite `corner`, or its
/// circumcenter when that is nearer the edge.
/// A vertex taken out of its star by [`fill_star`]: the triangles that fill the hole, and the
/// two slots of the star they left over.
pub(super) struct Emptied {
    pub vertex: u32,
    pub made: Vec<u32>,
    pub spare: Vec<u32>,
}

/// Takes the vertex at corner `k0` of triangle `t0` out of the triangulation where no wall
/// meets it and its star has at most [`MAX_DELETED_DEGREE`] triangles: the hole is filled by
/// the Delaunay triangulation of its rim (ears with no rim vertex strictly inside their
/// circumcircles, exact), in the star's first slots. The two slots left over are returned
/// unchanged for the caller to free; `None` with nothing changed.
pub(super) fn fill_star<S: Store>(s: &mut S, t0: u32, k0: usize) -> Option<Emptied> {
    let v = s.corners(t0)[k0];
    let ClosedStar {
        triangles: star,
        rim,
        outer,
    } = closed_star(s, t0, k0, MAX_DELETED_DEGREE)?;
    let ears = delaunay_ears(s, &rim)?;
    let region = s.region(t0);
    // The link across the rim edge from each position to the next one left: first the
    // outer triangles, then, past a cut ear (p, q, r), the ear across the diagonal p–r.
    let mut edge_link = outer;
    let mut made: Vec<u32> = Vec::with_capacity(ears.len());
    for (j, &(p, q, r)) in ears.iter().enumerate() {
        let slot = star[j];
        let last = j + 1 == ears.len();
        let (pq, qr) = (edge_link[p], edge_link[q]);
        let rp = if last { edge_link[r] } else { NONE };
        *s.corners_mut(slot) = [rim[p], rim[q], rim[r]];
        *s.across_mut(slot) = [qr, rp, pq];
        s.set_region(slot, region);
        for (link, corner) in [(qr, 0), (rp, 1), (pq, 2)] {
            link_back(s, link, slot, corner, &made);
        }
        edge_link[p] = slot;
        made.push(slot);
    }
    Some(Emptied {
        vertex: v,
        made,
        spare: star[ears.len()..].to_vec(),
    })
}

/// The star of a vertex walked counter-clockwise: triangle `i` is the vertex, `rim[i]` and
/// `rim[i + 1]`, and `outer[i]` the link across its edge opposite the vertex.
pub(super) struct ClosedStar {
    pub triangles: Vec<u32>,
    pub rim: Vec<u32>,
    pub outer: Vec<u32>,
}

/// The star of the vertex at corner `k0` of triangle `t0` when it closes around the vertex
/// with no wall at it and at most `max` triangles.
pub(super) fn closed_star<S: Store>(s: &S, t0: u32, k0: usize, max: usize) -> Option<ClosedStar> {
    let v = s.corners(t0)[k0];
    let mut star = ClosedStar {
        triangles: Vec::new(),
        rim: Vec::new(),
        outer: Vec::new(),
    };
    let (mut t, mut k) = (t0, k0);
    loop {
        let tri = s.triangle(t);
        let around = tri.n[NEXT[k]];
        if is_wall(around) || star.triangles.len() == max {
            return None;
        }
        star.triangles.push(t);
        star.rim.push(tri.v[NEXT[k]]);
        star.outer.push(tri.n[k]);
        t = around;
        k = s.corners(t).iter().position(|&c| c == v)?;
        if t == t0 {
            return Some(star);
        }
    }
}

/// Points the triangle across `link` back at new triangle `slot`, whose edge opposite
/// `corner` they share: an earlier new triangle (`made`), whose diagonal is opposite its
/// corner 1, or an outer one, which pointed at a star triangle.
fn link_back<S: Store>(s: &mut S, link: u32, slot: u32, corner: usize, made: &[u32]) {
    let other = beyond(link);
    if other == NONE {
        return;
    }
    if made.contains(&other) {
        s.across_mut(other)[1] = slot;
        return;
    }
    let (x, y) = s.triangle(slot).edge(corner);
    let far = s.triangle(other);
    let i = (0..3)
        .find(|&i| far.edge(i) == (y, x))
        .expect("the outer triangle shares the rim edge");
    let old = far.n[i];
    s.across_mut(other)[i] = slot | (old & SEGMENT);
}

pub(super) fn steiner_point<S: Store>(s: &S, bounds: &Bounds, id: u32, corner: usize) -> DVec2 {
    let tri = s.corners(id);
    let (p, q, r) = (
        s.point(tri[NEXT[corner]]),
        s.point(tri[PREV[corner]]),
        s.point(tri[corner]),
    );
    let d = q - p;
    let midpoint = p * 0.5 + q * 0.5;
    let centre = circumcenter(p, q, r);
    // Both lie on the edge's bisector, the apex's side: compare their heights over the edge.
    let height = (centre - midpoint).dot(d.perp()) / d.length_squared();
    if height > bounds.offset {
        midpoint + d.perp() * bounds.offset
    } else {
        centre
    }
}

/// The Steiner point of bad triangle `id`, whose shortest edge, of squared length
/// `shortest2`, is opposite `corner` ([`badness`]); or [`Error::RefinementResolution`] at the
/// triangle when it is not finite or that edge is shorter than [`MIN_GAP`] (the new point's
/// triangles would have exact in-circle products that underflow f64).
pub(super) fn resolvable_steiner_point<S: Store>(
    s: &S,
    bounds: &Bounds,
    id: u32,
    (corner, shortest2): (usize, f64),
) -> Result<DVec2, Error> {
    let p = steiner_point(s, bounds, id, corner);
    if !p.is_finite() || shortest2 < MIN_GAP * MIN_GAP {
        let c = s.corners(id).map(|v| s.point(v));
        let at = (c[0] + c[1] + c[2]) / 3.0;
        return Err(Error::resolution_at(at));
    }
    Ok(p)
}

/// Where a wall from `a` to `b` is split: its midpoint, or, with an acute corner between walls
/// at one end (`acute`, per end), the point on a power-of-two circle around it nearest the
/// midpoint; on an axis-parallel wall, with the side's constant coordinate kept bit for bit.
/// A piece shorter than [`MIN_GAP`] would underflow the in-circle products:
/// [`Error::RefinementResolution`] there.
pub(super) fn split_point(a: DVec2, b: DVec2, acute: (bool, bool)) -> Result<DVec2, Error> {
    let m = match acute {
        (true, false) => on_shell(a, b),
        (false, true) => on_shell(b, a),
        _ => a * 0.5 + b * 0.5,
    };
    let m = kept_on_axis(m, a, b);
    if m == a || m == b || m.distance(a).min(m.distance(b)) < MIN_GAP {
        return Err(Error::resolution_at(m));
    }
    Ok(m)
}

/// The midpoint of a wall from `a` to `b`, as [`split_point`] puts it without acute corners.
pub(super) fn midpoint(a: DVec2, b: DVec2) -> DVec2 {
    kept_on_axis(a * 0.5 + b * 0.5, a, b)
}

/// `m`, on the line from `a` to `b`, with the constant coordinate of an axis-parallel line.
fn kept_on_axis(mut m: DVec2, a: DVec2, b: DVec2) -> DVec2 {
    if a.x == b.x {
        m.x = a.x;
    } else if a.y == b.y {
        m.y = a.y;
    }
    m
}

/// Whether the entry's triangle is still in its slot.
pub(super) fn is_current<S: Store>(s: &S, q: &Queued) -> bool {
    newest(s.corners(q.triangle)) == q.newest
}

/// Whether the queued boundary edge is still there.
pub(super) fn is_live<S: Store>(s: &S, e: &Encroached) -> bool {
    let tri = s.triangle(e.triangle);
    is_wall(tri.n[e.corner as usize]) && tri.edge(e.corner as usize) == e.ends
}

/// Every bad triangle of a fresh triangulation, and every boundary edge its triangle's apex
/// encroaches on, found in parallel and listed in triangle order.
pub(super) fn inspect_all(t: &Triangulation, bounds: &Bounds) -> (Vec<Pending>, Vec<Encroached>) {
    let triangles = 0..t.len() as u32;
    let bad = triangles
        .clone()
        .into_par_iter()
        .filter_map(|id| inspection(t, bounds, id).bad)
        .collect();
    let edges = triangles
        .into_par_iter()
        .filter(|&id| t.across[id as usize].iter().any(|&n| is_wall(n)))
        .flat_map_iter(|id| inspection(t, bounds, id).encroached.into_iter().flatten())
        .collect();
    (bad, edges)
}

fn inspection<S: Store>(s: &S, bounds: &Bounds, id: u32) -> Inspection {
    let tri = s.triangle(id);
    let bad = measured_badness(s, bounds, id).map(|(_, shortest2, sin2)| Pending {
        class: SizeQueue::class_of(shortest2) as u32,
        entry: Queued {
            triangle: id,
            newest: newest(tri.v),
            rank: rank(sin2, place(bounds, s.point(tri.v[0]))),
        },
    });
    // Plain loops: `array::map` with a closure returning `Option` is a call per element here,
    // on the path every new triangle takes.
    let mut encroached = [None; 3];
    for (i, found) in encroached.iter_mut().enumerate() {
        if is_wall(tri.n[i]) && bounds.splits(tri.n[i]) {
            let ends = tri.edge(i);
            if encroaches(s, bounds, s.point(tri.v[i]), ends) {
                *found = Some(Encroached {
                    triangle: id,
                    corner: i as u8,
                    ends,
                });
            }
        }
    }
    Inspection { bad, encroached }
}

/// The most free vertices deleted before one wall split.
const MAX_DELETIONS_PER_SPLIT: usize = 16;

/// The largest star a free vertex is deleted from: stars are small in a quality mesh, and the
/// ear search takes time cubic in the star's size.
const MAX_DELETED_DEGREE: usize = 32;

/// The Delaunay triangulation of a deleted vertex's rim (`rim`, counter-clockwise, star-shaped
/// around where the vertex was), as ears in the order they are cut: each the positions
/// `(p, q, r)` of three consecutive rim vertices, counter-clockwise, with no other rim vertex
/// strictly inside its circumcircle, those already cut off included (else a later triangle
/// could hold one, across the diagonal that cut it, in its circle); the last ear is what
/// remains. `None` where no ear qualifies (not for the rim of a vertex of a Delaunay
/// triangulation).
fn delaunay_ears<S: Store>(s: &S, rim: &[u32]) -> Option<Vec<(usize, usize, usize)>> {
    let mut left: Vec<usize> = (0..rim.len()).collect();
    let mut ears = Vec::with_capacity(rim.len() - 2);
    while left.len() > 3 {
        let m = left.len();
        let ear = (0..m).find(|&i| {
            let (p, q, r) = (left[(i + m - 1) % m], left[i], left[(i + 1) % m]);
            let [a, b, c] = [p, q, r].map(|x| s.point(rim[x]));
            orientation(a, b, c) == Orientation::Left
                && (0..rim.len()).all(|x| {
                    x == p
                        || x == q
                        || x == r
                        || in_circle(a, b, c, s.point(rim[x])) != InCircle::Inside
                })
        })?;
        ears.push((left[(ear + m - 1) % m], left[ear], left[(ear + 1) % m]));
        left.remove(ear);
    }
    ears.push((left[0], left[1], left[2]));
    Some(ears)
}

/// Whether `p` lies in the diametral lens of the edge between vertices `ends` (Shewchuk's, as
/// Triangle uses): it sees the edge at 180° less twice the angle bound or more. A point outside
/// the lens makes no triangle on the edge worse than the bound; the lens is narrower than the
/// diametral circle, so fewer splits are made. Without an angle bound, the circle: 90° or more.
#[inline]
pub(super) fn encroaches<S: Store>(s: &S, bounds: &Bounds, p: DVec2, (a, b): (u32, u32)) -> bool {
    let (u, v) = (s.point(a) - p, s.point(b) - p);
    let dot = u.dot(v);
    dot <= 0.0 && dot * dot >= bounds.lens * u.length_squared() * v.length_squared()
}

/// The Morton key of point `p` on a 2^32 grid over the domain.
pub(super) fn place(bounds: &Bounds, p: DVec2) -> u64 {
    let g = (p - bounds.origin) * bounds.scale;
    interleave32(g.x as u32, g.y as u32)
}

/// For a bad triangle, the corner opposite its shortest edge and that edge's squared length.
pub(super) fn badness<S: Store>(s: &S, bounds: &Bounds, id: u32) -> Option<(usize, f64)> {
    measured_badness(s, bounds, id).map(|(corner, shortest2, _)| (corner, shortest2))
}

/// Where a bad triangle waits among those of its size class queued with it: smallest angle
/// first (`sin2`, the squared sine of its smallest angle, to 32 bits of mantissa), then in
/// Morton order (the top 20 bits of `place`), so that equal angles are fixed next to each
/// other. The worst triangle's Steiner point often clears its neighbours too: on graphs whose
/// segments bound wide areas, this leaves 6 % fewer triangles than Morton order alone.
fn rank(sin2: f64, place: u64) -> u64 {
    (sin2.to_bits() >> 20 << 20) | (place >> 44)
}

/// [`badness`], and the squared sine of the triangle's smallest angle.
#[inline]
fn measured_badness<S: Store>(s: &S, bounds: &Bounds, id: u32) -> Option<(usize, f64, f64)> {
    badness_against(s, bounds, id, bounds.sin2)
}

/// Whether triangle `id` meets the bounds with room against rounding: the squared sine of its
/// smallest angle a relative 1e-9 above the bound's (about 1e-8° at 33°; an angle measured in
/// degrees then meets the bound too), unless an input corner forces it; its area within its
/// region's bound.
pub(super) fn meets_bounds_firmly<S: Store>(s: &S, bounds: &Bounds, id: u32) -> bool {
    badness_against(s, bounds, id, bounds.sin2 * (1.0 + 1e-9)).is_none()
}

/// [`measured_badness`] against a squared sine of `sin2`.
#[inline]
fn badness_against<S: Store>(
    s: &S,
    bounds: &Bounds,
    id: u32,
    sin2: f64,
) -> Option<(usize, f64, f64)> {
    let c = s.corners(id);
    let v = [s.point(c[0]), s.point(c[1]), s.point(c[2])];
    let len2 = [
        v[1].distance_squared(v[2]),
        v[2].distance_squared(v[0]),
        v[0].distance_squared(v[1]),
    ];
    let shortest = (0..3)
        .min_by(|&i, &j| len2[i].total_cmp(&len2[j]))
        .expect("three edges");
    let area2 = (v[1] - v[0]).perp_dot(v[2] - v[0]);
    // The smallest angle faces the shortest edge, and its sine is twice the area over the
    // product of the two other sides.
    let others = len2[NEXT[shortest]] * len2[PREV[shortest]];
    let skinny = area2 * area2 < sin2 * others && !input_forced(s, bounds, c, v, shortest);
    let max_area2 = if bounds.region_area2.is_empty() {
        bounds.max_area2
    } else {
        bounds.max_area2_in(s.region(id))
    };
    (skinny || area2 > max_area2).then(|| (shortest, len2[shortest], area2 * area2 / others))
}

/// Whether the small angle of a skinny triangle (corners `c` at `v`, its shortest edge opposite
/// corner `shortest`) is forced by a corner between walls narrower than the bound: its
/// smallest angle lies in that corner, or its shortest edge spans it with its third corner no
/// further out (Shewchuk's rule).
fn input_forced<S: Store>(
    s: &S,
    bounds: &Bounds,
    c: [u32; 3],
    v: [DVec2; 3],
    shortest: usize,
) -> bool {
    let (apex, p, q) = (shortest, NEXT[shortest], PREV[shortest]);
    match &bounds.walls {
        None => {
            bounds.in_narrow_corner(c[apex] & !MARK)
                || bounds.spans_narrow_corner(v[p], v[q], v[apex])
        }
        Some(walls) => {
            let ids = c.map(|x| x & !MARK);
            walls.in_narrow_corner(ids[apex], v[apex], v[p], v[q])
                || walls
                    .spans_narrow_corner([s.segment_of(ids[p]), s.segment_of(ids[q])], [v[p], v[q]])
        }
    }
}

/// The point of segment `apex → other` at the power-of-two distance from `apex` nearest its
/// midpoint: between 0.35 and 0.71 of the way.
fn on_shell(apex: DVec2, other: DVec2) -> DVec2 {
    let length = apex.distance(other);
    let radius = 2f64.powf((length / 2.0).log2().round());
    apex + (other - apex) * (radius / length)
}

/// The largest vertex number among a triangle's corners.
pub(super) fn newest(corners: [u32; 3]) -> u32 {
    corners[0].max(corners[1]).max(corners[2])
}

/// How far, as a fraction of the height at which the new triangle would just meet the bound,
/// the off-center is put: nearer that height the new triangles are better shaped and fewer are
/// needed (Triangle's 95% leaves 0.5–1% more triangles at 20°–30°), but near the largest bounds
/// that refinement reaches, the slack keeps it finishing with the fewest triangles (at 33°, 98%
/// needs 0.3–1% more than 95%).
fn off_center_margin(min_angle_deg: f64) -> f64 {
    (0.98 - 0.01 * (min_angle_deg - 30.0)).clamp(0.95, 0.98)
}

/// The circumcenter of `p, q, r`, computed relative to `p` for accuracy.
fn circumcenter(p: DVec2, q: DVec2, r: DVec2) -> DVec2 {
    let (b, c) = (q - p, r - p);
    let d = 2.0 * b.perp_dot(c);
    let (b2, c2) = (b.length_squared(), c.length_squared());
    p + DVec2::new(c.y * b2 - b.y * c2, b.x * c2 - c.x * b2) / d
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::interior_angles_deg;

    fn bounds_of(outline: &[DVec2]) -> Bounds {
        let angles = interior_angles_deg(outline);
        let corners: Vec<(u32, DVec2, f64)> = (0..outline.len())
            .map(|k| (k as u32, outline[k], angles[k]))
            .collect();
        let options = RefineOptions {
            min_angle_deg: 20.0,
            ..RefineOptions::default()
        };
        let (lo, hi) = crate::morton::bounding_box(outline);
        Bounds::new(&options, lo, hi).with_corners(&corners)
    }

    #[test]
    fn a_point_is_on_a_narrow_corners_side_between_its_ends() {
        let outline = [DVec2::ZERO, DVec2::new(1.0, 0.0), DVec2::new(1.0, 0.01)];
        let bounds = bounds_of(&outline);
        let (p, q) = (DVec2::new(0.5, 0.0), DVec2::new(0.5, 0.005));
        assert!(bounds.spans_narrow_corner(p, q, DVec2::new(0.4, 0.002)));
        // Beyond a side's far end, in line with it: not on it.
        let beyond = DVec2::new(2.0, 0.0);
        assert!(!bounds.spans_narrow_corner(beyond, q, DVec2::new(0.4, 0.002)));
    }

    #[test]
    fn points_near_each_other_far_from_a_narrow_corner_are_not_on_both_its_sides() {
        // Seen from a corner 8e49 away, differences round the three other corners to one
        // direction.
        let outline = [
            DVec2::new(-5.630_506_713_171_445e49, -5.630_506_717_317_518e49),
            DVec2::new(-3.988_095_257_061_079_7e-16, -3.571_761_622_850_442e-16),
            DVec2::new(7.738_694_5e-317, 1.295_163e-318),
            DVec2::new(2.634_172_311_275_772_3e-178, 98_303.999_999_624_14),
        ];
        let bounds = bounds_of(&outline);
        assert!(bounds.in_narrow_corner(0));
        assert!(!bounds.spans_narrow_corner(outline[1], outline[2], outline[3]));
    }

    #[test]
    fn a_class_is_fixed_worst_angle_first_then_in_place_order() {
        let sin2 = |deg: f64| deg.to_radians().sin().powi(2);
        // The smaller angle first, whatever the places.
        assert!(rank(sin2(10.0), u64::MAX) < rank(sin2(10.5), 0));
        assert!(rank(sin2(29.9), u64::MAX) < rank(sin2(29.95), 0));
        // The same angle: by place.
        assert!(rank(sin2(20.0), 1 << 60) < rank(sin2(20.0), 2 << 60));
        // Through the queue: a class pops by rank.
        let mut queue = SizeQueue::new();
        for (t, deg) in [(0, 25.0), (1, 5.0), (2, 15.0)] {
            let entry = Queued {
                triangle: t,
                newest: t,
                rank: rank(sin2(deg), u64::from(t) << 40),
            };
            queue.push(SizeQueue::class_of(1.0), entry);
        }
        let order: Vec<u32> = std::iter::from_fn(|| queue.pop())
            .map(|(_, e)| e.triangle)
            .collect();
        assert_eq!(order, vec![1, 2, 0]);
    }
}
