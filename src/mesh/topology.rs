//! The mesh's topology as a finite-element code wants it: every edge once with its two triangles
//! and its boundary marker, the vertices' boundary markers, the vertices' input indices and the
//! triangles' neighbours as options.
//!
//! Markers follow Triangle's convention: 0 for the interior, the side's [`BoundarySide`] value
//! (1 bottom, 2 right, 3 top, 4 left) on the boundary of a rectangle, 1 on a convex hull. In a
//! mesh of a planar straight-line graph the edges and vertices on segments carry the segments'
//! markers, and those on the boundary whose segment marker is 0, or that lie on no segment, 1.
//!
//! [`BoundarySide`]: super::BoundarySide

use std::collections::{HashMap, HashSet};

use rayon::prelude::*;

use super::{Mesh, NONE};

/// An edge of a mesh, as [`Mesh::edges`] lists it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Edge {
    /// Its two vertices, in the counter-clockwise direction of `triangles[0]`.
    pub vertices: [u32; 2],
    /// The triangle that has the edge as `vertices[0] -> vertices[1]` on its counter-clockwise
    /// boundary, then the triangle on the other side, or [`NONE`] for a boundary edge.
    pub triangles: [u32; 2],
    /// For a boundary edge, the marker of its [`BoundaryEdge`](super::BoundaryEdge); for an
    /// interior edge, the marker of the segment it lies on, or 0 if none.
    pub marker: i32,
}

/// The edge opposite corner `i` of `triangle`, in the triangle's counter-clockwise direction.
pub(crate) fn opposite_edge(triangle: [u32; 3], i: usize) -> [u32; 2] {
    [triangle[(i + 1) % 3], triangle[(i + 2) % 3]]
}

/// Whether triangle `t` lists the edge opposite its corner `i`: a boundary edge always, an
/// interior edge only from the lower-numbered of its two triangles, so every edge once.
fn lists_edge(mesh: &Mesh, t: usize, i: usize) -> bool {
    let across = mesh.neighbours[t][i];
    across == NONE || t < across as usize
}

/// How many edges triangle `t` lists (0 to 3), in [`Mesh::edges`] and the `.edge` file.
pub(crate) fn edges_listed_with(mesh: &Mesh, t: usize) -> usize {
    (0..3).filter(|&i| lists_edge(mesh, t, i)).count()
}

/// An edge's two vertices, the lower first: the same key for both directions.
fn edge_key([a, b]: [u32; 2]) -> [u32; 2] {
    [a.min(b), a.max(b)]
}

/// Lists the edges of a mesh triangle by triangle, with their markers.
pub(crate) struct EdgeLister<'a> {
    mesh: &'a Mesh,
    /// The marker of each boundary edge, by [`edge_key`].
    markers: HashMap<[u32; 2], i32>,
    /// The marker of each subsegment, by [`edge_key`]; empty for a point set.
    segments: HashMap<[u32; 2], i32>,
}

impl<'a> EdgeLister<'a> {
    pub(crate) fn new(mesh: &'a Mesh) -> Self {
        let markers = mesh
            .boundary
            .iter()
            .map(|e| (edge_key(e.vertices), e.marker))
            .collect();
        let segments = mesh
            .segments
            .iter()
            .map(|s| (edge_key(s.vertices), s.marker))
            .collect();
        EdgeLister {
            mesh,
            markers,
            segments,
        }
    }

    /// The edges triangle `t` lists (see [`Mesh::edges`]), by the corner they are opposite.
    pub(crate) fn edges_of(&self, t: usize) -> impl Iterator<Item = Edge> + '_ {
        let mesh = self.mesh;
        (0..3)
            .filter(move |&i| lists_edge(mesh, t, i))
            .map(move |i| {
                let vertices = opposite_edge(mesh.triangles[t], i);
                let across = mesh.neighbours[t][i];
                // A side with no triangle across that is not listed as a boundary edge only
                // happens in an invalid mesh; it is given the interior's marker.
                let listed = match across {
                    NONE => &self.markers,
                    _ => &self.segments,
                };
                let marker = listed.get(&edge_key(vertices)).copied().unwrap_or(0);
                Edge {
                    vertices,
                    triangles: [t as u32, across],
                    marker,
                }
            })
    }
}

