//! The triangles edits change, found without warping the whole tree.
//!
//! While changes are tracked, the tree logs each split square an edit adds or takes out with
//! its state before, and the mesh logs each point an edit touches with where it was. Every
//! triangle of a leaf is a function of the leaf, its neighbours and the points near it
//! ([`crate::warp`]), so the triangles that differ lie in the changed leaves and their
//! neighbours. Both trees, as they were and as they are, are warped split only around that
//! place (with the squares balance forces), with the points around it: inside, their meshes are
//! the whole meshes' triangles; outside, both are the same coarser mesh and drop out of the
//! difference. The cost grows with the leaves around the change, not with the points.

use std::collections::HashMap;

use glam::DVec2;

use super::{DynamicMesh, Keyed, Tracked, mesh_tree};
use crate::balance::GridRect;
use crate::error::Error;
use crate::morton::{Cell, MortonKey};

/// Triangles of a dynamic mesh that edits took out and put in, each by its corners
/// counter-clockwise, starting from the least corner (by coordinates' bits).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriangleChanges {
    /// Triangles the edits took out.
    pub removed: Vec<[DVec2; 3]>,
    /// Triangles the edits put in.
    pub added: Vec<[DVec2; 3]>,
    /// The work it took: the leaves of the two partial trees warped to find them (in
    /// [`DynamicMesh`]), or the vertices triangulated ([`super::DynamicDelaunay`]).
    pub leaves: usize,
}

/// What a dynamic mesh keeps of the edits since its changes were last taken.
#[derive(Clone, Default)]
pub(super) struct ChangeLog {
    /// Each point an edit touched, by id, with where it was (`None`: not live).
    points: HashMap<u32, Option<DVec2>>,
    /// The tree as the first rebuild since the log started found it: its own log still holds
    /// its squares as they were.
    before: Option<Box<Tracked>>,
}

impl ChangeLog {
    /// Notes that point `id`, at `before` now, is about to change.
    pub(super) fn note_point(&mut self, id: u32, before: Option<DVec2>) {
        self.points.entry(id).or_insert(before);
    }

    /// Notes that `tree` is about to be built anew.
    pub(super) fn note_rebuild(&mut self, tree: &Tracked) {
        if self.before.is_none() {
            self.before = Some(Box::new(tree.clone()));
        }
    }
}

/// A triangle by its corners' coordinate bits, from the least corner on, its orientation kept:
/// equal triangles compare equal.
type TriangleBits = [[u64; 2]; 3];

fn triangle_bits(corners: [DVec2; 3]) -> TriangleBits {
    let mut bits = corners.map(|p| [p.x.to_bits(), p.y.to_bits()]);
    let least = (0..3).min_by_key(|&i| bits[i]).unwrap_or(0);
    bits.rotate_left(least);
    bits
}

/// `triangles` each from its least corner, sorted by their bits, repeats dropped.
pub(super) fn in_order(triangles: Vec<[DVec2; 3]>) -> Vec<[DVec2; 3]> {
    let mut bits: Vec<TriangleBits> = triangles.into_iter().map(triangle_bits).collect();
    bits.sort_unstable();
    bits.dedup();
    bits.iter().map(corners).collect()
}

fn corners(bits: &TriangleBits) -> [DVec2; 3] {
    bits.map(|[x, y]| DVec2::new(f64::from_bits(x), f64::from_bits(y)))
}

/// A point that edits changed: its id, where it was and where it is (`None`: not live).
type Moved = (u32, Option<DVec2>, Option<DVec2>);

/// Where two trees' meshes can differ, in grid units: the points to warp lie in `points`, and
/// the trees are split as in full where they meet `exact`.
#[derive(Clone, Debug)]
struct Region {
    points: Vec<GridRect>,
    exact: Vec<GridRect>,
}

impl DynamicMesh {
    /// Starts tracking which triangles edits change (see [`Self::take_changes`]), or with `on`
    /// false stops it. Tracking costs a little per edit, and a copy of the tree when an edit
    /// builds it anew.
    pub fn track_changes(&mut self, on: bool) {
        self.log = on.then(ChangeLog::default);
        self.tree.log_changes(on);
    }

