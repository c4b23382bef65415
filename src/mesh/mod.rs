//! The triangle mesh every meshing mode produces, its validity and Delaunay checks, its
//! topology (edges, boundary markers, neighbours) and its quality report.

mod delaunay_check;
mod topology;
mod validate;

use std::time::Duration;

use glam::{DVec2, Vec2Swizzles};
use rayon::prelude::*;

use crate::error::Error;

pub use delaunay_check::check_delaunay;
pub use topology::Edge;
pub(crate) use topology::{EdgeLister, edges_listed_with, opposite_edge};
pub use validate::{AngleBounds, validate};

/// Marks "no triangle" in [`Mesh::neighbours`] and "no input point" in [`Mesh::vertex_input`].
pub const NONE: u32 = u32::MAX;

/// An axis-parallel rectangle `[lo, hi]`, the region a mesh covers.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Domain {
    /// Lower-left corner.
    pub lo: DVec2,
    /// Upper-right corner.
    pub hi: DVec2,
}

impl Domain {
    /// Area of the rectangle.
    pub fn area(&self) -> f64 {
        let d = self.hi - self.lo;
        d.x * d.y
    }

    /// Whether `p` lies in the closed rectangle.
    pub fn contains(&self, p: DVec2) -> bool {
        self.lo.x <= p.x && p.x <= self.hi.x && self.lo.y <= p.y && p.y <= self.hi.y
    }

    /// Refuses a rectangle that is not finite or has no area.
    ///
    /// # Errors
    /// [`Error::InvalidOption`] for the `domain` option.
    pub fn check(&self) -> Result<(), Error> {
        let (lo, hi) = (self.lo, self.hi);
        if lo.is_finite() && hi.is_finite() && lo.x < hi.x && lo.y < hi.y {
            return Ok(());
        }
        Err(Error::InvalidOption {
            option: "domain",
            message: format!(
                "[{}, {}] x [{}, {}] is not a rectangle of positive area",
                lo.x, hi.x, lo.y, hi.y
            ),
        })
    }

    /// Refuses points outside the rectangle (its sides count as inside).
    ///
    /// # Errors
    /// [`Error::OutsideDomain`] for the first such point.
    pub fn check_holds(&self, points: &[DVec2]) -> Result<(), Error> {
        match points.par_iter().position_first(|&p| !self.contains(p)) {
            Some(index) => Err(Error::OutsideDomain {
                index,
                x: points[index].x,
                y: points[index].y,
            }),
            None => Ok(()),
        }
    }

    /// The rectangle's mirror image.
    pub fn reflected(&self, r: Reflection) -> Domain {
        let (a, b) = (r.point(self.lo), r.point(self.hi));
        Domain {
            lo: a.min(b),
            hi: a.max(b),
        }
    }
}

/// A mirror image the mesher may work in and map back from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reflection {
    /// Across the diagonal `x = y`: coordinates swapped.
    Diagonal,
    /// Across the x axis: `y` negated.
    Horizontal,
}

impl Reflection {
    /// The image of a point (exact: a swap or a sign change).
    pub fn point(self, p: DVec2) -> DVec2 {
        match self {
            Reflection::Diagonal => p.yx(),
            Reflection::Horizontal => DVec2::new(p.x, -p.y),
        }
    }

    /// The image of a domain side.
    pub fn side(self, side: BoundarySide) -> BoundarySide {
        use BoundarySide::{Bottom, Left, Right, Top};
        match (self, side) {
            (Reflection::Diagonal, Bottom) => Left,
            (Reflection::Diagonal, Left) => Bottom,
            (Reflection::Diagonal, Right) => Top,
            (Reflection::Diagonal, Top) => Right,
            (Reflection::Horizontal, Bottom) => Top,
            (Reflection::Horizontal, Top) => Bottom,
            (Reflection::Horizontal, other) => other,
        }
    }
}

/// Which side of the domain a boundary edge lies on; the value is the edge's marker in the
/// output files (Triangle's convention: 0 is interior, nonzero is boundary).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(u8)]
pub enum BoundarySide {
    /// `y = lo.y`.
    Bottom = 1,
    /// `x = hi.x`.
    Right = 2,
    /// `y = hi.y`.
    Top = 3,
    /// `x = lo.x`.
    Left = 4,
}

