//! Small hand-made meshes the unit tests of several modules share.

use glam::DVec2;

use super::{BoundaryEdge, BoundarySide, Domain, Mesh, NONE};

/// The unit square.
pub(crate) fn unit_domain() -> Domain {
    Domain {
        lo: DVec2::ZERO,
        hi: DVec2::ONE,
    }
}

/// The unit square's four boundary edges, counter-clockwise from the origin, given its
/// corners in that order.
pub(crate) fn square_boundary(corners: [u32; 4]) -> Vec<BoundaryEdge> {
    use BoundarySide::*;
    [Bottom, Right, Top, Left]
        .into_iter()
        .enumerate()
        .map(|(k, side)| BoundaryEdge {
            vertices: [corners[k], corners[(k + 1) % 4]],
            marker: side.marker(),
        })
        .collect()
}

/// The unit square cut along its diagonal from the origin.
pub(crate) fn two_triangles() -> Mesh {
    Mesh {
        outline: None,
        vertices: vec![
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(1.0, 1.0),
            DVec2::new(0.0, 1.0),
        ],
        vertex_input: vec![0, 2, 1, NONE],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        neighbours: vec![[NONE, 1, NONE], [NONE, NONE, 0]],
        boundary: square_boundary([0, 1, 2, 3]),
        domain: unit_domain(),
        ..Mesh::default()
    }
}

/// A planar straight-line graph's mesh: the unit square fanned around its centre (vertex 4),
/// every vertex an input point. Its subsegments: the bottom side (segment 0, marker 5), the
/// right side (segment 1, marker 0), the diagonal from the origin through the centre (segment
/// 2, marker -3, in two pieces) and the interior piece from the lower-right corner to the
/// centre (segment 3, marker 0); the top and left sides lie on no segment. The lowest triangle
/// is in region 0 (attribute 2.5), the right one in no region, the top and left ones in region
/// 1 (attribute -1). The one hole seed lies outside the square and so removes nothing.
pub(crate) fn pslg_square() -> Mesh {
    use super::SubSegment;
    let subsegment = |vertices, segment, marker| SubSegment {
        vertices,
        segment,
        marker,
    };
    let mut boundary = square_boundary([0, 1, 2, 3]);
    for (edge, marker) in boundary.iter_mut().zip([5, 1, 1, 1]) {
        edge.marker = marker;
    }
    Mesh {
        outline: None,
        vertices: vec![
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(1.0, 1.0),
            DVec2::new(0.0, 1.0),
            DVec2::new(0.5, 0.5),
        ],
        vertex_input: vec![0, 1, 2, 3, 4],
        triangles: vec![[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]],
        neighbours: vec![[1, 3, NONE], [2, 0, NONE], [3, 1, NONE], [0, 2, NONE]],
        boundary,
        domain: unit_domain(),
        segments: vec![
            subsegment([0, 1], 0, 5),
            subsegment([1, 2], 1, 0),
            subsegment([0, 4], 2, -3),
            subsegment([4, 2], 2, -3),
            subsegment([1, 4], 3, 0),
        ],
        triangle_regions: vec![0, NONE, 1, 1],
        region_attributes: vec![2.5, -1.0],
        holes: vec![DVec2::new(2.0, 0.5)],
    }
}
