//! Small hand-made meshes the unit tests of several modules share.

use std::collections::HashMap;

use glam::DVec2;

use super::{BoundaryEdge, BoundarySide, Domain, Mesh, NONE, opposite_edge};

/// The unit square.
pub(crate) fn unit_domain() -> Domain {
    Domain {
        lo: DVec2::ZERO,
        hi: DVec2::ONE,
    }
}

/// The smallest rectangle around `points`.
pub(crate) fn bounding_box(points: &[DVec2]) -> Domain {
    Domain {
        lo: points.iter().fold(DVec2::INFINITY, |m, &p| m.min(p)),
        hi: points.iter().fold(DVec2::NEG_INFINITY, |m, &p| m.max(p)),
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

/// The unit square's corners, counter-clockwise from the origin.
fn square_corners() -> Vec<DVec2> {
    [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
        .map(|[x, y]| DVec2::new(x, y))
        .to_vec()
}

/// The triangle across the edge opposite each corner of each of `triangles`, or [`NONE`]:
/// the one that has the edge the other way round.
pub(crate) fn neighbours_of(triangles: &[[u32; 3]]) -> Vec<[u32; 3]> {
    let mut owner = HashMap::new();
    for (t, &triangle) in (0..).zip(triangles) {
        for i in 0..3 {
            owner.insert(opposite_edge(triangle, i), t);
        }
    }
    triangles
        .iter()
        .map(|&triangle| {
            [0, 1, 2].map(|i| {
                let [a, b] = opposite_edge(triangle, i);
                owner.get(&[b, a]).copied().unwrap_or(NONE)
            })
        })
        .collect()
}

/// The unit square cut along its diagonal from the origin.
pub(crate) fn two_triangles() -> Mesh {
    Mesh {
        outline: None,
        vertices: square_corners(),
        vertex_input: vec![0, 2, 1, NONE],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        neighbours: vec![[NONE, 1, NONE], [NONE, NONE, 0]],
        boundary: square_boundary([0, 1, 2, 3]),
        domain: unit_domain(),
        ..Mesh::default()
    }
}

/// The unit square fanned around its centre (vertex 4), which is the only input point.
pub(crate) fn four_triangles() -> Mesh {
    Mesh {
        outline: None,
        vertices: [square_corners(), vec![DVec2::splat(0.5)]].concat(),
        vertex_input: vec![NONE, NONE, NONE, NONE, 0],
        triangles: vec![[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]],
        neighbours: vec![[1, 3, NONE], [2, 0, NONE], [3, 1, NONE], [0, 2, NONE]],
        boundary: square_boundary([0, 1, 2, 3]),
        domain: unit_domain(),
        ..Mesh::default()
    }
}

/// A planar straight-line graph's mesh: [`four_triangles`] with every vertex an input point.
/// Its subsegments: the bottom side (segment 0, marker 5), the right side (segment 1, marker
/// 0), the diagonal from the origin through the centre (segment 2, marker -3, in two pieces)
/// and the interior piece from the lower-right corner to the centre (segment 3, marker 0); the
/// top and left sides lie on no segment. The lowest triangle is in region 0 (attribute 2.5),
/// the right one in no region, the top and left ones in region 1 (attribute -1). The one hole
/// seed lies outside the square and so removes nothing.
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
        vertex_input: vec![0, 1, 2, 3, 4],
        boundary,
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
        ..four_triangles()
    }
}

/// The mesh of `triangles` on `vertices`, the `k`-th of `inputs` being input point `k`, its
/// boundary edges (marker 1) and neighbours found from the triangles, on the vertices' box.
pub(crate) fn mesh_of(vertices: Vec<DVec2>, inputs: &[u32], triangles: Vec<[u32; 3]>) -> Mesh {
    let mut vertex_input = vec![NONE; vertices.len()];
    for (i, &v) in inputs.iter().enumerate() {
        vertex_input[v as usize] = i as u32;
    }
    let neighbours = neighbours_of(&triangles);
    let mut boundary = Vec::new();
    for (&corners, across) in triangles.iter().zip(&neighbours) {
        for (i, &t) in across.iter().enumerate() {
            if t == NONE {
                boundary.push(BoundaryEdge {
                    vertices: opposite_edge(corners, i),
                    marker: 1,
                });
            }
        }
    }
    Mesh {
        domain: bounding_box(&vertices),
        vertices,
        vertex_input,
        triangles,
        neighbours,
        boundary,
        ..Mesh::default()
    }
}
