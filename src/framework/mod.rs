//! The framework: the compressed quadtree of BET §2, built from the Morton-sorted points by
//! all-nearest-smaller-values over the levels of the derived squares of adjacent points.
//!
//! Entry `e` (between points `e` and `e + 1`) has the derived square of that pair, at level
//! `d[e]`. The framework is the Cartesian tree of `d`: the square of entry `e` holds points
//! `L[e] + 1 ..= R[e]`, where `L`, `R` are the nearest strictly smaller levels left and right.
//! A square derived several times (up to 3) is kept once, from its leftmost entry.
//!
//! Nodes are stored in preorder, which for squares is the order of (first point, level): the
//! nodes whose first point is `s` form one chain, the prefix minima of `d` from entry `s` that
//! stay deeper than `d[s - 1]`. Counting chains, a prefix sum and a parallel fill build the
//! arrays without sorting.

mod ansv;

use std::ops::Range;

pub use ansv::{
    NONE, VALUE_LIMIT, nearest_at_most_right, nearest_smaller_left, nearest_smaller_right,
};

use crate::morton::Cell;
use crate::morton::MortonKey;
use crate::par::{collect_indexed, collect_segments_reversed, exclusive_scan_by};

/// A framework node: a derived square and the points inside it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FrameworkNode<K> {
    /// The square.
    pub cell: Cell<K>,
    /// First point (Morton position) inside the square.
    pub first: u32,
    /// One past the last point inside the square.
    pub end: u32,
}

/// The compressed quadtree: one node per distinct derived square, in preorder.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Framework<K> {
    /// The nodes in preorder.
    pub nodes: Vec<FrameworkNode<K>>,
    /// Index of each node's parent, [`NONE`] for the top node.
    pub parent: Vec<u32>,
}

impl<K: MortonKey> Framework<K> {
    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Whether there are no nodes (fewer than two points).
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// The points (Morton positions) inside node `u`'s square.
    pub fn points(&self, u: usize) -> Range<usize> {
        self.nodes[u].first as usize..self.nodes[u].end as usize
    }

    /// Level of node `u`'s parent, -1 for the top node.
    pub fn parent_level(&self, u: usize) -> i32 {
        match self.parent[u] {
            NONE => -1,
            p => self.nodes[p as usize].cell.level as i32,
        }
    }
}

/// Level of the derived square of each adjacent pair of strictly increasing keys.
pub fn derived_levels<K: MortonKey>(keys: &[K]) -> Vec<u8> {
    collect_indexed(keys.len().saturating_sub(1), |i| {
        keys[i].common_level(keys[i + 1])
    })
}

/// Builds the framework of strictly increasing Morton keys.
///
/// # Complexity
/// O(n) work: the nearest-smaller-values passes, one chain walk per node, one prefix sum; depth
/// O(n / P + P) for P blocks.
pub fn build_framework<K: MortonKey>(keys: &[K]) -> Framework<K> {
    assert!(
        keys.len() < u32::MAX as usize,
        "point positions must fit in u32"
    );
    debug_assert!(
        keys.windows(2).all(|w| w[0] < w[1]),
        "keys must be strictly increasing"
    );
    let d = derived_levels(keys);
    let right = nearest_smaller_right(&d);
    let chains = &Chains {
        keys,
        d: &d,
        right: &right,
    };
    let offsets = exclusive_scan_by(d.len(), |s| chains.walk(s).count());
    // Walks find a chain deepest first; preorder wants it shallowest first.
    let nodes =
        collect_segments_reversed(&offsets, |s| chains.walk(s).map(move |e| chains.node(s, e)));
    drop(right);
    let left = nearest_smaller_left(&d);
    let parent = collect_indexed(nodes.len(), |u| parent_of(u, &nodes, &d, &left, &offsets));
    Framework { nodes, parent }
}

struct Chains<'a, K> {
    keys: &'a [K],
    d: &'a [u8],
    right: &'a [u32],
}

impl<K: MortonKey> Chains<'_, K> {
    /// The entries of the nodes whose first point is `s`, deepest first.
    fn walk(&self, s: usize) -> impl Iterator<Item = usize> + '_ {
        let floor = if s == 0 { -1 } else { self.d[s - 1] as i32 };
        std::iter::successors(Some(s), |&e| {
            let r = self.right[e];
            (r != NONE).then_some(r as usize)
        })
        .take_while(move |&e| self.d[e] as i32 > floor)
    }

    fn node(&self, s: usize, entry: usize) -> FrameworkNode<K> {
        let r = self.right[entry];
        FrameworkNode {
            cell: Cell::containing(self.keys[s], self.d[entry]),
            first: s as u32,
            end: if r == NONE {
                self.keys.len() as u32
            } else {
                r + 1
            },
        }
    }
}

