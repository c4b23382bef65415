//! Off-center Delaunay refinement end to end (`refine_points`: Morton order, Delaunay
//! triangulation of the points and the square's corners, refinement, angle report), on
//! generated points.
//!
//! Group `refine/<dist>/t<threads>`, ids `a<angle>/<n>` (throughput: input points). Sizes
//! default to 1e4 and 1e5 (`QUADMESH_BENCH_REFINE_SIZES`), angles to 20 and 30
//! (`QUADMESH_BENCH_REFINE_ANGLES`); threads come from `QUADMESH_BENCH_THREADS` like the other
//! benches. Triangle counts are printed to stderr.
//!
//! Group `ordered/<dist>/t<threads>` puts refinement in order (`refine_points_in_order`, whose
//! mesh depends only on the points near each triangle) beside `refine_points` on the same
//! square domain, ids `default/a<angle>` and `ordered/a<angle>`, at 30° by default
//! (`QUADMESH_BENCH_ORDERED_ANGLES`), sizes from `QUADMESH_BENCH_ORDERED_SIZES` (1e4, 1e5).

mod common;

use common::{DISTRIBUTIONS, SEED, configure, env_counts, pools};
use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use quadmesh::generate::points;
use quadmesh::refine::{RefineDomain, RefineOptions, refine_points, refine_points_in_order};

fn refine_benches(c: &mut Criterion) {
    let angles = env_counts("QUADMESH_BENCH_REFINE_ANGLES", "20,30");
    for n in env_counts("QUADMESH_BENCH_REFINE_SIZES", "10000,100000") {
        for (dist_name, dist) in DISTRIBUTIONS {
            let pts = points(dist, n, SEED);
            for (threads, pool) in pools() {
                let group_name = format!("refine/{dist_name}/t{threads}");
                let mut group = c.benchmark_group(&group_name);
                configure(&mut group, n);
                for &angle in &angles {
                    let options = RefineOptions {
                        min_angle_deg: angle as f64,
                        ..RefineOptions::default()
                    };
                    let refine = || pool.install(|| refine_points(&pts, &options).expect("a mesh"));
                    let (_, report) = refine();
                    eprintln!(
                        "{group_name} {angle}°: {n} points, {} triangles ({:.2} per point)",
                        report.triangles,
                        report.triangles as f64 / n as f64
                    );
                    group.bench_function(BenchmarkId::new(format!("a{angle}"), n), |b| {
                        b.iter_with_large_drop(refine)
                    });
                }
                group.finish();
            }
        }
    }
}

fn ordered_benches(c: &mut Criterion) {
    let angles = env_counts("QUADMESH_BENCH_ORDERED_ANGLES", "30");
    for n in env_counts("QUADMESH_BENCH_ORDERED_SIZES", "10000,100000") {
        for (dist_name, dist) in DISTRIBUTIONS {
            let pts = points(dist, n, SEED);
            for (threads, pool) in pools() {
                let group_name = format!("ordered/{dist_name}/t{threads}");
                let mut group = c.benchmark_group(&group_name);
                configure(&mut group, n);
                for &angle in &angles {
                    let options = RefineOptions {
                        min_angle_deg: angle as f64,
                        domain: RefineDomain::Square,
                        ..RefineOptions::default()
                    };
                    let ways = [
                        ("default", refine_points as fn(&_, &_) -> _),
                        ("ordered", refine_points_in_order),
                    ];
                    for (way, refine) in ways {
                        let run = || pool.install(|| refine(&pts, &options).expect("a mesh"));
                        let (_, report) = run();
                        eprintln!(
                            "{group_name} {way} {angle}°: {n} points, {} triangles ({:.2} per point)",
                            report.triangles,
                            report.triangles as f64 / n as f64
                        );
                        group.bench_function(BenchmarkId::new(format!("{way}/a{angle}"), n), |b| {
                            b.iter_with_large_drop(run)
                        });
                    }
                }
                group.finish();
            }
        }
    }
}

criterion_group!(benches, refine_benches, ordered_benches);
criterion_main!(benches);
