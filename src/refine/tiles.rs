//! Refinement in parallel: the domain is cut into tiles, and the tiles of one colour are refined
//! at the same time, each by the sequential loop, in the one shared triangulation.
//!
//! A grid of cells covers the domain's bounding square. A tile is a 2×2 block of cells; the
//! four colours are the four ways of aligning the blocks, so a tile of one colour is centred on
//! a corner where tiles of another colour meet. Tiles of one colour are half-open squares that
//! do not overlap, and a tile works only on triangles with every corner inside it: work that
//! would reach further (a walk, a cavity) is set aside for the next colour, which has the spot
//! well inside one of its tiles. What no colour of any grid can take (triangles wider than the
//! coarsest grid's tiles, such as the slivers across the gap between two curves of a graph)
//! gets a few rounds on a grid twice as coarse, and what that leaves ends in the sequential
//! loop.
//!
//! Grids go from fine to coarse; each takes the bad triangles of two octaves of shortest-edge
//! lengths, so that small triangles are still fixed before large ones, and dense clusters get
//! small tiles.
//!
//! Nothing here depends on the number of threads: the grids depend on the sizes of the bad
//! triangles, the work of a tile only on the triangulation inside it and the order of its
//! queue, and the numbers of new vertices and triangles, handed out in chunks as threads happen
//! to ask for them, are renumbered at the end in the order of pass, tile and chunk.

use std::sync::atomic::{AtomicU32, Ordering};

use glam::DVec2;
use rayon::prelude::*;

use super::delaunay::{MARK, SEGMENT, Store, Triangulation, beyond};
use super::queue::SizeQueue;
use super::refiner::{Bounds, Encroached, Pending, Refiner, Work, is_current, is_live, newest};
use crate::error::Error;
use crate::mesh::NONE;

/// Below this many points, tiles do not pay.
pub(super) const MIN_POINTS: usize = 1 << 14;
/// The coarsest grid has `2^COARSEST` cells a side: coarser ones leave too few tiles to share.
const COARSEST: usize = 3;
/// The finest has `2^FINEST`, which keeps tile columns and rows within 32 bits.
const FINEST: usize = 32;
/// A grid's cells are this many times the longest shortest edge of the bad triangles it takes.
const CELL_PER_EDGE: f64 = 64.0;
/// Each grid takes this many octaves of edge lengths: fewer passes over the mesh than one
/// octave each, and nearly the same order.
const OCTAVES_PER_GRID: usize = 2;
/// Rounds of the four colours at most per grid.
const MAX_ROUNDS: usize = 4;
/// Vertex numbers and triangle slots are handed to tiles in chunks that double from the first
/// size up to the largest, so that a tile with little work leaves little unused.
const FIRST_CHUNK: u32 = 4;
const VERTEX_CHUNK: u32 = 64;
const TRIANGLE_CHUNK: u32 = 128;
/// A tile in a pass may insert this many points per entry it was given, plus a few, before it
/// sets the rest aside.
const ALLOWANCE_PER_ENTRY: usize = 4;
const ALLOWANCE_PER_TILE: usize = 32;

/// The grid the tiles are made of: `cells` cells a side over the square from `origin`.
#[derive(Clone, Copy, Debug)]
pub(super) struct Tiling {
    origin: DVec2,
    /// Cells per unit length.
    density: f64,
    cells: i64,
}

impl Tiling {
    /// The grid of `2^level` cells a side over the square of side `side` from `origin`.
    fn at_level(origin: DVec2, side: f64, level: usize) -> Self {
        let cells = 1i64 << level;
        Tiling {
            origin,
            density: cells as f64 / side,
            cells,
        }
    }

    /// The cell of `p`, clamped to the grid. Monotone in each coordinate, so a tile (a range
    /// of cells) holds every point between two of its points.
    #[inline]
    fn cell(&self, p: DVec2) -> (i64, i64) {
        let c = (p - self.origin) * self.density;
        // Truncation rounds up only below zero, where the clamp takes over: still monotone.
        let clamp = |x: f64| (x as i64).clamp(0, self.cells - 1);
        (clamp(c.x), clamp(c.y))
    }

    /// The tile of colour `colour` that holds point `p`: its column and row, packed.
    #[inline]
    fn tile(&self, colour: u8, p: DVec2) -> u64 {
        let (cx, cy) = self.cell(p);
        let tx = (cx + i64::from(colour & 1)) >> 1;
        let ty = (cy + i64::from(colour >> 1)) >> 1;
        ((ty as u64) << 32) | tx as u64
    }

    /// The smallest coordinate whose cell (along an axis from `origin`) is at least `m`, so
    /// that a range of cells is a range of coordinates: −∞ below the grid, +∞ above it. Found
    /// by bisection over the floats in order, since near zero a cell boundary can be many
    /// floats away from its computed value.
    fn threshold(&self, origin: f64, m: i64) -> f64 {
        if m <= 0 {
            return f64::NEG_INFINITY;
        }
        if m >= self.cells {
            return f64::INFINITY;
        }
        let cell = |x: f64| (((x - origin) * self.density) as i64).clamp(0, self.cells - 1);
        // Floats in order as integers (the map is its own inverse); ±∞ bracket the answer.
        let ordered = |x: f64| {
            let i = x.to_bits() as i64;
            i ^ ((((i >> 63) as u64) >> 1) as i64)
        };
        let float = |k: i64| f64::from_bits((k ^ ((((k >> 63) as u64) >> 1) as i64)) as u64);
        let (mut below, mut at) = (ordered(f64::NEG_INFINITY), ordered(f64::INFINITY));
        while i128::from(at) - i128::from(below) > 1 {
            let mid = ((i128::from(below) + i128::from(at)) / 2) as i64;
            if cell(float(mid)) >= m {
                at = mid;
            } else {
                below = mid;
            }
        }
        float(at)
    }

    /// The points of tile `tile` of colour `colour`: those `p` with `lo <= p < hi`, exactly
    /// the points [`Self::tile`] puts in it.
    fn bounds(&self, colour: u8, tile: u64) -> (DVec2, DVec2) {
        let (tx, ty) = ((tile & 0xffff_ffff) as i64, (tile >> 32) as i64);
        let (px, py) = (i64::from(colour & 1), i64::from(colour >> 1));
        // Column t holds the cells c with (c + parity) >> 1 == t: from 2t - parity.
        let lo = DVec2::new(
            self.threshold(self.origin.x, 2 * tx - px),
            self.threshold(self.origin.y, 2 * ty - py),
        );
        let hi = DVec2::new(
            self.threshold(self.origin.x, 2 * tx + 2 - px),
            self.threshold(self.origin.y, 2 * ty + 2 - py),
        );
        (lo, hi)
    }

