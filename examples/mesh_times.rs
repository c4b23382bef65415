//! Meshes generated points and prints the report: `mesh_times DIST N THREADS [REPEATS]`.

#[cfg(feature = "mimalloc")]
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

use quadmesh::generate::{self, Distribution2d};
use quadmesh::{MeshOptions, mesh_points};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let dist: Distribution2d = args[1].parse().expect("distribution");
    let n: usize = args[2].parse().expect("count");
    let threads: usize = args[3].parse().expect("threads");
    let repeats: usize = args.get(4).map_or(1, |r| r.parse().expect("repeats"));
    let points = generate::points(dist, n, 1);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("pool");
    for _ in 0..repeats {
        let (_mesh, report) = pool
            .install(|| mesh_points(&points, &MeshOptions::default()))
            .expect("mesh");
        let stages: Vec<String> = report
            .stages
            .iter()
            .map(|(s, d)| format!("{s} {:.3}", d.as_secs_f64()))
            .collect();
        println!(
            "{n} {dist:?} t{threads}: total {:.3} s [{}] vertices {} triangles {} ({:.1}/pt) angles {:.2}..{:.2}",
            report.total().as_secs_f64(),
            stages.join(", "),
            report.vertices,
            report.triangles,
            report.triangles as f64 / n as f64,
            report.min_angle,
            report.max_angle
        );
    }
}
