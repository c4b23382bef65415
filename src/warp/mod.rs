//! Warping a separated quadtree onto the points and triangulating its leaves by templates
//! (`beg-quadtree-meshing.md` §2.3–2.5).
//!
//! Each point moves the corner of its leaf nearest to it. In the block warp (a tree separated by
//! 5×5 blocks) the four leaves around that corner have no midpoints and are split by the max-min
//! diagonal: every angle in [22.5°, 112.5°]. In the compact warp (a tree separated by the 2×2
//! blocks around the corners, a third the size) they may carry midpoints on their sides away
//! from the corner, and each takes the best of a few swept candidates, some with a centre
//! vertex: every angle in [26.5°, 118.1°]. Every other leaf takes the template of its side
//! midpoints. All of it runs per leaf (or per point) in parallel, reading the leaves' cross
//! links only, and numbers vertices and triangles by prefix sums over the leaves in Morton
//! order, so the mesh does not depend on the thread count.

mod coarsen;
mod cut;
mod edges;
mod graph;
pub mod placement;
mod split;
mod templates;
mod vertices;

pub use coarsen::{COARSE_ANGLE_BOUNDS, Coarsened, NONOBTUSE_COARSE_BOUNDS, coarsen};
pub use cut::{leaves_below, leaves_in_domain};
pub use edges::{EdgePiece, EdgePieces, edge_pieces, leaf_at, square_box};
pub(crate) use graph::best_triangulation;
pub use graph::{
    Angles, EDGE_SNAP, GRAPH_ANGLE_BOUNDS, GraphLeaves, GraphTriangulation, SMOOTH_ABOVE_DEG,
    SMOOTH_BELOW_DEG, Smoothed, smooth_steiner_vertices, triangulate_graph,
};
pub use split::{NONOBTUSE_MAX_DEG, split};

use glam::DVec2;
use rayon::prelude::*;

use crate::balance::BalancedTree;
use crate::balance::upper_halves;
use crate::error::Error;
use crate::mesh::{
    AngleQuality, AngleTally, BoundaryEdge, BoundarySide, Domain, Mesh, NONE, StageTimes,
    angles_deg, corner_cosines,
};
use crate::morton::{GUARD_LEVELS, Grid, MortonKey, Side};
use crate::par::{GRAIN, SegmentWriter, chunk_offsets, collect_segments_by, exclusive_scan_u32_by};
use crate::predicates::{Orientation, orientation};
use templates::{
    Across, CENTRE, Kind, Part, RingSide, WARPED_CANDIDATES, template, uses_centre, warped_centre,
};
use vertices::{LeafGeometry, Numbering};

/// Vertex `v`'s lot in round `round` of a pass that moves or removes vertices in rounds: a
/// hash, so that no chain of neighbours waits on one another for long, and the same on any
/// thread count.
pub(crate) fn lot(v: u32, round: usize) -> u64 {
    // SplitMix64's finaliser.
    let mut z = (u64::from(v) | (round as u64) << 32).wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The angles every block-warped mesh keeps, in degrees: the max-min rule's proven range.
pub const ANGLE_BOUNDS: (f64, f64) = (22.5, 112.5);

/// The angles every compact-warped mesh keeps, in degrees. The sweep proves [26.5°, 118.1°]
/// for a point within half a leaf of its corner; the bounds leave room for a point a key's
/// rounding puts a hair past that.
pub const COMPACT_ANGLE_BOUNDS: (f64, f64) = (26.0, 120.0);

/// The mesh of a separated tree of the points `points` (input order), with `order[i]` the
/// input index of the `i`-th point in Morton order: the block warp of a
/// [`crate::balance::Separation::Block`] tree (`keys` `None`; every angle in [`ANGLE_BOUNDS`]),
/// or the compact warp of a [`crate::balance::Separation::Corner`] tree of the points' Morton
/// keys `keys` (every angle in [`COMPACT_ANGLE_BOUNDS`]).
///
/// # Errors
/// [`Error::TooLarge`] past 32-bit indices; [`Error::Unresolvable`] when a point's leaf is finer
/// than the grid resolves the points (see [`point_finer_than_grid`]) or f64 cannot place the
/// vertices near a point apart.
pub fn warp<K: MortonKey>(
    tree: &BalancedTree<K>,
    (order, keys): (&[u32], Option<&[K]>),
    grid: &Grid,
    points: &[DVec2],
    times: &mut StageTimes,
) -> Result<(Mesh, AngleQuality), Error> {
    let geometry = resolved_geometry(tree, (order, keys.is_some()), grid, points)?;
    let bounds = if keys.is_some() {
        COMPACT_ANGLE_BOUNDS
    } else {
        ANGLE_BOUNDS
    };
    let (numbering, vertices, vertex_input, moves, compact) =
        times.time("warp vertices", || {
            let moves = corner_moves(&geometry, order, points, keys);
            let compact = match keys {
                Some(_) => Some(compact_templates(&geometry, &moves, order, points)?),
                None => None,
            };
            let centred = |leaf: usize| {
                let kind = compact.as_ref().map_or(0, |c| c.kinds[leaf]);
                (kind != 0).then(|| uses_centre(kind & !MOVED))
            };
            let numbering = Numbering::new(&geometry, centred)?;
            let (mut vertices, mut vertex_input) = numbering.vertices(&geometry);
            place_moved(
                (&geometry, &numbering),
                (order, points),
                &moves,
                compact.as_ref().map_or(&[], |c| &c.centres[..]),
                (&mut vertices, &mut vertex_input),
            );
            Ok::<_, Error>((numbering, vertices, vertex_input, moves, compact))
        })?;
    let labels = |leaf: usize| numbering.labels(&geometry, leaf);
    let (kinds, moved_quality, offsets) = times.time("warp templates", || {
        let mut kinds = unmoved_templates(&geometry, order, points)?;
        let moved_quality = match compact {
            Some(CompactWarp {
                kinds: warped,
                quality,
                ..
            }) => {
                kinds
                    .par_iter_mut()
                    .zip(warped)
                    .filter(|(_, w)| *w != 0)
                    .for_each(|(k, w)| *k = w);
                quality
            }
            None => warped_templates(
                &geometry,
                &labels,
                &moves,
                (&vertices, &vertex_input),
                &mut kinds,
            )?,
        };
        let offsets = triangle_offsets(&kinds)?;
        Ok::<_, Error>((kinds, moved_quality, offsets))
    })?;
    let triangles = times.time("warp triangles", || {
        collect_per_leaf(&offsets, |leaf, out| {
            let labels = labels(leaf);
            for t in &template_of(kinds[leaf]).triangles {
                out.push(t.map(|label| labels[label as usize]));
            }
        })
    });
    // The numbering is only needed for labels; free it before the neighbours take their place.
    drop(numbering);
    let neighbours = times.time("warp neighbours", || {
        neighbours_of(&geometry, &kinds, &offsets)
    });
    let (boundary, quality) = times.time("warp boundary", || {
        let inexact = |leaf: usize| !geometry.template_accurate(leaf);
        let unmoved_inexact = |leaf: usize| kinds[leaf] & MOVED == 0 && inexact(leaf);
        let measured = measured_quality(&offsets, (&triangles, &vertices), unmoved_inexact);
        (
            boundary_edges(&geometry, &kinds, &triangles, &offsets),
            unmoved_quality(&kinds, inexact)
                .merge(moved_quality)
                .merge(measured),
        )
    });
    if !(quality.min >= bounds.0 - ROUNDING_SLACK_DEG
        && quality.max <= bounds.1 + ROUNDING_SLACK_DEG)
    {
        let bent = bent_leaf(&geometry, &offsets, (&triangles, &vertices), bounds);
        return Err(point_near(&geometry, bent, order, points));
    }
    let mesh = leaf_mesh(
        grid,
        (vertices, vertex_input),
        (triangles, neighbours),
        boundary,
    );
    Ok((mesh, quality))
}

/// The leaves' geometry, unless a point's leaf is finer than the grid resolves the points
/// ([`Error::Unresolvable`] naming it).
fn resolved_geometry<'a, K: MortonKey>(
    tree: &'a BalancedTree<K>,
    (order, corners): (&[u32], bool),
    grid: &'a Grid,
    points: &[DVec2],
) -> Result<LeafGeometry<'a, K>, Error> {
    if let Some(p) = point_finer_than_grid(tree, corners) {
        let index = order[p] as usize;
        return Err(unresolvable(points[index], index as u32));
    }
    Ok(LeafGeometry::new(tree, grid))
}

