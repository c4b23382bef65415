//! The crate's error type: every way an input can be refused, with what to fix.

use glam::DVec2;
use rayon::prelude::*;
use thiserror::Error;

use crate::domain::{BoundarySide, Domain, Reflection};
use crate::mesh::{Mesh, MeshReport};

/// Why an input was refused. Nothing is dropped silently: each variant names the offending data.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum Error {
    /// No points at all.
    #[error("the input has no points")]
    Empty,
    /// More points than 32-bit indices can number.
    #[error("the input has {0} points; at most 4294967294 are supported")]
    TooManyPoints(usize),
    /// A coordinate is NaN or infinite.
    #[error("point {index} has a non-finite coordinate ({x}, {y})")]
    NonFinite {
        /// Input index of the point.
        index: usize,
        /// Its x coordinate.
        x: f64,
        /// Its y coordinate.
        y: f64,
    },
    /// The bounding box is too large for f64 arithmetic on its extent, or (in the quadtree
    /// modes) so small that its mesh's areas underflow.
    #[error(
        "coordinates span [{lo:?}, {hi:?}], too wide or too narrow for f64 to measure the mesh's \
         areas; rescale the input"
    )]
    CoordinateRange {
        /// Lower-left corner of the bounding box.
        lo: [f64; 2],
        /// Upper-right corner of the bounding box.
        hi: [f64; 2],
    },
    /// Coordinates at a scale where the exact predicates of the Delaunay mode would overflow or
    /// underflow f64: an extent above 1e70 or below 1e-70, or a coordinate above 1e70.
    #[error(
        "coordinates span [{lo:?}, {hi:?}]; the Delaunay mode computes exactly only with an extent \
         between 1e-70 and 1e70 and coordinates below 1e70 in magnitude; rescale the input"
    )]
    ScaleRange {
        /// Lower-left corner of the bounding box.
        lo: [f64; 2],
        /// Upper-right corner of the bounding box.
        hi: [f64; 2],
    },
    /// Two distinct points that even the 64-bit-per-axis grid puts in one cell.
    #[error(
        "points {a} ({:?}) and {b} ({:?}) are distinct but too close to separate on a 64-bit grid \
         over the input's extent; merge or move them",
        pa,
        pb
    )]
    Inseparable {
        /// Input index of the first point.
        a: usize,
        /// Its coordinates.
        pa: [f64; 2],
        /// Input index of the second point.
        b: usize,
        /// Its coordinates.
        pb: [f64; 2],
    },
    /// Two distinct points closer together than the Delaunay mode's exact predicates resolve:
    /// within 1e-70 in both coordinates, where the in-circle test's products underflow f64.
    #[error(
        "points {a} ({:?}) and {b} ({:?}) are distinct but within 1e-70 of each other, closer \
         than the Delaunay mode computes exactly; merge or move them",
        pa,
        pb
    )]
    TooClose {
        /// Input index of the first point.
        a: usize,
        /// Its coordinates.
        pa: [f64; 2],
        /// Input index of the second point.
        b: usize,
        /// Its coordinates.
        pb: [f64; 2],
    },
    /// A point given twice: an edit of a dynamic mesh that puts a point where a live one is, or
    /// a dynamic mesh's initial points with one repeated.
    #[error("point {id} ({x}, {y}) is already point {existing}")]
    DuplicatePoint {
        /// The id the new point would have had, or the point moved.
        id: usize,
        /// The live point at the same place.
        existing: usize,
        /// Its x coordinate.
        x: f64,
        /// Its y coordinate.
        y: f64,
    },
    /// An edit names a point id that was never given out or whose point was deleted.
    #[error("no live point has id {id}")]
    UnknownPoint {
        /// The id.
        id: usize,
    },
    /// Points so close, relative to the input's extent, that the mesh between them needs
    /// vertices f64 cannot place apart.
    #[error(
        "the mesh around point {index} ({x}, {y}) needs vertices closer together than f64 \
         resolves at that position; the points span too many orders of magnitude"
    )]
    Unresolvable {
        /// Input index of the point.
        index: usize,
        /// Its x coordinate.
        x: f64,
        /// Its y coordinate.
        y: f64,
    },
    /// The warp of a graph met a place its templates cannot fill: the leaves bent onto the
    /// graph leave a polygon no triangulation of which keeps the graph's edges (features the
    /// tree could not keep far enough apart for the warp).
    #[error("the warped mesh of the graph cannot be completed near ({x}, {y}): {why}")]
    WarpStuck {
        /// Its x coordinate.
        x: f64,
        /// Its y coordinate.
        y: f64,
        /// What went wrong there.
        why: &'static str,
    },
    /// The output would need more elements than 32-bit indices can number.
    #[error("the mesh would have {count} {what}; at most 4294967294 are supported")]
    TooLarge {
        /// What overflowed (vertices, triangles).
        what: &'static str,
        /// How many there would be.
        count: usize,
    },
    /// A graph's separated tree would need more squares than the budget asked for: features
    /// very close together for their size, or two long edges at a very small angle, which must
    /// be kept apart all along. Two such features are named, by a point of each, where the
    /// squares went past the budget.
    #[error(
        "the graph's quadtree needs more than {limit} split squares: the features at point {a} \
         ({:?}) and point {b} ({:?}) lie very close together for their size, or meet at a very \
         small angle",
        pa,
        pb
    )]
    SquareBudget {
        /// The budget.
        limit: usize,
        /// Input index of a point of the first feature.
        a: usize,
        /// Its coordinates.
        pa: [f64; 2],
        /// Input index of a point of the second.
        b: usize,
        /// Its coordinates.
        pb: [f64; 2],
    },
    /// A point lies outside the domain asked for.
    #[error("point {index} ({x}, {y}) lies outside the domain")]
    OutsideDomain {
        /// Input index of the point.
        index: usize,
        /// Its x coordinate.
        x: f64,
        /// Its y coordinate.
        y: f64,
    },
    /// Points so close to a given domain's long side (the one the mesh lines), or so close
    /// together on it, that the row of equal cells the mesh keeps along that side would be too
    /// many.
    #[error(
        "point {index} ({x}, {y}) needs cells so small near the domain's {side} side, which the \
         mesh lines with equal cells, that it would take {cells} of them; move points that are \
         nearly on that side onto it or away from it, or widen the domain"
    )]
    NearDomainSide {
        /// Input index of the point.
        index: usize,
        /// Its x coordinate.
        x: f64,
        /// Its y coordinate.
        y: f64,
        /// Which side.
        side: BoundarySide,
        /// How many cells the band along the side would have.
        cells: u128,
    },
    /// A given domain so much wider than tall (or taller than wide) that the row of equal
    /// cells along its long sides would be too many.
    #[error(
        "the domain is {width} wide and {height} tall; its mesh would need more cells along its \
         long side than its points justify (at most 64 per point or 2^20); mesh a less elongated \
         domain"
    )]
    ThinDomain {
        /// The domain's width.
        width: f64,
        /// The domain's height.
        height: f64,
    },
    /// The points all lie on one line: their convex hull, the domain asked for, has no area.
    #[error(
        "the points are collinear (one of them: ({x}, {y})), so their convex hull has no area; \
         mesh a rectangle around them instead"
    )]
    Degenerate {
        /// An x coordinate of one of the points.
        x: f64,
        /// Its y coordinate.
        y: f64,
    },
    /// The input asks for something this version does not mesh.
    #[error("{what} are not supported yet")]
    Unsupported {
        /// What was asked for.
        what: &'static str,
    },
    /// An option's value is out of range.
    #[error("option {option}: {message}")]
    InvalidOption {
        /// The option, as [`crate::Options`] names it.
        option: &'static str,
        /// What is wrong with the value.
        message: String,
    },
    /// Refinement needed more vertices than its budget allows: the angle bound is above what
    /// refinement reaches on this input, or the budget is too small for it. The mesh reached so
    /// far comes with it: valid, with the triangles still outside the bounds listed.
    #[error(
        "refinement stopped at its budget of {} vertices (input points included) with {} \
         triangles still outside the bounds{}; raise the vertex budget or lower the angle bound \
         (termination is proven up to 20.7 degrees)",
        .0.limit,
        .0.unmet.len(),
        .0.unmet.first().map_or(String::new(), |u| format!(", the first near ({}, {})", u.at.x, u.at.y))
    )]
    VertexBudget(Box<Incomplete>),
    /// Refinement needed a vertex closer to others than f64 resolves: it kept shrinking the
    /// triangles at one place, which happens above the angle bounds refinement can reach.
    #[error(
        "refinement needs a vertex at ({x}, {y}), closer to others than f64 resolves there: it \
         cannot reach the angle bound near that point (it reliably does up to about 33 degrees; \
         termination is proven up to 20.7), or the points there are closer together than f64 \
         can refine between"
    )]
    RefinementResolution {
        /// Its x coordinate.
        x: f64,
        /// Its y coordinate.
        y: f64,
        /// The mesh refinement reached, where it stopped there (a quality refinement's loops;
        /// not a refinement in order, nor the insertion of input points): valid, with the
        /// triangles still outside the bounds listed.
        reached: Option<Box<Incomplete>>,
    },
    /// A segment names a point the input does not have.
    #[error("segment {segment} names point {index}, but the input has {points} points")]
    SegmentIndex {
        /// Input index of the segment.
        segment: usize,
        /// The point index it names.
        index: u32,
        /// How many points the input has.
        points: usize,
    },
    /// A segment whose two ends are one point: the same index, or two points at the same
    /// position.
    #[error(
        "segment {segment} has no length: its two ends are the same point (or two points at the \
         same position)"
    )]
    ZeroLengthSegment {
        /// Input index of the segment.
        segment: usize,
    },
    /// Two segments whose interiors meet: they cross, or overlap on one line.
    #[error(
        "segments {a} and {b} cross at ({}, {}); add a point there and split both at it, or ask \
         the cleaning to split crossings",
        at[0],
        at[1]
    )]
    CrossingSegments {
        /// Input index of one segment.
        a: usize,
        /// Input index of the other (larger than `a`).
        b: usize,
        /// Where they meet (rounded to f64).
        at: [f64; 2],
    },
    /// Splitting crossings does not settle: the split points, rounded to f64, keep making new
    /// crossings (segments nearly on one line, or far from the origin for their spacing).
    #[error(
        "segments {a} and {b} still cross at ({}, {}) after {rounds} rounds of splitting          crossings: the split points, rounded to f64, keep making new crossings there; join the          segments at a shared point or move them apart",
        at[0],
        at[1]
    )]
    CrossingsUnsettled {
        /// Input index of one segment.
        a: usize,
        /// Input index of the other (larger than `a`).
        b: usize,
        /// Where they meet (rounded to f64).
        at: [f64; 2],
        /// The rounds of splitting done.
        rounds: usize,
    },
    /// A hole or region seed lies exactly on a segment or on a segment's end: which region it
    /// names is ambiguous.
    #[error(
        "{kind} seed {index} at ({x}, {y}) lies on a segment or a segment's end, so the region \
         it names is ambiguous; move it inside that region"
    )]
    SeedOnSegment {
        /// `"hole"` or `"region"`.
        kind: &'static str,
        /// Its index among the input's holes or regions.
        index: usize,
        /// Its x coordinate.
        x: f64,
        /// Its y coordinate.
        y: f64,
    },
    /// The segments enclose no area once the outside and the holes are taken away (an open
    /// polyline, or a hole seed inside the only enclosed region).
    #[error(
        "the segments enclose no area once the outside and the holes are removed; close the \
         boundary, check the hole seeds, or mesh the convex hull instead"
    )]
    NothingEnclosed,
    /// A line of an input file could not be read.
    #[error("{source_name}:{line}: {message}")]
    Parse {
        /// File name (or `<input>`).
        source_name: String,
        /// 1-based line number.
        line: usize,
        /// What is wrong with it.
        message: String,
    },
    /// The operating system refused to read or write a file.
    #[error("{path}: {message}")]
    Io {
        /// The file.
        path: String,
        /// The system's message.
        message: String,
    },
}

