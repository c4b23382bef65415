//! Planar straight-line graphs in the Delaunay mode: the constrained Delaunay triangulation of
//! the points and segments, cut down to the domain the segments enclose, with regions.
//!
//! The points' Delaunay triangulation (of a square around them, or cut to their hull) gets
//! each segment that is not already an edge by flipping the edges that cross it (Sloan's
//! method, as for hull sides); the segment edges are then marked as walls in the links, and
//! Lawson's flips, which leave walls alone, make the rest constrained Delaunay. Triangles
//! reachable from the outside (the square's corners) or from a hole seed without crossing a
//! segment go, as Triangle's `-p` eats them; each region seed then gives its attribute to
//! the triangles it reaches. [`Walls`] keeps what refinement needs: which segment joins two
//! vertices, and the corners between walls narrower than 60° (split on concentric shells) and
//! than the angle bound (left as they are).

use std::collections::{HashMap, VecDeque};

use glam::DVec2;
use rayon::prelude::*;

use super::delaunay::{
    Location, NEXT, PREV, SEGMENT, Store, Triangulation, beyond, is_wall, locate_across_segments,
};
use super::hull::{
    ACUTE_CORNER_DEG, Stars, compact_keeping, recover_edge, touches_no_added_vertex,
};
use crate::domain::SubSegment;
use crate::error::Error;
use crate::mesh::{BoundaryEdge, NONE};
use crate::morton::interleave::box_key;
use crate::options::Input;
use crate::par::SharedSlots;
use crate::predicates::{Orientation, orientation};

/// The marker Triangle gives boundary edges and vertices that carry none of their own.
pub(super) const BOUNDARY_MARKER: i32 = 1;

/// A corner between two walls at a vertex, narrower than the angle bound: from the wall
/// towards `first` counter-clockwise to the wall towards `second` (their far ends when the
/// triangulation was made).
#[derive(Clone, Copy, Debug)]
struct NarrowCorner {
    first: DVec2,
    second: DVec2,
}

/// The segments of a planar straight-line graph as refinement sees them.
#[derive(Clone, Debug, Default)]
pub(crate) struct Walls {
    /// Input segments by their end vertices, the smaller first, sorted.
    by_ends: Vec<((u32, u32), u32)>,
    /// Where the segments whose smaller end is each vertex start in `by_ends`, for the
    /// vertices before refinement, and the end last: a lookup reads one short run instead of
    /// binary-searching them all.
    starts: Vec<u32>,
    /// Per vertex of the triangulation before refinement, whether a corner between walls
    /// there is narrower than [`ACUTE_CORNER_DEG`].
    acute: Vec<bool>,
    /// The corners narrower than the bound, by vertex.
    narrow: HashMap<u32, Vec<NarrowCorner>>,
    /// The vertex and position of the narrow corner between two segments, by the segments,
    /// the smaller first.
    narrow_pairs: HashMap<(u32, u32), DVec2>,
}

impl Walls {
    /// Whether a corner between walls at vertex `v` is narrower than [`ACUTE_CORNER_DEG`].
    #[inline]
    pub fn is_acute(&self, v: u32) -> bool {
        self.acute.get(v as usize).copied().unwrap_or(false)
    }

    /// The input segment the wall between vertices `a` and `b` lies on, given the segment each
    /// split vertex was put on (`segment_of`): a split end's, else the input segment joining
    /// them, or [`NONE`] (a hull side).
    pub fn segment_of_edge(&self, segment_of: impl Fn(u32) -> u32, a: u32, b: u32) -> u32 {
        [segment_of(a), segment_of(b)]
            .into_iter()
            .find(|&s| s != NONE)
            .unwrap_or_else(|| self.segment_between(a, b))
    }

