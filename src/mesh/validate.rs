//! The mesh validity check every test mesh goes through.
//!
//! Every check is exact (integer comparisons, bit patterns, an exact orientation predicate)
//! except the area sum, which is compensated and compared with a relative tolerance, and the
//! angle bounds, which allow 1e-9 degrees. Per-element checks run in parallel and report the
//! lowest-indexed fault; edge and vertex checks sort, so the whole check is O(n log n).

use std::sync::atomic::{AtomicBool, Ordering};

use glam::DVec2;
use rayon::prelude::*;

use super::{BoundarySide, Domain, Mesh, NONE, angles_deg, interior_angles_deg};
use crate::predicates::orient_value;

/// The angle range a meshing mode guarantees, in degrees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AngleBounds {
    /// Every angle is at least this.
    pub min_deg: f64,
    /// Every angle is at most this.
    pub max_deg: f64,
}

/// Slack on the angle bounds, degrees: `angles_deg` is itself rounded.
pub(super) const ANGLE_SLACK_DEG: f64 = 1e-9;

/// Allowed relative difference between the summed triangle areas and the domain's area.
pub(super) const AREA_REL_TOL: f64 = 1e-9;

/// Checks `mesh` against the input `points` it was made from; returns the first fault found.
///
/// In order: sizes and indices, strict counter-clockwise orientation (exact), distinct vertices,
/// every vertex in a triangle, edge manifold and neighbours, boundary edges against `mesh.boundary` and the domain's sides,
/// total area against the domain's, conformity to `points`, and the angle bounds.
///
/// # Errors
/// [`InvalidMesh`]: which check failed ([`MeshCheck`]) and the first fault it found.
pub fn validate(mesh: &Mesh, points: &[DVec2], bounds: AngleBounds) -> Result<(), InvalidMesh> {
    use MeshCheck::*;
    check_sizes(mesh).map_err(fault(Sizes))?;
    check_orientation(mesh).map_err(fault(Orientation))?;
    let by_position = sorted_by_position(&mesh.vertices);
    check_distinct(&by_position).map_err(fault(DistinctVertices))?;
    check_every_vertex_used(mesh).map_err(fault(Sizes))?;
    let single = check_edges(mesh).map_err(fault(Edges))?;
    check_boundary(mesh, &single).map_err(fault(Boundary))?;
    drop(single);
    check_area(mesh).map_err(fault(Area))?;
    check_conformity(mesh, points, &by_position).map_err(fault(Conformity))?;
    check_angles(mesh, bounds).map_err(fault(Angles))
}

/// [`validate`] for a nonobtuse mesh: the same checks, and every angle at most 90° up to the
/// rounding of the triangle's vertices to f64 (see [`first_obtuse`]) in place of the angle
/// bounds.
///
/// # Errors
/// [`InvalidMesh`] naming the check that failed.
pub fn validate_nonobtuse(mesh: &Mesh, points: &[DVec2]) -> Result<(), InvalidMesh> {
    let any_angle = AngleBounds {
        min_deg: 0.0,
        max_deg: 180.0,
    };
    validate(mesh, points, any_angle)?;
    match first_obtuse(mesh) {
        Some((_, message)) => Err(fault(MeshCheck::Angles)(message)),
        None => Ok(()),
    }
}

/// The first triangle with an angle over 90° by more than rounding explains, with a message.
///
/// A nonobtuse mesh reaches 90° by construction, between edges the grid makes perpendicular;
/// its vertices' f64 coordinates are the grid's rounded, each by at most a few units in the
/// last place of the largest coordinate of the domain, `m`. Moving the three corners of a
/// triangle whose shortest edge is `e` that far turns each edge by at most `2·√2·4ε·m / e`
/// radians, so an angle by at most twice that; the check allows this beyond
/// [`ANGLE_SLACK_DEG`].
pub fn first_obtuse(mesh: &Mesh) -> Option<(usize, String)> {
    let m = largest_coordinate(&mesh.domain);
    (0..mesh.triangles.len())
        .into_par_iter()
        .find_map_first(|t| {
            let tri = mesh.triangles[t];
            let [a, b, c] = tri.map(|v| mesh.vertices[v as usize]);
            let largest = angles_deg(a, b, c).into_iter().fold(0.0, f64::max);
            let rounding = rounding_allowance_deg([a, b, c], m);
            if !obtuse_beyond(largest, rounding) {
                return None;
            }
            let message = format!(
                "triangle {t} {tri:?} at {} {} {} has an angle of {largest} degrees, over 90 by \
             more than rounding its vertices explains ({rounding:e} degrees)",
                pt(a),
                pt(b),
                pt(c)
            );
            Some((t, message))
        })
}

/// The largest absolute coordinate of a domain's corners: the scale of the rounding of its
/// grid's vertices.
pub fn largest_coordinate(domain: &Domain) -> f64 {
    [domain.lo, domain.hi]
        .iter()
        .map(|p| p.abs().max_element())
        .fold(0.0, f64::max)
}

/// How far past 90° rounding can take a right angle of triangle `abc`, in degrees, beyond
/// [`ANGLE_SLACK_DEG`] (see [`first_obtuse`]); `m` as [`largest_coordinate`] gives.
pub fn rounding_allowance_deg([a, b, c]: [DVec2; 3], m: f64) -> f64 {
    let shortest = a.distance(b).min(b.distance(c)).min(c.distance(a));
    (rounding_turn(m) / shortest).to_degrees()
}

/// [`rounding_allowance_deg`] in radians times the triangle's shortest edge: how far rounding
/// the corners to f64 can turn an edge, times its length.
pub fn rounding_turn(m: f64) -> f64 {
    16.0 * 2f64.sqrt() * f64::EPSILON * m
}

/// Whether an angle `angle` of a triangle whose [`rounding_allowance_deg`] is `allowance` is
/// over 90° by more than rounding explains.
pub fn obtuse_beyond(angle: f64, allowance: f64) -> bool {
    angle > 90.0 + ANGLE_SLACK_DEG + allowance
}

/// Every vertex is a corner of some triangle: a vertex in none would be a node without an
/// element for the mesh's users. (Run after the index checks.)
fn check_every_vertex_used(mesh: &Mesh) -> Result<(), String> {
    let mut used = vec![false; mesh.vertices.len()];
    for t in &mesh.triangles {
        for &v in t {
            used[v as usize] = true;
        }
    }
    match used.iter().position(|&u| !u) {
        Some(v) => Err(format!(
            "vertex {v} at {} is in no triangle",
            pt(mesh.vertices[v])
        )),
        None => Ok(()),
    }
}

