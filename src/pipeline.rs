//! The stages chained: points → Morton order → framework → unbalanced quadtree, with timings.
//! The CLI, the benches and the tests all call these.

use std::time::{Duration, Instant};

use glam::DVec2;

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

/// Builds the Morton order, the framework and the unbalanced quadtree of `points` on the current
/// rayon pool, timing each stage.
///
/// # Errors
/// Whatever [`morton_order`] refuses: empty input, non-finite coordinates, inseparable points.
pub fn build_tree(points: &[DVec2], sort: SortAlgorithm) -> Result<(Tree, StageTimes), Error> {
    let mut times = StageTimes::default();
    let morton = times.time("morton", || morton_order(points, sort))?;
    let tree = match morton {
        Morton::Narrow(m) => Tree::Narrow(trees_of(m, &mut times)),
        Morton::Wide(m) => Tree::Wide(trees_of(m, &mut times)),
    };
    Ok((tree, times))
}

fn trees_of<K: MortonKey>(morton: MortonOrder<K>, times: &mut StageTimes) -> TreeBuild<K> {
    let framework = times.time("framework", || build_framework(&morton.keys));
    let quadtree = times.time("quadtree", || expand(&framework, &morton.keys));
    TreeBuild {
        morton,
        framework,
        quadtree,
    }
}
