//! The warp of a graph's separated tree (BET §5, `beg-quadtree-meshing.md` §4.2): its leaves
//! bent onto the graph's vertices and edges and triangulated, before the domain is cut out.
//!
//! 1. Each vertex moves the nearest corner or side midpoint of its leaf onto itself.
//! 2. Each other grid vertex lying closer to an edge than [`EDGE_SNAP`] of its shortest arm
//!    (the shortest leaf side running from it) moves onto the edge, to the nearest point.
//! 3. Where an edge still crosses a leaf side, between two grid vertices neither of which is on
//!    it, the crossing becomes a vertex of both leaves. Both ends of such a side lie at least
//!    [`EDGE_SNAP`] of their shortest arms from the edge, and an arm is at most twice the
//!    shortest at its vertex in a balanced tree, so the edge crosses the side at no less than
//!    asin([`EDGE_SNAP`]).
//! 4. Each leaf is then a polygon (its corners, midpoints and crossings) cut by the edge pieces
//!    that pass through it into parts, each triangulated for the largest smallest angle.
//!
//! Every step is per leaf or per edge and reads only the tree, so it runs in parallel; vertices
//! are numbered by their grid coordinates, crossings after them by side and edge, triangles by
//! leaf in Morton order: the same triangulation on any thread count.

mod polygon;
mod smooth;

use std::sync::OnceLock;

use glam::DVec2;
use rayon::prelude::*;

pub use polygon::Angles;
pub(crate) use polygon::best_triangulation;
pub use smooth::{SMOOTH_ABOVE_DEG, SMOOTH_BELOW_DEG, Smoothed, smooth_steiner_vertices};

use crate::balance::{BalancedTree, Links, across};
use crate::error::Error;
use crate::framework::NONE;
use crate::morton::{Cell, Grid, MortonKey, Side};
use crate::predicates::{Orientation, orientation};

use super::{EdgePieces, leaf_at};

/// How close to an edge, as a fraction of its shortest arm, a grid vertex moves onto it: every
/// side an edge still crosses then meets it at asin(0.4) ≈ 23.6° or more.
pub const EDGE_SNAP: f64 = 0.4;

/// The angles of a graph's warped mesh, degrees, outside input corners narrower than the
/// first: the mesh the stages leave is refined by off-centers to the smallest angle (which
/// [`crate::refine`] proves terminates up to about 20.7°), and a triangle whose smallest angle
/// is that has none above 180° less twice it.
pub const GRAPH_ANGLE_BOUNDS: (f64, f64) = (20.0, 140.0);

/// A graph in its separated tree: what [`triangulate_graph`] reads.
#[derive(Clone, Copy, Debug)]
pub struct GraphLeaves<'a, K: Copy> {
    /// The balanced tree, its point location by Morton position.
    pub tree: &'a BalancedTree<K>,
    /// The grid of the tree.
    pub grid: &'a Grid,
    /// `order[i]`: the vertex (index into `points`) at Morton position `i`.
    pub order: &'a [u32],
    /// The graph's vertices.
    pub points: &'a [DVec2],
    /// The graph's edges, as indices into `points`.
    pub edges: &'a [[u32; 2]],
    /// The edges cut at the sides of the leaves they pass through.
    pub pieces: &'a EdgePieces,
}

/// The triangulated leaves of a graph's tree, before the domain is cut out of them.
#[derive(Clone, Debug, PartialEq)]
pub struct GraphTriangulation {
    /// Vertex positions: the grid vertices (moved where they moved), then the crossings.
    pub vertices: Vec<DVec2>,
    /// Per vertex, the graph vertex it is (an index into the graph's points), or [`NONE`].
    pub vertex_point: Vec<u32>,
    /// Per graph vertex, its vertex.
    pub point_vertex: Vec<u32>,
    /// Triangles, counter-clockwise, leaf by leaf in Morton order.
    pub triangles: Vec<[u32; 3]>,
    /// Where each leaf's triangles start in `triangles`, and their end.
    pub leaf_triangles: Vec<usize>,
    /// Where each edge's chain starts in `chains`, and their end.
    pub chain_at: Vec<usize>,
    /// Per edge, its vertices from its first end to its second.
    pub chains: Vec<u32>,
    /// The smallest and largest angle of the triangles.
    pub angles: Angles,
}

impl GraphTriangulation {
    /// The vertices along edge `e`, from its first end to its second.
    pub fn chain(&self, e: usize) -> &[u32] {
        &self.chains[self.chain_at[e]..self.chain_at[e + 1]]
    }

