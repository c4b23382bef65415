//! The check of a mesh of a planar straight-line graph against its cleaned input.
//!
//! The domain is worked out from the input alone, with Triangle's semantics: the faces of the
//! planar graph of the segments (a half-edge face traversal, each connected component's outer
//! cycle nested in the face around it by exact winding numbers), less the unbounded face (`-p`)
//! and the faces holding a hole seed; with `hull` (`-c`), the graph includes the points' convex
//! hull, so the faces fill the hull. Region seeds then name their faces in input order, a later
//! seed in a face overriding an earlier one.
//!
//! Exact predicates decide every side, winding and angular order; the tolerances are the area
//! sum's relative 1e-9 (plus what the split vertices' rounding moves it by), the angle bounds'
//! 1e-9 degrees and [`SPLIT_ULPS`] roundings for vertices that split a segment or a hull side.
//! Split vertices are ordered along their segment by their coordinates, exactly.

use std::cmp::Ordering;
use std::collections::{HashMap, HashSet};

use glam::DVec2;
use rayon::prelude::*;
use rstar::RTree;
use rstar::primitives::{GeomWithData, Rectangle};

use super::validate::{
    ANGLE_SLACK_DEG, AREA_REL_TOL, AngleBounds, InvalidMesh, MeshCheck, Sum, check_counts,
    check_distinct, check_edges, check_inputs_once, check_orientation, compare_boundary,
    directed_key, fault, first_fault, input_vertex_fault, key_vertices, point_fault, pt,
    sorted_by_position, triangle_index_fault,
};
use super::{Mesh, NONE, SubSegment, angles_deg};
use crate::options::{Input, Segment};
use crate::predicates::{Orientation, orient_value, orientation};

/// How far, in roundings of its coordinates and length, a vertex splitting a segment or a hull
/// side may lie from its line: each split point is a rounded midpoint or shell point, and
/// splits of splits add up.
const SPLIT_ULPS: f64 = 64.0;

/// Checks `mesh` as a mesh of the planar straight-line graph `input` (cleaned: no duplicate
/// points, no point inside a segment, no crossing segments) with Triangle's `-p` domain: what the
/// segments enclose, less the faces of the hole seeds. See [`validate_pslg_with`].
///
/// # Errors
/// [`InvalidMesh`]: which check failed and its first fault.
pub fn validate_pslg(mesh: &Mesh, input: &Input, bounds: AngleBounds) -> Result<(), InvalidMesh> {
    validate_pslg_with(mesh, input, bounds, false)
}

/// Checks `mesh` as a mesh of the planar straight-line graph `input`; with `hull` the domain is
/// the points' convex hull less the faces of the hole seeds (Triangle's `-c`), without it what
/// the segments enclose less those faces (`-p`).
///
/// In order:
/// 1. [`MeshCheck::Sizes`], `Orientation`, `DistinctVertices`, `Edges`: as [`super::validate`],
///    plus the PSLG fields' sizes and indices; `Boundary`: `mesh.boundary` is the set of edges
///    with one triangle.
/// 2. `Conformity`: every input point in or beside a face of the domain a vertex of a triangle,
///    bit for bit (one away from the domain may be left out, or kept in no triangle).
///    `Segments`: the pieces of each segment in `mesh.segments` run from its first end to its
///    second, each an edge of a triangle with the segment's marker, the vertices between on its
///    line within 64 roundings (of its largest coordinate plus its length) and in order; a
///    segment with no face of the domain beside it has no pieces. `Boundary`: every edge with
///    one triangle lies on a segment or (`hull`) on a hull side.
/// 3. `Domain`: every triangle in a face of the domain (triangles joined across edges that are no
///    segment's share a face, located once by its largest triangle's centroid), no triangle on a
///    hole seed; `Area`: the triangles' areas sum to the domain's within a relative 1e-9 and
///    the rounding of the vertices that split its edges.
/// 4. `Regions`: each triangle's region is the last region seed in its face, or [`NONE`].
/// 5. `Angles`: every angle within `bounds` (1e-9° slack), except where two segments (or hull
///    sides) meet at an input point at less than `bounds.min_deg`: a triangle whose smallest
///    angle is at that point, or whose shortest edge joins a vertex on one of the two to a vertex
///    on the other, keeps its angles.
///
/// # Errors
/// [`InvalidMesh`]: which check failed and its first fault. A hole or region seed lying on a
/// segment or an input point names no face and is reported as a `Domain` or `Regions` fault.
///
/// # Complexity
/// O(n log n) in the mesh (a hole seed is looked for only among the triangles whose x range
/// holds it), and O(f·s) in the input for f faces and s segments: each group of triangles,
/// seed and nested component is located by a scan of the cycles.
pub fn validate_pslg_with(
    mesh: &Mesh,
    input: &Input,
    bounds: AngleBounds,
    hull: bool,
) -> Result<(), InvalidMesh> {
    use MeshCheck::*;
    check_sizes(mesh, input).map_err(fault(Sizes))?;
    check_orientation(mesh).map_err(fault(Orientation))?;
    let by_position = sorted_by_position(&mesh.vertices);
    check_distinct(&by_position).map_err(fault(DistinctVertices))?;
    let single = check_edges(mesh).map_err(fault(Edges))?;
    check_boundary_list(mesh, &single).map_err(fault(Boundary))?;
    check_input_vertices(mesh, &input.points).map_err(fault(Conformity))?;
    let at = vertex_of_point(mesh, input.points.len());
    let graph = Graph::new(&input.points, &input.segments, hull).map_err(fault(Domain))?;
    let faces = Faces::new(&graph);
    let holes = hole_faces(&graph, &faces, &input.holes).map_err(fault(Domain))?;
    let carved = Carved {
        graph: &graph,
        faces: &faces,
        holes: &holes,
    };
    check_points_used(mesh, &input.points, &by_position, &at, &carved)
        .map_err(fault(Conformity))?;
    drop(by_position);
    let pieces = check_segments(mesh, input, &at, &carved).map_err(fault(Segments))?;
    let on = vertex_edges(mesh, &graph, &at, &single, &pieces).map_err(fault(Boundary))?;
    let face = triangle_faces(mesh, &pieces, &graph, &faces).map_err(fault(Domain))?;
    check_in_domain(mesh, &face, &holes, hull).map_err(fault(Domain))?;
    check_hole_seeds(mesh, &input.holes).map_err(fault(Domain))?;
    check_area(mesh, &graph, &faces, &holes).map_err(fault(Area))?;
    let regions = region_faces(&graph, &faces, &holes, input).map_err(fault(Regions))?;
    check_regions(mesh, &face, &regions).map_err(fault(Regions))?;
    let narrow = NarrowAngles::new(&graph, &at, bounds.min_deg);
    check_angles(mesh, &narrow, &on, bounds).map_err(fault(Angles))
}

/// The key of the undirected edge `a b`.
fn undirected(a: u32, b: u32) -> u64 {
    directed_key(a.min(b), a.max(b))
}

/// The largest distance from the line `a b` that [`SPLIT_ULPS`] roundings allow.
fn line_tolerance(a: DVec2, b: DVec2) -> f64 {
    let scale = a.abs().max_element().max(b.abs().max_element()) + a.distance(b);
    SPLIT_ULPS * f64::EPSILON * scale
}

/// Where `p` lies along `a → b` (0 at `a`, 1 at `b`) and how far from its line.
fn along_and_off(p: DVec2, a: DVec2, b: DVec2) -> (f64, f64) {
    let d = b - a;
    let t = (p - a).dot(d) / d.length_squared();
    (t, d.perp_dot(p - a).abs() / d.length())
}

fn centroid(mesh: &Mesh, t: usize) -> DVec2 {
    let [a, b, c] = mesh.triangles[t].map(|v| mesh.vertices[v as usize]);
    (a + b + c) / 3.0
}

/// Twice the signed area of triangle `t`, by the adaptive determinant (the plain cross product
/// loses a thin triangle's area with far corners to cancellation).
fn twice_area(mesh: &Mesh, t: usize) -> f64 {
    let [a, b, c] = mesh.triangles[t].map(|v| mesh.vertices[v as usize]);
    orient_value(a, b, c)
}

// ---------------------------------------------------------------------------------------------
// 1. Sizes, indices and the boundary list

fn check_sizes(mesh: &Mesh, input: &Input) -> Result<(), String> {
    check_counts(mesh)?;
    check_input(input)?;
    let (nv, nt) = (mesh.vertices.len(), mesh.triangles.len());
    first_fault(nv, |v| {
        let p = mesh.vertices[v];
        (!p.is_finite()).then(|| format!("vertex {v} has a non-finite coordinate {}", pt(p)))
    })?;
    first_fault(nt, |t| triangle_index_fault(mesh, t))?;
    first_fault(mesh.boundary.len(), |e| {
        let vs = mesh.boundary[e].vertices;
        vs.iter()
            .any(|&v| v as usize >= nv)
            .then(|| format!("boundary edge {e} {vs:?}: vertex index out of range ({nv} vertices)"))
    })?;
    first_fault(mesh.segments.len(), |k| piece_index_fault(mesh, input, k))?;
    check_region_fields(mesh, input)
}

/// The input must be what cleaning leaves: finite, its segments joining two distinct points.
fn check_input(input: &Input) -> Result<(), String> {
    let np = input.points.len();
    if np >= NONE as usize {
        return Err(format!("{np} input points do not fit u32 indices"));
    }
    let seeds = input.regions.iter().map(|r| &r.seed);
    let mut all = input.points.iter().chain(&input.holes).chain(seeds);
    if let Some(&p) = all.find(|p| !p.is_finite()) {
        return Err(format!(
            "the input has a non-finite point or seed {}",
            pt(p)
        ));
    }
    let bad = |s: &Segment| s.ends.iter().any(|&e| e as usize >= np) || s.ends[0] == s.ends[1];
    match input.segments.iter().position(bad) {
        Some(s) => Err(format!(
            "input segment {s} {:?} does not join two of the {np} input points",
            input.segments[s].ends
        )),
        None => Ok(()),
    }
}

