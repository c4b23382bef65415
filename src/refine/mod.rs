//! Off-center Delaunay refinement: a Delaunay mesh of the points' convex hull (or of a square
//! or rectangle around them) in which every angle is at least the user's bound and every
//! triangle at most the user's area, with far fewer triangles than the warped quadtree mesh.
//!
//! The input points go into a Delaunay triangulation of a square around them in a Morton order
//! taken on the floats themselves (any spread), so each point location walks a few steps from
//! the last insertion; many points are split into vertical strips that are triangulated in
//! parallel and glued by edge flips. For the hull, its sides are put in by flipping the edges
//! that cross them, and what lies outside goes (`hull`). Then bad triangles (an angle below
//! the bound or an area above it) are fixed smallest first, as in Har-Peled and Üngör (within
//! a size class, the smallest angle first):
//! each gets Üngör's off-center, the point on the bisector of its shortest edge that makes a
//! triangle just meeting the bound with that edge, or its circumcenter when that is closer. A
//! point that would encroach on a boundary edge (lie in its diametral circle) is not inserted;
//! the edge is split instead, as in Ruppert's algorithm: at its midpoint, or, beside a hull
//! corner narrower than 60°, on a circle around the corner of a power-of-two radius, so that
//! the splits on its two sides stop encroaching on each other. On a graph, the sequential loop
//! first deletes the free vertices inside a segment's diametral circle (Chew's rule, as
//! Triangle does), which leaves fewer vertices along the segments. A hull corner narrower than the
//! bound keeps its angle: a triangle whose smallest angle lies there, or whose shortest edge
//! spans it with its third corner no further out, is left as it is (Shewchuk's rule). Every
//! insertion keeps the triangulation Delaunay, with exact predicates.
//!
//! Termination is proven for bounds up to arcsin(1/(2√2)) ≈ 20.7°; in practice it reaches 33°
//! and more. A vertex budget stops it with an error rather than let it run without end.
//!
//! ```
//! use quadmesh::DVec2;
//! use quadmesh::mesh::AngleBounds;
//! use quadmesh::refine::{RefineOptions, refine_points};
//!
//! let points = vec![DVec2::new(0.0, 0.0), DVec2::new(1.0, 0.5), DVec2::new(0.25, 0.75)];
//! let options = RefineOptions { min_angle_deg: 30.0, ..RefineOptions::default() };
//! let (mesh, report) = refine_points(&points, &options)?;
//! mesh.validate(&points, AngleBounds { min_deg: 30.0, max_deg: 120.0 }).expect("a valid mesh");
//! mesh.check_delaunay().expect("a Delaunay mesh");
//! assert!(report.min_angle >= 30.0);
//! # Ok::<(), quadmesh::Error>(())
//! ```

mod delaunay;
mod finish;
mod hull;
mod improve;
mod local_changes;
mod ordered;
mod queue;
mod refiner;
mod replay;
mod segments;
mod sides;
mod strips;
mod tiles;

pub(crate) use finish::refine_graph_mesh;
pub(crate) use local_changes::{local_changes, point_bits};
pub use ordered::refine_points_in_order;
pub(crate) use ordered::{Stamp, canonical_delaunay, run_in_order};
pub(crate) use refiner::Bounds;
pub(crate) use replay::{Window, replay};
pub(crate) use sides::{inside_chain, on_a_side, side_changes, side_ends};
use strips::Seams;

use std::time::{Duration, Instant};

use glam::DVec2;
use rayon::prelude::*;

use crate::error::{Error, Incomplete, Unmet};
use crate::mesh::{
    AngleQuality, BoundaryEdge, BoundarySide, Domain, Mesh, MeshReport, NONE, StageTimes,
    angles_deg, interior_angles_deg, report_of,
};
use crate::morton::{FloatOrder, SortAlgorithm, bounding_box, float_morton_order};
use crate::options::Input;
use delaunay::{Cavity, Location, MAX_VERTICES, NEXT, PREV, Triangulation, locate};
use refiner::{Finish, Refiner, Work};

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
    /// The region to mesh; by default the points' convex hull.
    pub domain: RefineDomain,
    /// The sort used for Morton order.
    pub sort: SortAlgorithm,
}

impl Default for RefineOptions {
    fn default() -> Self {
        RefineOptions {
            min_angle_deg: crate::options::DEFAULT_MIN_ANGLE_DEG,
            max_area: None,
            max_vertices: None,
            domain: RefineDomain::default(),
            sort: SortAlgorithm::default(),
        }
    }
}

