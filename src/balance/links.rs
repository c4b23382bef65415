//! Cross links between leaves that share a side, and the leaf of every point.
//!
//! The same-size square across each side of a child follows from its parent's: a sibling, or a
//! child of the parent's neighbour (or that neighbour itself, if it is a leaf). Squares in
//! preorder are walked in chunks, each keeping these neighbours along its path from the root,
//! so every square and leaf costs O(1) look-ups and no climbing.

use rayon::prelude::*;

use crate::framework::NONE;
use crate::morton::{Cell, MortonKey, Side};
use crate::par::{DisjointWrites, GRAIN, StreamFence, chunk_offsets, prefetch, with_capacity_huge};
use crate::quadtree::Quadtree;
use crate::quadtree::index::{LEAF, children};

/// A leaf's neighbours across its four sides: one leaf of the same or twice the size, the two
/// half-size leaves in increasing coordinate along the side, or none on the root's boundary.
///
/// One slot per side, 16 bytes. Two half-size leaves across a side are siblings (the children
/// of one square facing this leaf), so the first one names the second: west or east, they are
/// in consecutive quadrants, hence consecutive leaves; south or north, the second is the
/// first's east neighbour, of its own size. A slot holds the first, flagged `PAIR` when there
/// are two; [`across`] finds the second.
///
/// Aligned to 16 bytes, so that the links are written by streaming stores.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(align(16))]
pub struct Links([u32; 4]);

/// On a slot: the leaf there is the first of two. Leaf indices stay below it, as the children
/// index's [`LEAF`] tag already requires.
const PAIR: u32 = 1 << 31;

impl Links {
    /// A leaf with no neighbour on any side (the root alone).
    pub const NONE: Links = Links([NONE; 4]);

    /// From the leaves across each side, in [`Side::ALL`] order, as [`across`] gives them: a
    /// pair must be two sibling leaves facing this one, the first west or south of the second.
    #[inline]
    pub fn new(sides: [[u32; 2]; 4]) -> Links {
        for [first, second] in &sides[..2] {
            debug_assert!(*second == NONE || *second == first + 1, "{first} {second}");
        }
        Links(sides.map(|[first, second]| {
            debug_assert!(second == NONE || first < PAIR, "{first} {second}");
            if second == NONE { first } else { first | PAIR }
        }))
    }

    /// The first side whose slot names neither a leaf below `leaves` nor none, as corrupted
    /// links would; [`across`] follows a south or north slot into the table.
    pub fn side_out_of(&self, leaves: usize) -> Option<Side> {
        Side::ALL.into_iter().find(|&side| {
            let slot = self.0[side as usize];
            let first = (slot & !PAIR) as usize;
            let last = first + usize::from(slot & PAIR != 0);
            slot != NONE && last >= leaves
        })
    }
}

/// The leaves across `side` of `leaf`, from the links of all leaves: one and [`NONE`], two
/// smaller ones, or two [`NONE`].
#[inline]
pub fn across(links: &[Links], leaf: usize, side: Side) -> [u32; 2] {
    let slot = links[leaf].0[side as usize];
    if slot == NONE || slot & PAIR == 0 {
        return [slot, NONE];
    }
    let first = slot & !PAIR;
    let second = match side {
        Side::West | Side::East => first + 1,
        Side::South | Side::North => links[first as usize].0[Side::East as usize],
    };
    [first, second]
}

/// The cross links of every leaf of a balanced tree.
///
/// # Complexity
/// O(k) work for k leaves, in parallel over chunks of squares.
pub fn cross_links<K: MortonKey>(tree: &Quadtree<K>) -> Vec<Links> {
    if tree.internal.is_empty() {
        return vec![Links::NONE; tree.leaves.len()];
    }
    cross_links_by(tree, &children(tree))
}

