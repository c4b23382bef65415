//! The exact Delaunay check for meshes that claim to be Delaunay (the refinement mode's).
//!
//! A triangulation is Delaunay when every interior edge is locally Delaunay: the vertex of the
//! neighbour opposite the edge is not strictly inside the triangle's circumcircle. Each edge is
//! decided once, from its lower-numbered triangle (the in-circle sign of the four points is the
//! same seen from either side), with the exact in-circle predicate, so cocircular
//! vertices pass whichever diagonal the mesh chose. Runs in parallel, O(n), and reports the
//! lowest-indexed fault. In a mesh of a planar straight-line graph the edges on segments are
//! exempt: the mesh is constrained Delaunay.

use std::collections::HashSet;

use glam::DVec2;

use super::validate::{InvalidMesh, MeshCheck, fault, first_fault, pt};
use super::{Mesh, NONE};
use crate::predicates::in_circle_value;

/// Checks that every interior edge of `mesh` is locally Delaunay, which makes the whole mesh
/// Delaunay; returns the first fault found.
///
/// Expects a mesh that passes [`super::validate`]; on one that does not, it reports broken
/// indices or neighbour links it meets instead of panicking.
///
/// # Errors
/// [`InvalidMesh`] with [`MeshCheck::Delaunay`] and the first fault.
pub fn check_delaunay(mesh: &Mesh) -> Result<(), InvalidMesh> {
    if mesh.neighbours.len() != mesh.triangles.len() {
        return Err(InvalidMesh {
            check: MeshCheck::Delaunay,
            message: format!(
                "neighbours has {} entries for {} triangles",
                mesh.neighbours.len(),
                mesh.triangles.len()
            ),
        });
    }
    let walls: HashSet<(u32, u32)> = mesh
        .segments
        .iter()
        .map(|s| {
            let [a, b] = s.vertices;
            (a.min(b), a.max(b))
        })
        .collect();
    first_fault(mesh.triangles.len(), |t| {
        (0..3).find_map(|i| {
            let tri = mesh.triangles[t];
            let (a, b) = (tri[(i + 1) % 3], tri[(i + 2) % 3]);
            if walls.contains(&(a.min(b), a.max(b))) {
                return None;
            }
            edge_fault(mesh, t, i)
        })
    })
    .map_err(fault(MeshCheck::Delaunay))
}

impl Mesh {
    /// Checks that the mesh is Delaunay, exactly; see [`check_delaunay`].
    ///
    /// # Errors
    /// [`InvalidMesh`] with [`MeshCheck::Delaunay`].
    pub fn check_delaunay(&self) -> Result<(), InvalidMesh> {
        check_delaunay(self)
    }
}

/// The fault, if any, of the edge opposite corner `i` of triangle `t`, when `t` is the
/// lower-numbered of its two triangles.
fn edge_fault(mesh: &Mesh, t: usize, i: usize) -> Option<String> {
    let u = mesh.neighbours[t][i];
    if u == NONE || (u as usize) < t {
        return None;
    }
    let tri = mesh.triangles[t];
    let Some(&other) = mesh.triangles.get(u as usize) else {
        return Some(format!(
            "triangle {t}: neighbour {u} opposite corner {i} is out of range"
        ));
    };
    let (a, b) = (tri[(i + 1) % 3], tri[(i + 2) % 3]);
    // The neighbour runs the shared edge the other way, b -> a; its third corner is opposite.
    let Some(j) = (0..3).find(|&j| other[(j + 1) % 3] == b && other[(j + 2) % 3] == a) else {
        return Some(format!(
            "triangle {t} {tri:?}: neighbour {u} {other:?} opposite corner {i} does not have \
             the edge {b}->{a}"
        ));
    };
    let v = other[j];
    let [pa, pb, pc, pd] = [tri[0], tri[1], tri[2], v].map(|k| vertex(mesh, k));
    let det = in_circle_value(pa?, pb?, pc?, pd?);
    (det > 0.0).then(|| {
        let [a, b, c, d] = [tri[0], tri[1], tri[2], v].map(|k| pt(mesh.vertices[k as usize]));
        format!(
            "triangle {t} {tri:?} at {a} {b} {c} is not Delaunay: vertex {v} at {d} of its \
             neighbour {u} (across the edge opposite corner {i}) lies strictly inside its \
             circumcircle (incircle {det:e})"
        )
    })
}