    /// The triangle holding `p` on its closed area (the first found), if any: looked for in
    /// the leaf of `tree` whose square holds `p` and the two rings of leaves around it (bent
    /// sides move less than a leaf), then everywhere.
    pub fn triangle_at<K: MortonKey>(
        &self,
        tree: &BalancedTree<K>,
        grid: &Grid,
        p: DVec2,
    ) -> Option<u32> {
        let holds = |t: usize| {
            let [a, b, c] = self.triangles[t].map(|v| self.vertices[v as usize]);
            [(a, b), (b, c), (c, a)]
                .iter()
                .all(|&(u, w)| orientation(u, w, p) != Orientation::Right)
        };
        if let Some(start) = leaf_at(&tree.tree, grid, p) {
            let mut near = vec![start];
            let mut ring = 0..1;
            for _ in 0..2 {
                for k in ring.clone() {
                    for side in Side::ALL {
                        for n in across(&tree.links, near[k] as usize, side) {
                            if n != NONE && !near.contains(&n) {
                                near.push(n);
                            }
                        }
                    }
                }
                ring = ring.end..near.len();
            }
            for leaf in near {
                let range =
                    self.leaf_triangles[leaf as usize]..self.leaf_triangles[leaf as usize + 1];
                if let Some(t) = range.into_iter().find(|&t| holds(t)) {
                    return Some(t as u32);
                }
            }
        }
        (0..self.triangles.len())
            .find(|&t| holds(t))
            .map(|t| t as u32)
    }

    /// The triangles of leaf `leaf`.
    pub fn leaf(&self, leaf: usize) -> &[[u32; 3]] {
        &self.triangles[self.leaf_triangles[leaf]..self.leaf_triangles[leaf + 1]]
    }
}

/// What a grid vertex has moved onto.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Snap {
    /// Nothing: it keeps its grid position.
    Free,
    /// A graph vertex.
    Point(u32),
    /// The inside of an edge.
    Edge(u32),
}

/// Where an edge crosses a leaf side: the side's ends (the smaller first), the edge, the point.
#[derive(Clone, Copy, Debug)]
struct Crossing {
    side: [u32; 2],
    edge: u32,
    at: DVec2,
}

/// A grid vertex, by its coordinates in units of the finest level.
type GridPoint = [u128; 2];

/// The slots of a leaf's boundary, counter-clockwise from its lower-left corner: four per side,
/// at 0, 1/4, 1/2 and 3/4 of the way along it. A corner is always there; a midpoint where the
/// leaf beyond is smaller or the side is split; a quarter point where the half side beyond a
/// smaller leaf is split.
const SLOTS: usize = 16;

/// The triangulation of the leaves of a graph's separated tree, bent onto its vertices and
/// edges (see the module's description).
///
/// # Errors
/// [`Error::TooLarge`] past 32-bit indices; [`Error::WarpStuck`] where the bent leaves leave a
/// place the templates cannot fill (two vertices claiming one corner, an edge through a grid
/// vertex it could not take, a leaf with no triangulation that keeps its edges), naming it.
pub fn triangulate_graph<K: MortonKey>(
    leaves: &GraphLeaves<K>,
) -> Result<GraphTriangulation, Error> {
    let squares: Vec<[u128; 3]> = leaves
        .tree
        .tree
        .leaves
        .par_iter()
        .map(|l| square_of(l.cell))
        .collect();
    let edges_of_leaf = edges_of_leaves(leaves.pieces, squares.len());
    let (grid_points, cycles, arm) =
        split_grid((leaves.grid, &leaves.tree.links), &squares, &edges_of_leaf)?;
    let mut position: Vec<DVec2> = grid_points
        .par_iter()
        .map(|&[x, y]| leaves.grid.vertex(x, y))
        .collect();
    let home = position.clone();
    let mut snap = vec![Snap::Free; grid_points.len()];
    let point_vertex = snap_points(leaves, &cycles, &mut snap, &mut position)?;
    snap_edges(leaves, &cycles, &arm, &mut snap, &mut position);
    let grid = BentGrid {
        count: grid_points.len(),
        cycles: &cycles,
        edges_of_leaf: &edges_of_leaf,
        reach: shortest_arms(&cycles, &home),
        home,
    };
    let (crossings, per_leaf) = grid.settle(leaves, &mut snap, &mut position)?;
    let first_crossing = grid_points.len();
    let bent = Bent {
        leaves,
        snap: &snap,
        position: &position,
        crossings: &crossings,
        first_crossing: first_crossing as u32,
    };
    let mut leaf_triangles = Vec::with_capacity(per_leaf.len() + 1);
    leaf_triangles.push(0);
    let mut angles = Angles::NONE;
    for (triangles, a) in &per_leaf {
        leaf_triangles.push(leaf_triangles.last().copied().unwrap_or(0) + triangles.len());
        angles = angles.and(*a);
    }
    let triangles: Vec<[u32; 3]> = per_leaf.into_iter().flat_map(|(t, _)| t).collect();
    let (chain_at, chains) = bent.chains(&point_vertex);
    let mut vertex_point = vec![NONE; first_crossing + crossings.len()];
    for (v, s) in snap.iter().enumerate() {
        if let Snap::Point(p) = *s {
            vertex_point[v] = p;
        }
    }
    position.extend(crossings.iter().map(|c| c.at));
    Ok(GraphTriangulation {
        vertices: position,
        vertex_point,
        point_vertex,
        triangles,
        leaf_triangles,
        chain_at,
        chains,
        angles,
    })
}

