//! Well-separated point cells: the smallest balanced tree in which every point's leaf sits at the
//! centre of a 5×5 block of unsplit same-size leaves holding no other point (rules R1–R3 of
//! `algorithms/beg-quadtree-meshing.md` §2.2), the tree the warp needs.
//!
//! In terms of split squares the rules read:
//! * R1: a square holding two points is split (the unbalanced tree's internal squares);
//! * R2: balance (see [`super::balance_closure`]);
//! * R3b: every split square holding a point has its 8 same-size neighbours split (so the 5×5
//!   blocks around its children are squares of the tree);
//! * R3a, c, d: a point's leaf is split if its 5×5 block holds a split square, another point, or
//!   sticks out of the root.
//!
//! On a given domain ([`DomainSides`]) the block of a point on a side is cut at that side, and
//! only there may it reach the root's edge; the top side of a domain shorter than the root lies
//! inside it, and no other block may cross it. Once the points settle, a [`Band`] of equal leaves
//! lines that side (their parents split), and the points near it settle again.
//!
//! Every rule only adds splits, so their least fixed point is unique. The split squares holding
//! a point are the squares of its path above its leaf, so the state is each point's leaf level
//! and the set of split squares, found in incremental rounds:
//! 1. the points whose rules may newly fire are settled, in parallel: each leaf goes down past
//!    split squares and past squares whose block is crowded (by points and the root only in the
//!    first round: that crowding only lessens going down);
//! 2. the paths they passed and the rings of the paths' squares (R3b) are split, and closed
//!    under balance;
//! 3. the points whose leaf or block got a new split square are the next round's.
//!
//! The result does not depend on the thread count or on the order splits are found in.

use rayon::prelude::*;

use super::slack::SlackVec;
use super::split_set::{
    KeyMap, Rect, SplitSet, Squares, at_position, grid_position, last_position, rect_squares,
    window_tiles,
};
use super::{BalancedTree, linked_tree};
use crate::framework::NONE;
use crate::morton::{Cell, GUARD_LEVELS, Grid, MortonKey};
use crate::par::collect_indexed;
use crate::quadtree::Quadtree;
use glam::DVec2;

/// What a point's leaf keeps clear around it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Separation {
    /// The 5×5 block of same-size leaves centred on the point's leaf holds no other point
    /// (rules R1–R3): the tree of the block warp and of the nonobtuse split.
    #[default]
    Block,
    /// The 2×2 block of same-size leaves around the leaf's corner nearest the point (the
    /// corner the warp moves, see [`nearest_corner`]) holds no other point, and no other
    /// point's block shares a leaf with it: the compact warp's tree, about a third the size.
    /// On the root square, or a given domain whose sides inside the root are grid lines (a
    /// rectangle cut into cells, see [`crate::morton::Grid::on_domain_cells`]),
    /// where the block of a point on a side is cut there.
    Corner,
}

/// The well-separated refinement of `tree`, with links and point location.
///
/// Points must be at least a few finest-grid cells apart for their blocks to be separable; the
/// guard levels of [`crate::morton`] give 16. Squares at the finest level are never split.
///
/// # Complexity
/// Expected O(k + n log n) work for k output squares and n points, plus O(L) per round for L
/// levels: membership is hashed (bit masks over tiles of 8×8 squares), a round costs what it
/// adds and the points it moves, the first one a galloping search per point and level for
/// crowding points, and the preorder comes from a depth-first walk. Typical inputs need 4–15
/// rounds; a chain of points placed so that each split forces the next one takes a round per
/// point, each as cheap as the splits it adds.
pub fn separate<K: MortonKey>(tree: &Quadtree<K>, keys: &[K]) -> BalancedTree<K> {
    separate_with(tree, keys, Separation::Block)
}

/// [`separate`] by the given rule, on the root square.
pub fn separate_with<K: MortonKey>(
    tree: &Quadtree<K>,
    keys: &[K],
    separation: Separation,
) -> BalancedTree<K> {
    let (separated, _) =
        separate_in(tree, keys, None, u8::MAX, separation).expect("no band without a domain");
    separated
}

/// [`separate`] in a given domain (see [`DomainSides`]): a point's block may stick out of the
/// root only across a side the point lies on, and is cut there. When the domain's top side lies
/// inside the root, the tree also gets a [`Band`] along it; that band must be no finer than
/// `max_band_level`.
///
/// # Errors
/// [`BandError::TooFine`] when the band must be finer than `max_band_level`, and
/// [`BandError::NotGraded`] when the sides' graded levels do not hold.
pub fn separate_in<K: MortonKey>(
    tree: &Quadtree<K>,
    keys: &[K],
    sides: Option<&DomainSides>,
    max_band_level: u8,
    separation: Separation,
) -> Result<(BalancedTree<K>, Option<Band>), BandError> {
    let rules = Rules::new(sides).separating(separation);
    assert!(
        separation == Separation::Block || rules.top.is_none_or(|t| t.floor == t.ceil),
        "corner separation needs a domain whose sides are grid lines"
    );
    let mut set = SplitSet::new();
    set.insert_closed(tree.internal.iter().map(|s| Squares::one(s.cell)));
    if separation == Separation::Corner {
        set.insert_closed(squares_across_lines::<K>(rules.lines()));
    }
    let graded = sides.and_then(|s| s.graded_top).zip(rules.top);
    if let Some(((coarsest, _), top)) = graded {
        set.insert_closed(side_squares::<K>(top, rules.right, coarsest - 1));
    }
    let mut leaves = PointLeaves::new(keys.len());
    let mut moves = first_moves(&set, &rules, tree, keys);
    let mut band = None;
    loop {
        while !moves.is_empty() {
            let demanded: Vec<Vec<Squares<K>>> = moves
                .par_chunks(MOVES_PER_TASK)
                .map(|chunk| {
                    let mut out = Vec::new();
                    for &m in chunk {
                        rules.demands(&set, keys, m, &mut out);
                    }
                    out
                })
                .collect();
            // The two updates touch different structures.
            let (added, ()) = rayon::join(
                || set.insert_closed(demanded.iter().flatten().copied()),
                || leaves.record(keys, &moves),
            );
            let candidates = leaves.near(&added);
            moves = settle_all(&set, &rules, keys, &leaves.level, &candidates);
        }
        // Once the points are settled, the band goes in as split squares and the points near
        // it settle again; nothing that follows is finer than the band inside it.
        let Some(top) = rules
            .top
            .filter(|_| band.is_none() && separation == Separation::Block)
        else {
            break;
        };
        if let Some(((coarsest, finest), _)) = graded {
            if crossed_finer_than(&set, top, rules.right, finest) {
                return Err(BandError::NotGraded);
            }
            // The grid line at or just below the side, which every crossing leaf starts on.
            let side = 1u128 << (K::AXIS_BITS - coarsest as u32);
            let row = top.floor / side;
            band = Some(Band {
                level: coarsest,
                finest,
                top_row: row * side,
                row: u64::try_from(row).unwrap_or(u64::MAX),
            });
            break;
        }
        let chosen = band_for(&set, top);
        if chosen.level > max_band_level {
            let point = finest_near(keys, &leaves.level, top);
            return Err(BandError::TooFine {
                level: chosen.level,
                point,
            });
        }
        band = Some(chosen);
        let added = set.insert_closed(chosen.parents::<K>());
        let candidates = leaves.near(&added);
        moves = settle_all(&set, &rules, keys, &leaves.level, &candidates);
    }
    Ok((linked_tree(&set.preorder(), keys), band))
}

