//! The triangles edits of a [`DynamicDelaunay`] change, found around the changed vertices.
//!
//! While changes are tracked, every vertex an edit takes out or puts in (a live point or a
//! Steiner point) is counted at its place: out and in again at one place is no change. The
//! mesh is the canonical Delaunay triangulation of its vertices, so the triangles that went
//! and came are those the changed vertices touch; `refine::local_changes` finds them from
//! the vertices in a window around each group of changed places, doubling the window where
//! the triangles it finds reach beyond it.

use std::collections::{HashMap, HashSet};

use glam::DVec2;

use super::DynamicDelaunay;
use crate::dynamic::TriangleChanges;
use crate::dynamic::changes::in_order;
use crate::error::Error;
use crate::refine::{Window, local_changes, point_bits};

/// The vertices edits changed since changes were last taken: at each place, how many came
/// (1), went (-1) or both (0).
pub(super) type VertexLog = HashMap<[u64; 2], (DVec2, i32)>;

impl DynamicDelaunay {
    /// Starts tracking which triangles edits change (see [`Self::take_changes`]), or with `on`
    /// false stops it. Tracking costs a little per changed vertex.
    pub fn track_changes(&mut self, on: bool) {
        self.log = on.then(VertexLog::new);
    }

    /// The triangles of [`Self::mesh`] that the edits since tracking started, or since the
    /// last call, took out and put in, each counter-clockwise from its least corner (by its
    /// coordinates' bits), sorted; tracking starts again from here. Taking `removed` out of
    /// the mesh as it was and putting `added` in gives the mesh as it is. Found from the
    /// vertices around the changed ones, in time that grows with them; after an edit that
    /// refined everything again, from two triangulations of the whole domain.
    /// [`TriangleChanges::leaves`] counts the vertices triangulated.
    ///
    /// # Errors
    /// [`Error::InvalidOption`] when changes are not tracked; the changes are then kept.
    pub fn take_changes(&mut self) -> Result<TriangleChanges, Error> {
        let Some(log) = self.log.as_ref() else {
            return Err(Error::InvalidOption {
                option: "changes",
                message: "changes are not tracked: call track_changes(true) first".into(),
            });
        };
        let corners = self.domain_corners();
        let changed = |sign: i32| {
            let mut places: Vec<DVec2> = log
                .values()
                .filter(|&&(p, count)| count == sign && !corners.contains(&point_bits(p)))
                .map(|&(p, _)| p)
                .collect();
            places.sort_unstable_by_key(|&p| point_bits(p));
            places
        };
        let (removed, added) = (changed(-1), changed(1));
        let mut changes = TriangleChanges::default();
        let vertices = self.len() + self.steiner_count();
        let groups = if (removed.len() + added.len()) * 8 >= vertices {
            Vec::new()
        } else {
            self.groups(&removed, &added)
        };
        let mut found = Vec::with_capacity(groups.len());
        for group in &groups {
            match self.changes_of_group(group, (&removed, &added), vertices) {
                Some(group_changes) => found.push(group_changes),
                None => {
                    found.clear();
                    break;
                }
            }
        }
        if found.is_empty() {
            // Many changes, or a group whose windows grew past a quarter of the vertices:
            // one window over the whole domain, which trusts every triangle.
            let whole = self.window_over(self.domain.lo, self.domain.hi);
            let all = self.changes_in(&whole, &removed, &added);
            found.push(all.expect("the whole domain trusts every triangle"));
        }
        for group_changes in found {
            changes.removed.extend(group_changes.removed);
            changes.added.extend(group_changes.added);
            changes.leaves += group_changes.leaves;
        }
        changes.removed = in_order(changes.removed);
        changes.added = in_order(changes.added);
        self.log = Some(VertexLog::new());
        Ok(changes)
    }

    /// Notes, while changes are tracked, that a vertex at `p` came (`count` 1) or went (-1).
    pub(super) fn note_vertex(&mut self, p: DVec2, count: i32) {
        if let Some(log) = self.log.as_mut() {
            log.entry(point_bits(p)).or_insert((p, 0)).1 += count;
        }
    }

    fn domain_corners(&self) -> [[u64; 2]; 4] {
        let (lo, hi) = (self.domain.lo, self.domain.hi);
        [lo, DVec2::new(hi.x, lo.y), hi, DVec2::new(lo.x, hi.y)].map(point_bits)
    }