/// A leaf's triangles and their angles.
type LeafTriangles = (Vec<[u32; 3]>, Angles);

/// The grid vertices and leaf cycles the bending works on.
struct BentGrid<'a> {
    /// How many grid vertices.
    count: usize,
    cycles: &'a [[u32; SLOTS]],
    edges_of_leaf: &'a LeafEdges,
    /// Per grid vertex, its shortest arm once the long sides are split.
    reach: Vec<f64>,
    /// Per grid vertex, where it lies before moving.
    home: Vec<DVec2>,
}

impl BentGrid<'_> {
    /// The crossings and every leaf's triangles. A leaf no triangulation fits sends back the
    /// vertices around it that moved by more than [`EDGE_SNAP`] of their shortest arm once the
    /// long sides were split (they moved by their reach before), which may fold it, and all is
    /// redone; a leaf that fails with none of those is refused.
    fn settle<K: MortonKey>(
        &self,
        leaves: &GraphLeaves<K>,
        snap: &mut [Snap],
        position: &mut [DVec2],
    ) -> Result<(Vec<Crossing>, Vec<LeafTriangles>), Error> {
        loop {
            let crossings = crossings(leaves, self.cycles, snap, position)?;
            check_count(self.count + crossings.len())?;
            let bent = Bent {
                leaves,
                snap,
                position,
                crossings: &crossings,
                first_crossing: self.count as u32,
            };
            let per_leaf: Vec<Result<LeafTriangles, Error>> = self
                .cycles
                .par_iter()
                .enumerate()
                .map(|(leaf, cycle)| bent.triangulate_leaf(cycle, self.edges_of_leaf.of(leaf)))
                .collect();
            let Some(first) = per_leaf.iter().position(Result::is_err) else {
                let per_leaf = per_leaf.into_iter().collect::<Result<_, _>>()?;
                return Ok((crossings, per_leaf));
            };
            let failed: Vec<usize> = (0..per_leaf.len())
                .filter(|&leaf| per_leaf[leaf].is_err())
                .collect();
            if !self.send_back(&failed, snap, position) {
                return Err(per_leaf
                    .into_iter()
                    .nth(first)
                    .and_then(Result::err)
                    .expect("a failed leaf"));
            }
        }
    }

    /// Sends back the vertices around the `failed` leaves that moved beyond their reach;
    /// whether any did.
    fn send_back(&self, failed: &[usize], snap: &mut [Snap], position: &mut [DVec2]) -> bool {
        let mut changed = false;
        for &leaf in failed {
            for v in present(&self.cycles[leaf]) {
                let v = v as usize;
                let moved = self.home[v].distance(position[v]);
                if matches!(snap[v], Snap::Edge(_)) && moved >= EDGE_SNAP * self.reach[v] {
                    snap[v] = Snap::Free;
                    position[v] = self.home[v];
                    changed = true;
                }
            }
        }
        changed
    }
}

/// A leaf's lower-left corner and side, in units of the finest level.
fn square_of<K: MortonKey>(cell: Cell<K>) -> [u128; 3] {
    let (x, y) = { cell.anchor }.decode();
    let side = 1u128 << (K::AXIS_BITS - u32::from(cell.level));
    [u128::from(x), u128::from(y), side]
}

/// Every leaf corner, sorted and once each: all the grid vertices, side midpoints included
/// (each is a corner of the smaller leaves beside it).
fn grid_points(squares: &[[u128; 3]]) -> Vec<GridPoint> {
    let mut points: Vec<GridPoint> = squares
        .par_iter()
        .flat_map_iter(|&[x, y, s]| [[x, y], [x + s, y], [x + s, y + s], [x, y + s]])
        .collect();
    points.par_sort_unstable();
    points.dedup();
    points
}

/// The grid vertices, each leaf's cycle of them, and each vertex's shortest arm before the
/// split (half the side split, for a split point).
type SplitGrid = (Vec<GridPoint>, Vec<[u32; SLOTS]>, Vec<f64>);

