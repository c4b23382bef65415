//! Quality Delaunay meshes kept current under point insertions, deletions and moves.
//!
//! A [`DynamicDelaunay`] keeps the Steiner points of [`crate::refine::refine_points_in_order`]
//! for its live points, each with its stamp (when its step ran, the step's key, and a box
//! around all the step read). An edit replays refinement in order in a square window around the changed point,
//! once with the points before and once after, and keeps the replay's Steiner points where
//! the two replays show that the change reaches nothing outside the window (see
//! `refine::replay`); otherwise the window doubles, up to the whole domain. So after any
//! sequence of edits the mesh is byte for byte that of refinement in order of the live
//! points in id order, and an edit costs what its window holds.
//!
//! Refinement in order cuts the rectangle's sides before it begins (`refine::sides`), so
//! that no triangle of the first triangulation joins a point near a side to the far corners;
//! an edit changes only the side points whose circles hold the changed point and no other,
//! found along one chain of pieces per side. A point on a side starts that side's pieces, so
//! its edit refines everything again.
//!
//! Limits: where the first triangulation (the input points in the rectangle) has triangles
//! much larger than the spacing around the edit (in gaps between clusters), the windows grow
//! large, up to the whole rectangle.

mod changes;

use std::collections::HashMap;

use glam::DVec2;

use super::{Edit, check_place};
use crate::error::Error;
use crate::mesh::{Domain, Mesh};
use crate::refine::{
    Bounds, RefineDomain, RefineOptions, Stamp, Window, canonical_delaunay, inside_chain,
    on_a_side, replay, run_in_order, side_changes, side_ends,
};

/// What one edit of a [`DynamicDelaunay`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RefinedEdit {
    /// The point's id.
    pub id: u32,
    /// The side of the last window replayed (0 when nothing was replayed).
    pub window: f64,
    /// How many windows were replayed, each twice the side of the one before.
    pub windows: u32,
    /// Steiner points removed and added.
    pub steiner_removed: usize,
    /// Steiner points added.
    pub steiner_added: usize,
    /// Whether the window grew to the whole domain, which refines it all again.
    pub rebuilt: bool,
}

/// A quality Delaunay mesh of a changing point set in a fixed rectangle.
///
/// ```
/// use quadmesh::DVec2;
/// use quadmesh::dynamic::DynamicDelaunay;
/// use quadmesh::mesh::Domain;
/// use quadmesh::refine::{RefineDomain, RefineOptions, refine_points_in_order};
///
/// let domain = Domain { lo: DVec2::ZERO, hi: DVec2::ONE };
/// let options = RefineOptions {
///     min_angle_deg: 30.0,
///     domain: RefineDomain::Rectangle(domain),
///     ..RefineOptions::default()
/// };
/// let points: Vec<DVec2> = (0..200)
///     .map(|k| DVec2::new((k as f64 * 0.618_034).fract(), (k as f64 + 0.5) / 200.0))
///     .collect();
/// let mut dynamic = DynamicDelaunay::new(&points, &options)?;
/// let added = dynamic.insert(DVec2::new(0.51, 0.49))?;
/// dynamic.move_to(3, DVec2::new(0.2, 0.31))?;
/// dynamic.delete(added.id)?;
/// let (rebuilt, _) = refine_points_in_order(&dynamic.live_points(), &options)?;
/// assert_eq!(dynamic.mesh()?.triangles, rebuilt.triangles);
/// # Ok::<(), quadmesh::Error>(())
/// ```
#[derive(Clone, Debug)]
pub struct DynamicDelaunay {
    options: RefineOptions,
    domain: Domain,
    bounds: Bounds,
    /// The points by id; `None` once deleted.
    points: Vec<Option<DVec2>>,
    /// How many of them are live: those in `point_cells`.
    live_count: usize,
    /// The Steiner points, by slot; `None` for a free slot.
    steiner: Vec<Option<Stamp>>,
    free: Vec<u32>,
    /// Live point ids and Steiner slots (under both the point and the place its decision was
    /// taken for) by grid cell.
    point_cells: HashMap<(i64, i64), Vec<u32>>,
    steiner_cells: HashMap<(i64, i64), Vec<u32>>,
    cell: f64,
    /// The points on the rectangle's sides (see `refine::sides`), by grid cell.
    side_cells: HashMap<(i64, i64), Vec<DVec2>>,
    side_count: usize,
    /// Per side, its corners and the live points on it, in order along it.
    side_ends: [Vec<DVec2>; 4],
    /// While changes are tracked, the vertices edits changed since they were last taken.
    log: Option<changes::VertexLog>,
}

