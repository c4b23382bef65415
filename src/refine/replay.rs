//! Refinement in order replayed in a window, to find what a change of input points changes.
//!
//! A replay triangulates the window (a rectangle inside the domain) and runs the loop of
//! [`super::ordered`] there, in the same order. A step whose reads (its triangle's
//! circumcircle, the cavities it digs and the triangles around them) all lie clear of the
//! window's open sides is taken as the whole run takes it: the whole run's triangulation has
//! the same triangles there. The other steps' Steiner points are *forced*: taken from the mesh
//! before the change, inserted at their time; so is the point of a step the replay begins and
//! finds reading beyond the window.
//!
//! The same window is replayed twice, with the input before and after the change, and the two
//! are compared (see [`Replay::agrees_beyond_change`]). The replay before must give back the
//! Steiner points the mesh had; the triangles in which the two differ must lie inside the
//! window, made by fixes whose cavities and the triangles around them lie inside it; and no
//! forced point may read a triangle that differs. Then the change reaches nothing the window
//! does not hold, and the new Steiner points of the window are those of a whole new run.

use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap, HashSet};

use glam::DVec2;

use super::delaunay::{Cavity, Location, MARK, Triangulation, beyond, is_wall, locate};
use super::ordered::{
    Cause, Key, NO_REACH, Reach, Stamp, Time, Watch, queue_triangle, reach_around, reach_of_cavity,
    step, time_of,
};
use super::refiner::Bounds;
use crate::mesh::{Corners, NONE, corner_bits};

/// A rectangle inside the domain, and which of its sides cut through the domain (left, bottom,
/// right, top); the others lie on the domain's boundary.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Window {
    pub lo: DVec2,
    pub hi: DVec2,
    pub open: [bool; 4],
}

impl Window {
    /// Whether the circle through `c` stays clear of the open sides: then the window's
    /// triangulation has a triangle with these corners exactly when the whole one does.
    pub fn trusts(&self, c: [DVec2; 3]) -> bool {
        let mut reach = NO_REACH;
        reach_around(&mut reach, c);
        self.trusts_reach(&reach)
    }

    /// Whether the box stays clear of the open sides.
    pub fn trusts_reach(&self, r: &Reach) -> bool {
        let clear = [
            r[0] > self.lo.x,
            r[1] > self.lo.y,
            r[2] < self.hi.x,
            r[3] < self.hi.y,
        ];
        (0..4).all(|side| !self.open[side] || clear[side])
    }

    /// Whether `p` lies in the window, its open sides excluded.
    pub fn holds(&self, p: DVec2) -> bool {
        let within = |v: f64, lo: f64, hi: f64, open_lo: bool, open_hi: bool| {
            (v > lo || (!open_lo && v == lo)) && (v < hi || (!open_hi && v == hi))
        };
        within(p.x, self.lo.x, self.hi.x, self.open[0], self.open[2])
            && within(p.y, self.lo.y, self.hi.y, self.open[1], self.open[3])
    }

    /// Whether `p` lies on an open side, where a replay cannot place it.
    pub fn on_open_side(&self, p: DVec2) -> bool {
        (self.open[0] && p.x == self.lo.x)
            || (self.open[1] && p.y == self.lo.y)
            || (self.open[2] && p.x == self.hi.x)
            || (self.open[3] && p.y == self.hi.y)
    }
}

/// The time of the triangulation of the input points, before any fix.
const START: Time = ((0, 0, 0), 0, 0);

/// A triangle made or destroyed, when, and by which insertion (`NONE`: the first
/// triangulation).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
struct Logged {
    made: bool,
    time: Time,
    corners: Corners,
}