/// Why [`separate_in`] gave no band.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BandError {
    /// The band would be of `level`, finer than allowed; the Morton position of a point whose
    /// leaf near the side is that fine.
    TooFine {
        /// The band's level.
        level: u8,
        /// The point.
        point: usize,
    },
    /// A leaf finer than the sides' graded levels allow meets the top side.
    NotGraded,
}

/// The squares of `level` that the top side crosses or touches from below, and those on either
/// side of the right side's line: split, they keep leaves meeting the sides at finer levels.
fn side_squares<K: MortonKey>(top: InnerTop, right: Option<u128>, level: u8) -> Vec<Squares<K>> {
    let shift = K::AXIS_BITS - level as u32;
    let last = last_position(level);
    let row = u64::try_from(top.ceil.div_ceil(1 << shift).saturating_sub(1)).unwrap_or(last);
    let column = right.map_or(last, |line| {
        u64::try_from(line.div_ceil(1 << shift))
            .unwrap_or(last)
            .min(last)
    });
    let mut squares = rect_squares(
        level,
        Rect {
            columns: (0, column),
            rows: (row, row),
        },
    );
    if right.is_some() {
        squares.extend(rect_squares(
            level,
            Rect {
                columns: (column.saturating_sub(1), column),
                rows: (0, row),
            },
        ));
    }
    squares
}

/// The squares that a cells grid's domain sides inside the root (right and top, grid lines in
/// finest units, see [`Rules::lines`]) cross, at the finest level where they cross any, along
/// the domain: split with what balance forces (their parents among it), they leave no leaf
/// across a side.
pub(super) fn squares_across_lines<K: MortonKey>(lines: [Option<u128>; 2]) -> Vec<Squares<K>> {
    let full = 1u128 << K::AXIS_BITS;
    let [right, top] = lines;
    let mut squares = Vec::new();
    for (line, along, vertical) in [
        (right, top.unwrap_or(full), true),
        (top, right.unwrap_or(full), false),
    ] {
        let Some(line) = line.filter(|&l| l > 0 && l < full) else {
            continue;
        };
        // The coarsest level whose grid lines include this one, and the level above it.
        let level = (K::AXIS_BITS - line.trailing_zeros()) as u8 - 1;
        let side = 1u128 << (K::AXIS_BITS - level as u32);
        let across = u64::try_from(line / side).expect("a position within the root");
        let span = (
            0,
            u64::try_from((along - 1) / side).expect("a position within the root"),
        );
        let rect = match vertical {
            true => Rect {
                columns: (across, across),
                rows: span,
            },
            false => Rect {
                columns: span,
                rows: (across, across),
            },
        };
        squares.extend(rect_squares(level, rect));
    }
    squares
}

/// Whether `square` lies across one of the domain sides `lines` (right, top; grid lines in
/// finest units) and starts before the other, so reaches into the domain: one of
/// [`squares_across_lines`] or an ancestor.
pub(super) fn lies_across<K: MortonKey>(square: Cell<K>, lines: [Option<u128>; 2]) -> bool {
    let (x, y) = { square.anchor }.decode();
    let (x, y) = (u128::from(x), u128::from(y));
    let side = 1u128 << (K::AXIS_BITS - u32::from(square.level));
    let full = 1u128 << K::AXIS_BITS;
    let [right, top] = lines;
    let across = |at: u128, line: Option<u128>| line.is_some_and(|l| at < l && l < at + side);
    (across(x, right) && y < top.unwrap_or(full)) || (across(y, top) && x < right.unwrap_or(full))
}

/// Whether a split square of level `finest` or finer crosses the top side left of the right
/// side's line, so that leaves finer than `finest` meet the side in the domain.
fn crossed_finer_than<K: MortonKey>(
    set: &SplitSet<K>,
    top: InnerTop,
    right: Option<u128>,
    finest: u8,
) -> bool {
    let right = right.unwrap_or(u128::MAX);
    (finest..=K::AXIS_BITS as u8).any(|level| {
        let shift = K::AXIS_BITS - level as u32;
        set.squares_at(level).any(|cell| {
            let (x, y) = grid_position(cell);
            let bottom = u128::from(y) << shift;
            (u128::from(x) << shift) < right
                && bottom < top.ceil
                && bottom + (1u128 << shift) > top.floor
        })
    })
}

/// The Morton position of the point with the finest leaf among those whose leaf lies within
/// four of its sides (or the grid's guard cells) below the domain's top side `top`, the first
/// such if several: the point that made the band so fine.
fn finest_near<K: MortonKey>(keys: &[K], level: &[u8], top: InnerTop) -> usize {
    (0..keys.len())
        .into_par_iter()
        .filter(|&p| {
            let shift = K::AXIS_BITS - level[p] as u32;
            let (_, y) = grid_position(Cell::containing(keys[p], level[p]));
            let upper = (u128::from(y) + 1) << shift;
            let reach = (4u128 << shift).max(2 << GUARD_LEVELS);
            top.floor.saturating_sub(upper) < reach
        })
        .max_by_key(|&p| (level[p], std::cmp::Reverse(p)))
        .unwrap_or(0)
}