impl RefineOptions {
    /// Refuses bounds out of range.
    ///
    /// # Errors
    /// [`Error::InvalidOption`] naming the option.
    pub fn check(&self) -> Result<(), Error> {
        let a = self.min_angle_deg;
        if !(0.0..=MAX_MIN_ANGLE_DEG).contains(&a) {
            return Err(Error::InvalidOption {
                option: "min-angle",
                message: format!("{a} is not an angle in [0, {MAX_MIN_ANGLE_DEG}] degrees"),
            });
        }
        if let RefineDomain::Rectangle(d) = self.domain {
            d.check()?;
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

    /// Whether no bound is asked for: the mesh is the Delaunay triangulation.
    fn unbounded(&self) -> bool {
        self.min_angle_deg == 0.0 && self.max_area.is_none()
    }

    /// About how many vertices refinement of `points` uniform points makes (measured: 2.7 per
    /// point at 30°, 1.6 at 20°).
    fn expected_vertices(&self, points: usize) -> usize {
        let per_point = 1.2 + 0.055 * self.min_angle_deg;
        ((points as f64 * per_point) as usize + 64).min(self.budget(points))
    }

    fn budget(&self, points: usize) -> usize {
        self.max_vertices
            .unwrap_or(points.saturating_mul(100).saturating_add(10_000))
            .min(MAX_VERTICES)
    }
}

/// The region [`refine_points`] meshes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum RefineDomain {
    /// The points' convex hull, as Triangle meshes a bare point set.
    #[default]
    ConvexHull,
    /// The points' bounding box centred in a square twice its larger side.
    Square,
    /// A rectangle holding every point (on its sides too).
    Rectangle(Domain),
}

/// The refined Delaunay mesh of `points` on the current rayon pool, with its report.
///
/// # Errors
/// [`Error::Empty`], [`Error::NonFinite`] and [`Error::TooManyPoints`] for such input,
/// [`Error::InvalidOption`] for a bound out of range, [`Error::OutsideDomain`] for a point
/// outside a given rectangle, [`Error::Degenerate`] for collinear points on their hull,
/// [`Error::VertexBudget`] (with the mesh reached) when refinement needs more vertices than
/// allowed, and [`Error::RefinementResolution`] when it needs a vertex f64 cannot place.
pub fn refine_points(
    points: &[DVec2],
    options: &RefineOptions,
) -> Result<(Mesh, MeshReport), Error> {
    let mut times = StageTimes::default();
    let order = checked_order(points, options, &mut times)?;
    refine_order(order, points, options, times)
}

/// The options and the points checked as both point-set refinements need them, and the
/// points' Morton order (timed in `times`).
///
/// # Errors
/// As [`refine_points`] refuses options and points.
fn checked_order(
    points: &[DVec2],
    options: &RefineOptions,
    times: &mut StageTimes,
) -> Result<FloatOrder, Error> {
    options.check()?;
    let order = times.time("morton", || float_morton_order(points))?;
    check_scale(points)?;
    check_gaps(points, &order.order)?;
    if let RefineDomain::Rectangle(domain) = options.domain {
        domain.check_holds(points)?;
    }
    Ok(order)
}

/// How a planar straight-line graph is meshed, beyond the quality bounds of
/// [`RefineOptions`] (whose `domain` it does not use).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PslgOptions {
    /// Mesh the points' convex hull minus the holes (Triangle's `-c`), instead of what the
    /// segments enclose.
    pub convex_hull: bool,
    /// Never split a boundary edge (Triangle's `-Y`): boundary segments stay whole, and angles
    /// beside them may stay below the bound.
    pub no_boundary_steiner: bool,
    /// Split crossing segments at their intersection instead of refusing them.
    pub split_crossings: bool,
    /// After refinement, take out the Steiner vertices on no segment wherever what is left,
    /// with free vertices beside them moved, still meets the bounds (see `improve.rs`).
    pub remove_spare_vertices: bool,
}