/// A mesh that refinement left unfinished: at its vertex budget, or where f64 could not place
/// the vertex it needed.
#[derive(Clone, Debug, PartialEq)]
pub struct Incomplete {
    /// The vertex budget refinement ran under.
    pub limit: usize,
    /// The mesh reached: it passes [`Mesh::validate`] except for the bounds.
    pub mesh: Mesh,
    /// Its report.
    pub report: MeshReport,
    /// The triangles still outside the bounds, in triangle order.
    pub unmet: Vec<Unmet>,
}

/// A triangle outside the quality bounds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Unmet {
    /// Its index in the mesh.
    pub triangle: u32,
    /// Its centroid.
    pub at: DVec2,
    /// Its smallest angle, degrees.
    pub min_angle: f64,
    /// Its area.
    pub area: f64,
}

impl Error {
    /// [`Error::RefinementResolution`] at `p`, without a mesh.
    pub(crate) fn resolution_at(p: DVec2) -> Error {
        Error::RefinementResolution {
            x: p.x,
            y: p.y,
            reached: None,
        }
    }

    /// The same error for the input's mirror image `r`: coordinates and sides mapped.
    pub fn reflected(mut self, r: Reflection) -> Error {
        let image = |p: [f64; 2]| <[f64; 2]>::from(r.point(DVec2::from(p)));
        match &mut self {
            Error::NonFinite { x, y, .. }
            | Error::Unresolvable { x, y, .. }
            | Error::WarpStuck { x, y, .. }
            | Error::OutsideDomain { x, y, .. }
            | Error::NearDomainSide { x, y, .. } => [*x, *y] = image([*x, *y]),
            Error::Inseparable { pa, pb, .. } | Error::SquareBudget { pa, pb, .. } => {
                (*pa, *pb) = (image(*pa), image(*pb));
            }
            Error::CrossingSegments { at, .. } | Error::CrossingsUnsettled { at, .. } => {
                *at = image(*at);
            }
            Error::CoordinateRange { lo, hi } => {
                let (a, b) = (DVec2::from(image(*lo)), DVec2::from(image(*hi)));
                (*lo, *hi) = (a.min(b).into(), a.max(b).into());
            }
            Error::ThinDomain { width, height } if r == Reflection::Diagonal => {
                std::mem::swap(width, height);
            }
            _ => {}
        }
        if let Error::NearDomainSide { side, .. } = &mut self {
            *side = r.side(*side);
        }
        self
    }
}