/// Which sides of a given domain each point lies on, and where the domain's top side lies when
/// it is not the root's: what the separation rules need of a domain that points may touch. The
/// domain must be at least as wide as it is tall, so that its left and bottom sides are the
/// root's and its right side the root's or a grid line inside it (see
/// [`crate::morton::Grid::on_domain_columns`]).
#[derive(Clone, Debug, Default)]
pub struct DomainSides {
    /// Per point in Morton order, a bit per side it lies on: [`ON_LEFT`], [`ON_BOTTOM`],
    /// [`ON_RIGHT`], [`ON_TOP`].
    pub on: SlackVec<u8>,
    /// The domain's top side in finest-grid units when it lies inside the root.
    pub inner_top: Option<f64>,
    /// The domain's right side, a grid line (finest units), when it lies inside the root.
    pub inner_right: Option<u128>,
    /// The levels from which to which leaves may meet the top side, all of them with their
    /// bottoms on one grid line just below it (see [`Band`]), when the grid was chosen so; a
    /// uniform band lines the side otherwise.
    pub graded_top: Option<(u8, u8)>,
}

impl DomainSides {
    /// The sides each of `points` (in Morton order, `order[i]` the input index of the `i`-th)
    /// lies on, for a grid on a given domain; `None` for a grid around the points.
    pub fn of(points: &[DVec2], order: &[u32], grid: &Grid) -> Option<DomainSides> {
        let (lo, hi) = grid.given_domain()?;
        let on =
            collect_indexed(order.len(), |i| sides_of(points[order[i] as usize], lo, hi)).into();
        Some(DomainSides {
            on,
            inner_top: grid.inner_top(),
            inner_right: grid.inner_right(),
            graded_top: None,
        })
    }
}

/// The sides of the rectangle `[lo, hi]` that `p` lies on, a bit each ([`ON_LEFT`],
/// [`ON_BOTTOM`], [`ON_RIGHT`], [`ON_TOP`]).
pub fn sides_of(p: DVec2, lo: DVec2, hi: DVec2) -> u8 {
    [
        (p.x == lo.x, ON_LEFT),
        (p.y == lo.y, ON_BOTTOM),
        (p.x == hi.x, ON_RIGHT),
        (p.y == hi.y, ON_TOP),
    ]
    .into_iter()
    .filter(|&(on, _)| on)
    .fold(0, |bits, (_, side)| bits | side)
}

/// The point lies on the domain's left side.
pub const ON_LEFT: u8 = 1;
/// The point lies on the domain's bottom side.
pub const ON_BOTTOM: u8 = 2;
/// The point lies on the domain's right side.
pub const ON_RIGHT: u8 = 4;
/// The point lies on the domain's top side.
pub const ON_TOP: u8 = 8;

/// A domain's top side inside the root, in finest-grid units: the integers around it.
#[derive(Clone, Copy, Debug)]
struct InnerTop {
    exact: f64,
    floor: u128,
    ceil: u128,
}

impl InnerTop {
    fn new(exact: f64) -> Self {
        InnerTop {
            exact,
            floor: exact.floor() as u128,
            ceil: exact.ceil() as u128,
        }
    }
}

/// The leaves along a domain's top side that lies inside the root, and the grid row `top_row`
/// (in finest units) that moves onto it for every column at once.
///
/// Graded (`finest > level`, see [`DomainSides::graded_top`]): the side lies less than 1/16 of
/// a `finest` leaf above a grid line of `level`, so every leaf it crosses, of a level from
/// `level` to `finest`, starts on that line, `top_row`; those leaves go, and the leaves below, of
/// at least half their size, stretch by less than 1/8.
///
/// Uniform: every leaf the side crosses (or touches from below) is of `level`, and `top_row` is
/// that row's top when the side keeps at least half of it (its leaves become rectangles at least
/// half as tall as wide), its bottom when the side keeps less than 1/16 of it (those leaves go,
/// and the leaves below stretch by less than 1/8). `level` is the coarsest where one of those
/// holds and no leaf is finer in the row; the leaves below it are graded as usual.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Band {
    /// The level of the band's leaves (the coarsest of them when graded).
    pub level: u8,
    /// The finest level of the band's leaves: `level` unless graded.
    pub finest: u8,
    /// The grid row (finest units) that lies on the domain's top side.
    pub top_row: u128,
    /// The band's row among the rows of `level`.
    row: u64,
}

impl Band {
    /// The squares whose split makes the band's leaves.
    fn parents<K: MortonKey>(&self) -> Vec<Squares<K>> {
        let level = self.level - 1;
        rect_squares(
            level,
            Rect {
                columns: (0, last_position(level)),
                rows: (self.row / 2, self.row / 2),
            },
        )
    }
}

/// The level of the coarsest band a domain's top side at `inner_top` (finest grid units, as
/// [`DomainSides::inner_top`]) allows on an `axis_bits` grid, whatever the points: the band's
/// leaves can be no larger than the domain is tall.
pub fn coarsest_band_level(inner_top: f64, axis_bits: u32) -> u8 {
    allowed_from(InnerTop::new(inner_top), 1, axis_bits).level
}

/// The band along `top` for the split squares `set`: the coarsest level at which no split
/// square of that level or finer meets the band's row, and the side cuts that row in a shape
/// the templates keep within the angle bounds (at most three levels finer than the first).
fn band_for<K: MortonKey>(set: &SplitSet<K>, top: InnerTop) -> Band {
    let axis_bits = K::AXIS_BITS;
    let mut level = 1;
    // Each split square pushes the band below the finest level at which it meets the band.
    for l in (1..=axis_bits as u8).rev() {
        if l < level {
            break;
        }
        let from = level;
        let meets = set
            .squares_at(l)
            .filter_map(|cell| finest_meeting(cell, top, from))
            .max();
        if let Some(m) = meets {
            level = level.max(m + 1);
        }
    }
    allowed_from(top, level, axis_bits)
}

/// The band at the first level from `level` on where the side cuts the row in an allowed shape.
fn allowed_from(top: InnerTop, mut level: u8, axis_bits: u32) -> Band {
    loop {
        let band = band_at(top, level, axis_bits);
        if band.top_row != u128::MAX || level as u32 >= axis_bits {
            return band;
        }
        level += 1;
    }
}

