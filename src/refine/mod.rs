//! Off-center Delaunay refinement: a Delaunay mesh of the domain square in which every angle is
//! at least the user's bound and every triangle at most the user's area, with far fewer
//! triangles than the warped quadtree mesh.
//!
//! The input points go into a Delaunay triangulation of the domain square in Morton order, so
//! each point location walks a few steps from the last insertion. Then bad triangles (an angle
//! below the bound or an area above it) are fixed smallest first, as in Har-Peled and Üngör:
//! each gets Üngör's off-center, the point on the bisector of its shortest edge that makes a
//! triangle just meeting the bound with that edge, or its circumcenter when that is closer. A
//! point that would encroach on a boundary edge (lie in its diametral circle) is not inserted;
//! the edge is split at its midpoint instead, as in Ruppert's algorithm, so every circumcenter
//! stays inside the square. Every insertion keeps the triangulation Delaunay, with exact
//! predicates.
//!
//! Termination is proven for bounds up to arcsin(1/(2√2)) ≈ 20.7°; in practice it reaches 33°
//! and more. A vertex budget stops it with an error rather than let it run without end.

mod delaunay;
mod queue;

use glam::DVec2;
use rayon::prelude::*;

use crate::error::Error;
use crate::mesh::{BoundaryEdge, BoundarySide, Domain, Mesh, MeshReport, NONE, angles_deg};
use crate::morton::interleave::interleave32;
use crate::morton::{Morton, MortonKey, MortonOrder, SortAlgorithm, morton_order};
use crate::pipeline::StageTimes;
use crate::warp::AngleQuality;
use delaunay::{Location, MAX_VERTICES, NEXT, PREV, Triangulation};
use queue::{Queued, SizeQueue};

/// The largest angle bound for which off-center refinement is proven to terminate,
/// arcsin(1/(2√2)), in degrees.
pub const GUARANTEED_MIN_ANGLE_DEG: f64 = 20.704_811_054_635_46;

/// The largest angle bound accepted. Refinement rarely finishes above about 34°; the vertex
/// budget stops it.
pub const MAX_MIN_ANGLE_DEG: f64 = 45.0;

/// What [`refine_points`] builds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefineOptions {
    /// Every angle is at least this, in degrees, in `[0, 45]`. Zero asks only for the area bound
    /// (or, without one, the Delaunay triangulation of the points and the square's corners).
    pub min_angle_deg: f64,
    /// Every triangle's area is at most this, if given.
    pub max_area: Option<f64>,
    /// Refinement stops with [`Error::VertexBudget`] past this many vertices; by default
    /// 100 per distinct point plus 10 000.
    pub max_vertices: Option<usize>,
    /// The sort used for Morton order.
    pub sort: SortAlgorithm,
}

impl Default for RefineOptions {
    fn default() -> Self {
        RefineOptions {
            min_angle_deg: 30.0,
            max_area: None,
            max_vertices: None,
            sort: SortAlgorithm::default(),
        }
    }
}

impl RefineOptions {
    fn check(&self) -> Result<(), Error> {
        let a = self.min_angle_deg;
        if !(0.0..=MAX_MIN_ANGLE_DEG).contains(&a) {
            return Err(Error::InvalidOption {
                option: "min-angle",
                message: format!("{a} is not an angle in [0, {MAX_MIN_ANGLE_DEG}] degrees"),
            });
        }
        if let Some(area) = self.max_area
            && !(area > 0.0 && area.is_finite())
        {
            return Err(Error::InvalidOption {
                option: "max-area",
                message: format!("{area} is not a positive finite area"),
            });
        }
        Ok(())
    }

    fn budget(&self, points: usize) -> usize {
        self.max_vertices
            .unwrap_or(points.saturating_mul(100).saturating_add(10_000))
            .min(MAX_VERTICES)
    }
}

