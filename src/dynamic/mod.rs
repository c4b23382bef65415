//! Warped meshes kept current under point insertions, deletions and moves.
//!
//! A [`DynamicMesh`] lives on a rectangle fixed when it is made, so that the grid, and with
//! it every point's Morton key, stays put while points come and go. Its well-separated quadtree
//! is kept by [`SeparatedPoints`], which re-runs the static separation rules only on the points
//! an edit can reach; after any sequence of edits the tree, and the mesh [`DynamicMesh::mesh`]
//! warps from it, are byte for byte what [`crate::mesh()`] builds for the live points in id order
//! on the same domain.
//!
//! Points keep their ids across edits: the initial points are `0..n` in the order given, and
//! each insertion takes the next id; a deleted id is never given out again.

mod changes;
mod refined;

pub use changes::TriangleChanges;
pub use refined::{DynamicDelaunay, RefinedEdit};

use std::collections::HashMap;

use glam::DVec2;
use rayon::prelude::*;

use crate::balance::{SeparatedPoints, Separation, sides_of};
use crate::error::Error;
use crate::mesh::{Domain, Mesh, StageTimes};
use crate::morton::{DomainCells, Grid, MortonKey};
use crate::warp::{finest_resolved_level, leaves_in_domain, split, unresolvable, warp};

/// One edit of a dynamic mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Edit {
    /// Adds a point; it takes the next id.
    Insert(DVec2),
    /// Deletes the live point with this id.
    Delete(u32),
    /// Moves the live point with this id to a new place.
    Move(u32, DVec2),
}

/// A checked batch: the id each edit names, where each touched point ends up (`None`:
/// deleted), where the earlier points among them started, and the next free id.
#[derive(Default)]
struct Plan {
    ids: Vec<u32>,
    ends: std::collections::BTreeMap<u32, Option<DVec2>>,
    starts: HashMap<u32, Option<DVec2>>,
    inserted_at: HashMap<u32, DVec2>,
    next_id: u32,
}

impl Plan {
    fn note_start(&mut self, id: u32, start: Option<DVec2>) {
        self.starts.entry(id).or_insert(start);
    }
}

/// What an edit did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EditReport {
    /// The id of the point inserted, deleted or moved.
    pub id: u32,
    /// Split squares of the quadtree the edit added or took out.
    pub cells: usize,
    /// Whether the edit moved the tree to the other grid width, rebuilding it.
    pub rebuilt: bool,
}

/// What a batch of edits did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct BatchReport {
    /// The id of the point each edit inserted, deleted or moved, in order.
    pub ids: Vec<u32>,
    /// Split squares of the quadtree the batch added or took out.
    pub cells: usize,
    /// Whether the tree was built anew: for a batch moving more than a share of the points (an
    /// eighth for the block tree, a thirty-second for the corner tree), or to move it to the
    /// other grid width.
    pub rebuilt: bool,
}

/// A warped quality mesh of points on a fixed rectangle, kept current under edits.
#[derive(Clone)]
pub struct DynamicMesh {
    domain: Domain,
    /// Every point ever given an id, live or not.
    points: Vec<DVec2>,
    live: Vec<bool>,
    live_count: usize,
    tree: Tracked,
    /// While changes are tracked, what edits changed since they were last taken.
    log: Option<changes::ChangeLog>,
}

/// The tree on the grid width the live points need: the narrow grid unless two of them share
/// a narrow key or a leaf is finer than it resolves, as [`crate::mesh()`] chooses.
#[derive(Clone)]
enum Tracked {
    Narrow(Keyed<u64>),
    Wide(Keyed<u128>),
}

/// A separated tree with the id of each point by key.
#[derive(Clone)]
struct Keyed<K: MortonKey> {
    grid: Grid,
    separated: SeparatedPoints<K>,
    /// By key, not by Morton position: an edit then shifts no array of ids (the tree's own
    /// sorted arrays are shifted enough), and nothing reads the ids in the map's order.
    ids: HashMap<K, u32>,
}

impl DynamicMesh {
    /// The dynamic mesh of `points` on the rectangle `domain`, which holds them all (on its sides
    /// too); the points get ids `0..points.len()`.
    ///
    /// # Errors
    /// [`Error::InvalidOption`] for a domain that is not a rectangle of positive area (a square
    /// for [`Separation::Block`]), [`Error::ThinDomain`] for one that needs more than 2^20 cells
    /// along a side,
    /// [`Error::NonFinite`], [`Error::OutsideDomain`], [`Error::DuplicatePoint`] for a point
    /// given twice, and [`Error::Unresolvable`] for points too close together for the wide
    /// grid.
    pub fn new(points: &[DVec2], domain: Domain) -> Result<Self, Error> {
        Self::with_separation(points, domain, Separation::Corner)
    }

