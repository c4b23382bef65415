//! Planar straight-line graphs: cleaning an input's points and segments into a graph whose
//! segments meet only at their ends ([`clean`]), and cutting off its acute corners
//! ([`cut_acute_corners`]), the first step of meshing it in the quadtree (BET §5).
//!
//! The steps after it are [`crate::pipeline::graph_tree`] (the features separated in a balanced
//! tree, the edges cut at its leaves' sides), [`crate::warp::triangulate_graph`] (the leaves
//! bent onto the graph and triangulated) and [`carve_warped`] (the domain cut out, the caps put
//! back).

mod corners;
mod grid;
mod warped;

use std::collections::HashMap;

use glam::DVec2;
use rayon::prelude::*;

use crate::error::Error;
use crate::options::{Input, Segment};
use crate::par::SharedSlots;
use crate::predicates::{Orientation, orient_value, orientation};
pub use corners::{
    CAP_FRACTION, Cap, CornerCut, EdgeOrigin, GraphEdge, cut_acute_corners, feature_distances,
};
use grid::Grid;
pub use warped::carve_warped;

/// How many examples of each repair a [`CleanReport`] lists.
pub const REPORT_EXAMPLES: usize = 8;

/// Rounds of splitting at crossings before crossings that keep coming back (each split point is
/// rounded, and its pieces may cross again) are refused.
const MAX_ROUNDS: usize = 16;

/// Crossings a round after the first may find beyond twice the first round's before they are
/// refused as coming back without end: each round's splits can make new crossings, and pieces
/// nearly on one line far from the origin made more every round, doubling the points each time.
const RUNAWAY_SLACK: usize = 64;

/// What [`clean`] may repair beyond what it always does.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CleanOptions {
    /// Split crossing segments at their intersection point (a new point, rounded to f64), as
    /// Triangle does, instead of refusing them with [`Error::CrossingSegments`].
    pub split_crossings: bool,
}

/// A segment split at an input point lying in its interior.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct VertexSplit {
    /// Input index of the segment.
    pub segment: usize,
    /// The point, as an index into the cleaned points.
    pub point: u32,
}

/// Two crossing segments split at their intersection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CrossingSplit {
    /// Input index of one segment.
    pub a: usize,
    /// Input index of the other.
    pub b: usize,
    /// The point both were split at, as an index into the cleaned points (a new point, or an
    /// existing one at the rounded intersection).
    pub point: u32,
    /// Its position.
    pub at: DVec2,
}

/// What [`clean`] changed. Each repair has a count and its first [`REPORT_EXAMPLES`] examples.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CleanReport {
    /// Points merged into an earlier point at the same position.
    pub merged_points: usize,
    /// Examples: `[duplicate, kept]`, input point indices.
    pub merged_examples: Vec<[usize; 2]>,
    /// For each input point, its index in the cleaned points.
    pub point_map: Vec<u32>,
    /// Segments dropped because an earlier one joins the same two points (pieces of segments
    /// that overlap on one line included).
    pub repeated_segments: usize,
    /// Examples: `[dropped, kept]`, input segment indices.
    pub repeated_examples: Vec<[usize; 2]>,
    /// Splits of a segment at a point in its interior.
    pub vertex_splits: usize,
    /// Examples.
    pub vertex_split_examples: Vec<VertexSplit>,
    /// Pairs of crossing segments split at their intersection
    /// ([`CleanOptions::split_crossings`]).
    pub crossing_splits: usize,
    /// Examples.
    pub crossing_examples: Vec<CrossingSplit>,
    /// For each cleaned segment, the input segment it is (part of).
    pub segment_origin: Vec<u32>,
}

impl CleanReport {
    /// Whether the input needed no repair: the cleaned input is the input.
    pub fn is_clean(&self) -> bool {
        self.merged_points == 0
            && self.repeated_segments == 0
            && self.vertex_splits == 0
            && self.crossing_splits == 0
    }
}

/// The checks at the graph's door, before anything is indexed: the first point with a NaN or
/// infinite coordinate ([`Error::NonFinite`]), then, in segment order, a segment naming a point
/// that does not exist ([`Error::SegmentIndex`]) or naming one point twice
/// ([`Error::ZeroLengthSegment`]).
pub(crate) fn check_points_and_ends(input: &Input) -> Result<(), Error> {
    if let Some(index) = input.points.par_iter().position_first(|p| !p.is_finite()) {
        let p = input.points[index];
        return Err(Error::NonFinite {
            index,
            x: p.x,
            y: p.y,
        });
    }
    let n = input.points.len();
    for (segment, s) in input.segments.iter().enumerate() {
        if let Some(&index) = s.ends.iter().find(|&&e| e as usize >= n) {
            return Err(Error::SegmentIndex {
                segment,
                index,
                points: n,
            });
        }
        if s.ends[0] == s.ends[1] {
            return Err(Error::ZeroLengthSegment { segment });
        }
    }
    Ok(())
}