impl Mesh {
    /// Every edge of the mesh once, with its triangles and marker (see [`Edge`]).
    ///
    /// The order is deterministic, that of Triangle's `.edge` file as
    /// [`write_edge`](crate::io::write_edge) writes it: by triangle, then by the corner the edge
    /// is opposite. An interior edge is listed with the lower-numbered of its two triangles,
    /// which is then `triangles[0]`, in that triangle's counter-clockwise direction; a boundary
    /// edge is listed with its only triangle, in the direction of its [`BoundaryEdge`].
    ///
    /// Built in parallel, in time linear in the mesh's size.
    pub fn edges(&self) -> Vec<Edge> {
        let lister = EdgeLister::new(self);
        (0..self.triangles.len())
            .into_par_iter()
            .flat_map_iter(|t| lister.edges_of(t))
            .collect()
    }

    /// The number of edges, `edges().len()`, counted without listing them. For a valid mesh of
    /// a rectangle it is `V + F - 1` (Euler's formula `V - E + F = 1` of a disc).
    pub fn edge_count(&self) -> usize {
        (0..self.triangles.len())
            .into_par_iter()
            .map(|t| edges_listed_with(self, t))
            .sum()
    }

    /// The boundary marker of each vertex: 0 for an interior vertex; for a vertex on the
    /// boundary, the marker of the boundary edge that starts at it (boundary edges run
    /// counter-clockwise around the domain). A vertex inside a side thus gets that side's
    /// marker, and a corner of the domain the marker of the side that leaves it
    /// counter-clockwise: the lower-left corner 1 (bottom), the lower-right 2 (right), the
    /// upper-right 3 (top), the upper-left 4 (left).
    ///
    /// Every vertex of a boundary edge starts one in a valid mesh; a vertex that only ends one
    /// gets that edge's marker.
    ///
    /// In a mesh of a planar straight-line graph (Triangle's convention), a vertex on a segment
    /// with a nonzero marker gets the first such marker in the order of [`Mesh::segments`]; the
    /// other vertices on the boundary get the boundary edge's marker as above, which is then 1.
    pub fn vertex_markers(&self) -> Vec<i32> {
        let mut markers = vec![0; self.vertices.len()];
        for s in &self.segments {
            for v in s.vertices {
                if markers[v as usize] == 0 {
                    markers[v as usize] = s.marker;
                }
            }
        }
        let on_segment: Vec<bool> = markers.iter().map(|&m| m != 0).collect();
        let ends = self.boundary.iter().map(|e| (e.vertices[1], e.marker));
        let starts = self.boundary.iter().map(|e| (e.vertices[0], e.marker));
        for (v, marker) in ends.chain(starts) {
            if !on_segment[v as usize] {
                markers[v as usize] = marker;
            }
        }
        markers
    }

    /// The marker of each of [`Mesh::segments`] in the output files (Triangle's convention):
    /// its segment's marker, or 1 for a subsegment on the boundary whose segment's marker is 0.
    pub fn segment_markers(&self) -> Vec<i32> {
        let boundary: HashSet<[u32; 2]> =
            self.boundary.iter().map(|e| edge_key(e.vertices)).collect();
        self.segments
            .iter()
            .map(|s| match s.marker {
                0 if boundary.contains(&edge_key(s.vertices)) => 1,
                marker => marker,
            })
            .collect()
    }

    /// The input index (0-based, in input order) of vertex `v`, or `None` for a Steiner vertex.
    ///
    /// # Panics
    /// If `v` is not a vertex of the mesh.
    pub fn input_index(&self, v: u32) -> Option<u32> {
        match self.vertex_input[v as usize] {
            NONE => None,
            i => Some(i),
        }
    }

