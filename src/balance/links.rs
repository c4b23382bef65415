//! Cross links between leaves that share a side, and the leaf of every point.
//!
//! The same-size square across each side of a child follows from its parent's: a sibling, or a
//! child of the parent's neighbour (or that neighbour itself, if it is a leaf). Squares in
//! preorder are walked in chunks, each keeping these neighbours along its path from the root,
//! so every square and leaf costs O(1) look-ups and no climbing.

use rayon::prelude::*;

use crate::framework::NONE;
use crate::morton::{Cell, MortonKey, Side};
use crate::par::{GRAIN, chunk_offsets, collect_segments_by, prefetch};
use crate::quadtree::index::{LEAF, children, path_to};
use crate::quadtree::{Quadtree, leaf_starts, with_gap_leaves};

/// A leaf's neighbours across its four sides: one leaf of the same or twice the size, the two
/// half-size leaves in increasing coordinate along the side, or none on the root's boundary.
///
/// 24 bytes instead of 32: the two half-size leaves west or east of a leaf are siblings in
/// consecutive quadrants (the east or west children of one square), so they are consecutive
/// leaves and one index flagged `PAIR` stands for both. South and north pairs are not
/// consecutive (a sibling's subtree may lie between them) and keep two slots.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Links([u32; 6]);

/// On a west or east slot: the leaf there and the next one. Leaf indices stay below it, as the
/// children index's [`LEAF`] tag already requires.
const PAIR: u32 = 1 << 31;

impl Links {
    /// A leaf with no neighbour on any side (the root alone).
    pub const NONE: Links = Links([NONE; 6]);

    /// From the leaves across each side, in [`Side::ALL`] order, as [`Links::across`] gives
    /// them: a west or east pair must be two consecutive leaves.
    pub fn new([west, east, south, north]: [[u32; 2]; 4]) -> Links {
        Links([
            Self::consecutive(west),
            Self::consecutive(east),
            south[0],
            south[1],
            north[0],
            north[1],
        ])
    }

    fn consecutive([first, second]: [u32; 2]) -> u32 {
        if second == NONE {
            return first;
        }
        debug_assert!(second == first + 1 && first < PAIR, "{first} {second}");
        first | PAIR
    }

    /// The leaves across `side`: one and [`NONE`], two smaller ones, or two [`NONE`].
    #[inline]
    pub fn across(&self, side: Side) -> [u32; 2] {
        match side {
            Side::West | Side::East => {
                let slot = self.0[side as usize];
                if slot != NONE && slot & PAIR != 0 {
                    let first = slot & !PAIR;
                    [first, first + 1]
                } else {
                    [slot, NONE]
                }
            }
            Side::South => [self.0[2], self.0[3]],
            Side::North => [self.0[4], self.0[5]],
        }
    }
}

/// The cross links of every leaf of a balanced tree.
///
/// # Complexity
/// O(k) work for k leaves, in parallel over chunks of squares.
pub fn cross_links<K: MortonKey>(tree: &Quadtree<K>) -> Vec<Links> {
    let internal = &tree.internal;
    if internal.is_empty() {
        return vec![Links::NONE; tree.leaves.len()];
    }
    let children = &children(tree);
    let chunks = chunk_offsets(internal.len(), GRAIN);
    let offsets = leaf_starts(internal, &chunks);
    collect_segments_by(&offsets, |c, out| {
        let mut path = NeighbourPath::to(tree, children, chunks[c]);
        for (i, gap) in with_gap_leaves(internal, chunks[c]..chunks[c + 1]) {
            path.enter(i as u32, internal[i].cell);
            for leaf in &tree.leaves[gap] {
                out.push(path.leaf_links(leaf.cell));
            }
        }
    })
}

/// The internal squares on the path from the root to the current one, by level, each with the
/// entries of the same-size squares across its sides: an internal index, a leaf index tagged
/// [`LEAF`] for a leaf that covers that square (of the same or a larger size), or [`NONE`]
/// outside the root.
struct NeighbourPath<'a> {
    children: &'a [[u32; 4]],
    squares: Vec<u32>,
    beside: Vec<[u32; 4]>,
}