fn piece_index_fault(mesh: &Mesh, input: &Input, k: usize) -> Option<String> {
    let piece = mesh.segments[k];
    let nv = mesh.vertices.len();
    if piece.vertices.iter().any(|&v| v as usize >= nv) {
        return Some(format!(
            "segment piece {k} {:?}: vertex index out of range ({nv} vertices)",
            piece.vertices
        ));
    }
    let ns = input.segments.len();
    (piece.segment as usize >= ns).then(|| {
        format!(
            "segment piece {k} lies on segment {}, out of range ({ns} input segments)",
            piece.segment
        )
    })
}

fn check_region_fields(mesh: &Mesh, input: &Input) -> Result<(), String> {
    let (nt, nr) = (mesh.triangles.len(), input.regions.len());
    let want = if nr == 0 { 0 } else { nt };
    if mesh.triangle_regions.len() != want {
        return Err(format!(
            "triangle_regions has {} entries for {nt} triangles and {nr} region seeds",
            mesh.triangle_regions.len()
        ));
    }
    let same = mesh.region_attributes.len() == nr
        && (mesh.region_attributes.iter().zip(&input.regions))
            .all(|(a, r)| a.to_bits() == r.attribute.to_bits());
    if !same {
        return Err(format!(
            "region_attributes {:?} are not the region seeds' attributes",
            mesh.region_attributes
        ));
    }
    if mesh.holes != input.holes {
        return Err(format!(
            "holes {:?} are not the input's hole seeds {:?}",
            mesh.holes, input.holes
        ));
    }
    first_fault(mesh.triangle_regions.len(), |t| {
        let r = mesh.triangle_regions[t];
        (r != NONE && r as usize >= nr)
            .then(|| format!("triangle {t} is in region {r}, out of range ({nr} region seeds)"))
    })
}

/// `mesh.boundary` must list each edge with one triangle once, in that triangle's direction.
fn check_boundary_list(mesh: &Mesh, single: &[(u64, usize)]) -> Result<(), String> {
    let mut listed: Vec<(u64, usize)> = mesh
        .boundary
        .iter()
        .enumerate()
        .map(|(e, be)| (directed_key(be.vertices[0], be.vertices[1]), e))
        .collect();
    listed.sort_unstable();
    if let Some(w) = listed.windows(2).find(|w| w[0].0 == w[1].0) {
        let (a, b) = key_vertices(w[0].0);
        return Err(format!(
            "boundary edges {} and {} are both {a}->{b}",
            w[0].1, w[1].1
        ));
    }
    compare_boundary(mesh, single, &listed)
}

// ---------------------------------------------------------------------------------------------
// 2. Conformity: points, segments, boundary

/// Every vertex that is an input point at it, bit for bit, and no point two vertices.
fn check_input_vertices(mesh: &Mesh, points: &[DVec2]) -> Result<(), String> {
    first_fault(mesh.vertices.len(), |v| input_vertex_fault(mesh, points, v))?;
    check_inputs_once(mesh)
}

/// The vertex of each input point, or `NONE`.
fn vertex_of_point(mesh: &Mesh, n: usize) -> Vec<u32> {
    let mut at = vec![NONE; n];
    for (v, &i) in mesh.vertex_input.iter().enumerate() {
        if i != NONE {
            at[i as usize] = v as u32;
        }
    }
    at
}

/// An input point in or beside a face of the domain must be a vertex in a triangle; one away
/// from the domain may be left out (as Triangle's `-j` does) or kept in no triangle.
fn check_points_used(
    mesh: &Mesh,
    points: &[DVec2],
    by_position: &[((u64, u64), u32)],
    at: &[u32],
    carved: &Carved,
) -> Result<(), String> {
    let mut used = vec![false; mesh.vertices.len()];
    for &v in mesh.triangles.iter().flatten() {
        used[v as usize] = true;
    }
    first_fault(at.len(), |i| {
        if !carved.touches(i as u32) {
            return None;
        }
        let v = at[i];
        if v == NONE {
            let missing = || format!("input point {i} at {} is not a vertex", pt(points[i]));
            return point_fault(mesh, points, by_position, i).or_else(|| Some(missing()));
        }
        (!used[v as usize]).then(|| {
            format!(
                "vertex {v}, input point {i} at {}, is in no triangle but borders the domain",
                pt(points[i])
            )
        })
    })
}

/// Every edge of a triangle, as sorted undirected keys.
fn mesh_edges(mesh: &Mesh) -> Vec<u64> {
    let mut keys: Vec<u64> = mesh
        .triangles
        .par_iter()
        .flat_map_iter(|&[a, b, c]| [undirected(a, b), undirected(b, c), undirected(c, a)])
        .collect();
    keys.par_sort_unstable();
    keys.dedup();
    keys
}

/// Walks the pieces of each input segment next to the domain (the others must have none);
/// returns the pieces' undirected keys.
fn check_segments(
    mesh: &Mesh,
    input: &Input,
    at: &[u32],
    carved: &Carved,
) -> Result<HashSet<u64>, String> {
    let edges = mesh_edges(mesh);
    let mut k = 0;
    for (s, segment) in input.segments.iter().enumerate() {
        let run = mesh.segments[k..]
            .iter()
            .take_while(|piece| piece.segment as usize == s)
            .count();
        if !carved.borders(s) {
            if run > 0 {
                return Err(format!(
                    "segment {s} has {run} pieces, but the faces on both its sides are outside \
                     the domain"
                ));
            }
            continue;
        }
        let chain = Chain {
            mesh,
            s,
            segment,
            at,
            edges: &edges,
        };
        chain.check(&mesh.segments[k..k + run], k)?;
        k += run;
    }
    if k < mesh.segments.len() {
        return Err(format!(
            "segment piece {k} (of segment {}) is out of order: the pieces must be sorted by \
             segment",
            mesh.segments[k].segment
        ));
    }
    Ok(mesh
        .segments
        .iter()
        .map(|piece| undirected(piece.vertices[0], piece.vertices[1]))
        .collect())
}

/// One input segment and what its pieces are checked against.
struct Chain<'a> {
    mesh: &'a Mesh,
    s: usize,
    segment: &'a Segment,
    at: &'a [u32],
    edges: &'a [u64],
}

impl Chain<'_> {
    /// `run` (starting at piece `k0` of `mesh.segments`) must lead from the first end to the
    /// second through triangle edges, turning nowhere.
    fn check(&self, run: &[SubSegment], k0: usize) -> Result<(), String> {
        let (s, [i, j]) = (self.s, self.segment.ends);
        let (first, last) = (self.at[i as usize], self.at[j as usize]);
        if run.is_empty() {
            return Err(format!(
                "segment {s} (vertices {first}->{last}) has no pieces at piece {k0} of the list"
            ));
        }
        let (mut from, mut after) = (first, self.mesh.vertices[first as usize]);
        for (n, piece) in run.iter().enumerate() {
            self.check_piece(k0 + n, piece, from)?;
            let w = piece.vertices[1];
            if w == last && n + 1 < run.len() {
                return Err(format!(
                    "segment {s} reaches its second end at piece {} of its {}",
                    n + 1,
                    run.len()
                ));
            }
            if w != last {
                after = self.split_vertex(w, after)?;
            }
            from = w;
        }
        if from != last {
            return Err(format!(
                "the pieces of segment {s} end at vertex {from}, not at its second end, vertex \
                 {last}"
            ));
        }
        Ok(())
    }

    fn check_piece(&self, k: usize, piece: &SubSegment, from: u32) -> Result<(), String> {
        let (s, [u, w]) = (self.s, piece.vertices);
        if piece.marker != self.segment.marker {
            return Err(format!(
                "segment piece {k} has marker {}, its segment {s} {}",
                piece.marker, self.segment.marker
            ));
        }
        if u != from {
            return Err(format!(
                "segment piece {k} {u}->{w} of segment {s} starts at vertex {u}, not at vertex \
                 {from} where the segment has got to"
            ));
        }
        match self.edges.binary_search(&undirected(u, w)) {
            Ok(_) => Ok(()),
            Err(_) => Err(format!(
                "segment piece {k} {u}->{w} of segment {s} is not an edge of any triangle"
            )),
        }
    }

    /// A vertex between the segment's ends: a Steiner vertex on its line, beyond the vertex
    /// at `after`.
    fn split_vertex(&self, w: u32, after: DVec2) -> Result<DVec2, String> {
        let (mesh, s) = (self.mesh, self.s);
        let [i, j] = self.segment.ends;
        let input = mesh.vertex_input[w as usize];
        if input != NONE {
            return Err(format!(
                "segment {s} passes through vertex {w}, input point {input}, not one of its ends"
            ));
        }
        let [a, b] = [i, j].map(|e| mesh.vertices[self.at[e as usize] as usize]);
        let p = mesh.vertices[w as usize];
        let (t, off) = along_and_off(p, a, b);
        let tolerance = line_tolerance(a, b);
        if off > tolerance {
            return Err(format!(
                "vertex {w} at {} on segment {s} lies {off:e} from its line {} {} (tolerance \
                 {tolerance:e})",
                pt(p),
                pt(a),
                pt(b)
            ));
        }
        let d = b - a;
        if !(further_along(p, after, d) && further_along(b, p, d)) {
            return Err(format!(
                "vertex {w} at {} on segment {s} is out of order: {t} of the way along, after \
                 the vertex at {}",
                pt(p),
                pt(after)
            ));
        }
        Ok(p)
    }
}

/// Whether `p` lies strictly further than `q` in the direction `d`, for points on one line:
/// compared by the coordinate along which `d` changes most, then the other (exact, where the
/// fraction of the way along, a rounded quotient, can tie for distinct points of a long
/// segment).
fn further_along(p: DVec2, q: DVec2, d: DVec2) -> bool {
    let (major, minor) = if d.x.abs() >= d.y.abs() {
        ((p.x, q.x, d.x), (p.y, q.y, d.y))
    } else {
        ((p.y, q.y, d.y), (p.x, q.x, d.x))
    };
    let ahead = |(p, q, d): (f64, f64, f64)| (p - q) * d.signum();
    let along = ahead(major);
    along > 0.0 || (along == 0.0 && minor.2 != 0.0 && ahead(minor) > 0.0)
}