    /// The tile of colour `colour` that holds all of a triangle, if one does.
    #[inline]
    fn owner(&self, colour: u8, corners: [DVec2; 3]) -> Option<u64> {
        let [a, b, c] = [
            self.tile(colour, corners[0]),
            self.tile(colour, corners[1]),
            self.tile(colour, corners[2]),
        ];
        (a == b && b == c).then_some(a)
    }
}

/// A run of vertex numbers or triangle slots a tile used: `len` from `start`.
#[derive(Clone, Copy, Debug)]
struct Chunk {
    start: u32,
    len: u32,
    /// The numbers it holds, used or not.
    size: u32,
}

impl Chunk {
    /// No chunk yet.
    const NONE: Chunk = Chunk {
        start: NONE,
        len: 0,
        size: FIRST_CHUNK / 2,
    };
}

/// The triangulation's arrays as the tiles share them. Data past a vector's length lives in its
/// spare capacity, written by tiles, until [`Shared::settle`] moves it into place.
struct Arrays {
    vertices: *mut DVec2,
    corners: *mut [u32; 3],
    across: *mut [u32; 3],
    /// Per triangle, its region; null where regions are not kept.
    regions: *mut u32,
    /// Per vertex, the input segment it lies on; null where segments are not kept.
    segment_of: *mut u32,
    vertex_capacity: u32,
    triangle_capacity: u32,
}

// SAFETY: `Arrays` is shared (by reference, never sent) only with the tiles of one pass in
// `pass`, while `Shared` is borrowed there and nothing else uses the vectors. Through it a tile
// reads and writes only what the rules on `TileStore` give it: triangles with at least two
// corners inside it and vertices that existed before the pass or that it made itself. Tiles of
// one pass are disjoint half-open squares (`Tiling::bounds`, checked by
// `tile_bounds_hold_exactly_the_tiles_points`; `TileStore::may_change` tests corners against
// them), so no element is written by one tile while another reads or writes it; new vertex
// numbers and triangle slots come from chunks handed out by `fetch_add` on `Counters`, so no
// two tiles get the same one.
#[allow(unsafe_code)]
unsafe impl Sync for Arrays {}

/// The state of a parallel refinement: the triangulation, how far its arrays are used, and the
/// chunks handed out since it was last settled.
struct Shared<'t> {
    t: &'t mut Triangulation,
    arrays: Arrays,
    /// Vertex numbers and triangle slots below these are handed out.
    vertex_end: u32,
    triangle_end: u32,
    /// Chunks in the order of pass, tile and request, which is the order they are renumbered in.
    vertex_chunks: Vec<Chunk>,
    triangle_chunks: Vec<Chunk>,
}

impl<'t> Shared<'t> {
    fn new(t: &'t mut Triangulation) -> Self {
        let arrays = arrays_of(t);
        Shared {
            vertex_end: t.vertices.len() as u32,
            triangle_end: t.corners.len() as u32,
            t,
            arrays,
            vertex_chunks: Vec::new(),
            triangle_chunks: Vec::new(),
        }
    }

    /// Corners of triangle `t` outside a pass.
    fn corners(&self, t: u32) -> [u32; 3] {
        assert!(t < self.triangle_end);
        // SAFETY: in bounds: `t < triangle_end` (asserted), and `triangle_end` never exceeds
        // `arrays.triangle_capacity` (chunks are handed out only within the room `pass` made
        // with `has_room`/`make_room`, and `push_triangle` asserts each slot against the
        // capacity); `arrays` points at the vectors' current buffers (renewed by `arrays_of`
        // after every change of them). Initialised: the numbers looked up here come from queue
        // entries and triangles, which only name slots in the vector or slots a tile wrote
        // (`push_triangle` writes a slot as it hands it out), never the unused ends of chunks.
        // No tile runs while `self` is borrowed, so nothing writes the slot meanwhile.
        #[allow(unsafe_code)]
        unsafe {
            *self.arrays.corners.add(t as usize)
        }
    }

    fn point(&self, v: u32) -> DVec2 {
        let v = v & !MARK;
        assert!(v < self.vertex_end);
        // SAFETY: as for `corners`, with `v < vertex_end <= arrays.vertex_capacity` (asserted;
        // `push_vertex` asserts each new number against the capacity, and writes its point).
        #[allow(unsafe_code)]
        unsafe {
            *self.arrays.vertices.add(v as usize)
        }
    }

    /// The larger side of triangle `t`'s bounding box.
    fn extent(&self, t: u32) -> f64 {
        let [a, b, c] = self.corners(t).map(|v| self.point(v));
        let (lo, hi) = (a.min(b).min(c), a.max(b).max(c));
        (hi - lo).max_element()
    }

    fn owner(&self, tiling: &Tiling, colour: u8, t: u32) -> Option<u64> {
        let c = self.corners(t);
        let corners = [self.point(c[0]), self.point(c[1]), self.point(c[2])];
        tiling.owner(colour, corners)
    }

    /// Whether `vertices` and `triangles` more fit in the arrays' capacity.
    fn has_room(&self, vertices: usize, triangles: usize) -> bool {
        let fits =
            |used: u32, more: usize, capacity: u32| used as usize + more <= capacity as usize;
        fits(self.vertex_end, vertices, self.arrays.vertex_capacity)
            && fits(self.triangle_end, triangles, self.arrays.triangle_capacity)
    }

    /// Makes room for `vertices` and `triangles` more: settles, then grows the arrays.
    fn make_room(&mut self, vertices: usize, triangles: usize, lists: &mut Lists) {
        self.settle(lists);
        let t = &mut *self.t;
        let grow = |len: usize, more: usize| (len + more).max(len + len / 2);
        let m = grow(t.vertices.len(), vertices) - t.vertices.len();
        t.vertices.reserve_exact(m);
        if !t.segment_of.is_empty() {
            t.segment_of.reserve_exact(m);
        }
        let n = grow(t.corners.len(), triangles) - t.corners.len();
        t.corners.reserve_exact(n);
        t.across.reserve_exact(n);
        if !t.regions.is_empty() {
            t.regions.reserve_exact(n);
        }
        self.arrays = arrays_of(t);
        assert!(
            self.arrays.vertex_capacity as usize <= MARK as usize,
            "vertex numbers stay below the mark bit"
        );
    }

