//! Fewer Steiner vertices after refinement: each free Steiner vertex (on no wall) is taken out
//! where the triangulation left meets the bounds, the free vertices of any triangle that then
//! misses them moved first to where their stars' smallest angle is largest. Every step keeps
//! the triangulation constrained Delaunay (the hole filled by Delaunay ears, a moved vertex's
//! surroundings flipped back to Delaunay, exact predicates); a removal whose repair fails is
//! undone whole. Sequential, in the order of the vertices, so the result is the same on any
//! thread count.

use glam::DVec2;

use super::delaunay::{FREE, NEXT, PREV, Store, Triangulation, flip_to_delaunay_in};
use super::refiner::{Bounds, closed_star, fill_star, meets_bounds_firmly};
use crate::mesh::NONE;
use crate::predicates::{Orientation, orientation};

/// Passes over the vertices at most: later passes find few.
const MAX_PASSES: usize = 4;
/// A removal whose worst new triangle has a smallest angle's squared sine under this share of
/// the bound's is undone without trying moves.
const HOPELESS: f64 = 0.5;
/// Rounds of moves that may repair the triangles a removal left below the bounds.
const MAX_REPAIR_ROUNDS: usize = 6;
/// Flips that may follow one move before it is given up.
const MAX_FLIPS_PER_MOVE: usize = 256;
/// Halvings of the pattern search's step, from a quarter of the shortest spoke.
const SEARCH_HALVINGS: usize = 5;
/// Moves of the pattern search at one step size.
const MOVES_PER_STEP: usize = 2;
/// The largest star a moved vertex may have.
const MAX_STAR: usize = 32;

/// Takes out free Steiner vertices (numbered from `first_steiner`, on no wall) where the
/// triangulation left, after moving free vertices near them, meets `bounds`; returns how many
/// went. The freed slots and vertices are left for [`Triangulation::pack`].
pub(super) fn remove_spare_vertices(
    t: &mut Triangulation,
    bounds: &Bounds,
    first_steiner: u32,
) -> usize {
    let mut removed = 0;
    // A vertex is tried again only once a removal has changed a triangle of it.
    let mut changed = vec![true; t.vertices.len()];
    for _ in 0..MAX_PASSES {
        let mut home = homes(t);
        let mut gone = 0;
        for v in first_steiner..t.vertices.len() as u32 {
            let Some((t0, k0)) = home[v as usize] else {
                continue;
            };
            if t.segment_of(v) != NONE || !std::mem::take(&mut changed[v as usize]) {
                continue;
            }
            let mut j = Journal::new(t);
            if j.try_remove(bounds, first_steiner, t0, k0) {
                let touched = j.commit();
                for slot in touched {
                    let c = t.corners[slot as usize];
                    if c[0] != FREE {
                        for (k, &x) in c.iter().enumerate() {
                            home[x as usize] = Some((slot, k));
                            changed[x as usize] = true;
                        }
                    }
                }
                home[v as usize] = None;
                gone += 1;
            }
        }
        removed += gone;
        if gone == 0 {
            break;
        }
    }
    removed
}

/// A triangle and corner of each vertex that has one.
fn homes(t: &Triangulation) -> Vec<Option<(u32, usize)>> {
    let mut home = vec![None; t.vertices.len()];
    for (slot, c) in t.corners.iter().enumerate() {
        if c[0] == FREE {
            continue;
        }
        for (k, &x) in c.iter().enumerate() {
            home[x as usize] = Some((slot as u32, k));
        }
    }
    home
}

/// The triangulation as a store that saves each triangle and vertex before it changes, so
/// that an attempt can be undone.
struct Journal<'t> {
    t: &'t mut Triangulation,
    triangles: Vec<(u32, [u32; 3], [u32; 3], u32)>,
    moves: Vec<(u32, DVec2)>,
    spare: Vec<u32>,
    vertex: Option<u32>,
}

impl<'t> Journal<'t> {
    fn new(t: &'t mut Triangulation) -> Self {
        Journal {
            t,
            triangles: Vec::new(),
            moves: Vec::new(),
            spare: Vec::new(),
            vertex: None,
        }
    }

    fn save(&mut self, slot: u32) {
        let s = slot as usize;
        let region = self.t.regions.get(s).copied().unwrap_or(NONE);
        self.triangles
            .push((slot, self.t.corners[s], self.t.across[s], region));
    }