/// A segment being cleaned: its ends in the cleaned points, and its input segment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Piece {
    pub ends: [u32; 2],
    pub origin: u32,
}

/// Two pieces whose interiors meet, at `at`.
#[derive(Clone, Copy, Debug)]
struct Crossing {
    pieces: [usize; 2],
    at: DVec2,
}

/// The input's points and segments cleaned into a planar straight-line graph whose segments meet
/// only at their ends, with what was changed. Holes and regions are passed through unchanged.
///
/// In order: points at the same position (`0.0` and `-0.0` alike) are merged into the first
/// (the segments remapped; the cleaned points are the distinct ones in first-occurrence order);
/// a segment joining the same two points as an earlier one is dropped, the earlier one's marker
/// kept; a segment is split at every point lying exactly in its interior (exact orientation
/// test); then segments whose interiors still meet are refused, or split at their intersection
/// with [`CleanOptions::split_crossings`] (the rounded point appended to the points, or an
/// existing point at that position; the pieces are checked again, up to 16 rounds). Segments
/// that overlap on one line never reach that check: each has an end inside the other, where
/// they are split. Every decision uses exact predicates. The cleaned segments are the pieces of
/// the input segments in input order, each piece directed and marked as its segment.
///
/// The points and segments are bucketed on a uniform grid of about one cell per segment over the
/// points' bounding box: a segment goes into the cells it passes through, each point into its
/// cell, and only a segment and the points, or the segments, sharing a cell with it are tested.
/// The work is O(n + m + C + K) after O(n) expected hashing, for n points, m segments, C
/// segment–cell incidences (about m times a segment's length in cells) and K pairs tested in
/// shared cells: near-linear for inputs of evenly spread short segments, quadratic only where
/// many segments crowd one cell (a point where many segments meet). The tests run in parallel
/// on the current rayon pool; the output is the same on any thread count.
///
/// # Errors
/// [`Error::TooManyPoints`] beyond 32-bit indices, [`Error::NonFinite`] for the first point with
/// a NaN or infinite coordinate, [`Error::SegmentIndex`] for the first segment naming a point
/// that does not exist, [`Error::ZeroLengthSegment`] for the first segment whose ends are the
/// same point or at the same position, and [`Error::CrossingSegments`] naming the first pair (in
/// input segment order) of segments whose interiors meet, unless they are split;
/// [`Error::CrossingsUnsettled`] where splitting them keeps making new crossings.
pub fn clean(input: &Input, options: CleanOptions) -> Result<(Input, CleanReport), Error> {
    clean_segments(input, merge_points(input)?, options)
}

/// The first half of [`clean`]: the input checked, its points merged and its segments
/// remapped, repeats dropped. Its points are the cleaned points unless crossings are split,
/// so a triangulation of them may start while [`clean_segments`] finishes.
pub(crate) struct MergedInput {
    pub points: Vec<DVec2>,
    pieces: Vec<Piece>,
    report: CleanReport,
}

/// The first half of [`clean`], with the errors it finds.
///
/// # Errors
/// As [`clean`], but for crossing segments.
pub(crate) fn merge_points(input: &Input) -> Result<MergedInput, Error> {
    let n = input.points.len();
    if n >= u32::MAX as usize {
        return Err(Error::TooManyPoints(n));
    }
    check_points_and_ends(input)?;
    if input.segments.len() >= u32::MAX as usize {
        return Err(Error::TooLarge {
            what: "segments",
            count: input.segments.len(),
        });
    }

    let mut report = CleanReport::default();
    let merged = merge_positions(&input.points);
    let points = merged.points;
    report.merged_points = n - points.len();
    report.merged_examples = merged.examples;
    report.point_map = merged.point_map;

    let mut pieces = Vec::with_capacity(input.segments.len());
    for (segment, s) in input.segments.iter().enumerate() {
        let ends = s.ends.map(|e| report.point_map[e as usize]);
        if ends[0] == ends[1] {
            return Err(Error::ZeroLengthSegment { segment });
        }
        pieces.push(Piece {
            ends,
            origin: segment as u32,
        });
    }
    drop_repeats(&mut pieces, &mut report);
    Ok(MergedInput {
        points,
        pieces,
        report,
    })
}