/// The refined constrained Delaunay mesh of a planar straight-line graph: its points,
/// segments (each a union of mesh edges, with its marker), holes and regions (each region's
/// attribute on its triangles, its area bound applied with `options.max_area`), on the current
/// rayon pool, with its report.
///
/// The input is cleaned first ([`crate::pslg::clean`]): duplicates merged, segments split at
/// points on them (and at crossings, if asked); the segments' part runs alongside the Delaunay
/// triangulation of the merged points, whose time the report counts it in (the `clean` stage
/// is the merge). The mesh's `vertex_input` and its segment
/// pieces' `segment` refer to the input as given. Corners between segments narrower than the
/// angle bound keep their angle (see the module's notes). From 65 536 points that crowd the
/// strips' seams the points are triangulated in strips; from 16 384 points refinement runs by
/// tiles; the mesh is the same on any thread count.
///
/// # Errors
/// What [`crate::pslg::clean`] refuses, [`Error::InvalidOption`] for a bound out of range,
/// [`Error::NothingEnclosed`] when the segments enclose nothing, [`Error::Degenerate`] for
/// collinear points with `convex_hull`, and as [`refine_points`] for the refinement.
pub fn refine_pslg(
    input: &Input,
    options: &RefineOptions,
    pslg: PslgOptions,
) -> Result<(Mesh, MeshReport), Error> {
    options.check()?;
    let mut times = StageTimes::default();
    let clean_options = crate::pslg::CleanOptions {
        split_crossings: pslg.split_crossings,
    };
    let merged = times.time("clean", || crate::pslg::merge_points(input))?;
    // The segments are cleaned alongside the Delaunay triangulation of the points, which
    // cleaning changes only where it splits crossings (then the triangulation is made again):
    // the triangulation of points on curves runs in one sequence and leaves threads free.
    let early_points = merged.points.clone();
    let start = Instant::now();
    let (cleaned, early) = rayon::join(
        || crate::pslg::clean_segments(input, merged, clean_options),
        || graph_delaunay(&early_points, options),
    );
    let (clean, cleaning) = cleaned?;
    let points = &clean.points[..];
    let GraphDelaunay {
        mut t,
        mut vertex_input,
        distinct,
        morton_time,
    } = if points.len() == early_points.len() {
        early?
    } else {
        drop(early);
        graph_delaunay(points, options)?
    };
    drop(early_points);
    times.0.push(("morton", morton_time));
    times
        .0
        .push(("delaunay", start.elapsed().saturating_sub(morton_time)));
    if pslg.convex_hull {
        times.time("hull", || hull::cut_to_hull(&mut t, &mut vertex_input))?;
    }
    let constrained = times.time("segments", || {
        segments::constrain(
            &mut t,
            &mut vertex_input,
            &clean,
            pslg.convex_hull,
            options.min_angle_deg,
        )
    })?;
    let (lo, hi) = bounding_box(&t.vertices);
    let domain = Domain { lo, hi };
    let region_areas: Vec<Option<f64>> = clean.regions.iter().map(|r| r.max_area).collect();
    let bounds = Bounds::new(options, lo, hi).with_walls(
        constrained.walls,
        &region_areas,
        !pslg.no_boundary_steiner,
    );
    let budget = options.budget(distinct);
    let first_steiner = t.vertices.len() as u32;
    let unmet = times.time("refine", || {
        refine_to_budget(&mut t, &bounds, domain, distinct, budget)
    })?;
    let deleted = t.vertices_deleted;
    let mut spare_removed = 0;
    if pslg.remove_spare_vertices && unmet.is_none() && !bounds.unbounded() {
        spare_removed = times.time("spare", || {
            let removed = improve::remove_spare_vertices(&mut t, &bounds, first_steiner);
            t.pack();
            removed
        });
    }
    let mesh = times.time("mesh", || {
        let walls = bounds.walls().expect("a graph's bounds have walls");
        let (mut pieces, boundary) = segments::segment_pieces(&t, walls, &clean);
        for piece in &mut pieces {
            piece.segment = cleaning.segment_origin[piece.segment as usize];
        }
        let first_input = first_occurrences(&cleaning.point_map, points.len());
        for v in &mut vertex_input {
            if *v != NONE {
                *v = first_input[*v as usize];
            }
        }
        let regions = std::mem::take(&mut t.regions);
        let mut mesh = into_mesh(t, vertex_input, domain, Boundary::Graph(boundary));
        mesh.segments = pieces;
        if constrained.regions {
            mesh.triangle_regions = regions;
            mesh.region_attributes = clean.regions.iter().map(|r| r.attribute).collect();
        }
        mesh.holes = clean.holes.clone();
        mesh
    });
    let quality = times.time("angles", || angle_quality(&mesh.vertices, &mesh.triangles));
    let mut report = report_of(&mesh, distinct, cleaning.merged_points, &quality, times);
    report.cleaning = Some(cleaning);
    report.free_vertices_deleted = deleted;
    report.spare_vertices_removed = spare_removed;
    within_budget(mesh, report, unmet, budget)
}

