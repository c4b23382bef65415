//! A Delaunay triangulation of a rectangle's corners and points inside it, kept Delaunay under
//! point insertion by Bowyer–Watson cavities with exact predicates.
//!
//! Refinement needs to look at a cavity before committing to it (an off-center that would
//! encroach on a boundary edge is not inserted), which is why insertion is split into
//! [`Triangulation::locate`], [`Triangulation::dig`] and [`Triangulation::commit`].

use glam::DVec2;
use robust::{Coord, incircle, orient2d};

use crate::mesh::NONE;

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
const MARK: u32 = 1 << 31;

/// The most vertices a triangulation may have.
pub(crate) const MAX_VERTICES: usize = MARK as usize - 1;

/// The triangulation with the scratch space of its insertions. Corners and neighbours live in
/// separate arrays, the layout [`crate::mesh::Mesh`] takes over without a copy.
#[derive(Clone, Debug)]
pub(crate) struct Triangulation {
    pub vertices: Vec<DVec2>,
    pub corners: Vec<[u32; 3]>,
    pub across: Vec<[u32; 3]>,
    cavity: Vec<u32>,
    left_out: Vec<u32>,
    rim: Vec<RimEdge>,
    created: Vec<u32>,
}

#[inline]
fn coord(p: DVec2) -> Coord<f64> {
    Coord { x: p.x, y: p.y }
}

/// Positive if `c` is left of `a → b`, zero if collinear; exact.
#[inline]
pub(crate) fn orient(a: DVec2, b: DVec2, c: DVec2) -> f64 {
    orient2d(coord(a), coord(b), coord(c))
}

impl Triangulation {
    /// The rectangle `[lo, hi]` as two triangles; its corners are vertices 0 to 3,
    /// counter-clockwise from `lo`.
    pub fn rectangle(lo: DVec2, hi: DVec2) -> Self {
        Triangulation {
            vertices: vec![lo, DVec2::new(hi.x, lo.y), hi, DVec2::new(lo.x, hi.y)],
            corners: vec![[0, 1, 2], [0, 2, 3]],
            across: vec![[NONE, 1, NONE], [NONE, NONE, 0]],
            cavity: Vec::new(),
            left_out: Vec::new(),
            rim: Vec::new(),
            created: Vec::new(),
        }
    }

    /// Makes room for about `vertices` vertices in all and their triangles, touching the
    /// memory in parallel.
    pub fn reserve(&mut self, vertices: usize) {
        fn grow<T: Copy + Send + Sync>(v: &mut Vec<T>, n: usize, fill: T) {
            if n > v.capacity() {
                let mut bigger = crate::par::prefaulted(n, fill);
                bigger.extend_from_slice(v);
                *v = bigger;
            }
        }
        grow(&mut self.vertices, vertices, DVec2::ZERO);
        grow(&mut self.corners, 2 * vertices, [0; 3]);
        grow(&mut self.across, 2 * vertices, [NONE; 3]);
    }

    /// Triangles so far.
    pub fn len(&self) -> usize {
        self.corners.len()
    }

    /// Triangle `t` (outside a cavity search).
    #[inline]
    pub fn triangle(&self, t: u32) -> Triangle {
        Triangle {
            v: self.corners[t as usize],
            n: self.across[t as usize],
        }
    }

    #[inline]
    fn point(&self, v: u32) -> DVec2 {
        self.vertices[(v & !MARK) as usize]
    }

    /// Locates `p` by a visibility walk from triangle `start`. The walk ends on a Delaunay
    /// triangulation whatever edge it takes; a step count guards against a bug turning that
    /// into a hang, falling back to a scan of every triangle.
    pub fn locate(&self, p: DVec2, start: u32) -> Location {
        let mut t = start;
        let mut came_from = NONE;
        for _ in 0..=self.len() {
            match self.step(p, t, came_from) {
                Step::Found => return self.found(p, t),
                Step::Leave(i) => {
                    let next = self.across[t as usize][i];
                    if next == NONE {
                        return Location::Outside {
                            triangle: t,
                            edge: i,
                        };
                    }
                    came_from = t;
                    t = next;
                }
            }
        }
        self.locate_by_scan(p)
    }