/// The band row at `level`, with `top_row` [`u128::MAX`] when the side cuts it in a shape not
/// allowed (keeping between 1/16 and 1/2 of it, or less with no row below).
fn band_at(top: InnerTop, level: u8, axis_bits: u32) -> Band {
    let side = 1u128 << (axis_bits - level as u32);
    // The row whose leaves the side crosses or touches from below.
    let row = top.ceil.div_ceil(side).saturating_sub(1);
    let bottom = row * side;
    let kept = (top.exact - bottom as f64) / side as f64;
    let top_row = if kept >= 0.5 {
        bottom + side
    } else if kept < 1.0 / 16.0 && row > 0 {
        bottom
    } else {
        u128::MAX
    };
    Band {
        level,
        finest: level,
        top_row,
        row: u64::try_from(row).unwrap_or(u64::MAX),
    }
}

/// The finest level from `from` to `cell`'s own at which `cell`, a split square below the side
/// `top`, meets the band's row, if any. The row at level j lies within one of its sides below
/// the side, so a square further below meets only coarser rows.
fn finest_meeting<K: MortonKey>(cell: Cell<K>, top: InnerTop, from: u8) -> Option<u8> {
    let axis_bits = K::AXIS_BITS;
    let shift = axis_bits - cell.level as u32;
    let (_, y) = grid_position(cell);
    let bottom = u128::from(y) << shift;
    if bottom >= top.ceil || cell.level < from {
        return None;
    }
    let upper = bottom + (1u128 << shift);
    let distance = top.floor.saturating_sub(upper);
    // Rows of side at most half the distance lie wholly above the square.
    let bits = 128 - distance.leading_zeros();
    let mut level = (axis_bits + 1).saturating_sub(bits).min(cell.level as u32) as u8;
    loop {
        let side = 1u128 << (axis_bits - level as u32);
        let row_bottom = top.ceil.div_ceil(side).saturating_sub(1) * side;
        if row_bottom < upper {
            return Some(level);
        }
        if level <= from {
            return None;
        }
        level -= 1;
    }
}

/// The block rules R3a, c, d as a domain shapes them.
pub(super) struct Rules<'a> {
    sides: Option<&'a DomainSides>,
    top: Option<InnerTop>,
    right: Option<u128>,
    separation: Separation,
}

impl<'a> Rules<'a> {
    pub(super) fn new(sides: Option<&'a DomainSides>) -> Self {
        let top = sides.and_then(|s| s.inner_top).map(InnerTop::new);
        let right = sides.and_then(|s| s.inner_right);
        Rules {
            sides,
            top,
            right,
            separation: Separation::Block,
        }
    }

    pub(super) fn separating(self, separation: Separation) -> Self {
        Rules { separation, ..self }
    }

    /// The domain's right and top sides where they are grid lines inside the root (finest
    /// units): what a corner block may not cross.
    pub(super) fn lines(&self) -> [Option<u128>; 2] {
        [self.right, self.top.map(|t| t.floor)]
    }

    /// The squares of point `i`'s 5×5 block around `cell` that the rules look at: all of them,
    /// less those beyond a domain side the point lies on; `None` when the block crosses the
    /// root's side or the domain's top side elsewhere (the point's square must then be split).
    fn window<K: MortonKey>(&self, i: usize, cell: Cell<K>, key: K) -> Option<Rect> {
        let on = self.on(i);
        if self.separation == Separation::Corner {
            return corner_block(cell, key, on, self.lines());
        }
        let (x, y) = grid_position(cell);
        let last = last_position(cell.level);
        let low = |c: u64, on_side: bool| match c.checked_sub(2) {
            Some(c) => Some(c),
            None => on_side.then_some(0),
        };
        let high = |c: u64, on_side: bool| match c.checked_add(2).filter(|&c| c <= last) {
            Some(c) => Some(c),
            None => on_side.then_some(last),
        };
        let shift = K::AXIS_BITS - cell.level as u32;
        let right = match self.right {
            None => high(x, on & ON_RIGHT != 0)?,
            // The columns beyond a point on the side lie outside the domain.
            // The point's square must not straddle the side's line.
            Some(line) if on & ON_RIGHT != 0 => {
                let whole = line.trailing_zeros() >= shift;
                let before = (line >> shift).checked_sub(1)?;
                u64::try_from(before).ok().filter(|_| whole)?
            }
            Some(line) => ((u128::from(x) + 3) << shift <= line).then_some(x + 2)?,
        };
        let columns = (low(x, on & ON_LEFT != 0)?, right);
        let bottom = low(y, on & ON_BOTTOM != 0)?;
        let top = match self.top {
            None => high(y, on & ON_TOP != 0)?,
            // The rows above a point on the side lie outside the domain.
            Some(_) if on & ON_TOP != 0 => y,
            Some(t) => ((u128::from(y) + 3) << shift <= t.floor).then_some(y + 2)?,
        };
        Some(Rect {
            columns,
            rows: (bottom, top),
        })
    }
}

impl Rules<'_> {
    /// Appends the squares move `m` demands that are not split yet, by the rules' separation.
    pub(super) fn demands<K: MortonKey>(
        &self,
        set: &SplitSet<K>,
        keys: &[K],
        m: Move,
        out: &mut Vec<Squares<K>>,
    ) {
        match self.separation {
            Separation::Block => demands_of(set, keys, m, out),
            Separation::Corner => corner_demands_of(set, self, keys, m, out),
        }
    }

    /// The domain sides point `i` lies on ([`ON_LEFT`], ...), none on the root square.
    pub(super) fn on(&self, i: usize) -> u8 {
        self.sides.map_or(0, |s| s.on[i])
    }
}

/// Moves whose demands one task gathers.
const MOVES_PER_TASK: usize = 256;

/// A point whose leaf went down from level `from` to level `to`; the squares of its path
/// above level `split` were split already.
#[derive(Clone, Copy)]
pub(super) struct Move {
    pub(super) point: u32,
    pub(super) from: u8,
    pub(super) split: u8,
    pub(super) to: u8,
}

/// The first moves: each point from the root down past its leaf in the unbalanced tree (split
/// already) and every level whose block is crowded by points or the root (R3c, d), then as
/// [`descend`] goes. Crowding by points only lessens going down, so later rounds skip it.
fn first_moves<K: MortonKey>(
    set: &SplitSet<K>,
    rules: &Rules,
    tree: &Quadtree<K>,
    keys: &[K],
) -> Vec<Move> {
    tree.leaves
        .par_iter()
        .filter(|leaf| leaf.point != NONE)
        .map(|leaf| {
            let i = leaf.point as usize;
            let split = walk(set, keys[i], leaf.cell.level);
            let level = clear_of_points(rules, keys, i, split);
            Move {
                point: leaf.point,
                from: 0,
                split,
                to: descend(set, rules, keys, i, level),
            }
        })
        .collect()
}