/// Checks that every edge with one triangle lies on a segment or (with a hull) a hull side;
/// returns each vertex on a graph edge with that edge, sorted.
fn vertex_edges(
    mesh: &Mesh,
    graph: &Graph,
    at: &[u32],
    single: &[(u64, usize)],
    pieces: &HashSet<u64>,
) -> Result<Vec<(u32, u32)>, String> {
    let hull = (!graph.hull.is_empty()).then(|| HullSides::new(mesh, graph, at));
    let mut on = Vec::new();
    for &(key, t) in single {
        let (a, b) = key_vertices(key);
        if pieces.contains(&undirected(a, b)) {
            continue;
        }
        let Some(e) = hull.as_ref().and_then(|h| h.side_of(a, b)) else {
            let what = if hull.is_some() {
                "segment or hull side"
            } else {
                "segment"
            };
            return Err(format!(
                "edge {a}->{b} of triangle {t} {:?} has no other triangle but lies on no {what}",
                mesh.triangles[t]
            ));
        };
        on.extend([(a, e), (b, e)]);
    }
    for piece in &mesh.segments {
        on.extend(piece.vertices.map(|v| (v, piece.segment)));
    }
    on.sort_unstable();
    on.dedup();
    Ok(on)
}

/// The graph edges vertex `v` lies on, from [`vertex_edges`]' list.
fn edges_at(on: &[(u32, u32)], v: u32) -> &[(u32, u32)] {
    let lo = on.partition_point(|&(u, _)| u < v);
    let hi = on.partition_point(|&(u, _)| u <= v);
    &on[lo..hi]
}

/// Which hull side a boundary vertex lies on.
struct HullSides<'a> {
    mesh: &'a Mesh,
    graph: &'a Graph<'a>,
    /// The corner index of each hull corner's vertex.
    corner: HashMap<u32, usize>,
    /// A point inside the hull.
    centre: DVec2,
    /// Each corner's direction from `centre` (radians) and its index, sorted.
    by_angle: Vec<(f64, usize)>,
}

impl<'a> HullSides<'a> {
    fn new(mesh: &'a Mesh, graph: &'a Graph<'a>, at: &[u32]) -> Self {
        let hull = &graph.hull;
        let corner = hull
            .iter()
            .enumerate()
            .map(|(k, &p)| (at[p as usize], k))
            .filter(|&(v, _)| v != NONE)
            .collect();
        let centre = hull.iter().map(|&p| graph.at(p)).sum::<DVec2>() / hull.len() as f64;
        let mut by_angle: Vec<(f64, usize)> = hull
            .iter()
            .enumerate()
            .map(|(k, &p)| (direction(graph.at(p) - centre), k))
            .collect();
        by_angle.sort_by(|x, y| x.0.total_cmp(&y.0));
        HullSides {
            mesh,
            graph,
            corner,
            centre,
            by_angle,
        }
    }

    /// The sides vertex `v` may lie on: a corner's two, or the side the direction from the
    /// centre points at and its neighbours.
    fn candidates(&self, v: u32) -> [usize; 3] {
        let n = self.by_angle.len();
        if let Some(&k) = self.corner.get(&v) {
            return [(k + n - 1) % n, k, k];
        }
        let angle = direction(self.mesh.vertices[v as usize] - self.centre);
        let i = self.by_angle.partition_point(|&(a, _)| a <= angle);
        let k = self.by_angle[(i + n - 1) % n].1;
        [(k + n - 1) % n, k, (k + 1) % n]
    }

    /// Whether vertex `v` lies on side `k`: at a corner of it, or between them on its line.
    fn on_side(&self, v: u32, k: usize) -> bool {
        let hull = &self.graph.hull;
        let a = self.graph.at(hull[k]);
        let b = self.graph.at(hull[(k + 1) % hull.len()]);
        let p = self.mesh.vertices[v as usize];
        if p == a || p == b {
            return true;
        }
        let (t, off) = along_and_off(p, a, b);
        t > 0.0 && t < 1.0 && off <= line_tolerance(a, b)
    }

    /// The graph edge of the hull side the edge `a b` lies on, if any.
    fn side_of(&self, a: u32, b: u32) -> Option<u32> {
        self.candidates(a)
            .into_iter()
            .find(|&k| self.on_side(a, k) && self.on_side(b, k))
            .map(|k| self.graph.hull_edges[k])
    }
}

fn direction(d: DVec2) -> f64 {
    d.y.atan2(d.x)
}

// ---------------------------------------------------------------------------------------------
// 3. The planar graph and its faces

/// The planar graph of the input's segments, and of the points' convex hull with `hull`.
///
/// Half-edge `h` runs along edge `h / 2`, from its first end when `h` is even.
struct Graph<'a> {
    points: &'a [DVec2],
    /// How many of the edges are input segments.
    segments: usize,
    /// The ends of each edge: the input's segments in order, then the hull sides that are no
    /// segment.
    ends: Vec<[u32; 2]>,
    /// The half-edges leaving point `p` are `out[first[p]..first[p + 1]]`, counter-clockwise
    /// from the direction of +x.
    first: Vec<usize>,
    out: Vec<u32>,
    /// The position of each half-edge in its origin's list.
    slot: Vec<u32>,
    /// The hull's corners counter-clockwise, every input point on its sides among them (`hull`).
    hull: Vec<u32>,
    /// The edge along each hull side, from corner `k` to corner `k + 1`.
    hull_edges: Vec<u32>,
    /// Each edge's bounding box, for finding the edges a point may lie on.
    edge_boxes: RTree<IndexedBox>,
}

/// A bounding box and what it bounds (an edge, a cycle), by index.
type IndexedBox = GeomWithData<Rectangle<[f64; 2]>, usize>;

fn indexed_box([lo, hi]: [DVec2; 2], index: usize) -> IndexedBox {
    GeomWithData::new(Rectangle::from_corners(lo.to_array(), hi.to_array()), index)
}

impl<'a> Graph<'a> {
    fn new(points: &'a [DVec2], segments: &[Segment], hull: bool) -> Result<Self, String> {
        let mut ends: Vec<[u32; 2]> = segments.iter().map(|s| s.ends).collect();
        let (hull, hull_edges) = if hull {
            add_hull(points, &mut ends)?
        } else {
            (Vec::new(), Vec::new())
        };
        let (first, out, slot) = stars(points, &ends);
        let boxes = ends
            .iter()
            .enumerate()
            .map(|(e, &[i, j])| {
                let (a, b) = (points[i as usize], points[j as usize]);
                indexed_box([a.min(b), a.max(b)], e)
            })
            .collect();
        Ok(Graph {
            points,
            segments: segments.len(),
            edge_boxes: RTree::bulk_load(boxes),
            ends,
            first,
            out,
            slot,
            hull,
            hull_edges,
        })
    }

    fn at(&self, p: u32) -> DVec2 {
        self.points[p as usize]
    }

    fn origin(&self, h: u32) -> u32 {
        self.ends[(h / 2) as usize][(h % 2) as usize]
    }

    fn head(&self, h: u32) -> u32 {
        self.ends[(h / 2) as usize][1 - (h % 2) as usize]
    }

    fn star(&self, p: u32) -> &[u32] {
        &self.out[self.first[p as usize]..self.first[p as usize + 1]]
    }

    /// The half-edge after `h` around the face on its left: the first clockwise from `h`'s
    /// twin around `h`'s head.
    fn next(&self, h: u32) -> u32 {
        let star = self.star(self.head(h));
        let s = self.slot[(h ^ 1) as usize] as usize;
        star[(s + star.len() - 1) % star.len()]
    }

    /// The first edge `p` lies on (its ends included), exactly: among those whose boxes hold
    /// it.
    fn edge_through(&self, p: DVec2) -> Option<usize> {
        self.edge_boxes
            .locate_all_at_point(p.to_array())
            .map(|b| b.data)
            .filter(|&e| {
                let [i, j] = self.ends[e];
                orientation(self.at(i), self.at(j), p) == Orientation::On
            })
            .min()
    }

    fn edge_name(&self, e: usize) -> String {
        if e < self.segments {
            format!("segment {e}")
        } else {
            let [i, j] = self.ends[e];
            format!("the hull side from input point {i} to {j}")
        }
    }
}

/// Adds the hull sides that are no segment to `ends`; returns the hull's corners and the edge
/// along each side.
fn add_hull(points: &[DVec2], ends: &mut Vec<[u32; 2]>) -> Result<(Vec<u32>, Vec<u32>), String> {
    let corners = convex_hull(points)?;
    let mut known: HashMap<u64, u32> = ends
        .iter()
        .enumerate()
        .map(|(e, &[a, b])| (undirected(a, b), e as u32))
        .collect();
    let n = corners.len();
    let edges = (0..n)
        .map(|k| {
            let (a, b) = (corners[k], corners[(k + 1) % n]);
            *known.entry(undirected(a, b)).or_insert_with(|| {
                ends.push([a, b]);
                (ends.len() - 1) as u32
            })
        })
        .collect();
    Ok((corners, edges))
}

/// The points' convex hull, counter-clockwise, with every point on its sides (monotone chain,
/// exact turns).
fn convex_hull(points: &[DVec2]) -> Result<Vec<u32>, String> {
    let mut order: Vec<u32> = (0..points.len() as u32).collect();
    order.sort_by(|&i, &j| {
        let (p, q) = (points[i as usize], points[j as usize]);
        p.x.total_cmp(&q.x).then(p.y.total_cmp(&q.y))
    });
    let chain = |ids: &mut dyn Iterator<Item = u32>| {
        let mut h: Vec<u32> = Vec::new();
        for i in ids {
            while let [.., a, b] = h[..]
                && orientation(points[a as usize], points[b as usize], points[i as usize])
                    == Orientation::Right
            {
                h.pop();
            }
            h.push(i);
        }
        h.pop();
        h
    };
    let mut hull = chain(&mut order.iter().copied());
    hull.extend(chain(&mut order.iter().rev().copied()));
    let n = hull.len();
    let turns = (0..n).any(|k| {
        let [a, b, c] = [k, k + 1, k + 2].map(|i| points[hull[i % n] as usize]);
        orientation(a, b, c) == Orientation::Left
    });
    if turns {
        Ok(hull)
    } else {
        Err("the input points are collinear: their convex hull has no area".into())
    }
}

