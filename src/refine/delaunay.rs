//! A Delaunay triangulation of a rectangle's corners and points inside it, kept Delaunay under
//! point insertion by Bowyer–Watson cavities with exact predicates.
//!
//! Refinement needs to look at a cavity before committing to it (an off-center that would
//! encroach on a boundary edge is not inserted), which is why insertion is split into
//! [`Triangulation::locate`], [`Triangulation::dig`] and [`Triangulation::commit`].

use glam::DVec2;

use crate::mesh::NONE;
use crate::predicates::{InCircle, Orientation, in_circle, orientation};

/// Corner `i + 1` and corner `i + 2` of a triangle: the ends of the edge opposite corner `i`.
pub(crate) const NEXT: [usize; 3] = [1, 2, 0];
pub(crate) const PREV: [usize; 3] = [2, 0, 1];

/// A triangle: corners counter-clockwise and the triangle across the edge opposite each corner
/// ([`NONE`] on the rectangle's boundary).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Triangle {
    pub v: [u32; 3],
    pub n: [u32; 3],
}

impl Triangle {
    /// The ends of the edge opposite corner `i`, counter-clockwise around the triangle.
    #[inline]
    pub fn edge(&self, i: usize) -> (u32, u32) {
        (self.v[NEXT[i]], self.v[PREV[i]])
    }
}

/// Where a point lies in the triangulation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Location {
    /// In this triangle, its boundary included, and on none of its corners.
    Inside(u32),
    /// On this vertex.
    Vertex(u32),
    /// Outside the rectangle, beyond the boundary edge opposite corner `edge` of `triangle`.
    Outside { triangle: u32, edge: usize },
    /// Beyond the triangles the store may change.
    Foreign,
}

/// An edge of a cavity's boundary, the cavity on its left: `a → b`, the triangle `outer` beyond
/// it, and the cavity triangle `inner` whose edge opposite corner `corner` it is.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RimEdge {
    pub a: u32,
    pub b: u32,
    pub outer: u32,
    pub inner: u32,
    pub corner: u8,
}

/// Marks, in the high bit of a triangle's first corner, a triangle of the current cavity, and in
/// that of its second corner, one the current cavity search tested and left out. Keeping the
/// marks in the corners the search reads anyway saves an array and its cache misses; it limits
/// vertex numbers to 31 bits.
pub(crate) const MARK: u32 = 1 << 31;

/// The most vertices a triangulation may have (its triangles, about twice as many, must stay
/// below [`SEGMENT`]).
pub(crate) const MAX_VERTICES: usize = (MARK as usize >> 1) - 1;

/// Marks, in the high bit of a link in `across`, an edge on an input segment: a wall that
/// cavities and walks stop at and flips leave alone, with a triangle beyond it. [`NONE`] has
/// the bit too: the domain's boundary is a wall with nothing beyond.
pub(crate) const SEGMENT: u32 = 1 << 31;

/// Whether the link `n` crosses a wall: a segment or the boundary.
#[inline]
pub(crate) fn is_wall(n: u32) -> bool {
    n & SEGMENT != 0
}

/// The triangle link `n` leads to, segment or not ([`NONE`] beyond the boundary).
#[inline]
pub(crate) fn beyond(n: u32) -> u32 {
    if n == NONE { NONE } else { n & !SEGMENT }
}

/// Where an insertion reads and writes vertices and triangles, and which triangles it may
/// change: all of them in a whole triangulation, those of its own region in a tile that is
/// refined alongside others.
pub(crate) trait Store {
    /// Whether every triangle may be changed; a walk that gets lost may then scan them all.
    const WHOLE: bool;

    /// Vertex `v`'s position; `v` may carry [`MARK`].
    fn point(&self, v: u32) -> DVec2;
    fn corners(&self, t: u32) -> [u32; 3];
    fn corners_mut(&mut self, t: u32) -> &mut [u32; 3];
    fn across(&self, t: u32) -> [u32; 3];
    fn across_mut(&mut self, t: u32) -> &mut [u32; 3];
    /// Adds a vertex at `p` and returns its number, above every vertex of the triangles this
    /// store may change.
    fn push_vertex(&mut self, p: DVec2) -> u32;
    /// A fresh triangle slot.
    fn push_triangle(&mut self) -> u32;
    /// Whether an insertion may replace or relink the triangle with these corners (marks
    /// allowed). Only asked of triangles next to ones it may change.
    fn may_change(&self, corners: [u32; 3]) -> bool;
    /// Triangles so far: a bound on the length of any walk.
    fn triangle_count(&self) -> usize;
    /// Vertices so far, for the vertex budget of a whole triangulation.
    fn vertex_count(&self) -> usize;
    /// Whether one more insertion fits in the room this store was given.
    fn room(&self) -> bool;
    /// Whether this store keeps each triangle's region.
    #[inline]
    fn keeps_regions(&self) -> bool {
        false
    }
    /// The region of triangle `t` ([`NONE`] where regions are not kept).
    #[inline]
    fn region(&self, _t: u32) -> u32 {
        NONE
    }
    /// Puts triangle `t` in region `r`, where regions are kept.
    #[inline]
    fn set_region(&mut self, _t: u32, _r: u32) {}
    /// The input segment that Steiner vertex `v` was put on ([`NONE`] for none, or where
    /// segments are not kept).
    #[inline]
    fn segment_of(&self, _v: u32) -> u32 {
        NONE
    }
    /// Notes that vertex `v` lies on input segment `segment`, where segments are kept.
    #[inline]
    fn set_segment_of(&mut self, _v: u32, _segment: u32) {}
    /// Whether in-circle ties are broken by [`perturbed_inside`].
    #[inline]
    fn canonical(&self) -> bool {
        false
    }
    /// Gives back the slot of a triangle a vertex deletion removed, for a later insertion.
    /// Only a whole triangulation deletes vertices.
    fn free_triangle(&mut self, _t: u32) {
        unreachable!("only a whole triangulation deletes vertices")
    }
    /// Notes that vertex `v` is a corner of no triangle any more.
    fn free_vertex(&mut self, _v: u32) {
        unreachable!("only a whole triangulation deletes vertices")
    }
    /// Whether slot `t` holds no triangle.
    #[inline]
    fn is_free(&self, _t: u32) -> bool {
        false
    }

