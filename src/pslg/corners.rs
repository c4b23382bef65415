//! Acute corners cut off, the first step of meshing a graph in the quadtree (Bern, Eppstein and
//! Teng §5, after Bern, Eppstein and Gilbert).
//!
//! Around every vertex with a wedge (two segments consecutive about it) below 90°, the wedge's
//! tip is cut off by an isosceles triangle, a *cap*, whose equal sides lie on the two segments.
//! All caps of a vertex have the same radius, a third of the distance to its nearest
//! non-incident feature (another point, or a segment not ending at it) and at most a third of
//! its shortest segment. So a cap holds no other input, caps of different vertices lie in
//! disjoint disks, and the two caps on one segment leave at least a third of it between them.
//! What is left has no angle below 90° outside the caps: the cut wedge of angle θ leaves
//! 90° + θ/2 on either side of its cutting edge. The quadtree stage meshes what is left; the
//! caps come back after it, their sides divided as the mesh beside them divides them.

use glam::DVec2;
use rayon::prelude::*;

use crate::error::Error;
use crate::options::Input;
use crate::predicates::{Orientation, orientation};
use crate::pslg::check_points_and_ends;
use crate::spatial::graph_rtrees;

/// How much of the distance to the nearest non-incident feature, and of the shortest segment, a
/// cap's sides take.
pub const CAP_FRACTION: f64 = 1.0 / 3.0;

/// A graph with its acute corners cut off.
#[derive(Clone, Debug, PartialEq)]
pub struct CornerCut {
    /// The input's points, in their order and bit for bit, then the cut points: on each
    /// segment that bounds a cut wedge, one at the cap radius from the vertex.
    pub points: Vec<DVec2>,
    /// The edges the quadtree stage must keep: the pieces of segments outside the caps (a side
    /// of a cap too, where a wedge that is not cut lies beyond it), and the caps' cutting edges.
    pub edges: Vec<GraphEdge>,
    /// The cut-off triangles, to be put back after the quadtree stage.
    pub caps: Vec<Cap>,
    /// Per input point, the radius of its caps (0 where no wedge is cut).
    pub cap_radius: Vec<f64>,
    /// The vertices whose wedges are all cut: no edge reaches them; each lies inside its caps.
    pub enclosed: Vec<u32>,
}

/// An edge of the cut graph.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GraphEdge {
    /// Its ends, as indices into [`CornerCut::points`], in the direction of its segment.
    pub ends: [u32; 2],
    /// Where it came from.
    pub origin: EdgeOrigin,
}

/// What an edge of the cut graph is a piece of.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum EdgeOrigin {
    /// A piece of the input segment with this index (its marker applies).
    Segment(u32),
    /// The cutting edge of the cap with this index: no input segment.
    Cut(u32),
}

/// A cut-off triangle: the apex (an input vertex) and the two cut points, counterclockwise.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cap {
    /// The input vertex whose wedge it cuts off.
    pub apex: u32,
    /// The cut points on the wedge's first and second segment (counterclockwise about the
    /// apex), as indices into [`CornerCut::points`].
    pub ends: [u32; 2],
    /// The input segments its equal sides lie on, in the same order.
    pub sides: [u32; 2],
}

/// The distance from each point to its nearest non-incident feature: the nearest other point,
/// or the nearest segment not ending at it (infinity when there is neither). Computed in f64
/// with R-trees of the points and the segments, each query on its own (in parallel, the same
/// result on any thread count).
pub fn feature_distances(points: &[DVec2], segments: &[[u32; 2]]) -> Vec<f64> {
    let all: Vec<u32> = (0..points.len() as u32).collect();
    feature_distances_of(points, segments, &all)
}

/// [`feature_distances`] of the points `which` only, in that order; the R-trees are built
/// only when `which` names some point.
fn feature_distances_of(points: &[DVec2], segments: &[[u32; 2]], which: &[u32]) -> Vec<f64> {
    if which.is_empty() {
        return Vec::new();
    }
    let (point_tree, segment_tree) = graph_rtrees(points, segments);
    which
        .par_iter()
        .map(|&v| {
            let at = [points[v as usize].x, points[v as usize].y];
            let point = point_tree
                .nearest_neighbor_iter_with_distance_2(at)
                .find(|(p, _)| p.data != v)
                .map_or(f64::INFINITY, |(_, d2)| d2);
            let segment = segment_tree
                .nearest_neighbor_iter_with_distance_2(at)
                .find(|(s, _)| !segments[s.data as usize].contains(&v))
                .map_or(f64::INFINITY, |(_, d2)| d2);
            point.min(segment).sqrt()
        })
        .collect()
}

/// The segments at each vertex, counterclockwise from the direction nearest after +x (that
/// direction included), as compressed rows: vertex `v`'s are `at[v]..at[v + 1]` of `segments`.
struct Stars {
    at: Vec<usize>,
    segments: Vec<u32>,
}