    /// Moves the chunks' vertices and triangles into place after the vectors' contents, in the
    /// order of the chunk lists, renumbering every reference, so that the result does not
    /// depend on which thread got which chunk.
    fn settle(&mut self, lists: &mut Lists) {
        let (v0, t0) = (self.t.vertices.len() as u32, self.t.corners.len() as u32);
        let vertex_map = renumbering(&self.vertex_chunks, v0, self.vertex_end);
        let triangle_map = renumbering(&self.triangle_chunks, t0, self.triangle_end);
        // Keep only the entries that still hold, and give them their new numbers.
        let new_vertex = |v: u32| {
            if v < v0 {
                v
            } else {
                vertex_map[(v - v0) as usize]
            }
        };
        // A link keeps its segment mark.
        let new_triangle = |link: u32| {
            let t = beyond(link);
            if t < t0 || t == NONE {
                link
            } else {
                triangle_map[(t - t0) as usize] | (link & SEGMENT)
            }
        };
        for bad in std::iter::once(&mut lists.bad).chain(lists.later.iter_mut().flatten()) {
            bad.retain(|p| is_current(&Frozen(self), &p.entry));
            for p in bad.iter_mut() {
                let corners = self.corners(p.entry.triangle).map(new_vertex);
                p.entry.triangle = new_triangle(p.entry.triangle);
                p.entry.newest = newest(corners);
            }
        }
        lists.edges.retain(|e| is_live(&Frozen(self), e));
        for e in &mut lists.edges {
            e.triangle = new_triangle(e.triangle);
            e.ends = (new_vertex(e.ends.0), new_vertex(e.ends.1));
        }
        // Copy the chunks out of spare capacity, then append them.
        // The chunks' triangles get their new numbers as they are gathered; the ones before
        // them, which may name new vertices and triangles too, in place.
        let vertices = gather(self.arrays.vertices, &self.vertex_chunks, |v| v);
        let corners = gather(self.arrays.corners, &self.triangle_chunks, |c| {
            c.map(new_vertex)
        });
        let across = gather(self.arrays.across, &self.triangle_chunks, |n| {
            n.map(new_triangle)
        });
        let regions = (!self.arrays.regions.is_null())
            .then(|| gather(self.arrays.regions, &self.triangle_chunks, |r| r));
        let segment_of = (!self.arrays.segment_of.is_null())
            .then(|| gather(self.arrays.segment_of, &self.vertex_chunks, |s| s));
        let t = &mut *self.t;
        if let Some(regions) = regions {
            t.regions.par_extend(regions.par_iter().copied());
        }
        if let Some(segment_of) = segment_of {
            t.segment_of.par_extend(segment_of.par_iter().copied());
        }
        t.corners
            .par_iter_mut()
            .for_each(|c| *c = c.map(new_vertex));
        t.across
            .par_iter_mut()
            .for_each(|n| *n = n.map(new_triangle));
        t.vertices.par_extend(vertices.par_iter().copied());
        t.corners.par_extend(corners.par_iter().copied());
        t.across.par_extend(across.par_iter().copied());
        self.vertex_end = t.vertices.len() as u32;
        self.triangle_end = t.corners.len() as u32;
        self.vertex_chunks.clear();
        self.triangle_chunks.clear();
        self.arrays = arrays_of(t);
    }
}

/// The elements of `chunks`, in chunk order, copied out of the buffer at `base` through `map`.
fn gather<T, F>(base: *const T, chunks: &[Chunk], map: F) -> Vec<T>
where
    T: Copy + Send + Sync,
    F: Fn(T) -> T + Sync,
{
    // In parallel, so that the first touch of the fresh memory is shared out too.
    let offsets = crate::par::exclusive_scan_by(chunks.len(), |c| chunks[c].len as usize);
    let base = base as usize;
    crate::par::collect_segments(&offsets, |c| {
        let chunk = chunks[c];
        // SAFETY: a chunk's numbers were handed out below the capacity (each asserted against
        // it in `push_vertex`/`push_triangle`), and `base` is the buffer they were written into:
        // `settle` gathers before it changes any vector. The first `len` of them were written
        // by the tile that took the chunk (the unused end, past `len`, is not read); chunks do
        // not overlap (`fetch_add`). No tile runs while the chunks are gathered, so the reads
        // race with nothing.
        #[allow(unsafe_code)]
        let elements = unsafe {
            std::slice::from_raw_parts(
                (base as *const T).add(chunk.start as usize),
                chunk.len as usize,
            )
        };
        elements.iter().map(|&e| map(e))
    })
}

fn arrays_of(t: &mut Triangulation) -> Arrays {
    let kept = |v: &mut Vec<u32>| {
        if v.is_empty() {
            (std::ptr::null_mut(), usize::MAX)
        } else {
            (v.as_mut_ptr(), v.capacity())
        }
    };
    let (regions, region_capacity) = kept(&mut t.regions);
    let (segment_of, segment_capacity) = kept(&mut t.segment_of);
    Arrays {
        vertices: t.vertices.as_mut_ptr(),
        corners: t.corners.as_mut_ptr(),
        across: t.across.as_mut_ptr(),
        regions,
        segment_of,
        vertex_capacity: t
            .vertices
            .capacity()
            .min(segment_capacity)
            .min(u32::MAX as usize) as u32,
        triangle_capacity: t
            .corners
            .capacity()
            .min(t.across.capacity())
            .min(region_capacity)
            .min(u32::MAX as usize) as u32,
    }
}

/// New numbers for the numbers in `chunks` (which lie in `[first, end)`), in chunk order from
/// `first`; numbers in no chunk map to [`NONE`].
fn renumbering(chunks: &[Chunk], first: u32, end: u32) -> Vec<u32> {
    let mut map = vec![NONE; (end - first) as usize];
    let mut next = first;
    for c in chunks {
        for k in 0..c.len {
            map[(c.start + k - first) as usize] = next + k;
        }
        next += c.len;
    }
    map
}

/// Work waiting for a tile: bad triangles and encroached boundary edges for the current grid,
/// and per coarser grid, the batches of bad triangles filed under it.
#[derive(Debug, Default)]
struct Lists {
    bad: Vec<Pending>,
    edges: Vec<Encroached>,
    later: Vec<Vec<Vec<Pending>>>,
}

impl Lists {
    fn is_empty(&self) -> bool {
        self.bad.is_empty() && self.edges.is_empty()
    }
}

/// A read-only view of the shared arrays between passes, for the queue checks.
struct Frozen<'a, 't>(&'a Shared<'t>);