impl<'a> NeighbourPath<'a> {
    /// The path down to the parent of internal square `i`.
    fn to<K: MortonKey>(tree: &Quadtree<K>, children: &'a [[u32; 4]], i: usize) -> Self {
        let squares = path_to(tree, i);
        let mut path = NeighbourPath {
            children,
            beside: vec![[NONE; 4]; squares.len()],
            squares,
        };
        let cell = tree.internal[i].cell;
        for level in 1..cell.level {
            let ancestor = Cell::containing(cell.anchor, level);
            path.beside[level as usize] = path.child_beside(level, ancestor.quadrant());
        }
        path
    }

    /// Makes internal square `index`, `cell`, the path's square at its level.
    fn enter<K: MortonKey>(&mut self, index: u32, cell: Cell<K>) {
        let level = cell.level as usize;
        self.squares[level] = index;
        self.beside[level] = match level {
            0 => [NONE; 4],
            _ => self.child_beside(cell.level, cell.quadrant()),
        };
        // The children of split neighbours are read next, for this square's children.
        for e in self.beside[level] {
            if e & LEAF == 0 {
                prefetch(&self.children[e as usize]);
            }
        }
    }

    /// The neighbour entries of the child in quadrant `q` (`2 * xbit + ybit`) of the path's
    /// square at `level - 1`: a sibling across the sides inside the parent; across the parent's
    /// own sides, the parent's neighbour if that is a leaf (or [`NONE`]), else its child.
    fn child_beside(&self, level: u8, q: u32) -> [u32; 4] {
        let parent = level as usize - 1;
        let siblings = self.children[self.squares[parent] as usize];
        let beside = self.beside[parent];
        let across = |e: u32, quadrant: u32| {
            if e == NONE || e & LEAF != 0 {
                e
            } else {
                self.children[e as usize][quadrant as usize]
            }
        };
        let (x_mirror, y_mirror) = (q ^ 2, q ^ 1);
        let (west, east) = if q & 2 == 0 {
            (across(beside[0], x_mirror), siblings[x_mirror as usize])
        } else {
            (siblings[x_mirror as usize], across(beside[1], x_mirror))
        };
        let (south, north) = if q & 1 == 0 {
            (across(beside[2], y_mirror), siblings[y_mirror as usize])
        } else {
            (siblings[y_mirror as usize], across(beside[3], y_mirror))
        };
        [west, east, south, north]
    }

    /// The links of a leaf whose parent is on the path.
    fn leaf_links<K: MortonKey>(&self, cell: Cell<K>) -> Links {
        let [west, east, south, north] = self.child_beside(cell.level, cell.quadrant());
        Links::new([
            leaves_facing(self.children, west, Side::West),
            leaves_facing(self.children, east, Side::East),
            leaves_facing(self.children, south, Side::South),
            leaves_facing(self.children, north, Side::North),
        ])
    }
}

/// The leaves across `side` given the entry of the same-size square there: that leaf, or, if
/// the square is split, its two children facing us (leaves, by balance).
#[inline]
fn leaves_facing(children: &[[u32; 4]], entry: u32, side: Side) -> [u32; 2] {
    if entry == NONE {
        return [NONE; 2];
    }
    if entry & LEAF != 0 {
        return [entry & !LEAF, NONE];
    }
    let [a, b] = side.opposite().children_touching();
    let split = children[entry as usize];
    let leaf = |e: u32| if e & LEAF != 0 { e & !LEAF } else { NONE };
    [leaf(split[a as usize]), leaf(split[b as usize])]
}

/// The leaf of each point, by Morton position: points and leaves are both in Morton order.
pub fn point_leaves<K: MortonKey>(tree: &Quadtree<K>) -> Vec<u32> {
    let leaves = &tree.leaves;
    (0..leaves.len() as u32)
        .into_par_iter()
        .filter(|&j| leaves[j as usize].point != NONE)
        .collect()
}