/// The Delaunay triangulation of a graph's cleaned points, with the input index of each vertex,
/// the number of distinct points and the time their Morton order took.
struct GraphDelaunay {
    t: Triangulation,
    vertex_input: Vec<u32>,
    distinct: usize,
    morton_time: Duration,
}

/// The Delaunay triangulation of a graph's cleaned points and a square around them, with room
/// for the vertices refinement is expected to add.
///
/// # Errors
/// As [`check_scale`] and [`check_gaps`], and as the insertions.
fn graph_delaunay(points: &[DVec2], options: &RefineOptions) -> Result<GraphDelaunay, Error> {
    let start = Instant::now();
    let morton = float_morton_order(points)?;
    let morton_time = start.elapsed();
    check_scale(points)?;
    check_gaps(points, &morton.order)?;
    let square = square_around(points);
    let distinct = morton.order.len();
    let capacity = 2 * options.expected_vertices(distinct);
    let (t, vertex_input) = delaunay_of(
        points,
        &morton.order,
        square,
        capacity,
        Some(Seams::WhereCrowded),
    )?;
    Ok(GraphDelaunay {
        t,
        vertex_input,
        distinct,
        morton_time,
    })
}

/// For each cleaned point, the first input point at its position ([`NONE`] for a point the
/// cleaning made at a crossing).
pub(crate) fn first_occurrences(point_map: &[u32], cleaned: usize) -> Vec<u32> {
    let mut first = vec![NONE; cleaned];
    for (i, &o) in point_map.iter().enumerate().rev() {
        first[o as usize] = i as u32;
    }
    first
}

/// The Delaunay triangulation of the distinct points in Morton order `order` and the corners
/// of `square`, in strips glued at `strips` where there are many points and `strips` is given,
/// and the input index of each vertex.
fn delaunay_of(
    points: &[DVec2],
    order: &[u32],
    square: Domain,
    capacity: usize,
    strips: Option<Seams>,
) -> Result<(Triangulation, Vec<u32>), Error> {
    if let Some(glue_at) = strips {
        let count = strips::strip_count(order.len());
        if count > 1 {
            return strips::triangulate(points, order, square, count, capacity, glue_at);
        }
    }
    insert_in_one_sequence(points, order, square, capacity)
}

/// The Delaunay triangulation of the corners of `square` and the points `order` names,
/// inserted one after another, and the input index of each vertex.
fn insert_in_one_sequence(
    points: &[DVec2],
    order: &[u32],
    square: Domain,
    capacity: usize,
) -> Result<(Triangulation, Vec<u32>), Error> {
    let mut t = Triangulation::rectangle(square.lo, square.hi);
    t.reserve(capacity, order.len() + 4);
    let vertex_input = insert_in_order(&mut t, points, order)?;
    Ok((t, vertex_input))
}

/// The largest extent and coordinate, and the smallest extent, the Delaunay mode accepts: its
/// in-circle test multiplies four coordinate differences, which must neither overflow nor
/// underflow f64 (1e70^4 and 1e-70^4 stay within 1e±308 with room for the square around the
/// points and for refinement's small edges).
const MAX_SCALE: f64 = 1e70;
const MIN_EXTENT: f64 = 1e-70;

/// Refuses points at a scale where exact arithmetic breaks down.
///
/// # Errors
/// [`Error::ScaleRange`] naming the bounding box.
fn check_scale(points: &[DVec2]) -> Result<(), Error> {
    let (lo, hi) = bounding_box(points);
    let extent = (hi - lo).max_element();
    let largest = lo.abs().max(hi.abs()).max_element();
    if extent > MAX_SCALE || largest > MAX_SCALE || (extent > 0.0 && extent < MIN_EXTENT) {
        return Err(Error::ScaleRange {
            lo: lo.to_array(),
            hi: hi.to_array(),
        });
    }
    Ok(())
}

/// The smallest gap between distinct points, in either coordinate, the Delaunay mode accepts:
/// as [`MIN_EXTENT`], and for the same reason (products of four differences stay normal f64).
/// Refinement stops with [`Error::RefinementResolution`] rather than go below it.
pub(crate) const MIN_GAP: f64 = MIN_EXTENT;

/// Where a coordinate lies, for finding points within [`MIN_GAP`] of each other: a cell of
/// side [`MIN_GAP`] where f64's spacing is finer than the gap, else its exact value (where
/// f64's spacing is at least the gap, two values that close are equal).
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
enum GapKey {
    Cell(i64),
    Exact(u64),
}

impl GapKey {
    /// Twice the magnitude above which f64's spacing is at least [`MIN_GAP`] (2^52 gaps).
    const FINE: f64 = MIN_GAP * 9_007_199_254_740_992.0;

