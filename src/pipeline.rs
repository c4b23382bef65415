//! The stages chained: points → Morton order → framework → unbalanced quadtree, with timings.
//! The CLI, the benches and the tests all call these.

use glam::DVec2;
use rayon::prelude::*;

use crate::balance::{
    BalancedTree, Band, BandError, DomainSides, balance, coarsest_band_level, separate, separate_in,
};
use crate::error::Error;
use crate::framework::{Framework, build_framework};
pub use crate::mesh::StageTimes;
use crate::mesh::{AngleQuality, BoundarySide, Domain, Mesh, MeshReport, Reflection, report_of};
use crate::morton::{
    Duplicates, Grid, Morton, MortonKey, MortonOrder, SortAlgorithm, morton_order, morton_order_on,
    morton_order_wide, validate_points,
};
use crate::quadtree::{Quadtree, expand};
use crate::warp::{leaves_below, point_finer_than_grid, unresolvable, warp};

/// The trees of one input on one grid width.
#[derive(Clone, Debug)]
pub struct TreeBuild<K: Copy> {
    /// Distinct points in Morton order, the grid and the merged duplicates.
    pub morton: MortonOrder<K>,
    /// The compressed quadtree.
    pub framework: Framework<K>,
    /// The unbalanced quadtree.
    pub quadtree: Quadtree<K>,
    /// The balanced (or well-separated) tree, when asked for.
    pub balanced: Option<BalancedTree<K>>,
    /// The band of uniform leaves along a given domain's top side, when that lies inside the
    /// root.
    pub band: Option<Band>,
}

impl<K: MortonKey> TreeBuild<K> {
    /// The most refined tree built: the balanced one if there is one.
    pub fn final_tree(&self) -> &Quadtree<K> {
        self.balanced.as_ref().map_or(&self.quadtree, |b| &b.tree)
    }
}

/// How far to refine the quadtree.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Refinement {
    /// Every point alone in its leaf.
    #[default]
    Unbalanced,
    /// Also 2:1 balanced, with cross links and point location.
    Balanced,
    /// Balanced, and every point's leaf centred in a 5×5 block of same-size empty leaves.
    Separated,
}

/// What [`build_tree`] builds and how.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TreeOptions {
    /// The sort used for Morton order.
    pub sort: SortAlgorithm,
    /// How far to refine.
    pub refinement: Refinement,
}

impl TreeOptions {
    /// These options with another refinement.
    pub fn refinement(self, refinement: Refinement) -> Self {
        TreeOptions { refinement, ..self }
    }

    /// These options with another sort.
    pub fn sort(self, sort: SortAlgorithm) -> Self {
        TreeOptions { sort, ..self }
    }
}

/// The trees on whichever grid the input needed.
#[derive(Clone, Debug)]
pub enum Tree {
    /// 32 bits per axis.
    Narrow(TreeBuild<u64>),
    /// 64 bits per axis.
    Wide(TreeBuild<u128>),
}

impl Tree {
    /// The grid of the build.
    pub fn grid(&self) -> &Grid {
        match self {
            Tree::Narrow(b) => &b.morton.grid,
            Tree::Wide(b) => &b.morton.grid,
        }
    }

    /// The duplicates merged.
    pub fn duplicates(&self) -> &Duplicates {
        match self {
            Tree::Narrow(b) => &b.morton.duplicates,
            Tree::Wide(b) => &b.morton.duplicates,
        }
    }
}

/// Builds the Morton order, the framework, the unbalanced quadtree and, if asked, the balanced
/// tree of `points` on the current rayon pool, timing each stage.
///
/// # Errors
/// Whatever [`morton_order`] refuses: empty input, non-finite coordinates, inseparable points.
pub fn build_tree(points: &[DVec2], options: &TreeOptions) -> Result<(Tree, StageTimes), Error> {
    let mut times = StageTimes::default();
    let morton = times.time("morton", || morton_order(points, options.sort))?;
    let tree = match morton {
        Morton::Narrow(m) => Tree::Narrow(trees_of(m, options, &mut times)),
        Morton::Wide(m) => Tree::Wide(trees_of(m, options, &mut times)),
    };
    Ok((tree, times))
}

fn trees_of<K: MortonKey>(
    morton: MortonOrder<K>,
    options: &TreeOptions,
    times: &mut StageTimes,
) -> TreeBuild<K> {
    let keys = &morton.keys;
    let framework = times.time("framework", || build_framework(keys));
    let quadtree = times.time("quadtree", || expand(&framework, keys));
    let balanced = match options.refinement {
        Refinement::Unbalanced => None,
        Refinement::Balanced => Some(times.time("balance", || balance(&quadtree, keys))),
        Refinement::Separated => Some(times.time("separate", || separate(&quadtree, keys))),
    };
    TreeBuild {
        morton,
        framework,
        quadtree,
        balanced,
        band: None,
    }
}

/// What [`mesh_points`] builds and how.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MeshOptions {
    /// The sort used for Morton order.
    pub sort: SortAlgorithm,
    /// The rectangle to mesh, holding every point (on its sides too); by default the points'
    /// bounding box centred in a square twice its larger side.
    pub domain: Option<Domain>,
}