    /// The first edge of `t` that has `p` strictly on its far side, skipping the edge the walk
    /// came in by.
    #[inline]
    fn step(&self, p: DVec2, t: u32, came_from: u32) -> Step {
        let tri = self.triangle(t);
        for i in 0..3 {
            if tri.n[i] == came_from && came_from != NONE {
                continue;
            }
            let (a, b) = tri.edge(i);
            if orient(self.point(a), self.point(b), p) < 0.0 {
                return Step::Leave(i);
            }
        }
        Step::Found
    }

    fn found(&self, p: DVec2, t: u32) -> Location {
        match self.corners[t as usize]
            .iter()
            .find(|&&v| self.point(v) == p)
        {
            Some(&v) => Location::Vertex(v),
            None => Location::Inside(t),
        }
    }

    fn locate_by_scan(&self, p: DVec2) -> Location {
        let triangles = 0..self.len() as u32;
        if let Some(t) = triangles
            .clone()
            .find(|&t| matches!(self.step(p, t, NONE), Step::Found))
        {
            return self.found(p, t);
        }
        let (t, i) = triangles
            .flat_map(|t| (0..3).map(move |i| (t, i)))
            .find(|&(t, i)| {
                let tri = self.triangle(t);
                let (a, b) = tri.edge(i);
                tri.n[i] == NONE && orient(self.point(a), self.point(b), p) < 0.0
            })
            .expect("a point in no triangle lies beyond some boundary edge");
        Location::Outside {
            triangle: t,
            edge: i,
        }
    }

    /// Whether `p` lies strictly inside the circumcircle of triangle `t`; exact.
    #[inline]
    fn in_circumcircle(&self, t: u32, p: DVec2) -> bool {
        let [a, b, c] = self.corners[t as usize].map(|v| coord(self.point(v)));
        incircle(a, b, c, coord(p)) > 0.0
    }

    /// Finds the cavity of `p`, which lies in triangle `t` (from [`Self::locate`]): the
    /// triangles whose circumcircle strictly contains `p`, a connected set around `t`. Nothing
    /// changes until [`Self::commit`]; [`Self::abandon`] drops the cavity instead.
    pub fn dig(&mut self, p: DVec2, t: u32) {
        self.cavity.clear();
        self.left_out.clear();
        self.rim.clear();
        self.corners[t as usize][0] |= MARK;
        self.cavity.push(t);
        let mut k = 0;
        while k < self.cavity.len() {
            let c = self.cavity[k];
            k += 1;
            let tri = self.triangle(c);
            for i in 0..3 {
                let o = tri.n[i];
                if o != NONE && self.joins_cavity(o, p) {
                    continue;
                }
                let (a, b) = tri.edge(i);
                self.rim.push(RimEdge {
                    a: a & !MARK,
                    b: b & !MARK,
                    outer: o,
                    inner: c,
                    corner: i as u8,
                });
            }
        }
    }

    /// Whether triangle `o`, next to the cavity, is (now) in it; marks it either way.
    #[inline]
    fn joins_cavity(&mut self, o: u32, p: DVec2) -> bool {
        let [first, second, _] = self.corners[o as usize];
        if first & MARK != 0 {
            return true;
        }
        if second & MARK != 0 {
            return false;
        }
        if self.in_circumcircle(o, p) {
            self.corners[o as usize][0] |= MARK;
            self.cavity.push(o);
            true
        } else {
            self.corners[o as usize][1] |= MARK;
            self.left_out.push(o);
            false
        }
    }

    /// The boundary of the cavity [`Self::dig`] last found.
    pub fn rim(&self) -> &[RimEdge] {
        &self.rim
    }

    /// Drops the cavity [`Self::dig`] last found, leaving the triangulation as it was.
    pub fn abandon(&mut self) {
        for &t in &self.cavity {
            self.corners[t as usize][0] &= !MARK;
        }
        self.clear_left_out();
    }

    fn clear_left_out(&mut self) {
        for &t in &self.left_out {
            self.corners[t as usize][1] &= !MARK;
        }
    }

    /// Inserts `p` into the cavity [`Self::dig`] last found for it: the cavity's triangles are
    /// replaced by a fan from `p`. A boundary edge that `p` lies on is split. Returns the new
    /// vertex; [`Self::created`] lists the new triangles.
    pub fn commit(&mut self, p: DVec2) -> u32 {
        self.clear_left_out();
        let cavity = std::mem::take(&mut self.cavity);
        let rim = std::mem::take(&mut self.rim);
        let v = self.fan(p, &cavity, rim);
        self.cavity = cavity;
        v
    }

