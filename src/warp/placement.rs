//! Where a given domain goes on the warp's grid: the mirror image the mesher works in (the
//! side it lines with equal cells on top), and the graded columns that put the domain's right
//! side on a grid line so that leaves meet its top side graded. The domain's geometry only;
//! the pipeline builds the trees on it.

use glam::DVec2;
use rayon::prelude::*;

use crate::mesh::{BoundarySide, Domain, Reflection};

/// A root for a domain shorter than wide whose top side lies just above a grid line of
/// `level`: the domain is `columns` cells of `level` wide, and the side keeps less than 1/16
/// of the cells it crosses at every level down to `finest`. Leaves of those levels can then meet
/// the side side by side, graded like the rest of the tree, all with their bottoms on that line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct GradedColumns {
    /// The level of the grid line the right side is put on.
    pub(crate) level: u32,
    /// The domain's width in cells of `level`.
    pub(crate) columns: u64,
    /// The finest level whose leaves the side must meet graded.
    pub(crate) finest: u32,
}

/// The root that lets leaves meet a short domain's top side graded (see [`GradedColumns`]):
/// the coarsest level whose number of columns puts the side just above a grid line, for leaves
/// as fine as the points near the side (within about an eighth of their clearance) need.
pub(crate) fn graded_columns(points: &[DVec2], domain: Domain) -> Option<GradedColumns> {
    let extent = domain.hi - domain.lo;
    if extent.y >= extent.x {
        return None;
    }
    let clearance = side_clearance(points, |p| p, domain, BoundarySide::Top);
    // Leaves meeting the side near a point are about an eighth of its clearance or larger, on
    // a root at most twice as wide as the domain.
    let finest = (16.0 * extent.x / clearance.min(extent.y))
        .log2()
        .ceil()
        .clamp(2.0, 64.0) as u32;
    (2..=MAX_GRADED_LEVEL.min(finest)).find_map(|level| {
        let limit = (2.0f64).powi(level as i32 - finest as i32 - 4);
        let first = (1u64 << (level - 1)) + 1;
        (first..=1u64 << level).find_map(|columns| {
            // The top side in cells of `level`, rounded as `Grid::on_domain_columns` rounds it.
            let side = extent.x * (2.0f64).powi(level as i32) / columns as f64;
            let rows = extent.y / side * (2.0f64).powi(level as i32);
            (rows >= 1.0 && rows.fract() < limit).then_some(GradedColumns {
                level,
                columns,
                finest,
            })
        })
    })
}

/// The finest level of the grid line a domain's right side is put on: past it, the search for
/// columns costs more than the uniform band saves.
const MAX_GRADED_LEVEL: u32 = 22;

/// The mirror images, in order, that turn `domain` into one at least as wide as tall whose top
/// side is the better of its two long sides to line with equal cells: the one whose nearest
/// point not on it, and closest two points on it, are further apart. [`crate::mesh_points`]
/// meshes that image and maps the mesh back.
pub fn domain_reflections(points: &[DVec2], domain: Domain) -> Vec<Reflection> {
    let extent = domain.hi - domain.lo;
    let mut reflections = Vec::new();
    let mut image = domain;
    if extent.y > extent.x {
        reflections.push(Reflection::Diagonal);
        image = domain.reflected(Reflection::Diagonal);
    }
    let diagonal = reflections.first().copied();
    let flip = |p: DVec2| diagonal.map_or(p, |r| r.point(p));
    if extent.x != extent.y
        && side_clearance(points, flip, image, BoundarySide::Bottom)
            > side_clearance(points, flip, image, BoundarySide::Top)
    {
        reflections.push(Reflection::Horizontal);
    }
    reflections
}

/// How far points keep from the top or bottom `side` of `domain` (after `image` maps them into
/// it): the least distance from the side to a point not on it, or between two points on it, or
/// from a point on it to the side's ends (the corners; a point on a corner keeps clear of it).
fn side_clearance(
    points: &[DVec2],
    image: impl Fn(DVec2) -> DVec2 + Sync,
    domain: Domain,
    side: BoundarySide,
) -> f64 {
    let height = |p: DVec2| match side {
        BoundarySide::Bottom => p.y - domain.lo.y,
        _ => domain.hi.y - p.y,
    };
    let off_side = points
        .par_iter()
        .map(|&p| height(image(p)))
        .filter(|&h| h > 0.0)
        .reduce(|| f64::INFINITY, f64::min);
    let mut on_side: Vec<f64> = points
        .par_iter()
        .map(|&p| image(p))
        .filter(|&p| height(p) == 0.0)
        .map(|p| p.x)
        .collect();
    on_side.par_sort_unstable_by(f64::total_cmp);
    let ends: Vec<f64> = [domain.lo.x]
        .into_iter()
        .chain(on_side)
        .chain([domain.hi.x])
        .collect();
    let apart = ends
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|&d| d > 0.0)
        .fold(f64::INFINITY, f64::min);
    off_side.min(apart)
}

/// The points and the domain in the mirror image `reflections` make, in order.
pub(crate) fn mirrored(
    points: &[DVec2],
    domain: Domain,
    reflections: &[Reflection],
) -> (Vec<DVec2>, Domain) {
    let image = |p: DVec2| reflections.iter().fold(p, |p, r| r.point(p));
    let points = points.par_iter().map(|&p| image(p)).collect();
    (
        points,
        reflections.iter().fold(domain, |d, &r| d.reflected(r)),
    )
}