    /// [`Self::new`] with the tree separated by `separation`: [`Separation::Corner`] for the
    /// compact warp (what [`crate::mesh()`] gives in [`crate::Mode::CompactWarp`] on the
    /// rectangle, every angle in [`crate::warp::COMPACT_ANGLE_BOUNDS`]), [`Separation::Block`] for the block
    /// warp ([`crate::Mode::BlockWarp`], [`crate::warp::ANGLE_BOUNDS`]) and the nonobtuse
    /// split ([`Self::mesh_nonobtuse`]).
    ///
    /// # Errors
    /// As [`Self::new`].
    pub fn with_separation(
        points: &[DVec2],
        domain: Domain,
        separation: Separation,
    ) -> Result<Self, Error> {
        domain.check()?;
        let extent = domain.hi - domain.lo;
        if extent.x != extent.y && separation == Separation::Block {
            return Err(Error::InvalidOption {
                option: "domain",
                message: format!(
                    "a dynamic block warp needs a square domain, not {} x {}",
                    extent.x, extent.y
                ),
            });
        }
        for (index, &p) in points.iter().enumerate() {
            check_place(p, index, &domain)?;
        }
        if let Some((id, existing)) = first_repeat(points) {
            return Err(duplicate(id, existing, points[id]));
        }
        let mut mesh = DynamicMesh {
            domain,
            points: points.to_vec(),
            live: vec![true; points.len()],
            live_count: points.len(),
            tree: Tracked::Narrow(Keyed::empty(&domain, u64::AXIS_BITS, separation)?),
            log: None,
        };
        mesh.rebuild()?;
        Ok(mesh)
    }

    /// The domain.
    pub fn domain(&self) -> Domain {
        self.domain
    }

    /// How many points are live.
    pub fn len(&self) -> usize {
        self.live_count
    }

    /// Whether no point is live.
    pub fn is_empty(&self) -> bool {
        self.live_count == 0
    }

    /// The live point with id `id`, if there is one.
    pub fn point(&self, id: u32) -> Option<DVec2> {
        let id = id as usize;
        self.live
            .get(id)
            .is_some_and(|&live| live)
            .then(|| self.points[id])
    }

    /// The live points in id order, with their ids.
    pub fn live_points(&self) -> (Vec<u32>, Vec<DVec2>) {
        (0..self.points.len() as u32)
            .filter(|&id| self.live[id as usize])
            .map(|id| (id, self.points[id as usize]))
            .unzip()
    }

    /// The rule the tree is separated by, which decides the warp [`Self::mesh`] gives.
    pub fn separation(&self) -> Separation {
        match &self.tree {
            Tracked::Narrow(k) => k.separated.separation(),
            Tracked::Wide(k) => k.separated.separation(),
        }
    }

    /// Whether the tree is on the wide grid.
    pub fn is_wide(&self) -> bool {
        matches!(self.tree, Tracked::Wide(_))
    }

    /// Adds a point at `p`; returns what changed, with the point's id.
    ///
    /// # Errors
    /// [`Error::NonFinite`], [`Error::OutsideDomain`], [`Error::DuplicatePoint`] for a place a
    /// live point holds, [`Error::Unresolvable`] for a point too close to another for the wide
    /// grid; the mesh is then unchanged.
    pub fn insert(&mut self, p: DVec2) -> Result<EditReport, Error> {
        let id = self.points.len();
        check_place(p, id, &self.domain)?;
        if let Some(existing) = self.live_at(p) {
            return Err(duplicate(id, existing, p));
        }
        self.note_point(id as u32);
        self.points.push(p);
        self.live.push(true);
        self.live_count += 1;
        match self.place(id as u32) {
            Ok(report) => Ok(report),
            Err(e) => {
                self.points.pop();
                self.live.pop();
                self.live_count -= 1;
                Err(e)
            }
        }
    }

    /// Deletes the live point with id `id`.
    ///
    /// # Errors
    /// [`Error::UnknownPoint`] for an id not live; the mesh is then unchanged.
    pub fn delete(&mut self, id: u32) -> Result<EditReport, Error> {
        let p = self
            .point(id)
            .ok_or(Error::UnknownPoint { id: id as usize })?;
        self.note_point(id);
        let cells = self.tree.remove(p);
        self.live[id as usize] = false;
        self.live_count -= 1;
        let rebuilt = self.narrow_if_enough()?;
        Ok(EditReport { id, cells, rebuilt })
    }

