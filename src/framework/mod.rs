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
//! stay deeper than `d[s - 1]`. One stack scan per block of entries, from the right, finds
//! each chain as it pops it and writes its nodes; the blocks' nodes are then copied into place
//! after a prefix sum over the blocks. No sorting, and no array of per-entry offsets.

mod ansv;

use std::ops::Range;

pub use ansv::{
    NONE, VALUE_LIMIT, nearest_at_most_right, nearest_smaller_left, nearest_smaller_right,
};

use crate::morton::Cell;
use crate::morton::MortonKey;
use rayon::prelude::*;

use crate::par::{
    BlockScratch, SegmentWriter, collect_indexed, collect_segment_pairs_by, exclusive_scan_by,
};

/// A framework node: a derived square and the points inside it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C, packed)]
pub struct FrameworkNode<K: Copy> {
    /// The square.
    pub cell: Cell<K>,
    /// First point (Morton position) inside the square.
    pub first: u32,
    /// One past the last point inside the square.
    pub end: u32,
}

/// The compressed quadtree: one node per distinct derived square, in preorder.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Framework<K: Copy> {
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
/// O(n) work: one stack scan per block that emits the chains' nodes and finds each entry's
/// nearest smaller value to the left, then one pass that writes nodes and parents in preorder;
/// depth O(n / P + P) for P blocks.
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
    let (nodes, parent) = nodes_and_parents(keys, &d);
    Framework { nodes, parent }
}

/// Where each chain starts in the preorder of nodes, and each entry's nearest smaller value to
/// the left. Block `b` of entries emits its chains from the right, deepest node first, so its
/// nodes in preorder are its emission reversed.
struct ChainStarts {
    /// Per entry `s`, how many nodes its block had emitted once chain `s` was emitted.
    emitted: Vec<u32>,
    /// Per entry, the nearest entry to the left with a smaller level, [`NONE`] for none.
    left: Vec<u32>,
    /// Per block, where its nodes start in preorder; then the node count.
    block_start: Vec<usize>,
}

impl ChainStarts {
    /// Preorder index of the first node of chain `s`; for `s` = the entry count, the node count.
    fn start(&self, s: usize) -> usize {
        match self.emitted.get(s) {
            Some(&e) => self.block_start[s / ansv::BLOCK + 1] - e as usize,
            None => self.block_start[self.block_start.len() - 1],
        }
    }
}

/// The nodes in preorder and their parents.
///
/// Scanning a block from the right with a stack of nearest strictly smaller values to the right,
/// the stack after pushing entry `s` is the chain `s, R[s], R[R[s]], ...` as far as it lies in
/// the block; past the block it goes on through the table of the blocks after (the nearest entry
/// there below the last value is also the next one's nearest smaller value, since everything
/// between is larger). The nodes whose first point is `s` are the chain's entries deeper than
/// `d[s - 1]`.
fn nodes_and_parents<K: MortonKey>(keys: &[K], d: &[u8]) -> (Vec<FrameworkNode<K>>, Vec<u32>) {
    let after = ansv::tables_after_blocks(d);
    let before = ansv::tables_before_blocks(d);
    let mut emitted = collect_indexed(d.len(), |_| 0u32);
    // Holds who popped each entry until the block resolves it into the left answer.
    let mut left = collect_indexed(d.len(), |_| NOT_POPPED);
    let scan = |b: usize| BlockScan {
        keys,
        d,
        after: &after[b],
        before: &before[b],
        start: b * ansv::BLOCK,
    };
    let blocks = emitted
        .par_chunks_mut(ansv::BLOCK)
        .zip(left.par_chunks_mut(ansv::BLOCK));
    let emission = BlockScratch::fill(MAX_NODES_PER_BLOCK, blocks, |b, (emitted, left), out| {
        let scan = scan(b);
        scan.emit(emitted, left, out);
        scan.resolve_left(left);
    });
    let block_start = exclusive_scan_by(emission.blocks(), |b| emission.len_of(b));
    let chains = ChainStarts {
        emitted,
        left,
        block_start,
    };
    let find = ParentFinder {
        d,
        chains: &chains,
        emission: &emission,
    };
    collect_segment_pairs_by(&chains.block_start, |b, nodes, parents| {
        // In preorder: the emission reversed. A chain's first node is where the point changes.
        let mut previous = None;
        for (k, node) in emission.block(b).iter().rev().enumerate() {
            let s = b * ansv::BLOCK + node.first as usize;
            let u = chains.block_start[b] + k;
            nodes.push(FrameworkNode {
                cell: Cell::containing(keys[s], node.level),
                first: s as u32,
                end: node.end,
            });
            parents.push(if previous == Some(s) {
                (u - 1) as u32
            } else {
                find.first_parent(s)
            });
            previous = Some(s);
        }
    })
}