/// The grid vertices, each leaf's cycle of them and each one's shortest arm, once the long
/// sides of the leaves edges pass through are split: a side longer than the shortest arm at
/// one of its ends (twice it, in a balanced tree) gets its midpoint, whose arms are its
/// halves. Without it, an edge passing a vertex just beyond the vertex's reach (a fraction of
/// its shortest arm) would leave a strip that thin along the long side. The split points are
/// not counted in the other vertices' arms, so splitting does not spread along the edges.
fn split_grid(
    (grid, links): (&Grid, &[Links]),
    squares: &[[u128; 3]],
    edges_of_leaf: &LeafEdges,
) -> Result<SplitGrid, Error> {
    let corners = grid_points(squares);
    check_count(corners.len())?;
    let finder = CycleFinder {
        points: &corners,
        links,
        splits: &[],
    };
    let cycles: Vec<[u32; SLOTS]> = (0..squares.len())
        .into_par_iter()
        .map(|leaf| finder.cycle(leaf, squares[leaf]))
        .collect();
    let position: Vec<DVec2> = corners
        .par_iter()
        .map(|&[x, y]| grid.vertex(x, y))
        .collect();
    let arm = shortest_arms(&cycles, &position);
    let mut splits: Vec<(GridPoint, f64)> = (0..squares.len())
        .into_par_iter()
        .filter(|&leaf| !edges_of_leaf.of(leaf).is_empty())
        .flat_map_iter(|leaf| {
            sides(&cycles[leaf])
                .into_iter()
                .filter_map(|[u, w]| {
                    let length = position[u as usize].distance(position[w as usize]);
                    let shortest = arm[u as usize].min(arm[w as usize]);
                    let [gu, gw] = [corners[u as usize], corners[w as usize]];
                    let even = (gu[0] + gw[0]) % 2 == 0 && (gu[1] + gw[1]) % 2 == 0;
                    let middle = [(gu[0] + gw[0]) / 2, (gu[1] + gw[1]) / 2];
                    (length > shortest * 1.5 && even).then_some((middle, length / 2.0))
                })
                .collect::<Vec<_>>()
        })
        .collect();
    if splits.is_empty() {
        return Ok((corners, cycles, arm));
    }
    splits.par_sort_unstable_by(|a, b| a.0.cmp(&b.0));
    splits.dedup_by_key(|s| s.0);
    let mut points: Vec<GridPoint> = corners
        .iter()
        .copied()
        .chain(splits.iter().map(|s| s.0))
        .collect();
    points.par_sort_unstable();
    check_count(points.len())?;
    let mut new_arm = vec![f64::INFINITY; points.len()];
    for (v, p) in corners.iter().enumerate() {
        new_arm[points.binary_search(p).expect("a corner is kept")] = arm[v];
    }
    for (p, half) in &splits {
        new_arm[points.binary_search(p).expect("a split point is added")] = *half;
    }
    let split_points: Vec<GridPoint> = splits.iter().map(|s| s.0).collect();
    let finder = CycleFinder {
        points: &points,
        links,
        splits: &split_points,
    };
    let cycles = (0..squares.len())
        .into_par_iter()
        .map(|leaf| finder.cycle(leaf, squares[leaf]))
        .collect();
    Ok((points, cycles, new_arm))
}

fn check_count(count: usize) -> Result<(), Error> {
    if count >= NONE as usize {
        return Err(Error::TooLarge {
            what: "vertices",
            count,
        });
    }
    Ok(())
}

/// What finds the grid vertices around a leaf: the sorted grid vertices, the leaves' links
/// (a side has a midpoint where two leaves lie beyond it) and the sorted split points.
struct CycleFinder<'a> {
    points: &'a [GridPoint],
    links: &'a [Links],
    splits: &'a [GridPoint],
}

impl CycleFinder<'_> {
    /// The grid vertices around leaf `leaf` (square `[x, y, s]`), at its [`SLOTS`] ([`NONE`]
    /// for a point that is none): per side, from its first corner counter-clockwise, the
    /// points at 0, 1/4, 1/2 and 3/4 of the way.
    fn cycle(&self, leaf: usize, [x, y, s]: [u128; 3]) -> [u32; SLOTS] {
        let starts = [[x, y], [x + s, y], [x + s, y + s], [x, y + s]];
        let steps: [[i128; 2]; 4] = [[1, 0], [0, 1], [-1, 0], [0, -1]];
        let beyond = [Side::South, Side::East, Side::North, Side::West];
        let id = |p: &GridPoint| self.points.binary_search(p).ok().map(|v| v as u32);
        let mut cycle = [NONE; SLOTS];
        for side in 0..4 {
            let [sx, sy] = starts[side];
            let [dx, dy] = steps[side];
            let at = |along: u128| {
                [
                    (sx as i128 + dx * along as i128) as u128,
                    (sy as i128 + dy * along as i128) as u128,
                ]
            };
            cycle[side * 4] = id(&at(0)).expect("a leaf corner is a grid vertex");
            if s % 2 != 0 {
                continue;
            }
            let middle = at(s / 2);
            let paired = across(self.links, leaf, beyond[side])[1] != NONE;
            if paired || self.splits.binary_search(&middle).is_ok() {
                cycle[side * 4 + 2] = id(&middle).unwrap_or(NONE);
            }
            if s % 4 == 0 && !self.splits.is_empty() {
                for k in [1, 3] {
                    let quarter = at(k * s / 4);
                    if self.splits.binary_search(&quarter).is_ok() {
                        cycle[side * 4 + k as usize] = id(&quarter).unwrap_or(NONE);
                    }
                }
            }
        }
        cycle
    }
}

/// The grid vertices of a cycle, in order, the missing midpoints left out.
fn present(cycle: &[u32; SLOTS]) -> impl Iterator<Item = u32> + '_ {
    cycle.iter().copied().filter(|&v| v != NONE)
}

