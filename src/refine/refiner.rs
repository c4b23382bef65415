//! The refinement loop: bad triangles are fixed one at a time, smallest size class first, each
//! class in Morton order, and the bad triangles an insertion makes right after it, while their
//! memory is in cache. The first look at all triangles runs in parallel.

use glam::DVec2;
use rayon::prelude::*;

use super::RefineOptions;
use super::delaunay::{Location, NEXT, PREV, Triangulation};
use super::queue::{Queued, SizeQueue};
use crate::error::Error;
use crate::mesh::NONE;
use crate::morton::interleave::interleave32;

/// An encroached boundary edge as it was when queued: the edge opposite `corner` of `triangle`,
/// live while that slot still has these ends there.
#[derive(Clone, Copy, Debug)]
struct Encroached {
    triangle: u32,
    corner: u8,
    ends: (u32, u32),
}

/// What inspecting a new triangle found.
struct Inspection {
    bad: Option<(usize, Queued)>,
    encroached: [Option<Encroached>; 3],
}

/// The refinement loop's state.
pub(super) struct Refiner<'a> {
    t: &'a mut Triangulation,
    /// sin² of the angle bound.
    sin2: f64,
    /// Twice the area bound (cross products give twice the area).
    max_area2: f64,
    /// Off-centers lie this many shortest-edge lengths from the edge's midpoint.
    offset: f64,
    bad: SizeQueue,
    encroached: Vec<Encroached>,
    budget: usize,
    /// The domain's lower-left corner and the scale that maps it onto 32-bit grid coordinates.
    origin: DVec2,
    scale: f64,
}

impl<'a> Refiner<'a> {
    pub fn new(t: &'a mut Triangulation, options: &RefineOptions, budget: usize) -> Self {
        let angle = options.min_angle_deg.to_radians();
        // The off-center's triangle on the shortest edge is isosceles with apex angle equal to
        // the bound at height cot(A/2)/2 edge lengths; 95% of that leaves it strictly better.
        let offset = if angle > 0.0 {
            0.95 * 0.5 / (angle / 2.0).tan()
        } else {
            f64::INFINITY
        };
        // Vertices 0 and 2 are the domain's corners.
        let origin = t.vertices[0];
        let side = (t.vertices[2] - origin).max_element();
        let scale = 2f64.powi(32) / side * (1.0 - f64::EPSILON);
        Refiner {
            t,
            sin2: angle.sin().powi(2),
            max_area2: options.max_area.map_or(f64::INFINITY, |a| 2.0 * a),
            offset,
            bad: SizeQueue::new(),
            encroached: Vec::new(),
            budget,
            origin,
            scale,
        }
    }

    /// Refines a fresh triangulation: every triangle is looked at.
    pub fn refine_all(mut self) -> Result<(), Error> {
        if self.sin2 == 0.0 && self.max_area2 == f64::INFINITY {
            // No bound asked for: the Delaunay triangulation is the mesh.
            return Ok(());
        }
        self.inspect_all();
        self.run()
    }

    /// Fixes bad triangles and encroached boundary edges until none is left.
    fn run(mut self) -> Result<(), Error> {
        loop {
            if self.t.vertices.len() > self.budget {
                return Err(self.out_of_budget());
            }
            if let Some(e) = self.encroached.pop() {
                if self.is_live(&e) {
                    self.split_boundary_edge(e)?;
                }
                continue;
            }
            let Some(q) = self.bad.pop() else {
                return Ok(());
            };
            if self.is_current(&q) {
                self.fix(q)?;
            }
        }
    }

    /// Inserts the off-center (or circumcenter) of a bad triangle, unless it would encroach on
    /// boundary edges: then those are queued for splitting and the triangle waits again.
    fn fix(&mut self, q: Queued) -> Result<(), Error> {
        let Some((corner, shortest2)) = self.badness(q.triangle) else {
            return Ok(());
        };
        let p = self.steiner_point(q.triangle, corner);
        let requeue = |s: &mut Self| s.bad.push(SizeQueue::class_of(shortest2), q);
        match self.t.locate(p, q.triangle) {
            Location::Outside { triangle, edge } => {
                // Rounding put a circumcenter just past the boundary: split the edge it crossed.
                let ends = self.t.triangle(triangle).edge(edge);
                self.encroached.push(Encroached {
                    triangle,
                    corner: edge as u8,
                    ends,
                });
                requeue(self);
                Ok(())
            }
            Location::Vertex(_) => Err(Error::RefinementResolution { x: p.x, y: p.y }),
            Location::Inside(t) => {
                let before = self.encroached.len();
                self.t.dig(p, t);
                for e in self.t.rim().iter().filter(|e| e.outer == NONE) {
                    if self.encroaches(p, (e.a, e.b)) {
                        self.encroached.push(Encroached {
                            triangle: e.inner,
                            corner: e.corner,
                            ends: (e.a, e.b),
                        });
                    }
                }
                if self.encroached.len() > before {
                    self.t.abandon();
                    requeue(self);
                    return Ok(());
                }
                self.t.commit(p);
                self.inspect_created();
                Ok(())
            }
        }
    }

    /// Queues what the last insertion made: its bad triangles, its encroached boundary edges.
    fn inspect_created(&mut self) {
        for k in 0..self.t.created().len() {
            let found = self.inspection(self.t.created()[k]);
            self.queue(found);
        }
    }

    fn queue(&mut self, found: Inspection) {
        if let Some((class, entry)) = found.bad {
            self.bad.push(class, entry);
        }
        self.encroached
            .extend(found.encroached.into_iter().flatten());
    }