/// Vertex `k`'s coordinates for the predicate, `None` when `k` is out of range (then
/// [`edge_fault`] reports nothing and leaves the index to `validate`).
fn vertex(mesh: &Mesh, k: u32) -> Option<DVec2> {
    mesh.vertices.get(k as usize).copied()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{AngleBounds, BoundaryEdge, BoundarySide, Domain};

    const ANY: AngleBounds = AngleBounds {
        min_deg: 0.0,
        max_deg: 180.0,
    };

    /// The convex quadrilateral `q` (counter-clockwise) split along the diagonal from corner 0 to
    /// corner 2 (`rising`) or from corner 1 to corner 3. Its domain is the unit square, right
    /// only when `q` is that square; the Delaunay check does not look at it.
    fn quad(q: [DVec2; 4], rising: bool) -> Mesh {
        let (triangles, neighbours) = if rising {
            (
                vec![[0, 1, 2], [0, 2, 3]],
                vec![[NONE, 1, NONE], [NONE, NONE, 0]],
            )
        } else {
            (
                vec![[1, 2, 3], [1, 3, 0]],
                vec![[NONE, 1, NONE], [NONE, NONE, 0]],
            )
        };
        let side = [
            BoundarySide::Bottom,
            BoundarySide::Right,
            BoundarySide::Top,
            BoundarySide::Left,
        ];
        Mesh {
            outline: None,
            vertices: q.to_vec(),
            vertex_input: vec![0, 1, 2, 3],
            triangles,
            neighbours,
            boundary: (0..4)
                .map(|k| BoundaryEdge {
                    vertices: [k as u32, (k as u32 + 1) % 4],
                    marker: side[k].marker(),
                })
                .collect(),
            domain: Domain {
                lo: DVec2::ZERO,
                hi: DVec2::ONE,
            },
            ..Mesh::default()
        }
    }

    /// A convex quadrilateral whose corner 2 lies outside the circle through the other three,
    /// so only the diagonal 1-3 is Delaunay.
    fn kite() -> [DVec2; 4] {
        [
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(1.5, 1.5),
            DVec2::new(0.0, 1.0),
        ]
    }

    #[test]
    fn wrong_diagonal_fails_and_names_the_vertex() {
        let err = quad(kite(), true)
            .check_delaunay()
            .expect_err("not Delaunay");
        for w in ["triangle 0 [0, 1, 2]", "vertex 3 at (0, 1)", "neighbour 1"] {
            assert!(err.message.contains(w), "{err:?} should mention {w:?}");
        }
    }

    #[test]
    fn right_diagonal_passes() {
        assert_eq!(quad(kite(), false).check_delaunay(), Ok(()));
    }

    #[test]
    fn cocircular_passes_either_way() {
        let square = [
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(1.0, 1.0),
            DVec2::new(0.0, 1.0),
        ];
        for rising in [true, false] {
            let mesh = quad(square, rising);
            assert_eq!(mesh.validate(&square, ANY), Ok(()));
            assert_eq!(mesh.check_delaunay(), Ok(()));
        }
        // Four integer points on x² + y² = 25: exactly cocircular, a sign test in plain f64
        // could go either way.
        let circle = [
            DVec2::new(5.0, 0.0),
            DVec2::new(3.0, 4.0),
            DVec2::new(-4.0, 3.0),
            DVec2::new(0.0, -5.0),
        ];
        for rising in [true, false] {
            assert_eq!(quad(circle, rising).check_delaunay(), Ok(()));
        }
    }

    #[test]
    fn one_ulp_inside_the_circle_decides() {
        // Corner 2 moved one ulp towards the centre: now only the diagonal 0-2 is Delaunay, and
        // across 1-3 it is corner 0 that lies inside the circle through 1, 2, 3.
        let mut q = [
            DVec2::new(5.0, 0.0),
            DVec2::new(3.0, 4.0),
            DVec2::new(-4.0, 3.0),
            DVec2::new(0.0, -5.0),
        ];
        q[2].x = f64::from_bits(q[2].x.to_bits() - 1);
        assert!(q[2].x > -4.0);
        assert_eq!(quad(q, true).check_delaunay(), Ok(()));
        let err = quad(q, false).check_delaunay().expect_err("not Delaunay");
        assert!(err.message.contains("vertex 0 at (5, 0)"), "{err}");
    }

    #[test]
    fn broken_links_are_reported_not_panicked_on() {
        let mut mesh = quad(kite(), false);
        mesh.neighbours[0][1] = 7;
        let err = mesh.check_delaunay().expect_err("out of range");
        assert!(err.message.contains("neighbour 7"), "{err}");
        let mut mesh = quad(kite(), false);
        mesh.triangles[1] = [1, 0, 3];
        let err = mesh.check_delaunay().expect_err("edge missing");
        assert!(err.message.contains("does not have the edge"), "{err}");
    }
}