    /// The input segment joining vertices `a` and `b`, or [`NONE`].
    pub fn segment_between(&self, a: u32, b: u32) -> u32 {
        let (lo, hi) = (a.min(b) as usize, a.max(b));
        let Some(run) = self.starts.get(lo..lo + 2) else {
            return NONE;
        };
        let run = &self.by_ends[run[0] as usize..run[1] as usize];
        run.binary_search_by_key(&hi, |&((_, e), _)| e)
            .map_or(NONE, |k| run[k].1)
    }

    /// Walls of the segments `by_ends` (sorted) between the first `vertices` vertices.
    fn new(by_ends: Vec<((u32, u32), u32)>, vertices: usize) -> Self {
        let mut starts = Vec::with_capacity(vertices + 1);
        let mut k = 0;
        for v in 0..=vertices as u32 {
            while k < by_ends.len() && by_ends[k].0.0 < v {
                k += 1;
            }
            starts.push(k as u32);
        }
        Walls {
            by_ends,
            starts,
            ..Walls::default()
        }
    }

    /// Whether the corner of a triangle at vertex `v` (at `at`, the triangle's other corners
    /// at `x` and `y`) lies in a corner between walls narrower than the bound.
    pub fn in_narrow_corner(&self, v: u32, at: DVec2, x: DVec2, y: DVec2) -> bool {
        if self.narrow.is_empty() {
            return false;
        }
        let Some(corners) = self.narrow.get(&v) else {
            return false;
        };
        let within = |c: &NarrowCorner, p: DVec2| {
            orientation(at, c.first, p) != Orientation::Right
                && orientation(at, p, c.second) != Orientation::Right
        };
        corners.iter().any(|c| within(c, x) && within(c, y))
    }

    /// Whether `p` and `q`, on segments `segments`, lie on the two sides of a corner narrower
    /// than the bound at equal distances from it (Shewchuk's rule, as Triangle applies it): the
    /// concentric shells put them there, and splitting a triangle on such an edge would only
    /// shrink the splits towards the corner.
    pub fn spans_narrow_corner(&self, segments: [u32; 2], [p, q]: [DVec2; 2]) -> bool {
        let [a, b] = segments;
        if self.narrow_pairs.is_empty() || a == NONE || b == NONE || a == b {
            return false;
        }
        self.narrow_pairs
            .get(&(a.min(b), a.max(b)))
            .is_some_and(|&c| {
                let (dp, dq) = (p.distance_squared(c), q.distance_squared(c));
                dp < 1.001 * dq && dp > 0.999 * dq
            })
    }
}

/// What [`constrain`] leaves: the domain's triangulation and its walls.
pub(super) struct Constrained {
    pub walls: Walls,
    /// The triangles of each region seed, when the input has regions.
    pub regions: bool,
}

