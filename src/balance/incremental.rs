//! The well-separated tree of [`super::separate()`] kept current as points come and go: each
//! edit runs the static rules' rounds on the points it can reach, and the tree is always the
//! one `separate` builds for the current points, whatever edits came before.
//!
//! The rules' least fixed point only grows with the points, so an insertion resumes the rounds
//! from the state before it: the new point's first move, then the points its squares crowd,
//! and so on. A deletion cannot be undone that way (two points can hold each other's leaves
//! down once nothing else does), so it first finds every point whose level may have rested on
//! the removed one. A point whose leaf lies below its points-only level `l` (the first level
//! where its 5×5 block holds no other point) went down there because split squares crowded its
//! block at levels `l` and below; every square a point `r` demands at a level `m < level(r)`
//! lies within two squares of `r`'s square of that level (its path, the path's rings, and
//! their balance closure), so only points `r` finer than `l` and within four squares of the
//! point at level `l` can have crowded it. Those points, taken transitively from the removed
//! one, start again from their points-only levels; the squares that only they and the removed
//! point demanded go, finest level first; and the rounds run on them with every other point
//! held where it was, which is where the least fixed point keeps it.
//!
//! The same holds under [`Separation::Corner`], whose demands and crowding reach no farther
//! (a point's corner block and the squares around it lie within one square of its own). One
//! thing differs: a new point may crowd another's corner block without lying in it, so that
//! no split square tells; the points within two squares of a new one at their own level are
//! settled against the points as well.

use std::collections::{BTreeMap, BTreeSet, HashMap, HashSet};

use super::separate::{
    DomainSides, Move, ON_BOTTOM, ON_LEFT, ON_RIGHT, ON_TOP, Rules, around, chebyshev,
    clear_of_points, corner_block_parents, descend, lies_across, partition_from, settle_against,
    settle_all, squares_across_lines, walk,
};
use super::slack::SlackVec;
use super::split_set::{SplitSet, Squares, at_position, grid_position, last_position};
use super::{BalancedTree, Separation, forced_by, linked_tree, separate_in};
use crate::framework::build_framework;
use crate::morton::{Cell, MortonKey, Side};
use crate::par;
use crate::quadtree::expand;

/// Distinct points' Morton keys with the well-separated tree of them, kept current under
/// insertions and deletions.
#[derive(Clone)]
pub struct SeparatedPoints<K: MortonKey> {
    /// Sorted, distinct.
    keys: SlackVec<K>,
    /// The level of each point's leaf, by Morton position.
    levels: SlackVec<u8>,
    /// The domain sides each point lies on, and the right and top sides where they are grid
    /// lines inside the root (a corner tree on a rectangle cut into cells).
    sides: DomainSides,
    /// The keys of the points on a domain side, sorted: the only points whose corner block
    /// may reach past a corner on a side.
    on_a_side: Vec<K>,
    /// The rule the tree is separated by.
    separation: Separation,
    /// The split squares, closed under balance.
    set: SplitSet<K>,
    /// How many points have their leaf at each level.
    at_level: Vec<usize>,
    /// The points alone in their square of level `isolated_level` (their lone level at most
    /// that, see [`lone_level`]), with their lone levels: where the squares of a coarse level
    /// hold many points each, the few alone in theirs are found here, not in `keys`.
    isolated: BTreeMap<K, u8>,
    /// The same points by lone level, then key: those alone at a level are a few runs here.
    isolated_by_level: BTreeSet<(u8, K)>,
    /// The coarsest level whose squares' lone points are all in `isolated`, chosen at the build
    /// so that about one point in [`ISOLATED_SHARE`] is.
    isolated_level: u8,
    /// Split squares added and taken out by the last edit.
    touched: usize,
    /// While on, each split square edits changed, with whether it was split before.
    log: Option<HashMap<Cell<K>, bool>>,
}

impl<K: MortonKey> SeparatedPoints<K> {
    /// The tree of `keys` (sorted and distinct) with `on[i]` the domain sides the `i`-th lies
    /// on ([`super::ON_LEFT`] and the others), on a grid whose root is the domain, separated by
    /// `separation`.
    pub fn new(keys: Vec<K>, on: Vec<u8>, separation: Separation) -> Self {
        Self::within(keys, on, separation, [None; 2])
    }

    /// [`Self::new`] on a domain whose right and top sides are the grid lines `lines` (finest
    /// units) where given, inside the root (see [`crate::morton::Grid::inner_lines`]); only a
    /// [`Separation::Corner`] tree takes them.
    pub fn within(
        keys: Vec<K>,
        on: Vec<u8>,
        separation: Separation,
        lines: [Option<u128>; 2],
    ) -> Self {
        assert_eq!(keys.len(), on.len(), "a side mask per key");
        assert!(
            separation == Separation::Corner || lines == [None; 2],
            "only a corner tree takes sides inside the root"
        );
        let on_a_side = keys
            .iter()
            .zip(&on)
            .filter(|&(_, &on)| on != 0)
            .map(|(&key, _)| key)
            .collect();
        let sides = DomainSides {
            on: on.into(),
            inner_right: lines[0],
            inner_top: lines[1].map(|line| line as f64),
            ..DomainSides::default()
        };
        let mut set = SplitSet::new();
        // The squares across the sides stay split whatever the points.
        set.insert_closed(squares_across_lines::<K>(lines));
        let mut levels = Vec::new();
        if !keys.is_empty() {
            let quadtree = expand(&build_framework(&keys), &keys);
            let (tree, _) = separate_in(&quadtree, &keys, Some(&sides), u8::MAX, separation)
                .expect("no band without a side inside the root");
            levels = tree
                .point_leaf
                .iter()
                .map(|&leaf| tree.tree.leaves[leaf as usize].cell.level)
                .collect();
            set.insert_closed(tree.tree.internal.iter().map(|s| Squares::one(s.cell)));
        }
        let mut at_level = vec![0; K::AXIS_BITS as usize + 1];
        for &level in &levels {
            at_level[level as usize] += 1;
        }
        let (isolated, isolated_level) = isolated_points(&keys);
        let isolated_by_level = isolated.iter().map(|(&k, &l)| (l, k)).collect();
        SeparatedPoints {
            keys: keys.into(),
            levels: levels.into(),
            sides,
            on_a_side,
            separation,
            set,
            at_level,
            isolated,
            isolated_by_level,
            isolated_level,
            touched: 0,
            log: None,
        }
    }

    /// The rule the tree is separated by.
    pub fn separation(&self) -> Separation {
        self.separation
    }

    /// The domain's right and top sides where they are grid lines inside the root.
    pub fn lines(&self) -> [Option<u128>; 2] {
        Rules::new(Some(&self.sides)).lines()
    }

