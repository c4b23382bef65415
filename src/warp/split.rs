//! Nonobtuse meshes of the well-separated tree (`beg-quadtree-meshing.md` §3): no corner moves.
//! Instead each point splits its leaf by the horizontal and vertical lines through it into up to
//! four rectangles, each cut by its diagonal through the point, and the lines' feet on the
//! leaf's sides become single midpoints of the four neighbours, which join them to their far
//! corners. A point on a side of its leaf is such a midpoint of the two leaves the side
//! divides; one on a corner takes the corner's place. Every other leaf keeps its template.
//!
//! Every triangle is then nonobtuse for any place of the point: the rectangles' halves have
//! their right angle at a foot or a corner, a single midpoint anywhere on a side makes two right
//! triangles and one whose angles are all below 90°, and the centre stars of the templates are
//! right-angled at the midpoints. No angle is bounded below: a point near a grid line of its
//! leaf makes a thin strip. The separation rule (a 5×5 block of empty same-size leaves around
//! every point) keeps the four neighbours the same size as the point's leaf, free of midpoints,
//! and reached by no other point's lines, so the feet never need a second split.

use glam::DVec2;
use rayon::prelude::*;

use super::templates::{CENTRE, Kind, RingSide};
use super::vertices::{LeafGeometry, Numbering};
use super::{
    MOVED, UNRESOLVED, boundary_edges, collect_per_leaf, leaf_mesh, leaf_offsets, link_side,
    neighbours_of, point_near, resolved_geometry, template_of, triangle_offsets, unmoved_quality,
    unmoved_templates,
};
use crate::balance::BalancedTree;
use crate::error::Error;
use crate::mesh::{
    AngleQuality, AngleTally, Domain, Mesh, NONE, StageTimes, angles_deg, largest_coordinate,
    obtuse_beyond, rounding_allowance_deg,
};
use crate::morton::{Grid, MortonKey};
use crate::par::GRAIN;
use crate::predicates::{Orientation, orientation};

/// The largest angle of a nonobtuse mesh, in degrees.
pub const NONOBTUSE_MAX_DEG: f64 = 90.0;

/// How close to a side of its leaf, relatively, a point counts as on it (see [`Place::of`]):
/// 2^-40, so that the angles this bends stay within the check's 1e-9° slack.
const SNAP: f64 = 1.0 / (1u64 << 40) as f64;

/// Where a point lies in its leaf, by f64 comparison with the leaf's corners.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Place {
    /// On the corner with this ring label.
    Corner(u8),
    /// On this side, between its corners.
    Side(RingSide),
    /// Strictly inside.
    Inside,
}

impl Place {
    /// Where `x` lies in the leaf `(lo, hi)`. A point within [`SNAP`] of a side, relative to its
    /// distances from that side's ends, counts as on it, and one within [`SNAP`] of the leaf's
    /// side from a corner in both directions as on the corner: a strip that thin would bend no
    /// angle by more than [`SNAP`] radians if the point were on the line, and its own
    /// triangles' areas could fall below what f64 multiplies exactly.
    fn of(x: DVec2, (lo, hi): (DVec2, DVec2)) -> Place {
        // Distances to the four sides; negative where f64 put the point just outside.
        let (west, east, south, north) = (x.x - lo.x, hi.x - x.x, x.y - lo.y, hi.y - x.y);
        let (width, height) = (hi.x - lo.x, hi.y - lo.y);
        if west.min(east) <= SNAP * width && south.min(north) <= SNAP * height {
            return Place::Corner(match (east < west, north < south) {
                (false, false) => 0,
                (true, false) => 2,
                (true, true) => 4,
                (false, true) => 6,
            });
        }
        let on = |d: f64, end: f64, other_end: f64| d <= SNAP * end.min(other_end);
        if on(west, south, north) {
            Place::Side(RingSide::West)
        } else if on(east, south, north) {
            Place::Side(RingSide::East)
        } else if on(south, west, east) {
            Place::Side(RingSide::South)
        } else if on(north, west, east) {
            Place::Side(RingSide::North)
        } else {
            Place::Inside
        }
    }

    /// The vertices the point adds: itself, and inside its leaf the four feet, in ring order.
    fn added(self) -> usize {
        match self {
            Place::Corner(_) => 0,
            Place::Side(_) => 1,
            Place::Inside => 5,
        }
    }