    fn of(c: f64) -> GapKey {
        if c.abs() < Self::FINE {
            GapKey::Cell((c / MIN_GAP).floor() as i64)
        } else {
            GapKey::Exact((c + 0.0).to_bits())
        }
    }

    /// The keys a value within [`MIN_GAP`] of this one can have.
    fn near(self) -> impl Iterator<Item = GapKey> {
        let cells = match self {
            GapKey::Cell(k) => [Some(k - 1), Some(k), Some(k + 1)],
            GapKey::Exact(_) => [None; 3],
        };
        let exact = match self {
            GapKey::Exact(_) => Some(self),
            GapKey::Cell(_) => None,
        };
        cells.into_iter().flatten().map(GapKey::Cell).chain(exact)
    }
}

/// Refuses two of the `distinct` points within [`MIN_GAP`] of each other in both coordinates.
/// Such a pair differs in some coordinate where both values are tiny (elsewhere f64 cannot
/// put two values that close), so only points with a tiny coordinate are looked at, in cells
/// of side [`MIN_GAP`]; two distinct points in one cell are already too close, so the look
/// ends at the first full cell and is linear.
///
/// # Errors
/// [`Error::TooClose`] naming the pair.
fn check_gaps(points: &[DVec2], distinct: &[u32]) -> Result<(), Error> {
    let tiny = |p: DVec2| p.x.abs() < GapKey::FINE || p.y.abs() < GapKey::FINE;
    let candidates: Vec<u32> = distinct
        .par_iter()
        .copied()
        .filter(|&i| tiny(points[i as usize]))
        .collect();
    let key = |i: u32| {
        let p = points[i as usize];
        (GapKey::of(p.x), GapKey::of(p.y))
    };
    let mut cells: std::collections::HashMap<(GapKey, GapKey), Vec<u32>> =
        std::collections::HashMap::new();
    for &i in &candidates {
        cells.entry(key(i)).or_default().push(i);
    }
    for &i in &candidates {
        let p = points[i as usize];
        let (kx, ky) = key(i);
        for cell in kx.near().flat_map(|x| ky.near().map(move |y| (x, y))) {
            for &j in cells.get(&cell).into_iter().flatten() {
                let q = points[j as usize];
                if j != i && (q - p).abs().max_element() < MIN_GAP {
                    let (a, b) = (i.min(j) as usize, i.max(j) as usize);
                    return Err(Error::TooClose {
                        a,
                        pa: points[a].to_array(),
                        b,
                        pb: points[b].to_array(),
                    });
                }
            }
        }
    }
    Ok(())
}

/// The square centred on the points' bounding box, twice its larger side (or of side 2 around
/// a single point).
fn square_around(points: &[DVec2]) -> Domain {
    let (lo, hi) = bounding_box(points);
    let centre = lo * 0.5 + hi * 0.5;
    let half = (hi - lo).max_element();
    let half = if half > 0.0 {
        half
    } else {
        centre.abs().max_element().max(1.0)
    };
    Domain {
        lo: centre - DVec2::splat(half),
        hi: centre + DVec2::splat(half),
    }
}

fn refine_order(
    morton: FloatOrder,
    points: &[DVec2],
    options: &RefineOptions,
    mut times: StageTimes,
) -> Result<(Mesh, MeshReport), Error> {
    let square = match options.domain {
        RefineDomain::Rectangle(d) => d,
        _ => square_around(points),
    };
    let distinct = morton.order.len();
    // Room for the tiles' chunks too, so that they seldom need the arrays to move; memory past
    // what the points need is only touched as refinement uses it.
    let capacity = 2 * options.expected_vertices(distinct);
    let (mut triangulation, mut vertex_input) = times.time("delaunay", || {
        // Without bounds the mesh of a rectangle is the Delaunay triangulation of the points and
        // its corners alone, which the strips' seams would add vertices to.
        let hull = options.domain == RefineDomain::ConvexHull;
        let strips = (hull || !options.unbounded()).then_some(Seams::Always);
        delaunay_of(points, &morton.order, square, capacity, strips)
    })?;
    let outline = match options.domain {
        RefineDomain::ConvexHull => Some(times.time("hull", || {
            hull::cut_to_hull(&mut triangulation, &mut vertex_input)
        })?),
        _ => None,
    };
    let corners: Vec<DVec2> = outline.as_ref().map_or_else(Vec::new, |h| {
        h.vertices
            .iter()
            .map(|&v| triangulation.vertices[v as usize])
            .collect()
    });
    let domain = match outline {
        Some(_) => {
            let (lo, hi) = bounding_box(&corners);
            Domain { lo, hi }
        }
        None => square,
    };
    let angles = interior_angles_deg(&corners);
    let hull_corners: Vec<(u32, DVec2, f64)> = outline
        .iter()
        .flat_map(|h| h.vertices.iter().copied())
        .zip(&corners)
        .zip(angles)
        .map(|((v, &p), a)| (v, p, a))
        .collect();
    let bounds = Bounds::new(options, domain.lo, domain.hi).with_corners(&hull_corners);
    let budget = options.budget(distinct);
    let unmet = times.time("refine", || {
        refine_to_budget(&mut triangulation, &bounds, domain, distinct, budget)
    })?;
    let boundary = if outline.is_some() {
        Boundary::Hull
    } else {
        Boundary::Rectangle
    };
    let mut mesh = times.time("mesh", || {
        into_mesh(triangulation, vertex_input, domain, boundary)
    });
    mesh.outline = outline.map(|_| corners);
    let quality = times.time("angles", || angle_quality(&mesh.vertices, &mesh.triangles));
    let report = report_of(&mesh, distinct, morton.duplicates.count, &quality, times);
    within_budget(mesh, report, unmet, budget)
}