    /// The rules of the tree's separation on its domain.
    fn rules(&self) -> Rules<'_> {
        Rules::new(Some(&self.sides)).separating(self.separation)
    }

    /// The level of the finest point leaf, 0 with no points.
    pub fn deepest(&self) -> u8 {
        self.at_level.iter().rposition(|&n| n > 0).unwrap_or(0) as u8
    }

    /// How many split squares the last insertion or removal added or took out (a square taken
    /// out and put back counts twice).
    pub fn touched(&self) -> usize {
        self.touched
    }

    /// Sets point `i`'s leaf level, keeping the count per level.
    fn set_level(&mut self, i: usize, level: u8) {
        self.at_level[self.levels[i] as usize] -= 1;
        self.at_level[level as usize] += 1;
        self.levels[i] = level;
    }

    /// The points' keys in Morton order.
    pub fn keys(&self) -> &[K] {
        &self.keys
    }

    /// The level of each point's leaf, by Morton position.
    pub fn levels(&self) -> &[u8] {
        &self.levels
    }

    /// The domain sides the point with key `key` lies on, if it is one of the points.
    pub fn sides_on_of(&self, key: K) -> Option<u8> {
        let i = self.keys.binary_search(&key).ok()?;
        Some(self.sides.on[i])
    }

    /// Whether `key` is one of the points.
    pub fn contains(&self, key: K) -> bool {
        self.keys.binary_search(&key).is_ok()
    }

    /// The tree, with links and point location: the one [`super::separate_in`] gives for the
    /// current keys.
    pub fn tree(&self) -> BalancedTree<K> {
        linked_tree(&self.set.preorder(), &self.keys)
    }

    /// Starts a log of the split squares edits add or take out, each with whether it was split
    /// before its first change, so that the tree as it was can still be read (see
    /// [`Self::was_split`]); or, with `on` false, stops it.
    pub fn log_changes(&mut self, on: bool) {
        self.log = on.then(HashMap::new);
    }

    /// Whether `square` was split when the log started (now, without a log).
    pub fn was_split(&self, square: Cell<K>) -> bool {
        match self.log.as_ref().and_then(|log| log.get(&square)) {
            Some(&before) => before,
            None => self.set.contains(square),
        }
    }

    /// Whether `square` is split, now or, with `before`, when the log started.
    pub fn is_split(&self, square: Cell<K>, before: bool) -> bool {
        if before {
            self.was_split(square)
        } else {
            self.set.contains(square)
        }
    }

    /// The squares split now and not when the log started, or the other way round.
    pub fn changed_squares(&self) -> Vec<Cell<K>> {
        let Some(log) = &self.log else {
            return Vec::new();
        };
        let mut changed: Vec<Cell<K>> = log
            .iter()
            .filter(|&(&square, &before)| before != self.set.contains(square))
            .map(|(&square, _)| square)
            .collect();
        changed.sort_unstable_by_key(|c| (c.level, c.anchor));
        changed
    }

    /// The leaf holding `key`, now or, with `before`, when the log started.
    pub fn leaf_of(&self, key: K, before: bool) -> Cell<K> {
        let mut cell = Cell::root();
        while u32::from(cell.level) < K::AXIS_BITS && self.is_split(cell, before) {
            cell = Cell::containing(key, cell.level + 1);
        }
        cell
    }

    /// The tree, now or, with `before`, when the log started, split only where its squares meet
    /// one of `rects` (grid units) and where balance forces it, with the points `keys`
    /// (sorted): a coarser tree that is the same as the whole one inside the rectangles.
    pub fn part_within(&self, rects: &[GridRect], before: bool, keys: &[K]) -> BalancedTree<K> {
        let mut split = Vec::new();
        self.visit_meeting(rects, before, |cell, is_split| {
            if is_split {
                split.push(Squares::one(cell));
            }
        });
        let mut closed = SplitSet::new();
        closed.insert_closed(squares_across_lines::<K>(self.lines()));
        closed.insert_closed(split);
        linked_tree(&closed.preorder(), keys)
    }

    /// The leaves, now or, with `before`, when the log started, that meet `rect`.
    pub fn leaves_meeting(&self, rect: GridRect, before: bool) -> Vec<Cell<K>> {
        let mut leaves = Vec::new();
        self.visit_meeting(&[rect], before, |cell, is_split| {
            if !is_split {
                leaves.push(cell);
            }
        });
        leaves
    }

    /// The Morton positions of the points in the leaves that meet `rect` (grid units), now.
    pub fn points_within(&self, rect: GridRect) -> Vec<usize> {
        let mut positions = Vec::new();
        self.visit_meeting(&[rect], false, |cell, is_split| {
            if !is_split {
                positions.extend(self.points_in(cell));
            }
        });
        positions.sort_unstable();
        positions
    }

    /// Calls `visit` with every square, now or as it was, that meets one of `rects` and whose
    /// parent is split, and whether it is split itself: the split squares and the leaves there.
    fn visit_meeting(
        &self,
        rects: &[GridRect],
        before: bool,
        mut visit: impl FnMut(Cell<K>, bool),
    ) {
        let mut stack = vec![Cell::<K>::root()];
        while let Some(cell) = stack.pop() {
            if !rects.iter().any(|r| r.meets(cell)) {
                continue;
            }
            let split = u32::from(cell.level) < K::AXIS_BITS && self.is_split(cell, before);
            visit(cell, split);
            if split {
                stack.extend((0..4).map(|q| cell.child(q)));
            }
        }
    }

    /// Adds a point with key `key`, not one of the points yet, lying on the domain sides `on`;
    /// returns its Morton position.
    pub fn insert(&mut self, key: K, on: u8) -> usize {
        self.insert_many(&[(key, on)])[0]
    }

    /// Adds points with keys `new` (sorted, distinct, none of the points yet) and their domain
    /// sides; returns their Morton positions. Their first moves are found in parallel and the
    /// rounds run on all of them at once, as in a build from scratch.
    pub fn insert_many(&mut self, new: &[(K, u8)]) -> Vec<usize> {
        debug_assert!(
            new.windows(2).all(|w| w[0].0 < w[1].0),
            "sorted, distinct keys"
        );
        let positions = self.merge_in(new);
        self.at_level[0] += new.len();
        self.touched = 0;
        let moves = par::filter_map(&positions, |&i| Some(self.first_move(i)));
        let mut crowded = self.leaves_taken(&positions);
        if self.separation == Separation::Corner {
            crowded.extend(self.corners_crowded_by(&positions));
            crowded.sort_unstable();
            crowded.dedup();
        }
        self.run_rounds(moves, crowded);
        positions
    }

    /// The older points near the new points at `positions` (sorted) whose corner block a new
    /// point may crowd at their present level ([`Separation::Corner`]): a new point lies in
    /// the 6×6 squares of the next level around such a point's corner, so within two squares
    /// of its square at its level. (Under [`Separation::Block`] a new point in another's block
    /// splits its own square there, which crowds that block by a split square.)
    fn corners_crowded_by(&self, positions: &[usize]) -> Vec<u32> {
        let is_new = |j: usize| positions.binary_search(&j).is_ok();
        let deepest = self.deepest();
        let mut found = Vec::new();
        // Only levels some point's leaf has.
        let levels: Vec<u8> = (0..=deepest)
            .filter(|&l| self.at_level[l as usize] > 0)
            .collect();
        for &p in positions {
            for &level in &levels {
                let centre = Cell::containing(self.keys[p], level);
                found.extend(
                    self.alone_near(centre, 2)
                        .into_iter()
                        .filter(|&q| !is_new(q) && self.levels[q] == level)
                        .map(|q| q as u32),
                );
            }
        }
        found
    }

    /// Puts the keys `new` (sorted) with their sides into the arrays in place, at level 0, and
    /// those on a side into their list; returns their positions.
    fn merge_in(&mut self, new: &[(K, u8)]) -> Vec<usize> {
        let positions: Vec<usize> = new
            .iter()
            .enumerate()
            .map(|(j, &(key, _))| {
                let before = self.keys.partition_point(|k| *k < key);
                assert!(self.keys.get(before) != Some(&key), "a new key");
                before + j
            })
            .collect();
        let keys: Vec<K> = new.iter().map(|n| n.0).collect();
        let on: Vec<u8> = new.iter().map(|n| n.1).collect();
        self.keys.insert_sorted(&positions, &keys);
        self.levels.insert_sorted(&positions, &vec![0; new.len()]);
        self.sides.on.insert_sorted(&positions, &on);
        self.note_isolation_around(&positions);
        for &(key, _) in new.iter().filter(|n| n.1 != 0) {
            let at = self.on_a_side.partition_point(|k| *k < key);
            self.on_a_side.insert(at, key);
        }
        positions
    }

    /// The points whose leaf one of the new points at `positions` (sorted) lies in: the
    /// nearest earlier points on either side of each in Morton order, as a leaf is a run of
    /// keys holding one point.
    fn leaves_taken(&self, positions: &[usize]) -> Vec<u32> {
        let is_new = |j: usize| positions.binary_search(&j).is_ok();
        let mut taken = Vec::new();
        for &p in positions {
            let before = (0..p).rev().find(|&j| !is_new(j));
            let after = (p + 1..self.keys.len()).find(|&j| !is_new(j));
            for q in before.into_iter().chain(after) {
                if Cell::containing(self.keys[q], self.levels[q]).contains(self.keys[p]) {
                    taken.push(q as u32);
                }
            }
        }
        taken.sort_unstable();
        taken.dedup();
        taken
    }

    /// Moves the point with key `from` to key `to` if that keeps the tree as it is; returns
    /// whether it did. Under [`Separation::Block`] it does when the point stays in its leaf on
    /// the same domain sides: every rule reads a point's squares no finer than its leaf, and a
    /// square finer than another point's leaf holding it would have crowded that point's
    /// block. Under [`Separation::Corner`] the point must also stay in the quarter of its leaf
    /// at its corner, which its own rules read. Another point `q` with a finer leaf (side
    /// `s_q` at most half this leaf's `s`) reads this point's square of the level below its
    /// own when that lies within `1.5 s_q` of `q`'s corner; were any place of the quarter so
    /// near, `q` would lie within `s/2 + 1.5 s_q + s_q/2 ≤ 1.5 s` of this point's corner, in the
    /// squares whose points crowd this leaf, which the tree, separated, rules out.
    pub fn move_within_leaf(&mut self, from: K, to: K, on: u8) -> bool {
        let Ok(i) = self.keys.binary_search(&from) else {
            return false;
        };
        let level = self.levels[i];
        let read = match self.separation {
            Separation::Block => level,
            Separation::Corner => (level + 1).min(K::AXIS_BITS as u8),
        };
        if !Cell::containing(from, read).contains(to) || self.sides.on[i] != on {
            return false;
        }
        self.keys[i] = to;
        self.forget_isolated(from);
        self.note_isolation_around(&[i]);
        if on != 0 {
            // The point's leaf holds no other key: the order stays.
            let at = self
                .on_a_side
                .binary_search(&from)
                .expect("a point on a side");
            self.on_a_side[at] = to;
        }
        self.touched = 0;
        true
    }

    /// Removes the point with key `key`, one of the points; returns its Morton position.
    pub fn remove(&mut self, key: K) -> usize {
        self.remove_many(&[key])[0]
    }

    /// Removes the points with keys `gone` (sorted, distinct, all of them points); returns
    /// their Morton positions before the removal. The points that may have rested on any of
    /// them restart together, their first moves found in parallel.
    pub fn remove_many(&mut self, gone: &[K]) -> Vec<usize> {
        let removed: Vec<usize> = gone
            .iter()
            .map(|&key| self.keys.binary_search(&key).expect("a present key"))
            .collect();
        debug_assert!(
            removed.windows(2).all(|w| w[0] < w[1]),
            "sorted, distinct keys"
        );
        let resting = self.resting_on(&removed);
        let demanded = self.demands_of_points(resting.iter().chain(&removed).copied());
        self.compact_without(&removed);
        self.touched = 0;
        // Positions past removed points move down one for each.
        let restart: Vec<usize> = resting
            .into_iter()
            .map(|q| q - removed.partition_point(|&r| r < q))
            .collect();
        let held_back: HashSet<usize> = restart.iter().copied().collect();
        // The squares to judge lie around the removed points: their searches start there.
        let near = removed
            .first()
            .map_or(0, |&r| r.min(self.keys.len().saturating_sub(1)));
        self.drop_unsupported(&demanded, (&held_back, near));
        let moves = par::filter_map(&restart, |&q| Some(self.first_move(q)));
        self.run_rounds(moves, Vec::new());
        removed
    }

    /// Takes the points at the sorted positions `removed` out of the arrays (and the list of
    /// those on a side).
    fn compact_without(&mut self, removed: &[usize]) {
        for &i in removed {
            self.at_level[self.levels[i] as usize] -= 1;
            if self.sides.on[i] != 0 {
                let at = self
                    .on_a_side
                    .binary_search(&self.keys[i])
                    .expect("a point on a side");
                self.on_a_side.remove(at);
            }
        }
        for &i in removed {
            self.forget_isolated(self.keys[i]);
        }
        self.keys.remove_sorted(removed);
        self.levels.remove_sorted(removed);
        self.sides.on.remove_sorted(removed);
        // The points on either side of each gap have new Morton neighbours.
        let gaps: Vec<usize> = removed.iter().enumerate().map(|(j, &i)| i - j).collect();
        self.note_isolation_around(&gaps);
    }

    /// Brings the entries of `isolated` up to date at the Morton positions `positions` and
    /// next to them, after the keys there changed.
    fn note_isolation_around(&mut self, positions: &[usize]) {
        let n = self.keys.len();
        for &p in positions {
            for i in p.saturating_sub(1)..(p + 2).min(n) {
                let (key, lone) = (self.keys[i], lone_level(&self.keys, i));
                if self.isolated.get(&key) == Some(&lone) {
                    continue;
                }
                self.forget_isolated(key);
                if lone <= self.isolated_level {
                    self.isolated.insert(key, lone);
                    self.isolated_by_level.insert((lone, key));
                }
            }
        }
    }

    /// Takes `key` out of the isolated points, if it is there.
    fn forget_isolated(&mut self, key: K) {
        if let Some(lone) = self.isolated.remove(&key) {
            self.isolated_by_level.remove(&(lone, key));
        }
    }

    /// The move of point `i` from the root: past split squares and squares whose block holds
    /// another point or leaves the root, then past squares whose block holds a split square.
    fn first_move(&self, i: usize) -> Move {
        let rules = self.rules();
        let split = walk(&self.set, self.keys[i], lone_level(&self.keys, i));
        let level = clear_of_points(&rules, &self.keys, i, split);
        Move {
            point: i as u32,
            from: 0,
            split: 0,
            to: descend(&self.set, &rules, &self.keys, i, level),
        }
    }

    /// The rounds of [`super::separate_in`] from `moves` on: the squares the moves demand,
    /// then the moves of the points those crowd, until none moves.
    fn run_rounds(&mut self, mut moves: Vec<Move>, mut crowded: Vec<u32>) {
        while !moves.is_empty() || !crowded.is_empty() {
            let mut demanded = Vec::new();
            let rules = self.rules();
            for &m in &moves {
                rules.demands(&self.set, &self.keys, m, &mut demanded);
            }
            let added = self.set.insert_closed(demanded);
            if let Some(log) = &mut self.log {
                for square in added.iter().flat_map(|squares| squares.cells()) {
                    log.entry(square).or_insert(false);
                }
            }
            self.touched += added
                .iter()
                .map(|s| s.mask().count_ones() as usize)
                .sum::<usize>();
            for m in &moves {
                self.set_level(m.point as usize, m.to);
            }
            let mut candidates = self.near(&added);
            // Points whose leaf took new points, or whose corner block new points crowd, are
            // settled in the first round whatever it added, and against the points as well.
            candidates.retain(|c| crowded.binary_search(c).is_err());
            let rules = self.rules();
            moves = settle_all(&self.set, &rules, &self.keys, &self.levels, &candidates);
            let crowded = std::mem::take(&mut crowded);
            let against_points = (&crowded[..], true);
            moves.extend(settle_against(
                &self.set,
                &rules,
                &self.keys,
                &self.levels,
                against_points,
            ));
        }
    }

    /// The points whose leaf is one of the `added` squares or has one in its 5×5 block, sorted.
    fn near(&self, added: &[Squares<K>]) -> Vec<u32> {
        let mut points: Vec<u32> = added
            .iter()
            .flat_map(|squares| squares.cells())
            .flat_map(|square| around_and(square, 2))
            .filter_map(|cell| {
                // A leaf holds one point (those that took new points are settled apart).
                let i = self.only_point_in(cell)?;
                (self.levels[i] == cell.level).then_some(i as u32)
            })
            .collect();
        points.sort_unstable();
        points.dedup();
        points
    }

    /// The Morton position of the one point in `cell`, if it holds exactly one.
    fn only_point_in(&self, cell: Cell<K>) -> Option<usize> {
        let anchor = cell.anchor;
        let first = self.keys.partition_point(|k| *k < anchor);
        let inside = |j: usize| self.keys.get(j).is_some_and(|&k| cell.contains(k));
        (inside(first) && !inside(first + 1)).then_some(first)
    }

    /// The points alone in their square of `centre`'s level within `radius` (at most 5) of
    /// it. The squares four levels up that cover those (at most 2×2) are runs of Morton
    /// positions: a short run is read point by point, a long one searched square by square.
    fn alone_near(&self, centre: Cell<K>, radius: u64) -> Vec<usize> {
        const SHORT_RUN: usize = 48;
        let level = centre.level;
        if level <= self.isolated_level {
            return self.isolated_near(centre, radius);
        }
        let alone = |q: usize, cell: Cell<K>| {
            let holds = |j: Option<usize>| {
                j.and_then(|j| self.keys.get(j))
                    .is_some_and(|&k| cell.contains(k))
            };
            !holds(q.checked_sub(1)) && !holds(Some(q + 1))
        };
        let mut found = Vec::new();
        for cover in Window::new(centre, radius).covers() {
            let run = self.points_in(cover);
            if run.len() <= SHORT_RUN {
                for q in run {
                    let key = self.keys[q];
                    if lies_within(key, centre, radius) && alone(q, Cell::containing(key, level)) {
                        found.push(q);
                    }
                }
                continue;
            }
            let keys = &self.keys[run.clone()];
            for cell in around_and(centre, radius as i64).filter(|c| cover.contains(c.anchor)) {
                let anchor = cell.anchor;
                let first = keys.partition_point(|k| *k < anchor);
                if keys.get(first).is_some_and(|&k| cell.contains(k))
                    && alone(run.start + first, cell)
                {
                    found.push(run.start + first);
                }
            }
        }
        found
    }

    /// [`Self::alone_near`] at a level no finer than `isolated_level`, read from the isolated
    /// points: those alone in their square of `centre`'s level are the ones whose lone level is
    /// no finer. They are found lone level by lone level in the (at most 2×2) squares four
    /// levels up that cover the window, or, where that takes more searches than the window
    /// has squares, square by square: a square holds a point alone in it when its first
    /// isolated key has a lone level no finer than the square's.
    fn isolated_near(&self, centre: Cell<K>, radius: u64) -> Vec<usize> {
        let level = centre.level;
        let window = Window::new(centre, radius);
        let covers = window.covers();
        let position = |key: &K| {
            let at = self.keys.binary_search(key);
            at.expect("an isolated key is a point")
        };
        if covers.len() as u64 * (u64::from(level) + 1) > window.squares() {
            return around_and(centre, radius as i64)
                .filter_map(|cell| {
                    let (key, &lone) = self.isolated.range(cell.anchor..).next()?;
                    (cell.contains(*key) && lone <= level).then(|| position(key))
                })
                .collect();
        }
        let mut found = Vec::new();
        for cover in covers {
            for lone in 0..=level {
                let run = self
                    .isolated_by_level
                    .range((lone, cover.anchor)..)
                    .take_while(|&&(l, k)| l == lone && cover.contains(k));
                for (_, key) in run {
                    if lies_within(*key, centre, radius) {
                        found.push(position(key));
                    }
                }
            }
        }
        found
    }

    /// [`Self::points_in`], searched for by galloping from Morton position `near`: fewer
    /// steps, and close in memory, for squares near that point.
    fn points_in_from(&self, cell: Cell<K>, near: usize) -> std::ops::Range<usize> {
        let anchor = cell.anchor;
        let first = partition_from(&self.keys, near, |k| *k < anchor);
        let end = partition_from(&self.keys, first, |&k| k < anchor || cell.contains(k));
        first..end
    }

    /// The Morton positions of the points of `cell` that lie on a domain side.
    fn on_a_side_in(&self, cell: Cell<K>) -> impl Iterator<Item = usize> + '_ {
        let anchor = cell.anchor;
        let first = self.on_a_side.partition_point(|k| *k < anchor);
        self.on_a_side[first..]
            .iter()
            .take_while(move |&&k| cell.contains(k))
            .map(|key| self.keys.binary_search(key).expect("a point"))
    }

    /// The points of `cell` by Morton position.
    fn points_in(&self, cell: Cell<K>) -> std::ops::Range<usize> {
        let anchor = cell.anchor;
        let first = self.keys.partition_point(|k| *k < anchor);
        let end = first + self.keys[first..].partition_point(|&k| cell.contains(k));
        first..end
    }

    /// The points whose level may have rested on the points `removed` (see the module's
    /// account), found from them transitively; Morton positions before their removal.
    fn resting_on(&self, removed: &[usize]) -> Vec<usize> {
        let rules = self.rules();
        let mut points_only = std::collections::HashMap::new();
        let mut points_only_level = |q: usize| {
            *points_only.entry(q).or_insert_with(|| {
                clear_of_points(&rules, &self.keys, q, lone_level(&self.keys, q))
            })
        };
        let mut found: Vec<usize> = Vec::new();
        let mut seen: HashSet<usize> = removed.iter().copied().collect();
        let mut queue = removed.to_vec();
        let mut searched = HashSet::new();
        let mut windows = Windows::default();
        while let Some(r) = queue.pop() {
            let is_removed = removed.binary_search(&r).is_ok();
            // The removed point also frees the points its own presence crowded, one level
            // above their points-only level: within two squares there, five at that level.
            let (radius, deepest) = if is_removed {
                (5, self.levels[r])
            } else {
                (4, self.levels[r].saturating_sub(1))
            };
            for m in 0..=deepest {
                let centre = Cell::containing(self.keys[r], m);
                // What a search finds hangs only on its square, its radius, and whether the
                // point it is made for is removed or rests deeper: nearby points share the
                // coarse squares, and a search done once is not done again.
                let search = (centre, radius, is_removed, self.levels[r] > m);
                if !searched.insert(search) {
                    continue;
                }
                for q in windows.alone_near(self, centre, radius) {
                    if seen.contains(&q) {
                        continue;
                    }
                    let cell = Cell::containing(self.keys[q], m);
                    let distance = chebyshev(grid_position(cell), grid_position(centre));
                    let rested = self.levels[q] > m && self.levels[r] > m && distance <= 4;
                    let crowded = is_removed && m > 0 && {
                        let above = |k: K| grid_position(Cell::containing(k, m - 1));
                        chebyshev(above(self.keys[q]), above(self.keys[r])) <= 2
                    };
                    // The points-only level last: the dearest test.
                    if (rested || crowded) && points_only_level(q) == m {
                        seen.insert(q);
                        found.push(q);
                        queue.push(q);
                    }
                }
            }
        }
        found.sort_unstable();
        found
    }

    /// Every square that `points` demand at their present levels: their paths, the paths'
    /// rings, and what balance then forces (under [`Separation::Corner`], more than they
    /// demand: squares that are not split among them).
    fn demands_of_points(&self, points: impl Iterator<Item = usize>) -> SplitSet<K> {
        let mut demanded = SplitSet::new();
        for p in points {
            let mut wanted = Vec::new();
            for level in 0..self.levels[p] {
                let square = Cell::containing(self.keys[p], level);
                demanded.missing_near(square, 1, &mut wanted);
            }
            demanded.insert_closed(wanted);
        }
        demanded
    }

    /// Takes out of the split squares those of `demanded` that no point outside `held_back`
    /// demands at its present level, finest level first, so that the squares balance forces
    /// are judged on what stays at the level below.
    fn drop_unsupported(&mut self, demanded: &SplitSet<K>, held_back: (&HashSet<usize>, usize)) {
        for level in (0..=K::AXIS_BITS as u8).rev() {
            let squares: Vec<Cell<K>> = demanded
                .squares_of(level)
                .filter(|&square| self.set.contains(square))
                .collect();
            for square in squares {
                if !self.demanded_by_others(square, held_back) {
                    self.set.remove(square);
                    if let Some(log) = &mut self.log {
                        log.entry(square).or_insert(true);
                    }
                    self.touched += 1;
                }
            }
        }
    }

    /// Whether a point outside `held_back` demands `square`: it is on the path of such a point
    /// or of its ring (the point's square of that level within one of it, the point's leaf
    /// finer), or balance forces it from a split square of the level below. The points are
    /// searched for from Morton position `near`.
    fn demanded_by_others(
        &self,
        square: Cell<K>,
        (held_back, near): (&HashSet<usize>, usize),
    ) -> bool {
        let level = square.level;
        let forced = || {
            forcing_candidates(square)
                .any(|finer| self.set.contains(finer) && forced_by(finer).contains(&Some(square)))
        };
        if self.separation == Separation::Corner {
            let lines = self.lines();
            if lies_across(square, lines) {
                return true;
            }
            if level as u32 >= K::AXIS_BITS {
                return false;
            }
            // On the path of such a point, or a parent of its corner block one level down.
            let demands = |j: usize| {
                let key = self.keys[j];
                !held_back.contains(&j)
                    && self.levels[j] > level
                    && (square.contains(key)
                        || corner_block_parents(key, level, self.sides.on[j], lines)
                            .any(|c| c == square))
            };
            if self.points_in_from(square, near).any(demands) {
                return true;
            }
            // A point's corner block one level down reaches into `square` only from the
            // quarter of its square next to the corner: two levels down, touching `square`.
            // Which corner, and so whether it reaches, is the same for every point there
            // but where the corner lies on a side, and then only points on a side reach.
            let depth = 2.min(K::AXIS_BITS as u8 - level);
            let by_a_point = touching_ring(square, depth).any(|cell| {
                let reaches = |on: u8| {
                    corner_block_parents(cell.anchor, level, on, lines).any(|c| c == square)
                };
                if reaches(0) {
                    self.points_in_from(cell, near).any(demands)
                } else if reaches(ON_LEFT | ON_BOTTOM | ON_RIGHT | ON_TOP) {
                    self.on_a_side_in(cell).any(demands)
                } else {
                    false
                }
            });
            return by_a_point || forced();
        }
        let on_a_path = around_and(square, 1).any(|cell| {
            let mut others = 0;
            for j in self.points_in_from(cell, near) {
                if held_back.contains(&j) {
                    continue;
                }
                // Two points in a square split it, whatever their levels.
                others += 1;
                if self.levels[j] > level || others > 1 {
                    return true;
                }
            }
            false
        });
        on_a_path || forced()
    }
}

