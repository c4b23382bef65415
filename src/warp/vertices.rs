//! Leaf geometry and the vertex numbering: each mesh vertex is owned by exactly one leaf, found
//! from that leaf's links alone, and numbered by a prefix sum over the leaves in Morton order.
//!
//! A leaf owns its lower-left corner, the midpoints of its south and west sides when those are
//! split, its centre when it carries two or more midpoints, and the corners on the root's top
//! and right sides that no leaf beyond could own. Every other corner or midpoint of a leaf is
//! the lower-left corner or a south/west midpoint of a neighbour, reached through one or two
//! links.

use glam::DVec2;
use rayon::prelude::*;

use super::{collect_per_leaf, leaf_offsets};
use crate::balance::{BalancedTree, Links, across};
use crate::error::Error;
use crate::mesh::NONE;
use crate::morton::{Grid, MortonKey, Side};
use crate::quadtree::Leaf;

/// The leaves, their links and the grid, with the geometric questions the warp asks of them.
pub struct LeafGeometry<'a, K: Copy> {
    leaves: &'a [Leaf<K>],
    links: &'a [Links],
    /// The leaf of each point, by Morton position.
    pub point_leaf: &'a [u32],
    grid: &'a Grid,
    /// Leaves at this level or coarser are far larger than f64's spacing anywhere in the root.
    resolved_level: Option<u8>,
    /// Leaves at this level or coarser have their templates' angles to the report's precision
    /// (see [`Self::template_accurate`]).
    template_level: Option<u8>,
    /// The grid row moved onto a short domain's top side, if any (asked once, not per leaf).
    inner_top_row: Option<u128>,
}

impl<'a, K: MortonKey> LeafGeometry<'a, K> {
    pub fn new(tree: &'a BalancedTree<K>, grid: &'a Grid) -> Self {
        LeafGeometry {
            leaves: &tree.tree.leaves,
            links: &tree.links,
            point_leaf: &tree.point_leaf,
            grid,
            resolved_level: level_spanning(grid, K::AXIS_BITS, RESOLVED_SPACINGS),
            // Cells not quite square do not have the templates' angles.
            template_level: level_spanning(grid, K::AXIS_BITS, TEMPLATE_SPACINGS)
                .filter(|_| !grid.is_anisotropic()),
            inner_top_row: grid.inner_top_row(),
        }
    }

    /// The Morton position of the point in `leaf`, or [`NONE`].
    pub fn point(&self, leaf: usize) -> u32 {
        self.leaves[leaf].point
    }

    pub fn leaves(&self) -> usize {
        self.leaves.len()
    }

    pub fn level(&self, leaf: usize) -> u8 {
        self.leaves[leaf].cell.level
    }

    /// Lower-left grid corner and side, in grid units.
    fn grid_square(&self, leaf: usize) -> (u128, u128, u128) {
        let cell = self.leaves[leaf].cell;
        let (x, y) = cell.anchor.decode();
        (
            x as u128,
            y as u128,
            1u128 << (K::AXIS_BITS - cell.level as u32),
        )
    }

    /// Lower-left and upper-right corners in input coordinates.
    pub fn rect(&self, leaf: usize) -> (DVec2, DVec2) {
        let (x, y, size) = self.grid_square(leaf);
        (self.grid.vertex(x, y), self.grid.vertex(x + size, y + size))
    }

    /// The leaves across `side`: one and [`NONE`], two smaller ones, or two [`NONE`].
    pub fn across(&self, leaf: usize, side: Side) -> [u32; 2] {
        across(self.links, leaf, side)
    }

    fn split(&self, leaf: usize, side: Side) -> bool {
        self.across(leaf, side)[1] != NONE
    }

    fn has(&self, leaf: usize, side: Side) -> bool {
        self.across(leaf, side)[0] != NONE
    }

    /// Sides carrying a midpoint, one bit per ring side (south, east, north, west).
    pub fn midpoint_mask(&self, leaf: usize) -> u8 {
        [Side::South, Side::East, Side::North, Side::West]
            .iter()
            .enumerate()
            .fold(0, |mask, (bit, &side)| {
                mask | (u8::from(self.split(leaf, side)) << bit)
            })
    }