/// The checks [`validate`] and [`super::check_delaunay`] make, in order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum MeshCheck {
    /// Array sizes, index ranges, finite coordinates, the domain a rectangle, every vertex in a
    /// triangle.
    Sizes,
    /// Every triangle strictly counter-clockwise (exact).
    Orientation,
    /// No two vertices at one position.
    DistinctVertices,
    /// Every edge in one or two triangles, and the neighbour links matching.
    Edges,
    /// The boundary list equal to the edges with one triangle, on the domain's sides or the
    /// outline.
    Boundary,
    /// The triangles' areas summing to the region's.
    Area,
    /// Every input point a vertex with its exact coordinates, and the input map right.
    Conformity,
    /// Every angle within the bounds (outside input angles narrower than the bound).
    Angles,
    /// Every interior edge locally Delaunay (exact in-circle tests).
    Delaunay,
    /// Every input segment beside the domain a chain of mesh edges from its first end to its
    /// second, as `Mesh::segments` lists them, and the others without pieces
    /// ([`super::validate_pslg`]).
    Segments,
    /// Every triangle inside the domain the segments and hole seeds enclose, none on a hole
    /// seed ([`super::validate_pslg`]).
    Domain,
    /// Every triangle's region the one its face gets from the region seeds
    /// ([`super::validate_pslg`]).
    Regions,
}

/// A mesh that failed a check: which one, and its first fault.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{check:?} check: {message}")]
pub struct InvalidMesh {
    /// The check that failed.
    pub check: MeshCheck,
    /// The first fault it found, with the elements and coordinates involved.
    pub message: String,
}

/// Wraps a check's message in an [`InvalidMesh`].
pub(super) fn fault(check: MeshCheck) -> impl Fn(String) -> InvalidMesh {
    move |message| InvalidMesh { check, message }
}

impl Mesh {
    /// Checks indices, orientation, edge manifold and neighbours, boundary, area sum, conformity
    /// to `points` and the angle bounds; see [`validate`].
    ///
    /// # Errors
    /// [`InvalidMesh`] naming the check that failed.
    pub fn validate(&self, points: &[DVec2], bounds: AngleBounds) -> Result<(), InvalidMesh> {
        validate(self, points, bounds)
    }

    /// Checks a nonobtuse mesh; see [`validate_nonobtuse`].
    ///
    /// # Errors
    /// [`InvalidMesh`] naming the check that failed.
    pub fn validate_nonobtuse(&self, points: &[DVec2]) -> Result<(), InvalidMesh> {
        validate_nonobtuse(self, points)
    }
}

/// The message of the lowest `i < n` for which `fault` gives one.
pub(super) fn first_fault<F>(n: usize, fault: F) -> Result<(), String>
where
    F: Fn(usize) -> Option<String> + Sync + Send,
{
    match (0..n).into_par_iter().find_map_first(fault) {
        Some(message) => Err(message),
        None => Ok(()),
    }
}

/// A point with every digit needed to tell it apart from its neighbours in f64.
pub(super) fn pt(p: DVec2) -> String {
    format!("({}, {})", p.x, p.y)
}

/// The corners of triangle `t`'s edge opposite corner `i`, in the triangle's direction.
fn edge(tri: [u32; 3], i: usize) -> (u32, u32) {
    (tri[(i + 1) % 3], tri[(i + 2) % 3])
}

pub(super) fn directed_key(a: u32, b: u32) -> u64 {
    (u64::from(a) << 32) | u64::from(b)
}

pub(super) fn key_vertices(key: u64) -> (u32, u32) {
    ((key >> 32) as u32, key as u32)
}

// ---------------------------------------------------------------------------------------------
// 1. Sizes and indices

/// The arrays' lengths agree, and every index fits below [`NONE`].
pub(super) fn check_counts(mesh: &Mesh) -> Result<(), String> {
    let (nv, nt) = (mesh.vertices.len(), mesh.triangles.len());
    if mesh.vertex_input.len() != nv {
        return Err(format!(
            "vertex_input has {} entries for {nv} vertices",
            mesh.vertex_input.len()
        ));
    }
    if mesh.neighbours.len() != nt {
        return Err(format!(
            "neighbours has {} entries for {nt} triangles",
            mesh.neighbours.len()
        ));
    }
    if nt == 0 {
        return Err("the mesh has no triangles".to_string());
    }
    // NONE must never be a real index.
    if nv >= NONE as usize || nt >= NONE as usize {
        return Err(format!(
            "{nv} vertices or {nt} triangles do not fit u32 indices"
        ));
    }
    Ok(())
}

fn check_sizes(mesh: &Mesh) -> Result<(), String> {
    check_counts(mesh)?;
    let (nv, nt) = (mesh.vertices.len(), mesh.triangles.len());
    check_domain(&mesh.domain)?;
    first_fault(nv, |v| {
        let p = mesh.vertices[v];
        (!p.is_finite()).then(|| format!("vertex {v} has a non-finite coordinate {}", pt(p)))
    })?;
    first_fault(nt, |t| triangle_index_fault(mesh, t))
}

fn check_domain(d: &Domain) -> Result<(), String> {
    if d.lo.is_finite() && d.hi.is_finite() && d.lo.x < d.hi.x && d.lo.y < d.hi.y {
        Ok(())
    } else {
        Err(format!(
            "the domain {} to {} is not a finite non-empty rectangle",
            pt(d.lo),
            pt(d.hi)
        ))
    }
}

pub(super) fn triangle_index_fault(mesh: &Mesh, t: usize) -> Option<String> {
    let (nv, nt) = (mesh.vertices.len(), mesh.triangles.len());
    let tri = mesh.triangles[t];
    if let Some(&v) = tri.iter().find(|&&v| v as usize >= nv) {
        return Some(format!(
            "triangle {t} {tri:?}: vertex index {v} out of range ({nv} vertices)"
        ));
    }
    if tri[0] == tri[1] || tri[1] == tri[2] || tri[2] == tri[0] {
        return Some(format!("triangle {t} {tri:?} repeats a vertex"));
    }
    let nb = mesh.neighbours[t];
    nb.iter()
        .find(|&&n| n != NONE && n as usize >= nt)
        .map(|&n| {
            format!(
                "triangle {t} neighbours {nb:?}: triangle index {n} out of range ({nt} triangles)"
            )
        })
}

// ---------------------------------------------------------------------------------------------
// 2. Orientation

pub(super) fn check_orientation(mesh: &Mesh) -> Result<(), String> {
    first_fault(mesh.triangles.len(), |t| {
        let tri = mesh.triangles[t];
        let [a, b, c] = tri.map(|v| mesh.vertices[v as usize]);
        let det = orient_value(a, b, c);
        (det <= 0.0).then(|| {
            let how = if det == 0.0 {
                "degenerate"
            } else {
                "clockwise"
            };
            format!(
                "triangle {t} {tri:?} is {how}, not counter-clockwise: {} {} {} (orient2d {det})",
                pt(a),
                pt(b),
                pt(c)
            )
        })
    })
}