/// A rectangle of the grid, in finest grid units: columns `x0..x1`, rows `y0..y1`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GridRect {
    /// First column.
    pub x0: u128,
    /// Past the last column.
    pub x1: u128,
    /// First row.
    pub y0: u128,
    /// Past the last row.
    pub y1: u128,
}

impl GridRect {
    /// Whether the square `cell` meets the rectangle's interior.
    pub fn meets<K: MortonKey>(&self, cell: Cell<K>) -> bool {
        let (x, y) = { cell.anchor }.decode();
        let (x, y) = (u128::from(x), u128::from(y));
        let side = 1u128 << (K::AXIS_BITS - u32::from(cell.level));
        x < self.x1 && self.x0 < x + side && y < self.y1 && self.y0 < y + side
    }
}

/// The squares of a level within a radius of one of them, inside the root: columns and rows.
struct Window {
    level: u8,
    columns: std::ops::RangeInclusive<u64>,
    rows: std::ops::RangeInclusive<u64>,
}

impl Window {
    fn new<K: MortonKey>(centre: Cell<K>, radius: u64) -> Self {
        let (x, y) = grid_position(centre);
        let last = last_position(centre.level);
        let span = |c: u64| c.saturating_sub(radius)..=c.saturating_add(radius).min(last);
        Window {
            level: centre.level,
            columns: span(x),
            rows: span(y),
        }
    }