    /// Whether `leaf` and the larger `other` across `side` start at the same coordinate along
    /// that side (so `leaf` faces the low half of `other`'s side).
    pub fn starts_together(&self, leaf: usize, other: usize, side: Side) -> bool {
        let (x, y, _) = self.grid_square(leaf);
        let (ox, oy, _) = self.grid_square(other);
        match side {
            Side::South | Side::North => x == ox,
            Side::West | Side::East => y == oy,
        }
    }

    /// Whether f64 keeps the leaf's corners, midpoints and centre apart.
    pub fn resolvable(&self, leaf: usize) -> bool {
        if self.resolved_level.is_some_and(|l| self.level(leaf) <= l) {
            return true;
        }
        let (x, y, size) = self.grid_square(leaf);
        let half = size / 2;
        let lo = self.grid.vertex(x, y);
        let mid = self.grid.vertex(x + half, y + half);
        let hi = self.grid.vertex(x + size, y + size);
        lo.x < mid.x && mid.x < hi.x && lo.y < mid.y && mid.y < hi.y
    }

    /// Whether the leaf's triangles have its template's angles to the report's precision (see
    /// [`TEMPLATE_SPACINGS`]): it is coarse enough, and its top side is not the grid row moved
    /// onto a short domain's top side (which makes it a rectangle).
    pub fn template_accurate(&self, leaf: usize) -> bool {
        let (_, y, size) = self.grid_square(leaf);
        let coarse = self.template_level.is_some_and(|l| self.level(leaf) <= l);
        coarse && self.inner_top_row != Some(y + size)
    }

    /// A point of the grid in input coordinates.
    fn vertex(&self, x: u128, y: u128) -> DVec2 {
        self.grid.vertex(x, y)
    }

    /// The leaf's square.
    pub fn cell(&self, leaf: usize) -> crate::morton::Cell<K> {
        self.leaves[leaf].cell
    }

    /// The positions of the leaf's ring labels 0–7 on the grid (corners and side midpoints,
    /// whether or not the sides are split), as the numbering places them.
    pub fn ring_positions(&self, leaf: usize) -> [DVec2; 8] {
        let (x, y, size) = self.grid_square(leaf);
        let half = size / 2;
        // Three grid lines each way: each coordinate converted once.
        let [x0, x1, x2] = [x, x + half, x + size].map(|g| self.grid.x_of(g));
        let [y0, y1, y2] = [y, y + half, y + size].map(|g| self.grid.y_of(g));
        [
            DVec2::new(x0, y0),
            DVec2::new(x1, y0),
            DVec2::new(x2, y0),
            DVec2::new(x2, y1),
            DVec2::new(x2, y2),
            DVec2::new(x1, y2),
            DVec2::new(x0, y2),
            DVec2::new(x0, y1),
        ]
    }
}

/// F64 spacings a leaf's half side spans at [`LeafGeometry::resolvable`]'s coarse levels: its
/// corners, midpoints and centre are surely distinct.
const RESOLVED_SPACINGS: f64 = 1024.0;

/// F64 spacings a leaf's half side spans at the levels whose leaves the report takes to have
/// their templates' angles ([`LeafGeometry::template_accurate`]). A grid vertex is
/// `origin + gx * unit`, rounded twice, so it is off by up to about 1.5 spacings of the root's
/// largest coordinate (2.5 on a domain's far side, which is set to the domain's own coordinate).
/// Edges along grid lines stay on them, so only diagonals turn: by up to 2e/h for an error e
/// and half side h, and an angle between two diagonals by up to 4e/h. Here that is 6·2^-16
/// radians, 0.005° (0.01° on a far side); at [`RESOLVED_SPACINGS`] it is 0.3°, which a report
/// of template angles would miss. Measuring down to 2^21 spacings made the warp's last stage
/// 2.4 times as long for 3e6 Kuzmin points, most of whose leaves lie that deep; 2^16 costs 4–7%
/// of it.
const TEMPLATE_SPACINGS: f64 = (1u64 << 16) as f64;

