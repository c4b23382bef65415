//! Delaunay refinement of a graph's mesh made by another method (the warped quadtree mesh):
//! where a triangle is below the angle bound, the edges are flipped to constrained Delaunay,
//! the triangles below the bound fixed by off-centers and wall splits as in
//! [`super::refine_pslg`], and edges flipped back where that lowers a largest angle. A mesh
//! with no triangle below the bound is left as it is.
//!
//! A Lawson flip never lowers the smallest of the six angles it replaces, so the flips keep
//! every triangle that met the bound at it or above; they end in the constrained Delaunay
//! triangulation of the mesh's vertices and walls, which the refinement needs (its cavities
//! are Delaunay). Refinement treats the mesh's vertices as input points: the termination
//! proof of Ruppert's refinement, with Shewchuk's rule at corners between segments narrower
//! than the bound, holds for bounds up to [`super::GUARANTEED_MIN_ANGLE_DEG`], and every
//! triangle whose smallest angle is θ has no angle above 180° − 2θ.

use glam::DVec2;
use rayon::prelude::*;

use super::delaunay::{NEXT, PREV, SEGMENT, Triangulation, in_circumcircle, is_wall};
use super::improve::smallest_sine2;
use super::refiner::{Bounds, Finish, Refiner, Work, inspect_all};
use super::{RefineOptions, Unfinished, segments, unmet_triangles};
use crate::error::Error;
use crate::mesh::{Domain, Mesh, NONE, corner_cosines};
use crate::morton::bounding_box;
use crate::options::Input;
use crate::predicates::{Orientation, orientation};

/// What [`refine_graph_mesh`] did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct Finished {
    /// Triangles below the bound before the flips.
    pub bad_before: usize,
    /// Vertices refinement added.
    pub added: usize,
    /// Flips that lowered a largest angle after refinement.
    pub flipped_back: usize,
}

/// Refines `mesh`, a triangulation of the cleaned graph `clean` whose segment pieces name
/// `clean`'s segments, until every angle is at least `min_angle_deg` (at most
/// [`super::GUARANTEED_MIN_ANGLE_DEG`] for the proof to hold) outside corners between
/// segments narrower than that, or until `max_vertices` vertices. Input points, regions,
/// holes and markers are kept; new vertices on a segment piece split it.
///
/// Where the budget or f64's resolution stops it, the mesh reached is kept and the
/// [`Unfinished`] returned says where and why.
///
/// # Errors
/// [`Error::InvalidOption`] for a bound out of range.
pub(crate) fn refine_graph_mesh(
    mesh: &mut Mesh,
    clean: &Input,
    min_angle_deg: f64,
    max_vertices: usize,
) -> Result<(Finished, Option<Unfinished>), Error> {
    let options = RefineOptions {
        min_angle_deg,
        ..RefineOptions::default()
    };
    options.check()?;
    let by_ends = wall_segments(mesh);
    let mut t = triangulation_of(mesh, &by_ends);
    let walls = segments::walls_of(&t, by_ends, min_angle_deg);
    let (lo, hi) = bounding_box(&t.vertices);
    let no_region_areas = vec![None; mesh.region_attributes.len()];
    let bounds = Bounds::new(&options, lo, hi).with_walls(walls, &no_region_areas, true);
    let bad_before = inspect_all(&t, &bounds).0.len();
    if bad_before == 0 {
        // Nothing to refine: the flips would only trade some of the mesh's largest angles.
        return Ok((Finished::default(), None));
    }
    let not_delaunay = edges_where(&t, |t, (id, _), (u, j)| {
        in_circumcircle(t, id, t.vertices[t.corners[u as usize][j] as usize])
    });
    t.flip_to_delaunay(not_delaunay);
    let (bad, edges) = inspect_all(&t, &bounds);
    let first_added = t.vertices.len();
    let mut work = Work::new();
    work.queue_all(&bad, &edges);
    let budget = max_vertices.max(first_added);
    // Stopped where f64 cannot place a vertex, the triangulation is whole all the same.
    let unresolved = match Refiner::new(&mut t, &mut work, &bounds, budget).run() {
        Ok(Finish::Done) => None,
        Ok(Finish::OutOfBudget) => Some(None),
        Err(Error::RefinementResolution { x, y, .. }) => Some(Some(DVec2::new(x, y))),
        Err(e) => return Err(e),
    };
    let unfinished = unresolved.map(|unresolved| Unfinished {
        unmet: unmet_triangles(&t, &bounds),
        unresolved,
    });
    t.pack();
    let finished = Finished {
        bad_before,
        added: t.vertices.len() - first_added,
        flipped_back: lower_largest_angles(&mut t, &bounds),
    };
    let walls = bounds.walls().expect("a graph's bounds have walls");
    let (pieces, boundary) = segments::segment_pieces(&t, walls, clean);
    let mut vertex_input = std::mem::take(&mut mesh.vertex_input);
    vertex_input.resize(t.vertices.len(), NONE);
    let regions = std::mem::take(&mut t.regions);
    let domain = Domain { lo, hi };
    let mut refined = super::into_mesh(t, vertex_input, domain, super::Boundary::Graph(boundary));
    refined.segments = pieces;
    refined.triangle_regions = regions;
    refined.region_attributes = std::mem::take(&mut mesh.region_attributes);
    refined.holes = std::mem::take(&mut mesh.holes);
    *mesh = refined;
    Ok((finished, unfinished))
}