impl DynamicDelaunay {
    /// The mesh of `points` in `options.domain`, which must be a rectangle: the same as
    /// [`crate::refine::refine_points_in_order`] gives. The points take ids `0..n`.
    ///
    /// # Errors
    /// As [`crate::refine::refine_points_in_order`]; [`Error::InvalidOption`] for a domain that
    /// is not a rectangle; [`Error::DuplicatePoint`] for a point given twice.
    pub fn new(points: &[DVec2], options: &RefineOptions) -> Result<Self, Error> {
        let RefineDomain::Rectangle(domain) = options.domain else {
            return Err(Error::InvalidOption {
                option: "domain",
                message: "a dynamic mesh needs a fixed rectangle as its domain".into(),
            });
        };
        if let Some((id, existing)) = super::first_repeat(points) {
            return Err(super::duplicate(id, existing, points[id]));
        }
        let run = run_in_order(points, options, true)?;
        let mut mesh = DynamicDelaunay {
            options: *options,
            domain,
            bounds: run.bounds,
            points: points.iter().map(|&p| Some(p)).collect(),
            live_count: 0,
            steiner: Vec::new(),
            free: Vec::new(),
            point_cells: HashMap::new(),
            steiner_cells: HashMap::new(),
            cell: 1.0,
            side_cells: HashMap::new(),
            side_count: 0,
            side_ends: Default::default(),
            log: None,
        };
        mesh.index(run.stamps, run.side);
        Ok(mesh)
    }

    /// The point with this id, if it is live.
    pub fn point(&self, id: u32) -> Option<DVec2> {
        self.points.get(id as usize).copied().flatten()
    }

    /// How many points are live.
    pub fn len(&self) -> usize {
        self.live_count
    }

    /// Whether no point is live.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The ids of the live points, increasing.
    pub fn live_ids(&self) -> Vec<u32> {
        (0..self.points.len() as u32)
            .filter(|&id| self.points[id as usize].is_some())
            .collect()
    }

    /// The live points in id order.
    pub fn live_points(&self) -> Vec<DVec2> {
        self.points.iter().flatten().copied().collect()
    }

    /// How many vertices refinement added: the Steiner points, and the points it put on the
    /// rectangle's sides before it began.
    pub fn steiner_count(&self) -> usize {
        self.steiner.len() - self.free.len() + self.side_count
    }

    /// The mesh: byte for byte what [`crate::refine::refine_points_in_order`] makes of the
    /// live points in id order on the same rectangle.
    ///
    /// # Errors
    /// As [`crate::refine::refine_points_in_order`] for the live points (none for a mesh that
    /// was made).
    pub fn mesh(&self) -> Result<Mesh, Error> {
        let mut added: Vec<DVec2> = self.side_cells.values().flatten().copied().collect();
        added.extend(self.steiner.iter().flatten().map(|s| s.at));
        canonical_delaunay(&self.live_points(), &added, &self.options)
    }