/// Settles each candidate point against the current split squares; returns those that moved.
pub(super) fn settle_all<K: MortonKey>(
    set: &SplitSet<K>,
    rules: &Rules,
    keys: &[K],
    level: &[u8],
    candidates: &[u32],
) -> Vec<Move> {
    settle_against(set, rules, keys, level, (candidates, false))
}

/// [`settle_all`], and with `points` also against the other points (for points whose leaf
/// other points may crowd anew).
pub(super) fn settle_against<K: MortonKey>(
    set: &SplitSet<K>,
    rules: &Rules,
    keys: &[K],
    level: &[u8],
    (candidates, points): (&[u32], bool),
) -> Vec<Move> {
    crate::par::filter_map(candidates, |&point| {
        let i = point as usize;
        let from = level[i];
        let split = walk(set, keys[i], from);
        let clear = match points {
            true => clear_of_points(rules, keys, i, split),
            false => split,
        };
        let to = descend(set, rules, keys, i, clear);
        (to != from).then_some(Move {
            point,
            from,
            split,
            to,
        })
    })
}

/// The level of the leaf of `key`, from its unsplit square at level `from` on, once the rules
/// are applied to it alone: below every square whose block holds a split square (R3a).
pub(super) fn descend<K: MortonKey>(
    set: &SplitSet<K>,
    rules: &Rules,
    keys: &[K],
    i: usize,
    from: u8,
) -> u8 {
    let mut level = from;
    // Squares below an unsplit one are unsplit, so the path need not be walked again.
    while (level as u32) < K::AXIS_BITS && crowded_by_splits(set, rules, i, keys[i], level) {
        level += 1;
    }
    level
}

/// The first level from `from` on where the square holding `key` is not split.
pub(super) fn walk<K: MortonKey>(set: &SplitSet<K>, key: K, from: u8) -> u8 {
    let mut level = from;
    while (level as u32) < K::AXIS_BITS && set.contains(Cell::containing(key, level)) {
        level += 1;
    }
    level
}

/// Whether point `i`'s block at `level` sticks out where it may not or holds a split square.
fn crowded_by_splits<K: MortonKey>(
    set: &SplitSet<K>,
    rules: &Rules,
    i: usize,
    key: K,
    level: u8,
) -> bool {
    let cell = Cell::containing(key, level);
    rules
        .window(i, cell, key)
        .is_none_or(|window| set.any_in(cell.level, window))
}

/// Appends the squares a move demands that are not split yet: the path it passed (R3a, c, d),
/// and the rings of the path's squares (R3b). Each ring is demanded by the first point of its
/// square only, as every point of a split square passes it.
pub(super) fn demands_of<K: MortonKey>(
    set: &SplitSet<K>,
    keys: &[K],
    m: Move,
    out: &mut Vec<Squares<K>>,
) {
    let i = m.point as usize;
    for level in m.from..m.to {
        let square = Cell::containing(keys[i], level);
        let first = i == 0 || !square.contains(keys[i - 1]);
        if first || level >= m.split {
            set.missing_near(square, u64::from(first), out);
        }
    }
}

/// Appends the squares a move demands under [`Separation::Corner`] that are not split yet: the
/// path it passed, and for each square of it the parents of its child's corner block, so that
/// the block's squares exist wherever the point's square does.
fn corner_demands_of<K: MortonKey>(
    set: &SplitSet<K>,
    rules: &Rules,
    keys: &[K],
    m: Move,
    out: &mut Vec<Squares<K>>,
) {
    let i = m.point as usize;
    let key = keys[i];
    let on = rules.on(i);
    for level in m.from..m.to {
        let mut want = |cell: Cell<K>| {
            if !set.contains(cell) {
                out.push(Squares::one(cell));
            }
        };
        want(Cell::containing(key, level));
        // The points of one square two levels down share the child's nearest corner: the
        // first of them on the same domain sides demands its block.
        let grandchild = Cell::containing(key, (level + 2).min(K::AXIS_BITS as u8));
        if i > 0 && grandchild.contains(keys[i - 1]) && rules.on(i - 1) == on {
            continue;
        }
        corner_block_parents(key, level, on, rules.lines()).for_each(want);
    }
}

/// The squares of `level` whose split makes the corner block (cut at the sides `on`) of the
/// point with key `key` at the next level: what a split square of `level` holding the point
/// demands under [`Separation::Corner`].
pub(super) fn corner_block_parents<K: MortonKey>(
    key: K,
    level: u8,
    on: u8,
    lines: [Option<u128>; 2],
) -> impl Iterator<Item = Cell<K>> {
    let block = corner_block(Cell::containing(key, level + 1), key, on, lines);
    block.into_iter().flat_map(move |block| {
        (block.columns.0 >> 1..=block.columns.1 >> 1).flat_map(move |x| {
            (block.rows.0 >> 1..=block.rows.1 >> 1).map(move |y| at_position(x, y, level))
        })
    })
}

/// Whether `key` lies in the upper half of `cell` along x and along y (a key on the middle
/// line counts as upper): the ends of the square's axes its nearest corner lies at. The warp
/// moves that corner onto the point.
pub fn upper_halves<K: MortonKey>(cell: Cell<K>, key: K) -> (bool, bool) {
    if cell.level as u32 >= K::AXIS_BITS {
        return (false, false);
    }
    let (hx, hy) = grid_position(Cell::containing(key, cell.level + 1));
    (hx & 1 == 1, hy & 1 == 1)
}

/// The grid corner of `cell` nearest to `key` (see [`upper_halves`]), as a column and row of
/// the corners of its level.
pub fn nearest_corner<K: MortonKey>(cell: Cell<K>, key: K) -> (u64, u64) {
    let (x, y) = grid_position(cell);
    let (right, top) = upper_halves(cell, key);
    (x + u64::from(right), y + u64::from(top))
}