// ---------------------------------------------------------------------------------------------
// 3. Distinct vertices

/// Bits of a coordinate with -0.0 taken as 0.0, so equal values have equal bits.
fn value_bits(x: f64) -> u64 {
    if x == 0.0 { 0 } else { x.to_bits() }
}

fn position_key(p: DVec2) -> (u64, u64) {
    (value_bits(p.x), value_bits(p.y))
}

/// `(position key, vertex)` sorted, for the distinctness check and point look-ups.
pub(super) fn sorted_by_position(vertices: &[DVec2]) -> Vec<((u64, u64), u32)> {
    let mut keys: Vec<_> = vertices
        .par_iter()
        .enumerate()
        .map(|(v, &p)| (position_key(p), v as u32))
        .collect();
    keys.par_sort_unstable();
    keys
}

pub(super) fn check_distinct(by_position: &[((u64, u64), u32)]) -> Result<(), String> {
    let n = by_position.len().saturating_sub(1);
    first_fault(n, |k| {
        let ((key, u), (next, v)) = (by_position[k], by_position[k + 1]);
        (key == next).then(|| {
            let p = DVec2::new(f64::from_bits(key.0), f64::from_bits(key.1));
            format!("vertices {u} and {v} are both at {}", pt(p))
        })
    })
}

// ---------------------------------------------------------------------------------------------
// 4. Edge manifold and neighbours

/// `(undirected key, 3 t + i)` for every corner `i` of every triangle `t`, sorted.
fn sorted_half_edges(mesh: &Mesh) -> Vec<(u64, u64)> {
    let mut edges = vec![(0u64, 0u64); 3 * mesh.triangles.len()];
    edges
        .par_chunks_mut(3)
        .zip(mesh.triangles.par_iter())
        .enumerate()
        .for_each(|(t, (out, &tri))| {
            for (i, slot) in out.iter_mut().enumerate() {
                let (a, b) = edge(tri, i);
                *slot = (directed_key(a.min(b), a.max(b)), (3 * t + i) as u64);
            }
        });
    edges.par_sort_unstable();
    edges
}

fn half_edge(h: u64) -> (usize, usize) {
    ((h / 3) as usize, (h % 3) as usize)
}

/// Checks that every edge has one or two (opposite) triangles and that `neighbours` says so;
/// returns the edges with one triangle as sorted `(directed key, triangle)`.
pub(super) fn check_edges(mesh: &Mesh) -> Result<Vec<(u64, usize)>, String> {
    let edges = sorted_half_edges(mesh);
    let runs = || edges.par_chunk_by(|a, b| a.0 == b.0);
    if let Some(message) = runs().find_map_first(|run| run_fault(mesh, run)) {
        return Err(message);
    }
    let mut single: Vec<(u64, usize)> = runs()
        .filter(|run| run.len() == 1)
        .map(|run| {
            let (t, i) = half_edge(run[0].1);
            let (a, b) = edge(mesh.triangles[t], i);
            (directed_key(a, b), t)
        })
        .collect();
    single.par_sort_unstable();
    Ok(single)
}

/// The fault, if any, of the triangles sharing one undirected edge.
fn run_fault(mesh: &Mesh, run: &[(u64, u64)]) -> Option<String> {
    let (lo, hi) = key_vertices(run[0].0);
    match run {
        [(_, h)] => {
            let (t, i) = half_edge(*h);
            let nb = mesh.neighbours[t][i];
            (nb != NONE).then(|| {
                format!(
                    "triangle {t} {:?}: edge {lo}-{hi} (opposite corner {i}) has no other \
                     triangle, but its neighbour there is {nb}",
                    mesh.triangles[t]
                )
            })
        }
        [(_, h1), (_, h2)] => pair_fault(mesh, half_edge(*h1), half_edge(*h2)),
        _ => {
            let ts: Vec<usize> = run.iter().map(|&(_, h)| half_edge(h).0).collect();
            Some(format!(
                "edge {lo}-{hi} is used by {} triangles {ts:?}",
                ts.len()
            ))
        }
    }
}

fn pair_fault(mesh: &Mesh, (t, i): (usize, usize), (u, j): (usize, usize)) -> Option<String> {
    let (a, b) = edge(mesh.triangles[t], i);
    if edge(mesh.triangles[u], j) == (a, b) {
        return Some(format!(
            "edge {a}->{b} is used in the same direction by triangles {t} {:?} and {u} {:?}",
            mesh.triangles[t], mesh.triangles[u]
        ));
    }
    for ((x, k), y) in [((t, i), u), ((u, j), t)] {
        let nb = mesh.neighbours[x][k];
        if nb as usize != y {
            return Some(format!(
                "triangle {x}: neighbour opposite corner {k} (edge {a}-{b}) is {}, expected {y}",
                shown(nb)
            ));
        }
    }
    None
}

fn shown(index: u32) -> String {
    if index == NONE {
        "NONE".to_string()
    } else {
        index.to_string()
    }
}

// ---------------------------------------------------------------------------------------------
// 5. Boundary

fn on_side(d: &Domain, side: BoundarySide, p: DVec2) -> bool {
    let within_x = d.lo.x <= p.x && p.x <= d.hi.x;
    let within_y = d.lo.y <= p.y && p.y <= d.hi.y;
    match side {
        BoundarySide::Bottom => p.y == d.lo.y && within_x,
        BoundarySide::Right => p.x == d.hi.x && within_y,
        BoundarySide::Top => p.y == d.hi.y && within_x,
        BoundarySide::Left => p.x == d.lo.x && within_y,
    }
}

fn boundary_entry_fault(mesh: &Mesh, e: usize) -> Option<String> {
    let be = mesh.boundary[e];
    let nv = mesh.vertices.len();
    if let Some(&v) = be.vertices.iter().find(|&&v| v as usize >= nv) {
        return Some(format!(
            "boundary edge {e} {be:?}: vertex index {v} out of range ({nv} vertices)"
        ));
    }
    let [a, b] = be.vertices;
    let (p, q) = (mesh.vertices[a as usize], mesh.vertices[b as usize]);
    let d = &mesh.domain;
    if mesh.outline.is_some() {
        // The outline's own check walks the boundary.
        return None;
    }
    let Some(side) = be.side() else {
        return Some(format!(
            "boundary edge {e} {a}->{b} has marker {}, no side's",
            be.marker
        ));
    };
    (!on_side(d, side, p) || !on_side(d, side, q)).then(|| {
        format!(
            "boundary edge {e} {a}->{b} at {} {} is not on the {:?} side of the domain {} to {}",
            pt(p),
            pt(q),
            side,
            pt(d.lo),
            pt(d.hi)
        )
    })
}