/// Each point's outgoing half-edges sorted counter-clockwise, as `(first, out, slot)` of
/// [`Graph`].
fn stars(points: &[DVec2], ends: &[[u32; 2]]) -> (Vec<usize>, Vec<u32>, Vec<u32>) {
    let end = |h: u32, k: u32| ends[(h / 2) as usize][((h + k) % 2) as usize] as usize;
    let mut first = vec![0usize; points.len() + 1];
    for h in 0..2 * ends.len() as u32 {
        first[end(h, 0) + 1] += 1;
    }
    for p in 0..points.len() {
        first[p + 1] += first[p];
    }
    let (mut out, mut fill) = (vec![0u32; 2 * ends.len()], first.clone());
    for h in 0..2 * ends.len() as u32 {
        out[fill[end(h, 0)]] = h;
        fill[end(h, 0)] += 1;
    }
    let mut slot = vec![0u32; out.len()];
    for (p, &o) in points.iter().enumerate() {
        let star = &mut out[first[p]..first[p + 1]];
        star.sort_by(|&g, &h| ccw_order(o, points[end(g, 1)], points[end(h, 1)]));
        for (s, &h) in star.iter().enumerate() {
            slot[h as usize] = s as u32;
        }
    }
    (first, out, slot)
}

/// Whether the direction from `o` to `p` lies in the upper half turn [0°, 180°).
fn upper(o: DVec2, p: DVec2) -> bool {
    p.y > o.y || (p.y == o.y && p.x > o.x)
}

/// The order of the directions from `o` to `a` and to `b`, counter-clockwise from +x; exact.
fn ccw_order(o: DVec2, a: DVec2, b: DVec2) -> Ordering {
    upper(o, b)
        .cmp(&upper(o, a))
        .then_with(|| match orientation(o, a, b) {
            Orientation::Left => Ordering::Less,
            Orientation::Right => Ordering::Greater,
            Orientation::On => Ordering::Equal,
        })
}

/// The face cycles of a [`Graph`]: each the half-edges with one face on their left.
///
/// A connected component has one outer cycle (clockwise, around the face outside it); its other
/// cycles bound its inner faces. A face of the whole graph is an inner cycle less the outer
/// cycles of the components right inside it; the unbounded face is outside everything.
struct Faces {
    cycles: Vec<Vec<u32>>,
    /// Signed area inside each cycle (negative for an outer cycle), compensated.
    area: Vec<f64>,
    /// The cycles' bounding boxes.
    boxes: RTree<IndexedBox>,
    /// The cycle of each half-edge.
    cycle_of: Vec<u32>,
    /// The connected component of each cycle.
    component: Vec<u32>,
    /// Whether each cycle is its component's outer one.
    outer: Vec<bool>,
    /// The inner cycle of the face around each component, `None` for the unbounded face.
    around: Vec<Option<usize>>,
    /// For each inner cycle, the area of its face: its own less that of the components in it.
    face_area: Vec<f64>,
}

impl Faces {
    fn new(graph: &Graph) -> Faces {
        let (cycles, cycle_of) = trace_cycles(graph);
        let (component_of, lowest) = components(graph);
        let area: Vec<f64> = cycles.iter().map(|c| cycle_area(graph, c)).collect();
        let mut faces = Faces {
            boxes: RTree::bulk_load(
                cycles
                    .iter()
                    .enumerate()
                    .map(|(c, cycle)| indexed_box(cycle_box(graph, cycle), c))
                    .collect(),
            ),
            component: cycles
                .iter()
                .map(|c| component_of[graph.origin(c[0]) as usize])
                .collect(),
            outer: vec![false; cycles.len()],
            around: Vec::new(),
            face_area: area.clone(),
            area,
            cycles,
            cycle_of,
        };
        let outer: Vec<usize> = lowest
            .iter()
            .map(|&p| faces.cycle_of[outer_half_edge(graph, p) as usize] as usize)
            .collect();
        for &c in &outer {
            faces.outer[c] = true;
        }
        faces.around = (0..lowest.len() as u32)
            .map(|k| faces.locate(graph, graph.at(lowest[k as usize]), k))
            .collect();
        for (&around, &c) in faces.around.iter().zip(&outer) {
            if let Some(f) = around {
                faces.face_area[f] += faces.area[c];
            }
        }
        faces
    }

    /// The face on the left of half-edge `h`: an inner cycle, or `None` for the unbounded face.
    fn left_of(&self, h: u32) -> Option<usize> {
        let c = self.cycle_of[h as usize] as usize;
        if self.outer[c] {
            self.around[self.component[c] as usize]
        } else {
            Some(c)
        }
    }

    /// The inner cycle whose face holds `p`, ignoring component `skip`, or `None` for the
    /// unbounded face. `p` must lie on no edge (but those of `skip`).
    fn locate(&self, graph: &Graph, p: DVec2, skip: u32) -> Option<usize> {
        // The inner cycles around `p` are nested; the innermost is the smallest (the first of
        // equal ones).
        self.boxes
            .locate_all_at_point(p.to_array())
            .map(|b| b.data)
            .filter(|&c| !self.outer[c] && self.component[c] != skip)
            .filter(|&c| winding(graph, &self.cycles[c], p) != 0)
            .min_by(|&c, &d| self.area[c].total_cmp(&self.area[d]).then(c.cmp(&d)))
    }
}

/// The cycles of [`Graph::next`], and the cycle of each half-edge.
fn trace_cycles(graph: &Graph) -> (Vec<Vec<u32>>, Vec<u32>) {
    let mut cycle_of = vec![NONE; graph.out.len()];
    let mut cycles = Vec::new();
    for start in 0..graph.out.len() as u32 {
        if cycle_of[start as usize] != NONE {
            continue;
        }
        let (mut cycle, mut h) = (Vec::new(), start);
        loop {
            cycle_of[h as usize] = cycles.len() as u32;
            cycle.push(h);
            h = graph.next(h);
            if h == start {
                break;
            }
        }
        cycles.push(cycle);
    }
    (cycles, cycle_of)
}

/// The connected component of each point (`NONE` for a point on no edge), and each
/// component's lowest point (least x, then least y).
fn components(graph: &Graph) -> (Vec<u32>, Vec<u32>) {
    let mut component = vec![NONE; graph.points.len()];
    let (mut lowest, mut stack) = (Vec::new(), Vec::new());
    let key = |p: u32| (graph.at(p).x, graph.at(p).y);
    for start in 0..graph.points.len() as u32 {
        if component[start as usize] != NONE || graph.star(start).is_empty() {
            continue;
        }
        let (id, mut low) = (lowest.len() as u32, start);
        component[start as usize] = id;
        stack.push(start);
        while let Some(p) = stack.pop() {
            if key(p) < key(low) {
                low = p;
            }
            for &h in graph.star(p) {
                let q = graph.head(h);
                if component[q as usize] == NONE {
                    component[q as usize] = id;
                    stack.push(q);
                }
            }
        }
        lowest.push(low);
    }
    (component, lowest)
}

/// The half-edge leaving the lowest point `p` of a component with the unbounded side of the
/// component on its left: the face left of a half-edge reaches counter-clockwise to the next
/// one, and only the last in the upper half turn (or the last of all) reaches 180°.
fn outer_half_edge(graph: &Graph, p: u32) -> u32 {
    let star = graph.star(p);
    let o = graph.at(p);
    let ups = star
        .iter()
        .take_while(|&&h| upper(o, graph.at(graph.head(h))))
        .count();
    star[if ups > 0 { ups - 1 } else { star.len() - 1 }]
}

/// The signed area inside `cycle`, exact but for its last rounding: the shoelace's products
/// are split exactly (a fused multiply-add gives each one's rounding error) and summed in an
/// expansion, after scaling by a power of two that keeps them from overflowing. A fan of
/// rounded triangles from one corner loses a long thin cycle's area to cancellation (a cycle
/// 4e63 long and 2 wide came out with area 0).
fn cycle_area(graph: &Graph, cycle: &[u32]) -> f64 {
    let largest = cycle
        .iter()
        .map(|&h| graph.at(graph.origin(h)).abs().max_element())
        .fold(0.0, f64::max);
    let scale = if largest > 0.0 && largest.is_finite() {
        2f64.powi(-(largest.log2().ceil() as i32))
    } else {
        1.0
    };
    let mut expansion = Vec::new();
    for &h in cycle {
        let (a, b) = (
            graph.at(graph.origin(h)) * scale,
            graph.at(graph.head(h)) * scale,
        );
        for (x, y) in [(a.x, b.y), (-a.y, b.x)] {
            let product = x * y;
            grow_expansion(&mut expansion, product);
            grow_expansion(&mut expansion, x.mul_add(y, -product));
        }
    }
    0.5 * expansion.iter().sum::<f64>() / scale / scale
}

/// Adds `x` to `expansion` exactly (Shewchuk's grow-expansion: nonoverlapping components,
/// smallest first, zeros dropped).
fn grow_expansion(expansion: &mut Vec<f64>, x: f64) {
    let mut q = x;
    let mut kept = 0;
    for k in 0..expansion.len() {
        let c = expansion[k];
        let s = q + c;
        let bv = s - q;
        let error = (q - (s - bv)) + (c - bv);
        if error != 0.0 {
            expansion[kept] = error;
            kept += 1;
        }
        q = s;
    }
    expansion.truncate(kept);
    expansion.push(q);
}

fn cycle_box(graph: &Graph, cycle: &[u32]) -> [DVec2; 2] {
    cycle
        .iter()
        .fold([DVec2::INFINITY, -DVec2::INFINITY], |[lo, hi], &h| {
            let p = graph.at(graph.origin(h));
            [lo.min(p), hi.max(p)]
        })
}

/// The winding number of `cycle` around `p`, which lies on none of its edges (exact turns).
fn winding(graph: &Graph, cycle: &[u32], p: DVec2) -> i32 {
    cycle
        .iter()
        .map(|&h| {
            let (a, b) = (graph.at(graph.origin(h)), graph.at(graph.head(h)));
            if a.y <= p.y {
                i32::from(b.y > p.y && orientation(a, b, p) == Orientation::Left)
            } else {
                -i32::from(b.y <= p.y && orientation(a, b, p) == Orientation::Right)
            }
        })
        .sum()
}