    /// The triangles across the edges opposite the corners of triangle `t` (the edge from corner
    /// `i + 1` to corner `i + 2` for entry `i`), `None` on the boundary.
    ///
    /// # Panics
    /// If `t` is not a triangle of the mesh.
    pub fn triangle_neighbours(&self, t: u32) -> [Option<u32>; 3] {
        self.neighbours[t as usize].map(|n| (n != NONE).then_some(n))
    }
}

#[cfg(test)]
mod tests {
    use std::collections::{HashMap, HashSet};

    use glam::DVec2;

    use crate::domain::BoundaryEdge;
    use crate::refine::RefineDomain;

    use super::*;
    use crate::generate::{Distribution2d, points};
    use crate::mesh::fixtures::{neighbours_of, pslg_square, two_triangles};
    use crate::mesh::{AngleBounds, BoundarySide, Domain};
    use crate::refine::{RefineOptions, refine_points};
    use crate::warp::ANGLE_BOUNDS;
    use crate::{MeshOptions, mesh_points};

    /// The input points of a mesh whose input vertices are numbered 0 to k - 1.
    fn input_points(mesh: &Mesh) -> Vec<DVec2> {
        let inputs = mesh.vertex_input.iter().filter(|&&i| i != NONE).count();
        let mut points = vec![DVec2::NAN; inputs];
        for (v, &i) in mesh.vertex_input.iter().enumerate() {
            if i != NONE {
                points[i as usize] = mesh.vertices[v];
            }
        }
        points
    }

    /// The 3 by 3 grid of points `(i, j)` for `i, j` in `0..3`, vertex `3 j + i`, each of its four
    /// squares cut along the diagonal from its lower-left corner; all points are input points,
    /// numbered from the top row down.
    fn grid3() -> Mesh {
        let vertex = |i: u32, j: u32| 3 * j + i;
        let mut mesh = Mesh {
            domain: Domain {
                lo: DVec2::ZERO,
                hi: DVec2::splat(2.0),
            },
            ..Mesh::default()
        };
        for j in 0..3 {
            for i in 0..3 {
                mesh.vertices.push(DVec2::new(f64::from(i), f64::from(j)));
                mesh.vertex_input.push(3 * (2 - j) + i);
            }
        }
        for j in 0..2 {
            for i in 0..2 {
                let [a, b, c, d] = [
                    vertex(i, j),
                    vertex(i + 1, j),
                    vertex(i + 1, j + 1),
                    vertex(i, j + 1),
                ];
                mesh.triangles.push([a, b, c]);
                mesh.triangles.push([a, c, d]);
            }
        }
        mesh.neighbours = neighbours_of(&mesh.triangles);
        let sides = [
            (BoundarySide::Bottom, [[0, 0], [1, 0], [2, 0]]),
            (BoundarySide::Right, [[2, 0], [2, 1], [2, 2]]),
            (BoundarySide::Top, [[2, 2], [1, 2], [0, 2]]),
            (BoundarySide::Left, [[0, 2], [0, 1], [0, 0]]),
        ];
        for (side, path) in sides {
            for k in 0..2 {
                let [[i0, j0], [i1, j1]] = [path[k], path[k + 1]];
                mesh.boundary.push(BoundaryEdge {
                    vertices: [vertex(i0, j0), vertex(i1, j1)],
                    marker: side.marker(),
                });
            }
        }
        mesh
    }

