//! End-to-end warped meshing (`mesh_points`: Morton order, framework, quadtree, separation,
//! warp) by the compact and the block warp, the compact warp and the nonobtuse split coarsened
//! (the warp and nonobtuse modes), the block warp stage alone, and the nonobtuse split of the
//! same tree, on generated points.
//!
//! Group `mesh/<dist>/t<threads>`, ids `compact/<n>`, `mesh/<n>` (the block warp),
//! `coarsened/<n>` and `nonobtuse/<n>` (throughput: input points), `warp/<n>` and `split/<n>` (throughput: output triangles). Sizes default to 1e4 and 1e5 (`QUADMESH_BENCH_MESH_SIZES`);
//! threads come from `QUADMESH_BENCH_THREADS` like the other benches. Triangle counts are printed
//! to stderr.

mod common;

use common::{DISTRIBUTIONS, SEED, configure, env_counts, pools};
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use quadmesh::balance::{BalancedTree, Separation};
use quadmesh::generate::points;
use quadmesh::mesh::AngleQuality;
use quadmesh::mesh::StageTimes;
use quadmesh::morton::Grid;
use quadmesh::morton::MortonKey;
use quadmesh::pipeline::separated_tree;
use quadmesh::warp::{split, warp};
use quadmesh::{DVec2, Error, Mesh, MeshOptions, Tree, TreeBuild, mesh_points};
use rayon::ThreadPool;

fn bench_warp<K: MortonKey>(
    c: &mut Criterion,
    group_name: &str,
    build: &TreeBuild<K>,
    pts: &[DVec2],
    pool: &ThreadPool,
) {
    let tree = build.balanced.as_ref().expect("a separated tree");
    let m = &build.morton;
    let mut group = c.benchmark_group(group_name);
    configure(&mut group, pts.len());
    for (name, stage) in [("warp", block_warp::<K> as Stage<K>), ("split", split::<K>)] {
        let run = || {
            pool.install(|| {
                stage(tree, &m.order, &m.grid, pts, &mut StageTimes::default()).expect("a mesh")
            })
        };
        let triangles = run().0.triangles.len();
        group.throughput(Throughput::Elements(triangles as u64));
        group.bench_function(BenchmarkId::new(name, pts.len()), |b| {
            b.iter_with_large_drop(run)
        });
    }
    group.finish();
}

/// The block warp of a separated tree.
fn block_warp<K: MortonKey>(
    tree: &BalancedTree<K>,
    order: &[u32],
    grid: &Grid,
    pts: &[DVec2],
    times: &mut StageTimes,
) -> Result<(Mesh, AngleQuality), Error> {
    warp(tree, (order, None), grid, pts, times)
}

/// The warp and the nonobtuse split: a separated tree to its mesh.
type Stage<K> = fn(
    &BalancedTree<K>,
    &[u32],
    &Grid,
    &[DVec2],
    &mut StageTimes,
) -> Result<(Mesh, AngleQuality), Error>;

fn mesh_benches(c: &mut Criterion) {
    for n in env_counts("QUADMESH_BENCH_MESH_SIZES", "10000,100000") {
        for (dist_name, dist) in DISTRIBUTIONS {
            let pts = points(dist, n, SEED);
            for (threads, pool) in pools() {
                let group_name = format!("mesh/{dist_name}/t{threads}");
                let mesh =
                    || pool.install(|| mesh_points(&pts, &MeshOptions::default()).expect("a mesh"));
                let (_, report) = mesh();
                eprintln!(
                    "{group_name}: {n} points, {} triangles ({:.1} per point)",
                    report.triangles,
                    report.triangles as f64 / n as f64
                );
                let compact_options = MeshOptions {
                    separation: Separation::Corner,
                    ..MeshOptions::default()
                };
                let compact =
                    || pool.install(|| mesh_points(&pts, &compact_options).expect("a mesh"));
                let (_, compact_report) = compact();
                eprintln!(
                    "{group_name}: {n} points, {} compact-warped triangles ({:.1} per point)",
                    compact_report.triangles,
                    compact_report.triangles as f64 / n as f64
                );
                let mut group = c.benchmark_group(&group_name);
                configure(&mut group, n);
                group.bench_function(BenchmarkId::new("compact", n), |b| {
                    b.iter_with_large_drop(compact)
                });
                group.bench_function(BenchmarkId::new("mesh", n), |b| {
                    b.iter_with_large_drop(mesh)
                });
                let coarsened = [
                    ("coarsened", Separation::Corner, false),
                    ("nonobtuse", Separation::Block, true),
                ];
                for (id, separation, nonobtuse) in coarsened {
                    let options = MeshOptions {
                        separation,
                        nonobtuse,
                        coarsen: true,
                        ..MeshOptions::default()
                    };
                    let run = || pool.install(|| mesh_points(&pts, &options).expect("a mesh"));
                    eprintln!(
                        "{group_name}: {n} points, {} {id} triangles",
                        run().1.triangles
                    );
                    group.bench_function(BenchmarkId::new(id, n), |b| b.iter_with_large_drop(run));
                }
                group.finish();
                let options = MeshOptions::default();
                let (tree, _) = pool.install(|| separated_tree(&pts, &options).expect("a tree"));
                match &tree {
                    Tree::Narrow(build) => bench_warp(c, &group_name, build, &pts, &pool),
                    Tree::Wide(build) => bench_warp(c, &group_name, build, &pts, &pool),
                }
            }
        }
    }
}

criterion_group!(benches, mesh_benches);
criterion_main!(benches);