/// The sides of a cycle: each pair of consecutive grid vertices.
fn sides(cycle: &[u32; SLOTS]) -> Vec<[u32; 2]> {
    let around: Vec<u32> = present(cycle).collect();
    (0..around.len())
        .map(|i| [around[i], around[(i + 1) % around.len()]])
        .collect()
}

/// Per grid vertex, the length of the shortest leaf side running from it (its shortest arm).
fn shortest_arms(cycles: &[[u32; SLOTS]], position: &[DVec2]) -> Vec<f64> {
    let mut arm = vec![f64::INFINITY; position.len()];
    for cycle in cycles {
        for [a, b] in sides(cycle) {
            let length = position[a as usize].distance(position[b as usize]);
            for v in [a, b] {
                arm[v as usize] = arm[v as usize].min(length);
            }
        }
    }
    arm
}

/// Moves, for each graph vertex, the nearest grid vertex around its leaf onto it (the first
/// in the cycle on a tie); returns each graph vertex's grid vertex.
fn snap_points<K: MortonKey>(
    leaves: &GraphLeaves<K>,
    cycles: &[[u32; SLOTS]],
    snap: &mut [Snap],
    position: &mut [DVec2],
) -> Result<Vec<u32>, Error> {
    let chosen: Vec<(u32, u32)> = leaves
        .order
        .par_iter()
        .zip(&leaves.tree.point_leaf)
        .map(|(&p, &leaf)| {
            let at = leaves.points[p as usize];
            let nearest = present(&cycles[leaf as usize])
                .min_by(|&a, &b| {
                    let (da, db) = (
                        position[a as usize].distance_squared(at),
                        position[b as usize].distance_squared(at),
                    );
                    da.total_cmp(&db)
                })
                .expect("a leaf has corners");
            (p, nearest)
        })
        .collect();
    let mut point_vertex = vec![NONE; leaves.points.len()];
    for (p, v) in chosen {
        let at = leaves.points[p as usize];
        if snap[v as usize] != Snap::Free {
            return Err(stuck(at, "two vertices of the graph claim one corner"));
        }
        snap[v as usize] = Snap::Point(p);
        position[v as usize] = at;
        point_vertex[p as usize] = v;
    }
    Ok(point_vertex)
}

/// Moves every free grid vertex closer to an edge than [`EDGE_SNAP`] of its shortest arm onto
/// the nearest point of the edge (of the nearest edge, where two are that close).
fn snap_edges<K: MortonKey>(
    leaves: &GraphLeaves<K>,
    cycles: &[[u32; SLOTS]],
    arm: &[f64],
    snap: &mut [Snap],
    position: &mut [DVec2],
) {
    let mut near: Vec<(u32, f64, u32, DVec2)> = (0..leaves.edges.len())
        .into_par_iter()
        .flat_map_iter(|e| {
            let [a, b] = leaves.edges[e].map(|v| leaves.points[v as usize]);
            let mut found = Vec::new();
            for piece in leaves.pieces.of(e) {
                for v in present(&cycles[piece.leaf as usize]) {
                    if snap[v as usize] != Snap::Free {
                        continue;
                    }
                    let p = position[v as usize];
                    let Some(foot) = foot_inside(p, a, b) else {
                        continue;
                    };
                    let d = p.distance(foot);
                    let end_near = foot.distance(a).min(foot.distance(b)) < arm[v as usize] * 0.5;
                    if d < EDGE_SNAP * arm[v as usize] && !(end_near && d > 0.15 * arm[v as usize])
                    {
                        found.push((v, d, e as u32, foot));
                    }
                }
            }
            found
        })
        .collect();
    near.par_sort_unstable_by(|x, y| x.0.cmp(&y.0).then(x.1.total_cmp(&y.1)).then(x.2.cmp(&y.2)));
    near.dedup_by_key(|x| x.0);
    let stay = steep_pairs(leaves, cycles, &near, position);
    for (v, _, e, foot) in near {
        if stay.binary_search(&v).is_err() {
            snap[v as usize] = Snap::Edge(e);
            position[v as usize] = foot;
        }
    }
}