/// The 2×2 squares of `cell`'s level around its corner nearest to `key`, cut at the domain
/// sides `on` (bits as [`sides_of`] gives) the point lies on; `None` when they stick out of the
/// domain elsewhere: past the root's sides, or across `lines`, the right and top sides where
/// they are grid lines inside the root (finest units, see [`Rules::lines`]).
fn corner_block<K: MortonKey>(
    cell: Cell<K>,
    key: K,
    on: u8,
    lines: [Option<u128>; 2],
) -> Option<Rect> {
    let (cx, cy) = nearest_corner(cell, key);
    let shift = K::AXIS_BITS - cell.level as u32;
    let full = 1u128 << K::AXIS_BITS;
    // The squares on either side of corner line `c`, less the one beyond a side the point is
    // on; none if they would cross the far side `far`.
    let span = |c: u64, far: Option<u128>, (low, high): (u8, u8)| {
        let far = far.unwrap_or(full);
        let at = u128::from(c) << shift;
        match c {
            0 => (on & low != 0).then_some((0, 0)),
            c if at == far => (on & high != 0).then_some((c - 1, c - 1)),
            _ if at + (1u128 << shift) > far => None,
            c => Some((c - 1, c)),
        }
    };
    Some(Rect {
        columns: span(cx, lines[0], (ON_LEFT, ON_RIGHT))?,
        rows: span(cy, lines[1], (ON_BOTTOM, ON_TOP))?,
    })
}

/// Whether another point crowds point `i` at `level` under [`Separation::Corner`]: lies in
/// its corner block, or has its own nearest corner at most one square from `i`'s, so that the
/// blocks would share a square. Those are exactly the points in the 6×6 squares of the next
/// level centred on the corner, looked up as [`crowded_by_points`] does.
fn crowded_around_corner<K: MortonKey>(keys: &[K], i: usize, level: u8) -> bool {
    let (cx, cy) = nearest_corner(Cell::containing(keys[i], level), keys[i]);
    let finer = level + 1;
    let last = last_position(finer);
    let span = |c: u64| ((2 * c).saturating_sub(3), (2 * c + 2).min(last));
    let near = Rect {
        columns: span(cx),
        rows: span(cy),
    };
    let inside = |c: Cell<K>| {
        let (x, y) = grid_position(c);
        (near.columns.0..=near.columns.1).contains(&x) && (near.rows.0..=near.rows.1).contains(&y)
    };
    let coarse_level = finer.saturating_sub(2);
    let shift = finer - coarse_level;
    for gx in near.columns.0 >> shift..=near.columns.1 >> shift {
        for gy in near.rows.0 >> shift..=near.rows.1 >> shift {
            let coarse: Cell<K> = at_position(gx, gy, coarse_level);
            let start = partition_from(keys, i, |k| *k < { coarse.anchor });
            let end = partition_from(keys, start, |k| {
                k.cell_anchor(coarse.level) <= { coarse.anchor }
            });
            let crowds = |j: usize| j != i && inside(Cell::containing(keys[j], finer));
            let crowded = if end - start <= 32 {
                (start..end).any(crowds)
            } else {
                // Many points close by: look up the squares instead.
                rect_cells(near, finer)
                    .filter(|c| coarse.contains(c.anchor))
                    .any(|c| {
                        let first = keys.partition_point(|k| *k < { c.anchor });
                        let after = keys[first..].partition_point(|k| c.contains(*k)) + first;
                        (first..after).any(|j| j != i)
                    })
            };
            if crowded {
                return true;
            }
        }
    }
    false
}

/// The squares of `rect` at `level`.
fn rect_cells<K: MortonKey>(rect: Rect, level: u8) -> impl Iterator<Item = Cell<K>> {
    (rect.columns.0..=rect.columns.1)
        .flat_map(move |x| (rect.rows.0..=rect.rows.1).map(move |y| at_position(x, y, level)))
}

/// Each point's leaf level, and an index from tiles to the point leaves whose block meets them.
struct PointLeaves<K: Copy> {
    level: Vec<u8>,
    /// By level and tile anchor, heads of lists in `entries`.
    by_tile: Vec<KeyMap<K, u32>>,
    /// Entries of points that moved on are stale and skipped.
    entries: Vec<Entry>,
}

/// A point leaf listed under a tile: its point, its block's (and its own) bits in the tile,
/// and the next entry of the tile or `NONE`.
struct Entry {
    point: u32,
    window: u64,
    next: u32,
}

impl<K: MortonKey> PointLeaves<K> {
    fn new(points: usize) -> Self {
        PointLeaves {
            level: vec![0; points],
            by_tile: (0..=K::AXIS_BITS).map(|_| KeyMap::default()).collect(),
            entries: Vec::new(),
        }
    }

    fn record(&mut self, keys: &[K], moves: &[Move]) {
        for m in moves {
            self.level[m.point as usize] = m.to;
            // A finest-level leaf is never split, so nothing can crowd it any more.
            if (m.to as u32) >= K::AXIS_BITS {
                continue;
            }
            let leaf = Cell::containing(keys[m.point as usize], m.to);
            for (tile, window) in window_tiles(leaf, 2) {
                let head = self.by_tile[m.to as usize].entry(tile).or_insert(NONE);
                self.entries.push(Entry {
                    point: m.point,
                    window,
                    next: *head,
                });
                *head = (self.entries.len() - 1) as u32;
            }
        }
    }

    /// The points whose leaf is one of the `added` squares or has one in its block, sorted.
    fn near(&self, added: &[Squares<K>]) -> Vec<u32> {
        let mut points: Vec<u32> = added
            .par_iter()
            .flat_map_iter(|&squares| self.near_squares(squares))
            .collect();
        points.par_sort_unstable();
        points.dedup();
        points
    }

    fn near_squares(&self, squares: Squares<K>) -> Vec<u32> {
        let mut out = Vec::new();
        let level = squares.level();
        let mut next = self.by_tile[level as usize]
            .get(&squares.tile())
            .copied()
            .unwrap_or(NONE);
        while next != NONE {
            let entry = &self.entries[next as usize];
            if entry.window & squares.mask() != 0 && self.level[entry.point as usize] == level {
                out.push(entry.point);
            }
            next = entry.next;
        }
        out
    }
}

/// The first level from `from` on where the 5×5 block around point `i`'s square lies in the
/// root and holds no other point (R3c, d), or the finest level.
pub(super) fn clear_of_points<K: MortonKey>(rules: &Rules, keys: &[K], i: usize, from: u8) -> u8 {
    let mut level = from;
    while (level as u32) < K::AXIS_BITS && crowded_by_points(rules, keys, i, level) {
        level += 1;
    }
    level
}

