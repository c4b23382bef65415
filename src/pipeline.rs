//! The stages chained: points → Morton order → framework → unbalanced quadtree, with timings.
//! The CLI, the benches and the tests all call these.

use std::time::{Duration, Instant};

use glam::DVec2;

use crate::balance::{BalancedTree, balance, separate};
use crate::error::Error;
use crate::framework::{Framework, build_framework};
use crate::morton::{
    Duplicates, Grid, Morton, MortonKey, MortonOrder, SortAlgorithm, morton_order,
};
use crate::quadtree::{Quadtree, expand};

/// Wall-clock time of each stage, in the order they ran.
#[derive(Clone, Debug, Default)]
pub struct StageTimes(pub Vec<(&'static str, Duration)>);

impl StageTimes {
    fn time<T>(&mut self, stage: &'static str, f: impl FnOnce() -> T) -> T {
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
pub struct TreeBuild<K> {
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