    /// The triangles of [`Self::mesh`] that the edits since tracking started, or since the
    /// last call, took out and put in; tracking starts again from here (after an error, the
    /// changes are kept for the next call). Removing `removed` from the mesh as it was and
    /// adding `added` gives the mesh as it is. Found by warping the tree only around what
    /// changed, in time that grows with the leaves there; an edit that built the tree anew (a
    /// large batch, a change of grid) costs two whole warps.
    ///
    /// # Errors
    /// [`Error::InvalidOption`] when changes are not tracked; what the warp refuses.
    pub fn take_changes(&mut self) -> Result<TriangleChanges, Error> {
        self.take(false)
    }

    /// As [`Self::take_changes`], for [`Self::mesh_nonobtuse`].
    ///
    /// # Errors
    /// As [`Self::take_changes`].
    pub fn take_nonobtuse_changes(&mut self) -> Result<TriangleChanges, Error> {
        self.take(true)
    }

    fn take(&mut self, nonobtuse: bool) -> Result<TriangleChanges, Error> {
        self.check_nonobtuse(nonobtuse)?;
        let Some(log) = self.log.take() else {
            return Err(Error::InvalidOption {
                option: "changes",
                message: "changes are not tracked: call track_changes(true) first".into(),
            });
        };
        match self.changes_since(&log, nonobtuse) {
            Ok(changes) => {
                self.track_changes(true);
                Ok(changes)
            }
            Err(e) => {
                // Nothing is lost: the next call finds the same changes and any since.
                self.log = Some(log);
                Err(e)
            }
        }
    }

    fn changes_since(&self, log: &ChangeLog, nonobtuse: bool) -> Result<TriangleChanges, Error> {
        let mut moved: Vec<Moved> = log
            .points
            .iter()
            .filter_map(|(&id, &before)| {
                let now = self.point(id);
                (before != now).then_some((id, before, now))
            })
            .collect();
        moved.sort_unstable_by_key(|m| m.0);
        let (before, after) = match &log.before {
            Some(tree) => {
                let (_, now) = self.live_points();
                let was = points_before(now.clone(), &moved, |_| true);
                (
                    tree.part(None, true, &was, nonobtuse)?,
                    self.tree.part(None, false, &now, nonobtuse)?,
                )
            }
            None => {
                let Some(mut region) = self.tree.region(&moved) else {
                    return Ok(TriangleChanges::default());
                };
                let now = self.tree.points_within(&region.points, &self.points);
                let inside = |p: DVec2| self.tree.inside(&region.points, p);
                let was = points_before(now.clone(), &moved, inside);
                self.tree.add_blocks(&mut region, &now, &was);
                (
                    self.tree.part(Some(&region.exact), true, &was, nonobtuse)?,
                    self.tree
                        .part(Some(&region.exact), false, &now, nonobtuse)?,
                )
            }
        };
        Ok(difference(before, after))
    }
}

/// The points `now` as they were before the changes `moved`: those that moved or went taken
/// out, and where they were put back when `keep` takes it.
fn points_before(now: Vec<DVec2>, moved: &[Moved], keep: impl Fn(DVec2) -> bool) -> Vec<DVec2> {
    let gone: std::collections::HashSet<[u64; 2]> = moved
        .iter()
        .filter_map(|m| m.2)
        .map(|p| [p.x.to_bits(), p.y.to_bits()])
        .collect();
    let mut was: Vec<DVec2> = now
        .into_iter()
        .filter(|p| !gone.contains(&[p.x.to_bits(), p.y.to_bits()]))
        .collect();
    was.extend(moved.iter().filter_map(|m| m.1).filter(|&p| keep(p)));
    was
}

/// What `before` has and `after` has not, and the other way round (both sorted).
fn difference(
    (before, leaves_before): (Vec<TriangleBits>, usize),
    (after, leaves_after): (Vec<TriangleBits>, usize),
) -> TriangleChanges {
    let mut changes = TriangleChanges {
        leaves: leaves_before + leaves_after,
        ..TriangleChanges::default()
    };
    let (mut i, mut j) = (0, 0);
    while i < before.len() || j < after.len() {
        match (before.get(i), after.get(j)) {
            (Some(b), Some(a)) if b == a => {
                i += 1;
                j += 1;
            }
            (Some(b), Some(a)) if b < a => {
                changes.removed.push(corners(b));
                i += 1;
            }
            (Some(b), None) => {
                changes.removed.push(corners(b));
                i += 1;
            }
            (_, Some(a)) => {
                changes.added.push(corners(a));
                j += 1;
            }
            (None, None) => break,
        }
    }
    changes
}

