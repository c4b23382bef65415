//! The stages chained: points → Morton order → framework → unbalanced quadtree, with timings.
//! The CLI, the benches and the tests all call these.

use std::time::{Duration, Instant};

use glam::DVec2;

use crate::balance::{BalancedTree, balance, separate};
use crate::error::Error;
use crate::framework::{Framework, build_framework};
use crate::mesh::{AngleQuality, Mesh, MeshReport};
use crate::morton::{
    Duplicates, Grid, Morton, MortonKey, MortonOrder, SortAlgorithm, morton_order,
    morton_order_wide,
};
use crate::quadtree::{Quadtree, expand};
use crate::warp::{point_finer_than_grid, unresolvable, warp};

/// Wall-clock time of each stage, in the order they ran.
#[derive(Clone, Debug, Default)]
pub struct StageTimes(pub Vec<(&'static str, Duration)>);

impl StageTimes {
    /// Runs `f`, recording its wall-clock time under `stage`.
    pub fn time<T>(&mut self, stage: &'static str, f: impl FnOnce() -> T) -> T {
        let start = Instant::now();
        let out = f();
        self.0.push((stage, start.elapsed()));
        out
    }

    /// Sum of all stages.
    pub fn total(&self) -> Duration {
        self.0.iter().map(|(_, d)| *d).sum()
    }
}

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
    }
}

/// What [`mesh_points`] builds and how.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MeshOptions {
    /// The sort used for Morton order.
    pub sort: SortAlgorithm,
}

/// The well-separated tree the warp needs, on the narrow grid if it resolves the points finely
/// enough for their leaves, on the wide grid otherwise.
///
/// # Errors
/// Whatever [`morton_order`] refuses, and [`Error::Unresolvable`] for points too close together
/// relative to the extent for even the wide grid.
pub fn separated_tree(
    points: &[DVec2],
    options: &MeshOptions,
) -> Result<(Tree, StageTimes), Error> {
    let mut times = StageTimes::default();
    let separated = TreeOptions::default()
        .sort(options.sort)
        .refinement(Refinement::Separated);
    let morton = times.time("morton", || morton_order(points, options.sort))?;
    let m = match morton {
        Morton::Narrow(m) => {
            let build = trees_of(m, &separated, &mut times);
            if deepest_point_leaf(&build).is_none() {
                return Ok((Tree::Narrow(build), times));
            }
            // Points so close that their leaves are finer than the narrow grid resolves the
            // points: the wide grid places them exactly enough.
            times.time("morton wide", || morton_order_wide(points, options.sort))?
        }
        Morton::Wide(m) => m,
    };
    let build = trees_of(m, &separated, &mut times);
    if let Some(p) = deepest_point_leaf(&build) {
        let index = build.morton.order[p];
        return Err(unresolvable(points[index as usize], index));
    }
    Ok((Tree::Wide(build), times))
}

/// The quality mesh of `points` by warping (angles in [22.5°, 112.5°]) on the current rayon
/// pool, with its report. The domain is the quadtree's root square: the points' bounding box
/// centred in a square of twice its larger side.
///
/// # Errors
/// Whatever [`morton_order`] refuses, [`Error::Unresolvable`] for points too close together
/// relative to the extent for either grid or for f64, [`Error::TooLarge`] past 32-bit indices.
pub fn mesh_points(points: &[DVec2], options: &MeshOptions) -> Result<(Mesh, MeshReport), Error> {
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

/// The report of a finished mesh of `points` distinct points.
pub(crate) fn report_of(
    mesh: &Mesh,
    points: usize,
    duplicates: usize,
    quality: &AngleQuality,
    times: StageTimes,
) -> MeshReport {
    MeshReport {
        points,
        duplicates,
        vertices: mesh.vertices.len(),
        triangles: mesh.triangles.len(),
        min_angle: quality.min,
        max_angle: quality.max,
        histogram: quality.histogram,
        stages: times.0,
    }
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
        morton, balanced, ..
    } = build;
    let mut tree = balanced.expect("a separated tree");
    tree.tree.internal = Vec::new();
    let (mesh, quality) = warp(&tree, &morton.order, &morton.grid, points, times)?;
    Ok((mesh, quality, morton.duplicates.count))
}

fn deepest_point_leaf<K: MortonKey>(build: &TreeBuild<K>) -> Option<usize> {
    build.balanced.as_ref().and_then(point_finer_than_grid)
}