/// The second half of [`clean`]: segments split at the points on them, crossings refused or
/// split.
///
/// # Errors
/// [`Error::CrossingSegments`], as [`clean`].
pub(crate) fn clean_segments(
    input: &Input,
    merged: MergedInput,
    options: CleanOptions,
) -> Result<(Input, CleanReport), Error> {
    let MergedInput {
        mut points,
        mut pieces,
        mut report,
    } = merged;
    // Built only when a crossing is split: the point, if any, at each position.
    let mut first: Option<HashMap<(u64, u64), u32>> = None;
    let mut first_round = 0;
    for round in 0.. {
        let mut grid = Grid::new(&points, &pieces);
        // The pieces are as the grid has them unless split here or at crossings before.
        if split_at_points(&points, &mut pieces, &grid, &mut report) || round > 0 {
            drop_repeats(&mut pieces, &mut report);
            grid = Grid::new(&points, &pieces);
        }
        let crossings = find_crossings(&points, &pieces, &grid);
        let Some(c) = crossings.first() else {
            break;
        };
        let [a, b] = c.pieces.map(|i| pieces[i].origin as usize);
        let (a, b, at) = (a.min(b), a.max(b), c.at.into());
        if !options.split_crossings {
            return Err(Error::CrossingSegments { a, b, at });
        }
        if round == 0 {
            first_round = crossings.len();
        } else if round == MAX_ROUNDS || crossings.len() > 2 * first_round + RUNAWAY_SLACK {
            return Err(Error::CrossingsUnsettled {
                a,
                b,
                at,
                rounds: round,
            });
        }
        let first = first.get_or_insert_with(|| {
            (points.iter().enumerate())
                .map(|(i, &p)| (key(p), i as u32))
                .collect()
        });
        split_crossings(&mut points, first, &mut pieces, &crossings, &mut report);
    }

    if points.len() >= u32::MAX as usize {
        return Err(Error::TooManyPoints(points.len()));
    }
    let segments = pieces
        .iter()
        .map(|p| Segment {
            ends: p.ends,
            marker: input.segments[p.origin as usize].marker,
        })
        .collect();
    report.segment_origin = pieces.iter().map(|p| p.origin).collect();
    let cleaned = Input {
        points,
        segments,
        holes: input.holes.clone(),
        regions: input.regions.clone(),
    };
    Ok((cleaned, report))
}

/// A position as a hash key: equal keys for equal coordinates (`-0.0` as `0.0`).
fn key(p: DVec2) -> (u64, u64) {
    ((p.x + 0.0).to_bits(), (p.y + 0.0).to_bits())
}

/// The input's points with those at one position merged into the first.
struct Merged {
    /// The distinct points, in first-occurrence order.
    points: Vec<DVec2>,
    /// For each input point, its distinct point.
    point_map: Vec<u32>,
    /// The first [`REPORT_EXAMPLES`] merged points, each with the input point it was merged
    /// into.
    examples: Vec<[usize; 2]>,
}

/// Merges the points at one position (`0.0` and `-0.0` alike) into the first, by a parallel
/// sort of the positions: the same result on any thread count.
fn merge_positions(input: &[DVec2]) -> Merged {
    let n = input.len();
    let first_at = first_of_equal_keys(n, |i| key(input[i]));
    let kept: Vec<u32> = (0..n as u32)
        .into_par_iter()
        .filter(|&i| first_at[i as usize] == i)
        .collect();
    let examples = (0..n)
        .filter(|&i| first_at[i] as usize != i)
        .take(REPORT_EXAMPLES)
        .map(|i| [i, first_at[i] as usize])
        .collect();
    let point_map = if kept.len() == n {
        first_at
    } else {
        let mut rank = vec![0; n];
        let slots = SharedSlots::new(&mut rank);
        kept.par_iter()
            .enumerate()
            .for_each(|(r, &i)| slots.store(i as usize, r as u32));
        first_at.par_iter().map(|&f| rank[f as usize]).collect()
    };
    Merged {
        points: kept.par_iter().map(|&i| input[i as usize]).collect(),
        point_map,
        examples,
    }
}

/// For each of `0..n`, the first index with the same key.
fn first_of_equal_keys<K>(n: usize, key: impl Fn(usize) -> K + Sync) -> Vec<u32>
where
    K: Ord + Copy + Send + Sync,
{
    let mut by_key: Vec<(K, u32)> = (0..n).into_par_iter().map(|i| (key(i), i as u32)).collect();
    by_key.par_sort_unstable();
    let starts = crate::par::run_starts(n, |j| by_key[j].0);
    let mut first = vec![0; n];
    let slots = SharedSlots::new(&mut first);
    starts.par_windows(2).for_each(|run| {
        let head = by_key[run[0]].1;
        for &(_, i) in &by_key[run[0]..run[1]] {
            slots.store(i as usize, head);
        }
    });
    first
}