    /// Moves the live point with id `id` to `p`.
    ///
    /// # Errors
    /// [`Error::UnknownPoint`], and what [`Self::insert`] refuses at `p`; the mesh is then
    /// unchanged.
    pub fn move_to(&mut self, id: u32, p: DVec2) -> Result<EditReport, Error> {
        let old = self
            .point(id)
            .ok_or(Error::UnknownPoint { id: id as usize })?;
        check_place(p, id as usize, &self.domain)?;
        if p == old {
            return Ok(EditReport {
                id,
                ..EditReport::default()
            });
        }
        if let Some(existing) = self.live_at(p) {
            return Err(duplicate(id as usize, existing, p));
        }
        self.note_point(id);
        let on = sides_of(p, self.domain.lo, self.domain.hi);
        let within = match &mut self.tree {
            Tracked::Narrow(k) => k.move_within_leaf(old, p, on),
            Tracked::Wide(k) => k.move_within_leaf(old, p, on),
        };
        if within {
            self.points[id as usize] = p;
            return Ok(EditReport {
                id,
                ..EditReport::default()
            });
        }
        let gone = self.delete(id)?;
        self.points[id as usize] = p;
        self.live[id as usize] = true;
        self.live_count += 1;
        match self.place(id) {
            Ok(placed) => Ok(EditReport {
                id,
                cells: gone.cells + placed.cells,
                rebuilt: gone.rebuilt || placed.rebuilt,
            }),
            Err(e) => {
                // The tree depends on the live points alone: putting the point back where it
                // was gives back the tree it had.
                self.points[id as usize] = old;
                self.place(id)
                    .expect("the point fitted where it was before the move");
                Err(e)
            }
        }
    }

    /// Applies `edits` in order, all or none: on a bad edit the mesh goes back to what it was
    /// and the error names the edit's position. The edits are checked first, as
    /// [`Self::apply_batch`] checks them, and then done one by one.
    ///
    /// # Errors
    /// The first edit refused, by position, with why.
    pub fn apply(&mut self, edits: &[Edit]) -> Result<Vec<EditReport>, (usize, Error)> {
        let plan = self.plan(edits)?;
        let first_new = self.points.len() as u32;
        let mut reports = Vec::with_capacity(edits.len());
        for (k, &edit) in edits.iter().enumerate() {
            let done = match edit {
                Edit::Insert(p) => self.insert(p),
                Edit::Delete(id) => self.delete(id),
                Edit::Move(id, p) => self.move_to(id, p),
            };
            match done {
                Ok(report) => reports.push(report),
                Err(e) => {
                    // Only a place too crowded for the grid passes the checks and fails here.
                    self.restore(&plan.starts, first_new);
                    return Err((k, e));
                }
            }
        }
        Ok(reports)
    }

    /// Applies `edits` as one batch, all or none, with the same result as [`Self::apply`]: the
    /// edits are checked in order first (the error names the first bad one), then the tree is
    /// updated once. Points that stay in their leaves move in place; the others leave
    /// together and the new places are put in together, each group's first moves and rounds
    /// in parallel, so a batch costs one pass over the sorted keys rather than one per edit.
    /// The one difference: the grid must separate the points as the batch leaves them, not as
    /// each edit does, so a point placed next to one a later edit deletes is accepted here and
    /// refused by [`Self::apply`].
    ///
    /// # Errors
    /// The first edit refused, by position, with why.
    pub fn apply_batch(&mut self, edits: &[Edit]) -> Result<BatchReport, (usize, Error)> {
        let plan = self.plan(edits)?;
        let first_new = self.points.len() as u32;
        for &id in plan.ends.keys() {
            self.note_point(id);
        }
        // The points as they are now, and where the batch leaves each it touched.
        let mut leaving: Vec<DVec2> = Vec::new();
        let mut arriving: Vec<(u32, DVec2)> = Vec::new();
        for (&id, &end) in &plan.ends {
            let start = (id < first_new).then(|| self.point(id)).flatten();
            if start == end {
                continue;
            }
            if let (Some(from), Some(to)) = (start, end)
                && self.tree.move_within_leaf(
                    from,
                    to,
                    sides_of(to, self.domain.lo, self.domain.hi),
                )
            {
                self.points[id as usize] = to;
                continue;
            }
            leaving.extend(start);
            if let Some(to) = end {
                arriving.push((id, to));
            }
        }
        arriving.sort_unstable_by_key(|a| a.0);
        // The ids and places as the batch leaves them.
        for (&id, &end) in &plan.ends {
            if id >= first_new {
                continue;
            }
            if self.live[id as usize] && end.is_none() {
                self.live_count -= 1;
            }
            self.live[id as usize] = end.is_some();
            if let Some(p) = end {
                self.points[id as usize] = p;
            }
        }
        for id in first_new..plan.next_id {
            let end = plan.ends.get(&id).copied().flatten();
            self.points.push(end.unwrap_or(plan.inserted_at[&id]));
            self.live.push(end.is_some());
            self.live_count += usize::from(end.is_some());
        }
        let (ids, places): (Vec<u32>, Vec<DVec2>) = arriving.into_iter().unzip();
        // A batch that moves more than a share of the points costs more than building the
        // tree anew, and a build of the same points gives the same tree. The share, measured
        // on 1e5 uniform points: an eighth for the block tree (10 % of the points as one batch
        // took 0.93 of a rebuild); a thirty-second for the corner tree, which builds in half
        // the time (2.4 % of them leaving and arriving took 1.1 of a rebuild).
        let share = match self.separation() {
            Separation::Block => 8,
            Separation::Corner => 32,
        };
        let local = (leaving.len() + ids.len()) * share <= self.live_count;
        let mut cells = 0;
        let inserted = if local {
            cells += self.tree.remove_many(&leaving);
            self.tree.insert_many(&ids, &places, &self.domain)
        } else {
            None
        };
        let mut rebuilt = false;
        match inserted {
            Some(added) => cells += added,
            None => {
                // A large batch, or points too close together for this grid: build anew, on
                // the grid a build from scratch of the live points would pick.
                if let Err(e) = self.rebuild() {
                    self.restore(&plan.starts, first_new);
                    return Err((edits.len().saturating_sub(1), e));
                }
                rebuilt = true;
            }
        }
        rebuilt |= self.narrow_if_enough().map_err(|e| (edits.len() - 1, e))?;
        Ok(BatchReport {
            ids: plan.ids,
            cells,
            rebuilt,
        })
    }

