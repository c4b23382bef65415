//! The Steiner vertices of a graph's warped mesh moved to widen the poorest angles around them.
//!
//! Bending leaves onto a graph leaves thin triangles where a row of grid vertices stays just
//! beyond an edge's reach, or where a vertex took a corner half a leaf away. Most of them have a
//! corner that is no input point: a grid vertex, which may move anywhere inside its ring of
//! neighbours, or a vertex splitting a segment, which may slide along the segment between its
//! neighbours on it. Neither changes a segment, the boundary or a region. Each such corner of a
//! poor triangle (an angle below [`SMOOTH_BELOW_DEG`] or above [`SMOOTH_ABOVE_DEG`]) looks for
//! the place that makes the smallest angle of its triangles largest, then their largest angle
//! smallest, by a pattern search in shrinking steps; a place is taken only when it is better and
//! every triangle of the ring stays counter-clockwise by the exact test.
//!
//! Vertices move in rounds: in each, a vertex moves only when it goes before every neighbour
//! that also wants to move (a smaller smallest angle in whole degrees, then a higher lot drawn
//! by hashing its index with the round), so the vertices moving together share no triangle,
//! the poorest rings go first without long chains of neighbours waiting on one another, and the
//! result is the same on any thread count. A move must gain at least [`MIN_GAIN_DEG`].

use glam::DVec2;
use rayon::prelude::*;

use crate::mesh::{Mesh, NONE, Star, corner_cosines};
use crate::predicates::{Orientation, orientation};
use crate::warp::lot;

/// A triangle with an angle below this many degrees has its Steiner corners moved.
pub const SMOOTH_BELOW_DEG: f64 = 26.0;

/// A triangle with an angle above this many degrees has its Steiner corners moved.
pub const SMOOTH_ABOVE_DEG: f64 = 120.0;

/// The least gain in degrees, on a ring's smallest angle or its largest, that moves a vertex.
const MIN_GAIN_DEG: f64 = 0.05;

/// The most rounds of moves.
const MAX_ROUNDS: usize = 32;

/// The pattern search's steps, as fractions of the distance from the vertex to its nearest
/// neighbour.
const STEPS: [f64; 5] = [0.3, 0.15, 0.07, 0.03, 0.012];

/// How many directions the pattern search tries at each step off a segment.
const DIRECTIONS: usize = 8;

/// What the smoothing did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Smoothed {
    /// Moves made (a vertex moved in two rounds counts twice).
    pub moves: usize,
    /// Rounds run.
    pub rounds: usize,
}

/// Moves the Steiner vertices of `mesh`'s poor triangles (see the module's description): the
/// triangles, segments, boundary and regions stay as they are. `segment_ends[s]`: the ends of
/// the segment that the mesh's pieces numbered `s` lie on.
pub fn smooth_steiner_vertices(mesh: &mut Mesh, segment_ends: &[[DVec2; 2]]) -> Smoothed {
    let motions = motions(mesh);
    let poor = Quality::poor();
    let mut wanting = corners_of_poor_triangles(mesh, &motions, poor);
    let mut smoothed = Smoothed::default();
    // Per vertex, its order in this round while it wants to move (never 0), else 0, for its
    // neighbours to see.
    let mut want = vec![0; mesh.vertices.len()];
    while !wanting.is_empty() && smoothed.rounds < MAX_ROUNDS {
        smoothed.rounds += 1;
        let rings: Vec<Ring> = wanting
            .par_iter()
            .filter_map(|&(v, t)| Ring::around(mesh, v, t))
            .collect();
        for ring in &rings {
            want[ring.star.centre as usize] = ring.order(smoothed.rounds);
        }
        let turns: Vec<Turn> = rings
            .par_iter()
            .map(|ring| match ring.goes_first(&want) {
                false => Turn::Waits,
                true => match best_place(
                    &mesh.vertices,
                    ring,
                    motions[ring.star.centre as usize],
                    segment_ends,
                ) {
                    Some(at) => Turn::Moves(at),
                    None => Turn::Stays,
                },
            })
            .collect();
        for ring in &rings {
            want[ring.star.centre as usize] = 0;
        }
        let mut moves = 0;
        for (ring, turn) in rings.iter().zip(&turns) {
            if let Turn::Moves(at) = *turn {
                mesh.vertices[ring.star.centre as usize] = at;
                moves += 1;
            }
        }
        if moves == 0 {
            break;
        }
        smoothed.moves += moves;
        wanting = next_wanting(mesh, (&motions, poor), &rings, &turns);
    }
    smoothed
}