/// As [`cross_links`], given the tree's [`children`] index, as the crate builds it: each leaf
/// is named in at most one slot, since the leaves' gaps between internal squares follow one
/// another (checked as the index is built).
///
/// Each leaf's links are written when its parent is entered, from the entries the path keeps
/// for the parent's children: the leaves themselves are never read.
///
/// # Panics
/// If the children index does not name every leaf.
pub(crate) fn cross_links_by<K: MortonKey>(
    tree: &Quadtree<K>,
    children: &[[u32; 4]],
) -> Vec<Links> {
    let internal = &tree.internal;
    let leaves = tree.leaves.len();
    if internal.is_empty() {
        return vec![Links::NONE; leaves];
    }
    let mut links: Vec<Links> = with_capacity_huge(leaves);
    let slots = DisjointWrites::new(&mut links.spare_capacity_mut()[..leaves]);
    let chunks = chunk_offsets(internal.len(), GRAIN);
    let written: usize = (0..chunks.len() - 1)
        .into_par_iter()
        .map(|c| {
            // Streaming stores are weakly ordered: fenced before the join hands them on.
            let _fence = StreamFence;
            let mut path = NeighbourPath::to(tree, children, chunks[c]);
            let mut written = 0;
            for i in chunks[c]..chunks[c + 1] {
                let cell = internal[i].cell;
                path.enter(i as u32, cell);
                for (quadrant, &entry) in children[i].iter().enumerate() {
                    if entry & LEAF != 0 {
                        let leaf_links = path.child_links(cell.level, quadrant);
                        // SAFETY: `at < leaves` is asserted by the write. One writer per slot:
                        // each internal square is entered once, by the one chunk that holds it,
                        // and each leaf is named in at most one slot of the children index
                        // (`children` stores leaf `j` once, from the one gap of
                        // `with_gap_leaves` that holds it, whose gaps are asserted to follow one
                        // another). Any four words are `Links` (`[u32; 4]`, 16 bytes), and
                        // `Links` has no drop. The chunk's `_fence` is dropped, fencing the
                        // streaming stores, before the join hands the links on, a panic
                        // included.
                        #[allow(unsafe_code)]
                        unsafe {
                            let at = (entry & !LEAF) as usize;
                            slots.write_words_streaming(at, leaf_links.0)
                        };
                        written += 1;
                    }
                }
            }
            written
        })
        .sum();
    // Distinct leaves were written, as many as there are: all of them.
    assert_eq!(written, leaves, "the children index misses leaves");
    // SAFETY: `leaves` is the capacity asked for. Every slot below it was written: the writes
    // went to distinct slots (above), each below `leaves`, and there were `leaves` of them
    // (asserted), so they hit all of them; each chunk fenced its streaming stores before the
    // join, which orders them before this line. `slots` is no longer used.
    #[allow(unsafe_code)]
    unsafe {
        links.set_len(leaves)
    };
    links
}

/// The path from the root to the current internal square: for the square at each level, the
/// entries of the same-size squares across the four sides of each of its four children: an
/// internal index, a leaf index tagged [`LEAF`] for a leaf that covers that square (of the same
/// or a larger size), or [`NONE`] outside the root. The entries of a square's children are
/// worked out once, on entering it: its leaves' links then, and its internal children's entries
/// later, from them.
struct NeighbourPath<'a> {
    children: &'a [[u32; 4]],
    /// By level: for each quadrant of the path's square there, the entries across West, East,
    /// South and North of that child.
    beside_children: Vec<[[u32; 4]; 4]>,
}

impl<'a> NeighbourPath<'a> {
    /// The path down to the parent of internal square `i`, entered from the root (the first
    /// square in preorder) through the children index: one read a level.
    fn to<K: MortonKey>(tree: &Quadtree<K>, children: &'a [[u32; 4]], i: usize) -> Self {
        let mut path = NeighbourPath {
            children,
            beside_children: vec![[[NONE; 4]; 4]; K::AXIS_BITS as usize + 1],
        };
        let cell = tree.internal[i].cell;
        let mut square = 0;
        for level in 0..cell.level {
            let ancestor = Cell::containing(cell.anchor, level);
            if level > 0 {
                square = children[square as usize][ancestor.quadrant() as usize];
                debug_assert!(square & LEAF == 0, "an ancestor is a leaf in the index");
            }
            path.enter(square, ancestor);
        }
        path
    }