    /// How many squares it has.
    fn squares(&self) -> u64 {
        let width = |r: &std::ops::RangeInclusive<u64>| r.end() - r.start() + 1;
        width(&self.columns) * width(&self.rows)
    }

    /// The squares four levels up (fewer near the root) that cover it: at most 2×2 for a
    /// radius up to 7, each a run of Morton positions.
    fn covers<K: MortonKey>(&self) -> Vec<Cell<K>> {
        let up = 4.min(self.level);
        let span = |r: &std::ops::RangeInclusive<u64>| r.start() >> up..=r.end() >> up;
        span(&self.columns)
            .flat_map(|cx| span(&self.rows).map(move |cy| (cx, cy)))
            .map(|(cx, cy)| at_position(cx, cy, self.level - up))
            .collect()
    }
}

/// Whether the square of `centre`'s level holding `key` lies within `radius` of `centre`.
fn lies_within<K: MortonKey>(key: K, centre: Cell<K>, radius: u64) -> bool {
    let cell = Cell::containing(key, centre.level);
    chebyshev(grid_position(cell), grid_position(centre)) <= radius
}

/// About one point in this many is in [`SeparatedPoints::isolated`] after a build.
const ISOLATED_SHARE: usize = 32;

/// The first level where point `i` of `keys` (sorted) is alone in its square: one below the
/// deepest square it shares with a Morton neighbour.
fn lone_level<K: MortonKey>(keys: &[K], i: usize) -> u8 {
    let key = keys[i];
    let shared = |j: Option<usize>| {
        j.and_then(|j| keys.get(j))
            .map_or(0, |&other| key.common_level(other) + 1)
    };
    shared(i.checked_sub(1)).max(shared(Some(i + 1)))
}