    /// Whether the point's lines, or the point itself, meet its leaf's `side`.
    fn meets(self, side: RingSide) -> bool {
        match self {
            Place::Corner(_) => false,
            Place::Side(s) => s == side,
            Place::Inside => true,
        }
    }
}

/// The ring label of a side's midpoint.
fn midpoint_label(side: RingSide) -> u8 {
    2 * side as u8 + 1
}

/// The points' places and the first vertex each adds (numbered after the grid's vertices).
struct Splits {
    places: Vec<Place>,
    first: Vec<u32>,
}

impl Splits {
    /// The vertex on `side` of the leaf of point `p` (the foot there, or the point itself on a
    /// side), which must meet it.
    fn on_side(&self, p: usize, side: RingSide) -> u32 {
        match self.places[p] {
            Place::Inside => self.first[p] + 1 + side as u32,
            _ => self.first[p],
        }
    }
}

/// What the points make of one leaf: its template code and the ring labels it takes from them.
struct LeafSplit {
    code: u8,
    labels: [(u8, u32); 5],
    count: usize,
}

impl LeafSplit {
    fn unchanged(code: u8) -> LeafSplit {
        LeafSplit {
            code,
            labels: [(0, NONE); 5],
            count: 0,
        }
    }

    fn with(mut self, label: u8, vertex: u32) -> LeafSplit {
        self.labels[self.count] = (label, vertex);
        self.count += 1;
        self
    }

    fn apply(&self, labels: &mut [u32; 9]) {
        for &(label, vertex) in &self.labels[..self.count] {
            labels[label as usize] = vertex;
        }
    }
}

/// The neighbour across `side` of `leaf` if it is a single leaf of the same size, [`NONE`] on
/// the domain's boundary, `None` otherwise.
fn same_size_across<K: MortonKey>(
    geometry: &LeafGeometry<K>,
    leaf: usize,
    side: RingSide,
) -> Option<u32> {
    match geometry.across(leaf, link_side(side)) {
        [NONE, _] => Some(NONE),
        [next, NONE] if geometry.level(next as usize) == geometry.level(leaf) => Some(next),
        _ => None,
    }
}

/// The template and labels of `leaf` (whose template by its midpoints is `code`), or `None`
/// where the tree is not separated enough for the points' lines: a point's leaf or a leaf its
/// lines reach has midpoints, the leaf across a met side is not one of the same size, or two
/// points' lines reach one leaf.
fn leaf_split<K: MortonKey>(
    geometry: &LeafGeometry<K>,
    splits: &Splits,
    leaf: usize,
    code: u8,
) -> Option<LeafSplit> {
    let own = geometry.point(leaf);
    if own != NONE {
        let p = own as usize;
        let place = splits.places[p];
        for side in RingSide::ALL.into_iter().filter(|&s| place.meets(s)) {
            let next = same_size_across(geometry, leaf, side)?;
            if next != NONE
                && (geometry.midpoint_mask(next as usize) != 0
                    || geometry.point(next as usize) != NONE)
            {
                return None;
            }
        }
        // A point on a corner changes no template; any other replaces its leaf's.
        if !matches!(place, Place::Corner(_)) && geometry.midpoint_mask(leaf) != 0 {
            return None;
        }
        return Some(match place {
            Place::Corner(_) => LeafSplit::unchanged(code),
            Place::Side(side) => LeafSplit::unchanged(Kind::OneMidpoint(side).code())
                .with(midpoint_label(side), splits.first[p]),
            Place::Inside => RingSide::ALL.into_iter().fold(
                LeafSplit::unchanged(Kind::Star(0b1111).code()).with(CENTRE, splits.first[p]),
                |split, side| split.with(midpoint_label(side), splits.on_side(p, side)),
            ),
        });
    }
    // A neighbour's point whose lines meet the side it shares with us.
    let mut reached: Option<(RingSide, u32)> = None;
    for side in RingSide::ALL {
        let Some(next) = same_size_across(geometry, leaf, side) else {
            continue;
        };
        if next == NONE || geometry.point(next as usize) == NONE {
            continue;
        }
        let p = geometry.point(next as usize) as usize;
        if splits.places[p].meets(side.opposite()) {
            if reached.is_some() || geometry.midpoint_mask(leaf) != 0 {
                return None;
            }
            reached = Some((side, splits.on_side(p, side.opposite())));
        }
    }
    Some(match reached {
        None => LeafSplit::unchanged(code),
        Some((side, vertex)) => {
            LeafSplit::unchanged(Kind::OneMidpoint(side).code()).with(midpoint_label(side), vertex)
        }
    })
}