/// The deepest level whose half-size squares span at least `spacings` f64 spacings of the
/// largest coordinate in the root; `None` if not even the root's do.
fn level_spanning(grid: &Grid, axis_bits: u32, spacings: f64) -> Option<u8> {
    let lo = grid.origin();
    let largest = lo
        .abs()
        .max((lo + grid.sides()).abs())
        .max_element()
        .max(f64::MIN_POSITIVE);
    let spacing = largest * f64::EPSILON;
    let side = grid.sides().min_element();
    let spans = |level: u32| side / (2.0f64).powi(level as i32 + 1) >= spacing * spacings;
    (0..=axis_bits)
        .take_while(|&level| spans(level))
        .last()
        .map(|level| level as u8)
}

/// What a leaf owns besides its lower-left corner, in slot order.
mod own {
    pub const SOUTH_MID: u8 = 1;
    pub const WEST_MID: u8 = 2;
    pub const CENTRE: u8 = 4;
    pub const UPPER_LEFT: u8 = 8;
    pub const LOWER_RIGHT: u8 = 16;
    pub const UPPER_RIGHT: u8 = 32;
}

/// The vertex numbering: per leaf, what it owns and where its vertices start.
pub struct Numbering {
    owns: Vec<u8>,
    /// The first vertex each leaf owns, the total appended.
    first: Vec<u32>,
}

impl Numbering {
    /// The numbering of the leaves' vertices; where `centred` answers for a leaf (a
    /// compact-warp leaf: whether its template uses a centre), it owns its centre or not
    /// whatever its midpoints, so that no vertex is left out of every triangle.
    pub fn new<K: MortonKey>(
        geometry: &LeafGeometry<K>,
        centred: impl Fn(usize) -> Option<bool> + Sync,
    ) -> Result<Numbering, Error> {
        let owns: Vec<u8> = (0..geometry.leaves())
            .into_par_iter()
            .map(|leaf| {
                let owns = owned(geometry, leaf);
                match centred(leaf) {
                    Some(true) => owns | own::CENTRE,
                    Some(false) => owns & !own::CENTRE,
                    None => owns,
                }
            })
            .collect();
        let first = leaf_offsets(
            owns.len(),
            |leaf| 1 + owns[leaf].count_ones() as usize,
            "vertices",
        )?;
        Ok(Numbering { owns, first })
    }

    /// The coordinates of every vertex (grid positions, before any corner moves) and, for each,
    /// [`NONE`] as its input index.
    pub fn vertices<K: MortonKey>(&self, geometry: &LeafGeometry<K>) -> (Vec<DVec2>, Vec<u32>) {
        let coordinates = collect_per_leaf(&self.first, |leaf, out| {
            let (x, y, size) = geometry.grid_square(leaf);
            let half = size / 2;
            let owns = self.owns[leaf];
            let slots = [
                (own::SOUTH_MID, (x + half, y)),
                (own::WEST_MID, (x, y + half)),
                (own::CENTRE, (x + half, y + half)),
                (own::UPPER_LEFT, (x, y + size)),
                (own::LOWER_RIGHT, (x + size, y)),
                (own::UPPER_RIGHT, (x + size, y + size)),
            ];
            out.push(geometry.vertex(x, y));
            for (bit, (gx, gy)) in slots {
                if owns & bit != 0 {
                    out.push(geometry.vertex(gx, gy));
                }
            }
        });
        let inputs = (0..coordinates.len())
            .into_par_iter()
            .map(|_| NONE)
            .collect();
        (coordinates, inputs)
    }

    fn anchor(&self, leaf: u32) -> u32 {
        self.first[leaf as usize]
    }

    /// The vertex `bit` (one of [`own`]) that `leaf` owns.
    fn slot(&self, leaf: u32, bit: u8) -> u32 {
        let before = self.owns[leaf as usize] & (bit - 1);
        self.first[leaf as usize] + 1 + before.count_ones()
    }