/// The points of `keys` (sorted) alone in their square of the coarsest level that leaves at
/// most one point in [`ISOLATED_SHARE`] so, with their lone levels; and that level (the root's
/// with no keys, which keeps the map empty for a tree grown from none).
fn isolated_points<K: MortonKey>(keys: &[K]) -> (BTreeMap<K, u8>, u8) {
    if keys.is_empty() {
        return (BTreeMap::new(), 0);
    }
    let lone: Vec<u8> = (0..keys.len()).map(|i| lone_level(keys, i)).collect();
    let mut at = vec![0usize; K::AXIS_BITS as usize + 2];
    for &l in &lone {
        at[l as usize] += 1;
    }
    let allowed = keys.len() / ISOLATED_SHARE;
    let mut level = 0;
    let mut count = at[0];
    while level < K::AXIS_BITS as usize && count + at[level + 1] <= allowed {
        level += 1;
        count += at[level];
    }
    let level = level as u8;
    let isolated = keys
        .iter()
        .zip(&lone)
        .filter(|&(_, &l)| l <= level)
        .map(|(&k, &l)| (k, l))
        .collect();
    (isolated, level)
}

/// The searches of [`SeparatedPoints::alone_near`] one removal made, kept so that a window
/// inside one searched before is read from its answer: the points found around a removed point
/// lie near it, and their windows at the coarser levels mostly lie inside its own.
#[derive(Default)]
struct Windows<K: MortonKey> {
    /// By the square searched around: each radius searched and the points found.
    searched: HashMap<Cell<K>, Vec<(u64, Vec<usize>)>>,
}