    /// Removes the vertex at corner `k0` of `t0` if it is free and what is left, repaired by
    /// moves, meets the bounds; otherwise undoes everything. Whether it went.
    fn try_remove(&mut self, bounds: &Bounds, first_steiner: u32, t0: u32, k0: usize) -> bool {
        let Some(emptied) = fill_star(self, t0, k0) else {
            return false;
        };
        for &slot in &emptied.spare {
            *self.corners_mut(slot) = [FREE; 3];
            *self.across_mut(slot) = [NONE; 3];
        }
        self.spare = emptied.spare;
        self.vertex = Some(emptied.vertex);
        let mut last = (usize::MAX, f64::NEG_INFINITY);
        for _ in 0..=MAX_REPAIR_ROUNDS {
            let bad = self.missing_bounds(bounds);
            if bad.is_empty() {
                return true;
            }
            // Far below the bound, moves rarely repair it (half the squared sine: about
            // 22.6° at 33°); nor do rounds that leave as many bad triangles, none better.
            let now = (bad.len(), self.worst_sine2(&bad));
            if now.1 < HOPELESS * bounds.sin2 || (now.0 >= last.0 && now.1 <= last.1) {
                break;
            }
            last = now;
            let movable = self.movable_corners(&bad, first_steiner);
            if movable.is_empty() || !self.move_all(&movable) {
                break;
            }
        }
        self.undo();
        false
    }