    /// Triangle `t` (outside a cavity search).
    #[inline]
    fn triangle(&self, t: u32) -> Triangle {
        Triangle {
            v: self.corners(t),
            n: self.across(t),
        }
    }
}

/// The triangulation: corners and neighbours in separate arrays, the layout
/// [`crate::mesh::Mesh`] takes over without a copy.
#[derive(Clone, Debug)]
pub(crate) struct Triangulation {
    pub vertices: Vec<DVec2>,
    pub corners: Vec<[u32; 3]>,
    pub across: Vec<[u32; 3]>,
    /// Per triangle, its region; empty where regions are not kept.
    pub regions: Vec<u32>,
    /// Per vertex, the input segment it was put on; empty where segments are not kept.
    pub segment_of: Vec<u32>,
    /// Whether cocircular points are told apart by [`perturbed_inside`], so that the
    /// triangulation of a point set is one and the same whatever the order of insertion.
    pub canonical: bool,
    /// Slots a vertex deletion freed ([`FREE`] corners), reused by the next new triangles.
    pub free_slots: Vec<u32>,
    /// Vertices deleted since the arrays were last packed.
    pub freed_vertices: Vec<u32>,
    /// Vertices deleted in all.
    pub vertices_deleted: usize,
}

/// The corners of a slot that holds no triangle: no vertex has this number.
pub(crate) const FREE: u32 = MARK - 1;

impl Triangulation {
    /// The rectangle `[lo, hi]` as two triangles; its corners are vertices 0 to 3,
    /// counter-clockwise from `lo`.
    pub fn rectangle(lo: DVec2, hi: DVec2) -> Self {
        Triangulation {
            vertices: vec![lo, DVec2::new(hi.x, lo.y), hi, DVec2::new(lo.x, hi.y)],
            corners: vec![[0, 1, 2], [0, 2, 3]],
            across: vec![[NONE, 1, NONE], [NONE, NONE, 0]],
            regions: Vec::new(),
            segment_of: Vec::new(),
            canonical: false,
            free_slots: Vec::new(),
            freed_vertices: Vec::new(),
            vertices_deleted: 0,
        }
    }

    /// Makes room for `vertices` vertices in all and their triangles, touching the memory of
    /// the first `touched` of them in parallel.
    pub fn reserve(&mut self, vertices: usize, touched: usize) {
        fn grow<T: Copy + Send + Sync>(v: &mut Vec<T>, n: usize, touched: usize, fill: T) {
            if n > v.capacity() {
                let mut bigger = crate::par::prefaulted_within(n, touched, fill);
                bigger.extend_from_slice(v);
                *v = bigger;
            }
        }
        grow(&mut self.vertices, vertices, touched, DVec2::ZERO);
        grow(&mut self.corners, 2 * vertices, 2 * touched, [0; 3]);
        grow(&mut self.across, 2 * vertices, 2 * touched, [NONE; 3]);
    }

    /// Triangles so far.
    pub fn len(&self) -> usize {
        self.corners.len()
    }

    /// Drops the slots and vertices deletions freed, keeping the order of the others.
    pub fn pack(&mut self) {
        if !self.free_slots.is_empty() {
            let kept: Vec<u32> = (0..self.corners.len() as u32)
                .filter(|&t| self.corners[t as usize][0] != FREE)
                .collect();
            let mut renumber = vec![NONE; self.corners.len()];
            for (new, &old) in kept.iter().enumerate() {
                renumber[old as usize] = new as u32;
            }
            let link = |n: u32| match n {
                NONE => NONE,
                n => renumber[beyond(n) as usize] | (n & SEGMENT),
            };
            self.across = kept
                .iter()
                .map(|&t| self.across[t as usize].map(link))
                .collect();
            self.corners = kept.iter().map(|&t| self.corners[t as usize]).collect();
            if !self.regions.is_empty() {
                self.regions = kept.iter().map(|&t| self.regions[t as usize]).collect();
            }
            self.free_slots.clear();
        }
        if !self.freed_vertices.is_empty() {
            let mut gone = vec![false; self.vertices.len()];
            for &v in &self.freed_vertices {
                gone[v as usize] = true;
            }
            let mut renumber = vec![NONE; self.vertices.len()];
            let mut next = 0;
            for (v, &g) in gone.iter().enumerate() {
                if !g {
                    renumber[v] = next;
                    next += 1;
                }
            }
            for c in &mut self.corners {
                *c = c.map(|v| renumber[v as usize]);
            }
            let keep = |v: &usize| !gone[*v];
            self.vertices = (0..self.vertices.len())
                .filter(keep)
                .map(|v| self.vertices[v])
                .collect();
            if !self.segment_of.is_empty() {
                self.segment_of = (0..self.segment_of.len())
                    .filter(keep)
                    .map(|v| self.segment_of[v])
                    .collect();
            }
            self.freed_vertices.clear();
        }
    }