/// The refined Delaunay mesh of `points` on the current rayon pool, with its report. The domain
/// is the quadtree's root square, as for [`crate::mesh_points`].
///
/// # Errors
/// Whatever [`morton_order`] refuses, [`Error::InvalidOption`] for a bound out of range,
/// [`Error::VertexBudget`] when refinement needs more vertices than allowed, and
/// [`Error::RefinementResolution`] when it needs a vertex f64 cannot place.
pub fn refine_points(
    points: &[DVec2],
    options: &RefineOptions,
) -> Result<(Mesh, MeshReport), Error> {
    options.check()?;
    let mut times = StageTimes::default();
    let morton = times.time("morton", || morton_order(points, options.sort))?;
    match morton {
        Morton::Narrow(m) => refine_order(m, points, options, times),
        Morton::Wide(m) => refine_order(m, points, options, times),
    }
}

fn refine_order<K: MortonKey>(
    morton: MortonOrder<K>,
    points: &[DVec2],
    options: &RefineOptions,
    mut times: StageTimes,
) -> Result<(Mesh, MeshReport), Error> {
    let grid = &morton.grid;
    let side = 1u128 << grid.axis_bits();
    let domain = Domain {
        lo: grid.vertex(0, 0),
        hi: grid.vertex(side, side),
    };
    let mut triangulation = times.time("delaunay", || {
        let mut t = Triangulation::rectangle(domain.lo, domain.hi);
        t.reserve(3 * morton.order.len());
        insert_in_order(&mut t, points, &morton.order)?;
        Ok::<_, Error>(t)
    })?;
    let budget = options.budget(morton.order.len());
    times.time("refine", || {
        Refiner::new(&mut triangulation, options, budget).refine_all()
    })?;
    let mesh = times.time("mesh", || into_mesh(triangulation, &morton.order, domain));
    let quality = times.time("angles", || angle_quality(&mesh.vertices, &mesh.triangles));
    let report = MeshReport {
        points: morton.order.len(),
        duplicates: morton.duplicates.count,
        vertices: mesh.vertices.len(),
        triangles: mesh.triangles.len(),
        min_angle: quality.min,
        max_angle: quality.max,
        histogram: quality.histogram,
        stages: times.0,
    };
    Ok((mesh, report))
}

/// Inserts the distinct points in Morton order, each walk starting from the last new triangle.
fn insert_in_order(t: &mut Triangulation, points: &[DVec2], order: &[u32]) -> Result<(), Error> {
    let mut hint = 0;
    for &index in order {
        let p = points[index as usize];
        let Location::Inside(tri) = t.locate(p, hint) else {
            // Distinct points inside the square are always inserted; this guards the invariant.
            return Err(Error::RefinementResolution { x: p.x, y: p.y });
        };
        t.dig(p, tri);
        t.commit(p);
        hint = t.created()[0];
    }
    Ok(())
}

/// An encroached boundary edge as it was when queued: the edge opposite `corner` of `triangle`,
/// live while that slot still has these ends there.
#[derive(Clone, Copy, Debug)]
struct Encroached {
    triangle: u32,
    corner: u8,
    ends: (u32, u32),
}

