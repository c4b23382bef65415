//! The triangle mesh every meshing mode produces, its validity and Delaunay checks, its
//! topology (edges, boundary markers, neighbours) and its quality report.

mod changes;
mod delaunay_check;
#[cfg(test)]
pub(crate) mod fixtures;
mod report;
mod star;
mod topology;
mod validate;
mod validate_pslg;

use glam::DVec2;
use rayon::prelude::*;

/// Marks "no triangle" in [`Mesh::neighbours`] and "no input point" in [`Mesh::vertex_input`].
pub use crate::domain::NONE;
pub use crate::domain::{BoundaryEdge, BoundarySide, Domain, Reflection, SubSegment};
pub use changes::MeshChange;
pub(crate) use changes::{Corners, corner_bits};
pub use delaunay_check::check_delaunay;
pub(crate) use report::AngleTally;

pub(crate) use report::report_of;
pub use report::{AngleQuality, MeshReport, StageTimes};
pub(crate) use star::Star;
pub use topology::Edge;
pub(crate) use topology::{EdgeLister, edges_listed_with, opposite_edge};
pub use validate::{
    AngleBounds, InvalidMesh, MeshCheck, first_obtuse, largest_coordinate, obtuse_beyond,
    rounding_allowance_deg, rounding_turn, validate, validate_nonobtuse,
};
pub use validate_pslg::{validate_pslg, validate_pslg_with};

/// A conforming triangle mesh of a rectangle, or of the points' convex hull (`outline`).
///
/// Every distinct input point is a vertex with its exact input coordinates; `vertex_input` says
/// which. Triangles are counter-clockwise; `neighbours[t][i]` is the triangle across the edge
/// opposite corner `i` of triangle `t` (the edge from corner `i + 1` to corner `i + 2`), or
/// [`NONE`] on the boundary.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex coordinates.
    pub vertices: Vec<DVec2>,
    /// Input index (0-based, file order) of each vertex, or [`NONE`] for a Steiner vertex.
    /// Exact duplicates of a point are merged into its first occurrence.
    pub vertex_input: Vec<u32>,
    /// Vertex indices of each triangle, counter-clockwise.
    pub triangles: Vec<[u32; 3]>,
    /// The triangle across the edge opposite each corner, or [`NONE`].
    pub neighbours: Vec<[u32; 3]>,
    /// The edges on the domain boundary, counter-clockwise.
    pub boundary: Vec<BoundaryEdge>,
    /// The rectangle the triangles cover exactly, or, with an `outline`, its bounding box.
    pub domain: Domain,
    /// The polygon the triangles cover exactly when it is not the rectangle `domain`: the
    /// points' convex hull, its corners counter-clockwise, every input point on its sides
    /// included, and bent through any point inside it within 1e-11 of a side's length, or
    /// within 1e-70 of a side (see [`crate::refine`]).
    pub outline: Option<Vec<DVec2>>,
    /// The pieces of the input's segments (planar straight-line graphs), each once, in the
    /// order of their segments and along each from its first end; empty for a point set.
    pub segments: Vec<SubSegment>,
    /// Per triangle, the region (an index into `region_attributes`, one per region seed) it
    /// lies in, or [`NONE`]; empty when the input has no regions.
    pub triangle_regions: Vec<u32>,
    /// The attribute of each region seed (Triangle's regional attribute).
    pub region_attributes: Vec<f64>,
    /// The hole seeds of the input: the region around each is empty.
    pub holes: Vec<DVec2>,
}

impl Mesh {
    /// The regional attribute of triangle `t`: its region's, or 0 outside every region.
    pub fn triangle_attribute(&self, t: usize) -> f64 {
        match self.triangle_regions.get(t) {
            Some(&r) if r != NONE => self.region_attributes[r as usize],
            _ => 0.0,
        }
    }
}