impl Stars {
    fn of(points: &[DVec2], segments: &[[u32; 2]]) -> Stars {
        let mut ends: Vec<(u32, u32)> = segments
            .iter()
            .enumerate()
            .flat_map(|(s, &[a, b])| [(a, s as u32), (b, s as u32)])
            .collect();
        ends.par_sort_unstable();
        ends.par_chunk_by_mut(|a, b| a.0 == b.0).for_each(|row| {
            let v = row[0].0;
            let centre = points[v as usize];
            let end = |s: u32| points[other_end(segments[s as usize], v) as usize];
            row.sort_unstable_by(|&(_, s), &(_, t)| counterclockwise_order(centre, end(s), end(t)));
        });
        let mut at = vec![0; points.len() + 1];
        for &(v, _) in &ends {
            at[v as usize + 1] += 1;
        }
        for v in 0..points.len() {
            at[v + 1] += at[v];
        }
        Stars {
            at,
            segments: ends.into_iter().map(|(_, s)| s).collect(),
        }
    }

    fn row(&self, v: usize) -> &[u32] {
        &self.segments[self.at[v]..self.at[v + 1]]
    }
}

fn other_end([a, b]: [u32; 2], v: u32) -> u32 {
    if a == v { b } else { a }
}

/// The order of the directions from `centre` to `p` and to `q` counterclockwise from +x
/// (included), decided exactly: the half-plane by the sign of a difference (exact in f64), then
/// an orientation test.
fn counterclockwise_order(centre: DVec2, p: DVec2, q: DVec2) -> std::cmp::Ordering {
    let lower = |p: DVec2| p.y < centre.y || (p.y == centre.y && p.x < centre.x);
    lower(p)
        .cmp(&lower(q))
        .then_with(|| match orientation(centre, p, q) {
            Orientation::Left => std::cmp::Ordering::Less,
            Orientation::Right => std::cmp::Ordering::Greater,
            Orientation::On => std::cmp::Ordering::Equal,
        })
}

/// Whether the wedge counterclockwise from the direction `p - centre` to `q - centre` is below
/// 90°: turning left (exactly), with a positive dot product (in f64; a wedge within rounding of
/// 90° may go either way, and either is fine for the stages after).
fn acute(centre: DVec2, p: DVec2, q: DVec2) -> bool {
    orientation(centre, p, q) == Orientation::Left && (p - centre).dot(q - centre) > 0.0
}

/// The wedges of one vertex: for each segment of its star (in its counterclockwise order),
/// whether the wedge from it to the next one is cut.
fn cut_wedges(points: &[DVec2], segments: &[[u32; 2]], v: usize, star: &[u32]) -> Vec<bool> {
    if star.len() < 2 {
        return vec![false; star.len()];
    }
    let centre = points[v];
    let end = |s: u32| points[other_end(segments[s as usize], v as u32) as usize];
    (0..star.len())
        .map(|i| acute(centre, end(star[i]), end(star[(i + 1) % star.len()])))
        .collect()
}

/// Cuts off the acute corners of a cleaned graph (see [`crate::pslg::clean`]: segments meet only
/// at their ends, no two points coincide): the input's points and segments; holes and regions
/// are not read.
///
/// The cut points are numbered after the input's points, vertex by vertex in input order and,
/// about each vertex, counterclockwise from +x; the caps and edges likewise. The work is
/// O((n + m) log(n + m)) for n points and m segments, in parallel but for building the R-trees
/// and the final numbering (one pass); the result is the same on any thread count.
///
/// # Errors
/// [`Error::NonFinite`], [`Error::SegmentIndex`] and [`Error::ZeroLengthSegment`] for the first
/// such point or segment, as [`crate::pslg::clean`] refuses them (crossings are not looked
/// for: clean the graph first), and [`Error::Unresolvable`] naming a vertex whose cap f64 cannot
/// place: a cut point that rounds onto the vertex or onto another cut point, or a cap that is
/// not a counterclockwise triangle.
pub fn cut_acute_corners(input: &Input) -> Result<CornerCut, Error> {
    check_graph(input)?;
    let points = &input.points;
    let segments: Vec<[u32; 2]> = input.segments.iter().map(|s| s.ends).collect();
    let stars = Stars::of(points, &segments);
    let wedges: Vec<Vec<bool>> = (0..points.len())
        .into_par_iter()
        .map(|v| cut_wedges(points, &segments, v, stars.row(v)))
        .collect();
    // Only vertices with a wedge to cut need their nearest feature.
    let cut: Vec<u32> = (0..points.len() as u32)
        .into_par_iter()
        .filter(|&v| wedges[v as usize].contains(&true))
        .collect();
    let mut distances = vec![f64::INFINITY; points.len()];
    for (&v, d) in cut
        .iter()
        .zip(feature_distances_of(points, &segments, &cut))
    {
        distances[v as usize] = d;
    }
    let cap_radius: Vec<f64> = (0..points.len())
        .into_par_iter()
        .map(|v| {
            if !wedges[v].contains(&true) {
                return 0.0;
            }
            let shortest = stars
                .row(v)
                .iter()
                .map(|&s| {
                    let [a, b] = segments[s as usize];
                    points[a as usize].distance(points[b as usize])
                })
                .fold(f64::INFINITY, f64::min);
            CAP_FRACTION * distances[v].min(shortest)
        })
        .collect();
    let local: Vec<Local> = (0..points.len())
        .into_par_iter()
        .map(|v| {
            cut_vertex(
                points,
                &segments,
                v,
                stars.row(v),
                &wedges[v],
                cap_radius[v],
            )
        })
        .collect::<Result<_, _>>()?;
    Ok(assemble(points, &segments, local, cap_radius))
}