/// Where refinement stopped short of the bounds: the triangles still outside them, and the
/// point f64 could not place where that, not the vertex budget, stopped it.
pub(crate) struct Unfinished {
    unmet: Vec<Unmet>,
    unresolved: Option<DVec2>,
}

impl Unfinished {
    /// At the vertex budget, with `unmet` left.
    pub(crate) fn at_budget(unmet: Vec<Unmet>) -> Self {
        Unfinished {
            unmet,
            unresolved: None,
        }
    }
}

/// Refines as [`refine`] does; where it stops at the vertex budget, or where f64 cannot place
/// the vertex it needs, returns the triangles still outside the bounds and that point.
fn refine_to_budget(
    t: &mut Triangulation,
    bounds: &Bounds,
    domain: Domain,
    points: usize,
    budget: usize,
) -> Result<Option<Unfinished>, Error> {
    let unresolved = match refine(t, bounds, domain, points, budget) {
        Ok(Finish::Done) => return Ok(None),
        Ok(Finish::OutOfBudget) => None,
        Err(Error::RefinementResolution { x, y, .. }) => Some(DVec2::new(x, y)),
        Err(e) => return Err(e),
    };
    Ok(Some(Unfinished {
        unmet: unmet_triangles(t, bounds),
        unresolved,
    }))
}

/// The finished mesh, or, where refinement stopped short, the error that carries the mesh it
/// reached.
pub(crate) fn within_budget(
    mesh: Mesh,
    report: MeshReport,
    unfinished: Option<Unfinished>,
    budget: usize,
) -> Result<(Mesh, MeshReport), Error> {
    let Some(Unfinished { unmet, unresolved }) = unfinished else {
        return Ok((mesh, report));
    };
    let reached = Box::new(Incomplete {
        limit: budget,
        mesh,
        report,
        unmet,
    });
    Err(match unresolved {
        None => Error::VertexBudget(reached),
        Some(p) => Error::RefinementResolution {
            x: p.x,
            y: p.y,
            reached: Some(reached),
        },
    })
}

/// The triangles still outside the bounds, where they are and how far off.
fn unmet_triangles(t: &Triangulation, bounds: &Bounds) -> Vec<Unmet> {
    (0..t.len() as u32)
        .into_par_iter()
        .filter(|&id| refiner::badness(t, bounds, id).is_some())
        .map(|id| {
            let [a, b, c] = t.corners[id as usize].map(|v| t.vertices[v as usize]);
            Unmet {
                triangle: id,
                at: (a + b + c) / 3.0,
                min_angle: angles_deg(a, b, c)
                    .into_iter()
                    .fold(f64::INFINITY, f64::min),
                area: 0.5 * (b - a).perp_dot(c - a),
            }
        })
        .collect()
}