impl Tracked {
    pub(super) fn log_changes(&mut self, on: bool) {
        match self {
            Tracked::Narrow(k) => k.separated.log_changes(on),
            Tracked::Wide(k) => k.separated.log_changes(on),
        }
    }

    fn region(&self, moved: &[Moved]) -> Option<Region> {
        match self {
            Tracked::Narrow(k) => k.region(moved),
            Tracked::Wide(k) => k.region(moved),
        }
    }

    fn points_within(&self, rects: &[GridRect], points: &[DVec2]) -> Vec<DVec2> {
        match self {
            Tracked::Narrow(k) => k.points_within(rects, points),
            Tracked::Wide(k) => k.points_within(rects, points),
        }
    }

    fn inside(&self, rects: &[GridRect], p: DVec2) -> bool {
        match self {
            Tracked::Narrow(k) => k.inside(rects, p),
            Tracked::Wide(k) => k.inside(rects, p),
        }
    }

    fn add_blocks(&self, region: &mut Region, now: &[DVec2], was: &[DVec2]) {
        match self {
            Tracked::Narrow(k) => k.add_blocks(region, now, was),
            Tracked::Wide(k) => k.add_blocks(region, now, was),
        }
    }

    fn part(
        &self,
        split: Option<&[GridRect]>,
        before: bool,
        points: &[DVec2],
        nonobtuse: bool,
    ) -> Result<(Vec<TriangleBits>, usize), Error> {
        match self {
            Tracked::Narrow(k) => k.part(split, before, points, nonobtuse),
            Tracked::Wide(k) => k.part(split, before, points, nonobtuse),
        }
    }
}

impl<K: MortonKey> Keyed<K> {
    /// Where the meshes of the tree as it was when the log started and as it is can differ
    /// (see the module's account), from the squares the log holds changed and the leaves of
    /// the points `moved`, before and now; `None` if nothing changed.
    ///
    /// The leaves that differ are the changed squares and their children, where they are
    /// leaves. Their triangles, and those of the leaves touching them, may differ: those are
    /// the affected leaves, split as in full with the leaves touching them, whose sizes give
    /// their templates. A point warps the corner of its leaf nearest to it, of a leaf of its
    /// leaf's size, so the points that warp an affected leaf lie within half its side of it.
    fn region(&self, moved: &[Moved]) -> Option<Region> {
        let tree = &self.separated;
        let mut changed: Vec<(Cell<K>, bool)> = Vec::new();
        for square in tree.changed_squares() {
            let children = (u32::from(square.level) < K::AXIS_BITS)
                .then(|| (0..4).map(move |q| square.child(q)))
                .into_iter()
                .flatten();
            for cell in std::iter::once(square).chain(children) {
                for before in [true, false] {
                    if self.is_leaf(cell, before) {
                        changed.push((cell, before));
                    }
                }
            }
        }
        for &(_, was, now) in moved {
            changed.extend(was.map(|p| (tree.leaf_of(self.key(p), true), true)));
            changed.extend(now.map(|p| (tree.leaf_of(self.key(p), false), false)));
        }
        if changed.is_empty() {
            return None;
        }
        let mut affected: Vec<(Cell<K>, bool)> = changed
            .iter()
            .flat_map(|&(leaf, before)| {
                let touching = tree.leaves_meeting(around(leaf, 1), before);
                touching.into_iter().map(move |l| (l, before))
            })
            .collect();
        affected.sort_unstable_by_key(|&(c, before)| (c.level, c.anchor, before));
        affected.dedup();
        let mut points: Vec<GridRect> = affected
            .iter()
            .map(|&(a, _)| around(a, side(a) / 2 + 1))
            .collect();
        let mut exact: Vec<GridRect> = affected.iter().map(|&(a, _)| around(a, 1)).collect();
        for rects in [&mut points, &mut exact] {
            rects.sort_unstable_by_key(|r| (r.x0, r.y0, r.x1, r.y1));
            rects.dedup();
        }
        Some(Region { points, exact })
    }