impl Store for Frozen<'_, '_> {
    const WHOLE: bool = false;
    fn point(&self, v: u32) -> DVec2 {
        self.0.point(v)
    }
    fn corners(&self, t: u32) -> [u32; 3] {
        self.0.corners(t)
    }
    fn corners_mut(&mut self, _t: u32) -> &mut [u32; 3] {
        unreachable!("a frozen view is only read")
    }
    fn across(&self, t: u32) -> [u32; 3] {
        assert!(t < self.0.triangle_end);
        // SAFETY: as for `Shared::corners`: `corners` and `across` slots are handed out and
        // written together (`push_triangle`), and their capacity is the smaller of the two.
        #[allow(unsafe_code)]
        unsafe {
            *self.0.arrays.across.add(t as usize)
        }
    }
    fn across_mut(&mut self, _t: u32) -> &mut [u32; 3] {
        unreachable!("a frozen view is only read")
    }
    fn push_vertex(&mut self, _p: DVec2) -> u32 {
        unreachable!("a frozen view is only read")
    }
    fn push_triangle(&mut self) -> u32 {
        unreachable!("a frozen view is only read")
    }
    fn may_change(&self, _corners: [u32; 3]) -> bool {
        false
    }
    fn triangle_count(&self) -> usize {
        self.0.triangle_end as usize
    }
    fn vertex_count(&self) -> usize {
        self.0.vertex_end as usize
    }
    fn room(&self) -> bool {
        false
    }
}

/// One tile's view of the shared arrays during a pass.
///
/// The rules that make the sharing sound: the tiles of a pass are disjoint half-open squares,
/// and a tile touches only
/// - triangles whose three corners lie in it (it may change them), and the triangles next to
///   those (it may read them, mark them and relink them), which have two corners in it;
/// - vertices that existed before the pass or that it made itself.
///
/// No triangle has two corners in each of two disjoint tiles, so no triangle is touched by two
/// tiles of a pass; the triangles a tile makes have their corners in it (the new vertex lies
/// in a triangle of the tile, and a tile holds every point between two of its points). Vertex
/// and triangle numbers come from chunks that belong to one tile, inside the capacity reserved
/// before the pass.
struct TileStore<'a> {
    arrays: &'a Arrays,
    /// The tile: the points `p` with `lo <= p < hi`, the same as those the grid puts in it.
    lo: DVec2,
    hi: DVec2,
    next: &'a Counters,
    vertex: Chunk,
    triangle: Chunk,
    vertex_chunks: Vec<Chunk>,
    triangle_chunks: Vec<Chunk>,
    /// Vertices this tile may still make.
    allowance: usize,
}

/// The next free vertex number and triangle slot of a pass.
struct Counters {
    vertex: AtomicU32,
    triangle: AtomicU32,
}

/// The bound of a tile's raw access to the shared arrays, checked in debug builds and in the
/// crate's own tests (which CI runs in release builds too). A release library leaves it out:
/// these are the innermost accesses of every dig, where the check costs several percent of
/// the instructions refinement runs (valgrind's count on nested rings of 20 000 segments).
#[inline(always)]
fn check_slot(i: u32, capacity: u32) {
    if cfg!(any(debug_assertions, test)) {
        assert!(i < capacity, "slot {i} past the capacity {capacity}");
    }
}

impl TileStore<'_> {
    #[inline]
    fn vertex_ptr(&self, v: u32) -> *mut DVec2 {
        let v = v & !MARK;
        check_slot(v, self.arrays.vertex_capacity);
        // SAFETY: `add` stays within the buffer's capacity (checked above in debug builds and
        // in the crate's tests): the numbers a tile uses are corners of triangles it reached,
        // all below the `vertex_end` of its pass, at most the capacity reserved before the
        // pass, or numbers of its own chunks, each asserted against the capacity in
        // `push_vertex`. Only the offset is computed here; what may be read or written through
        // it is argued where it is dereferenced.
        #[allow(unsafe_code)]
        unsafe {
            self.arrays.vertices.add(v as usize)
        }
    }

    #[inline]
    fn corners_ptr(&self, t: u32) -> *mut [u32; 3] {
        check_slot(t, self.arrays.triangle_capacity);
        // SAFETY: as for `vertex_ptr`, the bound checked above: triangle numbers come from
        // triangles' neighbours and queue entries (below the pass's `triangle_end`, within the
        // reserved capacity) or from this tile's chunks (asserted against the capacity in
        // `push_triangle`).
        #[allow(unsafe_code)]
        unsafe {
            self.arrays.corners.add(t as usize)
        }
    }

    #[inline]
    fn across_ptr(&self, t: u32) -> *mut [u32; 3] {
        check_slot(t, self.arrays.triangle_capacity);
        // SAFETY: as for `corners_ptr`; `triangle_capacity` is that of the smaller of the
        // `corners` and `across` buffers.
        #[allow(unsafe_code)]
        unsafe {
            self.arrays.across.add(t as usize)
        }
    }

    /// The chunks this tile used, its last one cut to what it used.
    fn finish(mut self) -> (Vec<Chunk>, Vec<Chunk>) {
        for (chunk, list) in [
            (self.vertex, &mut self.vertex_chunks),
            (self.triangle, &mut self.triangle_chunks),
        ] {
            if chunk.len > 0 {
                list.push(chunk);
            }
        }
        (self.vertex_chunks, self.triangle_chunks)
    }
}

/// Takes the next number of `chunk`, starting a new chunk from `counter` when there is none
/// yet or it is full, twice as large as the last up to `largest`; the full chunk goes to
/// `used`.
#[inline]
fn take(chunk: &mut Chunk, used: &mut Vec<Chunk>, counter: &AtomicU32, largest: u32) -> u32 {
    if chunk.start == NONE || chunk.len == chunk.size {
        if chunk.len > 0 {
            used.push(*chunk);
        }
        let size = (2 * chunk.size).min(largest);
        *chunk = Chunk {
            start: counter.fetch_add(size, Ordering::Relaxed),
            len: 0,
            size,
        };
    }
    chunk.len += 1;
    chunk.start + chunk.len - 1
}