fn check_boundary(mesh: &Mesh, single: &[(u64, usize)]) -> Result<(), String> {
    first_fault(mesh.boundary.len(), |e| boundary_entry_fault(mesh, e))?;
    let mut listed: Vec<(u64, usize)> = mesh
        .boundary
        .par_iter()
        .enumerate()
        .map(|(e, be)| (directed_key(be.vertices[0], be.vertices[1]), e))
        .collect();
    listed.par_sort_unstable();
    first_fault(listed.len().saturating_sub(1), |k| {
        (listed[k].0 == listed[k + 1].0).then(|| {
            let (a, b) = key_vertices(listed[k].0);
            format!(
                "boundary edges {} and {} are both {a}->{b}",
                listed[k].1,
                listed[k + 1].1
            )
        })
    })?;
    compare_boundary(mesh, single, &listed)?;
    if let Some(outline) = &mesh.outline {
        check_outline(mesh, outline)?;
    }
    let d = mesh.domain;
    first_fault(mesh.vertices.len(), |v| {
        let p = mesh.vertices[v];
        (!d.contains(p)).then(|| {
            format!(
                "vertex {v} at {} is outside the domain {} to {}",
                pt(p),
                pt(d.lo),
                pt(d.hi)
            )
        })
    })
}

/// Both lists sorted and free of repeats: equal as sets iff equal elementwise. At the first
/// difference the smaller key is missing from the other list.
pub(super) fn compare_boundary(
    mesh: &Mesh,
    single: &[(u64, usize)],
    listed: &[(u64, usize)],
) -> Result<(), String> {
    let common = single.len().min(listed.len());
    let k = (0..common)
        .into_par_iter()
        .find_first(|&k| single[k].0 != listed[k].0)
        .unwrap_or(common);
    if k == single.len() && k == listed.len() {
        return Ok(());
    }
    if k < single.len() && (k == listed.len() || single[k].0 < listed[k].0) {
        let ((a, b), t) = (key_vertices(single[k].0), single[k].1);
        return Err(format!(
            "edge {a}->{b} of triangle {t} {:?} has no other triangle but is not in the boundary \
             list (a hole, a T-junction or a missing boundary edge)",
            mesh.triangles[t]
        ));
    }
    let ((a, b), e) = (key_vertices(listed[k].0), listed[k].1);
    Err(format!(
        "boundary edge {e} {a}->{b} is not an edge with exactly one triangle, the interior on its left"
    ))
}

/// The boundary of a mesh with an outline is one loop that runs along the outline: from its
/// first corner, through every corner in order (bit for bit), and between corners through
/// vertices on the side between them, within a few roundings (split points are rounded).
fn check_outline(mesh: &Mesh, outline: &[DVec2]) -> Result<(), String> {
    if outline.len() < 3 {
        return Err(format!("the outline has {} corners", outline.len()));
    }
    let tolerance = outline_tolerance(outline);
    let Some((next, start)) = boundary_loop(mesh, outline) else {
        return Err(format!(
            "no vertex lies on the outline's first corner {}",
            pt(outline[0])
        ));
    };
    let (mut v, mut side) = (start as u32, 0);
    for _ in 0..mesh.boundary.len() {
        v = next[v as usize];
        if v == NONE {
            return Err("the boundary is not a closed loop along the outline".into());
        }
        let p = mesh.vertices[v as usize];
        let (a, b) = (
            outline[side % outline.len()],
            outline[(side + 1) % outline.len()],
        );
        if same_point(p, b) {
            side += 1;
        } else if !near_segment(p, a, b, tolerance) {
            return Err(format!(
                "boundary vertex {v} at {} is not on the outline's side {} to {}",
                pt(p),
                pt(a),
                pt(b)
            ));
        }
        if v as usize == start {
            break;
        }
    }
    if v as usize != start || side != outline.len() {
        return Err(format!(
            "the boundary loop from the outline's first corner passes {side} of its {} corners \
             before it closes",
            outline.len()
        ));
    }
    Ok(())
}

/// The next vertex along the boundary from each vertex (`NONE` off it), and the vertex on the
/// outline's first corner, where a walk along the outline starts; `None` if no vertex is.
fn boundary_loop(mesh: &Mesh, outline: &[DVec2]) -> Option<(Vec<u32>, usize)> {
    let mut next = vec![NONE; mesh.vertices.len()];
    for e in &mesh.boundary {
        next[e.vertices[0] as usize] = e.vertices[1];
    }
    let start = mesh
        .vertices
        .iter()
        .position(|&p| same_point(p, outline[0]))?;
    Some((next, start))
}

fn same_point(p: DVec2, q: DVec2) -> bool {
    p.x.to_bits() == q.x.to_bits() && p.y.to_bits() == q.y.to_bits()
}

/// Whether `p` lies within `tolerance` of the segment `a b`.
fn near_segment(p: DVec2, a: DVec2, b: DVec2, tolerance: f64) -> bool {
    let d = b - a;
    let t = (p - a).dot(d) / d.length_squared();
    (0.0..=1.0).contains(&t) && (a + d * t).distance(p) <= tolerance
}

/// A polygon's area, its corners counter-clockwise (compensated).
fn polygon_area(corners: &[DVec2]) -> f64 {
    let origin = corners[0];
    let mut sum = Sum::default();
    for k in 1..corners.len().saturating_sub(1) {
        let (a, b) = (corners[k] - origin, corners[k + 1] - origin);
        sum = sum.add(0.5 * a.perp_dot(b));
    }
    sum.value()
}

/// The outline's corners narrower than `min_deg`, by their index in the outline: the angles
/// there are the input's.
fn narrow_corners(outline: &[DVec2], min_deg: f64) -> Vec<usize> {
    interior_angles_deg(outline)
        .into_iter()
        .enumerate()
        .filter(|&(_, angle)| angle < min_deg)
        .map(|(k, _)| k)
        .collect()
}

/// The outline side each boundary vertex lies on, walking the boundary loop from the
/// outline's first corner (side `k` runs from corner `k` to corner `k + 1`; a corner counts on
/// the side that leaves it); `NONE` for the other vertices. The loop was checked by
/// [`check_outline`].
fn outline_sides(mesh: &Mesh, outline: &[DVec2]) -> Vec<u32> {
    let mut side_of = vec![NONE; mesh.vertices.len()];
    let Some((next, start)) = boundary_loop(mesh, outline) else {
        return side_of;
    };
    let (mut v, mut side) = (start as u32, 0u32);
    for _ in 0..mesh.boundary.len() {
        side_of[v as usize] = side;
        v = next[v as usize];
        if v == NONE || v as usize == start {
            break;
        }
        if same_point(
            mesh.vertices[v as usize],
            outline[(side as usize + 1) % outline.len()],
        ) {
            side += 1;
        }
    }
    side_of
}