/// Flips edges where the larger of the two triangles' largest angles drops by more than
/// rounding and both new triangles meet the bound firmly, until none does: the Delaunay flips
/// maximize the smallest angles and can open the largest ones (from 120.0° to 136.4° on
/// rings of 20 000 segments); these flips take most of that back (130.6°) and keep the bound. Each flip lowers the largest
/// angle of the pair it replaces, so the flips end. Returns their number.
fn lower_largest_angles(t: &mut Triangulation, bounds: &Bounds) -> usize {
    let mut edges = edges_where(t, |t, side, far| lowers_largest_angle(t, bounds, side, far));
    edges.reverse();
    let mut flips = 0;
    while let Some((a_side, i)) = edges.pop() {
        let link = t.across[a_side as usize][i];
        if is_wall(link) {
            continue;
        }
        let j = t.corner_facing(link, a_side);
        if !lowers_largest_angle(t, bounds, (a_side, i), (link, j)) {
            continue;
        }
        t.flip(a_side, i, link, j);
        flips += 1;
        edges.extend([(a_side, 0), (a_side, 2), (link, 0), (link, 2)]);
    }
    flips
}

/// The edges across which `test` holds, as `(triangle, corner)` in triangle order, found in
/// parallel: `test` gets the triangulation, the edge and the far apex (`(triangle, corner)`).
/// Walls are left out.
fn edges_where(
    t: &Triangulation,
    test: impl Fn(&Triangulation, (u32, usize), (u32, usize)) -> bool + Sync,
) -> Vec<(u32, usize)> {
    (0..t.len() as u32)
        .into_par_iter()
        .flat_map_iter(|id| {
            let test = &test;
            (0..3).filter_map(move |i| {
                let u = t.across[id as usize][i];
                if is_wall(u) {
                    return None;
                }
                let j = t.corner_facing(u, id);
                test(t, (id, i), (u, j)).then_some((id, i))
            })
        })
        .collect()
}

/// Whether flipping the edge opposite corner `i` of triangle `t` (the far apex at corner `j`
/// of `u`) makes two counter-clockwise triangles that meet the bound firmly and whose largest
/// angle is smaller than the pair's now.
fn lowers_largest_angle(
    t: &Triangulation,
    bounds: &Bounds,
    (t0, i): (u32, usize),
    (u0, j): (u32, usize),
) -> bool {
    let at = |v: u32| t.vertices[v as usize];
    let c = t.corners[t0 as usize];
    let [a, b, cc] = [c[i], c[NEXT[i]], c[PREV[i]]].map(at);
    let w = at(t.corners[u0 as usize][j]);
    if orientation(a, b, w) != Orientation::Left || orientation(w, cc, a) != Orientation::Left {
        return false;
    }
    let before = smallest_cosine(a, b, cc).min(smallest_cosine(w, cc, b));
    let after = smallest_cosine(a, b, w).min(smallest_cosine(w, cc, a));
    let firm = bounds.sin2 * (1.0 + 1e-9);
    after > before + 1e-12 && smallest_sine2(a, b, w) >= firm && smallest_sine2(w, cc, a) >= firm
}

/// The cosine of the largest angle of triangle `a b c`.
fn smallest_cosine(a: DVec2, b: DVec2, c: DVec2) -> f64 {
    corner_cosines(a, b, c)
        .into_iter()
        .fold(f64::INFINITY, f64::min)
}

