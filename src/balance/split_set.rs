//! A growing set of split squares, closed under balance, with expected constant-time
//! membership, so that a round of [`super::separate()`] costs what it adds, not the size of the
//! set: per level, a hash map from tiles of 8×8 squares to a bit mask of the split ones.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use rayon::prelude::*;

use crate::morton::{Cell, MortonKey, Side};

/// A fast hasher for Morton indices: each word is mixed by a folded 64×64→128-bit product, so
/// both the low bits (the table's slot) and the top bits (its tag) depend on every input bit.
#[derive(Clone, Copy, Default)]
pub(super) struct KeyHasher(u64);

const MIX: u64 = 0x9E37_79B9_7F4A_7C15;

impl KeyHasher {
    fn mix(&mut self, word: u64) {
        let product = u128::from(self.0 ^ word) * u128::from(MIX);
        self.0 = (product as u64) ^ ((product >> 64) as u64);
    }
}

impl Hasher for KeyHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.mix(u64::from_le_bytes(word));
        }
    }

    fn write_u64(&mut self, v: u64) {
        self.mix(v);
    }

    fn write_u128(&mut self, v: u128) {
        self.mix(v as u64);
        self.mix((v >> 64) as u64);
    }
}

pub(super) type KeyMap<T, V> = HashMap<T, V, BuildHasherDefault<KeyHasher>>;

/// A square's column and row among the squares of its level.
pub(super) fn grid_position<K: MortonKey>(cell: Cell<K>) -> (u64, u64) {
    let shift = K::AXIS_BITS - cell.level as u32;
    let (x, y) = cell.anchor.decode();
    (
        x.checked_shr(shift).unwrap_or(0),
        y.checked_shr(shift).unwrap_or(0),
    )
}

/// The square in column `x` and row `y` of `level`.
pub(super) fn at_position<K: MortonKey>(x: u64, y: u64, level: u8) -> Cell<K> {
    let shift = K::AXIS_BITS - level as u32;
    Cell {
        anchor: K::encode(
            x.checked_shl(shift).unwrap_or(0),
            y.checked_shl(shift).unwrap_or(0),
        ),
        level,
    }
}

/// The last column (and row) of `level`.
pub(super) fn last_position(level: u8) -> u64 {
    u64::try_from((1u128 << level) - 1).unwrap_or(u64::MAX)
}

/// Spreads the 3 bits of `v` to the even bit positions.
const fn spread3(v: usize) -> usize {
    (v & 1) | (v & 2) << 1 | (v & 4) << 2
}

/// `COLUMNS[x]` (`ROWS[y]`): the bits of a tile's squares in column `x` (row `y`).
const COLUMNS: [u64; 8] = axis_masks(1);
const ROWS: [u64; 8] = axis_masks(0);

const fn axis_masks(x_shift: usize) -> [u64; 8] {
    let mut masks = [0u64; 8];
    let mut i = 0;
    while i < 8 {
        let mut j = 0;
        while j < 8 {
            masks[i] |= 1 << (spread3(i) << x_shift | spread3(j) << (1 - x_shift));
            j += 1;
        }
        i += 1;
    }
    masks
}

/// The bits of tile `t`'s squares whose coordinate along one axis lies in `lo..=hi`.
fn axis_mask(masks: &[u64; 8], lo: u64, hi: u64, t: u64) -> u64 {
    let origin = t << 3;
    let (from, to) = (lo.max(origin) - origin, hi.min(origin + 7) - origin);
    (from..=to).fold(0, |m, i| m | masks[i as usize])
}

/// The tiles that the squares within `radius` of `cell` inside the root meet, with
/// the bits of those squares in each.
pub(super) fn window_tiles<K: MortonKey>(
    cell: Cell<K>,
    radius: u64,
) -> impl Iterator<Item = (K, u64)> {
    let (x, y) = grid_position(cell);
    let last = last_position(cell.level);
    let span = move |c: u64| (c.saturating_sub(radius), c.saturating_add(radius).min(last));
    rect_tiles(Rect {
        columns: span(x),
        rows: span(y),
    })
}

