//! Separation of a planar straight-line graph's features in the quadtree: the tree Bern,
//! Eppstein and Teng call T_B* (§5), in which every vertex is far from other vertices and from
//! edges not ending at it, and every edge far from edges it shares no end with.
//!
//! A square is *crowded* when the square grown by [`CLEARANCE`] times its side on every side
//! (its *reach*, a closed box) meets two features that conflict: two vertices, a vertex and an
//! edge not ending at it, or two edges with no common end. Whether two features conflict does
//! not depend on the square, and a child's reach lies in its parent's, so a crowded square's
//! parent is crowded: the crowded squares are closed under parents, and they are exactly the
//! squares the tree must split. The leaves of their 2:1 balanced closure each see, within
//! [`CLEARANCE`] sides, at most one vertex, and only edges that end at it or, with no vertex,
//! edges that pairwise share an end: in a graph cut at its acute corners, the edges of one
//! vertex, or the sides of one cap.
//!
//! The squares are tested level by level from the root, each level's children of crowded
//! squares in parallel, against R-trees of the vertices and edges; every test is a function of
//! the square and the graph alone, so the result is the same on any thread count. The work is
//! O(log(n + m)) a tested square plus the features its reach meets until two conflict: O(1)
//! beyond the search for most squares.

use glam::DVec2;
use rayon::prelude::*;
use rstar::{AABB, RTree};

use crate::morton::{Cell, Grid, MortonKey};
use crate::predicates::{Orientation, orientation};
use crate::spatial::{IndexedPoint, IndexedSegment, graph_rtrees};

/// How many sides around a leaf must be free of features its own features do not share, unless
/// the caller asks for another clearance: Bern, Eppstein and Teng's example constant.
pub const CLEARANCE: f64 = 3.0;

/// A graph's features, indexed for the searches of the crowding test.
pub struct GraphFeatures<'a> {
    points: &'a [DVec2],
    edges: &'a [[u32; 2]],
    point_tree: RTree<IndexedPoint>,
    edge_tree: RTree<IndexedSegment>,
}

/// Two features a square's reach meets that may not share one, as a point of each (an edge by
/// its first end), indices into the graph's points.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Conflict {
    /// A point of the first feature.
    pub a: u32,
    /// A point of the second.
    pub b: u32,
}

/// A feature the reach of a square meets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Feature {
    Vertex(u32),
    Edge([u32; 2]),
}

/// The features met so far in one reach; none of them conflict.
#[derive(Default)]
struct Meeting {
    vertex: Option<u32>,
    edges: Vec<[u32; 2]>,
}

impl Meeting {
    /// Adds a feature; the conflict it makes with one met before, if any.
    fn add(&mut self, feature: Feature) -> Option<Conflict> {
        match feature {
            Feature::Vertex(v) => {
                if let Some(u) = self.vertex {
                    return Some(Conflict { a: u, b: v });
                }
                self.vertex = Some(v);
                let stranger = self.edges.iter().find(|e| !e.contains(&v))?;
                Some(Conflict {
                    a: v,
                    b: stranger[0],
                })
            }
            Feature::Edge(e) => {
                if let Some(v) = self.vertex.filter(|v| !e.contains(v)) {
                    return Some(Conflict { a: v, b: e[0] });
                }
                if let Some(f) = self.edges.iter().find(|f| !shares_an_end(e, **f)) {
                    return Some(Conflict { a: f[0], b: e[0] });
                }
                self.edges.push(e);
                None
            }
        }
    }
}

/// Whether two edges end at a common vertex.
pub fn shares_an_end(e: [u32; 2], f: [u32; 2]) -> bool {
    e.iter().any(|v| f.contains(v))
}