    /// Inserts `points`, each walking from the triangles the last one made; a point on a
    /// corner of the rectangle is there already. Returns the first point that lies on no
    /// triangle's inside or edge (outside the rectangle, or on another vertex).
    pub fn insert_all(&mut self, points: impl IntoIterator<Item = DVec2>) -> Result<(), DVec2> {
        let mut cavity = Cavity::default();
        let mut hint = 0;
        for p in points {
            match locate(self, p, hint) {
                Location::Inside(start) => {
                    cavity.dig(self, p, start);
                    cavity.commit(self, p, None);
                    hint = cavity.created()[0];
                }
                Location::Vertex(v) if v < 4 => {}
                _ => return Err(p),
            }
        }
        Ok(())
    }

    /// Flips edges until every one is locally Delaunay, starting from the edges opposite the
    /// given corners (`(triangle, corner)`): Lawson's flips, each of which replaces an edge whose
    /// far apex lies strictly inside the circumcircle, checking the four edges around it again.
    pub fn flip_to_delaunay(&mut self, edges: Vec<(u32, usize)>) {
        self.flip_to_delaunay_within(edges, usize::MAX);
    }

    /// As [`Self::flip_to_delaunay`], giving up (`false`) after `budget` flips.
    pub fn flip_to_delaunay_within(&mut self, edges: Vec<(u32, usize)>, budget: usize) -> bool {
        flip_to_delaunay_in(self, edges, budget)
    }

    /// The corner of triangle `u` opposite its edge shared with triangle `t`.
    pub(super) fn corner_facing(&self, u: u32, t: u32) -> usize {
        corner_facing_in(self, u, t)
    }

    /// The corner of triangle `u` opposite its edge shared with triangle `t`, if `u` links back
    /// to `t`.
    pub(super) fn linked_corner(&self, u: u32, t: u32) -> Option<usize> {
        linked_corner_in(self, u, t)
    }

    /// Replaces the edge between triangle `t` (corners `a b c`, the edge opposite corner `i`,
    /// `a` there) and triangle `u` (apex `w` at corner `j`) by the edge `a w`: `t` becomes
    /// `a b w` and `u` becomes `w c a`, each with the new edge opposite corner 1.
    pub(super) fn flip(&mut self, t: u32, i: usize, u: u32, j: usize) {
        flip_in(self, t, i, u, j);
    }
}

/// [`Triangulation::flip`] in any store.
pub(super) fn flip_in<S: Store>(s: &mut S, t: u32, i: usize, u: u32, j: usize) {
    let [a, b, c] = [i, NEXT[i], PREV[i]].map(|k| s.corners(t)[k]);
    let w = s.corners(u)[j];
    // Across a b (opposite c in t), c a (opposite b in t), b w (opposite c in u, whose
    // corners run c b w from corner NEXT[j]) and w c (opposite b in u).
    let n_ab = s.across(t)[PREV[i]];
    let n_ca = s.across(t)[NEXT[i]];
    let n_bw = s.across(u)[NEXT[j]];
    let n_wc = s.across(u)[PREV[j]];
    *s.corners_mut(t) = [a, b, w];
    *s.across_mut(t) = [n_bw, u, n_ab];
    *s.corners_mut(u) = [w, c, a];
    *s.across_mut(u) = [n_ca, t, n_wc];
    relink_in(s, n_bw, u, t);
    relink_in(s, n_ca, t, u);
}

/// Points triangle `n`'s link to `from` at `to` instead (`n` a link, which keeps its segment
/// mark).
fn relink_in<S: Store>(s: &mut S, n: u32, from: u32, to: u32) {
    if n != NONE {
        let n = beyond(n);
        let k = corner_facing_in(s, n, from);
        let link = &mut s.across_mut(n)[k];
        *link = to | (*link & SEGMENT);
    }
}

/// [`Triangulation::flip_to_delaunay_within`] in any store (a journaling one saves each
/// triangle a flip changes).
pub(super) fn flip_to_delaunay_in<S: Store>(
    s: &mut S,
    mut edges: Vec<(u32, usize)>,
    budget: usize,
) -> bool {
    let mut flips = 0;
    while let Some((t, i)) = edges.pop() {
        let u = s.across(t)[i];
        if is_wall(u) {
            continue;
        }
        let j = corner_facing_in(s, u, t);
        let far = s.point(s.corners(u)[j]);
        if !in_circumcircle(s, t, far) {
            continue;
        }
        if flips == budget {
            return false;
        }
        flips += 1;
        flip_in(s, t, i, u, j);
        edges.extend([(t, 0), (t, 2), (u, 0), (u, 2)]);
    }
    true
}

/// The corner of triangle `u` opposite its edge shared with triangle `t`.
pub(super) fn corner_facing_in<S: Store>(s: &S, u: u32, t: u32) -> usize {
    linked_corner_in(s, u, t).expect("neighbours link each other")
}

/// The corner of triangle `u` opposite its edge shared with triangle `t`, if `u` links back to
/// `t`.
fn linked_corner_in<S: Store>(s: &S, u: u32, t: u32) -> Option<usize> {
    (0..3).find(|&j| beyond(s.across(u)[j]) == t)
}

impl Store for Triangulation {
    const WHOLE: bool = true;