/// Refines the Delaunay triangulation of `points` points: by tiles in parallel where there
/// are enough points, then by the sequential loop for what the tiles left. Stopped with
/// [`Error::RefinementResolution`], it leaves `t` a whole triangulation of what it reached.
fn refine(
    t: &mut Triangulation,
    bounds: &Bounds,
    domain: Domain,
    points: usize,
    budget: usize,
) -> Result<Finish, Error> {
    if bounds.unbounded() {
        // No bound asked for: the Delaunay triangulation is the mesh.
        return Ok(Finish::Done);
    }
    let first_steiner = t.vertices.len() as u32;
    let (mut bad, mut edges) = refiner::inspect_all(t, bounds);
    if points >= tiles::MIN_POINTS {
        let side = (domain.hi - domain.lo).max_element();
        (bad, edges) = tiles::refine_tiles(t, domain.lo, side, bounds, bad, edges, budget)?;
    }
    let mut work = Work::new();
    work.queue_all(&bad, &edges);
    let canonical = t.canonical;
    let mut refiner = Refiner::new(&mut *t, &mut work, bounds, budget);
    // A graph's walls are split as Triangle splits segments, deleting the free vertices in
    // their way; a canonical triangulation (the dynamic meshes') keeps every vertex.
    if bounds.walls().is_some() && !canonical {
        refiner = refiner.deleting_free_vertices_from(first_steiner);
    }
    // Stopped where f64 cannot place a vertex, the triangulation is whole all the same.
    let finish = refiner.run();
    t.pack();
    finish
}

/// Inserts the distinct points in rounds of Morton order, each walk starting from the last new
/// triangle, and returns the input index of each vertex so far (a point on a domain corner is
/// that corner).
fn insert_in_order(
    t: &mut Triangulation,
    points: &[DVec2],
    order: &[u32],
) -> Result<Vec<u32>, Error> {
    let mut vertex_input = vec![NONE; t.vertices.len()];
    vertex_input.reserve(order.len());
    let mut cavity = Cavity::default();
    let mut hint = 0;
    for index in in_rounds(order) {
        let p = points[index as usize];
        match locate(t, p, hint) {
            Location::Inside(tri) => {
                cavity.dig(t, p, tri);
                cavity.commit(t, p, None);
                vertex_input.push(index);
                hint = cavity.created()[0];
            }
            Location::Vertex(v) if vertex_input[v as usize] == NONE => {
                vertex_input[v as usize] = index;
            }
            // Distinct points inside the domain are always inserted; this guards the invariant.
            _ => return Err(Error::resolution_at(p)),
        }
    }
    Ok(vertex_input)
}

/// The points of `order` in rounds that double in size, each in the order given (a biased
/// randomized insertion order, after Amenta, Choi and Rote): a point joins round `r` (from
/// the last) with probability 2^-(r+1), decided by a hash of its index. Morton order alone
/// inserts the points of a smooth curve one after the other, which leaves long thin triangles
/// whose circumcircles every next point falls in: cavities, and the work, grow with the
/// curve. A sparse sample of the whole first keeps triangles fat and cavities small; the
/// order within a round keeps the walks short.
fn in_rounds(order: &[u32]) -> Vec<u32> {
    const MAX_ROUNDS: usize = 24;
    let rounds = (usize::BITS - order.len().leading_zeros()).clamp(1, MAX_ROUNDS as u32) as usize;
    let round_of = |index: u32| (mix(index).trailing_zeros() as usize).min(rounds - 1);
    let mut starts = [0usize; MAX_ROUNDS + 1];
    for &index in order {
        starts[rounds - round_of(index)] += 1;
    }
    for r in 1..=MAX_ROUNDS {
        starts[r] += starts[r - 1];
    }
    let mut out = vec![0; order.len()];
    for &index in order {
        let slot = &mut starts[rounds - 1 - round_of(index)];
        out[*slot] = index;
        *slot += 1;
    }
    out
}