    /// Checks `edits` in order against the live points as the earlier ones leave them; where
    /// each touched point ends up.
    fn plan(&self, edits: &[Edit]) -> Result<Plan, (usize, Error)> {
        let mut plan = Plan {
            next_id: self.points.len() as u32,
            ..Plan::default()
        };
        let bits = |p: DVec2| ((p.x + 0.0).to_bits(), (p.y + 0.0).to_bits());
        // Places the batch filled, by their point.
        let mut taken: HashMap<(u64, u64), u32> = Default::default();
        for (k, &edit) in edits.iter().enumerate() {
            let now = |plan: &Plan, id: u32| match plan.ends.get(&id) {
                Some(&end) => end,
                None => self.point(id),
            };
            let occupant = |plan: &Plan, p: DVec2| {
                taken.get(&bits(p)).copied().or_else(|| {
                    self.live_at(p)
                        .map(|id| id as u32)
                        .filter(|id| !plan.ends.contains_key(id))
                })
            };
            let id = match edit {
                Edit::Insert(p) => {
                    let id = plan.next_id;
                    check_place(p, id as usize, &self.domain).map_err(|e| (k, e))?;
                    if let Some(existing) = occupant(&plan, p) {
                        return Err((k, duplicate(id as usize, existing as usize, p)));
                    }
                    taken.insert(bits(p), id);
                    plan.ends.insert(id, Some(p));
                    plan.inserted_at.insert(id, p);
                    plan.next_id += 1;
                    id
                }
                Edit::Delete(id) => {
                    let Some(at) = now(&plan, id) else {
                        return Err((k, Error::UnknownPoint { id: id as usize }));
                    };
                    taken.remove(&bits(at));
                    plan.note_start(id, self.point(id));
                    plan.ends.insert(id, None);
                    id
                }
                Edit::Move(id, p) => {
                    let Some(at) = now(&plan, id) else {
                        return Err((k, Error::UnknownPoint { id: id as usize }));
                    };
                    check_place(p, id as usize, &self.domain).map_err(|e| (k, e))?;
                    if p != at {
                        if let Some(existing) = occupant(&plan, p) {
                            return Err((k, duplicate(id as usize, existing as usize, p)));
                        }
                        taken.remove(&bits(at));
                        taken.insert(bits(p), id);
                        plan.note_start(id, self.point(id));
                        plan.ends.insert(id, Some(p));
                    }
                    id
                }
            };
            plan.ids.push(id);
        }
        Ok(plan)
    }

    /// Puts the points a failed batch touched back where they were, and the tree with them.
    fn restore(&mut self, starts: &HashMap<u32, Option<DVec2>>, first_new: u32) {
        self.points.truncate(first_new as usize);
        self.live.truncate(first_new as usize);
        for (&id, &start) in starts {
            if id < first_new {
                self.live[id as usize] = start.is_some();
                if let Some(p) = start {
                    self.points[id as usize] = p;
                }
            }
        }
        self.live_count = self.live.iter().filter(|&&l| l).count();
        self.rebuild()
            .expect("the live points fitted before the batch");
    }