/// A node as a block's scan emits it: its level, its first point relative to the block, one
/// past its last point.
#[derive(Clone, Copy)]
struct Emitted {
    level: u8,
    first: u16,
    end: u32,
}

const _: () = assert!(ansv::BLOCK <= 1 << 16, "block offsets must fit in u16");

/// Finds the parent of a chain's first node.
struct ParentFinder<'a> {
    d: &'a [u8],
    chains: &'a ChainStarts,
    emission: &'a BlockScratch<Emitted>,
}

impl ParentFinder<'_> {
    /// Parent of the first node of chain `s`: the square of pair `s - 1` (the pair just after
    /// its points is never deeper, or it would continue the chain), found in its own chain by
    /// level.
    fn first_parent(&self, s: usize) -> u32 {
        if s == 0 {
            return NONE;
        }
        let pe = s - 1;
        let chain = self.chains.left[pe].wrapping_add(1) as usize;
        let block = chain / ansv::BLOCK;
        // The chain in emission order (deepest first) is the block's emission between the
        // counts after the chain and after the one before it (the next entry's).
        let to = self.chains.emitted[chain] as usize;
        let from = match chain + 1 {
            next if next < self.d.len() && next / ansv::BLOCK == block => {
                self.chains.emitted[next] as usize
            }
            _ => 0,
        };
        let level = self.d[pe];
        let shallower = self.emission.block(block)[from..to]
            .iter()
            .filter(|n| n.level < level)
            .count();
        (self.chains.start(chain) + shallower) as u32
    }
}

/// A block's nodes are its entries' squares and at most one for each level past the block (the
/// entries there that chains reach are the ones the block's table names).
const MAX_NODES_PER_BLOCK: usize = ansv::BLOCK + VALUE_LIMIT;

/// In [`BlockScan::emit`]'s record of who popped each entry: the popper has the same level, so
/// the entry's nearest smaller value to the left is the popper's.
const SAME_LEVEL: u32 = 1 << 31;

/// In that record: never popped inside the block; the answer lies before it.
const NOT_POPPED: u32 = u32::MAX;

/// Where a block's scan writes the (level, end) of each node.
type Emission<'a> = SegmentWriter<'a, Emitted>;

/// One block's scan for [`nodes_and_parents`].
struct BlockScan<'a, K> {
    keys: &'a [K],
    d: &'a [u8],
    after: &'a [u32; VALUE_LIMIT],
    before: &'a [u32; VALUE_LIMIT],
    start: usize,
}

