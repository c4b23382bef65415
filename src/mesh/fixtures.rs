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