    /// Adds a point; it takes the next id.
    ///
    /// # Errors
    /// [`Error::NonFinite`], [`Error::OutsideDomain`], [`Error::DuplicatePoint`], and what
    /// refinement of the new points refuses; the mesh is then unchanged.
    pub fn insert(&mut self, p: DVec2) -> Result<RefinedEdit, Error> {
        let id = self.points.len() as u32;
        self.check_new_place(p, id)?;
        self.points.push(Some(p));
        self.add_point_cell(id, p);
        match self.settle(p, true) {
            Ok(edit) => Ok(RefinedEdit { id, ..edit }),
            Err(e) => {
                self.remove_point_cell(id, p);
                self.points.pop();
                Err(e)
            }
        }
    }

    /// Deletes the live point with this id.
    ///
    /// # Errors
    /// [`Error::UnknownPoint`] for an id not live, and what refinement of the remaining points
    /// refuses; the mesh is then unchanged.
    pub fn delete(&mut self, id: u32) -> Result<RefinedEdit, Error> {
        let p = self
            .point(id)
            .ok_or(Error::UnknownPoint { id: id as usize })?;
        self.points[id as usize] = None;
        self.remove_point_cell(id, p);
        match self.settle(p, false) {
            Ok(edit) => Ok(RefinedEdit { id, ..edit }),
            Err(e) => {
                self.points[id as usize] = Some(p);
                self.add_point_cell(id, p);
                Err(e)
            }
        }
    }

    /// Moves the live point with this id to `p`: a deletion and an insertion that keeps the
    /// id. Returns the two edits' reports.
    ///
    /// # Errors
    /// [`Error::UnknownPoint`], and what [`Self::insert`] refuses at `p`; the mesh is then
    /// unchanged.
    pub fn move_to(&mut self, id: u32, p: DVec2) -> Result<[RefinedEdit; 2], Error> {
        let old = self
            .point(id)
            .ok_or(Error::UnknownPoint { id: id as usize })?;
        if p == old {
            return Ok([RefinedEdit {
                id,
                ..RefinedEdit::default()
            }; 2]);
        }
        self.check_new_place(p, id)?;
        let gone = self.delete(id)?;
        self.points[id as usize] = Some(p);
        self.add_point_cell(id, p);
        match self.settle(p, true) {
            Ok(edit) => Ok([gone, RefinedEdit { id, ..edit }]),
            Err(e) => {
                // Back to where it was, which was meshed before.
                self.remove_point_cell(id, p);
                self.points[id as usize] = Some(old);
                self.add_point_cell(id, old);
                self.settle(old, true)?;
                Err(e)
            }
        }
    }

    /// Applies `edits` in order, all or none: a batch of at least 16 edits, and of at least a
    /// 1024th of the live points, moves the points and refines them all again once; a smaller
    /// one replays each edit. (An edit costs about what refining a thousand points does.)
    /// The result is the same either way: the mesh of the live points in id order.
    ///
    /// # Errors
    /// The index of the first edit refused and why (as [`Self::insert`], [`Self::delete`] and
    /// [`Self::move_to`] refuse); the mesh is then unchanged.
    pub fn apply(&mut self, edits: &[Edit]) -> Result<Vec<RefinedEdit>, (usize, Error)> {
        if edits.len() >= 16 && edits.len() * 1024 >= self.len() {
            return self.apply_at_once(edits);
        }
        let mut reports = Vec::with_capacity(edits.len());
        // What took each edit back, newest last.
        let mut undo = Vec::with_capacity(edits.len());
        for (k, &edit) in edits.iter().enumerate() {
            let back = match edit {
                Edit::Insert(_) => None,
                Edit::Delete(id) | Edit::Move(id, _) => self.point(id),
            };
            let done = match edit {
                Edit::Insert(p) => self.insert(p),
                Edit::Delete(id) => self.delete(id),
                Edit::Move(id, p) => self.move_to(id, p).map(|r| r[1]),
            };
            match done {
                Ok(report) => {
                    undo.push((edit, report.id, back));
                    reports.push(report);
                }
                Err(e) => {
                    self.take_back(undo);
                    return Err((k, e));
                }
            }
        }
        Ok(reports)
    }