/// The grid vertices that stay although they are close enough to an edge: of the two ends of a
/// leaf side steeper than 45° to an edge that both would move onto it from opposite sides, the
/// farther. Their feet would lie close together along the edge and could fold the leaves at
/// their corners; the end that stays is at least a third of the side away from the edge.
fn steep_pairs<K: MortonKey>(
    leaves: &GraphLeaves<K>,
    cycles: &[[u32; SLOTS]],
    near: &[(u32, f64, u32, DVec2)],
    position: &[DVec2],
) -> Vec<u32> {
    let moving = |v: u32| {
        near.binary_search_by_key(&v, |x| x.0)
            .ok()
            .map(|k| (near[k].1, near[k].2))
    };
    let mut stay: Vec<u32> = (0..leaves.edges.len())
        .into_par_iter()
        .flat_map_iter(|e| {
            let [a, b] = leaves.edges[e].map(|v| leaves.points[v as usize]);
            let mut stay = Vec::new();
            for piece in leaves.pieces.of(e) {
                for [u, w] in sides(&cycles[piece.leaf as usize]) {
                    let (Some((du, eu)), Some((dw, ew))) = (moving(u), moving(w)) else {
                        continue;
                    };
                    let (pu, pw) = (position[u as usize], position[w as usize]);
                    let steep = (pw - pu).normalize().dot((b - a).normalize()).abs()
                        < std::f64::consts::FRAC_1_SQRT_2;
                    let opposite = orientation(a, b, pu) != orientation(a, b, pw);
                    if eu == e as u32 && ew == e as u32 && steep && opposite {
                        stay.push(if (du, u) > (dw, w) { u } else { w });
                    }
                }
            }
            stay
        })
        .collect();
    stay.par_sort_unstable();
    stay.dedup();
    stay
}

/// The nearest point to `p` on the segment `ab`, if it lies strictly between its ends.
fn foot_inside(p: DVec2, a: DVec2, b: DVec2) -> Option<DVec2> {
    let d = b - a;
    let t = (p - a).dot(d) / d.length_squared();
    (t > 0.0 && t < 1.0).then(|| a + d * t)
}

/// Whether grid vertex `v` lies on edge `e`: moved onto it or onto one of its ends.
fn on_edge(snap: &[Snap], edges: &[[u32; 2]], v: u32, e: u32) -> bool {
    match snap[v as usize] {
        Snap::Free => false,
        Snap::Point(p) => edges[e as usize].contains(&p),
        Snap::Edge(f) => f == e,
    }
}

/// Where the edges cross the sides of the leaves they pass through, away from the sides' ends,
/// sorted by side and edge.
fn crossings<K: MortonKey>(
    leaves: &GraphLeaves<K>,
    cycles: &[[u32; SLOTS]],
    snap: &[Snap],
    position: &[DVec2],
) -> Result<Vec<Crossing>, Error> {
    let found: Vec<Vec<Crossing>> = (0..leaves.edges.len())
        .into_par_iter()
        .map(|e| {
            let [a, b] = leaves.edges[e].map(|v| leaves.points[v as usize]);
            let mut found = Vec::new();
            for piece in leaves.pieces.of(e) {
                for [u, w] in sides(&cycles[piece.leaf as usize]) {
                    if on_edge(snap, leaves.edges, u, e as u32)
                        || on_edge(snap, leaves.edges, w, e as u32)
                    {
                        continue;
                    }
                    let (pu, pw) = (position[u as usize], position[w as usize]);
                    if let Some(at) = crossing(a, b, pu, pw)? {
                        found.push(Crossing {
                            side: [u.min(w), u.max(w)],
                            edge: e as u32,
                            at,
                        });
                    }
                }
            }
            Ok(found)
        })
        .collect::<Result<_, Error>>()?;
    let mut all: Vec<Crossing> = found.into_iter().flatten().collect();
    all.par_sort_unstable_by(|x, y| x.side.cmp(&y.side).then(x.edge.cmp(&y.edge)));
    all.dedup_by(|x, y| x.side == y.side && x.edge == y.edge);
    Ok(all)
}

/// Where the edge `ab` crosses the side `pu pw`, if it does away from the side's ends; an edge
/// through an end of the side, or ending on it, is a place the warp cannot bend.
fn crossing(a: DVec2, b: DVec2, pu: DVec2, pw: DVec2) -> Result<Option<DVec2>, Error> {
    let (ou, ow) = (orientation(a, b, pu), orientation(a, b, pw));
    if ou == ow && ou != Orientation::On {
        return Ok(None);
    }
    let (oa, ob) = (orientation(pu, pw, a), orientation(pu, pw, b));
    if oa == ob && oa != Orientation::On {
        return Ok(None);
    }
    let within =
        |p: DVec2, q: DVec2, r: DVec2| (r - p).dot(q - p) >= 0.0 && (r - q).dot(p - q) >= 0.0;
    for (o, p) in [(ou, pu), (ow, pw)] {
        if o == Orientation::On && within(a, b, p) {
            return Err(stuck(
                p,
                "an edge passes through a grid vertex it could not take",
            ));
        }
    }
    for (o, p) in [(oa, a), (ob, b)] {
        if o == Orientation::On && within(pu, pw, p) {
            return Err(stuck(p, "an edge ends on a leaf side"));
        }
    }
    if ou == Orientation::On
        || ow == Orientation::On
        || oa == Orientation::On
        || ob == Orientation::On
    {
        return Ok(None);
    }
    let d = pw - pu;
    let s = (a - pu).perp_dot(b - a) / d.perp_dot(b - a);
    Ok(Some(pu + d * s))
}