/// The face a seed names: an inner cycle, or `None` for the unbounded face.
fn seed_face(
    graph: &Graph,
    faces: &Faces,
    what: &str,
    k: usize,
    p: DVec2,
) -> Result<Option<usize>, String> {
    match graph.edge_through(p) {
        Some(e) => Err(format!(
            "{what} seed {k} at {} lies on {}, so the face it names is ambiguous",
            pt(p),
            graph.edge_name(e)
        )),
        None => Ok(faces.locate(graph, p, NONE)),
    }
}

/// The faces and which of them the hole seeds take out of the domain.
struct Carved<'a> {
    graph: &'a Graph<'a>,
    faces: &'a Faces,
    /// Per cycle, the first hole seed in its face, or `NONE`.
    holes: &'a [u32],
}

impl Carved<'_> {
    fn in_domain(&self, face: Option<usize>) -> bool {
        face.is_some_and(|c| self.holes[c] == NONE)
    }

    /// Whether a face of the domain lies beside segment `s`.
    fn borders(&self, s: usize) -> bool {
        let h = 2 * s as u32;
        self.in_domain(self.faces.left_of(h)) || self.in_domain(self.faces.left_of(h + 1))
    }

    /// Whether input point `p` lies in or next to a face of the domain.
    fn touches(&self, p: u32) -> bool {
        let star = self.graph.star(p);
        if star.is_empty() {
            let face = self.faces.locate(self.graph, self.graph.at(p), NONE);
            return self.in_domain(face);
        }
        star.iter().any(|&h| self.in_domain(self.faces.left_of(h)))
    }
}

/// Per cycle, the first hole seed in its face, or `NONE`.
fn hole_faces(graph: &Graph, faces: &Faces, holes: &[DVec2]) -> Result<Vec<u32>, String> {
    let mut hole = vec![NONE; faces.cycles.len()];
    for (k, &p) in holes.iter().enumerate() {
        if let Some(c) = seed_face(graph, faces, "hole", k, p)?
            && hole[c] == NONE
        {
            hole[c] = k as u32;
        }
    }
    Ok(hole)
}

/// Per cycle, the last region seed in its face if that face is in the domain, or `NONE`.
fn region_faces(
    graph: &Graph,
    faces: &Faces,
    holes: &[u32],
    input: &Input,
) -> Result<Vec<u32>, String> {
    let mut region = vec![NONE; faces.cycles.len()];
    for (r, seed) in input.regions.iter().enumerate() {
        if let Some(c) = seed_face(graph, faces, "region", r, seed.seed)?
            && holes[c] == NONE
        {
            region[c] = r as u32;
        }
    }
    Ok(region)
}

/// The face (inner cycle, or `NONE` for the unbounded face) of every triangle.
///
/// Triangles joined across an edge that is no segment's share a face; each such group is
/// located once, by the centroid of its largest triangle.
fn triangle_faces(
    mesh: &Mesh,
    pieces: &HashSet<u64>,
    graph: &Graph,
    faces: &Faces,
) -> Result<Vec<u32>, String> {
    let (group, count) = triangle_groups(mesh, pieces);
    let mut largest = vec![(f64::NEG_INFINITY, 0usize); count];
    for (t, &g) in group.iter().enumerate() {
        let area = twice_area(mesh, t);
        if area > largest[g as usize].0 {
            largest[g as usize] = (area, t);
        }
    }
    let located: Vec<u32> = largest
        .par_iter()
        .map(|&(_, t)| {
            let c = centroid(mesh, t);
            match graph.edge_through(c) {
                Some(e) => Err(format!(
                    "the centroid {} of triangle {t} lies on {}",
                    pt(c),
                    graph.edge_name(e)
                )),
                None => Ok(faces.locate(graph, c, NONE).map_or(NONE, |f| f as u32)),
            }
        })
        .collect::<Result<_, _>>()?;
    Ok(group.iter().map(|&g| located[g as usize]).collect())
}

/// The groups of triangles joined across edges that are no segment piece, numbered in the order
/// of their first triangles, and their count.
fn triangle_groups(mesh: &Mesh, pieces: &HashSet<u64>) -> (Vec<u32>, usize) {
    let mut group = vec![NONE; mesh.triangles.len()];
    let (mut count, mut stack) = (0u32, Vec::new());
    for start in 0..mesh.triangles.len() {
        if group[start] != NONE {
            continue;
        }
        group[start] = count;
        stack.push(start);
        while let Some(t) = stack.pop() {
            let tri = mesh.triangles[t];
            for (i, &u) in mesh.neighbours[t].iter().enumerate() {
                let (a, b) = (tri[(i + 1) % 3], tri[(i + 2) % 3]);
                if u != NONE && group[u as usize] == NONE && !pieces.contains(&undirected(a, b)) {
                    group[u as usize] = count;
                    stack.push(u as usize);
                }
            }
        }
        count += 1;
    }
    (group, count as usize)
}

fn check_in_domain(mesh: &Mesh, face: &[u32], holes: &[u32], hull: bool) -> Result<(), String> {
    first_fault(mesh.triangles.len(), |t| {
        let f = face[t];
        let why = if f == NONE {
            let outside = if hull {
                "outside the points' convex hull"
            } else {
                "outside every face the segments enclose"
            };
            outside.to_string()
        } else if holes[f as usize] != NONE {
            format!("in the face of hole seed {}", holes[f as usize])
        } else {
            return None;
        };
        Some(format!(
            "triangle {t} {:?} with centroid {} lies {why}",
            mesh.triangles[t],
            pt(centroid(mesh, t))
        ))
    })
}

/// No triangle may cover a hole seed (its closed area). The seeds are sorted by x, so that each
/// triangle tests only those in its x range.
fn check_hole_seeds(mesh: &Mesh, holes: &[DVec2]) -> Result<(), String> {
    let mut by_x: Vec<(f64, usize)> = holes.iter().enumerate().map(|(k, p)| (p.x, k)).collect();
    by_x.sort_by(|a, b| a.0.total_cmp(&b.0));
    let covered = (0..mesh.triangles.len())
        .into_par_iter()
        .find_map_first(|t| {
            let corners = mesh.triangles[t].map(|v| mesh.vertices[v as usize]);
            let [a, b, c] = corners;
            let (lo, hi) = (a.min(b).min(c), a.max(b).max(c));
            let first = by_x.partition_point(|&(x, _)| x < lo.x);
            by_x[first..]
                .iter()
                .take_while(|&&(x, _)| x <= hi.x)
                .find(|&&(_, k)| covers(corners, holes[k]))
                .map(|&(_, k)| (t, k))
        });
    match covered {
        Some((t, k)) => Err(format!(
            "triangle {t} {:?} covers hole seed {k} at {}",
            mesh.triangles[t],
            pt(holes[k])
        )),
        None => Ok(()),
    }
}

/// Whether the closed counter-clockwise triangle `[a, b, c]` holds `p`.
fn covers([a, b, c]: [DVec2; 3], p: DVec2) -> bool {
    [(a, b), (b, c), (c, a)]
        .iter()
        .all(|&(u, w)| orientation(u, w, p) != Orientation::Right)
}

/// The triangles' areas sum to the domain's, within a relative [`AREA_REL_TOL`] and what the
/// vertices splitting the graph's edges may move it by: each lies up to [`line_tolerance`] off
/// its edge's line, which shifts the area along that edge by at most that times its length.
fn check_area(mesh: &Mesh, graph: &Graph, faces: &Faces, holes: &[u32]) -> Result<(), String> {
    let total = (0..mesh.triangles.len())
        .into_par_iter()
        .fold(Sum::default, |s, t| s.add(0.5 * twice_area(mesh, t)))
        .reduce(Sum::default, Sum::merge)
        .value();
    let want = (0..faces.cycles.len())
        .filter(|&c| !faces.outer[c] && holes[c] == NONE)
        .fold(Sum::default(), |s, c| s.add(faces.face_area[c]))
        .value();
    if want <= 0.0 {
        return Err(format!(
            "the domain is empty (area {want}), yet the triangles' areas sum to {total}"
        ));
    }
    let split_rounding = graph
        .ends
        .iter()
        .map(|&[i, j]| {
            let (a, b) = (graph.points[i as usize], graph.points[j as usize]);
            line_tolerance(a, b) * a.distance(b)
        })
        .fold(Sum::default(), Sum::add)
        .value();
    let rel = (total - want).abs() / want;
    if (total - want).abs() <= AREA_REL_TOL * want + split_rounding {
        Ok(())
    } else {
        Err(format!(
            "triangle areas sum to {total}, the domain's area is {want} (relative difference \
             {rel:e}, beyond 1e-9 and the {split_rounding:e} that split vertices' rounding \
             allows)"
        ))
    }
}

// ---------------------------------------------------------------------------------------------
// 4. Regions

fn check_regions(mesh: &Mesh, face: &[u32], regions: &[u32]) -> Result<(), String> {
    first_fault(mesh.triangle_regions.len(), |t| {
        let (want, got) = (regions[face[t] as usize], mesh.triangle_regions[t]);
        let name = |r: u32| {
            if r == NONE {
                "no region".to_string()
            } else {
                format!("region {r}")
            }
        };
        (want != got).then(|| {
            format!(
                "triangle {t} {:?} with centroid {} is in {}, but its face is in {}",
                mesh.triangles[t],
                pt(centroid(mesh, t)),
                name(got),
                name(want)
            )
        })
    })
}

// ---------------------------------------------------------------------------------------------
// 5. Angles

/// The input's angles narrower than the bound: where two graph edges meet at less than it.
#[derive(Default)]
struct NarrowAngles {
    /// The vertices of the input points where they meet.
    vertices: HashSet<u32>,
    /// The pairs of graph edges that meet so, the smaller index first.
    pairs: HashSet<(u32, u32)>,
}