    /// Whether the entry's triangle is still in its slot.
    fn is_current(&self, q: &Queued) -> bool {
        newest(self.t.corners[q.triangle as usize]) == q.newest
    }

    fn out_of_budget(&self) -> Error {
        let remaining = (0..self.t.len() as u32)
            .into_par_iter()
            .filter(|&id| self.badness(id).is_some())
            .count();
        Error::VertexBudget {
            limit: self.budget,
            remaining,
        }
    }

    fn is_live(&self, e: &Encroached) -> bool {
        let tri = self.t.triangle(e.triangle);
        tri.n[e.corner as usize] == NONE && tri.edge(e.corner as usize) == e.ends
    }

    /// Queues every bad triangle, and every boundary edge its triangle's apex encroaches on;
    /// the looking is done in parallel, the queueing in order.
    fn inspect_all(&mut self) {
        const CHUNK: u32 = 1 << 16;
        let len = self.t.len() as u32;
        // In chunks, so that the findings never take more memory than a slice of the mesh.
        for start in (0..len).step_by(CHUNK as usize) {
            let found: Vec<Inspection> = {
                let this = &*self;
                (start..len.min(start + CHUNK))
                    .into_par_iter()
                    .map(|id| this.inspection(id))
                    .collect()
            };
            for f in found {
                self.queue(f);
            }
        }
    }

    fn inspection(&self, id: u32) -> Inspection {
        let tri = self.t.triangle(id);
        let bad = self.badness(id).map(|(_, shortest2)| {
            let entry = Queued {
                triangle: id,
                newest: newest(tri.v),
                place: self.place(tri.v[0]),
            };
            (SizeQueue::class_of(shortest2), entry)
        });
        let encroached = [0, 1, 2].map(|i| {
            let ends = tri.edge(i);
            let apex = self.t.vertices[tri.v[i] as usize];
            (tri.n[i] == NONE && self.encroaches(apex, ends)).then_some(Encroached {
                triangle: id,
                corner: i as u8,
                ends,
            })
        });
        Inspection { bad, encroached }
    }

    /// Whether `p` lies in the closed diametral circle of the edge between vertices `ends`: it
    /// sees the edge at 90° or more.
    fn encroaches(&self, p: DVec2, (a, b): (u32, u32)) -> bool {
        let v = &self.t.vertices;
        (v[a as usize] - p).dot(v[b as usize] - p) <= 0.0
    }

    /// The Morton key of vertex `v` on a 2^32 grid over the domain.
    fn place(&self, v: u32) -> u64 {
        let p = (self.t.vertices[v as usize] - self.origin) * self.scale;
        interleave32(p.x as u32, p.y as u32)
    }

    /// For a bad triangle, the corner opposite its shortest edge and that edge's squared length.
    fn badness(&self, id: u32) -> Option<(usize, f64)> {
        let v = self.t.corners[id as usize].map(|k| self.t.vertices[k as usize]);
        let len2 = [0, 1, 2].map(|i| v[NEXT[i]].distance_squared(v[PREV[i]]));
        let shortest = (0..3)
            .min_by(|&i, &j| len2[i].total_cmp(&len2[j]))
            .expect("three edges");
        let area2 = (v[1] - v[0]).perp_dot(v[2] - v[0]);
        // The smallest angle faces the shortest edge, and its sine is twice the area over the
        // product of the two other sides.
        let others = len2[NEXT[shortest]] * len2[PREV[shortest]];
        let skinny = area2 * area2 < self.sin2 * others;
        (skinny || area2 > self.max_area2).then_some((shortest, len2[shortest]))
    }

    /// Üngör's off-center of triangle `id` whose shortest edge is opposite `corner`, or its
    /// circumcenter when that is nearer the edge.
    fn steiner_point(&self, id: u32, corner: usize) -> DVec2 {
        let tri = self.t.corners[id as usize];
        let [p, q, r] =
            [NEXT[corner], PREV[corner], corner].map(|i| self.t.vertices[tri[i] as usize]);
        let d = q - p;
        let midpoint = p * 0.5 + q * 0.5;
        let centre = circumcenter(p, q, r);
        // Both lie on the edge's bisector, the apex's side: compare their heights over the edge.
        let height = (centre - midpoint).dot(d.perp()) / d.length_squared();
        if height > self.offset {
            midpoint + d.perp() * self.offset
        } else {
            centre
        }
    }

    /// Splits a boundary edge at its midpoint, which keeps the side's constant coordinate bit
    /// for bit.
    fn split_boundary_edge(&mut self, e: Encroached) -> Result<(), Error> {
        let (a, b) = (
            self.t.vertices[e.ends.0 as usize],
            self.t.vertices[e.ends.1 as usize],
        );
        let mut m = a * 0.5 + b * 0.5;
        if a.x == b.x {
            m.x = a.x;
        } else {
            m.y = a.y;
        }
        if m == a || m == b {
            return Err(Error::RefinementResolution { x: m.x, y: m.y });
        }
        self.t.dig(m, e.triangle);
        self.t.commit(m);
        self.inspect_created();
        Ok(())
    }
}

/// The largest vertex number among a triangle's corners.
fn newest(corners: [u32; 3]) -> u32 {
    corners[0].max(corners[1]).max(corners[2])
}

/// The circumcenter of `p, q, r`, computed relative to `p` for accuracy.
fn circumcenter(p: DVec2, q: DVec2, r: DVec2) -> DVec2 {
    let (b, c) = (q - p, r - p);
    let d = 2.0 * b.perp_dot(c);
    let (b2, c2) = (b.length_squared(), c.length_squared());
    p + DVec2::new(c.y * b2 - b.y * c2, b.x * c2 - c.x * b2) / d
}