    /// The changed places (`removed`, then `added`, numbered in turn) in groups whose members
    /// lie in neighbouring cells of the index's grid.
    fn groups(&self, removed: &[DVec2], added: &[DVec2]) -> Vec<Vec<usize>> {
        let places: Vec<DVec2> = removed.iter().chain(added).copied().collect();
        let mut by_cell: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
        for (k, &p) in places.iter().enumerate() {
            by_cell.entry(self.cell_of(p)).or_default().push(k);
        }
        let mut parent: Vec<usize> = (0..places.len()).collect();
        fn root(parent: &mut [usize], mut k: usize) -> usize {
            while parent[k] != k {
                parent[k] = parent[parent[k]];
                k = parent[k];
            }
            k
        }
        for (&(cx, cy), members) in &by_cell {
            let neighbours = (cx - 1..=cx + 1).flat_map(|x| (cy - 1..=cy + 1).map(move |y| (x, y)));
            for cell in neighbours {
                for &other in by_cell.get(&cell).into_iter().flatten() {
                    let (a, b) = (root(&mut parent, members[0]), root(&mut parent, other));
                    parent[a.max(b)] = a.min(b);
                }
            }
        }
        let mut groups: HashMap<usize, Vec<usize>> = HashMap::new();
        for k in 0..places.len() {
            groups.entry(root(&mut parent, k)).or_default().push(k);
        }
        let mut groups: Vec<Vec<usize>> = groups.into_values().collect();
        groups.sort_unstable();
        groups
    }

    /// The triangles the changed places of `group` touch: windows around them, doubling,
    /// until one trusts them all; `None` once a window holds more than a quarter of the
    /// mesh's `vertices`, or the whole domain.
    fn changes_of_group(
        &self,
        group: &[usize],
        (removed, added): (&[DVec2], &[DVec2]),
        vertices: usize,
    ) -> Option<TriangleChanges> {
        let place = |k: usize| {
            if k < removed.len() {
                removed[k]
            } else {
                added[k - removed.len()]
            }
        };
        let (mut lo, mut hi) = (place(group[0]), place(group[0]));
        for &k in group {
            lo = lo.min(place(k));
            hi = hi.max(place(k));
        }
        let mut margin = self.first_half_side((lo + hi) / 2.0) / 4.0;
        loop {
            let window = self.window_over(lo - margin, hi + margin);
            if window.open == [false; 4] || self.holds_more_than(&window, vertices / 4) {
                return None;
            }
            if let Some(found) = self.changes_in(&window, removed, added) {
                return Some(found);
            }
            margin *= 2.0;
        }
    }

    /// The triangles the changed places in `window` touch, if the window trusts them.
    fn changes_in(
        &self,
        window: &Window,
        removed: &[DVec2],
        added: &[DVec2],
    ) -> Option<TriangleChanges> {
        let mut after = self.points_in(window)?;
        after.extend(self.steiner_places_in(window)?);
        after.extend(self.side_points_in(window)?);
        let inside = |places: &[DVec2]| -> Vec<DVec2> {
            places
                .iter()
                .copied()
                .filter(|&p| window.holds(p))
                .collect()
        };
        let (removed, added) = (inside(removed), inside(added));
        let came: HashSet<[u64; 2]> = added.iter().map(|&p| point_bits(p)).collect();
        let mut before: Vec<DVec2> = after
            .iter()
            .copied()
            .filter(|&p| !came.contains(&point_bits(p)))
            .collect();
        before.extend(&removed);
        let [gone, new] = local_changes(self.domain, window, &before, &after, &removed, &added)?;
        Some(TriangleChanges {
            removed: gone,
            added: new,
            leaves: before.len() + after.len(),
        })
    }

    /// The places of the Steiner points the window holds; `None` where one lies on an open
    /// side.
    fn steiner_places_in(&self, window: &Window) -> Option<Vec<DVec2>> {
        let slots = self.steiner_slots_over(window);
        let mut places = Vec::with_capacity(slots.len());
        for slot in slots {
            let p = self.steiner[slot as usize]
                .expect("indexed slots are live")
                .at;
            if window.on_open_side(p) {
                return None;
            }
            if window.holds(p) {
                places.push(p);
            }
        }
        Some(places)
    }
}