/// Puts the input's segments into the Delaunay triangulation `t` of its points, cuts away
/// the outside (unless `hull`: `t` is already cut to the hull) and the holes, and gives the
/// regions their triangles. `vertex_input` follows the vertices; `t.segment_of` and, with
/// regions, `t.regions` are filled.
///
/// # Errors
/// [`Error::NothingEnclosed`] when no triangle is left.
pub(super) fn constrain(
    t: &mut Triangulation,
    vertex_input: &mut Vec<u32>,
    input: &Input,
    hull: bool,
    min_angle_deg: f64,
) -> Result<Constrained, Error> {
    let mut vertex_of = vec![NONE; input.points.len()];
    for (v, &i) in vertex_input.iter().enumerate() {
        if i != NONE {
            vertex_of[i as usize] = v as u32;
        }
    }
    let ends = |k: usize| input.segments[k].ends.map(|i| vertex_of[i as usize]);
    let mut stars = Stars::of(t);
    let mut touched = Vec::new();
    // Most segments are edges already, which is found in parallel. Recovering one flips only
    // edges that cross it, which no other segment is.
    let edge_of = |t: &Triangulation, stars: &Stars, k: usize| {
        let [u, v] = ends(k);
        stars.edge(t, u, v).or_else(|| stars.edge(t, v, u))
    };
    let located: Vec<Option<(u32, usize)>> = (0..input.segments.len())
        .into_par_iter()
        .map(|k| edge_of(t, &stars, k))
        .collect();
    let missing: Vec<usize> = (0..located.len())
        .filter(|&k| located[k].is_none())
        .collect();
    for &k in &missing {
        let [u, v] = ends(k);
        recover_edge(t, &mut stars, (u, v), &mut touched)?;
    }
    // The flips of a recovery may move edges found before to other triangles: those no longer
    // where they were found, and the recovered ones, are found again.
    let still_there = |k: usize, (id, i): (u32, usize)| {
        let c = t.corners[id as usize];
        let ([u, v], seen) = (ends(k), [c[NEXT[i]], c[PREV[i]]]);
        seen == [u, v] || seen == [v, u]
    };
    let found: Vec<(u32, usize)> = located
        .into_par_iter()
        .enumerate()
        .map(|(k, place)| match place {
            Some(place) if missing.is_empty() || still_there(k, place) => place,
            _ => edge_of(t, &stars, k).expect("a recovered segment is an edge"),
        })
        .collect();
    mark_walls(t, &found);
    let edges = touched
        .iter()
        .flat_map(|&id| (0..3).map(move |i| (id, i)))
        .collect();
    t.flip_to_delaunay(edges);
    // The triangulation stays as it is until the outside is cut off: the seeds are found once.
    let seeds: Vec<DVec2> = (input.holes.iter().copied())
        .chain(input.regions.iter().map(|r| r.seed))
        .collect();
    let places = locate_all(t, &seeds);
    check_seeds(t, input, &vertex_of, &seeds, &places)?;
    let seed_triangles = triangles_at(t, &places);
    let (hole_triangles, region_triangles) = seed_triangles.split_at(input.holes.len());

    let outside = eat_outside(t, vertex_input, hole_triangles, hull);
    if outside.iter().all(|&gone| gone) {
        return Err(Error::NothingEnclosed);
    }
    let regions = !input.regions.is_empty();
    if regions {
        t.regions = spread_regions(t, &outside, region_triangles);
    }
    let keep: Vec<bool> = outside.iter().map(|&gone| !gone).collect();
    let (vertex_map, _) = compact_keeping(t, vertex_input, &keep);
    // As much room as the vertices and triangles have, which the tiles refine within.
    t.segment_of = Vec::with_capacity(t.vertices.capacity());
    t.segment_of.resize(t.vertices.len(), NONE);
    if !t.regions.is_empty() {
        t.regions
            .reserve(t.corners.capacity().saturating_sub(t.regions.len()));
    }
    let mut by_ends: Vec<((u32, u32), u32)> = (0..input.segments.len())
        .into_par_iter()
        .filter_map(|k| {
            let [u, v] = ends(k).map(|x| vertex_map.of(x));
            (u != NONE && v != NONE).then_some(((u.min(v), u.max(v)), k as u32))
        })
        .collect();
    // Cleaning left one segment per pair of ends.
    by_ends.par_sort_unstable();
    let mut walls = Walls::new(by_ends, t.vertices.len());
    find_corners(t, &mut walls, min_angle_deg);
    Ok(Constrained { walls, regions })
}

/// The walls of a triangulation made elsewhere whose wall links are marked already: the
/// segment of each wall by its ends (`by_ends`, the smaller end first, one entry per pair of
/// ends, sorted), and the corners between walls as [`constrain`] finds them.
pub(super) fn walls_of(
    t: &Triangulation,
    by_ends: Vec<((u32, u32), u32)>,
    min_angle_deg: f64,
) -> Walls {
    let mut walls = Walls::new(by_ends, t.vertices.len());
    find_corners(t, &mut walls, min_angle_deg);
    walls
}