/// Drops the pieces joining the same two points as an earlier piece, keeping the order.
fn drop_repeats(pieces: &mut Vec<Piece>, report: &mut CleanReport) {
    let first = first_of_equal_keys(pieces.len(), |i| {
        let [a, b] = pieces[i].ends;
        (a.min(b), a.max(b))
    });
    let repeats = (0..pieces.len()).filter(|&i| first[i] as usize != i);
    for i in repeats
        .clone()
        .take(REPORT_EXAMPLES.saturating_sub(report.repeated_examples.len()))
    {
        let earlier = pieces[first[i] as usize].origin as usize;
        report
            .repeated_examples
            .push([pieces[i].origin as usize, earlier]);
    }
    let dropped = repeats.count();
    if dropped > 0 {
        report.repeated_segments += dropped;
        let mut next = 0;
        pieces.retain(|_| {
            let kept = first[next] as usize == next;
            next += 1;
            kept
        });
    }
}

/// Lexicographic order of positions: along a line, the order of its points.
fn lex_less(a: DVec2, b: DVec2) -> bool {
    a.x < b.x || (a.x == b.x && a.y < b.y)
}

/// Whether `q`, on the line through `a` and `b`, lies strictly between them.
fn strictly_between(a: DVec2, b: DVec2, q: DVec2) -> bool {
    let (lo, hi) = if lex_less(a, b) { (a, b) } else { (b, a) };
    lex_less(lo, q) && lex_less(q, hi)
}

/// The pieces of `piece` split at `at` (points in its interior), in order from its first end.
fn split_piece(points: &[DVec2], piece: Piece, mut at: Vec<u32>, out: &mut Vec<Piece>) {
    let [a, b] = piece.ends.map(|e| points[e as usize]);
    let d = b - a;
    at.sort_by(|&u, &v| {
        let (tu, tv) = (
            (points[u as usize] - a).dot(d),
            (points[v as usize] - a).dot(d),
        );
        tu.total_cmp(&tv).then(u.cmp(&v))
    });
    at.dedup();
    let mut from = piece.ends[0];
    for v in at.into_iter().chain([piece.ends[1]]) {
        out.push(Piece {
            ends: [from, v],
            origin: piece.origin,
        });
        from = v;
    }
}

/// Splits every piece at the points lying exactly in its interior; whether any was.
fn split_at_points(
    points: &[DVec2],
    pieces: &mut Vec<Piece>,
    grid: &Grid,
    report: &mut CleanReport,
) -> bool {
    // (piece, point) for each point inside a piece, found cell by cell: a point lies in one
    // cell, and a piece is listed once in each of its cells, so each pair is found once.
    let mut found: Vec<(u32, u32)> = (0..grid.piece_cell_count())
        .into_par_iter()
        .flat_map_iter(|k| {
            let (here, near) = (grid.pieces_in(k), grid.points_in_cell_of(k));
            let mut out = Vec::new();
            for &i in here {
                let ends = pieces[i as usize].ends;
                let [a, b] = ends.map(|e| points[e as usize]);
                let (lo, hi) = (a.min(b), a.max(b));
                for &q in near {
                    let p = points[q as usize];
                    // Outside the piece's box, or one of its ends: not inside it, and cheaper
                    // to tell than by orientation.
                    let in_box = p.cmpge(lo).all() && p.cmple(hi).all();
                    if in_box
                        && !ends.contains(&q)
                        && orientation(a, b, p) == Orientation::On
                        && strictly_between(a, b, p)
                    {
                        out.push((i, q));
                    }
                }
            }
            out
        })
        .collect();
    if found.is_empty() {
        return false;
    }
    found.par_sort_unstable();
    let mut out = Vec::with_capacity(pieces.len() + found.len());
    let mut hits = found.chunk_by(|x, y| x.0 == y.0).peekable();
    for (i, &piece) in pieces.iter().enumerate() {
        let Some(on) = hits.next_if(|h| h[0].0 == i as u32) else {
            out.push(piece);
            continue;
        };
        for &(_, point) in on {
            report.vertex_splits += 1;
            if report.vertex_split_examples.len() < REPORT_EXAMPLES {
                report.vertex_split_examples.push(VertexSplit {
                    segment: piece.origin as usize,
                    point,
                });
            }
        }
        split_piece(points, piece, on.iter().map(|h| h.1).collect(), &mut out);
    }
    *pieces = out;
    true
}