/// How a vertex may move.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Motion {
    /// Not at all: an input point, an end of a segment's piece on two segments, or an end of
    /// a boundary edge on no segment.
    Fixed,
    /// Anywhere inside its ring: a grid vertex on no segment.
    Free,
    /// Along the segment it splits (an index into the segments' ends).
    Slides(u32),
}

/// How each vertex of `mesh` may move.
fn motions(mesh: &Mesh) -> Vec<Motion> {
    let mut motions: Vec<Motion> = mesh
        .vertex_input
        .par_iter()
        .map(|&i| match i {
            NONE => Motion::Free,
            _ => Motion::Fixed,
        })
        .collect();
    // How many pieces end at each vertex, and on which segment.
    let mut ends: Vec<(u8, u32)> = vec![(0, NONE); mesh.vertices.len()];
    for piece in &mesh.segments {
        for v in piece.vertices {
            let (count, segment) = &mut ends[v as usize];
            if *count > 0 && *segment != piece.segment {
                *count = u8::MAX;
            }
            *count = count.saturating_add(1);
            *segment = piece.segment;
        }
    }
    for (v, &(count, segment)) in ends.iter().enumerate() {
        motions[v] = match (motions[v], count) {
            (_, 0) | (Motion::Fixed, _) => motions[v],
            (_, 2) => Motion::Slides(segment),
            _ => Motion::Fixed,
        };
    }
    for edge in &mesh.boundary {
        for v in edge.vertices {
            if motions[v as usize] == Motion::Free {
                motions[v as usize] = Motion::Fixed;
            }
        }
    }
    motions
}

/// The quality of a set of triangles: the cosine of its smallest angle (smaller is better),
/// then of its largest (larger is better).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Quality {
    narrowest: f64,
    widest: f64,
}

impl Quality {
    const BEST: Quality = Quality {
        narrowest: f64::NEG_INFINITY,
        widest: f64::INFINITY,
    };

    const WORST: Quality = Quality {
        narrowest: f64::INFINITY,
        widest: f64::NEG_INFINITY,
    };

    fn of_triangle(a: DVec2, b: DVec2, c: DVec2) -> Quality {
        let cosines = corner_cosines(a, b, c);
        Quality {
            narrowest: cosines.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            widest: cosines.iter().copied().fold(f64::INFINITY, f64::min),
        }
    }

    fn and(self, other: Quality) -> Quality {
        Quality {
            narrowest: self.narrowest.max(other.narrowest),
            widest: self.widest.min(other.widest),
        }
    }

    fn beats(self, other: Quality) -> bool {
        self.narrowest < other.narrowest
            || (self.narrowest == other.narrowest && self.widest > other.widest)
    }

    /// Whether `self` beats `other` by at least [`MIN_GAIN_DEG`] on the smallest angle, or on
    /// the largest with the same smallest: smaller gains are not worth another round.
    fn gains_on(self, other: Quality) -> bool {
        let gain = |a: f64, b: f64| a.clamp(-1.0, 1.0).acos() - b.clamp(-1.0, 1.0).acos();
        let min_gain = MIN_GAIN_DEG.to_radians();
        gain(self.narrowest, other.narrowest) >= min_gain
            || (self.narrowest <= other.narrowest && gain(other.widest, self.widest) >= min_gain)
    }

