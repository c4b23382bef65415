//! The first stages of meshing a planar straight-line graph in the quadtree: acute corners cut
//! off (`cut`), then the features separated in a balanced tree (`tree`: Morton order, the
//! crowding tests, the balance), on the cut graph made beforehand.
//!
//! Group `graph/<input>/t<threads>`, ids `cut/<points>`, `tree/<points>` and, for trees of at
//! most [`WARP_LEAVES`] leaves, `warp/<points>` (the whole warped mesh through the front door:
//! cleaning, cut, tree, bending, carving); throughput is the number of input points. Inputs: nested closed curves of `QUADMESH_BENCH_SEGMENTS` segments
//! (default 200000; no acute wedge), a block with `QUADMESH_BENCH_HOLES` rectangular holes
//! (default 2000; right angles only), and the Delaunay triangulation's edges of
//! `QUADMESH_BENCH_DELAUNAY` uniform points (default 1000: almost every wedge is acute, and the
//! thin wedges beyond the caps, whose edges must be separated along their whole length, make
//! about 8 000 leaves a point). Threads come from the same variable as the other benches.

mod common;
#[path = "../tests/common/graphs.rs"]
#[allow(dead_code)]
mod graphs;

use common::{SEED, configure, env_counts, pools};
use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use graphs::delaunay_graph;
use quadmesh::generate::{block_with_holes, nested_curves};
use quadmesh::pipeline::{GraphTree, GraphTreeOptions, StageTimes, graph_tree};
use quadmesh::pslg::cut_acute_corners;
use quadmesh::{Input, Options};

/// The largest tree whose warped mesh is timed (a few seconds a run at most).
const WARP_LEAVES: usize = 2_000_000;

fn leaves(tree: &GraphTree) -> usize {
    match tree {
        GraphTree::Narrow(b) => b.tree.tree.leaves.len(),
        GraphTree::Wide(b) => b.tree.tree.leaves.len(),
    }
}

fn bench_graph(c: &mut Criterion, name: &str, input: &Input) {
    let n = input.points.len();
    for (threads, pool) in pools() {
        let cut = pool.install(|| cut_acute_corners(input)).expect("a cut");
        let tree = pool
            .install(|| {
                graph_tree(
                    &cut,
                    GraphTreeOptions::default(),
                    &mut StageTimes::default(),
                )
            })
            .expect("a tree");
        eprintln!(
            "graph/{name}: {n} points, {} segments, {} caps, {} cut edges, {} leaves",
            input.segments.len(),
            cut.caps.len(),
            cut.edges.len(),
            leaves(&tree)
        );
        let mut group = c.benchmark_group(format!("graph/{name}/t{threads}"));
        configure(&mut group, n);
        group.bench_function(BenchmarkId::new("cut", n), |b| {
            b.iter_with_large_drop(|| pool.install(|| cut_acute_corners(input)))
        });
        group.bench_function(BenchmarkId::new("tree", n), |b| {
            b.iter_with_large_drop(|| {
                pool.install(|| {
                    graph_tree(
                        &cut,
                        GraphTreeOptions::default(),
                        &mut StageTimes::default(),
                    )
                })
            })
        });
        if leaves(&tree) <= WARP_LEAVES {
            let warp = Options::default().warp();
            group.bench_function(BenchmarkId::new("warp", n), |b| {
                b.iter_with_large_drop(|| pool.install(|| quadmesh::mesh(input, &warp)))
            });
        }
        group.finish();
    }
}

fn graphs(c: &mut Criterion) {
    for segments in env_counts("QUADMESH_BENCH_SEGMENTS", "200000") {
        bench_graph(c, "nested", &nested_curves(segments, SEED));
    }
    for holes in env_counts("QUADMESH_BENCH_HOLES", "2000") {
        bench_graph(c, "holes", &block_with_holes(holes, SEED));
    }
    for n in env_counts("QUADMESH_BENCH_DELAUNAY", "1000") {
        bench_graph(c, "delaunay", &delaunay_graph(n, SEED));
    }
}

criterion_group!(benches, graphs);
criterion_main!(benches);