impl NarrowAngles {
    fn new(graph: &Graph, at: &[u32], min_deg: f64) -> Self {
        let mut narrow = NarrowAngles::default();
        for p in 0..graph.points.len() as u32 {
            let star = graph.star(p);
            if star.len() < 2 || at[p as usize] == NONE {
                continue;
            }
            for (i, &g) in star.iter().enumerate() {
                let h = star[(i + 1) % star.len()];
                if wedge_deg(graph, g, h) < min_deg {
                    narrow.vertices.insert(at[p as usize]);
                    narrow.pairs.insert(ordered(g / 2, h / 2));
                }
            }
        }
        narrow
    }

    /// Whether a triangle with these angles keeps them: its smallest angle is at a narrow
    /// input angle, or its shortest edge joins the two edges of one.
    fn exempts(&self, mesh: &Mesh, on: &[(u32, u32)], t: usize, angles: [f64; 3]) -> bool {
        if self.vertices.is_empty() {
            return false;
        }
        let tri = mesh.triangles[t];
        let least = angles.iter().copied().fold(f64::INFINITY, f64::min);
        let at_corner = (0..3).any(|i| angles[i] == least && self.vertices.contains(&tri[i]));
        let (a, b) = shortest_edge(mesh, tri);
        at_corner
            || edges_at(on, a).iter().any(|&(_, s)| {
                edges_at(on, b)
                    .iter()
                    .any(|&(_, r)| s != r && self.pairs.contains(&ordered(s, r)))
            })
    }
}

fn shortest_edge(mesh: &Mesh, tri: [u32; 3]) -> (u32, u32) {
    let ends = |i: usize| (tri[(i + 1) % 3], tri[(i + 2) % 3]);
    let length =
        |(a, b): (u32, u32)| mesh.vertices[a as usize].distance_squared(mesh.vertices[b as usize]);
    let shortest = (0..3).min_by(|&i, &j| length(ends(i)).total_cmp(&length(ends(j))));
    ends(shortest.unwrap_or(0))
}