/// The well-separated tree the warp needs, on the narrow grid if it resolves the points finely
/// enough for their leaves, on the wide grid otherwise; on the options' domain if they give one,
/// which must then be at least as wide as it is tall (see [`Grid::on_domain`]) and hold the
/// points.
///
/// # Errors
/// Whatever [`morton_order`] refuses, [`Error::Unresolvable`] for points too close together
/// relative to the extent for even the wide grid, [`Error::NearDomainSide`] when a domain's
/// top side needs too fine a band of leaves, and [`Error::ThinDomain`] for a domain too
/// elongated for one.
pub fn separated_tree(
    points: &[DVec2],
    options: &MeshOptions,
) -> Result<(Tree, StageTimes), Error> {
    // A failed graded attempt's stages stay in the times: they were spent.
    let mut times = StageTimes::default();
    let graded = options.domain.and_then(|d| graded_columns(points, d));
    if let Some(columns) = graded
        && let Some(tree) = separated_tree_on(points, options, Some(columns), &mut times)?
    {
        return Ok((tree, times));
    }
    let tree = separated_tree_on(points, options, None, &mut times)?;
    Ok((tree.expect("a uniform band needs no grading"), times))
}

/// [`separated_tree`] with the domain's right side on the grid line `columns` gives, if any;
/// `None` when the band along its top side turns out finer than that choice allows.
fn separated_tree_on(
    points: &[DVec2],
    options: &MeshOptions,
    columns: Option<GradedColumns>,
    times: &mut StageTimes,
) -> Result<Option<Tree>, Error> {
    let domain = options
        .domain
        .map(|d| (d.lo, d.hi, columns.map(|c| (c.level, c.columns))));
    let morton = times.time("morton", || morton_order_on(points, domain, options.sort))?;
    let m = match morton {
        Morton::Narrow(m) => {
            let Some(build) = separated_build(m, points, columns, times)? else {
                return Ok(None);
            };
            if deepest_point_leaf(&build).is_none() {
                return Ok(Some(Tree::Narrow(build)));
            }
            // Points so close that their leaves are finer than the narrow grid resolves the
            // points: the wide grid places them exactly enough.
            times.time("morton wide", || {
                morton_order_wide(points, domain, options.sort)
            })?
        }
        Morton::Wide(m) => m,
    };
    let Some(build) = separated_build(m, points, columns, times)? else {
        return Ok(None);
    };
    if let Some(p) = deepest_point_leaf(&build) {
        let index = build.morton.order[p];
        return Err(unresolvable(points[index as usize], index));
    }
    Ok(Some(Tree::Wide(build)))
}

/// A root for a domain shorter than wide whose top side lies just above a grid line of
/// `level`: the domain is `columns` cells of `level` wide, and the side keeps less than 1/16
/// of the cells it crosses at every level down to `finest`. Leaves of those levels can then meet
/// the side side by side, graded like the rest of the tree, all with their bottoms on that line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct GradedColumns {
    level: u32,
    columns: u64,
    finest: u32,
}