/// Parent of node `u`: the previous node if it starts the same chain; otherwise the square of
/// the deeper of the entries just outside `u`'s points (the pairs straddling its ends).
fn parent_of<K: MortonKey>(
    u: usize,
    nodes: &[FrameworkNode<K>],
    d: &[u8],
    left: &[u32],
    offsets: &[usize],
) -> u32 {
    let node = nodes[u];
    if u > 0 && nodes[u - 1].first == node.first {
        return (u - 1) as u32;
    }
    let before = (node.first > 0).then(|| node.first as usize - 1);
    let after = ((node.end as usize) <= d.len()).then(|| node.end as usize - 1);
    let Some(pe) = before.into_iter().chain(after).max_by_key(|&e| d[e]) else {
        return NONE;
    };
    let chain_start = left[pe].wrapping_add(1) as usize;
    let chain = &nodes[offsets[chain_start]..offsets[chain_start + 1]];
    (offsets[chain_start] + chain.partition_point(|n| n.cell.level < d[pe])) as u32
}

/// Checks the framework against its keys; returns what is wrong.
///
/// Every node's square holds exactly its points and at least two of its children's quadrants
/// hold points; parents strictly contain their children; nodes are distinct and in preorder; the
/// top node is the derived square of all points.
pub fn check<K: MortonKey>(fw: &Framework<K>, keys: &[K]) -> Result<(), String> {
    if keys.len() < 2 {
        return if fw.is_empty() {
            Ok(())
        } else {
            Err("nodes without a pair of points".into())
        };
    }
    for u in 0..fw.len() {
        check_node(fw, keys, u)?;
    }
    for u in 1..fw.len() {
        let (a, b) = (fw.nodes[u - 1], fw.nodes[u]);
        if (a.first, a.cell.level) >= (b.first, b.cell.level) {
            return Err(format!("nodes {} and {u} out of preorder", u - 1));
        }
    }
    check_every_derived_square_is_a_node(fw, keys)?;
    let tops = fw.parent.iter().filter(|&&p| p == NONE).count();
    if tops != 1 || fw.parent[0] != NONE || fw.points(0) != (0..keys.len()) {
        return Err(format!(
            "expected one top node holding every point, found {tops}"
        ));
    }
    Ok(())
}

/// Nodes are in preorder, that is sorted by (corner, level), so each derived square is found by
/// binary search.
fn check_every_derived_square_is_a_node<K: MortonKey>(
    fw: &Framework<K>,
    keys: &[K],
) -> Result<(), String> {
    for (e, pair) in keys.windows(2).enumerate() {
        let square = Cell::containing(pair[0], pair[0].common_level(pair[1]));
        let at = fw
            .nodes
            .partition_point(|n| (n.cell.anchor, n.cell.level) < (square.anchor, square.level));
        if fw.nodes.get(at).is_none_or(|n| n.cell != square) {
            return Err(format!(
                "the derived square {square:?} of points {e} and {} is no node",
                e + 1
            ));
        }
    }
    Ok(())
}

fn check_node<K: MortonKey>(fw: &Framework<K>, keys: &[K], u: usize) -> Result<(), String> {
    let Cell { anchor, level } = fw.nodes[u].cell;
    let points = fw.points(u);
    let inside = |k: &K| k.cell_anchor(level) == anchor;
    if points.is_empty() || !keys[points.clone()].iter().all(inside) {
        return Err(format!("node {u} does not hold its points {points:?}"));
    }
    let outside_before = points.start == 0 || !inside(&keys[points.start - 1]);
    let outside_after = points.end == keys.len() || !inside(&keys[points.end]);
    if !(outside_before && outside_after) {
        return Err(format!("node {u} holds points beyond {points:?}"));
    }
    let first_child = keys[points.start].cell_anchor(level + 1);
    if keys[points.end - 1].cell_anchor(level + 1) == first_child {
        return Err(format!("node {u} has fewer than two non-empty children"));
    }
    let p = fw.parent[u];
    if p != NONE {
        let p = p as usize;
        let above = fw.nodes[p].cell;
        let contained = above.level < level && above.contains(anchor);
        // The parent is the deepest node above u: the square just below it on u's path holds
        // only u's points.
        let below = above.level + 1;
        let cell = anchor.cell_anchor(below);
        let holds_only_u = |i: usize| i >= keys.len() || keys[i].cell_anchor(below) != cell;
        let no_gap =
            (points.start == 0 || holds_only_u(points.start - 1)) && holds_only_u(points.end);
        if !contained || !no_gap || p >= u {
            return Err(format!("node {u} has a wrong parent {p}"));
        }
        let between = fw.points(p);
        if between.start > points.start || between.end < points.end || between == points {
            return Err(format!(
                "parent {p} of node {u} does not strictly hold its points"
            ));
        }
    }
    Ok(())
}