// The methods dereference the pointers of `vertex_ptr`/`corners_ptr`/`across_ptr` (in
// bounds, as argued there) under the rules on `TileStore` (no other tile of the pass touches
// the element), each with its own argument.
#[allow(unsafe_code)]
impl Store for TileStore<'_> {
    const WHOLE: bool = false;

    #[inline]
    fn point(&self, v: u32) -> DVec2 {
        // SAFETY: `v` is a corner of a triangle the tile reached (or one it made), so the
        // vertex existed before the pass (written, below the vector's length or in a settled
        // chunk) or this tile wrote it in `push_vertex`; a vertex is never written again once
        // made, so no other tile writes it meanwhile.
        unsafe { *self.vertex_ptr(v) }
    }
    #[inline]
    fn corners(&self, t: u32) -> [u32; 3] {
        // SAFETY: the refiner reads only triangles of the tile and their neighbours, which have
        // two corners in it, so no other tile of the pass writes them; the slot was written
        // (before the pass, or by this tile's `push_triangle`).
        unsafe { *self.corners_ptr(t) }
    }
    #[inline]
    fn corners_mut(&mut self, t: u32) -> &mut [u32; 3] {
        // SAFETY: as for `corners`: the refiner changes only triangles of the tile
        // (`may_change`) and marks and relinks their neighbours, all with two corners in the
        // tile, which no other tile of the pass reads or writes; the reference lives no longer
        // than `&mut self`, so this tile makes no other reference to the slot meanwhile.
        unsafe { &mut *self.corners_ptr(t) }
    }
    #[inline]
    fn across(&self, t: u32) -> [u32; 3] {
        // SAFETY: as for `corners`.
        unsafe { *self.across_ptr(t) }
    }
    #[inline]
    fn across_mut(&mut self, t: u32) -> &mut [u32; 3] {
        // SAFETY: as for `corners_mut`.
        unsafe { &mut *self.across_ptr(t) }
    }
    fn push_vertex(&mut self, p: DVec2) -> u32 {
        let v = take(
            &mut self.vertex,
            &mut self.vertex_chunks,
            &self.next.vertex,
            VERTEX_CHUNK,
        );
        self.allowance -= 1;
        assert!(v < self.arrays.vertex_capacity, "vertex room was reserved");
        // SAFETY: in bounds (asserted just above); `v` is a fresh number of this tile's chunk,
        // which no other tile was given (`fetch_add` in `take`) and nothing reads before this
        // write; `write` drops nothing, so the slot may be uninitialised. The same holds for
        // the segment array, whose capacity bounds `vertex_capacity` too where it is kept.
        unsafe {
            self.vertex_ptr(v).write(p);
            if !self.arrays.segment_of.is_null() {
                self.arrays.segment_of.add(v as usize).write(NONE);
            }
        }
        v
    }
    fn push_triangle(&mut self) -> u32 {
        let t = take(
            &mut self.triangle,
            &mut self.triangle_chunks,
            &self.next.triangle,
            TRIANGLE_CHUNK,
        );
        assert!(
            t < self.arrays.triangle_capacity,
            "triangle room was reserved"
        );
        // SAFETY: as in `push_vertex`: in bounds of both buffers (asserted against the
        // smaller capacity), a fresh slot of this tile's chunk, written before it is read.
        unsafe {
            self.corners_ptr(t).write([0; 3]);
            self.across_ptr(t).write([NONE; 3]);
            if !self.arrays.regions.is_null() {
                self.arrays.regions.add(t as usize).write(NONE);
            }
        }
        t
    }
    #[inline]
    fn may_change(&self, corners: [u32; 3]) -> bool {
        corners.iter().all(|&v| {
            let p = self.point(v);
            self.lo.cmple(p).all() && p.cmplt(self.hi).all()
        })
    }
    fn triangle_count(&self) -> usize {
        self.arrays.triangle_capacity as usize
    }
    fn vertex_count(&self) -> usize {
        0
    }
    fn room(&self) -> bool {
        self.allowance > 0
    }
    #[inline]
    fn keeps_regions(&self) -> bool {
        !self.arrays.regions.is_null()
    }
    #[inline]
    fn region(&self, t: u32) -> u32 {
        if self.arrays.regions.is_null() {
            return NONE;
        }
        assert!(t < self.arrays.triangle_capacity);
        // SAFETY: as for `corners`: a triangle the tile reached, whose slot (within the
        // capacity, which the region array's bounds) was written before the pass or by this
        // tile's `push_triangle`, and which no other tile of the pass touches.
        unsafe { *self.arrays.regions.add(t as usize) }
    }
    #[inline]
    fn set_region(&mut self, t: u32, r: u32) {
        if !self.arrays.regions.is_null() {
            assert!(t < self.arrays.triangle_capacity);
            // SAFETY: as for `corners_mut`: a triangle of the tile, touched by no other tile.
            unsafe { self.arrays.regions.add(t as usize).write(r) }
        }
    }
    #[inline]
    fn segment_of(&self, v: u32) -> u32 {
        if self.arrays.segment_of.is_null() {
            return NONE;
        }
        let v = v & !MARK;
        assert!(v < self.arrays.vertex_capacity);
        // SAFETY: as for `point`: a vertex that existed before the pass or that this tile
        // made, written then; a vertex's segment is written only by the tile that makes it,
        // right after `push_vertex`, before any other tile can reach the vertex.
        unsafe { *self.arrays.segment_of.add(v as usize) }
    }
    #[inline]
    fn set_segment_of(&mut self, v: u32, segment: u32) {
        if !self.arrays.segment_of.is_null() {
            assert!(v < self.arrays.vertex_capacity);
            // SAFETY: `v` is a vertex this tile just made (see `segment_of`).
            unsafe { self.arrays.segment_of.add(v as usize).write(segment) }
        }
    }
}

/// What a tile's pass left: work set aside, and the chunks it used.
struct TileOutcome {
    result: Result<super::refiner::Finish, Error>,
    deferred: Lists,
    vertex_chunks: Vec<Chunk>,
    triangle_chunks: Vec<Chunk>,
    inserted: usize,
}

/// The work of one tile in a pass.
struct Job {
    tile: u64,
    work: Lists,
}

impl Job {
    /// The points the tile may insert in this pass, before the budget.
    fn allowance(&self) -> usize {
        ALLOWANCE_PER_ENTRY * (self.work.bad.len() + self.work.edges.len()) + ALLOWANCE_PER_TILE
    }
}

/// The points each job may insert: its allowance, all of them scaled down to share what is
/// left of the vertex budget when they would exceed it.
fn allowances(jobs: &[Job], remaining: usize) -> Vec<usize> {
    let wanted: Vec<usize> = jobs.iter().map(Job::allowance).collect();
    let total: usize = wanted.iter().sum();
    if total <= remaining {
        return wanted;
    }
    wanted
        .iter()
        .map(|&a| (a as u128 * remaining as u128 / total as u128) as usize)
        .collect()
}

/// The vertices and triangle slots that tiles with these allowances may take at most, their
/// last chunks included.
fn room_for(allowances: &[usize]) -> (usize, usize) {
    allowances.iter().fold((0, 0), |(v, t), &a| {
        (
            v + a + VERTEX_CHUNK as usize,
            t + 2 * a + TRIANGLE_CHUNK as usize,
        )
    })
}