/// Where the interiors of pieces `a = [p, q]` and `b = [r, s]` meet, if they do; pieces sharing
/// an end are skipped (after [`split_at_points`], they meet only there).
fn meet(points: &[DVec2], a: Piece, b: Piece) -> Option<DVec2> {
    if a.ends.iter().any(|e| b.ends.contains(e)) {
        return None;
    }
    let [p, q] = a.ends.map(|e| points[e as usize]);
    let [r, s] = b.ends.map(|e| points[e as usize]);
    let (o1, o2) = (orientation(p, q, r), orientation(p, q, s));
    if o1 == o2 && o1 != Orientation::On {
        return None;
    }
    let (o3, o4) = (orientation(r, s, p), orientation(r, s, q));
    if o3 == o4 && o3 != Orientation::On {
        return None;
    }
    if o1 == Orientation::On && o2 == Orientation::On {
        // On one line: they overlap where their intervals do.
        let (lo_a, hi_a) = if lex_less(p, q) { (p, q) } else { (q, p) };
        let (lo_b, hi_b) = if lex_less(r, s) { (r, s) } else { (s, r) };
        let lo = if lex_less(lo_a, lo_b) { lo_b } else { lo_a };
        let hi = if lex_less(hi_a, hi_b) { hi_a } else { hi_b };
        return lex_less(lo, hi).then_some(lo);
    }
    // An end on the other piece (which splitting at points leaves none of), or a proper crossing.
    for (o, e) in [(o1, r), (o2, s)] {
        if o == Orientation::On {
            return Some(e);
        }
    }
    for (o, e) in [(o3, p), (o4, q)] {
        if o == Orientation::On {
            return Some(e);
        }
    }
    let (d3, d4) = (orient_value(r, s, p), orient_value(r, s, q));
    let t = d3 / (d3 - d4);
    Some(p + (q - p) * t)
}

/// Every pair of pieces whose interiors meet, sorted by their input segments, then pieces.
fn find_crossings(points: &[DVec2], pieces: &[Piece], grid: &Grid) -> Vec<Crossing> {
    let mut found: Vec<Crossing> = (0..grid.piece_cell_count())
        .into_par_iter()
        .flat_map_iter(|cell| {
            let here = grid.pieces_in(cell);
            let mut out = Vec::new();
            for (k, &i) in here.iter().enumerate() {
                for &j in &here[k + 1..] {
                    let (i, j) = (i.min(j) as usize, i.max(j) as usize);
                    if let Some(at) = meet(points, pieces[i], pieces[j]) {
                        out.push(Crossing { pieces: [i, j], at });
                    }
                }
            }
            out
        })
        .collect();
    let order = |c: &Crossing| {
        let [a, b] = c.pieces.map(|i| pieces[i].origin);
        (a.min(b), a.max(b), c.pieces)
    };
    found.sort_by_key(order);
    found.dedup_by_key(|c| c.pieces);
    found
}

/// Splits each crossing pair at its rounded intersection point.
fn split_crossings(
    points: &mut Vec<DVec2>,
    first: &mut HashMap<(u64, u64), u32>,
    pieces: &mut Vec<Piece>,
    crossings: &[Crossing],
    report: &mut CleanReport,
) {
    let mut at: HashMap<usize, Vec<u32>> = HashMap::new();
    for c in crossings {
        let ends = c.pieces.map(|i| pieces[i].ends);
        let point = *first.entry(key(c.at)).or_insert_with(|| {
            points.push(c.at);
            (points.len() - 1) as u32
        });
        report.crossing_splits += 1;
        if report.crossing_examples.len() < REPORT_EXAMPLES {
            let [a, b] = c.pieces.map(|i| pieces[i].origin as usize);
            report.crossing_examples.push(CrossingSplit {
                a: a.min(b),
                b: a.max(b),
                point,
                at: c.at,
            });
        }
        for (i, e) in c.pieces.into_iter().zip(ends) {
            if !e.contains(&point) {
                at.entry(i).or_default().push(point);
            }
        }
    }
    let mut out = Vec::with_capacity(pieces.len() + 2 * crossings.len());
    for (i, &piece) in pieces.iter().enumerate() {
        match at.remove(&i) {
            Some(split) => split_piece(points, piece, split, &mut out),
            None => out.push(piece),
        }
    }
    *pieces = out;
}

#[cfg(test)]
mod tests;