    /// Moves every point `ids[k]` by `displacements[k]`: a time step of moving points, all or
    /// none, as one batch ([`Self::apply_batch`]).
    ///
    /// # Errors
    /// As [`Self::apply_batch`]; [`Error::InvalidOption`] when the two lists differ in length.
    pub fn move_all(
        &mut self,
        ids: &[u32],
        displacements: &[DVec2],
    ) -> Result<BatchReport, (usize, Error)> {
        if ids.len() != displacements.len() {
            let message = format!(
                "{} ids and {} displacements",
                ids.len(),
                displacements.len()
            );
            return Err((
                0,
                Error::InvalidOption {
                    option: "displacements",
                    message,
                },
            ));
        }
        let mut edits = Vec::with_capacity(ids.len());
        for (k, (&id, &d)) in ids.iter().zip(displacements).enumerate() {
            let p = self
                .point(id)
                .ok_or((k, Error::UnknownPoint { id: id as usize }))?;
            edits.push(Edit::Move(id, p + d));
        }
        self.apply_batch(&edits)
    }

    /// The warped mesh of the live points: what [`crate::mesh()`] gives for them in id order on
    /// this domain in the compact warp mode ([`crate::Mode::CompactWarp`], or the block warp
    /// mode for a tree [`Separation::Block`]), its `vertex_input` numbering them in that order.
    ///
    /// # Errors
    /// [`Error::Empty`] with no live point, and what the warp refuses ([`Error::Unresolvable`]
    /// where f64 cannot place the vertices around a point apart).
    pub fn mesh(&self) -> Result<Mesh, Error> {
        self.mesh_of(false)
    }

    /// [`Self::mesh`] coarsened ([`crate::warp::coarsen`]): what [`crate::mesh()`] gives in the
    /// warp mode ([`crate::Mode::Warp`]) for a corner tree. It is made from the whole mesh each
    /// time (the collapses go in rounds over all of it), in time linear in its size.
    ///
    /// # Errors
    /// As [`Self::mesh`]; [`Error::InvalidOption`] for a block tree.
    pub fn coarsened_mesh(&self) -> Result<Mesh, Error> {
        if self.separation() != Separation::Corner {
            return Err(Error::InvalidOption {
                option: "warp",
                message: "the coarsened warp needs a dynamic mesh separated by corners \
                          (Separation::Corner)"
                    .into(),
            });
        }
        let mut mesh = self.mesh()?;
        crate::warp::coarsen(&mut mesh, crate::warp::COARSE_ANGLE_BOUNDS);
        Ok(mesh)
    }

    /// The nonobtuse split of the live points, from the same tree: what [`crate::mesh()`] gives
    /// for them in id order on this domain in the nonobtuse split mode
    /// ([`crate::Mode::NonobtuseSplit`]). It needs the block tree
    /// ([`Self::with_separation`] with [`Separation::Block`]).
    ///
    /// # Errors
    /// As [`Self::mesh`]; [`Error::InvalidOption`] for a corner tree.
    pub fn mesh_nonobtuse(&self) -> Result<Mesh, Error> {
        self.mesh_of(true)
    }

    /// [`Self::mesh_nonobtuse`] coarsened ([`crate::warp::coarsen`] to
    /// [`crate::warp::NONOBTUSE_COARSE_BOUNDS`]): what [`crate::mesh()`] gives in the nonobtuse
    /// mode ([`crate::Mode::Nonobtuse`]). Made from the whole mesh each time, as
    /// [`Self::coarsened_mesh`].
    ///
    /// # Errors
    /// As [`Self::mesh_nonobtuse`].
    pub fn coarsened_nonobtuse_mesh(&self) -> Result<Mesh, Error> {
        let mut mesh = self.mesh_nonobtuse()?;
        crate::warp::coarsen(&mut mesh, crate::warp::NONOBTUSE_COARSE_BOUNDS);
        Ok(mesh)
    }

    /// Refuses the nonobtuse split of a tree not separated by blocks.
    fn check_nonobtuse(&self, nonobtuse: bool) -> Result<(), Error> {
        if nonobtuse && self.separation() != Separation::Block {
            return Err(Error::InvalidOption {
                option: "nonobtuse",
                message: "the nonobtuse split needs a dynamic mesh separated by blocks \
                          (Separation::Block)"
                    .into(),
            });
        }
        Ok(())
    }

    fn mesh_of(&self, nonobtuse: bool) -> Result<Mesh, Error> {
        self.check_nonobtuse(nonobtuse)?;
        if self.live_count == 0 {
            return Err(Error::Empty);
        }
        // Ids to positions among the live points.
        let mut rank = vec![u32::MAX; self.points.len()];
        let mut live_points = Vec::with_capacity(self.live_count);
        for (id, &p) in self.points.iter().enumerate() {
            if self.live[id] {
                rank[id] = live_points.len() as u32;
                live_points.push(p);
            }
        }
        match &self.tree {
            Tracked::Narrow(k) => k.mesh(&live_points, &rank, nonobtuse),
            Tracked::Wide(k) => k.mesh(&live_points, &rank, nonobtuse),
        }
    }