    /// Checks every property of the topology of `mesh`, which must be a valid mesh of its
    /// rectangle.
    fn check_topology(mesh: &Mesh) {
        let edges = mesh.edges();
        assert_eq!(edges.len(), mesh.edge_count());
        // Euler's formula for a disc.
        let (v, f) = (mesh.vertices.len(), mesh.triangles.len());
        assert_eq!(v as i64 - edges.len() as i64 + f as i64, 1);

        let contains = |t: u32, ab: [u32; 2]| {
            (0..3).any(|i| opposite_edge(mesh.triangles[t as usize], i) == ab)
        };
        let mut pairs = HashSet::new();
        let mut boundary = HashMap::new();
        let mut half_edges = 0;
        let mut last_triangle = 0;
        for e in &edges {
            let [a, b] = e.vertices;
            assert!(pairs.insert([a.min(b), a.max(b)]), "{e:?} twice");
            let [t, across] = e.triangles;
            assert!(t >= last_triangle, "{e:?} out of order");
            last_triangle = t;
            assert!(contains(t, [a, b]), "{e:?}");
            if across == NONE {
                assert_ne!(e.marker, 0, "{e:?}");
                assert!(boundary.insert([a, b], e.marker).is_none());
                half_edges += 1;
            } else {
                assert!(t < across, "{e:?} listed with its higher triangle");
                assert!(contains(across, [b, a]), "{e:?}");
                assert_eq!(e.marker, 0, "{e:?}");
                half_edges += 2;
            }
        }
        assert_eq!(half_edges, 3 * f);
        let listed: HashMap<[u32; 2], i32> = mesh
            .boundary
            .iter()
            .map(|e| (e.vertices, e.marker))
            .collect();
        assert_eq!(listed.len(), mesh.boundary.len());
        assert_eq!(boundary, listed);

        let markers = mesh.vertex_markers();
        assert_eq!(markers.len(), v);
        let starts: HashMap<u32, i32> = mesh
            .boundary
            .iter()
            .map(|e| (e.vertices[0], e.marker))
            .collect();
        let on_boundary: HashSet<u32> = mesh.boundary.iter().flat_map(|e| e.vertices).collect();
        for (vertex, &marker) in markers.iter().enumerate() {
            let vertex = vertex as u32;
            assert_eq!(
                marker != 0,
                on_boundary.contains(&vertex),
                "vertex {vertex}"
            );
            if marker != 0 {
                assert_eq!(Some(&marker), starts.get(&vertex), "vertex {vertex}");
            }
        }

        for vertex in 0..v as u32 {
            let expected = mesh.vertex_input[vertex as usize];
            assert_eq!(mesh.input_index(vertex).unwrap_or(NONE), expected);
        }
        for t in 0..f as u32 {
            let expected = mesh.neighbours[t as usize];
            assert_eq!(
                mesh.triangle_neighbours(t).map(|n| n.unwrap_or(NONE)),
                expected
            );
        }
    }

    fn validated(mesh: Mesh, points: &[DVec2], bounds: AngleBounds) -> Mesh {
        mesh.validate(points, bounds).unwrap();
        mesh
    }

    /// The edge with these fields, as [`Mesh::edges`] lists it.
    fn edge(vertices: [u32; 2], triangles: [u32; 2], marker: i32) -> Edge {
        Edge {
            vertices,
            triangles,
            marker,
        }
    }

    const RIGHT_ISOSCELES: AngleBounds = AngleBounds {
        min_deg: 45.0,
        max_deg: 90.0,
    };

    #[test]
    fn edges_of_two_triangles() {
        let mesh = two_triangles();
        let mesh = validated(mesh.clone(), &input_points(&mesh), RIGHT_ISOSCELES);
        assert_eq!(
            mesh.edges(),
            [
                edge([1, 2], [0, NONE], 2),
                edge([2, 0], [0, 1], 0),
                edge([0, 1], [0, NONE], 1),
                edge([2, 3], [1, NONE], 3),
                edge([3, 0], [1, NONE], 4),
            ]
        );
        assert_eq!(mesh.edge_count(), 5);
        assert_eq!(mesh.vertex_markers(), [1, 2, 3, 4]);
        assert_eq!(
            [0, 1, 2, 3].map(|v| mesh.input_index(v)),
            [Some(0), Some(2), Some(1), None]
        );
        assert_eq!(mesh.triangle_neighbours(0), [None, Some(1), None]);
        assert_eq!(mesh.triangle_neighbours(1), [None, None, Some(0)]);
        check_topology(&mesh);
    }