impl Mesh {
    /// The mesh's mirror image: each triangle's last two corners (with their neighbours) and
    /// each boundary edge's ends exchanged, so that orientations stay counter-clockwise.
    pub fn reflected(self, r: Reflection) -> Mesh {
        let swap = |[a, b, c]: [u32; 3]| [a, c, b];
        // A rectangle's markers name its sides, which the reflection moves.
        let rectangle = self.outline.is_none();
        Mesh {
            outline: self
                .outline
                .map(|o| o.into_iter().map(|p| r.point(p)).rev().collect()),
            vertices: self.vertices.par_iter().map(|&v| r.point(v)).collect(),
            vertex_input: self.vertex_input,
            triangles: self.triangles.into_par_iter().map(swap).collect(),
            neighbours: self.neighbours.into_par_iter().map(swap).collect(),
            boundary: self
                .boundary
                .into_par_iter()
                .map(|e| BoundaryEdge {
                    vertices: [e.vertices[1], e.vertices[0]],
                    marker: match e.side() {
                        Some(s) if rectangle => r.side(s).marker(),
                        _ => e.marker,
                    },
                })
                .collect(),
            domain: self.domain.reflected(r),
            segments: self.segments,
            triangle_regions: self.triangle_regions,
            region_attributes: self.region_attributes,
            holes: self.holes.into_iter().map(|p| r.point(p)).collect(),
        }
    }
}

/// Angles of a triangle in degrees, at its corners in order.
pub fn angles_deg(a: DVec2, b: DVec2, c: DVec2) -> [f64; 3] {
    corner_sides(a, b, c).map(|(u, v)| angle_deg(u, v))
}

/// The two sides leaving each corner of triangle `a, b, c`, in [`angles_deg`]'s order.
#[inline]
pub(crate) fn corner_sides(a: DVec2, b: DVec2, c: DVec2) -> [(DVec2, DVec2); 3] {
    [(b - a, c - a), (c - b, a - b), (a - c, b - c)]
}

/// The cosines of the angles of triangle `a, b, c`, in [`angles_deg`]'s order.
#[inline]
pub(crate) fn corner_cosines(a: DVec2, b: DVec2, c: DVec2) -> [f64; 3] {
    corner_sides(a, b, c).map(|(u, v)| cosine(u, v))
}

/// The angle between `u` and `v`, degrees, as [`angles_deg`] measures a triangle's.
#[inline]
pub(crate) fn angle_deg(u: DVec2, v: DVec2) -> f64 {
    u.perp_dot(v).abs().atan2(u.dot(v)).to_degrees()
}

/// The cosine of the angle between `u` and `v`, from their dot and cross products (NaN when
/// either is zero or infinite). Where those products' squares overflow or fall below f64's
/// normal range, the vectors are first scaled to a largest component of 1.
#[inline]
pub(crate) fn cosine(u: DVec2, v: DVec2) -> f64 {
    let (dot, cross) = (u.dot(v), u.perp_dot(v));
    let norm = dot * dot + cross * cross;
    if norm.is_normal() {
        return dot / norm.sqrt();
    }
    let (u, v) = (u / u.abs().max_element(), v / v.abs().max_element());
    let (dot, cross) = (u.dot(v), u.perp_dot(v));
    dot / (dot * dot + cross * cross).sqrt()
}

/// The interior angle at each corner of a counter-clockwise polygon, degrees (above 180 at a
/// reflex corner).
pub fn interior_angles_deg(polygon: &[DVec2]) -> Vec<f64> {
    let n = polygon.len();
    (0..n)
        .map(|k| {
            let (prev, here, next) = (polygon[(k + n - 1) % n], polygon[k], polygon[(k + 1) % n]);
            let (a, b) = (next - here, prev - here);
            let angle = a.perp_dot(b).atan2(a.dot(b)).to_degrees();
            if angle < 0.0 { angle + 360.0 } else { angle }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interior_angles_of_convex_and_reflex_corners() {
        let square = [DVec2::ZERO, DVec2::X, DVec2::ONE, DVec2::Y];
        assert_eq!(interior_angles_deg(&square), [90.0; 4]);
        // A side bent a hair inward through its midpoint: the bend is a reflex corner, not an
        // acute one.
        let bent = [
            DVec2::ZERO,
            DVec2::new(0.5, 1e-9),
            DVec2::X,
            DVec2::new(0.5, 1.0),
        ];
        let angles = interior_angles_deg(&bent);
        assert!(angles[1] > 180.0 && angles[1] < 180.001, "{angles:?}");
        let total: f64 = angles.iter().sum();
        assert!((total - 360.0).abs() < 1e-9, "{angles:?}");
    }
}