    /// Notes, while changes are tracked, where point `id` is before an edit changes it.
    fn note_point(&mut self, id: u32) {
        let now = self.point(id);
        if let Some(log) = &mut self.log {
            log.note_point(id, now);
        }
    }

    /// The id of the live point at exactly `p`, if any.
    fn live_at(&self, p: DVec2) -> Option<usize> {
        let id = match &self.tree {
            Tracked::Narrow(k) => k.id_of(p),
            Tracked::Wide(k) => k.id_of(p),
        }?;
        (self.points[id as usize] == p).then_some(id as usize)
    }

    /// Puts the live point `id` into the tree, moving to the wide grid if it needs it there.
    fn place(&mut self, id: u32) -> Result<EditReport, Error> {
        let p = self.points[id as usize];
        let on = sides_of(p, self.domain.lo, self.domain.hi);
        let fits = match &mut self.tree {
            Tracked::Narrow(k) => k.insert(id, p, on),
            Tracked::Wide(k) => k.insert(id, p, on),
        };
        match fits {
            Some(cells) => Ok(EditReport {
                id,
                cells,
                rebuilt: false,
            }),
            None => {
                // Too close to another point for this grid: the tree of all live points is
                // built anew, on the wide grid if need be, as a build from scratch would be.
                if let Err(e) = self.rebuild() {
                    self.live[id as usize] = false;
                    self.live_count -= 1;
                    self.rebuild().expect("the live points fitted before");
                    self.live[id as usize] = true;
                    self.live_count += 1;
                    return Err(e);
                }
                Ok(EditReport {
                    id,
                    cells: 0,
                    rebuilt: true,
                })
            }
        }
    }

    /// Back to the narrow grid once the wide one is no longer needed.
    fn narrow_if_enough(&mut self) -> Result<bool, Error> {
        let Tracked::Wide(k) = &self.tree else {
            return Ok(false);
        };
        if u32::from(k.separated.deepest()) > finest_resolved::<u64>(k.separated.separation()) {
            return Ok(false);
        }
        self.rebuild()?;
        Ok(true)
    }

    /// Builds the tree of the live points from scratch, on the narrow grid if that resolves
    /// them, on the wide one otherwise.
    fn rebuild(&mut self) -> Result<(), Error> {
        if let Some(log) = &mut self.log {
            log.note_rebuild(&self.tree);
        }
        let ids: Vec<u32> = (0..self.points.len() as u32)
            .filter(|&id| self.live[id as usize])
            .collect();
        let separation = self.separation();
        let (points, domain) = (&self.points, &self.domain);
        if let Some(narrow) = Keyed::<u64>::build(points, &ids, domain, separation)? {
            self.tree = Tracked::Narrow(narrow);
            return Ok(());
        }
        match Keyed::<u128>::build(points, &ids, domain, separation)? {
            Some(wide) => {
                self.tree = Tracked::Wide(wide);
                Ok(())
            }
            None => {
                let wide = Keyed::<u128>::build_unchecked(points, &ids, domain, separation)?;
                let id = wide.too_deep_point();
                let p = self.points[id as usize];
                Err(unresolvable(p, id))
            }
        }
    }
}

impl Tracked {
    fn remove_many(&mut self, places: &[DVec2]) -> usize {
        if places.is_empty() {
            return 0;
        }
        match self {
            Tracked::Narrow(k) => k.remove_many(places),
            Tracked::Wide(k) => k.remove_many(places),
        }
    }

    fn insert_many(&mut self, ids: &[u32], places: &[DVec2], domain: &Domain) -> Option<usize> {
        if ids.is_empty() {
            return Some(0);
        }
        match self {
            Tracked::Narrow(k) => k.insert_many(ids, places, domain),
            Tracked::Wide(k) => k.insert_many(ids, places, domain),
        }
    }

    fn move_within_leaf(&mut self, from: DVec2, to: DVec2, on: u8) -> bool {
        match self {
            Tracked::Narrow(k) => k.move_within_leaf(from, to, on),
            Tracked::Wide(k) => k.move_within_leaf(from, to, on),
        }
    }

    /// Takes the point at `p` out; returns the split squares touched.
    fn remove(&mut self, p: DVec2) -> usize {
        match self {
            Tracked::Narrow(k) => k.remove(p),
            Tracked::Wide(k) => k.remove(p),
        }
    }
}

impl<K: MortonKey> Keyed<K> {
    fn empty(domain: &Domain, axis_bits: u32, separation: Separation) -> Result<Self, Error> {
        let grid = grid_on(domain, axis_bits, separation)?;
        Ok(Keyed {
            grid,
            separated: SeparatedPoints::within(
                Vec::new(),
                Vec::new(),
                separation,
                grid.inner_lines(),
            ),
            ids: HashMap::new(),
        })
    }