    #[inline]
    fn point(&self, v: u32) -> DVec2 {
        self.vertices[(v & !MARK) as usize]
    }
    #[inline]
    fn corners(&self, t: u32) -> [u32; 3] {
        self.corners[t as usize]
    }
    #[inline]
    fn corners_mut(&mut self, t: u32) -> &mut [u32; 3] {
        &mut self.corners[t as usize]
    }
    #[inline]
    fn across(&self, t: u32) -> [u32; 3] {
        self.across[t as usize]
    }
    #[inline]
    fn across_mut(&mut self, t: u32) -> &mut [u32; 3] {
        &mut self.across[t as usize]
    }
    #[inline]
    fn push_vertex(&mut self, p: DVec2) -> u32 {
        self.vertices.push(p);
        if !self.segment_of.is_empty() {
            self.segment_of.push(NONE);
        }
        (self.vertices.len() - 1) as u32
    }
    #[inline]
    fn push_triangle(&mut self) -> u32 {
        if let Some(t) = self.free_slots.pop() {
            self.corners[t as usize] = [0; 3];
            self.across[t as usize] = [NONE; 3];
            self.set_region(t, NONE);
            return t;
        }
        self.corners.push([0; 3]);
        self.across.push([NONE; 3]);
        if !self.regions.is_empty() {
            self.regions.push(NONE);
        }
        (self.corners.len() - 1) as u32
    }
    #[inline]
    fn may_change(&self, _corners: [u32; 3]) -> bool {
        true
    }
    #[inline]
    fn triangle_count(&self) -> usize {
        self.corners.len()
    }
    fn vertex_count(&self) -> usize {
        self.vertices.len() - self.freed_vertices.len()
    }
    fn room(&self) -> bool {
        true
    }
    #[inline]
    fn keeps_regions(&self) -> bool {
        !self.regions.is_empty()
    }
    #[inline]
    fn region(&self, t: u32) -> u32 {
        self.regions.get(t as usize).copied().unwrap_or(NONE)
    }
    #[inline]
    fn set_region(&mut self, t: u32, r: u32) {
        if let Some(slot) = self.regions.get_mut(t as usize) {
            *slot = r;
        }
    }
    #[inline]
    fn segment_of(&self, v: u32) -> u32 {
        self.segment_of.get(v as usize).copied().unwrap_or(NONE)
    }
    #[inline]
    fn set_segment_of(&mut self, v: u32, segment: u32) {
        if let Some(slot) = self.segment_of.get_mut(v as usize) {
            *slot = segment;
        }
    }
    #[inline]
    fn canonical(&self) -> bool {
        self.canonical
    }
    fn free_triangle(&mut self, t: u32) {
        self.corners[t as usize] = [FREE; 3];
        self.across[t as usize] = [NONE; 3];
        self.free_slots.push(t);
    }
    fn free_vertex(&mut self, v: u32) {
        self.freed_vertices.push(v);
        self.vertices_deleted += 1;
    }
    #[inline]
    fn is_free(&self, t: u32) -> bool {
        self.corners[t as usize][0] == FREE
    }
}

impl<S: Store> Store for &mut S {
    const WHOLE: bool = S::WHOLE;

    #[inline]
    fn point(&self, v: u32) -> DVec2 {
        (**self).point(v)
    }
    #[inline]
    fn corners(&self, t: u32) -> [u32; 3] {
        (**self).corners(t)
    }
    #[inline]
    fn corners_mut(&mut self, t: u32) -> &mut [u32; 3] {
        (**self).corners_mut(t)
    }
    #[inline]
    fn across(&self, t: u32) -> [u32; 3] {
        (**self).across(t)
    }
    #[inline]
    fn across_mut(&mut self, t: u32) -> &mut [u32; 3] {
        (**self).across_mut(t)
    }
    #[inline]
    fn push_vertex(&mut self, p: DVec2) -> u32 {
        (**self).push_vertex(p)
    }
    #[inline]
    fn push_triangle(&mut self) -> u32 {
        (**self).push_triangle()
    }
    #[inline]
    fn may_change(&self, corners: [u32; 3]) -> bool {
        (**self).may_change(corners)
    }
    #[inline]
    fn triangle_count(&self) -> usize {
        (**self).triangle_count()
    }
    fn vertex_count(&self) -> usize {
        (**self).vertex_count()
    }
    fn room(&self) -> bool {
        (**self).room()
    }
    #[inline]
    fn keeps_regions(&self) -> bool {
        (**self).keeps_regions()
    }
    #[inline]
    fn region(&self, t: u32) -> u32 {
        (**self).region(t)
    }
    #[inline]
    fn set_region(&mut self, t: u32, r: u32) {
        (**self).set_region(t, r);
    }
    #[inline]
    fn segment_of(&self, v: u32) -> u32 {
        (**self).segment_of(v)
    }
    #[inline]
    fn set_segment_of(&mut self, v: u32, segment: u32) {
        (**self).set_segment_of(v, segment);
    }
    #[inline]
    fn canonical(&self) -> bool {
        (**self).canonical()
    }
    fn free_triangle(&mut self, t: u32) {
        (**self).free_triangle(t);
    }
    fn free_vertex(&mut self, v: u32) {
        (**self).free_vertex(v);
    }
    #[inline]
    fn is_free(&self, t: u32) -> bool {
        (**self).is_free(t)
    }
}