    /// The quality of a triangle whose angles are exactly [`SMOOTH_BELOW_DEG`] and
    /// [`SMOOTH_ABOVE_DEG`]: one worse is poor.
    fn poor() -> Quality {
        Quality {
            narrowest: SMOOTH_BELOW_DEG.to_radians().cos(),
            widest: SMOOTH_ABOVE_DEG.to_radians().cos(),
        }
    }
}

/// Whether the triangle with corners `corners` has an angle narrower or wider than `poor`'s.
fn is_poor(mesh: &Mesh, corners: [u32; 3], poor: Quality) -> bool {
    let [a, b, c] = corners.map(|v| mesh.vertices[v as usize]);
    let quality = Quality::of_triangle(a, b, c);
    quality.narrowest > poor.narrowest || quality.widest < poor.widest
}

/// The movable corners of the poor triangles, each once in index order with one of its
/// triangles.
fn corners_of_poor_triangles(mesh: &Mesh, motions: &[Motion], poor: Quality) -> Vec<(u32, u32)> {
    let mut corners: Vec<(u32, u32)> = (0..mesh.triangles.len())
        .into_par_iter()
        .filter(|&t| is_poor(mesh, mesh.triangles[t], poor))
        .flat_map_iter(|t| mesh.triangles[t].map(|v| (v, t as u32)))
        .filter(|&(v, _)| motions[v as usize] != Motion::Fixed)
        .collect();
    corners.par_sort_unstable();
    corners.dedup_by_key(|&mut (v, _)| v);
    corners
}

/// The vertices that want to move next: those that waited, and the movable corners of the
/// poor triangles around the vertices that moved (themselves included).
fn next_wanting(
    mesh: &Mesh,
    (motions, poor): (&[Motion], Quality),
    rings: &[Ring],
    turns: &[Turn],
) -> Vec<(u32, u32)> {
    let mut next: Vec<(u32, u32)> = Vec::new();
    for (ring, turn) in rings.iter().zip(turns) {
        match turn {
            Turn::Waits => next.push((ring.star.centre, ring.star.triangles[0])),
            // Its neighbours stood still while it searched: none of them went first.
            Turn::Stays => {}
            Turn::Moves(_) => {
                for &t in &ring.star.triangles {
                    let corners = mesh.triangles[t as usize];
                    if is_poor(mesh, corners, poor) {
                        let movable = corners
                            .into_iter()
                            .filter(|&x| motions[x as usize] != Motion::Fixed);
                        next.extend(movable.map(|x| (x, t)));
                    }
                }
            }
        }
    }
    next.sort_unstable();
    next.dedup_by_key(|&mut (v, _)| v);
    next
}

/// What a vertex that wants to move does in a round.
#[derive(Clone, Copy, Debug)]
enum Turn {
    /// A neighbour that also wants to move goes first.
    Waits,
    /// It found no better place.
    Stays,
    /// It moves there.
    Moves(DVec2),
}

/// A vertex's star with the quality of its triangles.
#[derive(Clone, Debug)]
struct Ring {
    star: Star,
    quality: Quality,
}

impl Ring {
    /// The ring around `v`, one of whose triangles is `start`.
    fn around(mesh: &Mesh, v: u32, start: u32) -> Option<Ring> {
        let star = Star::around(mesh, v, start)?;
        let mut ring = Ring {
            star,
            quality: Quality::WORST,
        };
        ring.quality = ring
            .quality_at(&mesh.vertices, mesh.vertices[v as usize])
            .unwrap_or(Quality::WORST);
        Some(ring)
    }

    /// The quality of the ring's triangles with its centre at `at`, or `None` when one of
    /// them is not counter-clockwise.
    fn quality_at(&self, vertices: &[DVec2], at: DVec2) -> Option<Quality> {
        let mut quality = Quality::BEST;
        for (w, u) in self.star.edges() {
            let [b, c] = [w, u].map(|x| vertices[x as usize]);
            if orientation(at, b, c) != Orientation::Left {
                return None;
            }
            quality = quality.and(Quality::of_triangle(at, b, c));
        }
        Some(quality)
    }