/// The mesh as a triangulation whose links across its segment pieces (`by_ends`, sorted)
/// carry the wall mark (links across the boundary are [`NONE`], which has it).
fn triangulation_of(mesh: &Mesh, by_ends: &[((u32, u32), u32)]) -> Triangulation {
    let across = mesh
        .triangles
        .par_iter()
        .zip(&mesh.neighbours)
        .map(|(c, n)| {
            let mut links = *n;
            for (i, link) in links.iter_mut().enumerate() {
                let ends = ordered(c[NEXT[i]], c[PREV[i]]);
                if *link != NONE && by_ends.binary_search_by_key(&ends, |e| e.0).is_ok() {
                    *link |= SEGMENT;
                }
            }
            links
        })
        .collect();
    let mut t = Triangulation::rectangle(DVec2::ZERO, DVec2::ONE);
    t.vertices = mesh.vertices.clone();
    t.corners = mesh.triangles.clone();
    t.across = across;
    t.regions = mesh.triangle_regions.clone();
    t.segment_of = vec![NONE; t.vertices.len()];
    // A Steiner vertex of a piece lies inside its segment: Shewchuk's rule at narrow corners
    // reads which segment.
    for s in &mesh.segments {
        for v in s.vertices {
            if mesh.vertex_input[v as usize] == NONE {
                t.segment_of[v as usize] = s.segment;
            }
        }
    }
    t
}

/// Each segment piece's ends, the smaller first, with its segment, sorted.
fn wall_segments(mesh: &Mesh) -> Vec<((u32, u32), u32)> {
    let mut by_ends: Vec<_> = mesh
        .segments
        .par_iter()
        .map(|s| (ordered(s.vertices[0], s.vertices[1]), s.segment))
        .collect();
    by_ends.par_sort_unstable();
    by_ends
}

fn ordered(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::fixtures::mesh_of;
    use crate::mesh::{AngleBounds, SubSegment, validate_pslg};
    use crate::options::Segment;

    /// The square [0, 1]² as a graph of its four sides (markers 1 to 4), meshed as a fan from a
    /// Steiner vertex a fiftieth above the middle of its bottom side: the bottom triangle has
    /// two angles of 2.3°.
    fn flat_fan() -> (Mesh, Input) {
        let corners = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)].map(DVec2::from);
        let mut vertices = corners.to_vec();
        vertices.push(DVec2::new(0.5, 0.02));
        let triangles = vec![[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]];
        let mut mesh = mesh_of(vertices, &[0, 1, 2, 3], triangles);
        mesh.segments = (0..4)
            .map(|k| SubSegment {
                vertices: [k, (k + 1) % 4],
                segment: k,
                marker: k as i32 + 1,
            })
            .collect();
        let input = Input {
            points: corners.to_vec(),
            segments: (0..4)
                .map(|k| Segment {
                    ends: [k, (k + 1) % 4],
                    marker: k as i32 + 1,
                })
                .collect(),
            ..Input::default()
        };
        (mesh, input)
    }

    const BOUNDS: AngleBounds = AngleBounds {
        min_deg: 20.0,
        max_deg: 140.0,
    };

    #[test]
    fn slivers_are_refined_to_the_bound_and_the_graph_kept() {
        let (mut mesh, input) = flat_fan();
        let (finished, unfinished) = refine_graph_mesh(&mut mesh, &input, 20.0, 10_000).unwrap();
        assert!(unfinished.is_none());
        assert!(
            finished.bad_before >= 1 && finished.added > 0,
            "{finished:?}"
        );
        validate_pslg(&mesh, &input, BOUNDS).unwrap_or_else(|e| panic!("{e}"));
        let markers: Vec<i32> = mesh.segments.iter().map(|s| s.marker).collect();
        assert!(markers.is_sorted() && markers.len() > 4, "{markers:?}");
    }

    #[test]
    fn the_vertex_budget_stops_it_with_the_triangles_left_named() {
        let (mut mesh, input) = flat_fan();
        let (_, unfinished) = refine_graph_mesh(&mut mesh, &input, 20.0, 5).unwrap();
        let unmet = unfinished.expect("stopped at the budget").unmet;
        assert!(!unmet.is_empty() && unmet.iter().all(|u| u.min_angle < 20.0));
        let any = AngleBounds {
            min_deg: 0.0,
            max_deg: 180.0,
        };
        validate_pslg(&mesh, &input, any).unwrap_or_else(|e| panic!("{e}"));
    }

    #[test]
    fn a_mesh_meeting_the_bound_is_left_as_it_is() {
        let (mut fan, input) = flat_fan();
        refine_graph_mesh(&mut fan, &input, 20.0, 10_000).unwrap();
        let once = fan.clone();
        let (finished, _) = refine_graph_mesh(&mut fan, &input, 20.0, 10_000).unwrap();
        assert_eq!(finished, Finished::default());
        assert_eq!(fan, once);
        validate_pslg(&fan, &input, BOUNDS).unwrap_or_else(|e| panic!("{e}"));
    }
}