/// The edges with a piece in each leaf, leaf by leaf.
struct LeafEdges {
    at: Vec<usize>,
    edges: Vec<u32>,
}

impl LeafEdges {
    fn of(&self, leaf: usize) -> &[u32] {
        &self.edges[self.at[leaf]..self.at[leaf + 1]]
    }
}

fn edges_of_leaves(pieces: &EdgePieces, leaves: usize) -> LeafEdges {
    let mut pairs: Vec<(u32, u32)> = (0..pieces.at.len() - 1)
        .into_par_iter()
        .flat_map_iter(|e| pieces.of(e).iter().map(move |p| (p.leaf, e as u32)))
        .collect();
    pairs.par_sort_unstable();
    pairs.dedup();
    let mut at = vec![0usize; leaves + 1];
    for &(leaf, _) in &pairs {
        at[leaf as usize + 1] += 1;
    }
    for i in 0..leaves {
        at[i + 1] += at[i];
    }
    LeafEdges {
        at,
        edges: pairs.into_iter().map(|(_, e)| e).collect(),
    }
}

/// The bent tree: what each leaf's triangulation reads.
struct Bent<'a, K: Copy> {
    leaves: &'a GraphLeaves<'a, K>,
    snap: &'a [Snap],
    position: &'a [DVec2],
    crossings: &'a [Crossing],
    first_crossing: u32,
}

/// A corner of a bent leaf's polygon: its vertex and where it lies.
#[derive(Clone, Copy, Debug)]
struct Corner {
    vertex: u32,
    at: DVec2,
    /// The edge it crossed at, for a crossing.
    crossed: u32,
}

impl<K: MortonKey> Bent<'_, K> {
    /// The crossings on the side `u w`, as indices into `crossings`.
    fn crossings_on(&self, u: u32, w: u32) -> std::ops::Range<usize> {
        let side = [u.min(w), u.max(w)];
        let lo = self.crossings.partition_point(|c| c.side < side);
        let hi = self.crossings.partition_point(|c| c.side <= side);
        lo..hi
    }

    /// The polygon of a leaf: its grid vertices and, on each side, the crossings in order.
    fn polygon(&self, cycle: &[u32; SLOTS]) -> Vec<Corner> {
        let mut corners = Vec::with_capacity(SLOTS + 4);
        for [u, w] in sides(cycle) {
            let pu = self.position[u as usize];
            corners.push(Corner {
                vertex: u,
                at: pu,
                crossed: NONE,
            });
            let range = self.crossings_on(u, w);
            let mut on_side: Vec<Corner> = range
                .map(|k| Corner {
                    vertex: self.first_crossing + k as u32,
                    at: self.crossings[k].at,
                    crossed: self.crossings[k].edge,
                })
                .collect();
            on_side.sort_by(|x, y| {
                pu.distance_squared(x.at)
                    .total_cmp(&pu.distance_squared(y.at))
                    .then(x.vertex.cmp(&y.vertex))
            });
            corners.extend(on_side);
        }
        corners
    }

    /// The triangles of a leaf no vertex moved in and no edge crosses: the best
    /// triangulation of a square with its midpoints, one per set of midpoints.
    fn plain(&self, cycle: &[u32; SLOTS]) -> Option<(Vec<[u32; 3]>, Angles)> {
        let moved = present(cycle).any(|v| self.snap[v as usize] != Snap::Free);
        if moved
            || sides(cycle)
                .iter()
                .any(|&[u, w]| !self.crossings_on(u, w).is_empty())
        {
            return None;
        }
        if (0..4).any(|side| cycle[side * 4 + 1] != NONE || cycle[side * 4 + 3] != NONE) {
            return None;
        }
        let mask = (0..4).fold(0, |m, k| m | (usize::from(cycle[4 * k + 2] != NONE) << k));
        let (slots, angles) = &plain_templates()[mask];
        Some((slots.iter().map(|t| t.map(|s| cycle[s])).collect(), *angles))
    }

    /// Whether a polygon corner lies on edge `e`.
    fn on(&self, corner: &Corner, e: u32) -> bool {
        if corner.crossed != NONE {
            corner.crossed == e
        } else {
            on_edge(self.snap, self.leaves.edges, corner.vertex, e)
        }
    }

    /// The triangles of one leaf and their angles.
    fn triangulate_leaf(
        &self,
        cycle: &[u32; SLOTS],
        edges: &[u32],
    ) -> Result<(Vec<[u32; 3]>, Angles), Error> {
        if let Some(plain) = self.plain(cycle) {
            return Ok(plain);
        }
        let corners = self.polygon(cycle);
        let mut kept = Vec::new();
        for &e in edges {
            self.chords(&corners, e, &mut kept);
        }
        let at: Vec<DVec2> = corners.iter().map(|c| c.at).collect();
        let Some((triangles, angles)) = best_triangulation(&at, &kept) else {
            let centre = at.iter().copied().sum::<DVec2>() / at.len() as f64;
            return Err(stuck(
                centre,
                "a bent leaf has no triangulation that keeps its edges",
            ));
        };
        let triangles = triangles
            .into_iter()
            .map(|t| t.map(|i| corners[i].vertex))
            .collect();
        Ok((triangles, angles))
    }

    /// The pieces of edge `e` that cross the polygon: consecutive corners on it (in order along
    /// it) that are not neighbours around the polygon.
    fn chords(&self, corners: &[Corner], e: u32, kept: &mut Vec<[usize; 2]>) {
        let [a, b] = self.leaves.edges[e as usize].map(|v| self.leaves.points[v as usize]);
        let d = b - a;
        let mut on: Vec<(f64, usize)> = (0..corners.len())
            .filter(|&i| self.on(&corners[i], e))
            .map(|i| ((corners[i].at - a).dot(d), i))
            .collect();
        on.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        let n = corners.len();
        for pair in on.windows(2) {
            let (i, j) = (pair[0].1.min(pair[1].1), pair[0].1.max(pair[1].1));
            let neighbours = j == i + 1 || (i == 0 && j == n - 1);
            let middle = (corners[i].at + corners[j].at) * 0.5;
            // A piece whose middle lies outside the bent leaf runs through the leaf beside it
            // (the edge passed just beyond a vertex on this leaf's side): it is that leaf's.
            if !neighbours && inside(corners, middle) {
                kept.push([i, j]);
            }
        }
    }

    /// Per edge, its vertices in order from its first end to its second.
    fn chains(&self, point_vertex: &[u32]) -> (Vec<usize>, Vec<u32>) {
        let edges = self.leaves.edges;
        let mut on: Vec<(u32, f64, u32)> = Vec::new();
        for (v, s) in self.snap.iter().enumerate() {
            if let Snap::Edge(e) = *s {
                on.push((e, 0.0, v as u32));
            }
        }
        for (k, c) in self.crossings.iter().enumerate() {
            on.push((c.edge, 0.0, self.first_crossing + k as u32));
        }
        for (e, ends) in edges.iter().enumerate() {
            for &p in ends {
                on.push((e as u32, 0.0, point_vertex[p as usize]));
            }
        }
        let position = |v: u32| {
            if v >= self.first_crossing {
                self.crossings[(v - self.first_crossing) as usize].at
            } else {
                self.position[v as usize]
            }
        };
        on.par_iter_mut().for_each(|(e, t, v)| {
            let [a, b] = edges[*e as usize].map(|p| self.leaves.points[p as usize]);
            *t = (position(*v) - a).dot(b - a);
        });
        on.par_sort_unstable_by(|x, y| x.0.cmp(&y.0).then(x.1.total_cmp(&y.1)).then(x.2.cmp(&y.2)));
        let mut at = vec![0usize; edges.len() + 1];
        for &(e, _, _) in &on {
            at[e as usize + 1] += 1;
        }
        for i in 0..edges.len() {
            at[i + 1] += at[i];
        }
        (at, on.into_iter().map(|(_, _, v)| v).collect())
    }
}