    /// Whether the ring's centre goes before every neighbour that also wants to move: its
    /// order this round (`want`, see [`Ring::order`]) is higher.
    fn goes_first(&self, want: &[u64]) -> bool {
        let own = want[self.star.centre as usize];
        self.star.neighbours.iter().all(|&w| want[w as usize] < own)
    }

    /// The ring's place in the order of `round` (higher goes first; never 0, as no triangle's
    /// smallest angle exceeds 60°): the whole degrees of its smallest angle below 90, then the
    /// centre's lot.
    fn order(&self, round: usize) -> u64 {
        let degrees = self.quality.narrowest.clamp(-1.0, 1.0).acos().to_degrees();
        let poorness = 90 - (degrees.min(90.0) as u64);
        poorness << 56 | lot(self.star.centre, round) >> 8
    }
}

/// The place for the ring's centre that makes its triangles best, if better than they are: a
/// pattern search around it, in steps shrinking from 0.3 of its nearest neighbour's distance,
/// in the plane for a free vertex and along its segment for one splitting a segment.
fn best_place(
    vertices: &[DVec2],
    ring: &Ring,
    motion: Motion,
    segment_ends: &[[DVec2; 2]],
) -> Option<DVec2> {
    let at = vertices[ring.star.centre as usize];
    if motion == Motion::Fixed || (motion == Motion::Free && !ring.star.closed) {
        return None;
    }
    let reach = ring
        .star
        .neighbours
        .iter()
        .map(|&w| vertices[w as usize].distance(at))
        .fold(f64::INFINITY, f64::min);
    let mut best = (ring.quality, at);
    let better = |place: DVec2, best: Quality| {
        ring.quality_at(vertices, place)
            .filter(|quality| quality.beats(best))
    };
    match motion {
        Motion::Slides(segment) => {
            let [from, to] = segment_ends[segment as usize];
            let length = from.distance(to);
            let mut along = (at - from).dot(to - from) / (length * length);
            for step in STEPS {
                let base = along;
                for sign in [-1.0, 1.0] {
                    let t = base + sign * step * reach / length;
                    let place = from + (to - from) * t;
                    if let Some(quality) = better(place, best.0) {
                        best = (quality, place);
                        along = t;
                    }
                }
            }
        }
        _ => {
            for step in STEPS {
                let base = best.1;
                for d in 0..DIRECTIONS {
                    let angle = std::f64::consts::TAU * d as f64 / DIRECTIONS as f64;
                    let place = base + DVec2::new(angle.cos(), angle.sin()) * (step * reach);
                    if let Some(quality) = better(place, best.0) {
                        best = (quality, place);
                    }
                }
            }
        }
    }
    best.0.gains_on(ring.quality).then_some(best.1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domain::SubSegment;
    use crate::mesh::angles_deg;
    use crate::mesh::fixtures::mesh_of;

    fn smallest_angle(mesh: &Mesh) -> f64 {
        mesh.triangles
            .iter()
            .flat_map(|t| {
                let [a, b, c] = t.map(|v| mesh.vertices[v as usize]);
                angles_deg(a, b, c)
            })
            .fold(f64::INFINITY, f64::min)
    }

    #[test]
    fn a_free_vertex_near_a_corner_moves_towards_the_middle() {
        let corners = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0], [0.3, 0.2]];
        let vertices: Vec<DVec2> = corners.iter().map(|&[x, y]| DVec2::new(x, y)).collect();
        let triangles = vec![[4, 0, 1], [4, 1, 2], [4, 2, 3], [4, 3, 0]];
        let mut mesh = mesh_of(vertices.clone(), &[0, 1, 2, 3], triangles.clone());
        let before = smallest_angle(&mesh);
        let smoothed = smooth_steiner_vertices(&mut mesh, &[]);
        assert!(smoothed.moves > 0);
        assert!(
            before < 10.0 && smallest_angle(&mesh) >= SMOOTH_BELOW_DEG,
            "{before} → {mesh:?}"
        );
        assert_eq!(mesh.vertices[..4], vertices[..4]);
        assert_eq!(mesh.triangles, triangles);
    }

    #[test]
    fn a_vertex_splitting_a_segment_slides_along_it_and_no_input_point_moves() {
        let corners = [[0.0, 0.0], [4.0, 0.0], [2.0, 2.0], [0.5, 0.0]];
        let vertices: Vec<DVec2> = corners.iter().map(|&[x, y]| DVec2::new(x, y)).collect();
        let triangles = vec![[0, 3, 2], [3, 1, 2]];
        let mut mesh = mesh_of(vertices.clone(), &[0, 1, 2], triangles);
        mesh.segments = [[0, 3], [3, 1]]
            .map(|vertices| SubSegment {
                vertices,
                segment: 0,
                marker: 5,
            })
            .to_vec();
        let before = smallest_angle(&mesh);
        smooth_steiner_vertices(&mut mesh, &[[vertices[0], vertices[1]]]);
        let slid = mesh.vertices[3];
        assert_eq!(slid.y, 0.0, "off its segment: {slid}");
        assert!(slid.x > 1.5 && slid.x < 2.5, "{slid}");
        assert!(before < 20.0 && smallest_angle(&mesh) >= SMOOTH_BELOW_DEG);
        assert_eq!(mesh.vertices[..3], vertices[..3]);
    }

    #[test]
    fn a_grid_vertex_on_the_boundary_off_any_segment_stays() {
        // Vertex 3 splits the boundary but no segment: it is fixed, like the corners.
        let corners = [[0.0, 0.0], [4.0, 0.0], [2.0, 2.0], [0.5, 0.0]];
        let vertices: Vec<DVec2> = corners.iter().map(|&[x, y]| DVec2::new(x, y)).collect();
        let mut mesh = mesh_of(vertices.clone(), &[0, 1, 2], vec![[0, 3, 2], [3, 1, 2]]);
        assert_eq!(smooth_steiner_vertices(&mut mesh, &[]), Smoothed::default());
        assert_eq!(mesh.vertices, vertices);
    }

    #[test]
    fn vertices_sharing_a_triangle_do_not_move_in_one_round() {
        // Two free vertices side by side in a rectangle, both off centre: the poorer ring
        // moves first, the other in a later round, and the result is better than either
        // start.
        let corners = [
            [0.0, 0.0],
            [4.0, 0.0],
            [4.0, 2.0],
            [0.0, 2.0],
            [0.4, 0.3],
            [3.2, 1.5],
        ];
        let vertices: Vec<DVec2> = corners.iter().map(|&[x, y]| DVec2::new(x, y)).collect();
        let triangles = vec![
            [4, 0, 1],
            [4, 1, 5],
            [5, 1, 2],
            [5, 2, 3],
            [5, 3, 4],
            [4, 3, 0],
        ];
        let mut mesh = mesh_of(vertices, &[0, 1, 2, 3], triangles);
        let rings = [(4, 0), (5, 1)].map(|(v, t)| Ring::around(&mesh, v, t).unwrap());
        let degrees = rings
            .each_ref()
            .map(|ring| ring.quality.narrowest.acos().to_degrees().floor());
        assert_ne!(degrees[0], degrees[1]);
        let poorer = usize::from(degrees[1] < degrees[0]);
        for round in 1..20 {
            let mut want = vec![0; 6];
            for ring in &rings {
                assert!(ring.star.closed);
                want[ring.star.centre as usize] = ring.order(round);
            }
            let first = rings.each_ref().map(|ring| ring.goes_first(&want));
            assert_eq!(first, [poorer == 0, poorer == 1], "round {round}");
        }
        let before = smallest_angle(&mesh);
        let smoothed = smooth_steiner_vertices(&mut mesh, &[]);
        assert!(smoothed.rounds >= 2, "{smoothed:?}");
        assert!(smallest_angle(&mesh) > before + 10.0);
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|v| mesh.vertices[v as usize]);
            assert_eq!(orientation(a, b, c), Orientation::Left);
        }
    }
}