/// Locates `p` by a visibility walk from triangle `start`, which stops at walls: a point
/// beyond a segment is reported [`Location::Outside`] that segment, as one beyond the
/// boundary is. The walk ends on a Delaunay triangulation whatever edge it takes; a step
/// count guards against a bug turning that into a hang, falling back to a scan of every
/// triangle where the store holds them all. In a store that may change only some triangles,
/// the walk stops where it would leave them.
pub(crate) fn locate<S: Store>(s: &S, p: DVec2, start: u32) -> Location {
    walk(s, p, start, false)
}

/// Locates `p` as [`locate`] does, walking across segments; only the boundary stops it.
pub(crate) fn locate_across_segments<S: Store>(s: &S, p: DVec2, start: u32) -> Location {
    walk(s, p, start, true)
}

fn walk<S: Store>(s: &S, p: DVec2, start: u32, across_segments: bool) -> Location {
    let mut t = start;
    let mut came_from = NONE;
    for _ in 0..=s.triangle_count() {
        match step(s, p, t, came_from) {
            Step::Found => return found(s, p, t),
            Step::Leave(i) => {
                let link = s.across(t)[i];
                let next = beyond(link);
                if next == NONE || (is_wall(link) && !across_segments) {
                    return Location::Outside {
                        triangle: t,
                        edge: i,
                    };
                }
                if !S::WHOLE && !s.may_change(s.corners(next)) {
                    return Location::Foreign;
                }
                came_from = t;
                t = next;
            }
        }
    }
    if S::WHOLE {
        locate_by_scan(s, p)
    } else {
        Location::Foreign
    }
}

/// The first edge of `t` that has `p` strictly on its far side, skipping the edge the walk came
/// in by.
#[inline]
fn step<S: Store>(s: &S, p: DVec2, t: u32, came_from: u32) -> Step {
    let tri = s.triangle(t);
    for i in 0..3 {
        if beyond(tri.n[i]) == came_from && came_from != NONE {
            continue;
        }
        let (a, b) = tri.edge(i);
        if orientation(s.point(a), s.point(b), p) == Orientation::Right {
            return Step::Leave(i);
        }
    }
    Step::Found
}

fn found<S: Store>(s: &S, p: DVec2, t: u32) -> Location {
    match s.corners(t).iter().find(|&&v| s.point(v) == p) {
        Some(&v) => Location::Vertex(v),
        None => Location::Inside(t),
    }
}

fn locate_by_scan<S: Store>(s: &S, p: DVec2) -> Location {
    let triangles = (0..s.triangle_count() as u32).filter(|&t| !s.is_free(t));
    if let Some(t) = triangles
        .clone()
        .find(|&t| matches!(step(s, p, t, NONE), Step::Found))
    {
        return found(s, p, t);
    }
    let (t, i) = triangles
        .flat_map(|t| (0..3).map(move |i| (t, i)))
        .find(|&(t, i)| {
            let tri = s.triangle(t);
            let (a, b) = tri.edge(i);
            tri.n[i] == NONE && orientation(s.point(a), s.point(b), p) == Orientation::Right
        })
        .expect("a point in no triangle lies beyond some boundary edge");
    Location::Outside {
        triangle: t,
        edge: i,
    }
}

/// Whether `p` lies strictly inside the circumcircle of triangle `t`; exact. In a canonical
/// store, a point on the circle counts as inside or not by [`perturbed_inside`].
#[inline]
pub(crate) fn in_circumcircle<S: Store>(s: &S, t: u32, p: DVec2) -> bool {
    let v = s.corners(t);
    let (a, b, c) = (s.point(v[0]), s.point(v[1]), s.point(v[2]));
    match in_circle(a, b, c, p) {
        InCircle::Inside => true,
        InCircle::Outside => false,
        InCircle::On => s.canonical() && perturbed_inside(a, b, c, p),
    }
}

/// Whether `d`, on the circle through `a`, `b`, `c` (counter-clockwise), counts as inside it
/// once each point's lift onto the paraboloid is raised by an infinitesimal that is larger the
/// earlier the point comes in (x, y) order (simulation of simplicity). Raising `d` puts it
/// outside; raising a corner tips the circle's plane up over `d` when `d` lies on that
/// corner's side of the opposite edge. The earliest of the four points decides, and four
/// distinct cocircular points have no three in line, so it always does. Every triangulation
/// built with this rule is the Delaunay triangulation of the raised points: one for a set of
/// points, whatever the order they came in.
pub(crate) fn perturbed_inside(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> bool {
    let earlier = |p: DVec2, q: DVec2| (p.x, p.y) < (q.x, q.y);
    let first = [a, b, c]
        .into_iter()
        .enumerate()
        .fold(
            (3, d),
            |(k, m), (i, p)| if earlier(p, m) { (i, p) } else { (k, m) },
        )
        .0;
    match first {
        0 => orientation(b, c, d) == Orientation::Left,
        1 => orientation(c, a, d) == Orientation::Left,
        2 => orientation(a, b, d) == Orientation::Left,
        _ => false,
    }
}

/// The scratch space of insertions: the cavity of the point being inserted, its rim, and the
/// triangles the last insertion made.
#[derive(Clone, Debug, Default)]
pub(crate) struct Cavity {
    triangles: Vec<u32>,
    left_out: Vec<u32>,
    rim: Vec<RimEdge>,
    created: Vec<u32>,
    /// Per rim edge, the rim edge that starts where it ends ([`NONE`] for none).
    after: Vec<u32>,
    /// Rim edges by their first vertex: an open-addressing table.
    by_start: Vec<u32>,
    /// The region of each rim edge's cavity triangle, read before the slots are reused.
    rim_regions: Vec<u32>,
}

/// A wall edge an insertion splits: its ends as the cavity triangle that holds it has them,
/// and whether a triangle lies beyond it (an input segment inside the domain).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Split {
    pub ends: (u32, u32),
    pub interior: bool,
}