    /// The tree of the points `ids`, or `None` if two of them share a key or a leaf is finer
    /// than this grid resolves the points.
    fn build(
        points: &[DVec2],
        ids: &[u32],
        domain: &Domain,
        separation: Separation,
    ) -> Result<Option<Self>, Error> {
        let keyed = Self::build_unchecked(points, ids, domain, separation)?;
        let distinct = keyed.separated.keys().len() == ids.len();
        Ok((distinct && !keyed.too_deep()).then_some(keyed))
    }

    /// The tree of the points `ids`, the first of each key only.
    fn build_unchecked(
        points: &[DVec2],
        ids: &[u32],
        domain: &Domain,
        separation: Separation,
    ) -> Result<Self, Error> {
        let mut keyed = Self::empty(domain, K::AXIS_BITS, separation)?;
        let mut pairs: Vec<(K, u32)> = ids
            .iter()
            .map(|&id| (keyed.key(points[id as usize]), id))
            .collect();
        pairs.sort_unstable();
        pairs.dedup_by_key(|pair| pair.0);
        let on = pairs
            .iter()
            .map(|&(_, id)| sides_of(points[id as usize], domain.lo, domain.hi))
            .collect();
        keyed.ids = pairs.iter().copied().collect();
        let keys = pairs.into_iter().map(|(key, _)| key).collect();
        keyed.separated = SeparatedPoints::within(keys, on, separation, keyed.grid.inner_lines());
        Ok(keyed)
    }

    fn key(&self, p: DVec2) -> K {
        let (x, y) = self.grid.quantize(p);
        K::encode(x, y)
    }

    /// The id of the point whose key `p` has, if any.
    fn id_of(&self, p: DVec2) -> Option<u32> {
        self.ids.get(&self.key(p)).copied()
    }

    /// Puts point `id` at `p` in; `None`, with the tree as it was, if its key is taken or its
    /// leaf would be finer than this grid resolves.
    fn insert(&mut self, id: u32, p: DVec2, on: u8) -> Option<usize> {
        let key = self.key(p);
        // The id map holds the tree's keys: it answers without a search of the sorted keys.
        if self.ids.contains_key(&key) {
            return None;
        }
        self.separated.insert(key, on);
        if self.too_deep() {
            self.separated.remove(key);
            return None;
        }
        self.ids.insert(key, id);
        Some(self.separated.touched())
    }

    /// Puts the points `ids` at `places` in, all at once; `None`, with the tree as it was,
    /// if a key is taken or a leaf would be finer than this grid resolves.
    fn insert_many(&mut self, ids: &[u32], places: &[DVec2], domain: &Domain) -> Option<usize> {
        let mut new: Vec<(K, u8, u32)> = ids
            .iter()
            .zip(places)
            .map(|(&id, &p)| (self.key(p), sides_of(p, domain.lo, domain.hi), id))
            .collect();
        new.sort_unstable_by_key(|n| n.0);
        let repeated = new.windows(2).any(|w| w[0].0 == w[1].0);
        if repeated || new.iter().any(|n| self.ids.contains_key(&n.0)) {
            return None;
        }
        let keyed: Vec<(K, u8)> = new.iter().map(|n| (n.0, n.1)).collect();
        self.separated.insert_many(&keyed);
        let touched = self.separated.touched();
        if self.too_deep() {
            let keys: Vec<K> = new.iter().map(|n| n.0).collect();
            self.separated.remove_many(&keys);
            return None;
        }
        self.ids.extend(new.iter().map(|n| (n.0, n.2)));
        Some(touched)
    }

    /// Takes the points at `places` out, all at once; returns the split squares touched.
    fn remove_many(&mut self, places: &[DVec2]) -> usize {
        let mut keys: Vec<K> = places.iter().map(|&p| self.key(p)).collect();
        keys.sort_unstable();
        self.separated.remove_many(&keys);
        for key in &keys {
            self.ids.remove(key);
        }
        self.separated.touched()
    }

    /// Moves the point at `from` to `to` if that keeps the tree as it is (see
    /// [`SeparatedPoints::move_within_leaf`]).
    fn move_within_leaf(&mut self, from: DVec2, to: DVec2, on: u8) -> bool {
        let (from, to) = (self.key(from), self.key(to));
        if from == to {
            return self.separated.sides_on_of(from) == Some(on);
        }
        if !self.separated.move_within_leaf(from, to, on) {
            return false;
        }
        let id = self.ids.remove(&from).expect("a point's id");
        self.ids.insert(to, id);
        true
    }

