//! Dynamic warped meshes: one edit on a built mesh against a rebuild.
//!
//! Group `dynamic/uniform/t<threads>`, ids `insert_delete/<n>` (a point inserted and deleted
//! again, so the mesh is the same after each iteration), `move_there_and_back/<n>` (a point
//! moved across the domain and back), `mesh/<n>` (warping the current tree) and `rebuild/<n>`
//! (the static mesh of the same points). Sizes default to 1e4 and 1e5
//! (`QUADMESH_BENCH_DYNAMIC_SIZES`); threads come from `QUADMESH_BENCH_THREADS`.
//!
//! Group `dynamic_delaunay/uniform/t<threads>`: the same for a quality Delaunay mesh at 30°
//! (`DynamicDelaunay`), with `move_near_and_back/<n>` (a point moved by a thousandth of the
//! side and back) and `rebuild/<n>` (refinement in order of the same points), at places all
//! over the square.

mod common;

use common::{SEED, configure, env_counts, pools};
use criterion::measurement::WallTime;
use criterion::{BenchmarkGroup, BenchmarkId, Criterion, criterion_group, criterion_main};
use quadmesh::dynamic::{DynamicDelaunay, DynamicMesh};
use quadmesh::generate::{Distribution2d, points};
use quadmesh::mesh::Domain;
use quadmesh::refine::{RefineDomain, RefineOptions, refine_points_in_order};
use quadmesh::{DVec2, Input, Options, Region};
use rayon::ThreadPool;

/// Places spread over the unit square, off the generated points.
fn places(count: usize) -> Vec<DVec2> {
    let golden = 0.618_033_988_749_894_9;
    (0..count)
        .map(|k| {
            let t = k as f64 + 0.5;
            DVec2::new((t * golden).fract(), t / count as f64)
        })
        .collect()
}

/// What both dynamic meshes do for the benches.
trait Edits {
    /// Inserts `p`, returning its id, or `None` where the place is refused.
    fn insert_at(&mut self, p: DVec2) -> Option<u32>;
    fn delete_id(&mut self, id: u32);
}

impl Edits for DynamicMesh {
    fn insert_at(&mut self, p: DVec2) -> Option<u32> {
        self.insert(p).ok().map(|done| done.id)
    }
    fn delete_id(&mut self, id: u32) {
        self.delete(id).expect("a live point");
    }
}

impl Edits for DynamicDelaunay {
    fn insert_at(&mut self, p: DVec2) -> Option<u32> {
        self.insert(p).ok().map(|done| done.id)
    }
    fn delete_id(&mut self, id: u32) {
        self.delete(id).expect("a live point");
    }
}

/// `insert_delete/<n>`: a point inserted at the next place and deleted again.
fn bench_insert_delete(
    group: &mut BenchmarkGroup<'_, WallTime>,
    n: usize,
    pool: &ThreadPool,
    targets: &[DVec2],
    dynamic: &mut (impl Edits + Send),
) {
    let mut next = 0;
    group.bench_function(BenchmarkId::new("insert_delete", n), |b| {
        b.iter(|| {
            pool.install(|| {
                next = (next + 1) % targets.len();
                if let Some(id) = dynamic.insert_at(targets[next]) {
                    dynamic.delete_id(id);
                }
            })
        })
    });
}

fn dynamic_benches(c: &mut Criterion) {
    let domain = Domain {
        lo: DVec2::ZERO,
        hi: DVec2::ONE,
    };
    for n in env_counts("QUADMESH_BENCH_DYNAMIC_SIZES", "10000,100000") {
        let pts = points(Distribution2d::Uniform, n, SEED);
        let targets = places(1024);
        for (threads, pool) in pools() {
            let mut group = c.benchmark_group(format!("dynamic/uniform/t{threads}"));
            configure(&mut group, n);
            let mut dynamic = pool.install(|| DynamicMesh::new(&pts, domain).expect("a mesh"));
            let mut next = 0;
            bench_insert_delete(&mut group, n, &pool, &targets, &mut dynamic);
            group.bench_function(BenchmarkId::new("move_there_and_back", n), |b| {
                b.iter(|| {
                    pool.install(|| {
                        next = (next + 1) % targets.len();
                        let id = (next * 7919 % n) as u32;
                        let home = dynamic.point(id).expect("a live point");
                        if dynamic.move_to(id, targets[next]).is_ok() {
                            dynamic.move_to(id, home).expect("back home");
                        }
                    })
                })
            });
            group.bench_function(BenchmarkId::new("mesh", n), |b| {
                b.iter_with_large_drop(|| pool.install(|| dynamic.mesh().expect("a mesh")))
            });
            let options = Options::default().warp().region(Region::Rectangle(domain));
            let input = Input::points(pts.clone());
            group.bench_function(BenchmarkId::new("rebuild", n), |b| {
                b.iter_with_large_drop(|| {
                    pool.install(|| quadmesh::mesh(&input, &options).expect("a mesh"))
                })
            });
            group.finish();
        }
    }
}

fn dynamic_delaunay_benches(c: &mut Criterion) {
    let domain = Domain {
        lo: DVec2::ZERO,
        hi: DVec2::ONE,
    };
    let options = RefineOptions {
        min_angle_deg: 30.0,
        domain: RefineDomain::Rectangle(domain),
        ..RefineOptions::default()
    };
    for n in env_counts("QUADMESH_BENCH_DYNAMIC_SIZES", "10000,100000") {
        let pts = points(Distribution2d::Uniform, n, SEED);
        let targets = places(1024);
        for (threads, pool) in pools() {
            let mut group = c.benchmark_group(format!("dynamic_delaunay/uniform/t{threads}"));
            configure(&mut group, n);
            let mut dynamic =
                pool.install(|| DynamicDelaunay::new(&pts, &options).expect("a mesh"));
            let mut next = 0;
            bench_insert_delete(&mut group, n, &pool, &targets, &mut dynamic);
            group.bench_function(BenchmarkId::new("move_near_and_back", n), |b| {
                b.iter(|| {
                    pool.install(|| {
                        next = (next + 1) % targets.len();
                        let id = (next * 7919 % n) as u32;
                        let home = dynamic.point(id).expect("a live point");
                        let near =
                            (home + (targets[next] - 0.5) * 1e-3).clamp(DVec2::ZERO, DVec2::ONE);
                        if dynamic.move_to(id, near).is_ok() {
                            dynamic.move_to(id, home).expect("back home");
                        }
                    })
                })
            });
            group.bench_function(BenchmarkId::new("rebuild", n), |b| {
                b.iter_with_large_drop(|| {
                    pool.install(|| refine_points_in_order(&pts, &options).expect("a mesh"))
                })
            });
            group.finish();
        }
    }
}

criterion_group!(benches, dynamic_benches, dynamic_delaunay_benches);
criterion_main!(benches);