impl Cavity {
    /// Finds the cavity of `p`, which lies in triangle `t` (from [`locate`]): the triangles
    /// whose circumcircle strictly contains `p`, a connected set around `t`. Nothing changes
    /// until [`Self::commit`]; [`Self::abandon`] drops the cavity instead. Returns false, with
    /// nothing changed, when the cavity reaches a triangle the store may not change.
    pub fn dig<S: Store>(&mut self, s: &mut S, p: DVec2, t: u32) -> bool {
        self.dig_through(s, p, t, None)
    }

    /// Finds the cavity of `p` as [`Self::dig`] does, where `p` splits the segment `split`
    /// (its ends as a cavity triangle has them): the triangle beyond it joins the cavity.
    pub fn dig_through<S: Store>(
        &mut self,
        s: &mut S,
        p: DVec2,
        t: u32,
        split: Option<(u32, u32)>,
    ) -> bool {
        self.triangles.clear();
        self.left_out.clear();
        self.rim.clear();
        s.corners_mut(t)[0] |= MARK;
        self.triangles.push(t);
        let mut k = 0;
        while k < self.triangles.len() {
            let c = self.triangles[k];
            k += 1;
            let tri = s.triangle(c);
            for i in 0..3 {
                let o = tri.n[i];
                let (a, b) = tri.edge(i);
                let splits = o != NONE
                    && split.is_some_and(|(x, y)| {
                        let (a, b) = (a & !MARK, b & !MARK);
                        (a, b) == (x, y) || (a, b) == (y, x)
                    });
                if splits {
                    if !S::WHOLE && !s.may_change(s.corners(beyond(o))) {
                        self.abandon(s);
                        return false;
                    }
                    self.force_join(s, beyond(o));
                    continue;
                }
                if !is_wall(o) {
                    match self.joins(s, o, p) {
                        Joins::Yes => continue,
                        Joins::No => {}
                        Joins::Foreign => {
                            self.abandon(s);
                            return false;
                        }
                    }
                }
                self.rim.push(RimEdge {
                    a: a & !MARK,
                    b: b & !MARK,
                    outer: o,
                    inner: c,
                    corner: i as u8,
                });
            }
        }
        true
    }

    /// Puts triangle `o`, beyond the segment being split, in the cavity: the split point lies
    /// on their shared edge, inside its circumcircle but for rounding.
    fn force_join<S: Store>(&mut self, s: &mut S, o: u32) {
        let corners = s.corners(o);
        if corners[0] & MARK != 0 {
            return;
        }
        if corners[1] & MARK != 0 {
            s.corners_mut(o)[1] &= !MARK;
            self.left_out.retain(|&t| t != o);
        }
        s.corners_mut(o)[0] |= MARK;
        self.triangles.push(o);
    }

    /// Whether triangle `o`, next to the cavity, is (now) in it; marks it either way.
    #[inline]
    fn joins<S: Store>(&mut self, s: &mut S, o: u32, p: DVec2) -> Joins {
        let corners = s.corners(o);
        if corners[0] & MARK != 0 {
            return Joins::Yes;
        }
        if corners[1] & MARK != 0 {
            return Joins::No;
        }
        if in_circumcircle(s, o, p) {
            if !s.may_change(corners) {
                return Joins::Foreign;
            }
            s.corners_mut(o)[0] |= MARK;
            self.triangles.push(o);
            Joins::Yes
        } else {
            s.corners_mut(o)[1] |= MARK;
            self.left_out.push(o);
            Joins::No
        }
    }

    /// The triangles of the cavity [`Self::dig`] last found (the first corner of each carries
    /// [`MARK`] until the cavity is committed or abandoned).
    pub fn dug(&self) -> &[u32] {
        &self.triangles
    }

    /// The boundary of the cavity [`Self::dig`] last found.
    pub fn rim(&self) -> &[RimEdge] {
        &self.rim
    }

    /// Whether the cavity [`Self::dig`] last found is a disk with every vertex on its rim: a
    /// triangulated polygon has two rim edges more than triangles, one with a vertex inside or
    /// a hole fewer. Rounding can make a cavity otherwise (a split point within rounding of a
    /// vertex), and then a fan from the point would drop that vertex or overlap the hole.
    pub fn is_disk(&self) -> bool {
        self.rim.len() == self.triangles.len() + 2
    }

    /// Drops the cavity [`Self::dig`] last found, leaving the triangulation as it was.
    pub fn abandon<S: Store>(&mut self, s: &mut S) {
        for &t in &self.triangles {
            s.corners_mut(t)[0] &= !MARK;
        }
        self.clear_left_out(s);
    }

    fn clear_left_out<S: Store>(&mut self, s: &mut S) {
        for &t in &self.left_out {
            s.corners_mut(t)[1] &= !MARK;
        }
    }