impl std::fmt::Display for BoundarySide {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            BoundarySide::Bottom => "bottom",
            BoundarySide::Right => "right",
            BoundarySide::Top => "top",
            BoundarySide::Left => "left",
        })
    }
}

/// A triangle edge on the domain boundary, oriented counter-clockwise around the domain.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BoundaryEdge {
    /// Its two vertices, the domain's interior on their left.
    pub vertices: [u32; 2],
    /// The side of the domain it lies on.
    pub side: BoundarySide,
}

/// A conforming triangle mesh of a rectangular domain.
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
    /// The region the triangles cover exactly.
    pub domain: Domain,
}

impl Mesh {
    /// The mesh's mirror image: each triangle's last two corners (with their neighbours) and
    /// each boundary edge's ends exchanged, so that orientations stay counter-clockwise.
    pub fn reflected(self, r: Reflection) -> Mesh {
        let swap = |[a, b, c]: [u32; 3]| [a, c, b];
        Mesh {
            vertices: self.vertices.par_iter().map(|&v| r.point(v)).collect(),
            vertex_input: self.vertex_input,
            triangles: self.triangles.into_par_iter().map(swap).collect(),
            neighbours: self.neighbours.into_par_iter().map(swap).collect(),
            boundary: self
                .boundary
                .into_par_iter()
                .map(|e| BoundaryEdge {
                    vertices: [e.vertices[1], e.vertices[0]],
                    side: r.side(e.side),
                })
                .collect(),
            domain: self.domain.reflected(r),
        }
    }
}

/// Angles of a triangle in degrees, at its corners in order.
pub fn angles_deg(a: DVec2, b: DVec2, c: DVec2) -> [f64; 3] {
    let angle = |p: DVec2, q: DVec2, r: DVec2| {
        let (u, v) = (q - p, r - p);
        u.perp_dot(v).abs().atan2(u.dot(v)).to_degrees()
    };
    [angle(a, b, c), angle(b, c, a), angle(c, a, b)]
}

/// Smallest and largest angle (degrees) and the count of angles per 10° bin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AngleQuality {
    /// Smallest angle.
    pub min: f64,
    /// Largest angle.
    pub max: f64,
    /// `histogram[i]` counts angles in `[10 i, 10 (i + 1))` degrees.
    pub histogram: [u64; 18],
}

impl AngleQuality {
    pub(crate) fn empty() -> Self {
        AngleQuality {
            min: f64::INFINITY,
            max: f64::NEG_INFINITY,
            histogram: [0; 18],
        }
    }

    pub(crate) fn add(&mut self, angle: f64, count: u64) {
        self.min = self.min.min(angle);
        self.max = self.max.max(angle);
        self.histogram[((angle / 10.0) as usize).min(17)] += count;
    }

    /// The same angles `count` times over.
    pub(crate) fn repeated(mut self, count: u64) -> Self {
        self.histogram.iter_mut().for_each(|h| *h *= count);
        self
    }

    pub(crate) fn merge(mut self, other: Self) -> Self {
        self.min = self.min.min(other.min);
        self.max = self.max.max(other.max);
        for (h, o) in self.histogram.iter_mut().zip(other.histogram) {
            *h += o;
        }
        self
    }
}

/// Counts, angles and timings of a mesh run.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshReport {
    /// Distinct input points meshed.
    pub points: usize,
    /// Exact duplicates merged into an earlier point.
    pub duplicates: usize,
    /// Vertices of the mesh.
    pub vertices: usize,
    /// Triangles of the mesh.
    pub triangles: usize,
    /// Smallest angle, degrees.
    pub min_angle: f64,
    /// Largest angle, degrees.
    pub max_angle: f64,
    /// Count of angles per 10° bin: `histogram[i]` counts angles in `[10 i, 10 (i + 1))`.
    pub histogram: [u64; 18],
    /// Wall-clock time of each stage.
    pub stages: Vec<(&'static str, Duration)>,
}

impl MeshReport {
    /// Sum of the stage times.
    pub fn total(&self) -> Duration {
        self.stages.iter().map(|(_, d)| *d).sum()
    }
}