/// The nonobtuse mesh of a well-separated tree (see [`crate::balance::separate`]) of the
/// points `points` (input order), with `order[i]` the input index of the `i`-th point in Morton
/// order: every angle at most [`NONOBTUSE_MAX_DEG`].
///
/// # Errors
/// As [`super::warp`]: [`Error::TooLarge`] past 32-bit indices, [`Error::Unresolvable`] when a
/// point's leaf is finer than the grid resolves the points or f64 cannot keep a right angle
/// near a point.
pub fn split<K: MortonKey>(
    tree: &BalancedTree<K>,
    order: &[u32],
    grid: &Grid,
    points: &[DVec2],
    times: &mut StageTimes,
) -> Result<(Mesh, AngleQuality), Error> {
    let geometry = resolved_geometry(tree, (order, false), grid, points)?;
    let point_at = |p: usize| points[order[p] as usize];
    let (numbering, vertices, vertex_input, splits) = times.time("split vertices", || {
        let numbering = Numbering::new(&geometry, |_| None)?;
        let (mut vertices, mut vertex_input) = numbering.vertices(&geometry);
        let places: Vec<Place> = (0..order.len())
            .into_par_iter()
            .map(|p| Place::of(point_at(p), geometry.rect(geometry.point_leaf[p] as usize)))
            .collect();
        let added = leaf_offsets(places.len(), |p| places[p].added(), "vertices")?;
        let base = vertices.len();
        let total = base + added[places.len()] as usize;
        if total >= NONE as usize {
            return Err(Error::TooLarge {
                what: "vertices",
                count: total,
            });
        }
        let first = added.par_iter().map(|&a| base as u32 + a).collect();
        let splits = Splits { places, first };
        take_corners(
            &geometry,
            &numbering,
            &splits,
            order,
            points,
            (&mut vertices, &mut vertex_input),
        );
        add_vertices(
            &geometry,
            &splits,
            &added,
            order,
            points,
            (&mut vertices, &mut vertex_input),
        );
        Ok::<_, Error>((numbering, vertices, vertex_input, splits))
    })?;
    let (kinds, offsets) = times.time("split templates", || {
        let mut kinds = unmoved_templates(&geometry, order, points)?;
        // A leaf the points change, or that holds one, is marked as a warped one is: its
        // angles are measured and its triangles checked.
        kinds.par_iter_mut().enumerate().for_each(|(leaf, code)| {
            let holds = geometry.point(leaf) != NONE;
            *code = match leaf_split(&geometry, &splits, leaf, *code) {
                None => UNRESOLVED,
                Some(split) if split.count > 0 || holds => split.code | MOVED,
                Some(split) => split.code,
            }
        });
        if let Some(leaf) = kinds.par_iter().position_first(|&k| k == UNRESOLVED) {
            return Err(point_near(&geometry, leaf, order, points));
        }
        let offsets = triangle_offsets(&kinds)?;
        Ok((kinds, offsets))
    })?;
    let triangles = times.time("split triangles", || {
        collect_per_leaf(&offsets, |leaf, out| {
            let mut labels = numbering.labels(&geometry, leaf);
            // Only the leaves the points split take labels from them.
            if kinds[leaf] & MOVED != 0
                && let Some(split) = leaf_split(&geometry, &splits, leaf, kinds[leaf] & !MOVED)
            {
                split.apply(&mut labels);
            }
            for t in &template_of(kinds[leaf]).triangles {
                out.push(t.map(|label| labels[label as usize]));
            }
        })
    });
    drop(numbering);
    let neighbours = times.time("split neighbours", || {
        neighbours_of(&geometry, &kinds, &offsets)
    });
    let (boundary, quality, bent) = times.time("split boundary", || {
        let inexact = |leaf: usize| !geometry.template_accurate(leaf);
        let (measured, bent) =
            measured_and_bent(&kinds, &offsets, (&triangles, &vertices), grid, inexact);
        let quality = unmoved_quality(&kinds, inexact).merge(measured);
        let boundary = boundary_edges(&geometry, &kinds, &triangles, &offsets);
        (boundary, quality, bent)
    });
    if let Some(leaf) = bent {
        return Err(point_near(&geometry, leaf, order, points));
    }
    let mesh = leaf_mesh(
        grid,
        (vertices, vertex_input),
        (triangles, neighbours),
        boundary,
    );
    Ok((mesh, quality))
}