/// The refinement loop's state.
struct Refiner<'a> {
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
    fn new(t: &'a mut Triangulation, options: &RefineOptions, budget: usize) -> Self {
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
        let scale = 2f64.powi(32) / (t.vertices[2].x - origin.x) * (1.0 - f64::EPSILON);
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
    fn refine_all(mut self) -> Result<(), Error> {
        for id in 0..self.t.len() as u32 {
            self.inspect(id);
        }
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
            if self.t.corners[q.triangle as usize] == q.corners {
                self.fix(q)?;
            }
        }
    }

    fn out_of_budget(&self) -> Error {
        let remaining = (0..self.t.len() as u32)
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

    /// Queues triangle `id` if it is bad, and its boundary edges if its apex encroaches on them.
    fn inspect(&mut self, id: u32) {
        let tri = self.t.triangle(id);
        if let Some((_, shortest2)) = self.badness(id) {
            let entry = Queued {
                triangle: id,
                corners: tri.v,
                place: self.place(tri.v[0]),
            };
            self.bad.push(SizeQueue::class_of(shortest2), entry);
        }
        for i in 0..3 {
            if tri.n[i] != NONE {
                continue;
            }
            let (a, b) = tri.edge(i);
            let v = &self.t.vertices;
            let apex = v[tri.v[i] as usize];
            // In the closed diametral circle: the apex sees the edge at 90° or more.
            if (v[a as usize] - apex).dot(v[b as usize] - apex) <= 0.0 {
                self.encroached.push(Encroached {
                    triangle: id,
                    corner: i as u8,
                    ends: (a, b),
                });
            }
        }
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
                let v = &self.t.vertices;
                for e in self.t.rim().iter().filter(|e| e.outer == NONE) {
                    if (v[e.a as usize] - p).dot(v[e.b as usize] - p) <= 0.0 {
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

    fn inspect_created(&mut self) {
        for k in 0..self.t.created().len() {
            let id = self.t.created()[k];
            self.inspect(id);
        }
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

/// The circumcenter of `p, q, r`, computed relative to `p` for accuracy.
fn circumcenter(p: DVec2, q: DVec2, r: DVec2) -> DVec2 {
    let (b, c) = (q - p, r - p);
    let d = 2.0 * b.perp_dot(c);
    let (b2, c2) = (b.length_squared(), c.length_squared());
    p + DVec2::new(c.y * b2 - b.y * c2, b.x * c2 - c.x * b2) / d
}

/// The mesh of a finished triangulation: vertex `k` of the triangulation is vertex `k` of the
/// mesh (the square's corners, the points in Morton order, then the Steiner points in order of
/// insertion), and triangles keep their numbers.
fn into_mesh(t: Triangulation, order: &[u32], domain: Domain) -> Mesh {
    let Triangulation {
        vertices,
        corners,
        across,
        ..
    } = t;
    let mut vertex_input = vec![NONE; vertices.len()];
    vertex_input[4..4 + order.len()].copy_from_slice(order);
    let boundary = boundary_edges(&corners, &across, &vertices, domain);
    Mesh {
        vertices,
        vertex_input,
        triangles: corners,
        neighbours: across,
        boundary,
        domain,
    }
}

/// The triangle edges on the domain's boundary, with their sides.
fn boundary_edges(
    corners: &[[u32; 3]],
    across: &[[u32; 3]],
    vertices: &[DVec2],
    domain: Domain,
) -> Vec<BoundaryEdge> {
    let side_of = |a: DVec2, b: DVec2| {
        if a.y == domain.lo.y && b.y == domain.lo.y {
            BoundarySide::Bottom
        } else if a.x == domain.hi.x && b.x == domain.hi.x {
            BoundarySide::Right
        } else if a.y == domain.hi.y && b.y == domain.hi.y {
            BoundarySide::Top
        } else {
            BoundarySide::Left
        }
    };
    corners
        .par_iter()
        .zip(across)
        .flat_map_iter(|(v, n)| {
            (0..3)
                .filter(|&i| n[i] == NONE)
                .map(|i| (v[NEXT[i]], v[PREV[i]]))
        })
        .map(|(a, b)| BoundaryEdge {
            vertices: [a, b],
            side: side_of(vertices[a as usize], vertices[b as usize]),
        })
        .collect()
}

/// `cos(10° (i + 1))` for `i` in `0..17`: an angle is in histogram bin `i` when `i` of these
/// are at least its cosine.
fn cos_bin_ends() -> [f64; 17] {
    std::array::from_fn(|i| (10.0 * (i + 1) as f64).to_radians().cos())
}

/// Angle counts per bin and the triangles holding the widest and the narrowest angle, with
/// their cosines.
#[derive(Clone, Copy)]
struct AngleScan {
    histogram: [u64; 18],
    widest: (f64, usize),
    narrowest: (f64, usize),
}

impl AngleScan {
    const EMPTY: AngleScan = AngleScan {
        histogram: [0; 18],
        widest: (f64::INFINITY, 0),
        narrowest: (f64::NEG_INFINITY, 0),
    };

    /// Scans triangles `first..` of `corners`: cosines only, no inverse trigonometry.
    fn of(vertices: &[DVec2], corners: &[[u32; 3]], first: usize, ends: &[f64; 17]) -> Self {
        let mut scan = AngleScan::EMPTY;
        for (t, tri) in corners.iter().enumerate() {
            let [a, b, c] = tri.map(|k| vertices[k as usize]);
            let (ab, bc, ca) = (b - a, c - b, a - c);
            let (lab, lbc, lca) = (
                ab.length_squared(),
                bc.length_squared(),
                ca.length_squared(),
            );
            let cosines = [
                -ab.dot(ca) / (lab * lca).sqrt(),
                -bc.dot(ab) / (lbc * lab).sqrt(),
                -ca.dot(bc) / (lca * lbc).sqrt(),
            ];
            for cos in cosines {
                let bin: usize = ends.iter().map(|&e| usize::from(e >= cos)).sum();
                scan.histogram[bin] += 1;
            }
            let (lo, hi) = (
                cosines[0].min(cosines[1]).min(cosines[2]),
                cosines[0].max(cosines[1]).max(cosines[2]),
            );
            if lo < scan.widest.0 {
                scan.widest = (lo, first + t);
            }
            if hi > scan.narrowest.0 {
                scan.narrowest = (hi, first + t);
            }
        }
        scan
    }

    /// Both scans together; ties go to the earlier triangle, so the result does not depend on
    /// how the triangles were split.
    fn merge(mut self, other: AngleScan) -> AngleScan {
        for (h, o) in self.histogram.iter_mut().zip(other.histogram) {
            *h += o;
        }
        let earlier = |x: (f64, usize), y: (f64, usize)| if y.1 < x.1 { y } else { x };
        self.widest = match other.widest.0.total_cmp(&self.widest.0) {
            std::cmp::Ordering::Less => other.widest,
            std::cmp::Ordering::Equal => earlier(self.widest, other.widest),
            std::cmp::Ordering::Greater => self.widest,
        };
        self.narrowest = match other.narrowest.0.total_cmp(&self.narrowest.0) {
            std::cmp::Ordering::Greater => other.narrowest,
            std::cmp::Ordering::Equal => earlier(self.narrowest, other.narrowest),
            std::cmp::Ordering::Less => self.narrowest,
        };
        self
    }
}

/// The angle histogram of the mesh, and its exact smallest and largest angles (measured again,
/// with [`angles_deg`], on the triangles that hold them).
fn angle_quality(vertices: &[DVec2], corners: &[[u32; 3]]) -> AngleQuality {
    const CHUNK: usize = 1 << 14;
    let ends = cos_bin_ends();
    let found = corners
        .par_chunks(CHUNK)
        .enumerate()
        .map(|(k, chunk)| AngleScan::of(vertices, chunk, k * CHUNK, &ends))
        .reduce(|| AngleScan::EMPTY, AngleScan::merge);
    let angles_of = |t: usize| {
        let [a, b, c] = corners[t].map(|k| vertices[k as usize]);
        angles_deg(a, b, c)
    };
    let mut quality = AngleQuality::empty();
    quality.histogram = found.histogram;
    if !corners.is_empty() {
        quality.min = angles_of(found.narrowest.1)
            .into_iter()
            .fold(f64::INFINITY, f64::min);
        quality.max = angles_of(found.widest.1)
            .into_iter()
            .fold(f64::NEG_INFINITY, f64::max);
    }
    quality
}