/// The input-forced exemptions of a hull's corners narrower than the bound: a triangle keeps
/// its angles if it has a corner there, or if its shortest edge joins the corner's two sides
/// (Shewchuk's rule: no triangle on such an edge can be better).
struct NarrowHullCorners {
    /// The narrow corners' positions.
    corners: Vec<DVec2>,
    /// Pairs of outline sides that meet at a narrow corner, the side that leaves it second.
    side_pairs: Vec<(u32, u32)>,
    /// The outline side of each boundary vertex ([`outline_sides`]).
    side_of: Vec<u32>,
    /// The outline's corners.
    outline: Vec<DVec2>,
}

impl NarrowHullCorners {
    fn new(mesh: &Mesh, min_deg: f64) -> Self {
        let Some(outline) = &mesh.outline else {
            return NarrowHullCorners {
                corners: Vec::new(),
                side_pairs: Vec::new(),
                side_of: Vec::new(),
                outline: Vec::new(),
            };
        };
        let n = outline.len() as u32;
        let narrow = narrow_corners(outline, min_deg);
        let side_of = if narrow.is_empty() {
            Vec::new()
        } else {
            outline_sides(mesh, outline)
        };
        NarrowHullCorners {
            corners: narrow.iter().map(|&k| outline[k]).collect(),
            side_pairs: narrow
                .iter()
                .map(|&k| ((k as u32 + n - 1) % n, k as u32))
                .collect(),
            side_of,
            outline: outline.clone(),
        }
    }

    fn exempts(&self, mesh: &Mesh, tri: [u32; 3]) -> bool {
        if self.corners.is_empty() {
            return false;
        }
        let at = tri.map(|v| mesh.vertices[v as usize]);
        if at.iter().any(|p| self.corners.contains(p)) {
            return true;
        }
        let length = |i: usize| at[(i + 1) % 3].distance_squared(at[(i + 2) % 3]);
        let shortest = (0..3)
            .min_by(|&i, &j| length(i).total_cmp(&length(j)))
            .unwrap_or(0);
        let (p, q) = (tri[(shortest + 1) % 3], tri[(shortest + 2) % 3]);
        let (on_p, on_q) = (self.sides(mesh, p), self.sides(mesh, q));
        self.side_pairs.iter().any(|&(s, r)| {
            (on_p.contains(&s) && on_q.contains(&r)) || (on_p.contains(&r) && on_q.contains(&s))
        })
    }

    /// The outline sides vertex `v` lies on: none, one, or two at a corner.
    fn sides(&self, mesh: &Mesh, v: u32) -> [u32; 2] {
        let side = self.side_of[v as usize];
        let n = self.outline.len() as u32;
        if side != NONE && same_point(mesh.vertices[v as usize], self.outline[side as usize]) {
            [side, (side + n - 1) % n]
        } else {
            [side, side]
        }
    }
}

// ---------------------------------------------------------------------------------------------
// 6. Area

/// A Neumaier compensated sum.
#[derive(Clone, Copy, Default)]
pub(super) struct Sum {
    hi: f64,
    lo: f64,
}

impl Sum {
    pub(super) fn add(self, x: f64) -> Sum {
        let s = self.hi + x;
        let err = if self.hi.abs() >= x.abs() {
            (self.hi - s) + x
        } else {
            (x - s) + self.hi
        };
        Sum {
            hi: s,
            lo: self.lo + err,
        }
    }

    pub(super) fn merge(self, other: Sum) -> Sum {
        let s = self.add(other.hi);
        Sum {
            hi: s.hi,
            lo: s.lo + other.lo,
        }
    }

    pub(super) fn value(self) -> f64 {
        self.hi + self.lo
    }
}