/// Whether the 5×5 block around point `i`'s square at `level` sticks out of the root or holds
/// another point. Only the points in the (at most 2×2) squares four times as large that cover
/// the block are looked at, found by galloping from `i`: they are mostly close in Morton order.
fn crowded_by_points<K: MortonKey>(rules: &Rules, keys: &[K], i: usize, level: u8) -> bool {
    let cell = Cell::containing(keys[i], level);
    let centre = grid_position(cell);
    // No point lies beyond a side the window is cut at, so the whole block is searched.
    if rules.window(i, cell, keys[i]).is_none() {
        return true;
    }
    if rules.separation == Separation::Corner {
        return crowded_around_corner(keys, i, level);
    }
    let crowds = |&k: &K| {
        let other = Cell::containing(k, level);
        other != cell && chebyshev(grid_position(other), centre) <= 2
    };
    for coarse in window_cover(cell, 2) {
        let start = partition_from(keys, i, |k| *k < { coarse.anchor });
        let end = partition_from(keys, start, |k| {
            k.cell_anchor(coarse.level) <= { coarse.anchor }
        });
        let inside = &keys[start..end];
        let crowded = if inside.len() <= 32 {
            inside.iter().any(crowds)
        } else {
            // Many points close by: search them for the block's squares instead.
            block(cell)
                .flatten()
                .filter(|c| coarse.contains(c.anchor))
                .any(|c| holds_point(c, inside))
        };
        if crowded {
            return true;
        }
    }
    false
}

/// `v.partition_point(pred)` by galloping from index `i`: O(log d) for an answer d away.
pub(super) fn partition_from<T>(v: &[T], i: usize, pred: impl Fn(&T) -> bool) -> usize {
    let mut step = 1;
    if v.get(i).is_some_and(&pred) {
        // The answer lies right of `i`; `pred` holds below `lo`.
        let mut lo = i + 1;
        while lo + step <= v.len() && pred(&v[lo + step - 1]) {
            lo += step;
            step *= 2;
        }
        let hi = (lo + step).min(v.len());
        lo + v[lo..hi].partition_point(pred)
    } else {
        // The answer is `i` or left of it; `pred` fails from `hi` on.
        let mut hi = i.min(v.len());
        while hi >= step && !pred(&v[hi - step]) {
            hi -= step;
            step *= 2;
        }
        let lo = hi.saturating_sub(step);
        lo + v[lo..hi].partition_point(pred)
    }
}

fn holds_point<K: MortonKey>(cell: Cell<K>, keys: &[K]) -> bool {
    let first = keys.partition_point(|k| *k < { cell.anchor });
    keys.get(first).is_some_and(|k| cell.contains(*k))
}

pub(super) fn chebyshev((ax, ay): (u64, u64), (bx, by): (u64, u64)) -> u64 {
    ax.abs_diff(bx).max(ay.abs_diff(by))
}

/// The squares two levels up (at most 2×2 for a radius up to 2) that cover the squares within
/// `radius` of `cell` inside the root; `cell` must be at level 2 or deeper.
fn window_cover<K: MortonKey>(cell: Cell<K>, radius: u64) -> impl Iterator<Item = Cell<K>> {
    let (x, y) = grid_position(cell);
    let last = last_position(cell.level);
    let span =
        move |c: u64| (c.saturating_sub(radius) >> 2)..=(c.saturating_add(radius).min(last) >> 2);
    let level = cell.level - 2;
    span(x).flat_map(move |cx| span(y).map(move |cy| at_position(cx, cy, level)))
}

/// The 8 same-size squares around `cell` (`None` outside the root).
fn ring<K: MortonKey>(cell: Cell<K>) -> impl Iterator<Item = Option<Cell<K>>> {
    around(cell, 1)
}

/// The 24 same-size squares of the 5×5 block around `cell` (`None` outside the root).
pub fn block<K: MortonKey>(cell: Cell<K>) -> impl Iterator<Item = Option<Cell<K>>> {
    around(cell, 2)
}

/// The same-size squares within `radius` of `cell`, column by column (`None` outside the root);
/// as [`Cell::offset`] but decoding the anchor once.
pub(super) fn around<K: MortonKey>(
    cell: Cell<K>,
    radius: i64,
) -> impl Iterator<Item = Option<Cell<K>>> {
    let (x, y) = grid_position(cell);
    let side = 1i128 << cell.level;
    square_offsets(radius).map(move |(dx, dy)| {
        let nx = x as i128 + dx as i128;
        let ny = y as i128 + dy as i128;
        let inside = (0..side).contains(&nx) && (0..side).contains(&ny);
        inside.then(|| at_position(nx as u64, ny as u64, cell.level))
    })
}

/// Offsets `(dx, dy)` with `max(|dx|, |dy|)` from 1 to `radius`.
fn square_offsets(radius: i64) -> impl Iterator<Item = (i64, i64)> {
    (-radius..=radius)
        .flat_map(move |dx| (-radius..=radius).map(move |dy| (dx, dy)))
        .filter(|&d| d != (0, 0))
}

/// Checks [`Separation::Corner`] on a tree, with hash maps: every point leaf's corner block
/// lies in the root and consists of leaves of its size holding no other point, and no leaf is
/// in two points' blocks.
pub fn check_corner_separated<K: MortonKey>(tree: &Quadtree<K>, keys: &[K]) -> Result<(), String> {
    check_corner_separated_in(tree, keys, None)
}

/// [`check_corner_separated`] on a given domain: a block is cut at the sides its point lies
/// on, and sticks out nowhere else; no leaf lies across a side that is a grid line inside the
/// root.
pub fn check_corner_separated_in<K: MortonKey>(
    tree: &Quadtree<K>,
    keys: &[K],
    sides: Option<&DomainSides>,
) -> Result<(), String> {
    use std::collections::HashMap;
    let rules = Rules::new(sides);
    if let Some(leaf) = tree
        .leaves
        .iter()
        .find(|l| lies_across(l.cell, rules.lines()))
    {
        let cell = leaf.cell;
        return Err(format!("{cell:?} lies across a side of the domain"));
    }
    let leaf_point: HashMap<Cell<K>, u32> = tree.leaves.iter().map(|l| (l.cell, l.point)).collect();
    let mut claimed: HashMap<Cell<K>, u32> = HashMap::new();
    for leaf in tree.leaves.iter().filter(|l| l.point != NONE) {
        let cell = leaf.cell;
        let key = keys[leaf.point as usize];
        let Some(block) = corner_block(cell, key, rules.on(leaf.point as usize), rules.lines())
        else {
            return Err(format!("corner block of {cell:?} leaves the domain"));
        };
        for square in rect_cells::<K>(block, cell.level) {
            match leaf_point.get(&square) {
                Some(&p) if p == NONE || square == cell => {}
                Some(_) => return Err(format!("corner block of {cell:?} holds another point")),
                None => {
                    return Err(format!(
                        "corner block of {cell:?} has {square:?}, not a leaf"
                    ));
                }
            }
            let point = leaf.point;
            if let Some(other) = claimed.insert(square, point) {
                return Err(format!(
                    "{square:?} is in the corner blocks of points {other} and {point}"
                ));
            }
        }
    }
    Ok(())
}