/// What a replay found.
#[derive(Debug, Default)]
pub(crate) struct Replay {
    /// The Steiner points the replay decided itself, in insertion order.
    pub computed: Vec<Stamp>,
    log: Vec<(Logged, u32)>,
    /// Per insertion: whether it was forced, and whether its cavity and every triangle around
    /// it lie inside the window.
    insertions: Vec<(bool, bool)>,
    /// The triangles forced points' decisions read.
    reads: Vec<Corners>,
    /// The entries (time and key) whose steps reached beyond the window, left to the forced
    /// points.
    skipped: Vec<(Time, Key)>,
    /// The Steiner points of the mesh before that the replay took for steps it skipped.
    pub adopted: Vec<Stamp>,
}

/// The loop's watch in a replay: queues only triangles the window trusts, at their time, and
/// refuses cavities it does not trust.
struct Replaying<'a> {
    window: &'a Window,
    queue: BinaryHeap<Reverse<(Time, Key, u32, u32)>>,
    time: Time,
    replay: Replay,
    /// The cavity last allowed: its triangles, and whether it and the triangles around it are
    /// trusted.
    dug: Vec<Corners>,
    ring_trusted: bool,
    /// What the current step has read so far.
    reach: Reach,
    key: Key,
}

/// Marks a forced entry in the queue's third word.
const FORCED: u32 = u32::MAX;

impl Replaying<'_> {
    fn corners(t: &Triangulation, id: u32) -> [DVec2; 3] {
        t.corners[id as usize].map(|v| t.vertices[(v & !MARK) as usize])
    }

    /// Notes the cavity just dug: whether the window trusts its triangles and those beyond
    /// its rim, and their corners.
    fn note_cavity(&mut self, t: &Triangulation, cavity: &Cavity) -> bool {
        self.dug.clear();
        let mut trusted = true;
        for &id in cavity.dug() {
            let c = Self::corners(t, id);
            trusted &= self.window.trusts(c);
            self.dug.push(corner_bits(c));
        }
        self.ring_trusted = trusted
            && cavity
                .rim()
                .iter()
                .all(|e| is_wall(e.outer) || self.window.trusts(Self::corners(t, beyond(e.outer))));
        trusted
    }

    /// Logs the insertion the last noted cavity made.
    fn log_insertion(&mut self, t: &Triangulation, cavity: &Cavity, forced: bool) {
        let k = self.replay.insertions.len() as u32;
        self.replay.insertions.push((forced, self.ring_trusted));
        for &corners in &self.dug {
            let entry = Logged {
                made: false,
                time: self.time,
                corners,
            };
            self.replay.log.push((entry, k));
        }
        for &id in cavity.created() {
            let entry = Logged {
                made: true,
                time: self.time,
                corners: corner_bits(Self::corners(t, id)),
            };
            self.replay.log.push((entry, k));
        }
    }
}

impl Watch for Replaying<'_> {
    fn begin(&mut self, key: Key, creator: [DVec2; 3]) {
        self.key = key;
        self.reach = NO_REACH;
        reach_around(&mut self.reach, creator);
    }

    fn queue(&mut self, t: &Triangulation, key: Key, slot: u32, corners: [u32; 3], edge: u32) {
        if self.window.trusts(Self::corners(t, slot)) {
            let stamp = corners[0].max(corners[1]).max(corners[2]) | edge << 30;
            self.queue
                .push(Reverse((time_of(self.time, key), key, slot, stamp)));
        }
    }

    /// Lets the step go on while all it read lies inside the window; a step that reads
    /// beyond is left to the forced points.
    fn allows(&mut self, t: &Triangulation, cavity: &Cavity) -> bool {
        reach_of_cavity(&mut self.reach, t, cavity);
        if !self.window.trusts_reach(&self.reach) {
            self.replay.skipped.push((self.time, self.key));
            for &id in cavity.dug() {
                let corners = corner_bits(Self::corners(t, id));
                self.replay.reads.push(corners);
            }
            return false;
        }
        self.note_cavity(t, cavity);
        true
    }

    fn inserted(&mut self, t: &Triangulation, cavity: &Cavity, v: u32, cause: &Cause) {
        self.log_insertion(t, cavity, false);
        self.replay.computed.push(Stamp {
            at: t.vertices[v as usize],
            time: self.time,
            cause: *cause,
            reach: self.reach,
        });
    }
}