impl<K: MortonKey> BlockScan<'_, K> {
    /// Emits the block's chains from its last entry to its first, each deepest node first, and
    /// records in `emitted` the running count after each chain. Records in `popped` (which
    /// arrives filled with [`NOT_POPPED`]) who popped each entry off the stack (block-relative,
    /// [`SAME_LEVEL`] marking an equal level), for
    /// [`BlockScan::resolve_left`]: a strictly smaller popper is the nearest smaller value to
    /// the left.
    ///
    /// The entries that entry `s` pops with a deeper level are exactly chain `s + 1`, so the
    /// chain is written as it is popped; the block's first chain is what is left on the stack.
    fn emit(&self, emitted: &mut [u32], popped: &mut [u32], nodes: &mut Emission) {
        // (level, entry) pairs, levels strictly increasing towards the top.
        let mut stack: Vec<(u8, u32)> = Vec::with_capacity(VALUE_LIMIT);
        for i in (0..emitted.len()).rev() {
            let s = self.start + i;
            let v = self.d[s];
            // The level of chain s + 1's last entry so far, while the chain may go on past the
            // block.
            let mut open_end = None;
            while let Some(&(top, entry)) = stack.last().filter(|&&(top, _)| top >= v) {
                stack.pop();
                let by = i as u32;
                if top == v {
                    popped[entry as usize - self.start] = by | SAME_LEVEL;
                    open_end = None;
                    break;
                }
                popped[entry as usize - self.start] = by;
                let end = match stack.last() {
                    Some(&(_, next)) => next + 1,
                    None => self.end_after_block(top),
                };
                nodes.push(Emitted {
                    level: top,
                    first: i as u16 + 1,
                    end,
                });
                open_end = Some(top);
            }
            if let (Some(level), true) = (open_end, stack.is_empty()) {
                self.emit_after_block(i + 1, level, v as i32, nodes);
            }
            if i + 1 < emitted.len() {
                emitted[i + 1] = nodes.len() as u32;
            }
            stack.push((v, s as u32));
        }
        if !emitted.is_empty() {
            let s = self.start;
            let floor = if s == 0 { -1 } else { self.d[s - 1] as i32 };
            self.emit_chain(floor, &stack, nodes);
            emitted[0] = nodes.len() as u32;
        }
    }

    /// One past the points of the square of an entry at `level` whose nearest smaller value to
    /// the right lies after the block.
    fn end_after_block(&self, level: u8) -> u32 {
        self.next_after_block(level)
            .map_or(self.keys.len() as u32, |(_, e)| e + 1)
    }

    /// The rest of chain `start + i` after the block, deeper than `floor`, from an entry at
    /// `level`.
    fn emit_after_block(&self, i: usize, mut level: u8, floor: i32, nodes: &mut Emission) {
        while let Some((next, _)) = self.next_after_block(level) {
            if next as i32 <= floor {
                break;
            }
            nodes.push(Emitted {
                level: next,
                first: i as u16,
                end: self.end_after_block(next),
            });
            level = next;
        }
    }

    /// The nodes of the block's first chain, deepest first: the stack from its top, then the
    /// blocks after.
    fn emit_chain(&self, floor: i32, stack: &[(u8, u32)], nodes: &mut Emission) {
        for (k, &(level, _)) in stack.iter().enumerate().rev() {
            if level as i32 <= floor {
                return;
            }
            let end = match k {
                0 => self.end_after_block(level),
                _ => stack[k - 1].1 + 1,
            };
            nodes.push(Emitted {
                level,
                first: 0,
                end,
            });
        }
        if let Some(&(level, _)) = stack.first() {
            self.emit_after_block(0, level, floor, nodes);
        }
    }

    /// Turns the record of poppers into each entry's nearest smaller value to the left, from
    /// the left so that an equal popper is resolved first.
    fn resolve_left(&self, left: &mut [u32]) {
        for i in 0..left.len() {
            left[i] = match left[i] {
                NOT_POPPED => match self.d[self.start + i] {
                    0 => NONE,
                    l => self.before[l as usize - 1].wrapping_sub(1),
                },
                p if p & SAME_LEVEL != 0 => left[(p & !SAME_LEVEL) as usize],
                p => (self.start + p as usize) as u32,
            };
        }
    }

    /// The first entry after the block with a level below `level`.
    fn next_after_block(&self, level: u8) -> Option<(u8, u32)> {
        let index = match level {
            0 => 0,
            l => self.after[l as usize - 1],
        };
        (index != 0).then(|| (self.d[index as usize - 1], index - 1))
    }
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
        if fw.nodes.get(at).is_none_or(|n| { n.cell } != square) {
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