/// A 64-bit mix of `x` (the finalizer of SplitMix64): its low bits are about independent.
fn mix(x: u32) -> u64 {
    let mut z = u64::from(x).wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The mesh of a finished triangulation: vertex `k` of the triangulation is vertex `k` of the
/// mesh (the domain's corners, the points in Morton order, then the Steiner points in order of
/// insertion), and triangles keep their numbers. `vertex_input` covers the corners and points.
fn into_mesh(
    t: Triangulation,
    mut vertex_input: Vec<u32>,
    domain: Domain,
    boundary: Boundary,
) -> Mesh {
    let Triangulation {
        vertices,
        corners,
        mut across,
        ..
    } = t;
    vertex_input.resize(vertices.len(), NONE);
    let boundary = match boundary {
        Boundary::Graph(edges) => {
            // Only a graph's links carry segment marks.
            across
                .par_iter_mut()
                .for_each(|n| *n = n.map(delaunay::beyond));
            edges
        }
        Boundary::Hull => boundary_edges(&corners, &across, &vertices, None),
        Boundary::Rectangle => boundary_edges(&corners, &across, &vertices, Some(domain)),
    };
    Mesh {
        outline: None,
        vertices,
        vertex_input,
        triangles: corners,
        neighbours: across,
        boundary,
        domain,
        ..Mesh::default()
    }
}

/// What bounds a finished triangulation, for its boundary edges' markers.
enum Boundary {
    /// The rectangle `domain`: markers by side.
    Rectangle,
    /// The points' convex hull: [`HULL_MARKER`].
    Hull,
    /// A graph's segments and hull sides, whose boundary edges and markers
    /// [`segments::segment_pieces`] found.
    Graph(Vec<BoundaryEdge>),
}

/// The marker of the edges on the points' convex hull (Triangle's).
pub const HULL_MARKER: i32 = 1;

/// The triangle edges on the domain's boundary, with their markers: a rectangle's sides, or
/// [`HULL_MARKER`].
fn boundary_edges(
    corners: &[[u32; 3]],
    across: &[[u32; 3]],
    vertices: &[DVec2],
    rectangle: Option<Domain>,
) -> Vec<BoundaryEdge> {
    let side_of = |a: DVec2, b: DVec2| {
        let Some(domain) = rectangle else {
            return HULL_MARKER;
        };
        if a.y == domain.lo.y && b.y == domain.lo.y {
            BoundarySide::Bottom.marker()
        } else if a.x == domain.hi.x && b.x == domain.hi.x {
            BoundarySide::Right.marker()
        } else if a.y == domain.hi.y && b.y == domain.hi.y {
            BoundarySide::Top.marker()
        } else {
            BoundarySide::Left.marker()
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
            marker: side_of(vertices[a as usize], vertices[b as usize]),
        })
        .collect()
}

/// How many triangles ahead the angle scan asks for the corners it will read: the vertices of
/// consecutive triangles lie far apart in memory.
const PREFETCH_AHEAD: usize = 16;

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
            if let Some(ahead) = corners.get(t + PREFETCH_AHEAD) {
                for &k in ahead {
                    crate::par::prefetch(vertices.as_ptr().wrapping_add(k as usize));
                }
            }
            let [a, b, c] = tri.map(|k| vertices[k as usize]);
            let (ab, bc, ca) = (b - a, c - b, a - c);
            let (lab, lbc, lca) = (
                ab.length_squared(),
                bc.length_squared(),
                ca.length_squared(),
            );
            let products = [lab * lca, lbc * lab, lca * lbc];
            let cosines = match products.iter().all(|p| p.is_normal()) {
                true => [
                    -ab.dot(ca) / products[0].sqrt(),
                    -bc.dot(ab) / products[1].sqrt(),
                    -ca.dot(bc) / products[2].sqrt(),
                ],
                // Products past f64's range: the vectors scaled first.
                false => crate::mesh::corner_cosines(a, b, c),
            };
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
pub(crate) fn angle_quality(vertices: &[DVec2], corners: &[[u32; 3]]) -> AngleQuality {
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

#[cfg(test)]
mod tests {
    use super::*;

    fn gaps(points: &[DVec2]) -> Result<(), Error> {
        let all: Vec<u32> = (0..points.len() as u32).collect();
        check_gaps(points, &all)
    }

    #[test]
    fn only_points_within_the_gap_in_both_coordinates_are_refused() {
        let big = 5.0;
        // The same coordinate where f64's spacing is coarse, a tiny gap in the other.
        let close = [DVec2::new(big, 1e-80), DVec2::new(big, 3e-80)];
        assert!(matches!(
            gaps(&close),
            Err(Error::TooClose { a: 0, b: 1, .. })
        ));
        // Neighbouring cells, across zero.
        let across = [DVec2::new(-4e-71, 0.0), DVec2::new(4e-71, 0.0)];
        assert!(matches!(gaps(&across), Err(Error::TooClose { .. })));
        // A tiny gap in one coordinate only, or adjacent floats where f64 is coarse: accepted.
        let far_in_y = [DVec2::new(0.0, 0.0), DVec2::new(1e-80, 1.0)];
        assert!(gaps(&far_in_y).is_ok());
        let adjacent = [
            DVec2::new(big, 0.0),
            DVec2::new(f64::from_bits(big.to_bits() + 1), 0.0),
        ];
        assert!(gaps(&adjacent).is_ok());
        let apart = [DVec2::ZERO, DVec2::new(2e-70, 0.0), DVec2::new(0.0, -2e-70)];
        assert!(gaps(&apart).is_ok());
    }
}