    /// Takes back edits done, newest first; each puts back a mesh that was made before.
    fn take_back(&mut self, undo: Vec<(Edit, u32, Option<DVec2>)>) {
        for (edit, id, back) in undo.into_iter().rev() {
            let restored = match (edit, back) {
                (Edit::Insert(_), _) => self.delete(id).map(|_| {
                    self.points.pop();
                }),
                (Edit::Delete(_), Some(p)) => {
                    self.points[id as usize] = Some(p);
                    self.add_point_cell(id, p);
                    self.settle(p, true).map(|_| ())
                }
                (Edit::Move(..), Some(p)) => self.move_to(id, p).map(|_| ()),
                _ => Ok(()),
            };
            restored.expect("a mesh made before is made again");
        }
    }

    /// [`Self::apply`] for a large batch: the points first, then one refinement of them all.
    fn apply_at_once(&mut self, edits: &[Edit]) -> Result<Vec<RefinedEdit>, (usize, Error)> {
        let saved = (self.points.clone(), self.log.clone());
        let mut ids = Vec::with_capacity(edits.len());
        let placed = edits
            .iter()
            .enumerate()
            .try_for_each(|(k, &edit)| self.place(edit).map(|id| ids.push(id)).map_err(|e| (k, e)));
        let rebuilt = placed.and_then(|()| {
            self.rebuild(0)
                .map_err(|e| (edits.len().saturating_sub(1), e))
        });
        match rebuilt {
            Ok(report) => Ok(ids
                .into_iter()
                .map(|id| RefinedEdit { id, ..report })
                .collect()),
            Err(refused) => {
                // The Steiner points are untouched until a rebuild succeeds.
                (self.points, self.log) = saved;
                self.index_points();
                Err(refused)
            }
        }
    }

    /// Applies `edit` to the points alone, with the checks of a single edit; its point's id.
    fn place(&mut self, edit: Edit) -> Result<u32, Error> {
        let live = |s: &Self, id: u32| s.point(id).ok_or(Error::UnknownPoint { id: id as usize });
        match edit {
            Edit::Insert(p) => {
                let id = self.points.len() as u32;
                self.check_new_place(p, id)?;
                self.points.push(Some(p));
                self.add_point_cell(id, p);
                Ok(id)
            }
            Edit::Delete(id) => {
                let p = live(self, id)?;
                self.points[id as usize] = None;
                self.remove_point_cell(id, p);
                Ok(id)
            }
            Edit::Move(id, p) => {
                let old = live(self, id)?;
                if p != old {
                    self.check_new_place(p, id)?;
                    self.remove_point_cell(id, old);
                    self.points[id as usize] = Some(p);
                    self.add_point_cell(id, p);
                }
                Ok(id)
            }
        }
    }

    fn check_new_place(&self, p: DVec2, id: u32) -> Result<(), Error> {
        check_place(p, id as usize, &self.domain)?;
        let (cx, cy) = self.cell_of(p);
        for x in cx - 1..=cx + 1 {
            for y in cy - 1..=cy + 1 {
                for &other in self.point_cells.get(&(x, y)).into_iter().flatten() {
                    let q = self.points[other as usize].expect("indexed points are live");
                    if q == p {
                        return Err(super::duplicate(id as usize, other as usize, p));
                    }
                    if (q - p).abs().max_element() < crate::refine::MIN_GAP {
                        return Err(Error::TooClose {
                            a: other as usize,
                            pa: q.to_array(),
                            b: id as usize,
                            pb: p.to_array(),
                        });
                    }
                }
            }
        }
        Ok(())
    }