    /// Replaces the `cavity` triangles, bounded by `rim`, by a fan from the new vertex `p`.
    fn fan(&mut self, p: DVec2, cavity: &[u32], mut rim: Vec<RimEdge>) -> u32 {
        let v = self.vertices.len() as u32;
        self.vertices.push(p);
        let vertices = &self.vertices;
        rim.retain(|e| {
            e.outer != NONE || orient(vertices[e.a as usize], vertices[e.b as usize], p) != 0.0
        });
        // A fan has one triangle more than an interior cavity (one less for a boundary edge
        // split), so every cavity slot is reused, which also clears its mark.
        self.created.clear();
        for k in 0..rim.len() {
            let id = match cavity.get(k) {
                Some(&id) => id,
                None => {
                    self.corners.push([0; 3]);
                    self.across.push([NONE; 3]);
                    (self.corners.len() - 1) as u32
                }
            };
            self.created.push(id);
        }
        for (k, e) in rim.iter().enumerate() {
            let id = self.created[k];
            // Triangle (a, b, p): across b → p is the fan triangle starting at b, across p → a
            // the one ending at a.
            let after = rim.iter().position(|f| f.a == e.b);
            let before = rim.iter().position(|f| f.b == e.a);
            self.corners[id as usize] = [e.a, e.b, v];
            self.across[id as usize] = [
                after.map_or(NONE, |m| self.created[m]),
                before.map_or(NONE, |m| self.created[m]),
                e.outer,
            ];
            if e.outer != NONE {
                let outer = self.triangle(e.outer);
                let j = (0..3)
                    .find(|&j| outer.edge(j) == (e.b, e.a))
                    .expect("the triangle beyond a rim edge shares it");
                self.across[e.outer as usize][j] = id;
            }
        }
        self.rim = rim;
        v
    }

    /// The triangles the last [`Self::commit`] made.
    pub fn created(&self) -> &[u32] {
        &self.created
    }

    /// Inserts `p`, a point inside the rectangle and on no vertex, walking from `hint`.
    #[cfg(test)]
    /// Returns the new vertex, or where the point was found instead.
    pub fn insert(&mut self, p: DVec2, hint: u32) -> Result<u32, Location> {
        match self.locate(p, hint) {
            Location::Inside(t) => {
                self.dig(p, t);
                Ok(self.commit(p))
            }
            other => Err(other),
        }
    }
}

enum Step {
    Found,
    Leave(usize),
}

#[cfg(test)]
mod tests {
    use super::*;

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
                    && !t.in_circumcircle(id, t.vertices[other.v[j] as usize])
            })
        })
    }

    fn area(t: &Triangulation) -> f64 {
        t.corners
            .iter()
            .map(|tri| {
                let [a, b, c] = tri.map(|v| t.vertices[v as usize]);
                assert!(
                    orient(a, b, c) > 0.0,
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
        let mut hint = 0;
        for y in 1..8 {
            for x in 1..8 {
                let v = t.insert(DVec2::new(x as f64, y as f64), hint).unwrap();
                hint = t.created()[0];
                assert_eq!(v as usize, t.vertices.len() - 1);
            }
        }
        assert_eq!(t.len(), 2 * 49 + 2);
        assert!(is_delaunay(&t));
        assert!((area(&t) - 64.0).abs() < 1e-12);
    }

    #[test]
    fn a_point_on_the_boundary_splits_its_edge() {
        let mut t = Triangulation::rectangle(DVec2::ZERO, DVec2::splat(4.0));
        t.insert(DVec2::new(2.0, 0.0), 1).unwrap();
        t.insert(DVec2::new(4.0, 1.0), 1).unwrap();
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
        let v = t.insert(DVec2::new(1.0, 1.0), 0).unwrap();
        assert_eq!(t.locate(DVec2::new(1.0, 1.0), 0), Location::Vertex(v));
        assert_eq!(t.locate(DVec2::new(4.0, 4.0), 0), Location::Vertex(2));
        match t.locate(DVec2::new(5.0, 1.0), 0) {
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
        let mut hint = 0;
        for _ in 0..2000 {
            let p = DVec2::new(rng.random_range(0.01..0.99), rng.random_range(0.01..0.99));
            t.insert(p, hint).unwrap();
            hint = t.created()[0];
        }
        assert_eq!(t.len(), 2 * 2000 + 2);
        assert!(is_delaunay(&t));
        assert!((area(&t) - 1.0).abs() < 1e-12);
    }
}