impl<K: MortonKey> Windows<K> {
    /// The widest radius searched.
    const WIDEST: u64 = 5;

    /// The points alone in their square of `centre`'s level within `radius` (at most
    /// [`Self::WIDEST`]) of it.
    fn alone_near(
        &mut self,
        points: &SeparatedPoints<K>,
        centre: Cell<K>,
        radius: u64,
    ) -> Vec<usize> {
        debug_assert!(radius <= Self::WIDEST);
        let position = grid_position(centre);
        let holding = around_and(centre, (Self::WIDEST - radius) as i64).find_map(|cell| {
            let distance = chebyshev(grid_position(cell), position);
            self.searched
                .get(&cell)?
                .iter()
                .find(|(wider, _)| distance + radius <= *wider)
        });
        if let Some((_, found)) = holding {
            let near = |&q: &usize| lies_within(points.keys[q], centre, radius);
            return found.iter().copied().filter(near).collect();
        }
        let found = points.alone_near(centre, radius);
        let searches = self.searched.entry(centre).or_default();
        searches.push((radius, found.clone()));
        found
    }
}

/// `cell` and the same-size squares within `radius` of it inside the root.
fn around_and<K: MortonKey>(cell: Cell<K>, radius: i64) -> impl Iterator<Item = Cell<K>> {
    std::iter::once(cell).chain(around(cell, radius).flatten())
}

/// The squares `depth` levels below `square` that touch it from outside, inside the root.
fn touching_ring<K: MortonKey>(square: Cell<K>, depth: u8) -> impl Iterator<Item = Cell<K>> {
    let level = square.level + depth;
    let (x, y) = grid_position(square);
    let first = |c: u64| (i128::from(c) << depth) - 1;
    let (x0, y0) = (first(x), first(y));
    let span = (1i128 << depth) + 2;
    let side = 1i128 << level;
    let on_ring = move |i: i128, j: i128| i == 0 || j == 0 || i == span - 1 || j == span - 1;
    (0..span)
        .flat_map(move |i| (0..span).map(move |j| (i, j)))
        .filter(move |&(i, j)| on_ring(i, j))
        .map(move |(i, j)| (x0 + i, y0 + j))
        .filter(move |&(cx, cy)| (0..side).contains(&cx) && (0..side).contains(&cy))
        .map(move |(cx, cy)| at_position(cx as u64, cy as u64, level))
}