/// Replays refinement in order in `window` with the input points `inputs` (those in the
/// window) and the `forced` Steiner points; a step that reads beyond the window takes the
/// Steiner point it made before from `expected` (the others the replay should decide
/// itself). `probes` are points absent here whose cavity in the first triangulation, and the
/// triangles around it, must lie inside the window. `None` where the replay reaches something
/// the window cannot tell.
pub(crate) fn replay(
    window: &Window,
    bounds: &Bounds,
    inputs: &[DVec2],
    forced: &[Stamp],
    expected: &[Stamp],
    probes: &[DVec2],
) -> Option<Replay> {
    let expected_by_step: HashMap<(Time, Key), usize> = expected
        .iter()
        .enumerate()
        .map(|(k, s)| ((s.time, s.cause.key), k))
        .collect();
    let mut t = Triangulation::rectangle(window.lo, window.hi);
    t.canonical = true;
    let mut cavity = Cavity::default();
    let mut hint = 0;
    for &p in inputs {
        hint = insert(&mut t, &mut cavity, p, hint)?;
    }
    let mut watch = Replaying {
        window,
        queue: BinaryHeap::new(),
        time: START,
        replay: Replay::default(),
        dug: Vec::new(),
        ring_trusted: true,
        reach: NO_REACH,
        key: (0, 0, 0),
    };
    for probe in probes {
        if let Location::Inside(start) = locate(&t, *probe, hint) {
            cavity.dig(&mut t, *probe, start);
            watch.note_cavity(&t, &cavity);
            cavity.abandon(&mut t);
            if !watch.ring_trusted {
                return None;
            }
        }
    }
    for id in 0..t.len() as u32 {
        let entry = Logged {
            made: true,
            time: START,
            corners: corner_bits(Replaying::corners(&t, id)),
        };
        watch.replay.log.push((entry, NONE));
    }
    if !bounds.unbounded() {
        for id in 0..t.len() as u32 {
            queue_triangle(&mut t, bounds, id, &mut watch);
        }
    }
    // Forced points of one entry in the order it made them.
    let mut order: Vec<u32> = (0..forced.len() as u32).collect();
    order.sort_unstable_by_key(|&k| {
        let s = &forced[k as usize];
        (s.time, s.cause.key)
    });
    for (rank, &k) in order.iter().enumerate() {
        let s = &forced[k as usize];
        watch.queue.push(Reverse((
            s.time,
            s.cause.key,
            FORCED - forced.len() as u32 + rank as u32,
            k,
        )));
    }
    while let Some(Reverse((time, key, slot, stamp))) = watch.queue.pop() {
        if slot >= FORCED - forced.len() as u32 {
            watch.time = time;
            force(
                &mut t,
                bounds,
                &mut cavity,
                &forced[stamp as usize],
                &mut watch,
            )?;
            continue;
        }
        let corners = t.corners[slot as usize];
        if corners[0].max(corners[1]).max(corners[2]) != stamp & ((1 << 30) - 1) {
            continue;
        }
        watch.time = time;
        let skipped = watch.replay.skipped.len();
        step(
            &mut t,
            bounds,
            &mut cavity,
            slot,
            stamp >> 30,
            key,
            &mut watch,
        )
        .ok()?;
        if watch.replay.skipped.len() > skipped
            && let Some(&k) = expected_by_step.get(&(time, key))
        {
            force(&mut t, bounds, &mut cavity, &expected[k], &mut watch)?;
            watch.replay.adopted.push(expected[k]);
        }
    }
    leaves_to_forced_exactly(&watch.replay, forced).then_some(watch.replay)
}

/// Whether the steps the replay left to the forced points are those the forced points came
/// from, and it decided none of those itself.
fn leaves_to_forced_exactly(replay: &Replay, forced: &[Stamp]) -> bool {
    let from: HashSet<(Time, Key)> = forced.iter().map(|s| (s.time, s.cause.key)).collect();
    let adopted: HashSet<(Time, Key)> = replay
        .adopted
        .iter()
        .map(|s| (s.time, s.cause.key))
        .collect();
    replay
        .skipped
        .iter()
        .all(|k| from.contains(k) || adopted.contains(k))
        && replay
            .computed
            .iter()
            .all(|s| !from.contains(&(s.time, s.cause.key)))
}