/// Marks the edges opposite corner `i` of triangle `id`, for each `(id, i)` of `edges`
/// (distinct edges), as segments on both their sides, in parallel: each link is one side of
/// one edge, so has one writer, and the links read to find the far side only gain the mark.
fn mark_walls(t: &mut Triangulation, edges: &[(u32, usize)]) {
    let links = SharedSlots::new(t.across.as_flattened_mut());
    let slot = |id: u32, i: usize| 3 * id as usize + i;
    edges.par_iter().for_each(|&(id, i)| {
        let other = beyond(links.load(slot(id, i)));
        if other == NONE {
            return;
        }
        let j = (0..3)
            .find(|&j| beyond(links.load(slot(other, j))) == id)
            .expect("neighbours link each other");
        for s in [slot(id, i), slot(other, j)] {
            links.store(s, links.load(s) | SEGMENT);
        }
    });
}

/// The triangles outside the domain: those reached without crossing a wall from a triangle
/// with a vertex that is not an input point (the square's corners and the strips' seam ends;
/// none once cut to the hull) or from a hole seed.
fn eat_outside(
    t: &Triangulation,
    vertex_input: &[u32],
    holes: &[Option<u32>],
    hull: bool,
) -> Vec<bool> {
    let mut outside = vec![false; t.len()];
    let mut queue: VecDeque<u32> = VecDeque::new();
    if !hull {
        let inside = touches_no_added_vertex(t, vertex_input);
        queue.extend((0..t.len() as u32).filter(|&id| !inside[id as usize]));
    }
    queue.extend(holes.iter().flatten());
    for &id in &queue {
        outside[id as usize] = true;
    }
    spread(t, &mut queue, |id| {
        let fresh = !outside[id as usize];
        outside[id as usize] = true;
        fresh
    });
    outside
}

/// Refuses a hole or region seed on a segment or on a segment's end, where it would name
/// either of the regions beside it. `seeds` are the hole seeds then the region seeds, with the
/// places [`locate_all`] found for them.
///
/// # Errors
/// [`Error::SeedOnSegment`] naming the first such seed, holes first.
fn check_seeds(
    t: &Triangulation,
    input: &Input,
    vertex_of: &[u32],
    seeds: &[DVec2],
    places: &[Location],
) -> Result<(), Error> {
    let mut ends = vec![false; t.vertices.len()];
    for s in &input.segments {
        for i in s.ends {
            ends[vertex_of[i as usize] as usize] = true;
        }
    }
    let on_segment = |p: DVec2, place: Location| match place {
        Location::Vertex(v) => ends[v as usize],
        Location::Inside(id) => {
            let (c, n) = (t.corners[id as usize], t.across[id as usize]);
            (0..3).any(|i| {
                let (a, b) = (c[NEXT[i]], c[PREV[i]]);
                n[i] != NONE
                    && is_wall(n[i])
                    && orientation(t.vertices[a as usize], t.vertices[b as usize], p)
                        == Orientation::On
            })
        }
        Location::Outside { .. } | Location::Foreign => false,
    };
    let holes = input.holes.len();
    for (k, (&p, &place)) in seeds.iter().zip(places).enumerate() {
        let (kind, index) = if k < holes {
            ("hole", k)
        } else {
            ("region", k - holes)
        };
        if on_segment(p, place) {
            return Err(Error::SeedOnSegment {
                kind,
                index,
                x: p.x,
                y: p.y,
            });
        }
    }
    Ok(())
}