fn check_area(mesh: &Mesh) -> Result<(), String> {
    let total = mesh
        .triangles
        .par_iter()
        .fold(Sum::default, |s, tri| {
            let [a, b, c] = tri.map(|v| mesh.vertices[v as usize]);
            // The adaptive determinant: a thin triangle with far corners loses its whole area
            // to cancellation in the plain cross product.
            s.add(0.5 * orient_value(a, b, c))
        })
        .reduce(Sum::default, Sum::merge)
        .value();
    let (want, split_rounding) = match &mesh.outline {
        Some(outline) => (polygon_area(outline), outline_rounding(outline)),
        None => (mesh.domain.area(), 0.0),
    };
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

/// What the rounding of split vertices on an outline's sides can move the mesh's area by: each
/// lies within [`outline_tolerance`] of its side, which moves the area by at most that much
/// times the side's length (a thin hull's area is small beside it).
fn outline_rounding(outline: &[DVec2]) -> f64 {
    let n = outline.len();
    let perimeter: f64 = (0..n)
        .map(|k| outline[k].distance(outline[(k + 1) % n]))
        .sum();
    outline_tolerance(outline) * perimeter
}

/// How far a split vertex may lie from the outline side it is on: a few roundings at the
/// outline's largest coordinate.
fn outline_tolerance(outline: &[DVec2]) -> f64 {
    let scale = outline
        .iter()
        .fold(0.0f64, |m, p| m.max(p.abs().max_element()));
    64.0 * f64::EPSILON * scale
}

// ---------------------------------------------------------------------------------------------
// 7. Conformity

fn check_conformity(
    mesh: &Mesh,
    points: &[DVec2],
    by_position: &[((u64, u64), u32)],
) -> Result<(), String> {
    first_fault(mesh.vertices.len(), |v| input_vertex_fault(mesh, points, v))?;
    check_inputs_once(mesh)?;
    check_inputs_used(mesh)?;
    // A mapped point is at its vertex bit for bit by now; only the others need a look-up.
    let mapped: Vec<AtomicBool> = (0..points.len()).map(|_| AtomicBool::new(false)).collect();
    mesh.vertex_input
        .par_iter()
        .filter(|&&i| i != NONE)
        .for_each(|&i| mapped[i as usize].store(true, Ordering::Relaxed));
    first_fault(points.len(), |j| {
        let unmapped = !mapped[j].load(Ordering::Relaxed);
        unmapped
            .then(|| point_fault(mesh, points, by_position, j))
            .flatten()
    })
}

pub(super) fn input_vertex_fault(mesh: &Mesh, points: &[DVec2], v: usize) -> Option<String> {
    let i = mesh.vertex_input[v];
    if i == NONE {
        return None;
    }
    let p = mesh.vertices[v];
    let Some(&q) = points.get(i as usize) else {
        return Some(format!(
            "vertex {v} is input point {i}, out of range ({} points)",
            points.len()
        ));
    };
    let same = p.x.to_bits() == q.x.to_bits() && p.y.to_bits() == q.y.to_bits();
    (!same).then(|| {
        format!(
            "vertex {v} at {} is input point {i}, but that point is {} (bits {:#x} {:#x} vs {:#x} {:#x})",
            pt(p),
            pt(q),
            p.x.to_bits(),
            p.y.to_bits(),
            q.x.to_bits(),
            q.y.to_bits()
        )
    })
}

pub(super) fn check_inputs_once(mesh: &Mesh) -> Result<(), String> {
    let mut owners: Vec<(u32, u32)> = mesh
        .vertex_input
        .par_iter()
        .enumerate()
        .filter(|&(_, &i)| i != NONE)
        .map(|(v, &i)| (i, v as u32))
        .collect();
    owners.par_sort_unstable();
    first_fault(owners.len().saturating_sub(1), |k| {
        let ((i, u), (j, v)) = (owners[k], owners[k + 1]);
        (i == j).then(|| format!("input point {i} is both vertex {u} and vertex {v}"))
    })
}

/// An input vertex no triangle uses would lie inside a triangle or on an edge.
fn check_inputs_used(mesh: &Mesh) -> Result<(), String> {
    let used: Vec<AtomicBool> = (0..mesh.vertices.len())
        .map(|_| AtomicBool::new(false))
        .collect();
    mesh.triangles.par_iter().for_each(|tri| {
        for &v in tri {
            used[v as usize].store(true, Ordering::Relaxed);
        }
    });
    first_fault(mesh.vertices.len(), |v| {
        let i = mesh.vertex_input[v];
        (i != NONE && !used[v].load(Ordering::Relaxed)).then(|| {
            format!(
                "vertex {v}, input point {i} at {}, is in no triangle",
                pt(mesh.vertices[v])
            )
        })
    })
}

/// Input point `j` must be at an input vertex whose point is `j` or an earlier exact duplicate.
/// Duplicates are merged by value, so a later `-0.0` copy of a `0.0` point matches by value.
pub(super) fn point_fault(
    mesh: &Mesh,
    points: &[DVec2],
    by_position: &[((u64, u64), u32)],
    j: usize,
) -> Option<String> {
    let q = points[j];
    let found = by_position.binary_search_by_key(&position_key(q), |&(key, _)| key);
    let Ok(k) = found else {
        return Some(format!("input point {j} at {} is not a vertex", pt(q)));
    };
    let v = by_position[k].1;
    let i = mesh.vertex_input[v as usize];
    if i == NONE {
        return Some(format!(
            "input point {j} at {} is vertex {v}, which is marked as a Steiner vertex",
            pt(q)
        ));
    }
    (i as usize > j).then(|| {
        format!(
            "input point {j} at {} is vertex {v}, which belongs to the later input point {i} \
             (a duplicate must map to its first occurrence)",
            pt(q)
        )
    })
}

// ---------------------------------------------------------------------------------------------
// 8. Angles

fn check_angles(mesh: &Mesh, bounds: AngleBounds) -> Result<(), String> {
    let (lo, hi) = (
        bounds.min_deg - ANGLE_SLACK_DEG,
        bounds.max_deg + ANGLE_SLACK_DEG,
    );
    // Triangles in an input angle smaller than the bound keep it.
    let narrow = NarrowHullCorners::new(mesh, bounds.min_deg);
    first_fault(mesh.triangles.len(), |t| {
        let tri = mesh.triangles[t];
        let [a, b, c] = tri.map(|v| mesh.vertices[v as usize]);
        let angles = angles_deg(a, b, c);
        let bad = angles.iter().any(|x| !(lo..=hi).contains(x)) && !narrow.exempts(mesh, tri);
        bad.then(|| {
            format!(
                "triangle {t} {tri:?} at {} {} {} has angles {angles:?} degrees, outside [{}, {}]",
                pt(a),
                pt(b),
                pt(c),
                bounds.min_deg,
                bounds.max_deg
            )
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::BoundaryEdge;
    use BoundarySide::{Bottom, Left, Right, Top};

    const LOOSE: AngleBounds = AngleBounds {
        min_deg: 20.0,
        max_deg: 120.0,
    };

    fn unit_domain() -> Domain {
        Domain {
            lo: DVec2::ZERO,
            hi: DVec2::ONE,
        }
    }

    fn be(a: u32, b: u32, side: BoundarySide) -> BoundaryEdge {
        BoundaryEdge {
            vertices: [a, b],
            marker: side.marker(),
        }
    }

    fn corners() -> Vec<DVec2> {
        vec![
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(1.0, 1.0),
            DVec2::new(0.0, 1.0),
        ]
    }

    fn square_boundary() -> Vec<BoundaryEdge> {
        vec![
            be(0, 1, Bottom),
            be(1, 2, Right),
            be(2, 3, Top),
            be(3, 0, Left),
        ]
    }

    /// The unit square split along its diagonal 0-2.
    fn square() -> (Mesh, Vec<DVec2>) {
        let mesh = Mesh {
            outline: None,
            vertices: corners(),
            vertex_input: vec![0, 1, 2, 3],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
            neighbours: vec![[NONE, 1, NONE], [NONE, NONE, 0]],
            boundary: square_boundary(),
            domain: unit_domain(),
            ..Mesh::default()
        };
        (mesh, corners())
    }

    /// The unit square as a fan of four triangles around its centre, vertex 4 = input point 4.
    fn fan() -> (Mesh, Vec<DVec2>) {
        let mut vertices = corners();
        vertices.push(DVec2::splat(0.5));
        let mesh = Mesh {
            outline: None,
            vertex_input: vec![0, 1, 2, 3, 4],
            triangles: vec![[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]],
            neighbours: vec![[1, 3, NONE], [2, 0, NONE], [3, 1, NONE], [0, 2, NONE]],
            boundary: square_boundary(),
            domain: unit_domain(),
            vertices: vertices.clone(),
            ..Mesh::default()
        };
        (mesh, vertices)
    }

    fn fails(mesh: &Mesh, points: &[DVec2], bounds: AngleBounds, words: &[&str]) {
        let err = validate(mesh, points, bounds).expect_err("an invalid mesh");
        for w in words {
            assert!(err.message.contains(w), "{err:?} should mention {w:?}");
        }
    }

    /// A wedge of 5.7° at the origin (the hull of its three corners), cut by the points 3 on
    /// its lower side and 4 at (5, 0.5) on its upper one into three triangles.
    fn wedge(lower: f64) -> (Mesh, Vec<DVec2>) {
        let outline = vec![DVec2::ZERO, DVec2::new(10.0, 0.0), DVec2::new(10.0, 1.0)];
        let mut vertices = outline.clone();
        vertices.extend([DVec2::new(lower, 0.0), DVec2::new(5.0, 0.5)]);
        let edge = |a, b| BoundaryEdge {
            vertices: [a, b],
            marker: 1,
        };
        let mesh = Mesh {
            outline: Some(outline.clone()),
            vertex_input: vec![0, 1, 2, NONE, NONE],
            triangles: vec![[0, 3, 4], [3, 1, 4], [4, 1, 2]],
            neighbours: vec![[1, NONE, NONE], [2, 0, NONE], [NONE, NONE, 1]],
            boundary: vec![edge(0, 3), edge(3, 1), edge(1, 2), edge(2, 4), edge(4, 0)],
            domain: Domain {
                lo: DVec2::ZERO,
                hi: DVec2::new(10.0, 1.0),
            },
            vertices,
            ..Mesh::default()
        };
        (mesh, outline)
    }

    #[test]
    fn a_shortest_edge_across_a_narrow_hull_corner_is_exempt() {
        // Triangle 1's shortest edge 3-4 and triangle 2's 1-2 join the two sides of the 5.7°
        // corner: both keep their small angles (11°), as triangle 0 at the corner does.
        let (mesh, points) = wedge(5.0);
        assert_eq!(validate(&mesh, &points, LOOSE), Ok(()));
        // The same small angles with the shortest edge along one side are faults.
        let (mesh, points) = wedge(9.9);
        fails(&mesh, &points, LOOSE, &["triangle 1", "outside [20, 120]"]);
    }

    #[test]
    fn valid_meshes_pass() {
        let (mesh, points) = square();
        assert_eq!(mesh.validate(&points, LOOSE), Ok(()));
        let (mesh, points) = fan();
        assert_eq!(validate(&mesh, &points, LOOSE), Ok(()));
    }

    #[test]
    fn duplicate_input_points_map_to_the_first() {
        let (mesh, mut points) = square();
        points.push(points[2]);
        points.push(DVec2::new(-0.0, 0.0));
        assert_eq!(validate(&mesh, &points, LOOSE), Ok(()));
        // A vertex naming the later copy is a fault.
        let mut later = mesh.clone();
        later.vertex_input[2] = 4;
        fails(
            &later,
            &points,
            LOOSE,
            &["input point 2", "later input point 4"],
        );
    }

    #[test]
    fn index_out_of_range() {
        let (mut mesh, points) = square();
        mesh.triangles[1] = [0, 2, 7];
        fails(&mesh, &points, LOOSE, &["triangle 1", "7 out of range"]);
        let (mut mesh, points) = square();
        mesh.neighbours[0][1] = 2;
        fails(&mesh, &points, LOOSE, &["triangle 0", "2 out of range"]);
    }

    #[test]
    fn sizes() {
        let (mut mesh, points) = square();
        mesh.vertex_input.pop();
        fails(&mesh, &points, LOOSE, &["vertex_input"]);
        let (mut mesh, points) = square();
        mesh.triangles[0] = [0, 1, 1];
        fails(&mesh, &points, LOOSE, &["repeats a vertex"]);
        let (mut mesh, points) = square();
        mesh.triangles.clear();
        mesh.neighbours.clear();
        fails(&mesh, &points, LOOSE, &["no triangles"]);
    }

    #[test]
    fn clockwise_triangle() {
        let (mut mesh, points) = square();
        mesh.triangles[0] = [0, 2, 1];
        fails(&mesh, &points, LOOSE, &["triangle 0", "clockwise"]);
        let err = validate(&mesh, &points, LOOSE).unwrap_err();
        assert_eq!(err.check, MeshCheck::Orientation);
    }

    #[test]
    fn a_fault_names_its_check() {
        let (mesh, points) = square();
        let tight = AngleBounds {
            min_deg: 50.0,
            max_deg: 90.0,
        };
        let err = validate(&mesh, &points, tight).unwrap_err();
        assert_eq!(err.check, MeshCheck::Angles);
        assert!(
            err.to_string().starts_with("Angles check: triangle 0"),
            "{err}"
        );
        let mut moved = mesh.clone();
        moved.vertex_input.swap(1, 2);
        let err = validate(&moved, &points, LOOSE).unwrap_err();
        assert_eq!(err.check, MeshCheck::Conformity, "{err}");
    }

    #[test]
    fn vertex_in_no_triangle() {
        let (mut mesh, points) = square();
        mesh.vertices.push(DVec2::new(0.25, 0.5));
        mesh.vertex_input.push(NONE);
        fails(
            &mesh,
            &points,
            LOOSE,
            &["vertex 4", "(0.25, 0.5)", "no triangle"],
        );
    }

    #[test]
    fn duplicate_vertex() {
        let (mut mesh, points) = square();
        mesh.vertices.push(DVec2::new(1.0, 1.0));
        mesh.vertex_input.push(NONE);
        fails(&mesh, &points, LOOSE, &["vertices 2 and 4", "(1, 1)"]);
    }

    #[test]
    fn wrong_neighbour() {
        let (mut mesh, points) = square();
        mesh.neighbours[1] = [NONE, NONE, NONE];
        fails(
            &mesh,
            &points,
            LOOSE,
            &["triangle 1", "neighbour", "NONE, expected 0"],
        );
        let (mut mesh, points) = square();
        mesh.neighbours[0][0] = 1;
        fails(&mesh, &points, LOOSE, &["triangle 0", "no other triangle"]);
    }

    #[test]
    fn edge_used_in_the_same_direction() {
        let (mut mesh, points) = square();
        // Triangle 1 folded over triangle 0: its edge 2->0 runs the same way as 0's.
        mesh.vertices[3] = DVec2::new(1.0, -1.0);
        mesh.triangles[1] = [2, 0, 3];
        fails(
            &mesh,
            &points,
            LOOSE,
            &["same direction", "triangles 0", "and 1"],
        );
    }

    #[test]
    fn missing_boundary_edge() {
        let (mut mesh, points) = square();
        mesh.boundary.pop();
        fails(
            &mesh,
            &points,
            LOOSE,
            &["edge 3->0", "triangle 1", "not in the boundary list"],
        );
    }

    #[test]
    fn boundary_edge_on_the_wrong_side() {
        let (mut mesh, points) = square();
        mesh.boundary[1].marker = Left.marker();
        fails(&mesh, &points, LOOSE, &["boundary edge 1", "Left"]);
    }

    #[test]
    fn t_junction() {
        // The lower triangle split at the diagonal's midpoint, which lies on the upper
        // triangle's edge 0-2: that edge has one triangle yet is not on the boundary.
        let (mut mesh, mut points) = square();
        mesh.vertices.push(DVec2::splat(0.5));
        mesh.vertex_input.push(4);
        points.push(DVec2::splat(0.5));
        mesh.triangles = vec![[0, 1, 4], [4, 1, 2], [0, 2, 3]];
        mesh.neighbours = vec![[1, NONE, NONE], [NONE, NONE, 0], [NONE, NONE, NONE]];
        fails(
            &mesh,
            &points,
            LOOSE,
            &["edge 0->2", "triangle 2", "not in the boundary list"],
        );
    }

    #[test]
    fn hole() {
        let (mut mesh, points) = fan();
        mesh.triangles.pop();
        mesh.neighbours.pop();
        mesh.neighbours[0][1] = NONE;
        mesh.neighbours[2][0] = NONE;
        // The boundary and edge checks see it first; the area check on its own as well.
        // Edge 3->0 lost its triangle; the sorted comparison meets it before the hole's rim.
        fails(
            &mesh,
            &points,
            LOOSE,
            &["boundary edge 3 3->0", "exactly one triangle"],
        );
        let err = check_area(&mesh).expect_err("three quarters of the area");
        assert!(err.contains("sum to 0.75"), "{err}");
        assert!(err.contains("area is 1"), "{err}");
    }

    #[test]
    fn input_point_moved_by_one_ulp() {
        let (mesh, mut points) = fan();
        points[4].x = f64::from_bits(points[4].x.to_bits() + 1);
        fails(
            &mesh,
            &points,
            LOOSE,
            &["vertex 4", "input point 4", "0.5000000000000001"],
        );
    }

    #[test]
    fn input_point_missing_or_steiner() {
        let (mesh, mut points) = square();
        points.push(DVec2::new(0.25, 0.5));
        fails(&mesh, &points, LOOSE, &["input point 4", "not a vertex"]);
        let (mut mesh, points) = fan();
        mesh.vertex_input[4] = NONE;
        fails(&mesh, &points, LOOSE, &["input point 4", "Steiner"]);
        let (mut mesh, points) = fan();
        mesh.vertex_input[4] = 2;
        fails(&mesh, &points, LOOSE, &["vertex 4", "input point 2"]);
    }

    #[test]
    fn unused_input_vertex() {
        let (mut mesh, mut points) = square();
        mesh.vertices.push(DVec2::new(0.75, 0.25));
        mesh.vertex_input.push(4);
        points.push(DVec2::new(0.75, 0.25));
        fails(&mesh, &points, LOOSE, &["vertex 4", "in no triangle"]);
    }

    #[test]
    fn angle_out_of_bounds() {
        let (mesh, points) = square();
        let tight = AngleBounds {
            min_deg: 50.0,
            max_deg: 90.0,
        };
        fails(
            &mesh,
            &points,
            tight,
            &["triangle 0", "[0, 1, 2]", "angles", "[50, 90]"],
        );
        let exact = AngleBounds {
            min_deg: 45.0,
            max_deg: 90.0,
        };
        assert_eq!(validate(&mesh, &points, exact), Ok(()));
    }

    #[test]
    fn vertex_outside_the_domain() {
        let (mut mesh, points) = square();
        mesh.domain.hi.x = 2.0;
        fails(&mesh, &points, LOOSE, &["boundary edge 1", "Right"]);
    }

    /// An `n` by `n` grid of unit squares, each split along its rising diagonal.
    fn grid(n: u32) -> (Mesh, Vec<DVec2>) {
        let at = |i: u32, j: u32| j * (n + 1) + i;
        let vertices: Vec<DVec2> = (0..=n)
            .flat_map(|j| (0..=n).map(move |i| DVec2::new(f64::from(i), f64::from(j))))
            .collect();
        let cell = |i: u32, j: u32| j * n + i;
        let (mut triangles, mut neighbours) = (Vec::new(), Vec::new());
        for j in 0..n {
            for i in 0..n {
                let c = cell(i, j);
                let [right, below] = [(i + 1 < n, c + 1), (j > 0, c.wrapping_sub(n))];
                let [above, left] = [(j + 1 < n, c + n), (i > 0, c.wrapping_sub(1))];
                let lower = |(ok, d): (bool, u32)| if ok { 2 * d } else { NONE };
                let upper = |(ok, d): (bool, u32)| if ok { 2 * d + 1 } else { NONE };
                triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                neighbours.push([upper(right), 2 * c + 1, upper(below)]);
                triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
                neighbours.push([lower(above), lower(left), 2 * c]);
            }
        }
        let mut boundary = Vec::new();
        for k in 0..n {
            boundary.push(be(at(k, 0), at(k + 1, 0), Bottom));
            boundary.push(be(at(n, k), at(n, k + 1), Right));
            boundary.push(be(at(k + 1, n), at(k, n), Top));
            boundary.push(be(at(0, k + 1), at(0, k), Left));
        }
        let mesh = Mesh {
            outline: None,
            vertex_input: (0..vertices.len() as u32).collect(),
            triangles,
            neighbours,
            boundary,
            domain: Domain {
                lo: DVec2::ZERO,
                hi: DVec2::splat(f64::from(n)),
            },
            vertices: vertices.clone(),
            ..Mesh::default()
        };
        (mesh, vertices)
    }

    #[test]
    fn grid_passes_and_reports_a_swapped_neighbour() {
        let (mut mesh, points) = grid(40);
        assert_eq!(validate(&mesh, &points, LOOSE), Ok(()));
        mesh.neighbours[1001].swap(0, 1);
        fails(&mesh, &points, LOOSE, &["triangle 1001"]);
    }

    /// Timing on a large mesh: `QUADMESH_VALIDATE_N=4000 cargo test --release -- --ignored`.
    #[test]
    #[ignore = "timing, run by hand in release"]
    fn large_grid_timing() {
        let n = std::env::var("QUADMESH_VALIDATE_N").map_or(2000, |s| s.parse().unwrap());
        let (mesh, points) = grid(n);
        let start = std::time::Instant::now();
        assert_eq!(validate(&mesh, &points, LOOSE), Ok(()));
        println!(
            "{} triangles validated in {:?}",
            mesh.triangles.len(),
            start.elapsed()
        );
    }

    #[test]
    fn compensated_sum_keeps_small_terms() {
        let s = [1e16, 1.0, -1e16, 1.0]
            .iter()
            .fold(Sum::default(), |s, &x| s.add(x));
        assert_eq!(s.value(), 2.0);
        let (a, b) = (
            Sum::default().add(1e16).add(1.0),
            Sum::default().add(-1e16).add(1.0),
        );
        assert_eq!(a.merge(b).value(), 2.0);
    }
}