/// The mesh of the leaves' arrays on the grid's domain.
fn leaf_mesh(
    grid: &Grid,
    (vertices, vertex_input): (Vec<DVec2>, Vec<u32>),
    (triangles, neighbours): (Vec<[u32; 3]>, Vec<[u32; 3]>),
    boundary: Vec<BoundaryEdge>,
) -> Mesh {
    let (lo, hi) = grid.domain();
    Mesh {
        outline: None,
        vertices,
        vertex_input,
        triangles,
        neighbours,
        boundary,
        domain: Domain { lo, hi },
        ..Mesh::default()
    }
}

/// The triangles across each triangle's edges, leaf by leaf from the templates' tables.
fn neighbours_of<K: MortonKey>(
    geometry: &LeafGeometry<K>,
    kinds: &[u8],
    offsets: &[u32],
) -> Vec<[u32; 3]> {
    collect_per_leaf(offsets, |leaf, out| {
        for row in &template_of(kinds[leaf]).across {
            out.push(row.map(|a| match a {
                Across::Inside { triangle, .. } => offsets[leaf] + triangle as u32,
                Across::Boundary { side, part } => {
                    facing_triangle(geometry, kinds, offsets, leaf, side, part)
                }
            }));
        }
    })
}

/// The template of a leaf's code, whether or not a corner of the leaf moved.
fn template_of(kind: u8) -> &'static templates::Template {
    template(kind & !MOVED)
}

/// Where each leaf's triangles start, with the total appended; 32-bit, as triangle indices are.
fn triangle_offsets(kinds: &[u8]) -> Result<Vec<u32>, Error> {
    leaf_offsets(
        kinds.len(),
        |leaf| template_of(kinds[leaf]).triangles.len(),
        "triangles",
    )
}