/// Checks the well-separation rules on a tree, with hash sets: every point leaf's 5×5 block
/// lies in the root and consists of leaves of its size holding no other point, and every split
/// square holding a point has its 8 neighbours split.
pub fn check_separated<K: MortonKey>(tree: &Quadtree<K>, keys: &[K]) -> Result<(), String> {
    check_separated_in(tree, keys, None, None)
}

/// [`check_separated`] in a given domain: each point leaf's block is cut at the domain's sides
/// the point lies on and must not cross any other; and with a band, every leaf that the band's
/// row meets below the domain's top side is of the band's level.
pub fn check_separated_in<K: MortonKey>(
    tree: &Quadtree<K>,
    keys: &[K],
    sides: Option<&DomainSides>,
    band: Option<Band>,
) -> Result<(), String> {
    use std::collections::{HashMap, HashSet};
    let rules = Rules::new(sides);
    let split: HashSet<Cell<K>> = tree.internal.iter().map(|s| s.cell).collect();
    let leaf_point: HashMap<Cell<K>, u32> = tree.leaves.iter().map(|l| (l.cell, l.point)).collect();
    for leaf in tree.leaves.iter().filter(|l| l.point != NONE) {
        let cell = leaf.cell;
        let point = leaf.point as usize;
        let Some(window) = rules.window(point, cell, keys[point]) else {
            return Err(format!("block of {cell:?} leaves the domain"));
        };
        let (columns, rows) = (window.columns, window.rows);
        let squares = (columns.0..=columns.1)
            .flat_map(|x| (rows.0..=rows.1).map(move |y| at_position(x, y, cell.level)));
        for square in squares.filter(|&c| c != cell) {
            match leaf_point.get(&square) {
                Some(&NONE) => {}
                Some(_) => return Err(format!("block of {cell:?} holds another point")),
                None => {
                    return Err(format!("block of {cell:?} has {square:?}, not a leaf"));
                }
            }
        }
    }
    for s in &tree.internal {
        if holds_point(s.cell, keys) && ring(s.cell).flatten().any(|c| !split.contains(&c)) {
            let cell = s.cell;
            return Err(format!(
                "split square {cell:?} holds a point but a neighbour is not split"
            ));
        }
    }
    if let (Some(band), Some(top)) = (band, rules.top)
        && band.finest > band.level
    {
        // Graded: every leaf the side crosses in the domain starts on the band's row, at a
        // level in range.
        let right = rules.right.unwrap_or(u128::MAX);
        for leaf in &tree.leaves {
            let shift = K::AXIS_BITS - leaf.cell.level as u32;
            let (x, y) = grid_position(leaf.cell);
            let (left, bottom) = (u128::from(x) << shift, u128::from(y) << shift);
            let size = 1u128 << shift;
            let crosses =
                left < right && (bottom as f64) < top.exact && ((bottom + size) as f64) > top.exact;
            let level = leaf.cell.level;
            if crosses && (bottom != band.top_row || !(band.level..=band.finest).contains(&level)) {
                let cell = leaf.cell;
                return Err(format!(
                    "{cell:?} crosses the side outside the graded band {band:?}"
                ));
            }
        }
    } else if let (Some(band), Some(top)) = (band, rules.top) {
        let side = 1u128 << (K::AXIS_BITS - band.level as u32);
        let row = u128::from(band.row) * side..(u128::from(band.row) + 1) * side;
        let right = rules.right.unwrap_or(u128::MAX);
        for leaf in &tree.leaves {
            let shift = K::AXIS_BITS - leaf.cell.level as u32;
            let (x, y) = grid_position(leaf.cell);
            let bottom = u128::from(y) << shift;
            let upper = bottom + (1u128 << shift);
            let inside = (u128::from(x) << shift) < right && bottom < top.ceil;
            let meets = inside && bottom < row.end && upper > row.start;
            if meets && leaf.cell.level != band.level {
                let cell = leaf.cell;
                return Err(format!("{cell:?} meets the band at level {}", band.level));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const BITS: u32 = 32;

    /// The band at `level` for a top side `kept` of the way up the row at `row`.
    fn band_with(level: u8, row: u128, kept: f64) -> Band {
        let side = (1u128 << (BITS - level as u32)) as f64;
        band_at(InnerTop::new((row as f64 + kept) * side), level, BITS)
    }

    #[test]
    fn the_side_keeps_a_row_if_it_keeps_half_and_drops_it_if_it_keeps_a_sixteenth() {
        let side = 1u128 << (BITS - 10);
        for (kept, top_row) in [
            (0.5, 21 * side),
            (0.99, 21 * side),
            (1.0, 21 * side),
            (0.06, 20 * side),
            (0.001, 20 * side),
            (0.07, u128::MAX),
            (0.49, u128::MAX),
        ] {
            assert_eq!(band_with(10, 20, kept).top_row, top_row, "{kept}");
        }
        // With no row below, the row cannot go.
        assert_eq!(band_with(10, 0, 0.01).top_row, u128::MAX);
    }

    #[test]
    fn an_allowed_shape_is_at_most_three_levels_finer() {
        for i in 1..2000 {
            let top = InnerTop::new((i as f64 * 0.618_033_988_7).fract() * (1u64 << 31) as f64);
            // From levels whose rows are no taller than the domain, so one lies below the row.
            let first = (2u8..20).find(|&l| top.exact >= (1u64 << (BITS - l as u32)) as f64);
            for level in first.unwrap_or(20)..20 {
                let band = allowed_from(top, level, BITS);
                assert!(band.level <= level + 3, "{top:?} from {level}: {band:?}");
                assert_ne!(band.top_row, u128::MAX);
            }
        }
    }

    #[test]
    fn the_coarsest_band_fits_the_domains_height() {
        // A domain a thousandth as tall as wide needs rows at most about twice that tall.
        let top = (1u64 << 32) as f64 / 1000.0;
        let level = coarsest_band_level(top, BITS);
        assert!((9..=12).contains(&level), "{level}");
    }
}