    /// Whether `cell` is a leaf, now or as it was.
    fn is_leaf(&self, cell: Cell<K>, before: bool) -> bool {
        let tree = &self.separated;
        let parent_split = cell.level == 0 || tree.is_split(cell.parent(), before);
        parent_split && !tree.is_split(cell, before)
    }

    /// Adds to the region's exact part, for each point warped, as it was (`was`) and as it is
    /// (`now`), the 3×3 squares of its leaf's size around its leaf and a unit ring: a point
    /// warps the 2×2 leaves around one corner of its leaf (or splits its leaf and the four
    /// beside it), whose templates read whether the squares across their sides are split.
    /// Those squares' own leaves need not be exact: in a corner-separated tree leaves may halve
    /// ring by ring, so a wider exact block could reach a crowd of points and split all its
    /// tree.
    fn add_blocks(&self, region: &mut Region, now: &[DVec2], was: &[DVec2]) {
        let tree = &self.separated;
        for (points, before) in [(now, false), (was, true)] {
            for &p in points {
                let leaf = tree.leaf_of(self.key(p), before);
                region.exact.push(around(leaf, side(leaf) + 1));
            }
        }
    }

    /// Whether point `p`'s finest square lies in one of `rects`.
    fn inside(&self, rects: &[GridRect], p: DVec2) -> bool {
        let (x, y) = self.grid.quantize(p);
        let (x, y) = (u128::from(x), u128::from(y));
        rects
            .iter()
            .any(|r| (r.x0..r.x1).contains(&x) && (r.y0..r.y1).contains(&y))
    }

    /// The live points (of all points `points`, by id) that lie in one of `rects`.
    fn points_within(&self, rects: &[GridRect], points: &[DVec2]) -> Vec<DVec2> {
        let mut positions: Vec<usize> = rects
            .iter()
            .flat_map(|&r| self.separated.points_within(r))
            .collect();
        positions.sort_unstable();
        positions.dedup();
        positions
            .into_iter()
            .map(|i| points[self.ids[&self.separated.keys()[i]] as usize])
            .filter(|&p| self.inside(rects, p))
            .collect()
    }

    /// The triangles of the warp (or the nonobtuse split) of the tree, now or as it was when
    /// the log started, split in full only within `split` (everywhere with `None`), with the
    /// points `points`; and its leaf count.
    fn part(
        &self,
        split: Option<&[GridRect]>,
        before: bool,
        points: &[DVec2],
        nonobtuse: bool,
    ) -> Result<(Vec<TriangleBits>, usize), Error> {
        let end = 1u128 << K::AXIS_BITS;
        let whole = [GridRect {
            x0: 0,
            x1: end,
            y0: 0,
            y1: end,
        }];
        let split = split.unwrap_or(&whole);
        let mut keyed: Vec<(K, DVec2)> = points.iter().map(|&p| (self.key(p), p)).collect();
        keyed.sort_unstable_by_key(|&(k, _)| k);
        let (keys, places): (Vec<K>, Vec<DVec2>) = keyed.into_iter().unzip();
        let tree = self.separated.part_within(split, before, &keys);
        let order: Vec<u32> = (0..places.len() as u32).collect();
        let corner_keys = self.corner_keys(&keys);
        let leaves = tree.tree.leaves.len();
        let mesh = mesh_tree(tree, (&order, corner_keys), &self.grid, &places, nonobtuse)?;
        let mut triangles: Vec<TriangleBits> = mesh
            .triangles
            .iter()
            .map(|t| triangle_bits(t.map(|v| mesh.vertices[v as usize])))
            .collect();
        triangles.sort_unstable();
        Ok((triangles, leaves))
    }
}

/// The side of `cell`, in grid units.
fn side<K: MortonKey>(cell: Cell<K>) -> u128 {
    1u128 << (K::AXIS_BITS - u32::from(cell.level))
}

/// The square `cell` widened by `by` grid units on every side (it may leave the root).
fn around<K: MortonKey>(cell: Cell<K>, by: u128) -> GridRect {
    let (x, y) = { cell.anchor }.decode();
    let (x, y, s) = (u128::from(x), u128::from(y), side(cell));
    GridRect {
        x0: x.saturating_sub(by),
        x1: x + s + by,
        y0: y.saturating_sub(by),
        y1: y + s + by,
    }
}