    /// Brings the Steiner points up to date after the point at `changed` was inserted (or
    /// deleted): replays windows around it, doubling, until one holds the change.
    fn settle(&mut self, changed: DVec2, inserted: bool) -> Result<RefinedEdit, Error> {
        if on_a_side(self.domain, changed) {
            // The side's pieces start from the points on it: all of them change.
            return self.rebuild(0);
        }
        let side = self.side_changes(changed);
        let (side_added, side_removed) = if inserted {
            (side, Vec::new())
        } else {
            (Vec::new(), side)
        };
        self.change_side_points(&side_added, &side_removed);
        let settled = self.settle_steiner(changed, inserted, (&side_added, &side_removed));
        if settled.is_err() {
            self.change_side_points(&side_removed, &side_added);
        }
        settled
    }

    /// Brings the Steiner points up to date after the change at `changed`, whose side points
    /// `side` (added, removed) are in place.
    fn settle_steiner(
        &mut self,
        changed: DVec2,
        inserted: bool,
        side: (&[DVec2], &[DVec2]),
    ) -> Result<RefinedEdit, Error> {
        let mut half = self.first_half_side(changed);
        let mut windows = 0;
        let vertices = self.len() + self.steiner_count();
        loop {
            let window = self.window_around(changed, half);
            // A replay costs a few times what refining its points does, and there are two:
            // once the first window failed, one holding an eighth of the vertices costs more
            // than refining them all.
            let large = windows > 0 && self.holds_more_than(&window, vertices / 8);
            if window.open == [false; 4] || large {
                return self.rebuild(windows);
            }
            windows += 1;
            if let Some(edit) = self.try_window(&window, (changed, inserted), side) {
                return Ok(RefinedEdit {
                    windows,
                    window: (window.hi - window.lo).max_element(),
                    ..edit
                });
            }
            half *= 2.0;
        }
    }

    /// Whether the window holds more than `limit` live points and Steiner points, a Steiner
    /// point counted under each of its cells (its place's and its decision's) that the window
    /// covers; counts no further than that.
    pub(super) fn holds_more_than(&self, window: &Window, limit: usize) -> bool {
        let points = self.cells_over(window.lo, window.hi).flat_map(|cell| {
            let live = self.point_cells.get(&cell).into_iter().flatten();
            let steiner = self.steiner_cells.get(&cell).into_iter().flatten();
            live.map(|&id| self.points[id as usize].expect("indexed points are live"))
                .chain(steiner.map(|&slot| self.steiner[slot as usize].expect("a live slot").at))
        });
        points.filter(|&p| window.holds(p)).nth(limit).is_some()
    }