/// The grids, from fine to coarse, and the size classes each takes: [`OCTAVES_PER_GRID`]
/// octaves of shortest-edge lengths per grid, the edges [`CELL_PER_EDGE`] times shorter than
/// the cells.
struct Levels {
    /// `limits[level]`: the largest size class the grid of that level takes.
    limits: Vec<usize>,
    finest: usize,
    /// The grid of each size class.
    level_of_class: Vec<u8>,
    /// The side of the square the grids cover.
    side: f64,
}

impl Levels {
    fn new(side: f64, bad: &[Pending]) -> Self {
        let limits: Vec<usize> = (0..=FINEST)
            .map(|level| {
                let edge = side / 2f64.powi(level as i32) / CELL_PER_EDGE;
                SizeQueue::class_of(edge * edge)
            })
            .collect();
        let smallest = bad.par_iter().map(|p| p.class as usize).min().unwrap_or(0);
        let finest = (COARSEST..=FINEST)
            .rev()
            .find(|&l| smallest <= limits[l])
            .unwrap_or(COARSEST);
        let mut levels = Levels {
            limits,
            finest,
            level_of_class: Vec::new(),
            side,
        };
        levels.level_of_class = (0..SizeQueue::CLASSES)
            .map(|class| levels.level_of(class) as u8)
            .collect();
        levels
    }

    /// The grids used, finest first.
    fn used(&self) -> impl Iterator<Item = usize> + '_ {
        (COARSEST..=self.finest)
            .rev()
            .filter(|&l| (self.finest - l).is_multiple_of(OCTAVES_PER_GRID) || l == COARSEST)
    }

    /// The finest grid that takes size class `class` (the coarsest for larger ones).
    fn level_of(&self, class: usize) -> usize {
        self.used()
            .find(|&l| class <= self.limits[l])
            .unwrap_or(COARSEST)
    }

    /// The finest grid whose cells are wider than `extent`, where some tile of some colour
    /// holds a triangle that wide: a tile of a finer grid would only set it aside.
    fn holding(&self, extent: f64) -> usize {
        // One level coarser than the ratio says: rounding cannot make it too fine, and the
        // nested rings' refinement took less time so than at the finest fitting level.
        let levels = (self.side / extent).log2();
        if levels.is_nan() || levels < 1.0 {
            return COARSEST;
        }
        (levels as usize - 1).clamp(COARSEST, FINEST)
    }

    /// The grid that takes a bad triangle of size class `class` and extent `extent`: the one
    /// of its class if its cells are wider than the triangle (then some tile holds it), else a
    /// coarser one that holds it.
    fn level_for(&self, class: u32, extent: f64) -> usize {
        let by_class = self.level_of_class[class as usize] as usize;
        if extent < self.side / 2f64.powi(by_class as i32) {
            return by_class;
        }
        // The triangle is at least a cell of `by_class` wide: `holding` is no finer.
        let fits = self.holding(extent);
        self.used().find(|&l| l <= fits).unwrap_or(COARSEST)
    }

    /// Files bad triangles under the grid that takes them, as one new batch per grid: lists
    /// that grew instead would be copied again and again.
    fn file(&self, shared: &Shared, bad: Vec<Pending>, by_level: &mut [Vec<Vec<Pending>>]) {
        let levels: Vec<u8> = bad
            .par_iter()
            .map(|p| self.level_for(p.class, shared.extent(p.entry.triangle)) as u8)
            .collect();
        let mut counts = vec![0; by_level.len()];
        for &l in &levels {
            counts[l as usize] += 1;
        }
        let mut batches: Vec<Vec<Pending>> = counts.into_iter().map(Vec::with_capacity).collect();
        for (p, l) in bad.into_iter().zip(levels) {
            batches[l as usize].push(p);
        }
        for (waiting, batch) in by_level.iter_mut().zip(batches) {
            if !batch.is_empty() {
                waiting.push(batch);
            }
        }
    }
}

/// Refines by tiles, grid after grid from fine to coarse: each grid takes the bad triangles of
/// its octave of sizes, so that, as Har-Peled and Üngör order them, the small ones are fixed
/// first, and what did not fit its tiles; rounds of the four colours run while they make
/// progress. Returns the work no tile could do, numbered for the settled triangulation.
pub(super) fn refine_tiles(
    t: &mut Triangulation,
    origin: DVec2,
    side: f64,
    bounds: &Bounds,
    bad: Vec<Pending>,
    edges: Vec<Encroached>,
    budget: usize,
) -> Result<(Vec<Pending>, Vec<Encroached>), Error> {
    let levels = Levels::new(side, &bad);
    let mut shared = Shared::new(t);
    let mut lists = Lists {
        bad: Vec::new(),
        edges,
        later: vec![Vec::new(); levels.finest + 1],
    };
    levels.file(&shared, bad, &mut lists.later);
    // A tile that stops where f64 cannot place a vertex leaves the triangulation valid: it is
    // settled all the same, so that the mesh reached can be returned with the error.
    let grids = grid_after_grid(
        &mut shared,
        origin,
        side,
        bounds,
        budget,
        &levels,
        &mut lists,
    );
    shared.settle(&mut lists);
    grids?;
    let mut bad = lists.bad;
    for batch in lists.later.into_iter().flatten() {
        bad.extend(batch);
    }
    Ok((bad, lists.edges))
}

/// The grids of [`refine_tiles`] from fine to coarse, then the pass on tiles twice as wide.
fn grid_after_grid(
    shared: &mut Shared,
    origin: DVec2,
    side: f64,
    bounds: &Bounds,
    budget: usize,
    levels: &Levels,
    lists: &mut Lists,
) -> Result<(), Error> {
    let used: Vec<usize> = levels.used().collect();
    for level in used {
        let waiting = std::mem::take(&mut lists.later[level]);
        lists.bad.reserve(waiting.iter().map(Vec::len).sum());
        for batch in waiting {
            lists.bad.extend(batch);
        }
        let tiling = Tiling::at_level(origin, side, level);
        let limit = levels.limits[level];
        let file = |shared: &Shared, larger, lists: &mut Lists| {
            levels.file(shared, larger, &mut lists.later);
        };
        if !rounds(shared, (&tiling, limit), bounds, budget, lists, file)? {
            break;
        }
    }
    // What no grid's tiles took, often triangles wider than a tile of the coarsest: a few
    // rounds on tiles twice as wide, all size classes at once, before the sequential loop
    // (none past the vertex budget: `rounds` checks it first).
    for batch in lists.later.iter_mut().flat_map(std::mem::take) {
        lists.bad.extend(batch);
    }
    let tiling = Tiling::at_level(origin, side, COARSEST - 1);
    let none_larger = |_: &Shared, larger: Vec<Pending>, _: &mut Lists| {
        debug_assert!(larger.is_empty());
    };
    rounds(
        shared,
        (&tiling, usize::MAX),
        bounds,
        budget,
        lists,
        none_larger,
    )?;
    Ok(())
}