fn ordered(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

/// The angle counter-clockwise from half-edge `g` to half-edge `h`, which leave one point,
/// degrees in [0, 360).
fn wedge_deg(graph: &Graph, g: u32, h: u32) -> f64 {
    let o = graph.at(graph.origin(g));
    let (u, v) = (graph.at(graph.head(g)) - o, graph.at(graph.head(h)) - o);
    let angle = u.perp_dot(v).atan2(u.dot(v)).to_degrees();
    if angle < 0.0 { angle + 360.0 } else { angle }
}

fn check_angles(
    mesh: &Mesh,
    narrow: &NarrowAngles,
    on: &[(u32, u32)],
    bounds: AngleBounds,
) -> Result<(), String> {
    let (lo, hi) = (
        bounds.min_deg - ANGLE_SLACK_DEG,
        bounds.max_deg + ANGLE_SLACK_DEG,
    );
    first_fault(mesh.triangles.len(), |t| {
        let tri = mesh.triangles[t];
        let [a, b, c] = tri.map(|v| mesh.vertices[v as usize]);
        let angles = angles_deg(a, b, c);
        let bad = angles.iter().any(|x| !(lo..=hi).contains(x));
        (bad && !narrow.exempts(mesh, on, t, angles)).then(|| {
            format!(
                "triangle {t} {tri:?} at {} {} {} has angles {angles:?} degrees, outside [{}, {}] \
                 and not at an input angle narrower than {}",
                pt(a),
                pt(b),
                pt(c),
                bounds.min_deg,
                bounds.max_deg,
                bounds.min_deg
            )
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::fixtures::{bounding_box, neighbours_of};
    use crate::mesh::{BoundaryEdge, opposite_edge};
    use crate::options::RegionSeed;
    use spade::{
        AngleLimit, ConstrainedDelaunayTriangulation, Point2, RefinementParameters, Triangulation,
    };

    type Cdt = ConstrainedDelaunayTriangulation<Point2<f64>>;

    const fn bounds(min_deg: f64, max_deg: f64) -> AngleBounds {
        AngleBounds { min_deg, max_deg }
    }

    const LOOSE: AngleBounds = bounds(0.0, 180.0);

    /// Points and segments, segment `s` with marker `s + 1`.
    fn input(points: &[[f64; 2]], segments: &[[u32; 2]]) -> Input {
        Input {
            points: points.iter().map(|&[x, y]| DVec2::new(x, y)).collect(),
            segments: (0..)
                .zip(segments)
                .map(|(s, &ends)| Segment {
                    ends,
                    marker: s + 1,
                })
                .collect(),
            ..Input::default()
        }
    }

    /// The closed polygon through points `first..first + n`.
    fn ring(first: u32, n: u32) -> Vec<[u32; 2]> {
        (0..n).map(|k| [first + k, first + (k + 1) % n]).collect()
    }

    /// The corners of the square [lo, hi]², counter-clockwise from (lo, lo).
    fn square(lo: f64, hi: f64) -> [[f64; 2]; 4] {
        [[lo, lo], [hi, lo], [hi, hi], [lo, hi]]
    }

    /// The unit square around the square [0.25, 0.75]², a hole seed in the middle.
    fn square_with_hole() -> Input {
        let points = [square(0.0, 1.0), square(0.25, 0.75)].concat();
        let mut input = input(&points, &[ring(0, 4), ring(4, 4)].concat());
        input.holes = vec![DVec2::splat(0.5)];
        input
    }

    fn in_middle(c: DVec2) -> bool {
        (0.25..=0.75).contains(&c.x) && (0.25..=0.75).contains(&c.y)
    }

    fn point(p: Point2<f64>) -> DVec2 {
        DVec2::new(p.x, p.y)
    }

    /// The constrained Delaunay triangulation of the input points and the Steiner points
    /// `extra`, each segment a constraint through the vertices on it.
    fn cdt(input: &Input, extra: &[DVec2]) -> Cdt {
        let mut cdt = Cdt::new();
        let all: Vec<DVec2> = input.points.iter().chain(extra).copied().collect();
        let handles: Vec<_> = all
            .iter()
            .map(|p| cdt.insert(Point2::new(p.x, p.y)).expect("a finite point"))
            .collect();
        for s in &input.segments {
            let chain = on_segment(&all, input, s);
            for w in chain.windows(2) {
                cdt.add_constraint(handles[w[0] as usize], handles[w[1] as usize]);
            }
        }
        cdt
    }

    /// The indices of `points` on segment `s` (within split roundings), from its first end.
    fn on_segment(points: &[DVec2], input: &Input, s: &Segment) -> Vec<u32> {
        let [a, b] = s.ends.map(|e| input.points[e as usize]);
        let mut on: Vec<(f64, u32)> = (0..)
            .zip(points)
            .filter_map(|(v, &p)| {
                let (t, off) = along_and_off(p, a, b);
                (off <= line_tolerance(a, b) && (0.0..=1.0).contains(&t)).then_some((t, v))
            })
            .collect();
        on.sort_by(|x, y| x.0.total_cmp(&y.0));
        on.into_iter().map(|(_, v)| v).collect()
    }

    /// The mesh of the triangles of the input's constrained Delaunay triangulation whose
    /// centroid passes `keep`.
    fn meshed(input: &Input, keep: impl Fn(DVec2) -> bool) -> Mesh {
        mesh_of(&cdt(input, &[]), input, keep)
    }

    /// The mesh of the triangles of `cdt` whose centroid passes `keep`.
    fn mesh_of(cdt: &Cdt, input: &Input, keep: impl Fn(DVec2) -> bool) -> Mesh {
        let all: Vec<DVec2> = cdt.vertices().map(|v| point(v.position())).collect();
        let triangles: Vec<[u32; 3]> = cdt
            .inner_faces()
            .map(|f| f.vertices().map(|v| v.fix().index() as u32))
            .filter(|tri| keep(tri.iter().map(|&v| all[v as usize]).sum::<DVec2>() / 3.0))
            .collect();
        // Input points stay vertices even outside the domain, as in Triangle.
        let mut used: Vec<bool> = all.iter().map(|p| input.points.contains(p)).collect();
        triangles
            .iter()
            .flatten()
            .for_each(|&v| used[v as usize] = true);
        let mut renumber = vec![NONE; all.len()];
        let mut vertices = Vec::new();
        for v in (0..all.len()).filter(|&v| used[v]) {
            renumber[v] = vertices.len() as u32;
            vertices.push(all[v]);
        }
        let triangles = triangles
            .iter()
            .map(|tri| tri.map(|v| renumber[v as usize]))
            .collect();
        let mut mesh = assemble(vertices, triangles, input);
        // A segment outside the domain has no pieces.
        let edges = mesh_edges(&mesh);
        let is_edge = |p: &SubSegment| edges.contains(&undirected(p.vertices[0], p.vertices[1]));
        let kept: HashSet<u32> = mesh
            .segments
            .iter()
            .filter(|p| is_edge(p))
            .map(|p| p.segment)
            .collect();
        mesh.segments.retain(|p| kept.contains(&p.segment));
        mesh
    }

    /// A mesh of these triangles: the input map, neighbours, boundary and segment pieces
    /// worked out.
    fn assemble(vertices: Vec<DVec2>, triangles: Vec<[u32; 3]>, input: &Input) -> Mesh {
        let neighbours = neighbours_of(&triangles);
        Mesh {
            vertex_input: input_indices(&vertices, input),
            boundary: hull_edges(&triangles, &neighbours),
            domain: bounding_box(&vertices),
            segments: pieces(&vertices, input),
            holes: input.holes.clone(),
            vertices,
            triangles,
            neighbours,
            ..Mesh::default()
        }
    }

    /// The index of each vertex among the input points, or [`NONE`].
    fn input_indices(vertices: &[DVec2], input: &Input) -> Vec<u32> {
        let index = |p: &DVec2| input.points.iter().position(|q| q == p);
        vertices
            .iter()
            .map(|p| index(p).map_or(NONE, |i| i as u32))
            .collect()
    }

    /// The triangles' sides with no triangle across, marked 1 as on a convex hull.
    fn hull_edges(triangles: &[[u32; 3]], neighbours: &[[u32; 3]]) -> Vec<BoundaryEdge> {
        let open = |(t, &triangle): (usize, &[u32; 3])| {
            (0..3)
                .filter(move |&i| neighbours[t][i] == NONE)
                .map(move |i| BoundaryEdge {
                    vertices: opposite_edge(triangle, i),
                    marker: 1,
                })
        };
        triangles.iter().enumerate().flat_map(open).collect()
    }

    fn pieces(vertices: &[DVec2], input: &Input) -> Vec<SubSegment> {
        let mut pieces = Vec::new();
        for (s, segment) in (0..).zip(&input.segments) {
            for w in on_segment(vertices, input, segment).windows(2) {
                pieces.push(SubSegment {
                    vertices: [w[0], w[1]],
                    segment: s,
                    marker: segment.marker,
                });
            }
        }
        pieces
    }

    /// Gives each triangle the region `region` names for its centroid.
    fn with_regions(mut mesh: Mesh, input: &Input, region: impl Fn(DVec2) -> u32) -> Mesh {
        mesh.triangle_regions = (0..mesh.triangles.len())
            .map(|t| region(centroid(&mesh, t)))
            .collect();
        mesh.region_attributes = input.regions.iter().map(|r| r.attribute).collect();
        mesh
    }

    fn fails(result: Result<(), InvalidMesh>, check: MeshCheck, words: &[&str]) {
        let err = result.expect_err("an invalid mesh");
        assert_eq!(err.check, check, "{err}");
        for w in words {
            assert!(err.message.contains(w), "{err} should mention {w:?}");
        }
    }

    #[test]
    fn square_with_a_hole_passes() {
        let input = square_with_hole();
        let mesh = meshed(&input, |c| !in_middle(c));
        assert_eq!(mesh.segments.len(), 8);
        assert_eq!(validate_pslg(&mesh, &input, LOOSE), Ok(()));
    }

    #[test]
    fn faces_of_a_square_with_a_hole() {
        let input = square_with_hole();
        let graph = Graph::new(&input.points, &input.segments, false).unwrap();
        let faces = Faces::new(&graph);
        let inner: Vec<usize> = (0..faces.cycles.len())
            .filter(|&c| !faces.outer[c])
            .collect();
        let mut areas: Vec<f64> = inner.iter().map(|&c| faces.face_area[c]).collect();
        areas.sort_by(f64::total_cmp);
        assert_eq!(areas, [0.25, 0.75]);
        let mut outer: Vec<f64> = (0..faces.cycles.len())
            .filter(|&c| faces.outer[c])
            .map(|c| faces.area[c])
            .collect();
        outer.sort_by(f64::total_cmp);
        assert_eq!(outer, [-1.0, -0.25]);
        let area_at = |p: DVec2| faces.locate(&graph, p, NONE).map(|c| faces.face_area[c]);
        assert_eq!(area_at(DVec2::splat(0.5)), Some(0.25));
        assert_eq!(area_at(DVec2::new(0.1, 0.9)), Some(0.75));
        assert_eq!(area_at(DVec2::new(2.0, 0.5)), None);
    }

    #[test]
    fn refined_square_with_a_hole_meets_the_angle_bound() {
        let input = square_with_hole();
        let mut cdt = cdt(&input, &[]);
        let parameters = RefinementParameters::<f64>::new()
            .with_angle_limit(AngleLimit::from_deg(25.0))
            .with_max_allowed_area(0.01)
            .exclude_outer_faces(true);
        assert!(cdt.refine(parameters).refinement_complete);
        let mesh = mesh_of(&cdt, &input, |c| !in_middle(c));
        assert!(mesh.segments.len() > 16, "{} pieces", mesh.segments.len());
        assert_eq!(validate_pslg(&mesh, &input, bounds(25.0, 130.0)), Ok(()));
        fails(
            validate_pslg(&mesh, &input, bounds(61.0, 130.0)),
            MeshCheck::Angles,
            &["not at an input angle narrower than 61"],
        );
    }

    #[test]
    fn a_triangle_in_the_hole_fails() {
        let input = square_with_hole();
        let mesh = meshed(&input, |_| true);
        fails(
            validate_pslg(&mesh, &input, LOOSE),
            MeshCheck::Domain,
            &["in the face of hole seed 0"],
        );
    }

    #[test]
    fn the_hole_seed_alone_is_checked_too() {
        let input = square_with_hole();
        let mesh = meshed(&input, |_| true);
        let err = check_hole_seeds(&mesh, &input.holes).expect_err("a covered seed");
        assert!(err.contains("covers hole seed 0 at (0.5, 0.5)"), "{err}");
    }

    #[test]
    fn an_unfilled_face_is_an_area_mismatch() {
        // Without its hole seed the middle square belongs to the domain.
        let mut input = square_with_hole();
        input.holes.clear();
        let mesh = meshed(&input, |c| !in_middle(c));
        fails(
            validate_pslg(&mesh, &input, LOOSE),
            MeshCheck::Area,
            &["sum to 0.75", "the domain's area is 1"],
        );
        let full = meshed(&input, |_| true);
        assert_eq!(validate_pslg(&full, &input, LOOSE), Ok(()));
    }

    /// The unit square cut down the middle by segment 6, from (0.5, 0) to (0.5, 1).
    fn halves() -> Input {
        let points = [
            [0.0, 0.0],
            [0.5, 0.0],
            [1.0, 0.0],
            [1.0, 1.0],
            [0.5, 1.0],
            [0.0, 1.0],
        ];
        let mut input = input(&points, &[ring(0, 6), vec![[1, 4]]].concat());
        let seed = |x: f64, attribute| RegionSeed {
            seed: DVec2::new(x, 0.5),
            attribute,
            max_area: None,
        };
        input.regions = vec![seed(0.25, 1.0), seed(0.75, 2.0)];
        input
    }

    /// The region of a triangle of [`halves`] with centroid `c`: 0 on the left, 1 on the right.
    fn left_or_right(c: DVec2) -> u32 {
        u32::from(c.x > 0.5)
    }

    #[test]
    fn two_regions_split_by_a_segment() {
        let input = halves();
        let mesh = with_regions(meshed(&input, |_| true), &input, left_or_right);
        assert_eq!(validate_pslg(&mesh, &input, LOOSE), Ok(()));
        let mut wrong = mesh.clone();
        let t = wrong.triangle_regions.iter().position(|&r| r == 1).unwrap();
        wrong.triangle_regions[t] = 0;
        fails(
            validate_pslg(&wrong, &input, LOOSE),
            MeshCheck::Regions,
            &[
                &format!("triangle {t}"),
                "is in region 0",
                "its face is in region 1",
            ],
        );
        let mut none = mesh.clone();
        none.triangle_regions[0] = NONE;
        fails(
            validate_pslg(&none, &input, LOOSE),
            MeshCheck::Regions,
            &["triangle 0", "is in no region"],
        );
    }

    #[test]
    fn a_later_seed_in_the_same_face_wins() {
        let mut input = halves();
        input.regions.push(RegionSeed {
            seed: DVec2::new(0.1, 0.1),
            attribute: 3.0,
            max_area: Some(0.5),
        });
        let base = meshed(&input, |_| true);
        let first = with_regions(base.clone(), &input, left_or_right);
        fails(
            validate_pslg(&first, &input, LOOSE),
            MeshCheck::Regions,
            &["is in region 0", "its face is in region 2"],
        );
        let last = with_regions(base, &input, |c| if c.x > 0.5 { 1 } else { 2 });
        assert_eq!(validate_pslg(&last, &input, LOOSE), Ok(()));
    }

    #[test]
    fn region_seeds_in_holes_are_ignored() {
        let mut input = halves();
        input.holes = vec![DVec2::new(0.75, 0.25)];
        let mesh = meshed(&input, |c| c.x < 0.5);
        let mesh = with_regions(mesh, &input, |_| 0);
        assert_eq!(validate_pslg(&mesh, &input, LOOSE), Ok(()));
    }

    /// The unit square with its diagonal from corner 0 to corner 2 as segment 4.
    fn square_and_diagonal() -> Input {
        input(&square(0.0, 1.0), &[ring(0, 4), vec![[0, 2]]].concat())
    }

    #[test]
    fn a_segment_missing_from_the_edges_fails() {
        let input = square_and_diagonal();
        let other_diagonal = vec![[0, 1, 3], [1, 2, 3]];
        let mesh = assemble(input.points.clone(), other_diagonal, &input);
        fails(
            validate_pslg(&mesh, &input, LOOSE),
            MeshCheck::Segments,
            &["segment piece 4 0->2 of segment 4", "not an edge"],
        );
        let right = assemble(input.points.clone(), vec![[0, 1, 2], [0, 2, 3]], &input);
        assert_eq!(validate_pslg(&right, &input, LOOSE), Ok(()));
        let mut dropped = right.clone();
        dropped.segments.pop();
        fails(
            validate_pslg(&dropped, &input, LOOSE),
            MeshCheck::Segments,
            &["segment 4", "has no pieces"],
        );
    }

    #[test]
    fn pieces_in_the_wrong_order_or_with_the_wrong_marker_fail() {
        let input = square_and_diagonal();
        let mesh = assemble(input.points.clone(), vec![[0, 1, 2], [0, 2, 3]], &input);
        let mut swapped = mesh.clone();
        swapped.segments.swap(0, 1);
        fails(
            validate_pslg(&swapped, &input, LOOSE),
            MeshCheck::Segments,
            &["segment 0", "has no pieces"],
        );
        let mut marked = mesh.clone();
        marked.segments[2].marker = 9;
        fails(
            validate_pslg(&marked, &input, LOOSE),
            MeshCheck::Segments,
            &["segment piece 2 has marker 9, its segment 2 3"],
        );
        let mut reversed = mesh;
        reversed.segments[4].vertices = [2, 0];
        fails(
            validate_pslg(&reversed, &input, LOOSE),
            MeshCheck::Segments,
            &["starts at vertex 2, not at vertex 0"],
        );
    }

    #[test]
    fn split_segments_pass_and_a_split_off_the_line_fails() {
        let input = square_and_diagonal();
        let extra = [
            DVec2::new(0.5, 0.0),
            DVec2::splat(0.5),
            DVec2::new(1.0, 0.25),
        ];
        let mesh = mesh_of(&cdt(&input, &extra), &input, |_| true);
        assert_eq!(mesh.segments.len(), 8);
        assert_eq!(validate_pslg(&mesh, &input, LOOSE), Ok(()));
        let centre = mesh.vertices.iter().position(|&p| p == DVec2::splat(0.5));
        let mut moved = mesh.clone();
        moved.vertices[centre.unwrap()].x += 1e-9;
        fails(
            validate_pslg(&moved, &input, LOOSE),
            MeshCheck::Segments,
            &["on segment 4 lies", "from its line"],
        );
        // A few roundings off the line are a rounded split point.
        let mut rounded = mesh;
        let x = &mut rounded.vertices[centre.unwrap()].x;
        *x = f64::from_bits(x.to_bits() + 2);
        assert_eq!(validate_pslg(&rounded, &input, LOOSE), Ok(()));
    }

    #[test]
    fn a_boundary_edge_on_no_segment_fails() {
        // The whole square meshed, though only the triangle in it is enclosed.
        let input = triangle_in_square();
        let mesh = meshed(&input, |_| true);
        fails(
            validate_pslg(&mesh, &input, LOOSE),
            MeshCheck::Boundary,
            &["has no other triangle but lies on no segment"],
        );
    }

    #[test]
    fn dangling_and_floating_segments() {
        let points = [
            [0.0, 0.0],
            [1.0, 0.0],
            [1.0, 1.0],
            [0.0, 1.0],
            [0.3, 0.5],
            [0.7, 0.5],
            [0.2, 0.2],
        ];
        let segments = [ring(0, 4), vec![[4, 5], [0, 6]]].concat();
        let input = input(&points, &segments);
        let mesh = meshed(&input, |_| true);
        assert_eq!(validate_pslg(&mesh, &input, LOOSE), Ok(()));
        // A hole seed beside the floating segment empties the whole square.
        let mut holed = input.clone();
        holed.holes = vec![DVec2::new(0.5, 0.6)];
        let mut mesh = mesh;
        mesh.holes = holed.holes.clone();
        fails(
            validate_pslg(&mesh, &holed, LOOSE),
            MeshCheck::Segments,
            &[
                "segment 0 has 1 pieces",
                "both its sides are outside the domain",
            ],
        );
    }

    #[test]
    fn seeds_on_segments_are_ambiguous() {
        let mut input = square_with_hole();
        input.holes = vec![DVec2::new(0.5, 0.25)];
        let mut mesh = meshed(&input, |c| !in_middle(c));
        mesh.holes = input.holes.clone();
        fails(
            validate_pslg(&mesh, &input, LOOSE),
            MeshCheck::Domain,
            &["hole seed 0 at (0.5, 0.25) lies on segment 4", "ambiguous"],
        );
    }

    /// The square [0, 2]² with a point on its bottom side, around the triangle
    /// (0.5, 0.5) (1.5, 0.5) (1, 1.5), whose sides alone are segments.
    fn triangle_in_square() -> Input {
        let points = [
            [0.0, 0.0],
            [1.0, 0.0],
            [2.0, 0.0],
            [2.0, 2.0],
            [0.0, 2.0],
            [0.5, 0.5],
            [1.5, 0.5],
            [1.0, 1.5],
        ];
        input(&points, &ring(5, 3))
    }

    #[test]
    fn the_convex_hull_variant() {
        let input = triangle_in_square();
        let extra = [
            DVec2::new(1.5, 0.0),
            DVec2::new(2.0, 1.0),
            DVec2::new(0.25, 2.0),
        ];
        let mesh = mesh_of(&cdt(&input, &extra), &input, |_| true);
        assert_eq!(validate_pslg_with(&mesh, &input, LOOSE, true), Ok(()));
        fails(
            validate_pslg(&mesh, &input, LOOSE),
            MeshCheck::Boundary,
            &["lies on no segment"],
        );
        let triangle = [5, 6, 7].map(|i| input.points[i]);
        let inner = meshed(&input, |c| !outside(c, triangle));
        assert_eq!(validate_pslg(&inner, &input, LOOSE), Ok(()));
        let mut holed = input.clone();
        holed.holes = vec![DVec2::new(1.0, 0.8)];
        let mut ring = mesh_of(&cdt(&input, &extra), &input, |c| outside(c, triangle));
        ring.holes = holed.holes.clone();
        assert_eq!(validate_pslg_with(&ring, &holed, LOOSE, true), Ok(()));
        fails(
            validate_pslg_with(&mesh, &holed, LOOSE, true),
            MeshCheck::Sizes,
            &["holes"],
        );
    }

    #[test]
    fn points_away_from_the_domain_may_be_left_out() {
        let input = triangle_in_square();
        let corners = [5, 6, 7].map(|i| input.points[i]).to_vec();
        let alone = assemble(corners, vec![[0, 1, 2]], &input);
        assert_eq!(alone.vertex_input, [5, 6, 7]);
        assert_eq!(validate_pslg(&alone, &input, LOOSE), Ok(()));
        // Point 1, the middle of the bottom side, borders the domain.
        let halves = halves();
        let corners = [0, 2, 3, 5].map(|i| halves.points[i]).to_vec();
        let mesh = assemble(corners, vec![[0, 1, 2], [0, 2, 3]], &halves);
        let mesh = with_regions(mesh, &halves, left_or_right);
        fails(
            validate_pslg(&mesh, &halves, LOOSE),
            MeshCheck::Conformity,
            &["input point 1 at (0.5, 0) is not a vertex"],
        );
    }

    fn outside(c: DVec2, [a, b, d]: [DVec2; 3]) -> bool {
        [(a, b), (b, d), (d, a)]
            .iter()
            .any(|&(u, w)| orientation(u, w, c) == Orientation::Right)
    }

    #[test]
    fn a_triangle_outside_the_hull_domain_fails() {
        let input = triangle_in_square();
        let mut mesh = meshed(&input, |_| true);
        // A triangle hung below the bottom side, at a new vertex.
        let below = mesh.vertices.len() as u32;
        mesh.vertices.push(DVec2::new(1.0, -1.0));
        mesh.vertex_input.push(NONE);
        let [a, b] = [0.0, 1.0].map(|x| {
            let p = DVec2::new(x, 0.0);
            mesh.vertices.iter().position(|&q| q == p).unwrap() as u32
        });
        mesh.triangles.push([a, below, b]);
        let mesh = assemble(mesh.vertices, mesh.triangles, &input);
        fails(
            validate_pslg_with(&mesh, &input, LOOSE, true),
            MeshCheck::Boundary,
            &["lies on no segment or hull side"],
        );
    }

    /// A wedge of 5.7° at the origin, its long sides split at their midpoints.
    fn wedge() -> (Input, Mesh) {
        let input = input(&[[0.0, 0.0], [1.0, 0.0], [1.0, 0.1]], &ring(0, 3));
        let extra = [DVec2::new(0.5, 0.0), DVec2::new(0.5, 0.05)];
        let mesh = mesh_of(&cdt(&input, &extra), &input, |_| true);
        (input, mesh)
    }

    /// The angle bounds the wedge's triangles meet, but for its narrow corner.
    const WEDGE_BOUNDS: AngleBounds = bounds(20.0, 140.0);

    /// Checks that [`wedge`], its segments cut down by `cut` and its mesh assembled again, is a
    /// valid mesh of its convex hull.
    fn assert_wedge_hull_passes(cut: impl FnOnce(&mut Vec<Segment>)) {
        let (mut input, mesh) = wedge();
        cut(&mut input.segments);
        let mesh = assemble(mesh.vertices, mesh.triangles, &input);
        assert_eq!(
            validate_pslg_with(&mesh, &input, WEDGE_BOUNDS, true),
            Ok(())
        );
    }

    #[test]
    fn triangles_in_a_narrow_input_angle_are_exempt() {
        let (input, mesh) = wedge();
        assert_eq!(mesh.triangles.len(), 3);
        assert_eq!(validate_pslg(&mesh, &input, WEDGE_BOUNDS), Ok(()));
        let graph = Graph::new(&input.points, &input.segments, false).unwrap();
        let at = vertex_of_point(&mesh, 3);
        let narrow = NarrowAngles::new(&graph, &at, 20.0);
        assert_eq!(narrow.vertices, HashSet::from([at[0]]));
        assert_eq!(narrow.pairs, HashSet::from([(0, 2)]));
    }

    #[test]
    fn a_segment_and_a_hull_side_make_a_narrow_angle() {
        // The first two sides stay segments: the third is a hull side.
        assert_wedge_hull_passes(|segments| segments.truncate(2));
    }

    #[test]
    fn a_small_angle_away_from_narrow_input_angles_fails() {
        // The halves are 0.5 by 1 rectangles: their triangles have angles of 26.6°.
        let input = halves();
        let mesh = with_regions(meshed(&input, |_| true), &input, left_or_right);
        fails(
            validate_pslg(&mesh, &input, bounds(30.0, 120.0)),
            MeshCheck::Angles,
            &["not at an input angle narrower than 30"],
        );
    }

    #[test]
    fn hull_corners_narrower_than_the_bound_are_exempt() {
        assert_wedge_hull_passes(Vec::clear);
    }

    #[test]
    fn sizes_of_the_pslg_fields() {
        let input = halves();
        let mesh = meshed(&input, |_| true);
        fails(
            validate_pslg(&mesh, &input, LOOSE),
            MeshCheck::Sizes,
            &["triangle_regions has 0 entries"],
        );
        let mut bad = with_regions(mesh, &input, |_| 0);
        bad.segments[0].segment = 99;
        fails(
            validate_pslg(&bad, &input, LOOSE),
            MeshCheck::Sizes,
            &["segment piece 0 lies on segment 99"],
        );
    }

    #[test]
    fn convex_hull_keeps_points_on_its_sides() {
        let points: Vec<DVec2> = [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [2.0, 2.0], [1.0, 0.5]]
            .map(|[x, y]| DVec2::new(x, y))
            .to_vec();
        assert_eq!(convex_hull(&points), Ok(vec![0, 1, 2, 3]));
        let line = [DVec2::ZERO, DVec2::ONE, DVec2::splat(2.0)];
        assert!(convex_hull(&line).is_err());
    }
}