    /// The vertices of `leaf` by ring label: LL, S-mid, LR, E-mid, UR, N-mid, UL, W-mid,
    /// centre ([`NONE`] for absent midpoints and centre).
    pub fn labels<K: MortonKey>(&self, geometry: &LeafGeometry<K>, leaf: usize) -> [u32; 9] {
        let l = leaf as u32;
        let owns = self.owns[leaf];
        let owned_or_none = |bit: u8| {
            if owns & bit != 0 {
                self.slot(l, bit)
            } else {
                NONE
            }
        };
        let [_, upper_east] = geometry.across(leaf, Side::East);
        let [_, right_north] = geometry.across(leaf, Side::North);
        [
            self.anchor(l),
            owned_or_none(own::SOUTH_MID),
            self.lower_right(geometry, l),
            if upper_east == NONE {
                NONE
            } else {
                self.anchor(upper_east)
            },
            self.upper_right(geometry, l),
            if right_north == NONE {
                NONE
            } else {
                self.anchor(right_north)
            },
            self.upper_left(geometry, l),
            owned_or_none(own::WEST_MID),
            owned_or_none(own::CENTRE),
        ]
    }

    fn lower_right<K: MortonKey>(&self, geometry: &LeafGeometry<K>, leaf: u32) -> u32 {
        let l = leaf as usize;
        match geometry.across(l, Side::East) {
            [NONE, _] => self.slot(leaf, own::LOWER_RIGHT),
            [lower, other] if other != NONE => self.anchor(lower),
            [q, _] if geometry.level(q as usize) >= geometry.level(l) => self.anchor(q),
            [q, _] if geometry.starts_together(l, q as usize, Side::East) => self.anchor(q),
            // Our lower-right corner is the midpoint of the larger leaf's west side.
            [q, _] => self.slot(q, own::WEST_MID),
        }
    }

    fn upper_left<K: MortonKey>(&self, geometry: &LeafGeometry<K>, leaf: u32) -> u32 {
        let l = leaf as usize;
        match geometry.across(l, Side::North) {
            [NONE, _] => self.slot(leaf, own::UPPER_LEFT),
            [left, other] if other != NONE => self.anchor(left),
            [q, _] if geometry.level(q as usize) >= geometry.level(l) => self.anchor(q),
            [q, _] if geometry.starts_together(l, q as usize, Side::North) => self.anchor(q),
            // Our upper-left corner is the midpoint of the larger leaf's south side.
            [q, _] => self.slot(q, own::SOUTH_MID),
        }
    }

    fn upper_right<K: MortonKey>(&self, geometry: &LeafGeometry<K>, leaf: u32) -> u32 {
        let l = leaf as usize;
        match geometry.across(l, Side::North) {
            [NONE, _] => match geometry.across(l, Side::East) {
                [NONE, _] => self.slot(leaf, own::UPPER_RIGHT),
                [_, upper] if upper != NONE => self.upper_left(geometry, upper),
                [q, _] if geometry.level(q as usize) >= geometry.level(l) => {
                    self.upper_left(geometry, q)
                }
                // A larger leaf on the east, on the root's top side: our corner is its
                // upper-left one (we cannot lie along its lower half and touch the top).
                [q, _] => self.upper_left(geometry, q),
            },
            [left, right] => {
                let t = if right != NONE { right } else { left };
                if right != NONE || geometry.level(t as usize) >= geometry.level(l) {
                    return self.lower_right(geometry, t);
                }
                // A larger leaf on the north: our corner is its lower-right one or the midpoint
                // of its south side.
                if geometry.starts_together(l, t as usize, Side::North) {
                    self.slot(t, own::SOUTH_MID)
                } else {
                    self.lower_right(geometry, t)
                }
            }
        }
    }
}

/// What `leaf` owns besides its lower-left corner.
fn owned<K: MortonKey>(geometry: &LeafGeometry<K>, leaf: usize) -> u8 {
    let mut owns = 0;
    if geometry.split(leaf, Side::South) {
        owns |= own::SOUTH_MID;
    }
    if geometry.split(leaf, Side::West) {
        owns |= own::WEST_MID;
    }
    if geometry.midpoint_mask(leaf).count_ones() >= 2 {
        owns |= own::CENTRE;
    }
    let (north, east) = (
        geometry.has(leaf, Side::North),
        geometry.has(leaf, Side::East),
    );
    if !north {
        owns |= own::UPPER_LEFT;
    }
    if !east {
        owns |= own::LOWER_RIGHT;
    }
    if !north && !east {
        owns |= own::UPPER_RIGHT;
    }
    owns
}