/// The angles of the leaves the points split and of the `inexact` ones, measured, and the first
/// split leaf with an angle over 90° by more than rounding explains or a triangle f64 cannot
/// orient (coordinates so small that its area underflows), if any: a template's right angles
/// are the grid's, rounded, and only a point that f64 puts just outside its leaf can bend one
/// further.
fn measured_and_bent(
    kinds: &[u8],
    offsets: &[u32],
    (triangles, vertices): (&[[u32; 3]], &[DVec2]),
    grid: &Grid,
    inexact: impl Fn(usize) -> bool + Sync,
) -> (AngleQuality, Option<usize>) {
    let (lo, hi) = grid.domain();
    let m = largest_coordinate(&Domain { lo, hi });
    let split = |leaf: usize| kinds[leaf] & MOVED != 0;
    // A tally per run of leaves: folding leaf by leaf would move it at each one.
    let run_of = |run: usize| {
        let (mut tally, mut bent) = (AngleTally::new(), None);
        let from = run * GRAIN;
        for leaf in (from..kinds.len().min(from + GRAIN)).filter(|&l| split(l) || inexact(l)) {
            for t in &triangles[offsets[leaf] as usize..offsets[leaf + 1] as usize] {
                let corners = t.map(|v| vertices[v as usize]);
                let [a, b, c] = corners;
                // Only a triangle with an angle not clearly acute (a cosine at most 1e-9, or
                // NaN where the products overflow) needs its angles in degrees for the test.
                let cosines = tally.add_triangle(a, b, c);
                let clearly_acute = cosines.iter().all(|&cos| cos > 1e-9);
                let obtuse = || {
                    let largest = angles_deg(a, b, c).into_iter().fold(0.0, f64::max);
                    obtuse_beyond(largest, rounding_allowance_deg(corners, m))
                };
                if bent.is_none()
                    && split(leaf)
                    && ((!clearly_acute && obtuse()) || orientation(a, b, c) != Orientation::Left)
                {
                    bent = Some(leaf);
                }
            }
        }
        (tally.quality(), bent)
    };
    (0..kinds.len().div_ceil(GRAIN))
        .into_par_iter()
        .map(run_of)
        .reduce(
            || (AngleQuality::empty(), None),
            |(a, x): (AngleQuality, Option<usize>), (b, y)| (a.merge(b), x.min(y).or(x).or(y)),
        )
}

/// Puts each point that lies on a corner of its leaf in that corner's place.
fn take_corners<K: MortonKey>(
    geometry: &LeafGeometry<K>,
    numbering: &Numbering,
    splits: &Splits,
    order: &[u32],
    points: &[DVec2],
    (vertices, vertex_input): (&mut [DVec2], &mut [u32]),
) {
    for (p, &place) in splits.places.iter().enumerate() {
        if let Place::Corner(label) = place {
            let leaf = geometry.point_leaf[p] as usize;
            let vertex = numbering.labels(geometry, leaf)[label as usize] as usize;
            let input = order[p];
            vertices[vertex] = points[input as usize];
            vertex_input[vertex] = input;
        }
    }
}

/// Appends each point not on a corner of its leaf, and inside its leaf the feet of its lines
/// on the leaf's sides (south, east, north, west).
fn add_vertices<K: MortonKey>(
    geometry: &LeafGeometry<K>,
    splits: &Splits,
    added: &[u32],
    order: &[u32],
    points: &[DVec2],
    (vertices, vertex_input): (&mut Vec<DVec2>, &mut Vec<u32>),
) {
    let coordinates: Vec<DVec2> = collect_per_leaf(added, |p, out| {
        let x = points[order[p] as usize];
        match splits.places[p] {
            Place::Corner(_) => {}
            Place::Side(_) => out.push(x),
            Place::Inside => {
                let (lo, hi) = geometry.rect(geometry.point_leaf[p] as usize);
                out.push(x);
                out.push(DVec2::new(x.x, lo.y));
                out.push(DVec2::new(hi.x, x.y));
                out.push(DVec2::new(x.x, hi.y));
                out.push(DVec2::new(lo.x, x.y));
            }
        }
    });
    let inputs: Vec<u32> = collect_per_leaf(added, |p, out| {
        for k in 0..splits.places[p].added() {
            out.push(if k == 0 { order[p] } else { NONE });
        }
    });
    vertices.extend(coordinates);
    vertex_input.extend(inputs);
}