/// The domain's checks of itself and of the points, here with the errors they raise, so that
/// [`crate::domain`] stays a leaf.
impl Domain {
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
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_reflected_error_names_the_mirrored_point_and_side() {
        let near = Error::NearDomainSide {
            index: 3,
            x: 1.0,
            y: -2.0,
            side: BoundarySide::Top,
            cells: 9,
        };
        let Error::NearDomainSide { x, y, side, .. } = near.clone().reflected(Reflection::Diagonal)
        else {
            unreachable!()
        };
        assert_eq!((x, y, side), (-2.0, 1.0, BoundarySide::Right));
        let errors = [
            near,
            Error::NonFinite {
                index: 1,
                x: 1.0,
                y: f64::INFINITY,
            },
            Error::Unresolvable {
                index: 1,
                x: 1.0,
                y: 2.0,
            },
            Error::OutsideDomain {
                index: 1,
                x: 1.0,
                y: 2.0,
            },
            Error::Inseparable {
                a: 1,
                pa: [1.0, 2.0],
                b: 2,
                pb: [3.0, 4.0],
            },
            Error::SquareBudget {
                limit: 10,
                a: 1,
                pa: [1.0, 2.0],
                b: 2,
                pb: [3.0, 4.0],
            },
            Error::CoordinateRange {
                lo: [1.0, -3.0],
                hi: [2.0, 4.0],
            },
            Error::ThinDomain {
                width: 1.0,
                height: 1e-9,
            },
            Error::Empty,
            Error::CrossingSegments {
                a: 1,
                b: 2,
                at: [0.5, -2.0],
            },
        ];
        for e in errors {
            for r in [Reflection::Diagonal, Reflection::Horizontal] {
                assert_eq!(e.clone().reflected(r).reflected(r), e, "{r:?}");
            }
        }
        let Error::CoordinateRange { lo, hi } = Error::CoordinateRange {
            lo: [1.0, -3.0],
            hi: [2.0, 4.0],
        }
        .reflected(Reflection::Horizontal) else {
            unreachable!()
        };
        assert_eq!((lo, hi), ([1.0, -4.0], [2.0, 3.0]));
    }
}