/// Where each leaf's `size(leaf)` items start, with the total appended, in 32 bits as the mesh's
/// indices are.
///
/// # Errors
/// [`Error::TooLarge`] when the total reaches [`NONE`].
fn leaf_offsets<F>(leaves: usize, size: F, what: &'static str) -> Result<Vec<u32>, Error>
where
    F: Fn(usize) -> usize + Sync,
{
    exclusive_scan_u32_by(leaves, size).map_err(|count| Error::TooLarge { what, count })
}

/// The values of every leaf in turn, `fill(leaf, writer)` writing exactly the leaf's share as
/// `offsets` gives it (the start of each leaf's values, the total appended).
fn collect_per_leaf<T, F>(offsets: &[u32], fill: F) -> Vec<T>
where
    T: Send,
    F: Fn(usize, &mut SegmentWriter<T>) + Sync,
{
    let chunks = chunk_offsets(offsets.len() - 1, GRAIN);
    let starts: Vec<usize> = chunks.iter().map(|&leaf| offsets[leaf] as usize).collect();
    collect_segments_by(&starts, |c, out| {
        for leaf in chunks[c]..chunks[c + 1] {
            fill(leaf, out);
        }
    })
}

/// The finest point leaf level at which a grid of `K` keys resolves the points: below it a
/// point need not lie in its leaf. With `corners` (the compact warp) one level coarser: a
/// leaf's nearest corner needs the half of it the point lies in, one level finer.
pub fn finest_resolved_level<K: MortonKey>(corners: bool) -> u8 {
    (K::AXIS_BITS - GUARD_LEVELS) as u8 - u8::from(corners)
}

/// The Morton position of a point whose leaf is finer than the grid resolves the points
/// ([`finest_resolved_level`]), if any: the tree must then be built on the wide grid.
pub fn point_finer_than_grid<K: MortonKey>(tree: &BalancedTree<K>, corners: bool) -> Option<usize> {
    let finest = finest_resolved_level::<K>(corners);
    tree.point_leaf
        .par_iter()
        .position_first(|&leaf| tree.tree.leaves[leaf as usize].cell.level > finest)
}

/// The angles of the leaves without a moved corner, from their templates: such a leaf is a
/// square, so its angles are the template's. (The warped leaves' angles are measured as their
/// diagonals are chosen, and those of the leaves that f64 rounding bends too far from a square,
/// as [`LeafGeometry::template_accurate`] tells, by [`measured_quality`].)
fn unmoved_quality(kinds: &[u8], inexact: impl Fn(usize) -> bool + Sync) -> AngleQuality {
    let unmoved_per_kind = kinds
        .par_chunks(GRAIN)
        .enumerate()
        .fold(
            || [0u64; templates::KINDS],
            |mut counts, (c, chunk)| {
                let first = c * GRAIN;
                for (j, &k) in chunk.iter().enumerate() {
                    if k & MOVED == 0 && !inexact(first + j) {
                        counts[k as usize] += 1;
                    }
                }
                counts
            },
        )
        .reduce(
            || [0u64; templates::KINDS],
            |mut a, b| {
                a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
                a
            },
        );
    unmoved_per_kind
        .iter()
        .enumerate()
        .filter(|(_, count)| **count > 0)
        .map(|(code, &count)| templates::unit_angles(code as u8).repeated(count))
        .fold(AngleQuality::empty(), AngleQuality::merge)
}

/// The angles of the triangles of the leaves `measure` picks, measured.
fn measured_quality(
    offsets: &[u32],
    (triangles, vertices): (&[[u32; 3]], &[DVec2]),
    measure: impl Fn(usize) -> bool + Sync,
) -> AngleQuality {
    let leaves = offsets.len() - 1;
    // A tally per run of leaves: folding leaf by leaf would move the tally at each one.
    (0..leaves.div_ceil(GRAIN))
        .into_par_iter()
        .map(|run| {
            let mut tally = AngleTally::new();
            let from = run * GRAIN;
            for leaf in (from..leaves.min(from + GRAIN)).filter(|&l| measure(l)) {
                let range = offsets[leaf] as usize..offsets[leaf + 1] as usize;
                for t in &triangles[range] {
                    let [a, b, c] = t.map(|v| vertices[v as usize]);
                    tally.add_triangle(a, b, c);
                }
            }
            tally.quality()
        })
        .reduce(AngleQuality::empty, AngleQuality::merge)
}

/// A point's moved corner: its leaf and the corner's ring label there.
#[derive(Clone, Copy)]
struct Move {
    leaf: u32,
    corner: u8,
}

/// For every point, the corner of its leaf that moves onto it: the nearest one (ties to the
/// smallest `(y, x)`) for the block warp; for the compact warp, the one the tree was separated
/// by, from the point's key ([`upper_halves`]), which f64 may place a hair farther.
fn corner_moves<K: MortonKey>(
    geometry: &LeafGeometry<K>,
    order: &[u32],
    points: &[DVec2],
    keys: Option<&[K]>,
) -> Vec<Move> {
    (0..order.len())
        .into_par_iter()
        .map(|p| {
            let leaf = geometry.point_leaf[p];
            let (right, top) = match keys {
                Some(keys) => upper_halves(geometry.cell(leaf as usize), keys[p]),
                None => {
                    let x = points[order[p] as usize];
                    let (lo, hi) = geometry.rect(leaf as usize);
                    (x.x - lo.x > hi.x - x.x, x.y - lo.y > hi.y - x.y)
                }
            };
            let corner = match (right, top) {
                (false, false) => 0,
                (true, false) => 2,
                (true, true) => 4,
                (false, true) => 6,
            };
            Move { leaf, corner }
        })
        .collect()
}

/// Puts every moved corner's vertex on its point, with the exact coordinates, and each of
/// `centres` (a compact-warp leaf and where its centre goes) in place.
fn place_moved<K: MortonKey>(
    (geometry, numbering): (&LeafGeometry<K>, &Numbering),
    (order, points): (&[u32], &[DVec2]),
    moves: &[Move],
    centres: &[(u32, DVec2)],
    (vertices, vertex_input): (&mut [DVec2], &mut [u32]),
) {
    // Found in parallel, written in turn: every vertex is written once.
    let corners: Vec<u32> = moves
        .par_iter()
        .map(|m| numbering.labels(geometry, m.leaf as usize)[m.corner as usize])
        .collect();
    for (&vertex, &input) in corners.iter().zip(order) {
        vertices[vertex as usize] = points[input as usize];
        vertex_input[vertex as usize] = input;
    }
    let centre_vertices: Vec<u32> = centres
        .par_iter()
        .map(|&(leaf, _)| numbering.labels(geometry, leaf as usize)[CENTRE as usize])
        .collect();
    for (&vertex, &(_, position)) in centre_vertices.iter().zip(centres) {
        vertices[vertex as usize] = position;
    }
}

/// The compact warp's choices: the template of every leaf around a moved corner (`0`
/// elsewhere), the centres of those whose template uses one (by leaf), and the angles of
/// their triangles.
struct CompactWarp {
    kinds: Vec<u8>,
    centres: Vec<(u32, DVec2)>,
    quality: AngleQuality,
}

/// The compact warp's templates, chosen by [`choose_warped`].
///
/// # Errors
/// [`Error::Unresolvable`] naming the point when a leaf around it has a midpoint on a side at
/// the moved corner (the tree is not corner-separated) or no candidate f64 can orient.
fn compact_templates<K: MortonKey>(
    geometry: &LeafGeometry<K>,
    moves: &[Move],
    order: &[u32],
    points: &[DVec2],
) -> Result<CompactWarp, Error> {
    // One point's block, its centres appended to `centres`.
    let block = |p: usize, centres: &mut Vec<(u32, DVec2)>, tally: &mut AngleTally| {
        let m = moves[p];
        let x = points[order[p] as usize];
        let mut out: WarpedBlock = [(NONE, 0); 4];
        for (slot, (leaf, corner)) in out.iter_mut().zip(block_around(geometry, m)?) {
            if leaf == NONE {
                continue;
            }
            let ring = geometry.ring_positions(leaf as usize);
            let mask = geometry.midpoint_mask(leaf as usize);
            let (kind, centre) = choose_warped(&ring, mask, corner, x, tally)?;
            if uses_centre(kind.code()) {
                centres.push((leaf, centre));
            }
            *slot = (leaf, kind.code() | MOVED);
        }
        Some(out)
    };
    type Part = (Vec<Option<WarpedBlock>>, Vec<(u32, DVec2)>, AngleQuality);
    let parts: Vec<Part> = (0..moves.len())
        .into_par_iter()
        .chunks(GRAIN)
        .map(|chunk| {
            let (mut centres, mut tally) = (Vec::new(), AngleTally::new());
            let blocks = chunk
                .into_iter()
                .map(|p| block(p, &mut centres, &mut tally))
                .collect();
            (blocks, centres, tally.quality())
        })
        .collect();
    let blocks = || parts.iter().flat_map(|(blocks, ..)| blocks);
    if let Some(bad) = blocks().position(|b| b.is_none()) {
        let input = order[bad];
        return Err(unresolvable(points[input as usize], input));
    }
    let mut kinds = vec![0u8; geometry.leaves()];
    for &(leaf, kind) in blocks().flatten().flatten().filter(|(l, _)| *l != NONE) {
        kinds[leaf as usize] = kind;
    }
    Ok(CompactWarp {
        kinds,
        centres: parts.iter().flat_map(|(_, c, _)| c).copied().collect(),
        quality: parts
            .iter()
            .map(|(.., q)| *q)
            .fold(AngleQuality::empty(), AngleQuality::merge),
    })
}

/// Candidates whose smallest angle reaches 26.5° are equally good; the smaller largest angle
/// decides between them (the sweep's rule, which keeps the largest at 118.1°). As cosines:
/// the cosine of the smallest angle at most this.
const WARPED_MIN_TARGET_COS: f64 = 0.894_934_361_602_025; // cos 26.5°
/// No candidate with an angle above 120° (a cosine below this) is taken.
const WARPED_MAX_CAP_COS: f64 = -0.5;
/// Cosines this close count as equal, so that choices do not hang on f64 noise.
const WARPED_TIE_COS: f64 = 1e-12;
#[cfg(test)]
const WARPED_MIN_TARGET_DEG: f64 = 26.5;

/// The compact warp's template of a leaf whose ring (labels 0–7, as placed on the grid) has
/// split sides `mask` and corner `moved` on point `x`, with its angles: of
/// [`WARPED_CANDIDATES`] turned to the corner, those whose triangles f64 orients
/// counter-clockwise and whose largest angle is at most 120°, the one whose smallest angle is
/// largest up to 26.5°, then whose largest angle is smallest, then the first; and where its
/// centre goes if it uses one ([`warped_centre`]). `None` when a split side meets the moved
/// corner or no candidate qualifies. Candidates are compared by cosines; only the choice's
/// angles are measured, into `tally`.
pub(crate) fn choose_warped(
    ring: &[DVec2; 8],
    mask: u8,
    moved: u8,
    x: DVec2,
    tally: &mut AngleTally,
) -> Option<(Kind, DVec2)> {
    let turn = moved / 2;
    let side_bit = |frame_side: u8| 1u8 << ((frame_side + turn) % 4);
    if mask & (side_bit(0) | side_bit(3)) != 0 {
        return None;
    }
    let far = u8::from(mask & side_bit(1) != 0) | u8::from(mask & side_bit(2) != 0) << 1;
    let centre = warped_centre(ring, moved, x);
    let at = |label: u8| match label {
        CENTRE => centre,
        l if l == moved => x,
        l => ring[l as usize],
    };
    // The best so far: its kind, the cosine of its smallest angle (floored at the target's)
    // and of its largest.
    let mut best: Option<(Kind, f64, f64)> = None;
    let mut cosines = [[0.0; 3]; MAX_WARPED_TRIANGLES];
    let mut best_cosines = [[0.0; 3]; MAX_WARPED_TRIANGLES];
    for choice in 0..WARPED_CANDIDATES[far as usize].len() as u8 {
        let kind = Kind::Warped { turn, far, choice };
        // Measuring more angles only raises the score and lowers the largest angle's cosine,
        // so a candidate that already cannot be taken, or cannot beat the best, is dropped
        // there: the same choice, sooner. One that is measured in full beats the best.
        let hopeless =
            |of_min: f64, of_max: f64| of_max < WARPED_MAX_CAP_COS || !beats(best, of_min, of_max);
        let Some((of_min, of_max)) = oriented_cosines(kind, at, &mut cosines, hopeless) else {
            continue;
        };
        best = Some((kind, score(of_min), of_max));
        best_cosines = cosines;
    }
    let (kind, ..) = best?;
    // The choice's angles from the cosines measured already; `atan2` where the tally asks.
    for (tri, cosines) in template(kind.code()).triangles.iter().zip(best_cosines) {
        let [a, b, c] = tri.map(at);
        tally.add_measured(a, b, c, cosines);
    }
    Some((kind, centre))
}

/// Whether a candidate whose smallest and largest angles have cosines `of_min` and `of_max`
/// beats `best` (its kind, score and largest angle's cosine): a smaller score (the smallest
/// angle's cosine, floored at the target's), or an equal one with a smaller largest angle.
fn beats(best: Option<(Kind, f64, f64)>, of_min: f64, of_max: f64) -> bool {
    let score = score(of_min);
    best.is_none_or(|(_, best_score, best_max)| {
        score < best_score - WARPED_TIE_COS
            || (score <= best_score + WARPED_TIE_COS && of_max > best_max + WARPED_TIE_COS)
    })
}

/// A candidate's score, smaller is better: the cosine of its smallest angle, floored at the
/// target's (every smallest angle of at least 26.5° is as good).
fn score(of_min: f64) -> f64 {
    of_min.max(WARPED_MIN_TARGET_COS)
}

/// The most triangles of a [`WARPED_CANDIDATES`] entry.
const MAX_WARPED_TRIANGLES: usize = 6;

/// The cosines of the smallest and the largest angle of template `kind` with vertices
/// `at(label)`, or `None` if f64 does not orient every triangle counter-clockwise or if
/// `hopeless` says so of those cosines over the triangles measured so far; every angle's
/// cosine, by triangle and corner, in `cosines`.
fn oriented_cosines(
    kind: Kind,
    at: impl Fn(u8) -> DVec2,
    cosines: &mut [[f64; 3]; MAX_WARPED_TRIANGLES],
    hopeless: impl Fn(f64, f64) -> bool,
) -> Option<(f64, f64)> {
    let (mut of_min, mut of_max) = (f64::NEG_INFINITY, f64::INFINITY);
    for (tri, out) in template(kind.code()).triangles.iter().zip(cosines) {
        let [a, b, c] = tri.map(&at);
        if orientation(a, b, c) != Orientation::Left {
            return None;
        }
        *out = corner_cosines(a, b, c);
        of_min = out.iter().fold(of_min, |m, &cos| m.max(cos));
        of_max = out.iter().fold(of_max, |m, &cos| m.min(cos));
        if hopeless(of_min, of_max) {
            return None;
        }
    }
    Some((of_min, of_max))
}

/// Marks, in a leaf's template code, that one of its corners moved onto a point.
const MOVED: u8 = 0x80;
/// Marks a leaf f64 cannot triangulate.
const UNRESOLVED: u8 = 0xFF;

/// The template code of every leaf by its midpoints alone, or [`UNRESOLVED`].
fn unmoved_templates<K: MortonKey>(
    geometry: &LeafGeometry<K>,
    order: &[u32],
    points: &[DVec2],
) -> Result<Vec<u8>, Error> {
    let kinds: Vec<u8> = (0..geometry.leaves())
        .into_par_iter()
        .map(|leaf| {
            if geometry.resolvable(leaf) {
                Kind::for_midpoints(geometry.midpoint_mask(leaf)).code()
            } else {
                UNRESOLVED
            }
        })
        .collect();
    match kinds.par_iter().position_first(|&k| k == UNRESOLVED) {
        None => Ok(kinds),
        Some(leaf) => Err(point_near(geometry, leaf, order, points)),
    }
}

/// How far f64 rounding may take an angle past the bounds, as [`crate::mesh::validate`]
/// allows.
const ROUNDING_SLACK_DEG: f64 = 1e-9;

/// The first leaf with a triangle whose angles f64 rounding of the vertices bent past the
/// bounds (leaves so small that rounding moves their corners by a fair part of their side).
fn bent_leaf<K: MortonKey>(
    geometry: &LeafGeometry<K>,
    offsets: &[u32],
    (triangles, vertices): (&[[u32; 3]], &[DVec2]),
    bounds: (f64, f64),
) -> usize {
    let (lo, hi) = (bounds.0 - ROUNDING_SLACK_DEG, bounds.1 + ROUNDING_SLACK_DEG);
    (0..geometry.leaves())
        .into_par_iter()
        .position_first(|leaf| {
            let range = offsets[leaf] as usize..offsets[leaf + 1] as usize;
            triangles[range].iter().any(|t| {
                let [a, b, c] = t.map(|v| vertices[v as usize]);
                angles_deg(a, b, c).iter().any(|&x| !(lo..=hi).contains(&x))
            })
        })
        .unwrap_or(0)
}

/// The error for a `leaf` f64 cannot mesh: leaves that small only surround points that close,
/// so it names the point nearest the leaf in Morton order.
fn point_near<K: MortonKey>(
    geometry: &LeafGeometry<K>,
    leaf: usize,
    order: &[u32],
    points: &[DVec2],
) -> Error {
    let holding = |j: &usize| geometry.point(*j) != NONE;
    let after = (leaf..geometry.leaves()).find(holding);
    let before = (0..leaf).rev().find(holding);
    let p = after.or(before).map_or(0, |j| geometry.point(j) as usize);
    let input = order[p];
    unresolvable(points[input as usize], input)
}

/// The error for input point `input` at `point`.
pub(crate) fn unresolvable(point: DVec2, input: u32) -> Error {
    Error::Unresolvable {
        index: input as usize,
        x: point.x,
        y: point.y,
    }
}

/// The four leaves around a moved corner, each with its template code.
type WarpedBlock = [(u32, u8); 4];

/// The max-min diagonals of the four leaves around every moved corner, written into `kinds`
/// with [`MOVED`] set; returns the angles of those leaves' triangles.
fn warped_templates<K: MortonKey>(
    geometry: &LeafGeometry<K>,
    labels: &(impl Fn(usize) -> [u32; 9] + Sync),
    moves: &[Move],
    (vertices, vertex_input): (&[DVec2], &[u32]),
    kinds: &mut [u8],
) -> Result<AngleQuality, Error> {
    // A block's angles go straight into its chunk's summary: a block that fails fails the call.
    let warped_block = |m: Move, quality: &mut AngleQuality| {
        let block = block_around(geometry, m)?;
        let mut out: WarpedBlock = [(NONE, 0); 4];
        for (slot, (leaf, corner)) in out.iter_mut().zip(block) {
            if leaf == NONE {
                continue;
            }
            let labels = labels(leaf as usize);
            if geometry.midpoint_mask(leaf as usize) != 0 {
                return None;
            }
            let (kind, angles) = max_min_diagonal(&labels, corner as usize, vertices)?;
            *slot = (leaf, kind.code() | MOVED);
            *quality = quality.merge(angles);
        }
        Some(out)
    };
    // Per chunk of moves: the blocks, and the angles of their triangles.
    let parts: Vec<(Vec<Option<WarpedBlock>>, AngleQuality)> = moves
        .par_chunks(GRAIN)
        .map(|chunk| {
            let mut quality = AngleQuality::empty();
            let blocks = chunk
                .iter()
                .map(|&m| warped_block(m, &mut quality))
                .collect();
            (blocks, quality)
        })
        .collect();
    let blocks = || parts.iter().flat_map(|(blocks, _)| blocks);
    if let Some(bad) = blocks().position(|b| b.is_none()) {
        let leaf = moves[bad].leaf as usize;
        let vertex = labels(leaf)[moves[bad].corner as usize] as usize;
        return Err(unresolvable(vertices[vertex], vertex_input[vertex]));
    }
    for &(leaf, kind) in blocks()
        .flatten()
        .flatten()
        .filter(|(leaf, _)| *leaf != NONE)
    {
        kinds[leaf as usize] = kind;
    }
    let quality = parts.iter().map(|(_, q)| *q);
    Ok(quality.fold(AngleQuality::empty(), AngleQuality::merge))
}

/// The four leaves around a moved corner, each with the corner's ring label in it: the point's
/// leaf, its neighbours across the two sides at the corner, and the leaf diagonally across;
/// [`NONE`] for those beyond the domain's boundary when the corner lies on it. `None` unless
/// the others are single leaves of the same size (as separation guarantees).
fn block_around<K: MortonKey>(geometry: &LeafGeometry<K>, m: Move) -> Option<[(u32, u8); 4]> {
    let (horizontal, vertical) = match m.corner {
        0 => (Side::West, Side::South),
        2 => (Side::East, Side::South),
        4 => (Side::East, Side::North),
        _ => (Side::West, Side::North),
    };
    let same_size = |leaf: u32, side: Side| {
        if leaf == NONE {
            return Some(NONE);
        }
        match geometry.across(leaf as usize, side) {
            [NONE, _] => Some(NONE),
            [next, NONE] if geometry.level(next as usize) == geometry.level(leaf as usize) => {
                Some(next)
            }
            _ => None,
        }
    };
    let beside = same_size(m.leaf, horizontal)?;
    let below = same_size(m.leaf, vertical)?;
    let diagonal = same_size(beside, vertical)?;
    if beside != NONE && (below == NONE) != (diagonal == NONE) {
        return None;
    }
    // Mirroring across a vertical side swaps LL↔LR and UL↔UR; across a horizontal side LL↔UL
    // and LR↔UR.
    let mirror_x = |c: u8| [2, 0, 0, 0, 6, 0, 4][c as usize];
    let mirror_y = |c: u8| [6, 0, 4, 0, 2, 0, 0][c as usize];
    Some([
        (m.leaf, m.corner),
        (beside, mirror_x(m.corner)),
        (below, mirror_y(m.corner)),
        (diagonal, mirror_y(mirror_x(m.corner))),
    ])
}

/// The diagonal of a quadrilateral with one moved corner whose two triangles have the larger
/// smallest angle, with the angles of those triangles; on a tie the one through the moved
/// corner; never one that makes a triangle of area ≤ 0. `None` if neither works (f64 cannot
/// resolve the leaf).
fn max_min_diagonal(
    labels: &[u32; 9],
    moved: usize,
    vertices: &[DVec2],
) -> Option<(Kind, AngleQuality)> {
    let at = |label: u8| vertices[labels[label as usize] as usize];
    let angles = |kind: Kind| {
        let mut quality = AngleQuality::empty();
        for tri in &template(kind.code()).triangles {
            let [a, b, c] = tri.map(at);
            if orientation(a, b, c) != Orientation::Left {
                return None;
            }
            angles_deg(a, b, c)
                .into_iter()
                .for_each(|angle| quality.add(angle, 1));
        }
        Some((kind, quality))
    };
    let through = if moved.is_multiple_of(4) {
        Kind::DiagonalUp
    } else {
        Kind::DiagonalDown
    };
    let other = if through == Kind::DiagonalUp {
        Kind::DiagonalDown
    } else {
        Kind::DiagonalUp
    };
    match (angles(through), angles(other)) {
        (Some(a), Some(b)) => Some(if b.1.min > a.1.min { b } else { a }),
        (a, b) => a.or(b),
    }
}

/// The link side of a ring side.
fn link_side(side: RingSide) -> Side {
    match side {
        RingSide::South => Side::South,
        RingSide::East => Side::East,
        RingSide::North => Side::North,
        RingSide::West => Side::West,
    }
}

/// The triangle across boundary segment `(side, part)` of `leaf`, or [`NONE`] on the domain's
/// boundary.
fn facing_triangle<K: MortonKey>(
    geometry: &LeafGeometry<K>,
    kinds: &[u8],
    offsets: &[u32],
    leaf: usize,
    side: RingSide,
    part: Part,
) -> u32 {
    let [first, second] = geometry.across(leaf, link_side(side));
    if first == NONE {
        return NONE;
    }
    let (other, other_part) = if second != NONE {
        // Two smaller leaves: each faces us with its whole side.
        let other = if part == Part::Low { first } else { second };
        (other as usize, Part::Full)
    } else if geometry.level(first as usize) >= geometry.level(leaf) {
        // A leaf of our size faces us with the same parts: the whole side, or, where a point's
        // lines meet the side (see [`split`]), the same halves.
        (first as usize, part)
    } else {
        // A larger leaf: we face the half of its side we lie along.
        let low = geometry.starts_together(leaf, first as usize, link_side(side));
        (first as usize, if low { Part::Low } else { Part::High })
    };
    let (triangle, _) =
        template_of(kinds[other]).facing[side.opposite() as usize][other_part as usize];
    offsets[other] + triangle as u32
}

/// The segments of a leaf's `side` in ring order: the whole side, or, where a point's lines
/// meet a side on the domain's boundary (see [`split`]), its two halves.
fn boundary_parts(kind: u8, side: RingSide) -> impl Iterator<Item = Part> {
    let halved = templates::midpoint_mask_of(kind & !MOVED) & (1 << side as u8) != 0;
    let increasing = matches!(side, RingSide::South | RingSide::East);
    let parts = match (halved, increasing) {
        (false, _) => [Some(Part::Full), None],
        (true, true) => [Some(Part::Low), Some(Part::High)],
        (true, false) => [Some(Part::High), Some(Part::Low)],
    };
    parts.into_iter().flatten()
}

/// The triangle edges on the root's sides, counter-clockwise, leaf by leaf in Morton order.
fn boundary_edges<K: MortonKey>(
    geometry: &LeafGeometry<K>,
    kinds: &[u8],
    triangles: &[[u32; 3]],
    offsets: &[u32],
) -> Vec<BoundaryEdge> {
    (0..geometry.leaves())
        .into_par_iter()
        .flat_map_iter(|leaf| {
            RingSide::ALL
                .into_iter()
                .filter(move |&side| geometry.across(leaf, link_side(side))[0] == NONE)
                .flat_map(move |side| {
                    boundary_parts(kinds[leaf], side).map(move |part| (side, part))
                })
                .map(move |(side, part)| {
                    let (t, corner) = template_of(kinds[leaf]).facing[side as usize][part as usize];
                    let tri = triangles[offsets[leaf] as usize + t as usize];
                    let c = corner as usize;
                    BoundaryEdge {
                        vertices: [tri[(c + 1) % 3], tri[(c + 2) % 3]],
                        marker: match side {
                            RingSide::South => BoundarySide::Bottom,
                            RingSide::East => BoundarySide::Right,
                            RingSide::North => BoundarySide::Top,
                            RingSide::West => BoundarySide::Left,
                        }
                        .marker(),
                    }
                })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng as _, SeedableRng};
    use rand_xoshiro::Xoshiro256PlusPlus;

    /// The unit square's ring: corners and side midpoints, labels 0–7.
    fn unit_ring() -> [DVec2; 8] {
        std::array::from_fn(|label| templates::unit_position(label as u8))
    }

    /// The smallest and largest angle [`choose_warped`] gives over every offset of the point
    /// from the moved corner on a `steps`×`steps` grid spanning `reach` each way (boundary lines
    /// included), for every corner and every set of midpoints on the sides away from it.
    fn sweep(steps: u32, reach: f64) -> (f64, f64) {
        sweep_stretched(steps, reach, DVec2::ONE)
    }

    /// [`sweep`] on a leaf stretched by `stretch` along each axis (offsets stretched with it).
    fn sweep_stretched(steps: u32, reach: f64, stretch: DVec2) -> (f64, f64) {
        let ring = unit_ring().map(|p| p * stretch);
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for moved in [0u8, 2, 4, 6] {
            let turn = moved / 2;
            let far = [1u8 << ((turn + 1) % 4), 1 << ((turn + 2) % 4)];
            for mask in [0, far[0], far[1], far[0] | far[1]] {
                for i in 0..=steps {
                    for j in 0..=steps {
                        let step = |k: u32| reach * (2.0 * k as f64 / steps as f64 - 1.0);
                        let x = ring[moved as usize] + DVec2::new(step(i), step(j)) * stretch;
                        let mut tally = AngleTally::new();
                        choose_warped(&ring, mask, moved, x, &mut tally)
                            .unwrap_or_else(|| panic!("corner {moved}, mask {mask}, at {x}"));
                        let q = tally.quality();
                        lo = lo.min(q.min);
                        hi = hi.max(q.max);
                    }
                }
            }
        }
        (lo, hi)
    }

    #[test]
    fn the_sweep_bounds_every_warped_leaf() {
        // Every leaf around a moved corner, whatever its far midpoints, with the point anywhere
        // within half a leaf of the corner (the nearest corner's range): [26.5°, 118.1°], and
        // the sweep does reach both ends.
        let (lo, hi) = sweep(240, 0.5);
        assert!(lo >= WARPED_MIN_TARGET_DEG - 1e-9, "smallest angle {lo}");
        assert!(hi <= 118.1, "largest angle {hi}");
        assert!(
            lo < WARPED_MIN_TARGET_DEG + 0.1 && hi > 118.0,
            "[{lo}, {hi}]"
        );
        // A key's rounding may put the point a hair past half a leaf: the mode's bounds hold
        // well beyond that.
        let (lo, hi) = sweep(60, 0.5 + 1.0 / 1024.0);
        assert!(
            lo >= COMPACT_ANGLE_BOUNDS.0 && hi <= COMPACT_ANGLE_BOUNDS.1,
            "[{lo}, {hi}]"
        );
    }

    #[test]
    fn the_sweep_bounds_leaves_of_nearly_square_cells() {
        // A rectangle cut into cells up to CELL_ANISOTROPY from square: its leaves are that
        // much wider than tall or taller than wide, and the mode's bounds still hold, key
        // rounding included, around moved corners and in the plain templates.
        let a = crate::morton::CELL_ANISOTROPY;
        let (mut low, mut high) = (f64::INFINITY, f64::NEG_INFINITY);
        for stretch in [
            (1.0 + a, 1.0),
            (1.0, 1.0 + a),
            (1.0 - a, 1.0),
            (1.0, 1.0 - a),
        ] {
            let stretch = DVec2::from(stretch);
            let (lo, hi) = sweep_stretched(80, 0.5 + 1.0 / 1024.0, stretch);
            (low, high) = (low.min(lo), high.max(hi));
            for code in 0..templates::KINDS as u8 {
                for tri in &template(code).triangles {
                    let [a, b, c] = tri.map(|l| templates::unit_position(l) * stretch);
                    for angle in crate::mesh::angles_deg(a, b, c) {
                        (low, high) = (low.min(angle), high.max(angle));
                    }
                }
            }
        }
        assert!(
            low >= COMPACT_ANGLE_BOUNDS.0 && high <= COMPACT_ANGLE_BOUNDS.1,
            "[{low}, {high}]"
        );
        // Twice as far from square, the warped leaves' bound fails: the figure is not slack.
        let (lo, _) = sweep_stretched(80, 0.5 + 1.0 / 1024.0, DVec2::new(1.0 + 2.0 * a, 1.0));
        assert!(lo < COMPACT_ANGLE_BOUNDS.0, "{lo}");
    }

    #[test]
    fn a_midpoint_at_the_moved_corner_is_refused() {
        let ring = unit_ring();
        for moved in [0u8, 2, 4, 6] {
            let turn = moved / 2;
            for near in [turn, (turn + 3) % 4] {
                let x = ring[moved as usize] + DVec2::splat(0.1);
                let mut tally = AngleTally::new();
                assert!(choose_warped(&ring, 1 << near, moved, x, &mut tally).is_none());
            }
        }
    }

    /// The candidate [`choose_warped`] must take: every candidate measured in full, then
    /// compared by [`beats`].
    fn chosen_by_measuring_all(ring: &[DVec2; 8], mask: u8, moved: u8, x: DVec2) -> Option<Kind> {
        let turn = moved / 2;
        let far = u8::from(mask & 1 << ((turn + 1) % 4) != 0)
            | u8::from(mask & 1 << ((turn + 2) % 4) != 0) << 1;
        let centre = warped_centre(ring, moved, x);
        let at = |label: u8| match label {
            CENTRE => centre,
            l if l == moved => x,
            l => ring[l as usize],
        };
        let mut cosines = [[0.0; 3]; MAX_WARPED_TRIANGLES];
        let mut best: Option<(Kind, f64, f64)> = None;
        for choice in 0..WARPED_CANDIDATES[far as usize].len() as u8 {
            let kind = Kind::Warped { turn, far, choice };
            let Some((of_min, of_max)) = oriented_cosines(kind, at, &mut cosines, |_, _| false)
            else {
                continue;
            };
            if of_max >= WARPED_MAX_CAP_COS && beats(best, of_min, of_max) {
                best = Some((kind, score(of_min), of_max));
            }
        }
        best.map(|(kind, ..)| kind)
    }

    #[test]
    fn dropping_hopeless_candidates_early_keeps_every_choice() {
        let ring = unit_ring();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
        let mut offsets: Vec<DVec2> = (0..=16)
            .flat_map(|i| (0..=16).map(move |j| DVec2::new(i as f64, j as f64) / 32.0 - 0.25))
            .collect();
        offsets.extend((0..4000).map(|_| DVec2::new(rng.random(), rng.random()) - 0.5));
        let mut taken = [0usize; 4];
        for moved in [0u8, 2, 4, 6] {
            let turn = moved / 2;
            let far = [1u8 << ((turn + 1) % 4), 1 << ((turn + 2) % 4)];
            for mask in [0, far[0], far[1], far[0] | far[1]] {
                for &offset in &offsets {
                    let x = ring[moved as usize] + offset;
                    let mut tally = AngleTally::new();
                    let got = choose_warped(&ring, mask, moved, x, &mut tally).map(|(k, _)| k);
                    let want = chosen_by_measuring_all(&ring, mask, moved, x);
                    assert_eq!(got, want, "corner {moved}, mask {mask}, at {x}");
                    if let Some(Kind::Warped { choice, .. }) = got {
                        taken[choice as usize] += 1;
                    }
                }
            }
        }
        // The first three candidates each win somewhere, so later ones were dropped early
        // against a best of every rank.
        assert!(
            taken[..3].iter().all(|&n| n > 0),
            "choices taken: {taken:?}"
        );
    }

    /// The smallest and largest angle of the 2×2 block around a corner at the origin moved to
    /// `x`, each of the four unit leaves split by the max-min rule.
    fn block_angles(x: DVec2) -> (f64, f64) {
        // Vertices: 0 = the moved corner, then the block's boundary grid points.
        let grid = |i: i32, j: i32| DVec2::new(i as f64, j as f64);
        let mut vertices = vec![x];
        let mut index = |p: DVec2| {
            vertices.iter().position(|&v| v == p).unwrap_or_else(|| {
                vertices.push(p);
                vertices.len() - 1
            }) as u32
        };
        // Each leaf by its lower-left grid corner, and which of its corners is the moved one.
        let leaves = [((0, 0), 0), ((-1, 0), 2), ((-1, -1), 4), ((0, -1), 6)];
        let mut quads = Vec::new();
        for ((i, j), moved) in leaves {
            let corners = [
                grid(i, j),
                grid(i + 1, j),
                grid(i + 1, j + 1),
                grid(i, j + 1),
            ];
            let mut labels = [NONE; 9];
            for (k, c) in corners.into_iter().enumerate() {
                labels[2 * k] = if 2 * k == moved { 0 } else { index(c) };
            }
            quads.push((labels, moved));
        }
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for (labels, moved) in quads {
            let (kind, reported) =
                max_min_diagonal(&labels, moved, &vertices).expect("a valid diagonal");
            let mut measured = AngleQuality::empty();
            for t in &template(kind.code()).triangles {
                let [a, b, c] = t.map(|l| vertices[labels[l as usize] as usize]);
                for angle in angles_deg(a, b, c) {
                    measured.add(angle, 1);
                }
            }
            // The angles reported with the diagonal are those of its triangles.
            assert_eq!(reported, measured);
            lo = lo.min(measured.min);
            hi = hi.max(measured.max);
        }
        (lo, hi)
    }

    #[test]
    fn max_min_rule_keeps_angles_in_range_for_every_offset() {
        let steps = 200;
        for i in 0..=steps {
            for j in 0..=steps {
                let x = DVec2::new(i as f64, j as f64) * (0.5 / steps as f64);
                let (lo, hi) = block_angles(x);
                assert!(lo >= ANGLE_BOUNDS.0 - 1e-9, "offset {x}: min {lo}");
                assert!(hi <= ANGLE_BOUNDS.1 + 1e-9, "offset {x}: max {hi}");
            }
        }
    }

    /// The largest angle of the block when each leaf takes the diagonal that minimizes its
    /// largest angle (never a degenerate one).
    fn best_largest_angle(x: DVec2) -> f64 {
        let grid = |i: i32, j: i32| DVec2::new(i as f64, j as f64);
        let leaves = [((0, 0), 0), ((-1, 0), 1), ((-1, -1), 2), ((0, -1), 3)];
        let mut worst: f64 = 0.0;
        for ((i, j), moved) in leaves {
            let mut corners = [
                grid(i, j),
                grid(i + 1, j),
                grid(i + 1, j + 1),
                grid(i, j + 1),
            ];
            corners[moved] = x;
            let largest = |tris: [[usize; 3]; 2]| {
                let mut hi: f64 = 0.0;
                for t in tris {
                    let [a, b, c] = t.map(|k| corners[k]);
                    if orientation(a, b, c) != Orientation::Left {
                        return f64::INFINITY;
                    }
                    hi = angles_deg(a, b, c).into_iter().fold(hi, f64::max);
                }
                hi
            };
            let up = largest([[0, 1, 2], [0, 2, 3]]);
            let down = largest([[0, 1, 3], [1, 2, 3]]);
            worst = worst.max(up.min(down));
        }
        worst
    }

    #[test]
    fn no_diagonal_choice_makes_warped_blocks_nonobtuse() {
        let steps = 200;
        let worst = (0..=steps)
            .flat_map(|i| (0..=steps).map(move |j| (i, j)))
            .map(|(i, j)| best_largest_angle(DVec2::new(i as f64, j as f64) * (0.5 / steps as f64)))
            .fold(0.0, f64::max);
        // The figure the documentation states for why `--nonobtuse` splits leaves instead.
        assert!((worst - 102.13).abs() < 0.01, "{worst}");
    }

    #[test]
    fn worst_offset_reaches_the_bounds_exactly() {
        // The worst case of the max-min rule, found by hand: ((√2 − 1)/2, 1/2).
        let (lo, hi) = block_angles(DVec2::new((2f64.sqrt() - 1.0) / 2.0, 0.5));
        assert!((lo - 22.5).abs() < 1e-9, "{lo}");
        assert!((hi - 112.5).abs() < 1e-9, "{hi}");
        // An unmoved corner gives the plain squares' right triangles.
        assert_eq!(block_angles(DVec2::ZERO), (45.0, 90.0));
    }
}