/// The checks of [`cut_acute_corners`] on its input, before it indexes anything: those at
/// [`crate::pslg::clean`]'s door, then a segment whose ends are two points at one position.
fn check_graph(input: &Input) -> Result<(), Error> {
    check_points_and_ends(input)?;
    let at_one_place = input.segments.iter().position(|s| {
        let [a, b] = s.ends.map(|v| input.points[v as usize]);
        a == b
    });
    match at_one_place {
        Some(segment) => Err(Error::ZeroLengthSegment { segment }),
        None => Ok(()),
    }
}

/// One vertex's share of the cut: its cut points (with the segment each lies on), its caps (as
/// positions in its cut points), and which of its segments' pieces beside it stay edges.
struct Local {
    cuts: Vec<(DVec2, u32)>,
    caps: Vec<([usize; 2], [u32; 2])>,
    /// Per cut point, whether its piece from the vertex borders a wedge that is not cut.
    side_kept: Vec<bool>,
    enclosed: bool,
}

fn cut_vertex(
    points: &[DVec2],
    segments: &[[u32; 2]],
    v: usize,
    star: &[u32],
    wedges: &[bool],
    radius: f64,
) -> Result<Local, Error> {
    let centre = points[v];
    let k = star.len();
    let unresolvable = || Error::Unresolvable {
        index: v,
        x: centre.x,
        y: centre.y,
    };
    let mut cuts = Vec::new();
    let mut side_kept = Vec::new();
    let mut cut_of = vec![usize::MAX; k];
    for i in 0..k {
        let before = wedges[(i + k - 1) % k];
        let after = wedges[i];
        if !(before || after) {
            continue;
        }
        let s = star[i];
        let far = points[other_end(segments[s as usize], v as u32) as usize];
        let along = far - centre;
        let cut = centre + along * (radius / along.length());
        if cut == centre || cut == far {
            return Err(unresolvable());
        }
        cut_of[i] = cuts.len();
        cuts.push((cut, s));
        side_kept.push(!(before && after));
    }
    let mut caps = Vec::new();
    for i in (0..k).filter(|&i| wedges[i]) {
        let j = (i + 1) % k;
        let (a, b) = (cut_of[i], cut_of[j]);
        if cuts[a].0 == cuts[b].0 || orientation(centre, cuts[a].0, cuts[b].0) != Orientation::Left
        {
            return Err(unresolvable());
        }
        caps.push(([a, b], [star[i], star[j]]));
    }
    Ok(Local {
        cuts,
        caps,
        side_kept,
        enclosed: k > 0 && wedges.iter().all(|&w| w),
    })
}

/// Numbers the cut points, caps and edges from the vertices' shares, in vertex order.
fn assemble(
    points: &[DVec2],
    segments: &[[u32; 2]],
    local: Vec<Local>,
    cap_radius: Vec<f64>,
) -> CornerCut {
    let mut out_points = points.to_vec();
    let mut caps = Vec::new();
    let mut edges = Vec::new();
    let mut enclosed = Vec::new();
    // Per segment, its cut point at each end, if any.
    let mut cut_at = vec![[u32::MAX; 2]; segments.len()];
    for (v, share) in local.into_iter().enumerate() {
        let first = out_points.len() as u32;
        for (i, &(at, s)) in share.cuts.iter().enumerate() {
            let end = usize::from(segments[s as usize][1] == v as u32);
            cut_at[s as usize][end] = first + i as u32;
            out_points.push(at);
            if share.side_kept[i] {
                let ends = if end == 0 {
                    [v as u32, first + i as u32]
                } else {
                    [first + i as u32, v as u32]
                };
                edges.push(GraphEdge {
                    ends,
                    origin: EdgeOrigin::Segment(s),
                });
            }
        }
        for ([a, b], sides) in share.caps {
            let cap = caps.len() as u32;
            let ends = [first + a as u32, first + b as u32];
            caps.push(Cap {
                apex: v as u32,
                ends,
                sides,
            });
            edges.push(GraphEdge {
                ends,
                origin: EdgeOrigin::Cut(cap),
            });
        }
        if share.enclosed {
            enclosed.push(v as u32);
        }
    }
    for (s, &[a, b]) in segments.iter().enumerate() {
        let [ca, cb] = cut_at[s];
        let from = if ca == u32::MAX { a } else { ca };
        let to = if cb == u32::MAX { b } else { cb };
        edges.push(GraphEdge {
            ends: [from, to],
            origin: EdgeOrigin::Segment(s as u32),
        });
    }
    CornerCut {
        points: out_points,
        edges,
        caps,
        cap_radius,
        enclosed,
    }
}