    /// Replays `window` before and after the change, and keeps the result if the change
    /// stays inside it.
    fn try_window(
        &mut self,
        window: &Window,
        (changed, inserted): (DVec2, bool),
        (side_added, side_removed): (&[DVec2], &[DVec2]),
    ) -> Option<RefinedEdit> {
        let held = |side: &[DVec2]| side.iter().all(|&p| window.holds(p));
        if !held(side_added) || !held(side_removed) {
            return None;
        }
        let mut after = self.points_in(window)?;
        after.extend(self.side_points_in(window)?);
        let (mut gone, mut came) = (side_added.to_vec(), side_removed.to_vec());
        if inserted {
            gone.push(changed);
        } else {
            came.push(changed);
        }
        let mut before: Vec<DVec2> = after
            .iter()
            .copied()
            .filter(|p| !gone.contains(p))
            .collect();
        before.extend(came);
        let by_place = |a: &DVec2, b: &DVec2| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y));
        after.sort_by(by_place);
        before.sort_by(by_place);
        let (forced, expected, slots) = self.steiner_in(window)?;
        let probe = [changed];
        let (probe_before, probe_after): (&[DVec2], &[DVec2]) = if inserted {
            (&probe, &[])
        } else {
            (&[], &probe)
        };
        // The two replays are independent: one on each of two threads where there are two.
        let (old, new) = rayon::join(
            || {
                replay(
                    window,
                    &self.bounds,
                    &before,
                    &forced,
                    &expected,
                    probe_before,
                )
            },
            || {
                replay(
                    window,
                    &self.bounds,
                    &after,
                    &forced,
                    &expected,
                    probe_after,
                )
            },
        );
        let (old, new) = (old?, new?);
        if !old.agrees_beyond_change(&new, window, &expected) {
            return None;
        }
        for slot in slots {
            self.remove_steiner(slot);
        }
        let added = new.computed.len() + new.adopted.len();
        for s in new.computed.into_iter().chain(new.adopted) {
            self.add_steiner(s);
        }
        Some(RefinedEdit {
            steiner_removed: expected.len(),
            steiner_added: added,
            ..RefinedEdit::default()
        })
    }

    /// Refines the live points again from scratch.
    fn rebuild(&mut self, windows: u32) -> Result<RefinedEdit, Error> {
        let run = run_in_order(&self.live_points(), &self.options, true)?;
        let removed = self.steiner_count();
        let added = run.stamps.len() + run.side.len();
        self.index(run.stamps, run.side);
        Ok(RefinedEdit {
            windows,
            window: (self.domain.hi - self.domain.lo).max_element(),
            steiner_removed: removed,
            steiner_added: added,
            rebuilt: true,
            ..RefinedEdit::default()
        })
    }

    /// Indexes the live points, `stamps` and the side points `side` afresh, on a grid of
    /// about 16 vertices a cell.
    fn index(&mut self, stamps: Vec<Stamp>, side: Vec<DVec2>) {
        let size = self.domain.hi - self.domain.lo;
        let vertices = (self.points.len() + stamps.len()).max(1) as f64;
        self.cell = (size.x * size.y * 16.0 / vertices)
            .sqrt()
            .max(f64::MIN_POSITIVE);
        self.index_points();
        if self.log.is_some() {
            let old: Vec<DVec2> = self.steiner.iter().flatten().map(|s| s.at).collect();
            for p in old {
                self.note_vertex(p, -1);
            }
        }
        self.steiner_cells.clear();
        self.steiner.clear();
        self.free.clear();
        for s in stamps {
            self.add_steiner(s);
        }
        // The grid changed: the old side points leave the index at once.
        let old: Vec<DVec2> = self.side_cells.drain().flat_map(|(_, v)| v).collect();
        for p in old {
            self.note_vertex(p, -1);
        }
        self.side_count = 0;
        self.change_side_points(&side, &[]);
        let live = self.live_points();
        self.side_ends = std::array::from_fn(|k| side_ends(self.domain, k, &live));
    }

    /// Takes the side points `removed` out of the index and puts `added` in.
    fn change_side_points(&mut self, added: &[DVec2], removed: &[DVec2]) {
        for &p in removed {
            let cell = self.cell_of(p);
            if let Some(points) = self.side_cells.get_mut(&cell) {
                points.retain(|&q| q != p);
            }
            self.side_count -= 1;
            self.note_vertex(p, -1);
        }
        for &p in added {
            let cell = self.cell_of(p);
            self.side_cells.entry(cell).or_default().push(p);
            self.side_count += 1;
            self.note_vertex(p, 1);
        }
    }

    /// The side points that the live point at `p` (not on a side) alone decides.
    fn side_changes(&self, p: DVec2) -> Vec<DVec2> {
        let other_inside = |chain: &[(DVec2, DVec2)]| {
            let &(a, b) = chain.last().expect("a piece");
            let (centre, radius) = ((a + b) / 2.0, a.distance(b) / 2.0);
            self.any_point_near(p, (centre - radius, centre + radius), |q| {
                q != p && inside_chain(chain, q)
            })
        };
        side_changes(p, &self.side_ends, other_inside)
    }

    /// Whether a live point in the box `(lo, hi)` passes `test`, looking from `p` outwards.
    fn any_point_near(
        &self,
        p: DVec2,
        (lo, hi): (DVec2, DVec2),
        test: impl Fn(DVec2) -> bool,
    ) -> bool {
        let (centre, a, b) = (self.cell_of(p), self.cell_of(lo), self.cell_of(hi));
        let reach = [
            centre.0 - a.0,
            centre.1 - a.1,
            b.0 - centre.0,
            b.1 - centre.1,
        ]
        .into_iter()
        .max()
        .unwrap_or(0)
        .max(0);
        let in_box = |(x, y): (i64, i64)| x >= a.0 && x <= b.0 && y >= a.1 && y <= b.1;
        // The cells at Chebyshev distance `ring` from the centre's.
        let ring_cells = |ring: i64| {
            (centre.0 - ring..=centre.0 + ring).flat_map(move |x| {
                let edge = x == centre.0 - ring || x == centre.0 + ring;
                let step = if edge { 1 } else { (2 * ring).max(1) as usize };
                (centre.1 - ring..=centre.1 + ring)
                    .step_by(step)
                    .map(move |y| (x, y))
            })
        };
        (0..=reach)
            .flat_map(ring_cells)
            .filter(|&cell| in_box(cell))
            .flat_map(|cell| self.point_cells.get(&cell).into_iter().flatten())
            .any(|&id| test(self.points[id as usize].expect("indexed points are live")))
    }

    /// The side points the window holds; `None` where one lies on an open side.
    fn side_points_in(&self, window: &Window) -> Option<Vec<DVec2>> {
        let mut inside = Vec::new();
        for cell in self.cells_over(window.lo, window.hi) {
            for &p in self.side_cells.get(&cell).into_iter().flatten() {
                if window.on_open_side(p) {
                    return None;
                }
                if window.holds(p) {
                    inside.push(p);
                }
            }
        }
        Some(inside)
    }

    fn index_points(&mut self) {
        self.point_cells.clear();
        self.live_count = 0;
        for id in 0..self.points.len() as u32 {
            if let Some(p) = self.points[id as usize] {
                let cell = self.cell_of(p);
                self.point_cells.entry(cell).or_default().push(id);
                self.live_count += 1;
            }
        }
    }

    fn cell_of(&self, p: DVec2) -> (i64, i64) {
        let c = ((p - self.domain.lo) / self.cell).floor();
        (c.x as i64, c.y as i64)
    }

    /// Indexes live point `id` at `p`, which it just took.
    fn add_point_cell(&mut self, id: u32, p: DVec2) {
        self.note_vertex(p, 1);
        self.live_count += 1;
        let cell = self.cell_of(p);
        self.point_cells.entry(cell).or_default().push(id);
    }

    /// Takes point `id`, which just left `p`, out of the index.
    fn remove_point_cell(&mut self, id: u32, p: DVec2) {
        self.note_vertex(p, -1);
        self.live_count -= 1;
        let cell = self.cell_of(p);
        if let Some(ids) = self.point_cells.get_mut(&cell) {
            ids.retain(|&i| i != id);
        }
    }

    /// The cells of a Steiner point: its own and its decision's.
    fn steiner_cells_of(&self, s: &Stamp) -> [(i64, i64); 2] {
        [self.cell_of(s.at), self.cell_of(s.cause.decision)]
    }

    fn add_steiner(&mut self, s: Stamp) {
        self.note_vertex(s.at, 1);
        let slot = match self.free.pop() {
            Some(slot) => {
                self.steiner[slot as usize] = Some(s);
                slot
            }
            None => {
                self.steiner.push(Some(s));
                (self.steiner.len() - 1) as u32
            }
        };
        let [a, b] = self.steiner_cells_of(&s);
        self.steiner_cells.entry(a).or_default().push(slot);
        if b != a {
            self.steiner_cells.entry(b).or_default().push(slot);
        }
    }

    fn remove_steiner(&mut self, slot: u32) {
        let s = self.steiner[slot as usize].take().expect("a live slot");
        self.note_vertex(s.at, -1);
        for cell in self.steiner_cells_of(&s) {
            if let Some(slots) = self.steiner_cells.get_mut(&cell) {
                slots.retain(|&k| k != slot);
            }
        }
        self.free.push(slot);
    }

    /// The cells a rectangle covers.
    fn cells_over(&self, lo: DVec2, hi: DVec2) -> impl Iterator<Item = (i64, i64)> {
        let (a, b) = (self.cell_of(lo), self.cell_of(hi));
        (a.0..=b.0).flat_map(move |x| (a.1..=b.1).map(move |y| (x, y)))
    }

    /// The live points the window holds; `None` where one lies on an open side.
    fn points_in(&self, window: &Window) -> Option<Vec<DVec2>> {
        let mut inside = Vec::new();
        for cell in self.cells_over(window.lo, window.hi) {
            for &id in self.point_cells.get(&cell).into_iter().flatten() {
                let p = self.points[id as usize].expect("indexed points are live");
                if window.on_open_side(p) {
                    return None;
                }
                if window.holds(p) {
                    inside.push(p);
                }
            }
        }
        Some(inside)
    }

    /// The slots of the Steiner points indexed in the cells the window covers, increasing.
    fn steiner_slots_over(&self, window: &Window) -> Vec<u32> {
        let mut slots: Vec<u32> = self
            .cells_over(window.lo, window.hi)
            .flat_map(|cell| self.steiner_cells.get(&cell).into_iter().flatten().copied())
            .collect();
        slots.sort_unstable();
        slots.dedup();
        slots
    }

    /// The Steiner points whose place or decision the window holds: those a replay must force
    /// (their deciding triangle reaches beyond the window), those it should decide itself, and
    /// the latter's slots. `None` where one lies on an open side.
    #[allow(clippy::type_complexity)]
    fn steiner_in(&self, window: &Window) -> Option<(Vec<Stamp>, Vec<Stamp>, Vec<u32>)> {
        let slots = self.steiner_slots_over(window);
        let (mut forced, mut expected, mut decided) = (Vec::new(), Vec::new(), Vec::new());
        for slot in slots {
            let s = self.steiner[slot as usize].expect("indexed slots are live");
            if window.on_open_side(s.at) {
                return None;
            }
            if !window.holds(s.at) && !window.holds(s.cause.decision) {
                continue;
            }
            if window.trusts_reach(&s.reach) {
                expected.push(s);
                decided.push(slot);
            } else {
                forced.push(s);
            }
        }
        Some((forced, expected, decided))
    }

    /// Half the side of the first window around `p`: a dozen vertex spacings, from the
    /// vertices in the cells around it.
    fn first_half_side(&self, p: DVec2) -> f64 {
        let (cx, cy) = self.cell_of(p);
        let count: usize = (cx - 1..=cx + 1)
            .flat_map(|x| (cy - 1..=cy + 1).map(move |y| (x, y)))
            .map(|cell| {
                self.point_cells.get(&cell).map_or(0, Vec::len)
                    + self.steiner_cells.get(&cell).map_or(0, Vec::len)
            })
            .sum();
        let spacing = 3.0 * self.cell / ((count + 1) as f64).sqrt();
        12.0 * spacing
    }

    /// The square of half side `half` around `p`, cut to the domain.
    fn window_around(&self, p: DVec2, half: f64) -> Window {
        self.window_over(p - half, p + half)
    }

    /// The rectangle from `lo` to `hi`, cut to the domain.
    fn window_over(&self, lo: DVec2, hi: DVec2) -> Window {
        let (d_lo, d_hi) = (self.domain.lo, self.domain.hi);
        Window {
            lo: lo.max(d_lo),
            hi: hi.min(d_hi),
            open: [lo.x > d_lo.x, lo.y > d_lo.y, hi.x < d_hi.x, hi.y < d_hi.y],
        }
    }
}