/// Inserts `p` into the window's triangulation, walking from `hint`; the new hint.
fn insert(t: &mut Triangulation, cavity: &mut Cavity, p: DVec2, hint: u32) -> Option<u32> {
    match locate(t, p, hint) {
        Location::Inside(start) => {
            cavity.dig(t, p, start);
            cavity.commit(t, p, None);
            Some(cavity.created()[0])
        }
        _ => None,
    }
}

/// Inserts forced Steiner point `s`, after noting what its decision read.
fn force(
    t: &mut Triangulation,
    bounds: &Bounds,
    cavity: &mut Cavity,
    s: &Stamp,
    watch: &mut Replaying,
) -> Option<()> {
    if s.cause.decision != s.at
        && watch.window.holds(s.cause.decision)
        && let Location::Inside(start) = locate(t, s.cause.decision, 0)
    {
        cavity.dig(t, s.cause.decision, start);
        watch.note_cavity(t, cavity);
        watch.replay.reads.extend_from_slice(&watch.dug);
        cavity.abandon(t);
    }
    if !watch.window.holds(s.at) {
        return Some(());
    }
    let Location::Inside(start) = locate(t, s.at, 0) else {
        return None;
    };
    cavity.dig(t, s.at, start);
    watch.note_cavity(t, cavity);
    cavity.commit(t, s.at, None);
    watch.log_insertion(t, cavity, true);
    for &id in cavity.created() {
        queue_triangle(t, bounds, id, watch);
    }
    Some(())
}

impl Replay {
    /// Whether the replays `self` (before the change) and `after` differ only inside the
    /// window, so that `after`'s Steiner points are those of a whole run; `expected` are the
    /// Steiner points the mesh had that the replay before should have decided itself.
    pub fn agrees_beyond_change(
        &self,
        after: &Replay,
        window: &Window,
        expected: &[Stamp],
    ) -> bool {
        let decided: Vec<Stamp> = self.computed.iter().chain(&self.adopted).copied().collect();
        same_stamps(&decided, expected)
            && differences_inside(self, after, window)
            && differences_inside(after, self, window)
    }
}

fn stamp_bits(s: &Stamp) -> (u64, u64, Time, Key) {
    (s.at.x.to_bits(), s.at.y.to_bits(), s.time, s.cause.key)
}

fn same_stamps(a: &[Stamp], b: &[Stamp]) -> bool {
    let mut a: Vec<_> = a.iter().map(stamp_bits).collect();
    let mut b: Vec<_> = b.iter().map(stamp_bits).collect();
    a.sort_unstable();
    b.sort_unstable();
    a == b
}

/// Whether every logged change of `one` that `other` lacks is a trusted triangle, made or
/// destroyed by a fix (not a forced point) whose cavity and surroundings the window trusts,
/// and read by no forced point of either.
fn differences_inside(one: &Replay, other: &Replay, window: &Window) -> bool {
    let theirs: HashSet<Logged> = other.log.iter().map(|&(l, _)| l).collect();
    let read: HashSet<Corners> = one.reads.iter().chain(&other.reads).copied().collect();
    one.log.iter().all(|&(entry, k)| {
        if theirs.contains(&entry) {
            return true;
        }
        let by_trusted_fix = k == NONE || {
            let (forced, ring) = one.insertions[k as usize];
            !forced && ring
        };
        by_trusted_fix && window.trusts(points_of(entry.corners)) && !read.contains(&entry.corners)
    })
}

fn points_of(c: Corners) -> [DVec2; 3] {
    [0, 1, 2].map(|i| DVec2::new(f64::from_bits(c[2 * i]), f64::from_bits(c[2 * i + 1])))
}