    /// Inserts `p` into the cavity [`Self::dig`] last found for it: the cavity's triangles are
    /// replaced by a fan from `p`. A boundary edge that `p` lies on is split, and so is the
    /// wall `split` if given (`p` is its rounded midpoint, which may lie a rounding off its
    /// line): a boundary edge drops out of the rim, and an interior segment's two halves
    /// become segments. Returns the new vertex; [`Self::created`] lists the new triangles.
    pub fn commit<S: Store>(&mut self, s: &mut S, p: DVec2, split: Option<Split>) -> u32 {
        self.clear_left_out(s);
        let v = s.push_vertex(p);
        let boundary_split = split.filter(|x| !x.interior).map(|x| x.ends);
        self.rim.retain(|e| {
            e.outer != NONE
                || (Some((e.a, e.b)) != boundary_split
                    && orientation(s.point(e.a), s.point(e.b), p) != Orientation::On)
        });
        // Each fan triangle takes the region of the cavity triangle on its rim edge, read
        // before the slots are reused; a point set's stores keep no regions.
        let regions = s.keeps_regions();
        self.rim_regions.clear();
        if regions {
            self.rim_regions
                .extend(self.rim.iter().map(|e| s.region(e.inner)));
        }
        // A fan has one triangle more than an interior cavity (one less for a boundary edge
        // split), so every cavity slot is reused, which also clears its mark.
        debug_assert!(
            self.triangles.len() <= self.rim.len(),
            "a cavity that is no disk"
        );
        self.created.clear();
        for k in 0..self.rim.len() {
            let id = match self.triangles.get(k) {
                Some(&id) => id,
                None => s.push_triangle(),
            };
            self.created.push(id);
        }
        self.link_rim();
        let fan = |m: u32| {
            if m == NONE {
                NONE
            } else {
                self.created[m as usize]
            }
        };
        for (k, e) in self.rim.iter().enumerate() {
            let id = self.created[k];
            // Triangle (a, b, p): across b → p is the fan triangle starting at b, across p → a
            // the one ending at a, linked below from that one's side.
            *s.corners_mut(id) = [e.a, e.b, v];
            *s.across_mut(id) = [fan(self.after[k]), NONE, e.outer];
            if regions {
                s.set_region(id, self.rim_regions[k]);
            }
            if e.outer != NONE {
                let outer = beyond(e.outer);
                let tri = s.triangle(outer);
                let j = (0..3)
                    .find(|&j| tri.edge(j) == (e.b, e.a))
                    .expect("the triangle beyond a rim edge shares it");
                s.across_mut(outer)[j] = id | (e.outer & SEGMENT);
            }
        }
        for (k, &next) in self.after.iter().enumerate() {
            if next != NONE {
                s.across_mut(self.created[next as usize])[1] = self.created[k];
            }
        }
        if let Some(Split {
            ends: (a, b),
            interior: true,
        }) = split
        {
            self.mark_halves(s, a, b);
        }
        v
    }

    /// Marks the fan's edges from the new vertex to `a` and to `b`, the halves of the segment
    /// it split, as segments on both sides.
    fn mark_halves<S: Store>(&self, s: &mut S, a: u32, b: u32) {
        for &id in &self.created {
            let c = s.corners(id);
            // Fan triangle (x, y, new): the edge y → new is opposite corner 0, new → x
            // opposite corner 1.
            if c[1] == a || c[1] == b {
                s.across_mut(id)[0] |= SEGMENT;
            }
            if c[0] == a || c[0] == b {
                s.across_mut(id)[1] |= SEGMENT;
            }
        }
    }

    /// Finds, for each rim edge, the one that starts where it ends, through a hash table of
    /// the edges by first vertex (the rim's first vertices are distinct): a search of the rim
    /// per edge would cost the square of its length.
    fn link_rim(&mut self) {
        let n = self.rim.len();
        let size = (2 * n).next_power_of_two().max(8);
        let mask = size - 1;
        let slot = |v: u32| (v.wrapping_mul(0x9E37_79B1) >> 7) as usize & mask;
        self.by_start.clear();
        self.by_start.resize(size, NONE);
        for (k, e) in self.rim.iter().enumerate() {
            let mut h = slot(e.a);
            while self.by_start[h] != NONE {
                h = (h + 1) & mask;
            }
            self.by_start[h] = k as u32;
        }
        self.after.clear();
        for e in &self.rim {
            let mut h = slot(e.b);
            let next = loop {
                let k = self.by_start[h];
                if k == NONE || self.rim[k as usize].a == e.b {
                    break k;
                }
                h = (h + 1) & mask;
            };
            self.after.push(next);
        }
    }

    /// The triangles the last [`Self::commit`] made.
    pub fn created(&self) -> &[u32] {
        &self.created
    }

    /// Inserts `p`, a point inside the rectangle and on no vertex, walking from `hint`.
    /// Returns the new vertex, or where the point was found instead.
    #[cfg(test)]
    pub fn insert(&mut self, t: &mut Triangulation, p: DVec2, hint: u32) -> Result<u32, Location> {
        match locate(t, p, hint) {
            Location::Inside(tri) => {
                assert!(self.dig(t, p, tri));
                Ok(self.commit(t, p, None))
            }
            other => Err(other),
        }
    }
}

enum Joins {
    Yes,
    No,
    Foreign,
}