    /// The smallest squared sine among the smallest angles of triangles `slots`.
    fn worst_sine2(&self, slots: &[u32]) -> f64 {
        slots
            .iter()
            .map(|&s| {
                let [a, b, c] = self.t.corners[s as usize].map(|v| self.point(v));
                smallest_sine2(a, b, c)
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// The changed triangles that miss the bounds.
    fn missing_bounds(&self, bounds: &Bounds) -> Vec<u32> {
        self.changed_slots()
            .into_iter()
            .filter(|&s| self.t.corners[s as usize][0] != FREE)
            .filter(|&s| !meets_bounds_firmly(self, bounds, s))
            .collect()
    }

    /// The free Steiner corners of triangles `bad`, with a triangle of each, in vertex order.
    fn movable_corners(&self, bad: &[u32], first_steiner: u32) -> Vec<(u32, u32, usize)> {
        let mut out: Vec<(u32, u32, usize)> = bad
            .iter()
            .flat_map(|&slot| {
                let c = self.t.corners[slot as usize];
                (0..3).map(move |k| (c[k], slot, k))
            })
            .filter(|&(x, _, _)| x >= first_steiner && self.t.segment_of(x) == NONE)
            .collect();
        out.sort_unstable_by_key(|&(x, _, _)| x);
        out.dedup_by_key(|e| e.0);
        out
    }

    /// Moves each vertex to where its star's smallest angle is largest and flips its
    /// surroundings back to Delaunay; `false` if a flip budget ran out.
    fn move_all(&mut self, movable: &[(u32, u32, usize)]) -> bool {
        for &(x, slot, k) in movable {
            // An earlier move's flips may have moved the vertex to another triangle.
            let (slot, k) = if self.t.corners[slot as usize][k] == x {
                (slot, k)
            } else {
                match self.find_corner(x) {
                    Some(found) => found,
                    None => continue,
                }
            };
            let Some(star) = closed_star(&*self, slot, k, MAX_STAR) else {
                continue;
            };
            let from = self.t.vertices[x as usize];
            let to = best_position(&self.t.vertices, x, &star.rim);
            if to == from {
                continue;
            }
            // The star's triangles change shape: they are checked with the changed ones.
            for &s in &star.triangles {
                self.save(s);
            }
            self.moves.push((x, from));
            self.t.vertices[x as usize] = to;
            let edges = star
                .triangles
                .iter()
                .flat_map(|&s| [(s, 0), (s, 1), (s, 2)])
                .collect();
            if !flip_to_delaunay_in(self, edges, MAX_FLIPS_PER_MOVE) {
                return false;
            }
        }
        true
    }

    /// A triangle and corner of vertex `x` among the changed triangles.
    fn find_corner(&self, x: u32) -> Option<(u32, usize)> {
        self.triangles.iter().find_map(|e| {
            let c = self.t.corners[e.0 as usize];
            (c[0] != FREE)
                .then(|| c.iter().position(|&y| y == x).map(|k| (e.0, k)))
                .flatten()
        })
    }

    /// Puts every saved triangle and moved vertex back.
    fn undo(&mut self) {
        for &(slot, corners, across, region) in self.triangles.iter().rev() {
            let s = slot as usize;
            self.t.corners[s] = corners;
            self.t.across[s] = across;
            if let Some(r) = self.t.regions.get_mut(s) {
                *r = region;
            }
        }
        for &(x, p) in self.moves.iter().rev() {
            self.t.vertices[x as usize] = p;
        }
        self.triangles.clear();
        self.moves.clear();
    }

    /// Keeps the changes: the spare slots and the vertex are freed. Returns the changed
    /// triangles' slots.
    fn commit(self) -> Vec<u32> {
        for &slot in &self.spare {
            self.t.free_slots.push(slot);
        }
        if let Some(v) = self.vertex {
            self.t.freed_vertices.push(v);
            self.t.vertices_deleted += 1;
        }
        self.changed_slots()
    }

    /// The slots of the triangles saved so far, each once, in order.
    fn changed_slots(&self) -> Vec<u32> {
        let mut slots: Vec<u32> = self.triangles.iter().map(|e| e.0).collect();
        slots.sort_unstable();
        slots.dedup();
        slots
    }
}

/// Where vertex `x` makes the smallest angle of the fan to its `rim` largest, every triangle
/// of the fan counter-clockwise by the exact test: a pattern search from where it is (where it
/// is, if the place found fails the exact test).
fn best_position(vertices: &[DVec2], x: u32, rim: &[u32]) -> DVec2 {
    let ring: Vec<DVec2> = rim.iter().map(|&r| vertices[r as usize]).collect();
    let mut best = vertices[x as usize];
    let mut score = fan_quality(best, &ring);
    let shortest = ring
        .iter()
        .map(|&p| p.distance(best))
        .fold(f64::INFINITY, f64::min);
    let mut step = 0.25 * shortest;
    const DIRECTIONS: [(f64, f64); 8] = [
        (1.0, 0.0),
        (-1.0, 0.0),
        (0.0, 1.0),
        (0.0, -1.0),
        (0.707, 0.707),
        (-0.707, 0.707),
        (0.707, -0.707),
        (-0.707, -0.707),
    ];
    for _ in 0..SEARCH_HALVINGS {
        // Move while some direction improves (a few times: along a ridge, steps this size
        // would creep), then halve the step.
        for _ in 0..MOVES_PER_STEP {
            let better = DIRECTIONS.iter().find_map(|&(dx, dy)| {
                let q = best + step * DVec2::new(dx, dy);
                let s = fan_quality(q, &ring);
                (s > score).then_some((q, s))
            });
            match better {
                Some((q, s)) => (best, score) = (q, s),
                None => break,
            }
        }
        step *= 0.5;
    }
    // The search tests turns in f64; the place it ends at must pass the exact test.
    let exact = (0..ring.len())
        .all(|i| orientation(best, ring[i], ring[(i + 1) % ring.len()]) == Orientation::Left);
    if exact { best } else { vertices[x as usize] }
}

/// The smallest squared sine of the smallest angles of the fan from `p` to `ring`, or -1 if a
/// triangle of it does not turn counter-clockwise in f64.
fn fan_quality(p: DVec2, ring: &[DVec2]) -> f64 {
    let n = ring.len();
    let mut worst = f64::INFINITY;
    for i in 0..n {
        let (a, b) = (ring[i], ring[(i + 1) % n]);
        if (a - p).perp_dot(b - p) <= 0.0 {
            return -1.0;
        }
        worst = worst.min(smallest_sine2(p, a, b));
    }
    worst
}

/// The squared sine of the smallest angle of triangle `p a b`: twice its area squared over
/// the product of the squares of the two sides beside that angle.
pub(super) fn smallest_sine2(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    let len2 = [
        a.distance_squared(b),
        b.distance_squared(p),
        p.distance_squared(a),
    ];
    let shortest = (0..3)
        .min_by(|&i, &j| len2[i].total_cmp(&len2[j]))
        .expect("three sides");
    let area2 = (a - p).perp_dot(b - p);
    area2 * area2 / (len2[NEXT[shortest]] * len2[PREV[shortest]])
}

impl Store for Journal<'_> {
    const WHOLE: bool = true;

    #[inline]
    fn point(&self, v: u32) -> DVec2 {
        self.t.point(v)
    }
    #[inline]
    fn corners(&self, t: u32) -> [u32; 3] {
        self.t.corners[t as usize]
    }
    fn corners_mut(&mut self, t: u32) -> &mut [u32; 3] {
        self.save(t);
        &mut self.t.corners[t as usize]
    }
    #[inline]
    fn across(&self, t: u32) -> [u32; 3] {
        self.t.across[t as usize]
    }
    fn across_mut(&mut self, t: u32) -> &mut [u32; 3] {
        self.save(t);
        &mut self.t.across[t as usize]
    }
    fn push_vertex(&mut self, _p: DVec2) -> u32 {
        unreachable!("improvement adds no vertex")
    }
    fn push_triangle(&mut self) -> u32 {
        unreachable!("improvement adds no triangle")
    }
    fn may_change(&self, _corners: [u32; 3]) -> bool {
        true
    }
    fn triangle_count(&self) -> usize {
        self.t.corners.len()
    }
    fn vertex_count(&self) -> usize {
        self.t.vertex_count()
    }
    fn room(&self) -> bool {
        true
    }
    fn keeps_regions(&self) -> bool {
        self.t.keeps_regions()
    }
    fn region(&self, t: u32) -> u32 {
        self.t.region(t)
    }
    fn set_region(&mut self, t: u32, r: u32) {
        self.save(t);
        self.t.set_region(t, r);
    }
    fn segment_of(&self, v: u32) -> u32 {
        self.t.segment_of(v)
    }
    fn is_free(&self, t: u32) -> bool {
        self.t.corners[t as usize][0] == FREE
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::predicates::{InCircle, in_circle};
    use crate::refine::delaunay::corner_facing_in;

    /// A Delaunay triangulation of the square [0, 8]² and 40 points spread over it by a
    /// fixed sequence (no four cocircular).
    fn scattered() -> Triangulation {
        let mut t = Triangulation::rectangle(DVec2::ZERO, DVec2::splat(8.0));
        let points = (1..=40).map(|k| {
            let k = f64::from(k);
            DVec2::new(
                0.3 + (k * 0.618_034).fract() * 7.4,
                0.3 + (k * 0.414_214).fract() * 7.4,
            )
        });
        t.insert_all(points).expect("points inside the square");
        t
    }

    /// Every link reciprocal, every triangle counter-clockwise, every edge locally Delaunay.
    fn assert_delaunay(t: &Triangulation) {
        for id in 0..t.len() as u32 {
            let c = t.corners[id as usize];
            if c[0] == FREE {
                continue;
            }
            let [a, b, d] = c.map(|v| t.vertices[v as usize]);
            assert_eq!(orientation(a, b, d), Orientation::Left, "triangle {id}");
            for i in 0..3 {
                let o = t.across[id as usize][i];
                if o == NONE {
                    continue;
                }
                let j = corner_facing_in(t, o, id);
                let far = t.vertices[t.corners[o as usize][j] as usize];
                assert_ne!(in_circle(a, b, d, far), InCircle::Inside, "edge {id}/{i}");
            }
        }
    }

    #[test]
    fn an_undone_attempt_leaves_every_slot_and_vertex_as_it_was() {
        let mut t = scattered();
        let before = t.clone();
        let home = homes(&t);
        let mut moved = 0;
        for v in 4..t.vertices.len() as u32 {
            let (t0, k0) = home[v as usize].expect("every vertex has a triangle");
            let mut j = Journal::new(&mut t);
            let emptied = fill_star(&mut j, t0, k0).expect("an interior vertex's star fills");
            // Move a corner of the fill as a repair would, with its flips, then undo it all.
            let slot = emptied.made[0];
            let corner = (0..3)
                .find(|&k| j.t.corners[slot as usize][k] >= 4)
                .unwrap_or(0);
            let x = j.t.corners[slot as usize][corner];
            assert!(j.move_all(&[(x, slot, corner)]));
            moved += usize::from(!j.moves.is_empty());
            j.undo();
            assert_eq!(t.corners, before.corners, "vertex {v}");
            assert_eq!(t.across, before.across, "vertex {v}");
            assert_eq!(t.vertices, before.vertices, "vertex {v}");
        }
        assert!(moved > 20, "only {moved} attempts moved a vertex");
    }

    #[test]
    fn a_kept_removal_and_its_moves_leave_a_delaunay_triangulation() {
        let mut t = scattered();
        let home = homes(&t);
        let (t0, k0) = home[20].expect("vertex 20 has a triangle");
        let mut j = Journal::new(&mut t);
        let emptied = fill_star(&mut j, t0, k0).expect("an interior vertex's star fills");
        for &slot in &emptied.spare {
            *j.corners_mut(slot) = [FREE; 3];
        }
        j.spare = emptied.spare;
        j.vertex = Some(emptied.vertex);
        let movable: Vec<(u32, u32, usize)> = emptied
            .made
            .iter()
            .flat_map(|&s| (0..3).map(move |k| (s, k)))
            .map(|(s, k)| (j.t.corners[s as usize][k], s, k))
            .filter(|&(x, _, _)| x >= 4)
            .collect();
        assert!(j.move_all(&movable));
        j.commit();
        assert_eq!(t.freed_vertices, [20]);
        assert_delaunay(&t);
        t.pack();
        assert_eq!(t.vertices.len(), 44 - 1);
        assert_delaunay(&t);
    }
}