/// Rounds of the four colours of `tiling`, each tile taking the bad triangles up to size
/// class `limit`, while they make progress and at most [`MAX_ROUNDS`]; after each pass,
/// `set_aside` takes the bad triangles above the limit. Returns false where the vertex budget
/// stopped them.
fn rounds(
    shared: &mut Shared,
    (tiling, limit): (&Tiling, usize),
    bounds: &Bounds,
    budget: usize,
    lists: &mut Lists,
    mut set_aside: impl FnMut(&Shared, Vec<Pending>, &mut Lists),
) -> Result<bool, Error> {
    for _ in 0..MAX_ROUNDS {
        let mut inserted = 0;
        for colour in 0..4 {
            if shared.vertex_end as usize > budget {
                return Ok(false);
            }
            let (n, larger) = pass(shared, tiling, bounds, colour, limit, budget, lists)?;
            set_aside(shared, larger, lists);
            inserted += n;
        }
        if lists.is_empty() || inserted == 0 {
            break;
        }
    }
    Ok(true)
}

/// One pass: the tiles of `colour` refined in parallel, each working through the entries it
/// holds up to size class `limit`. Returns the number of points inserted and the bad triangles
/// above the limit the tiles set aside; `lists` is left with what no tile took and what the
/// tiles set aside otherwise, in tile order.
fn pass(
    shared: &mut Shared,
    tiling: &Tiling,
    bounds: &Bounds,
    colour: u8,
    limit: usize,
    budget: usize,
    lists: &mut Lists,
) -> Result<(usize, Vec<Pending>), Error> {
    if lists.is_empty() {
        return Ok((0, Vec::new()));
    }
    let mut jobs = share_out(shared, tiling, colour, lists);
    // A tile makes at most a few vertices per entry before its allowance runs out. Room for
    // all tiles is reserved first, so that none can run out, whatever the timing.
    let remaining = budget.saturating_sub(shared.vertex_end as usize);
    let mut allowed = allowances(&jobs, remaining);
    let (vertices, triangles) = room_for(&allowed);
    if !shared.has_room(vertices, triangles) {
        // Settling renumbers: give the work back, settle, and share it out again.
        for job in jobs {
            lists.bad.extend(job.work.bad);
            lists.edges.extend(job.work.edges);
        }
        shared.make_room(vertices, triangles, lists);
        jobs = share_out(shared, tiling, colour, lists);
        allowed = allowances(&jobs, remaining);
    }
    if jobs.is_empty() {
        return Ok((0, Vec::new()));
    }
    let counters = Counters {
        vertex: AtomicU32::new(shared.vertex_end),
        triangle: AtomicU32::new(shared.triangle_end),
    };
    let arrays = &shared.arrays;
    let outcomes: Vec<TileOutcome> = jobs
        .into_par_iter()
        .zip(allowed)
        .map_init(Work::new, |work, (job, allowance)| {
            let (lo, hi) = tiling.bounds(colour, job.tile);
            let store = TileStore {
                arrays,
                lo,
                hi,
                next: &counters,
                vertex: Chunk::NONE,
                triangle: Chunk::NONE,
                vertex_chunks: Vec::new(),
                triangle_chunks: Vec::new(),
                allowance,
            };
            run_tile(store, work, bounds, limit, job)
        })
        .collect();
    shared.vertex_end = counters.vertex.into_inner();
    shared.triangle_end = counters.triangle.into_inner();
    let mut inserted = 0;
    let mut larger = Vec::new();
    let mut first_error = None;
    for o in outcomes {
        if first_error.is_none()
            && let Err(e) = o.result
        {
            first_error = Some(e);
        }
        inserted += o.inserted;
        shared.vertex_chunks.extend(o.vertex_chunks);
        shared.triangle_chunks.extend(o.triangle_chunks);
        for p in o.deferred.bad {
            if p.class as usize > limit {
                larger.push(p);
            } else {
                lists.bad.push(p);
            }
        }
        lists.edges.extend(o.deferred.edges);
    }
    match first_error {
        Some(e) => Err(e),
        None => Ok((inserted, larger)),
    }
}

fn run_tile(
    mut store: TileStore,
    work: &mut Work,
    bounds: &Bounds,
    class_limit: usize,
    job: Job,
) -> TileOutcome {
    work.queue_all(&job.work.bad, &job.work.edges);
    work.inserted = 0;
    // The store goes into the loop by reference so that its chunks can be read back after.
    let result = Refiner::new(&mut store, work, bounds, usize::MAX)
        .up_to_class(class_limit)
        .run();
    let deferred = Lists {
        bad: std::mem::take(&mut work.deferred),
        edges: std::mem::take(&mut work.deferred_edges),
        later: Vec::new(),
    };
    let (vertex_chunks, triangle_chunks) = store.finish();
    TileOutcome {
        result,
        deferred,
        vertex_chunks,
        triangle_chunks,
        inserted: work.inserted,
    }
}

/// Splits the waiting bad triangles and edges of `lists` between the tiles of `colour`: each
/// live entry goes to the tile that holds its whole triangle, in the order it had; stale
/// entries are dropped, and entries no tile holds stay in `lists`, in order.
fn share_out(shared: &Shared, tiling: &Tiling, colour: u8, lists: &mut Lists) -> Vec<Job> {
    let frozen = Frozen(shared);
    let bad = std::mem::take(&mut lists.bad);
    let edges = std::mem::take(&mut lists.edges);
    let bad_owner = owners(&bad, |p| {
        is_current(&frozen, &p.entry).then(|| shared.owner(tiling, colour, p.entry.triangle))
    });
    let edge_owner = owners(&edges, |e| {
        is_live(&frozen, e).then(|| shared.owner(tiling, colour, e.triangle))
    });
    lists.bad = unowned(&bad, &bad_owner);
    lists.edges = unowned(&edges, &edge_owner);
    // (tile, entry) pairs, edges numbered after the bad triangles: by tile, each in its old
    // order, bad triangles first.
    let edge_base = bad.len() as u64;
    let mut owned: Vec<(u64, u64)> = owned_by_tiles(&bad_owner, 0)
        .chain(owned_by_tiles(&edge_owner, edge_base))
        .collect();
    owned.par_sort_unstable();
    let starts = crate::par::run_starts(owned.len(), |i| owned[i].0);
    starts
        .par_windows(2)
        .map(|w| {
            let group = &owned[w[0]..w[1]];
            let split = group.partition_point(|&(_, k)| k < edge_base);
            Job {
                tile: group[0].0,
                work: Lists {
                    bad: group[..split]
                        .iter()
                        .map(|&(_, k)| bad[k as usize])
                        .collect(),
                    edges: group[split..]
                        .iter()
                        .map(|&(_, k)| edges[(k - edge_base) as usize])
                        .collect(),
                    later: Vec::new(),
                },
            }
        })
        .collect()
}