impl<'a> GraphFeatures<'a> {
    /// Indexes the vertices `points` and the edges `edges` (indices into `points`; edges meet
    /// only at their ends).
    pub fn new(points: &'a [DVec2], edges: &'a [[u32; 2]]) -> GraphFeatures<'a> {
        let (point_tree, edge_tree) = graph_rtrees(points, edges);
        GraphFeatures {
            points,
            edges,
            point_tree,
            edge_tree,
        }
    }

    /// A conflict in the reach `[lo, hi]`, if there is one: the first the searches come to,
    /// vertices before edges.
    pub fn conflict_in(&self, lo: DVec2, hi: DVec2) -> Option<Conflict> {
        let envelope = AABB::from_corners([lo.x, lo.y], [hi.x, hi.y]);
        let mut meeting = Meeting::default();
        for p in self.point_tree.locate_in_envelope(envelope) {
            if let Some(conflict) = meeting.add(Feature::Vertex(p.data)) {
                return Some(conflict);
            }
        }
        self.edge_tree
            .locate_in_envelope_intersecting(envelope)
            .filter(|e| {
                let [a, b] = self.edges[e.data as usize];
                segment_meets_box(self.points[a as usize], self.points[b as usize], lo, hi)
            })
            .find_map(|e| meeting.add(Feature::Edge(self.edges[e.data as usize])))
    }
}

/// The reach of a square, in input coordinates: the square grown by `clearance` sides.
pub fn reach<K: MortonKey>(grid: &Grid, cell: Cell<K>, clearance: f64) -> (DVec2, DVec2) {
    let (gx, gy) = { cell.anchor }.decode();
    let (corner, side) = grid.cell_rect(gx, gy, cell.level);
    let margin = clearance * side;
    (corner - margin, corner + side + margin)
}

/// Whether the closed segment `ab` meets the closed box `[lo, hi]`, exactly: the boxes
/// overlap and the box's corners do not all lie strictly on one side of the line.
pub fn segment_meets_box(a: DVec2, b: DVec2, lo: DVec2, hi: DVec2) -> bool {
    if a.max(b).cmplt(lo).any() || a.min(b).cmpgt(hi).any() {
        return false;
    }
    let corners = [lo, DVec2::new(hi.x, lo.y), hi, DVec2::new(lo.x, hi.y)];
    let sides = corners.map(|c| orientation(a, b, c));
    !(sides.iter().all(|&s| s == Orientation::Left)
        || sides.iter().all(|&s| s == Orientation::Right))
}

/// Why the crowded squares were not all found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TooCrowded<K: Copy> {
    /// A square at the finest level the grid resolves is still crowded, by this conflict.
    Finest {
        /// The square.
        cell: Cell<K>,
        /// The conflict.
        conflict: Conflict,
    },
    /// There are more crowded squares than the budget allows; `conflict` crowds the first
    /// square of the level that went past it.
    Budget {
        /// The budget.
        limit: usize,
        /// What crowds that square.
        conflict: Conflict,
    },
}

/// The crowded squares of the graph on `grid` with reaches grown by `clearance` sides, in
/// preorder, tested level by level down to `finest`; a square still crowded there is refused,
/// and so are more than `budget` crowded squares (a level's squares are counted before their
/// children are made).
pub fn crowded_squares<K: MortonKey>(
    grid: &Grid,
    features: &GraphFeatures,
    clearance: f64,
    (finest, budget): (u8, usize),
) -> Result<Vec<Cell<K>>, TooCrowded<K>> {
    let mut split = Vec::new();
    let mut frontier = vec![Cell::<K>::root()];
    for level in 0..=finest {
        let tested: Vec<(Cell<K>, Option<Conflict>)> = frontier
            .par_iter()
            .map(|&cell| {
                let (lo, hi) = reach(grid, cell, clearance);
                (cell, features.conflict_in(lo, hi))
            })
            .collect();
        let crowded: Vec<Cell<K>> = tested
            .iter()
            .filter(|(_, c)| c.is_some())
            .map(|&(cell, _)| cell)
            .collect();
        if level == finest
            && let Some(&(cell, Some(conflict))) = tested.iter().find(|(_, c)| c.is_some())
        {
            return Err(TooCrowded::Finest { cell, conflict });
        }
        if crowded.is_empty() {
            break;
        }
        if split.len() + crowded.len() > budget {
            let conflict = tested
                .iter()
                .find_map(|&(_, c)| c)
                .expect("a crowded square has a conflict");
            return Err(TooCrowded::Budget {
                limit: budget,
                conflict,
            });
        }
        frontier = crowded
            .par_iter()
            .flat_map_iter(|&cell| (0..4).map(move |q| cell.child(q)))
            .collect();
        split.extend(crowded);
    }
    split.par_sort_unstable_by_key(|c| (c.anchor, c.level));
    Ok(split)
}