/// Whether `p` lies inside the polygon of `corners` (crossings of a ray to the right).
fn inside(corners: &[Corner], p: DVec2) -> bool {
    let n = corners.len();
    let mut odd = false;
    for k in 0..n {
        let (a, b) = (corners[k].at, corners[(k + 1) % n].at);
        if (a.y > p.y) != (b.y > p.y) {
            let x = a.x + (p.y - a.y) / (b.y - a.y) * (b.x - a.x);
            if x > p.x {
                odd = !odd;
            }
        }
    }
    odd
}

/// Per set of side midpoints (bit k: the midpoint at slot 2k + 1), the best triangulation of
/// the square with them, as slots, and its angles.
fn plain_templates() -> &'static [(Vec<[usize; 3]>, Angles); 16] {
    static TEMPLATES: OnceLock<[(Vec<[usize; 3]>, Angles); 16]> = OnceLock::new();
    TEMPLATES.get_or_init(|| {
        std::array::from_fn(|mask| {
            let slots: Vec<usize> = (0..SLOTS)
                .filter(|&s| s % 4 == 0 || (s % 4 == 2 && mask & (1 << (s / 4)) != 0))
                .collect();
            let unit = [
                [0.0, 0.0],
                [0.5, 0.0],
                [1.0, 0.0],
                [1.0, 0.5],
                [1.0, 1.0],
                [0.5, 1.0],
                [0.0, 1.0],
                [0.0, 0.5],
            ];
            let at: Vec<DVec2> = slots.iter().map(|&s| DVec2::from(unit[s / 2])).collect();
            let (triangles, angles) =
                best_triangulation(&at, &[]).expect("a square with midpoints has a triangulation");
            (
                triangles.into_iter().map(|t| t.map(|i| slots[i])).collect(),
                angles,
            )
        })
    })
}

fn stuck(at: DVec2, why: &'static str) -> Error {
    Error::WarpStuck {
        x: at.x,
        y: at.y,
        why,
    }
}