/// Where each of `points` lies (`Foreign` for a point that is not finite). The walks go in
/// Morton order of the points, in parallel chunks, each from where the one before ended: seeds
/// spread over a large mesh then cost a short walk each, not one from the first triangle.
fn locate_all(t: &Triangulation, points: &[DVec2]) -> Vec<Location> {
    let mut places = vec![Location::Foreign; points.len()];
    if t.len() == 0 {
        return places;
    }
    let finite: Vec<usize> = (0..points.len())
        .filter(|&k| points[k].is_finite())
        .collect();
    let (lo, hi) = finite.iter().fold(
        (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
        |(lo, hi), &k| (lo.min(points[k]), hi.max(points[k])),
    );
    let mut order = finite;
    order.par_sort_unstable_by_key(|&k| (box_key(points[k], lo, hi - lo), k));
    // Fixed chunks, each walking from the first triangle and then from where it last ended:
    // the same walks on any thread count.
    const CHUNK: usize = 1024;
    let found: Vec<Vec<Location>> = order
        .par_chunks(CHUNK)
        .map(|chunk| {
            let mut start = 0;
            (chunk.iter())
                .map(|&k| {
                    let place = locate_across_segments(t, points[k], start);
                    if let Location::Inside(id) | Location::Outside { triangle: id, .. } = place {
                        start = id;
                    }
                    place
                })
                .collect()
        })
        .collect();
    for (&k, place) in order.iter().zip(found.into_iter().flatten()) {
        places[k] = place;
    }
    places
}

/// The triangle at each place, if any. A place on a vertex gets one of the vertex's
/// triangles: the check of the seeds refused those on segments' ends, so no wall meets the
/// vertex and its triangles lie in one region.
fn triangles_at(t: &Triangulation, places: &[Location]) -> Vec<Option<u32>> {
    let on_vertex = places.iter().any(|p| matches!(p, Location::Vertex(_)));
    let stars = on_vertex.then(|| Stars::of(t));
    places
        .iter()
        .map(|&place| match place {
            Location::Inside(id) => Some(id),
            Location::Vertex(v) => stars.as_ref()?.around(t, v).next().map(|(id, _)| id),
            Location::Outside { .. } | Location::Foreign => None,
        })
        .collect()
}

/// Spreads from the queued triangles across every link that is not a wall, to each triangle
/// that `visit` takes (returns true for).
fn spread(t: &Triangulation, queue: &mut VecDeque<u32>, mut visit: impl FnMut(u32) -> bool) {
    while let Some(id) = queue.pop_front() {
        for &n in &t.across[id as usize] {
            if !is_wall(n) && visit(n) {
                queue.push_back(n);
            }
        }
    }
}

/// Per triangle, the last region seed (in input order) whose region holds it, or [`NONE`]:
/// each seed's triangle and all it reaches without crossing a wall.
fn spread_regions(t: &Triangulation, outside: &[bool], seeds: &[Option<u32>]) -> Vec<u32> {
    let mut region = vec![NONE; t.len()];
    let mut stamp = vec![NONE; t.len()];
    for (k, &seed) in seeds.iter().enumerate() {
        let Some(start) = seed.filter(|&id| !outside[id as usize]) else {
            continue;
        };
        let k = k as u32;
        region[start as usize] = k;
        stamp[start as usize] = k;
        let mut queue = VecDeque::from([start]);
        spread(t, &mut queue, |id| {
            let fresh = stamp[id as usize] != k;
            stamp[id as usize] = k;
            region[id as usize] = k;
            fresh
        });
    }
    region
}

/// Finds, at every vertex, the corners between consecutive walls around it: those narrower
/// than [`ACUTE_CORNER_DEG`] and those narrower than the bound.
fn find_corners(t: &Triangulation, walls: &mut Walls, min_angle_deg: f64) {
    let stars = Stars::of(t);
    let narrowest = min_angle_deg.max(ACUTE_CORNER_DEG);
    let found: Vec<(u32, Vec<WallCorner>)> = (0..t.vertices.len() as u32)
        .into_par_iter()
        .filter_map(|v| {
            let corners = corners_at(t, &stars, v, narrowest);
            (!corners.is_empty()).then_some((v, corners))
        })
        .collect();
    walls.acute = vec![false; t.vertices.len()];
    for (v, corners) in found {
        let at = t.vertices[v as usize];
        for (angle, first, second) in corners {
            if angle < ACUTE_CORNER_DEG {
                walls.acute[v as usize] = true;
            }
            if angle < min_angle_deg {
                let corner = NarrowCorner {
                    first: t.vertices[first as usize],
                    second: t.vertices[second as usize],
                };
                walls.narrow.entry(v).or_default().push(corner);
                let (a, b) = (
                    walls.segment_between(v, first),
                    walls.segment_between(v, second),
                );
                if a != NONE && b != NONE {
                    walls.narrow_pairs.insert((a.min(b), a.max(b)), at);
                }
            }
        }
    }
}

/// A corner between two walls at a vertex: its angle (degrees) and the far ends of its walls,
/// counter-clockwise.
type WallCorner = (f64, u32, u32);

/// The corners narrower than `narrowest` degrees between consecutive walls around vertex
/// `v`, each as its angle (degrees) and the far ends of its two walls, counter-clockwise from
/// the first; none where fewer than two walls meet.
fn corners_at(t: &Triangulation, stars: &Stars, v: u32, narrowest: f64) -> Vec<WallCorner> {
    let at = t.vertices[v as usize];
    // Clockwise around v; in each triangle, with v at corner i, the edge from v to the corner
    // PREV[i] (opposite NEXT[i]) comes first, the edge to NEXT[i] (opposite PREV[i]) last.
    let starts_at_wall = |(id, i): (u32, usize)| is_wall(t.across[id as usize][NEXT[i]]);
    let ends_at_wall = |(id, i): (u32, usize)| is_wall(t.across[id as usize][PREV[i]]);
    let Some(start) = stars.around(t, v).find(|&f| starts_at_wall(f)) else {
        return Vec::new();
    };
    // The fan from the first triangle after a wall, around once.
    let fan = stars
        .around(t, v)
        .skip_while(move |&f| f != start)
        .chain(stars.around(t, v).take_while(move |&f| f != start));
    let mut corners = Vec::new();
    let (mut angle, mut second) = (0.0, NONE);
    for (id, i) in fan {
        let c = t.corners[id as usize];
        if starts_at_wall((id, i)) {
            angle = 0.0;
            second = c[PREV[i]];
        }
        let (x, y) = (
            t.vertices[c[NEXT[i]] as usize] - at,
            t.vertices[c[PREV[i]] as usize] - at,
        );
        // The angle grows with each triangle; past the narrowest that counts, it is not summed.
        if angle < narrowest {
            angle += x.perp_dot(y).atan2(x.dot(y)).to_degrees();
        }
        if ends_at_wall((id, i)) && angle < narrowest {
            corners.push((angle, c[NEXT[i]], second));
        }
    }
    // A single wall (a segment ending inside the domain) makes one corner all around.
    if corners.len() == 1 && corners[0].1 == corners[0].2 {
        corners.clear();
    }
    corners
}

/// The pieces of the input segments among the triangulation's walls, ordered by segment and
/// along each from its first end, and the boundary edges with Triangle's markers: a
/// segment's own if nonzero, else [`BOUNDARY_MARKER`].
pub(super) fn segment_pieces(
    t: &Triangulation,
    walls: &Walls,
    input: &Input,
) -> (Vec<SubSegment>, Vec<BoundaryEdge>) {
    let segment_of = |a: u32, b: u32| walls.segment_of_edge(|v| t.segment_of(v), a, b);
    let found: Vec<(SubSegment, bool)> = (0..t.len() as u32)
        .into_par_iter()
        .flat_map_iter(|id| {
            let (c, n) = (t.corners[id as usize], t.across[id as usize]);
            (0..3).filter_map(move |i| {
                let link = n[i];
                // Each interior wall once, from the triangle with the smaller number.
                if !is_wall(link) || (link != NONE && beyond(link) < id) {
                    return None;
                }
                let (a, b) = (c[NEXT[i]], c[PREV[i]]);
                Some((a, b, link == NONE))
            })
        })
        .map(|(a, b, boundary)| {
            let segment = segment_of(a, b);
            let marker = if segment == NONE {
                BOUNDARY_MARKER
            } else {
                input.segments[segment as usize].marker
            };
            (
                SubSegment {
                    vertices: [a, b],
                    segment,
                    marker,
                },
                boundary,
            )
        })
        .collect();
    let boundary = found
        .par_iter()
        .filter(|(_, boundary)| *boundary)
        .map(|(s, _)| BoundaryEdge {
            vertices: s.vertices,
            marker: if s.marker == 0 || s.segment == NONE {
                BOUNDARY_MARKER
            } else {
                s.marker
            },
        })
        .collect();
    let mut pieces: Vec<(SubSegment, [f64; 2])> = found
        .into_par_iter()
        .filter(|(s, _)| s.segment != NONE)
        .map(|(mut s, _)| {
            let [i, j] = input.segments[s.segment as usize].ends;
            let d = input.points[j as usize] - input.points[i as usize];
            let [a, b] = s.vertices.map(|v| along(t.vertices[v as usize], d));
            // Each piece runs forward, and is ordered by where it starts.
            let start = if by_key(b, a).is_lt() {
                s.vertices.swap(0, 1);
                b
            } else {
                a
            };
            (s, start)
        })
        .collect();
    pieces.par_sort_unstable_by(|(s, x), (r, y)| s.segment.cmp(&r.segment).then(by_key(*x, *y)));
    (pieces.into_par_iter().map(|(s, _)| s).collect(), boundary)
}

/// Where a point on a segment of direction `d` lies along it, as a key that orders the points
/// of the segment exactly: its coordinate along the axis `d` changes most on, then along the
/// other, each signed to grow with `d`. (A fraction of the way along, a rounded quotient, ties
/// for distinct points near the ends of a long segment.)
fn along(p: DVec2, d: DVec2) -> [f64; 2] {
    let sign = |c: f64| if c < 0.0 { -1.0 } else { 1.0 };
    if d.x.abs() >= d.y.abs() {
        [p.x * sign(d.x), p.y * sign(d.y)]
    } else {
        [p.y * sign(d.y), p.x * sign(d.x)]
    }
}

/// The order of two [`along`] keys.
fn by_key(a: [f64; 2], b: [f64; 2]) -> std::cmp::Ordering {
    a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::refine::delaunay::Cavity;
    use rand::{Rng, SeedableRng};

    /// Seeds found by walks that start where the last one ended lie where a walk from the
    /// first triangle finds them; seeds that are not finite are nowhere.
    #[test]
    fn seeds_are_found_where_a_walk_from_the_first_triangle_finds_them() {
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(9);
        let mut t = Triangulation::rectangle(DVec2::ZERO, DVec2::splat(1.0));
        let mut cavity = Cavity::default();
        for _ in 0..3000 {
            let p = DVec2::new(rng.random(), rng.random());
            cavity.insert(&mut t, p, 0).unwrap();
        }
        let mut seeds: Vec<DVec2> = (0..500)
            .map(|_| DVec2::new(rng.random_range(-0.1..1.1), rng.random_range(-0.1..1.1)))
            .collect();
        seeds.extend([t.vertices[100], DVec2::new(f64::NAN, 0.5), DVec2::INFINITY]);
        let places = locate_all(&t, &seeds);
        for (&p, &place) in seeds.iter().zip(&places) {
            let expected = if p.is_finite() {
                locate_across_segments(&t, p, 0)
            } else {
                Location::Foreign
            };
            match (place, expected) {
                // Outside: the boundary edge it is beyond depends on the walk.
                (Location::Outside { .. }, Location::Outside { .. }) => {}
                _ => assert_eq!(place, expected, "{p}"),
            }
        }
        assert!(matches!(places[500], Location::Vertex(100)));
    }
}