    /// Takes the point at `p` out; returns the split squares touched.
    fn remove(&mut self, p: DVec2) -> usize {
        let key = self.key(p);
        self.separated.remove(key);
        self.ids.remove(&key);
        self.separated.touched()
    }

    /// Whether a point's leaf is finer than the grid resolves the points.
    fn too_deep(&self) -> bool {
        u32::from(self.separated.deepest()) > finest_resolved::<K>(self.separated.separation())
    }

    /// The id of a point whose leaf is finer than the grid resolves.
    fn too_deep_point(&self) -> u32 {
        let finest = finest_resolved::<K>(self.separated.separation());
        let i = self
            .separated
            .levels()
            .iter()
            .position(|&l| u32::from(l) > finest)
            .unwrap_or(0);
        self.ids[&self.separated.keys()[i]]
    }

    fn mesh(&self, live_points: &[DVec2], rank: &[u32], nonobtuse: bool) -> Result<Mesh, Error> {
        let tree = self.separated.tree();
        let order: Vec<u32> = self
            .separated
            .keys()
            .par_iter()
            .map(|key| rank[self.ids[key] as usize])
            .collect();
        let keys = self.corner_keys(self.separated.keys());
        mesh_tree(tree, (&order, keys), &self.grid, live_points, nonobtuse)
    }

    /// `keys`, the points' keys in Morton order, where the tree is a corner tree: what the
    /// compact warp needs.
    fn corner_keys<'a>(&self, keys: &'a [K]) -> Option<&'a [K]> {
        (self.separated.separation() == Separation::Corner).then_some(keys)
    }
}

/// The finest leaf level at which a grid of `K` keys resolves the points for a tree separated
/// by `separation`, as the warp judges it.
fn finest_resolved<K: MortonKey>(separation: Separation) -> u32 {
    u32::from(finest_resolved_level::<K>(separation == Separation::Corner))
}

/// The mesh of a separated tree of `points`, `order[i]` the index of the `i`-th point in Morton
/// order: the nonobtuse split of a block tree, or the warp of the tree's rule, compact given
/// the points' keys `corner_keys` (a [`Separation::Corner`] tree).
fn mesh_tree<K: MortonKey>(
    tree: crate::balance::BalancedTree<K>,
    (order, corner_keys): (&[u32], Option<&[K]>),
    grid: &Grid,
    points: &[DVec2],
    nonobtuse: bool,
) -> Result<Mesh, Error> {
    let mut times = StageTimes::default();
    // The leaves beyond a rectangle's sides inside the root go, as in the static build.
    let tree = leaves_in_domain(tree, grid, (order, points))?;
    let meshed = if nonobtuse {
        split(&tree, order, grid, points, &mut times)
    } else {
        warp(&tree, (order, corner_keys), grid, points, &mut times)
    };
    meshed.map(|(mesh, _)| mesh)
}

/// The grid a dynamic mesh keeps on `domain`: the static warp's, cut into nearly square cells
/// for a corner tree (any rectangle), on the square for a block tree.
fn grid_on(domain: &Domain, axis_bits: u32, separation: Separation) -> Result<Grid, Error> {
    match separation {
        Separation::Block => Grid::on_domain(domain.lo, domain.hi, axis_bits),
        Separation::Corner => {
            let cells = DomainCells::for_domain(domain.hi - domain.lo, MAX_CELLS_ALONG)?;
            Grid::on_domain_cells(domain.lo, domain.hi, axis_bits, cells)
        }
    }
}

/// The most cells along a side of a dynamic mesh's rectangle: what the static warp allows
/// whatever the number of points.
const MAX_CELLS_ALONG: u64 = 1 << 20;

/// Refuses a point that is not finite or lies outside the domain.
fn check_place(p: DVec2, index: usize, domain: &Domain) -> Result<(), Error> {
    if !p.is_finite() {
        return Err(Error::NonFinite {
            index,
            x: p.x,
            y: p.y,
        });
    }
    if !domain.contains(p) {
        return Err(Error::OutsideDomain {
            index,
            x: p.x,
            y: p.y,
        });
    }
    Ok(())
}

/// A point given twice, as its later index and the earlier one: the pair with the smallest
/// later index.
fn first_repeat(points: &[DVec2]) -> Option<(usize, usize)> {
    let mut order: Vec<usize> = (0..points.len()).collect();
    let place = |i: usize| (points[i].x.to_bits(), points[i].y.to_bits());
    order.sort_unstable_by_key(|&i| (place(i), i));
    order
        .windows(2)
        .filter(|pair| points[pair[0]] == points[pair[1]])
        .map(|pair| (pair[1], pair[0]))
        .min()
}

fn duplicate(id: usize, existing: usize, p: DVec2) -> Error {
    Error::DuplicatePoint {
        id,
        existing,
        x: p.x,
        y: p.y,
    }
}