/// An entry's owner: the tile holding its triangle, [`UNOWNED`] for none, [`STALE`] for an
/// entry no longer live.
const STALE: u64 = u64::MAX;
const UNOWNED: u64 = u64::MAX - 1;

/// Each entry's owner, in parallel; `owner` gives `None` for a stale entry.
fn owners<T: Sync>(entries: &[T], owner: impl Fn(&T) -> Option<Option<u64>> + Sync) -> Vec<u64> {
    entries
        .par_iter()
        .map(|e| match owner(e) {
            None => STALE,
            Some(tile) => tile.unwrap_or(UNOWNED),
        })
        .collect()
}

/// The live entries no tile holds, in order.
fn unowned<T: Copy + Send + Sync>(entries: &[T], owners: &[u64]) -> Vec<T> {
    entries
        .par_iter()
        .zip(owners)
        .filter(|&(_, &o)| o == UNOWNED)
        .map(|(e, _)| *e)
        .collect()
}

/// `(tile, base + k)` for every entry `k` a tile holds.
fn owned_by_tiles(owners: &[u64], base: u64) -> impl ParallelIterator<Item = (u64, u64)> + '_ {
    owners
        .par_iter()
        .enumerate()
        .filter(|&(_, &o)| o < UNOWNED)
        .map(move |(k, &o)| (o, base + k as u64))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// Enough clustered points for the tiles (at least [`MIN_POINTS`]), refined on two
    /// threads: in the crate's tests, release builds included, every access of a tile to the
    /// shared arrays has its bound checked (`check_slot` in `TileStore::vertex_ptr`,
    /// `corners_ptr`, `across_ptr`), so this runs the tiles' unsafe code under those checks.
    /// The mesh is valid, and the same on one thread.
    #[test]
    fn tiles_refine_enough_points_the_same_on_one_and_two_threads() {
        let points = crate::generate::points(crate::generate::Distribution2d::Cluster, 20_000, 4);
        assert!(points.len() >= MIN_POINTS, "the tiles run");
        let options = crate::refine::RefineOptions {
            domain: crate::refine::RefineDomain::Square,
            min_angle_deg: 30.0,
            ..crate::refine::RefineOptions::default()
        };
        let on = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| crate::refine::refine_points(&points, &options).unwrap().0)
        };
        let two = on(2);
        let bounds = crate::mesh::AngleBounds {
            min_deg: 30.0,
            max_deg: 120.0,
        };
        two.validate(&points, bounds).unwrap();
        assert!(two == on(1), "the mesh depends on the thread count");
    }

    /// A bad triangle narrower than the coarsest grid's cells is filed under a grid where a
    /// tile of some colour holds it whole, so that no grid finer than its size passes it by
    /// unrefined; and under a grid at most three levels coarser than the finest that would.
    #[test]
    fn a_bad_triangle_goes_to_a_grid_whose_tiles_hold_it() {
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(5);
        for (origin, side) in [(DVec2::ZERO, 1.0), (DVec2::new(-3e5, 7.0), 6e5)] {
            // No bad triangles: every grid down to the finest is used.
            let levels = Levels::new(side, &[]);
            for _ in 0..5000 {
                // Narrower than the coarsest grid's cells: wider ones no tile holds, and the
                // sequential loop takes them.
                let extent = side * 2f64.powf(-rng.random_range(COARSEST as f64 + 0.01..30.0));
                let lo = origin + DVec2::new(rng.random(), rng.random()) * (side - extent);
                let corners = [(); 3].map(|_| lo + DVec2::new(rng.random(), rng.random()) * extent);
                let (a, b) = (
                    corners.iter().fold(corners[0], |m, &c| m.min(c)),
                    corners.iter().fold(corners[0], |m, &c| m.max(c)),
                );
                let width = (b - a).max_element();
                let held = |level| {
                    let tiling = Tiling::at_level(origin, side, level);
                    (0..4).any(|colour| tiling.owner(colour, corners).is_some())
                };
                // Class 0 belongs to the finest grid, which holds none of these.
                let level = levels.level_for(0, width);
                assert!(held(level), "{corners:?} at level {level}");
                let finest_holding = (level..=FINEST).rev().find(|&l| held(l)).unwrap();
                assert!(
                    level + 3 >= finest_holding,
                    "{corners:?}: {level} for {finest_holding}"
                );
                // A triangle narrower than its class's cells stays with its class.
                let limit = levels.limits[rng.random_range(COARSEST..=FINEST)];
                let class = limit.saturating_sub(rng.random_range(0..8)) as u32;
                let own = levels.level_of_class[class as usize] as usize;
                let level = levels.level_for(class, width);
                if width < side / 2f64.powi(own as i32) {
                    assert_eq!(level, own, "{corners:?} of class {class}");
                } else {
                    assert!(level < own && held(level), "{corners:?} of class {class}");
                }
            }
        }
    }

    /// A tile's bounds hold exactly the points the grid puts in the tile, on grids far from
    /// the origin and with cells near the resolution of f64, and for points right at the
    /// bounds.
    #[test]
    fn tile_bounds_hold_exactly_the_tiles_points() {
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(3);
        for (origin, side, level) in [
            (DVec2::ZERO, 1.0, 3),
            (DVec2::new(-0.5, -0.25), 2.0, 9),
            (DVec2::new(-6.5e11, -6.5e11), 1.3e12, 32),
            (DVec2::new(1e6, -3.0), 1e-3, 20),
        ] {
            let tiling = Tiling::at_level(origin, side, level);
            for _ in 0..2000 {
                let p = origin + DVec2::new(rng.random(), rng.random()) * side;
                for colour in 0..4 {
                    let tile = tiling.tile(colour, p);
                    let (lo, hi) = tiling.bounds(colour, tile);
                    assert!(lo.cmple(p).all() && p.cmplt(hi).all(), "{p} in {lo}..{hi}");
                    for q in [lo, hi, DVec2::new(lo.x.next_down(), lo.y.next_down())] {
                        let inside = lo.cmple(q).all() && q.cmplt(hi).all();
                        let finite = q.is_finite();
                        assert!(
                            !finite || inside == (tiling.tile(colour, q) == tile),
                            "{q} at level {level}, colour {colour}"
                        );
                    }
                }
            }
        }
    }
}