/// Columns and rows (inclusive) of squares of one level.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Rect {
    pub columns: (u64, u64),
    pub rows: (u64, u64),
}

/// The tiles that the squares of `rect` (inside the root) meet, with the bits of those squares
/// in each.
pub(super) fn rect_tiles<K: MortonKey>(rect: Rect) -> impl Iterator<Item = (K, u64)> {
    let ((x0, x1), (y0, y1)) = (rect.columns, rect.rows);
    (x0 >> 3..=x1 >> 3).flat_map(move |tx| {
        let columns = axis_mask(&COLUMNS, x0, x1, tx);
        (y0 >> 3..=y1 >> 3).map(move |ty| {
            let tile = K::encode(tx, ty);
            (tile, columns & axis_mask(&ROWS, y0, y1, ty))
        })
    })
}

/// The indices of the set bits of a mask, lowest first.
struct BitIndices(u64);

impl Iterator for BitIndices {
    type Item = u32;

    fn next(&mut self) -> Option<u32> {
        (self.0 != 0).then(|| {
            let index = self.0.trailing_zeros();
            self.0 &= self.0 - 1;
            index
        })
    }
}

/// The squares of `rect` at `level`, a tile at a time.
pub(super) fn rect_squares<K: MortonKey>(level: u8, rect: Rect) -> Vec<Squares<K>> {
    rect_tiles::<K>(rect)
        .map(|(tile, mask)| Squares { tile, mask, level })
        .collect()
}

/// Squares of one tile: the tile (see [`tile_bit`]), its level, and a bit per square.
#[derive(Clone, Copy, Debug)]
pub(super) struct Squares<K> {
    tile: K,
    mask: u64,
    level: u8,
}

impl<K: MortonKey> Squares<K> {
    pub(super) fn one(cell: Cell<K>) -> Self {
        let (tile, bit) = tile_bit(cell);
        Squares {
            tile,
            mask: bit,
            level: cell.level,
        }
    }

    pub(super) fn level(&self) -> u8 {
        self.level
    }

    pub(super) fn tile(&self) -> K {
        self.tile
    }

    pub(super) fn mask(&self) -> u64 {
        self.mask
    }

    /// The squares, in Morton order.
    pub(super) fn cells(self) -> impl Iterator<Item = Cell<K>> {
        BitIndices(self.mask).map(move |i| self.square(i))
    }

    /// The square of bit `index`.
    fn square(&self, index: u32) -> Cell<K> {
        let position = self.tile.to_u128() << 6 | u128::from(index);
        let shift = 2 * (K::AXIS_BITS - self.level as u32);
        Cell {
            // Only the root has a 128-bit shift, and position 0.
            anchor: K::from_u128(position.checked_shl(shift).unwrap_or(0)),
            level: self.level,
        }
    }
}

/// Appends `squares` to `list`, into its last entry if that is of the same tile.
fn push_merged<K: MortonKey>(list: &mut Vec<Squares<K>>, squares: Squares<K>) {
    match list.last_mut() {
        Some(last) if last.tile == squares.tile && last.level == squares.level => {
            last.mask |= squares.mask;
        }
        _ => list.push(squares),
    }
}

/// The bits of the four siblings (by quadrant) of the square with bit `index` in tile `mask`.
fn sibling_bits(mask: u64, index: u32) -> u8 {
    (mask >> (index & !3)) as u8 & 0xF
}

/// What balance forces from a newly split `cell` (its parent, and the parent's neighbours
/// across the two sides of the parent that `cell` touches; see [`super::forced_by`]), less what
/// its split `siblings` (a bit per quadrant) forced already.
fn forced_anew<K: MortonKey>(cell: Cell<K>, siblings: u8) -> [Option<Cell<K>>; 3] {
    if cell.level == 0 {
        return [None; 3];
    }
    let q = cell.quadrant();
    let parent = cell.parent();
    // A sibling in the same column touches the same west or east side, one in the same row the
    // same south or north side.
    let across_x = if q & 2 == 0 { Side::West } else { Side::East };
    let across_y = if q & 1 == 0 { Side::South } else { Side::North };
    let unforced = |sibling: u32| siblings & (1 << sibling) == 0;
    [
        (siblings == 0).then_some(parent),
        parent.neighbour(across_x).filter(|_| unforced(q ^ 1)),
        parent.neighbour(across_y).filter(|_| unforced(q ^ 2)),
    ]
}