    #[test]
    fn edges_of_a_grid() {
        let mesh = grid3();
        let mesh = validated(mesh.clone(), &input_points(&mesh), RIGHT_ISOSCELES);
        assert_eq!(mesh.edge_count(), 16);
        let interior = mesh.edges().iter().filter(|e| e.marker == 0).count();
        assert_eq!(interior, 8);
        // Corners take the side that leaves them counter-clockwise; the centre is interior.
        assert_eq!(mesh.vertex_markers(), [1, 1, 2, 4, 0, 2, 4, 3, 3]);
        check_topology(&mesh);
    }

    #[test]
    fn segments_carry_their_markers_to_edges_and_vertices() {
        let mesh = pslg_square();
        // Interior edges on segments keep their markers, 0 included; boundary edges carry
        // their boundary markers.
        assert_eq!(
            mesh.edges(),
            [
                edge([1, 4], [0, 1], 0),
                edge([4, 0], [0, 3], -3),
                edge([0, 1], [0, NONE], 5),
                edge([2, 4], [1, 2], -3),
                edge([1, 2], [1, NONE], 1),
                edge([3, 4], [2, 3], 0),
                edge([2, 3], [2, NONE], 1),
                edge([3, 0], [3, NONE], 1),
            ]
        );
        // The first nonzero segment marker; 1 on the boundary off such segments.
        assert_eq!(mesh.vertex_markers(), [5, 5, -3, 1, -3]);
        // The right side's marker 0 becomes 1 on the boundary; the interior piece keeps 0.
        assert_eq!(mesh.segment_markers(), [5, 1, -3, -3, 0]);
        assert!(two_triangles().segment_markers().is_empty());
    }

    #[test]
    fn empty_mesh_has_no_edges() {
        let mesh = Mesh::default();
        assert!(mesh.edges().is_empty());
        assert_eq!(mesh.edge_count(), 0);
        assert!(mesh.vertex_markers().is_empty());
    }

    #[test]
    fn edges_of_refined_meshes() {
        let points = points(Distribution2d::Uniform, 1000, 7);
        let bounds = AngleBounds {
            min_deg: 30.0,
            max_deg: 120.0,
        };
        let domain = Domain {
            lo: DVec2::new(-0.5, 0.0),
            hi: DVec2::new(1.0, 1.25),
        };
        for domain in [RefineDomain::Square, RefineDomain::Rectangle(domain)] {
            let options = RefineOptions {
                domain,
                min_angle_deg: 30.0,
                ..RefineOptions::default()
            };
            let (mesh, _) = refine_points(&points, &options).unwrap();
            let mesh = validated(mesh, &points, bounds);
            check_topology(&mesh);
        }
    }

    #[test]
    fn edges_of_warped_meshes() {
        let points = points(Distribution2d::Cluster, 1000, 11);
        let bounds = AngleBounds {
            min_deg: ANGLE_BOUNDS.0,
            max_deg: ANGLE_BOUNDS.1,
        };
        // The second domain is taller than wide, which the mesher meshes in a mirror image.
        let domain = Domain {
            lo: DVec2::new(-0.25, -1.0),
            hi: DVec2::new(1.25, 2.0),
        };
        for domain in [None, Some(domain)] {
            let options = MeshOptions {
                domain,
                ..MeshOptions::default()
            };
            let (mesh, _) = mesh_points(&points, &options).unwrap();
            let mesh = validated(mesh, &points, bounds);
            check_topology(&mesh);
        }
    }

    #[test]
    fn edges_do_not_depend_on_the_thread_count() {
        let points = points(Distribution2d::Uniform, 3000, 5);
        let (mesh, _) = mesh_points(&points, &MeshOptions::default()).unwrap();
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        assert_eq!(one.install(|| mesh.edges()), mesh.edges());
    }
}