/// The squares of the level below whose split may force `square`: its children and those of
/// its four side neighbours.
fn forcing_candidates<K: MortonKey>(square: Cell<K>) -> impl Iterator<Item = Cell<K>> {
    let finest = square.level as u32 >= K::AXIS_BITS;
    let neighbours = [Side::West, Side::East, Side::South, Side::North]
        .into_iter()
        .filter_map(move |side| square.neighbour(side));
    std::iter::once(square)
        .chain(neighbours)
        .filter(move |_| !finest)
        .flat_map(|parent| (0..4).map(move |q| parent.child(q)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::balance::sides_of;
    use crate::morton::{Grid, MortonKey};
    use glam::DVec2;
    use rand::{Rng as _, SeedableRng};
    use rand_xoshiro::Xoshiro256PlusPlus as Rng;

    /// What `separate_in` builds for these keys from scratch.
    fn static_tree<K: MortonKey>(
        keys: &[K],
        sides: &DomainSides,
        separation: Separation,
    ) -> Option<BalancedTree<K>> {
        if keys.is_empty() {
            return None;
        }
        let quadtree = expand(&build_framework(keys), keys);
        Some(
            separate_in(&quadtree, keys, Some(sides), u8::MAX, separation)
                .unwrap()
                .0,
        )
    }

    fn check_against_static<K: MortonKey>(points: &SeparatedPoints<K>) {
        let on_a_side: Vec<K> = (0..points.keys.len())
            .filter(|&i| points.sides.on[i] != 0)
            .map(|i| points.keys[i])
            .collect();
        assert_eq!(points.on_a_side, on_a_side, "the points on a side, listed");
        let isolated: BTreeMap<K, u8> = (0..points.keys.len())
            .map(|i| (points.keys[i], lone_level(&points.keys, i)))
            .filter(|&(_, lone)| lone <= points.isolated_level)
            .collect();
        assert_eq!(points.isolated, isolated, "the isolated points");
        let by_level: BTreeSet<(u8, K)> = isolated.iter().map(|(&k, &l)| (l, k)).collect();
        assert_eq!(
            points.isolated_by_level, by_level,
            "the isolated points by level"
        );
        let Some(expected) = static_tree(&points.keys, &points.sides, points.separation) else {
            return;
        };
        let tree = points.tree();
        if tree != expected {
            let cells = |t: &BalancedTree<K>| -> HashSet<(K, u8)> {
                t.tree
                    .internal
                    .iter()
                    .map(|s| (s.cell.anchor, s.cell.level))
                    .collect()
            };
            let (have, want) = (cells(&tree), cells(&expected));
            let extra: Vec<_> = have.difference(&want).collect();
            let missing: Vec<_> = want.difference(&have).collect();
            let levels = |t: &BalancedTree<K>| -> Vec<u8> {
                t.point_leaf
                    .iter()
                    .map(|&l| {
                        t.tree
                            .leaves
                            .get(l as usize)
                            .map_or(255, |leaf| leaf.cell.level)
                    })
                    .collect()
            };
            panic!(
                "the tree of {} points differs: extra {extra:?}, missing {missing:?}, levels {:?} vs {:?}",
                points.keys.len(),
                levels(&tree),
                levels(&expected)
            );
        }
    }

    /// The sides of the unit square `p` lies on.
    fn on_sides(p: DVec2) -> u8 {
        sides_of(p, DVec2::ZERO, DVec2::ONE)
    }

    /// A random point of the unit square: uniform, in a tight cluster, on a side or a
    /// corner, or on a row of points three squares apart at one level (a row whose leaves
    /// each rest on the next one's).
    fn point(rng: &mut Rng) -> DVec2 {
        match rng.random_range(0..10) {
            0 | 1 => DVec2::new(
                0.3 + rng.random::<f64>() * 1e-3,
                0.6 + rng.random::<f64>() * 1e-3,
            ),
            2 => DVec2::new(rng.random::<f64>(), 0.0),
            3 => DVec2::new(1.0, rng.random::<f64>()),
            4 => DVec2::new(rng.random::<f64>(), 1.0),
            5 => [DVec2::ZERO, DVec2::ONE, DVec2::X][rng.random_range(0..3)],
            6 | 7 => {
                let k = f64::from(rng.random_range(0..40u8));
                DVec2::new(0.1 + k * 3.0 / 256.0 + rng.random::<f64>() * 1e-4, 0.25)
            }
            _ => DVec2::new(rng.random::<f64>(), rng.random::<f64>()),
        }
    }

    /// The keys of `count` random points with their sides, sorted, one per key.
    fn random_keys(rng: &mut Rng, count: usize, grid: &Grid) -> Vec<(u64, u8)> {
        let mut pairs: Vec<(u64, u8)> = (0..count)
            .map(|_| {
                let p = point(rng);
                (key_of(grid, p), on_sides(p))
            })
            .collect();
        pairs.sort_unstable();
        pairs.dedup_by_key(|p| p.0);
        pairs
    }

    fn key_of(grid: &Grid, p: DVec2) -> u64 {
        let (x, y) = grid.quantize(p);
        u64::encode(x, y)
    }

    fn key_of_wide(grid: &Grid, p: DVec2) -> u128 {
        let (x, y) = grid.quantize(p);
        u128::encode(x, y)
    }

    /// Random insertions and deletions, down to no point and back, each followed by a check
    /// against the static build.
    fn random_edits<K: MortonKey>(
        seeds: std::ops::RangeInclusive<u64>,
        key: impl Fn(DVec2) -> K,
        separation: Separation,
    ) {
        for seed in seeds {
            let mut rng = Rng::seed_from_u64(seed * 0x9E37_79B9_7F4A_7C15);
            let mut points = SeparatedPoints::<K>::new(Vec::new(), Vec::new(), separation);
            let mut live: Vec<K> = Vec::new();
            for step in 0..400 {
                let delete =
                    !live.is_empty() && (rng.random_range(0..5) < 2 || (150..220).contains(&step));
                if delete {
                    let key = live.swap_remove(rng.random_range(0..live.len()));
                    points.remove(key);
                } else {
                    let p = point(&mut rng);
                    let key = key(p);
                    if points.contains(key) {
                        continue;
                    }
                    points.insert(key, on_sides(p));
                    live.push(key);
                }
                check_against_static(&points);
            }
        }
    }

    const SEPARATIONS: [Separation; 2] = [Separation::Block, Separation::Corner];

    #[test]
    fn on_a_rectangle_cut_into_cells_random_edits_keep_the_static_tree() {
        // 3 × 2 cells of level 2 and 2 × 7 of level 3: the right and top sides are grid lines
        // inside the root, and the squares across them stay split through every edit.
        for (hi, columns, rows, level) in [
            (DVec2::new(1.5, 1.0), 3, 2, 2),
            (DVec2::new(0.5, 1.75), 2, 7, 3),
        ] {
            let cells = crate::morton::DomainCells {
                level,
                columns,
                rows,
            };
            let grid = Grid::on_domain_cells(DVec2::ZERO, hi, u64::AXIS_BITS, cells).unwrap();
            let lines = grid.inner_lines();
            assert!(lines.iter().all(Option::is_some));
            let onto = |p: DVec2| {
                let axis = |t: f64, h: f64| if t == 1.0 { h } else { (t * h).min(h) };
                DVec2::new(axis(p.x, hi.x), axis(p.y, hi.y))
            };
            for seed in 1..=6u64 {
                let mut rng = Rng::seed_from_u64(seed * 0x9E37_79B9_7F4A_7C15);
                let mut points = SeparatedPoints::<u64>::within(
                    Vec::new(),
                    Vec::new(),
                    Separation::Corner,
                    lines,
                );
                let mut live: Vec<u64> = Vec::new();
                for step in 0..300 {
                    if !live.is_empty()
                        && (rng.random_range(0..5) < 2 || (100..160).contains(&step))
                    {
                        let key = live.swap_remove(rng.random_range(0..live.len()));
                        points.remove(key);
                    } else {
                        let p = onto(point(&mut rng));
                        let key = key_of(&grid, p);
                        if points.contains(key) {
                            continue;
                        }
                        points.insert(key, sides_of(p, DVec2::ZERO, hi));
                        live.push(key);
                    }
                    check_against_static(&points);
                    let tree = points.tree();
                    crate::balance::check_corner_separated_in(
                        &tree.tree,
                        &points.keys,
                        Some(&points.sides),
                    )
                    .unwrap();
                    if live.is_empty() {
                        // No points: the squares across the sides alone.
                        let mut alone = SplitSet::<u64>::new();
                        alone.insert_closed(squares_across_lines::<u64>(lines));
                        assert_eq!(points.set.preorder(), alone.preorder());
                    }
                }
            }
        }
    }

    #[test]
    fn moves_within_a_leaf_keep_the_static_tree() {
        for separation in SEPARATIONS {
            moves_within_a_leaf(separation);
        }
    }

    fn moves_within_a_leaf(separation: Separation) {
        // A small step in grid units, often within the leaf, sometimes out of it.
        let step = |key: u64, _: u8, rng: &mut Rng| {
            let (x, y) = key.decode();
            let step = |c: u64, r: u64| c.wrapping_add(r % (1 << 22)).wrapping_sub(1 << 21);
            u64::encode(step(x, rng.random::<u64>()), step(y, rng.random::<u64>()))
        };
        let (moved, _) = random_moves(31, 2000, separation, step);
        assert!(
            moved > 100,
            "{separation:?}: only {moved} moves kept the tree"
        );
    }

    #[test]
    fn corner_moves_anywhere_in_the_leafs_nearest_quarter_keep_the_static_tree() {
        // Moves to random places in the quarter of the leaf by the moved corner: each keeps
        // the tree (see `move_within_leaf`).
        let anywhere_in_the_quarter = |key: u64, level: u8, rng: &mut Rng| {
            let quarter = Cell::containing(key, level + 1);
            let (x, y) = { quarter.anchor }.decode();
            let side = 1u64 << (u64::AXIS_BITS - u32::from(quarter.level));
            u64::encode(x + rng.random_range(0..side), y + rng.random_range(0..side))
        };
        let (moved, refused) = random_moves(41, 4000, Separation::Corner, anywhere_in_the_quarter);
        assert!(
            moved > 1000 && refused == 0,
            "{moved} moved, {refused} refused"
        );
    }

    /// `trials` moves of random points of a tree of 300 random ones to the keys `target`
    /// picks from a point's key and leaf level, each kept (and compared with the static tree)
    /// or refused by `move_within_leaf`; how many of each.
    fn random_moves(
        seed: u64,
        trials: usize,
        separation: Separation,
        target: impl Fn(u64, u8, &mut Rng) -> u64,
    ) -> (usize, usize) {
        let grid = Grid::on_domain(DVec2::ZERO, DVec2::ONE, u64::AXIS_BITS).unwrap();
        let mut rng = Rng::seed_from_u64(seed);
        let pairs = random_keys(&mut rng, 300, &grid);
        let (mut keys, on): (Vec<u64>, Vec<u8>) = pairs.iter().copied().unzip();
        let mut points = SeparatedPoints::new(keys.clone(), on.clone(), separation);
        let (mut moved, mut refused) = (0, 0);
        for _ in 0..trials {
            let i = rng.random_range(0..keys.len());
            let to = target(keys[i], points.levels()[i], &mut rng);
            if points.contains(to) {
                continue;
            }
            if !points.move_within_leaf(keys[i], to, on[i]) {
                refused += 1;
                continue;
            }
            moved += 1;
            keys[i] = to;
            assert_eq!(points.keys(), &keys[..]);
            check_against_static(&points);
        }
        (moved, refused)
    }

    #[test]
    fn batches_of_insertions_and_removals_give_the_static_tree() {
        for separation in SEPARATIONS {
            batches(separation);
        }
    }

    fn batches(separation: Separation) {
        let grid = Grid::on_domain(DVec2::ZERO, DVec2::ONE, u64::AXIS_BITS).unwrap();
        let mut rng = Rng::seed_from_u64(57);
        let mut points = SeparatedPoints::<u64>::new(Vec::new(), Vec::new(), separation);
        let mut live: Vec<u64> = Vec::new();
        for round in 0..30 {
            let size = 1 + rng.random_range(0..40usize);
            if round % 3 == 2 && !live.is_empty() {
                let mut gone: Vec<u64> = (0..size.min(live.len()))
                    .map(|_| live.swap_remove(rng.random_range(0..live.len())))
                    .collect();
                gone.sort_unstable();
                points.remove_many(&gone);
            } else {
                let mut new: Vec<(u64, u8)> = (0..size)
                    .map(|_| {
                        let p = point(&mut rng);
                        (key_of(&grid, p), on_sides(p))
                    })
                    .filter(|&(k, _)| !points.contains(k))
                    .collect();
                new.sort_unstable();
                new.dedup_by_key(|p| p.0);
                points.insert_many(&new);
                live.extend(new.iter().map(|p| p.0));
            }
            check_against_static(&points);
        }
    }

    #[test]
    fn random_edits_give_the_static_tree_after_every_step() {
        let grid = Grid::on_domain(DVec2::ZERO, DVec2::ONE, u64::AXIS_BITS).unwrap();
        random_edits(1..=12, |p| key_of(&grid, p), Separation::Block);
    }

    #[test]
    fn random_edits_of_the_corner_tree_give_the_static_tree_after_every_step() {
        let grid = Grid::on_domain(DVec2::ZERO, DVec2::ONE, u64::AXIS_BITS).unwrap();
        random_edits(1..=12, |p| key_of(&grid, p), Separation::Corner);
    }

    /// A crowd in one corner of the domain, some of it on the sides there: the empty squares
    /// beside it are judged from the corners of the crowd's edge, and on the sides only the
    /// points on them reach across (the corner tree's deletions).
    #[test]
    fn a_crowd_in_a_corner_of_the_domain_edits_like_the_static_tree() {
        let grid = Grid::on_domain(DVec2::ZERO, DVec2::ONE, u64::AXIS_BITS).unwrap();
        for seed in 1..=4u64 {
            let mut rng = Rng::seed_from_u64(seed);
            let mut points =
                SeparatedPoints::<u64>::new(Vec::new(), Vec::new(), Separation::Corner);
            let mut live: Vec<u64> = Vec::new();
            for step in 0..300 {
                if !live.is_empty() && (rng.random_range(0..3) == 0 || step >= 240) {
                    let key = live.swap_remove(rng.random_range(0..live.len()));
                    points.remove(key);
                } else {
                    let (a, b) = (rng.random::<f64>() * 0.25, rng.random::<f64>() * 0.25);
                    let p = match rng.random_range(0..6) {
                        0 => DVec2::new(a, 0.0),
                        1 => DVec2::new(0.0, a),
                        _ => DVec2::new(a, b),
                    };
                    let key = key_of(&grid, p);
                    if points.contains(key) {
                        continue;
                    }
                    points.insert(key, on_sides(p));
                    live.push(key);
                }
                check_against_static(&points);
            }
        }
    }

    #[test]
    fn random_edits_on_the_wide_grid_give_the_static_tree() {
        let grid = Grid::on_domain(DVec2::ZERO, DVec2::ONE, u128::AXIS_BITS).unwrap();
        for separation in SEPARATIONS {
            random_edits(20..=23, |p| key_of_wide(&grid, p), separation);
        }
    }

    #[test]
    fn a_built_tree_edits_like_one_grown_point_by_point() {
        for separation in SEPARATIONS {
            built_then_edited(separation);
        }
    }

    #[test]
    fn a_built_tree_takes_random_edits_as_a_rebuild_would() {
        let grid = Grid::on_domain(DVec2::ZERO, DVec2::ONE, u64::AXIS_BITS).unwrap();
        for separation in SEPARATIONS {
            let mut rng = Rng::seed_from_u64(5);
            let pairs = random_keys(&mut rng, 600, &grid);
            let (keys, on): (Vec<u64>, Vec<u8>) = pairs.iter().copied().unzip();
            let mut points = SeparatedPoints::new(keys.clone(), on, separation);
            assert!(points.isolated_level > 0, "a build chooses a level");
            let mut live = keys;
            for _ in 0..150 {
                let p = point(&mut rng);
                let key = key_of(&grid, p);
                match rng.random_range(0..3) {
                    0 if !points.contains(key) => {
                        points.insert(key, on_sides(p));
                        live.push(key);
                    }
                    1 => {
                        let from = live[rng.random_range(0..live.len())];
                        let on = points.sides_on_of(from).expect("a live point");
                        // Places off the domain's sides, near the point: most stay in its leaf.
                        let near = from ^ rng.random_range(0..1u64 << 20);
                        let free = on == 0 && !points.contains(near);
                        if free && points.move_within_leaf(from, near, on) {
                            live.retain(|&k| k != from);
                            live.push(near);
                        }
                    }
                    _ => {
                        let key = live.swap_remove(rng.random_range(0..live.len()));
                        points.remove(key);
                    }
                }
                check_against_static(&points);
            }
        }
    }

    fn built_then_edited(separation: Separation) {
        let grid = Grid::on_domain(DVec2::ZERO, DVec2::ONE, u64::AXIS_BITS).unwrap();
        let mut rng = Rng::seed_from_u64(77);
        let pairs = random_keys(&mut rng, 400, &grid);
        let (keys, on): (Vec<u64>, Vec<u8>) = pairs.iter().copied().unzip();
        let mut points = SeparatedPoints::new(keys, on, separation);
        check_against_static(&points);
        for (k, &(key, _)) in pairs.iter().enumerate().step_by(3) {
            points.remove(key);
            if k % 2 == 0 {
                check_against_static(&points);
            }
        }
        check_against_static(&points);
    }
}