/// Split squares closed under parents and balance, as bit masks over tiles: a tile is the 8×8
/// squares of one level inside a square three levels up (the root for levels 0 to 2), so
/// neighbouring squares mostly share one hash entry and one cache line.
#[derive(Clone)]
pub(super) struct SplitSet<K> {
    levels: Vec<KeyMap<K, u64>>,
}

/// The tile holding `cell`, and the cell's bit in it: a tile is named by its Morton index among
/// the tiles of its level, and numbers its squares in Morton order.
fn tile_bit<K: MortonKey>(cell: Cell<K>) -> (K, u64) {
    let shift = 2 * (K::AXIS_BITS - cell.level as u32);
    let position = cell.anchor.to_u128().checked_shr(shift).unwrap_or(0);
    (K::from_u128(position >> 6), 1 << (position & 63))
}

impl<K: MortonKey> SplitSet<K> {
    pub(super) fn new() -> Self {
        SplitSet {
            levels: (0..=K::AXIS_BITS).map(|_| KeyMap::default()).collect(),
        }
    }

    pub(super) fn contains(&self, cell: Cell<K>) -> bool {
        let (tile, bit) = tile_bit(cell);
        self.levels[cell.level as usize]
            .get(&tile)
            .is_some_and(|mask| mask & bit != 0)
    }

    /// Takes `cell` out; keeping the set closed under balance is the caller's part.
    pub(super) fn remove(&mut self, cell: Cell<K>) {
        let (tile, bit) = tile_bit(cell);
        let tiles = &mut self.levels[cell.level as usize];
        if let Some(mask) = tiles.get_mut(&tile) {
            *mask &= !bit;
            if *mask == 0 {
                tiles.remove(&tile);
            }
        }
    }

    /// Whether a split square of `level` lies in `rect`.
    pub(super) fn any_in(&self, level: u8, rect: Rect) -> bool {
        let tiles = &self.levels[level as usize];
        rect_tiles::<K>(rect)
            .any(|(tile, window)| tiles.get(&tile).is_some_and(|mask| mask & window != 0))
    }

