//! Prints the time of each tree stage for generated points, in ns per point:
//! `cargo run --release --example stage_times -- uniform 10000000 2 [repeats] [voracious|radsort|rayon]`.

/// As in the CLI: an allocator that reuses freed memory.
#[cfg(feature = "mimalloc")]
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

use quadmesh::build_tree;
use quadmesh::generate::{Distribution2d, points};
use quadmesh::morton::SortAlgorithm;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let dist: Distribution2d = args
        .get(1)
        .map_or("uniform", |s| s.as_str())
        .parse()
        .expect("distribution");
    let n: usize = args
        .get(2)
        .map_or(1_000_000, |s| s.parse().expect("point count"));
    let threads: usize = args.get(3).map_or(2, |s| s.parse().expect("thread count"));
    let repeats: usize = args.get(4).map_or(5, |s| s.parse().expect("repeat count"));
    let sort = match args.get(5).map(|s| s.as_str()) {
        Some("radsort") => SortAlgorithm::Radsort,
        Some("rayon") => SortAlgorithm::RayonUnstable,
        _ => SortAlgorithm::Voracious,
    };
    let pts = points(dist, n, 1);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool");
    for _ in 0..repeats {
        let (tree, times) = pool.install(|| build_tree(&pts, sort)).expect("tree");
        let per_point: Vec<String> = times
            .0
            .iter()
            .map(|(stage, d)| format!("{stage} {:.1}", d.as_secs_f64() * 1e9 / n as f64))
            .collect();
        let leaves = match &tree {
            quadmesh::Tree::Narrow(b) => b.quadtree.leaves.len(),
            quadmesh::Tree::Wide(b) => b.quadtree.leaves.len(),
        };
        println!(
            "{dist:?} n={n} t={threads} ns/pt: {} total {:.1} leaves/pt {:.2}",
            per_point.join(" "),
            times.total().as_secs_f64() * 1e9 / n as f64,
            leaves as f64 / n as f64
        );
    }
}