enum Step {
    Found,
    Leave(usize),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cocircular_ties_pick_one_diagonal_whatever_the_corner_order() {
        // Four points of one circle, counter-clockwise: a quadrilateral with two Delaunay
        // diagonals. The tie must keep exactly one, and not depend on which corner comes first.
        let circles = [
            [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)],
            [(0.0, 0.0), (2.0, 0.0), (2.0, 1.0), (0.0, 1.0)],
            [(3.0, 4.0), (-4.0, 3.0), (-3.0, -4.0), (5.0, 0.0)],
        ];
        for circle in circles {
            let [a, b, c, d] = circle.map(|(x, y)| DVec2::new(x, y));
            for [a, b, c, d] in [[a, b, c, d], [b, c, d, a], [c, d, a, b], [d, a, b, c]] {
                assert_eq!(in_circle(a, b, c, d), InCircle::On);
                let ac = !perturbed_inside(a, b, c, d) && !perturbed_inside(c, d, a, b);
                let bd = perturbed_inside(a, b, c, d) && perturbed_inside(c, d, a, b);
                assert!(ac || bd, "{a} {b} {c} {d}");
                assert_eq!(perturbed_inside(a, b, c, d), perturbed_inside(b, c, a, d));
                assert_eq!(perturbed_inside(a, b, c, d), perturbed_inside(c, a, b, d));
            }
        }
    }

    fn is_delaunay(t: &Triangulation) -> bool {
        (0..t.len() as u32).all(|id| {
            let tri = t.triangle(id);
            (0..3).all(|i| {
                let o = tri.n[i];
                if o == NONE {
                    return true;
                }
                let other = t.triangle(o);
                let back = (0..3).find(|&j| other.n[j] == id);
                let Some(j) = back else { return false };
                other.edge(j) == (tri.edge(i).1, tri.edge(i).0)
                    && !in_circumcircle(t, id, t.vertices[other.v[j] as usize])
            })
        })
    }

    fn area(t: &Triangulation) -> f64 {
        t.corners
            .iter()
            .map(|tri| {
                let [a, b, c] = tri.map(|v| t.vertices[v as usize]);
                assert!(
                    orientation(a, b, c) == Orientation::Left,
                    "triangle {tri:?} is not counter-clockwise"
                );
                (b - a).perp_dot(c - a) / 2.0
            })
            .sum()
    }

    #[test]
    fn grid_points_keep_the_triangulation_delaunay() {
        // Cocircular quadruples everywhere: the strict in-circle test must still give a valid,
        // Delaunay result.
        let mut t = Triangulation::rectangle(DVec2::ZERO, DVec2::splat(8.0));
        let mut cavity = Cavity::default();
        let mut hint = 0;
        for y in 1..8 {
            for x in 1..8 {
                let v = cavity
                    .insert(&mut t, DVec2::new(x as f64, y as f64), hint)
                    .unwrap();
                hint = cavity.created()[0];
                assert_eq!(v as usize, t.vertices.len() - 1);
            }
        }
        assert_eq!(t.len(), 2 * 49 + 2);
        assert!(is_delaunay(&t));
        assert!((area(&t) - 64.0).abs() < 1e-12);
    }

    #[test]
    fn flips_stop_at_their_budget() {
        // A quadrilateral whose diagonal 0-2 is not Delaunay: corner 3 is inside the circle
        // through 0, 1, 2.
        let mut t = Triangulation::rectangle(DVec2::ZERO, DVec2::splat(4.0));
        t.vertices[2] = DVec2::splat(5.0);
        assert!(!is_delaunay(&t));
        assert!(!t.clone().flip_to_delaunay_within(vec![(0, 1)], 0));
        assert!(t.flip_to_delaunay_within(vec![(0, 1)], 1));
        assert!(is_delaunay(&t));
    }

    #[test]
    fn a_point_on_the_boundary_splits_its_edge() {
        let mut t = Triangulation::rectangle(DVec2::ZERO, DVec2::splat(4.0));
        let mut cavity = Cavity::default();
        cavity.insert(&mut t, DVec2::new(2.0, 0.0), 1).unwrap();
        cavity.insert(&mut t, DVec2::new(4.0, 1.0), 1).unwrap();
        assert_eq!(t.len(), 4);
        let boundary = t
            .across
            .iter()
            .flat_map(|n| (0..3).filter(|&i| n[i] == NONE))
            .count();
        assert_eq!(boundary, 6);
        assert!(is_delaunay(&t));
        assert!((area(&t) - 16.0).abs() < 1e-12);
    }

    #[test]
    fn locate_reports_vertices_and_the_outside() {
        let mut t = Triangulation::rectangle(DVec2::ZERO, DVec2::splat(4.0));
        let v = Cavity::default()
            .insert(&mut t, DVec2::new(1.0, 1.0), 0)
            .unwrap();
        assert_eq!(locate(&t, DVec2::new(1.0, 1.0), 0), Location::Vertex(v));
        assert_eq!(locate(&t, DVec2::new(4.0, 4.0), 0), Location::Vertex(2));
        match locate(&t, DVec2::new(5.0, 1.0), 0) {
            Location::Outside { triangle, edge } => {
                let (a, b) = t.triangle(triangle).edge(edge);
                assert_eq!(t.vertices[a as usize].x, 4.0);
                assert_eq!(t.vertices[b as usize].x, 4.0);
            }
            other => panic!("expected outside, got {other:?}"),
        }
    }

    #[test]
    fn random_points_give_a_delaunay_triangulation() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(7);
        let mut t = Triangulation::rectangle(DVec2::ZERO, DVec2::ONE);
        let mut cavity = Cavity::default();
        let mut hint = 0;
        for _ in 0..2000 {
            let p = DVec2::new(rng.random_range(0.01..0.99), rng.random_range(0.01..0.99));
            cavity.insert(&mut t, p, hint).unwrap();
            hint = cavity.created()[0];
        }
        assert_eq!(t.len(), 2 * 2000 + 2);
        assert!(is_delaunay(&t));
        assert!((area(&t) - 1.0).abs() < 1e-12);
    }
}