    /// The split squares of `level`, in no particular order.
    pub(super) fn squares_at(&self, level: u8) -> impl ParallelIterator<Item = Cell<K>> + '_ {
        self.levels[level as usize]
            .par_iter()
            .flat_map_iter(move |(&tile, &mask)| Squares { tile, mask, level }.cells())
    }

    /// [`Self::squares_at`], one by one: for the few squares of an edit.
    pub(super) fn squares_of(&self, level: u8) -> impl Iterator<Item = Cell<K>> + '_ {
        self.levels[level as usize]
            .iter()
            .flat_map(move |(&tile, &mask)| Squares { tile, mask, level }.cells())
    }

    /// Appends to `out` the squares within `radius` of `cell` (`cell` included) that are not
    /// split, a tile at a time.
    pub(super) fn missing_near(&self, cell: Cell<K>, radius: u64, out: &mut Vec<Squares<K>>) {
        let tiles = &self.levels[cell.level as usize];
        for (tile, window) in window_tiles(cell, radius) {
            let missing = window & !tiles.get(&tile).copied().unwrap_or(0);
            if missing != 0 {
                out.push(Squares {
                    tile,
                    mask: missing,
                    level: cell.level,
                });
            }
        }
    }

    /// Adds `cell`. If it was new, returns which of its siblings (by quadrant bit) were split
    /// before it. `recent` holds a tile per level seen lately, with bits split then: bits are
    /// never cleared, so those still are, and most forced squares are found there.
    fn insert(&mut self, cell: Cell<K>, recent: &mut [(K, u64)]) -> Option<u8> {
        let (tile, bit) = tile_bit(cell);
        let level = cell.level as usize;
        if recent[level].0 == tile && recent[level].1 & bit != 0 {
            return None;
        }
        let mask = self.levels[level].entry(tile).or_insert(0);
        let before = *mask;
        *mask |= bit;
        recent[level] = (tile, *mask);
        (before & bit == 0).then(|| sibling_bits(before, bit.trailing_zeros()))
    }

    /// Adds the squares `wanted` and whatever balance then forces; returns the squares that
    /// were new, a tile at a time, in an order fixed by that of `wanted`.
    ///
    /// Each new square's forced squares are added at once (depth first), while its tiles are
    /// still in cache; the closure is the same in any order. When a square comes in, every
    /// split square of its level has had its own forced squares added already, so what its
    /// split siblings forced need not be looked up again.
    pub(super) fn insert_closed(
        &mut self,
        wanted: impl IntoIterator<Item = Squares<K>>,
    ) -> Vec<Squares<K>> {
        let mut added = Vec::new();
        let mut stack = Vec::new();
        // An empty mask matches nothing.
        let mut recent = vec![(K::default(), 0); self.levels.len()];
        for squares in wanted {
            let mask = self.levels[squares.level as usize]
                .entry(squares.tile)
                .or_insert(0);
            let mut done = *mask;
            let mut fresh = squares.mask & !done;
            *mask |= squares.mask;
            if fresh != 0 {
                added.push(Squares {
                    mask: fresh,
                    ..squares
                });
            }
            while fresh != 0 {
                let index = fresh.trailing_zeros();
                fresh &= fresh - 1;
                let cell = squares.square(index);
                let forced = forced_anew(cell, sibling_bits(done, index));
                stack.extend(forced.into_iter().flatten());
                done |= 1 << index;
                while let Some(cell) = stack.pop() {
                    if let Some(siblings) = self.insert(cell, &mut recent) {
                        push_merged(&mut added, Squares::one(cell));
                        stack.extend(forced_anew(cell, siblings).into_iter().flatten());
                    }
                }
            }
        }
        added
    }

    /// Every square of the set, in preorder, by a depth-first walk. The walk meets each
    /// level's tiles in Morton order, so it reads them from sorted lists rather than looking
    /// them up (which misses the cache on large sets).
    pub(super) fn preorder(&self) -> Vec<Cell<K>> {
        let tiles: Vec<Vec<(K, u64)>> = self
            .levels
            .par_iter()
            .map(|level| {
                let mut tiles: Vec<(K, u64)> = level.iter().map(|(&t, &m)| (t, m)).collect();
                tiles.par_sort_unstable_by_key(|&(tile, _)| tile);
                tiles
            })
            .collect();
        let count = tiles.iter().flatten().map(|(_, m)| m.count_ones() as usize);
        let out = Vec::with_capacity(count.sum());
        let mut walk = Walk {
            next: vec![0; tiles.len()],
            tiles,
            out,
        };
        if walk.mask(0, K::default()) & 1 != 0 {
            walk.visit(Cell::root());
        }
        walk.out
    }
}

/// A depth-first walk of the split squares, with each level's tiles sorted and the next one
/// to read.
struct Walk<K: Copy> {
    tiles: Vec<Vec<(K, u64)>>,
    next: Vec<usize>,
    out: Vec<Cell<K>>,
}

impl<K: MortonKey> Walk<K> {
    /// The mask of `tile` at `level`; tiles must be asked for in increasing order per level.
    fn mask(&mut self, level: usize, tile: K) -> u64 {
        let (tiles, next) = (&self.tiles[level], &mut self.next[level]);
        while tiles.get(*next).is_some_and(|&(t, _)| t < tile) {
            *next += 1;
        }
        tiles
            .get(*next)
            .filter(|&&(t, _)| t == tile)
            .map_or(0, |&(_, m)| m)
    }

    fn visit(&mut self, cell: Cell<K>) {
        self.out.push(cell);
        if cell.level as u32 >= K::AXIS_BITS {
            return;
        }
        // The four children are consecutive bits of one tile.
        let (tile, first) = tile_bit(cell.child(0));
        let mask = self.mask(cell.level as usize + 1, tile);
        for quadrant in 0..4 {
            if mask & first << quadrant != 0 {
                self.visit(cell.child(quadrant));
            }
        }
    }
}