    /// Makes internal square `index`, `cell`, the path's square at its level.
    #[inline]
    fn enter<K: MortonKey>(&mut self, index: u32, cell: Cell<K>) {
        let level = cell.level as usize;
        let beside = match level {
            0 => [NONE; 4],
            _ => self.beside_children[level - 1][cell.quadrant() as usize],
        };
        let children = self.children;
        // The row of children across each side: those of a split neighbour, or the entry itself
        // for every quadrant (a leaf covers them all; none stays none).
        let row = |e: u32| {
            if e == NONE || e & LEAF != 0 {
                [e; 4]
            } else {
                children[e as usize]
            }
        };
        let [west, east, south, north] = beside.map(row);
        let own = children[index as usize];
        self.beside_children[level] = std::array::from_fn(|q| {
            let (x_mirror, y_mirror) = (q ^ 2, q ^ 1);
            let (w, e) = if q & 2 == 0 {
                (west[x_mirror], own[x_mirror])
            } else {
                (own[x_mirror], east[x_mirror])
            };
            let (s, n) = if q & 1 == 0 {
                (south[y_mirror], own[y_mirror])
            } else {
                (own[y_mirror], north[y_mirror])
            };
            [w, e, s, n]
        });
        // The children of split squares beside the children are read next, for their links.
        // A leaf's or none's entry fetches the first square's instead, which is in the cache
        // already: selecting costs less than branching on each entry.
        for entries in &self.beside_children[level] {
            for &e in entries {
                let split = if e & LEAF == 0 { e as usize } else { 0 };
                prefetch(children.as_ptr().wrapping_add(split));
            }
        }
    }

    /// The links of a leaf, child `quadrant` of the path's square at `level`.
    #[inline]
    fn child_links(&self, level: u8, quadrant: usize) -> Links {
        let [west, east, south, north] = self.beside_children[level as usize][quadrant];
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::framework::build_framework;
    use crate::quadtree::{Internal, Leaf, expand};

    fn balanced_tree() -> Quadtree<u64> {
        let mut keys: Vec<u64> = (0..500u64)
            .map(|i| i.wrapping_mul(0x9E37_79B9_7F4A_7C15))
            .collect();
        keys.sort_unstable();
        keys.dedup();
        let tree = expand(&build_framework(&keys), &keys);
        crate::balance::balance(&tree, &keys).tree
    }

    /// A tree of several chunks of internal squares: the chunks after the first start their
    /// paths below the root (`NeighbourPath::to`, whose descent a debug build checks), and the
    /// links every chunk writes by streaming stores are checked leaf by leaf.
    #[test]
    fn links_of_a_tree_of_several_chunks() {
        let mut keys: Vec<u64> = (0..40_000u64)
            .map(|i| i.wrapping_mul(0x9E37_79B9_7F4A_7C15))
            .collect();
        keys.sort_unstable();
        keys.dedup();
        let tree = expand(&build_framework(&keys), &keys);
        let balanced = crate::balance::balance(&tree, &keys);
        let internal = balanced.tree.internal.len();
        assert!(internal > 2 * GRAIN, "{internal} internal squares");
        balanced.check(&keys).unwrap();
        assert!(cross_links(&balanced.tree) == balanced.links);
    }

    #[test]
    #[should_panic(expected = "out of preorder")]
    fn squares_out_of_preorder_are_refused() {
        // The third square's leaves would start before the second's: gaps that overlap would
        // name leaves twice.
        let internal = [
            Cell::<u64>::root(),
            Cell::root().child(3),
            Cell::root().child(0).child(0),
        ]
        .map(|cell| Internal { cell, first: 0 });
        let leaf = Leaf {
            cell: Cell::root().child(1),
            point: NONE,
        };
        let tree = Quadtree {
            internal: internal.to_vec(),
            leaves: vec![leaf; 10],
        };
        cross_links(&tree);
    }

    #[test]
    #[should_panic(expected = "misses leaves")]
    fn an_index_that_misses_a_leaf_is_refused() {
        let tree = balanced_tree();
        let mut index = children(&tree);
        let slot = index
            .as_flattened_mut()
            .iter_mut()
            .find(|e| **e & LEAF != 0)
            .unwrap();
        // The root's index: an internal square, so the leaf is named nowhere.
        *slot = 0;
        cross_links_by(&tree, &index);
    }
}