/// The root that lets leaves meet a short domain's top side graded (see [`GradedColumns`]):
/// the coarsest level whose number of columns puts the side just above a grid line, for leaves
/// as fine as the points near the side (within about an eighth of their clearance) need.
fn graded_columns(points: &[DVec2], domain: Domain) -> Option<GradedColumns> {
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

/// The framework, the unbalanced tree and the well-separated tree on `morton`'s grid, with the
/// band along the domain's top side if it has one inside the root (the grid then moves the
/// band's top row onto that side); graded as `columns` says if given, `None` if leaves finer
/// than that allows meet the side.
fn separated_build<K: MortonKey>(
    mut morton: MortonOrder<K>,
    points: &[DVec2],
    columns: Option<GradedColumns>,
    times: &mut StageTimes,
) -> Result<Option<TreeBuild<K>>, Error> {
    let mut sides = DomainSides::of(points, &morton.order, &morton.grid);
    // `graded_columns` rounded the top side as this grid does, so the choice holds here.
    if let (Some(sides), Some(c)) = (sides.as_mut(), columns) {
        sides.graded_top = Some((c.level as u8, c.finest.min(K::AXIS_BITS) as u8));
    }
    let keys = &morton.keys;
    let limit = band_level_limit::<K>(keys.len());
    if let Some(top) = morton.grid.inner_top()
        && coarsest_band_level(top, K::AXIS_BITS) > limit
    {
        let (lo, hi) = morton.grid.domain();
        return Err(Error::ThinDomain {
            width: hi.x - lo.x,
            height: hi.y - lo.y,
        });
    }
    let framework = times.time("framework", || build_framework(keys));
    let quadtree = times.time("quadtree", || expand(&framework, keys));
    let separated = times.time("separate", || {
        separate_in(&quadtree, keys, sides.as_ref(), limit)
    });
    let (balanced, band) = match separated {
        Ok(tree) => tree,
        Err(BandError::NotGraded) => return Ok(None),
        Err(BandError::TooFine { level, point }) => {
            let index = morton.order[point];
            let p = points[index as usize];
            return Err(Error::NearDomainSide {
                index: index as usize,
                x: p.x,
                y: p.y,
                side: BoundarySide::Top,
                cells: 1u128 << level,
            });
        }
    };
    if let Some(band) = band {
        morton.grid.set_top_row(band.top_row);
    }
    Ok(Some(TreeBuild {
        morton,
        framework,
        quadtree,
        balanced: Some(balanced),
        band,
    }))
}

/// The finest band along a domain's top side allowed for `points` points: at most 64 cells per
/// point or 2^20 cells, whichever is more, and within the grid.
fn band_level_limit<K: MortonKey>(points: usize) -> u8 {
    let cells = (points as u128 * 64).max(1 << 20);
    cells.ilog2().min(K::AXIS_BITS - 1) as u8
}

/// The quality mesh of `points` by warping (angles in [22.5°, 112.5°]) on the current rayon
/// pool, with its report. The domain is the options' rectangle, or else the quadtree's root
/// square: the points' bounding box centred in a square of twice its larger side.
///
/// # Errors
/// Whatever [`morton_order`] refuses, [`Error::Unresolvable`] for points too close together
/// relative to the extent for either grid or for f64, [`Error::TooLarge`] past 32-bit indices;
/// with a domain, [`Error::InvalidOption`] unless it is a finite rectangle,
/// [`Error::OutsideDomain`] for a point outside it, [`Error::NearDomainSide`] for a point
/// so close to a side (or points so close together on it) that the cells along it would be too
/// many, and [`Error::ThinDomain`] for a domain too elongated for its cells.
pub fn mesh_points(points: &[DVec2], options: &MeshOptions) -> Result<(Mesh, MeshReport), Error> {
    let Some(domain) = options.domain else {
        return mesh_on(points, options);
    };
    domain.check()?;
    validate_points(points)?;
    domain.check_holds(points)?;
    // The mesher lines one side with equal cells (the top of a domain at least as wide as
    // tall): it works in the mirror image that makes that side the better one.
    let reflections = domain_reflections(points, domain);
    if reflections.is_empty() {
        return mesh_on(points, options);
    }
    let image = |p: DVec2| reflections.iter().fold(p, |p, r| r.point(p));
    let mirrored: Vec<DVec2> = points.par_iter().map(|&p| image(p)).collect();
    let options = MeshOptions {
        domain: Some(reflections.iter().fold(domain, |d, &r| d.reflected(r))),
        ..*options
    };
    let back = reflections.iter().rev();
    match mesh_on(&mirrored, &options) {
        Ok((mesh, report)) => Ok((back.fold(mesh, |m, &r| m.reflected(r)), report)),
        Err(e) => Err(back.fold(e, |e, &r| e.reflected(r))),
    }
}

/// The mirror images, in order, that turn `domain` into one at least as wide as tall whose top
/// side is the better of its two long sides to line with equal cells: the one whose nearest
/// point not on it, and closest two points on it, are further apart. [`mesh_points`] meshes
/// that image and maps the mesh back.
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

/// [`mesh_points`] once the domain, if any, is at least as wide as it is tall.
fn mesh_on(points: &[DVec2], options: &MeshOptions) -> Result<(Mesh, MeshReport), Error> {
    let (tree, mut times) = separated_tree(points, options)?;
    let (mesh, quality, duplicates) = match tree {
        Tree::Narrow(build) => warp_build(build, points, &mut times)?,
        Tree::Wide(build) => warp_build(build, points, &mut times)?,
    };
    let report = report_of(
        &mesh,
        points.len() - duplicates,
        duplicates,
        &quality,
        times,
    );
    Ok((mesh, report))
}

type Warped = (Mesh, AngleQuality, usize);

fn warp_build<K: MortonKey>(
    build: TreeBuild<K>,
    points: &[DVec2],
    times: &mut StageTimes,
) -> Result<Warped, Error> {
    // The framework and the unbalanced tree go here; the warp reads the separated tree's leaves,
    // links and point location only, so its internal squares go too, before the mesh's arrays
    // are made.
    let TreeBuild {
        morton,
        balanced,
        band,
        ..
    } = build;
    let mut tree = balanced.expect("a separated tree");
    tree.tree.internal = Vec::new();
    if let Some(band) = band {
        let right = morton.grid.inner_right();
        tree = times
            .time("warp band", || leaves_below(tree, band.top_row, right))
            .map_err(|p| {
                let index = morton.order[p];
                unresolvable(points[index as usize], index)
            })?;
    }
    let (mesh, quality) = warp(&tree, &morton.order, &morton.grid, points, times)?;
    Ok((mesh, quality, morton.duplicates.count))
}

fn deepest_point_leaf<K: MortonKey>(build: &TreeBuild<K>) -> Option<usize> {
    build.balanced.as_ref().and_then(point_finer_than_grid)
}
