//! Prints the time of each tree stage for generated points, in ns per input point:
//! `cargo run --release --example stage_times -- DIST N THREADS [REPEATS] [unbalanced|balanced|separated]
//! [voracious|radsort|rayon]`.

/// As in the CLI: an allocator that reuses freed memory.
#[cfg(feature = "mimalloc")]
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

use quadmesh::generate::{Distribution2d, points};
use quadmesh::morton::SortAlgorithm;
use quadmesh::{Refinement, Tree, TreeOptions, build_tree};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let arg = |i: usize, default: &str| args.get(i).cloned().unwrap_or_else(|| default.to_string());
    let dist: Distribution2d = arg(1, "uniform").parse().expect("distribution");
    let n: usize = arg(2, "1000000").parse().expect("point count");
    let threads: usize = arg(3, "2").parse().expect("thread count");
    let repeats: usize = arg(4, "5").parse().expect("repeat count");
    let refinement = match arg(5, "unbalanced").as_str() {
        "balanced" => Refinement::Balanced,
        "separated" => Refinement::Separated,
        _ => Refinement::Unbalanced,
    };
    let sort = match arg(6, "voracious").as_str() {
        "radsort" => SortAlgorithm::Radsort,
        "rayon" => SortAlgorithm::RayonUnstable,
        _ => SortAlgorithm::Voracious,
    };
    let options = TreeOptions { sort, refinement };
    let pts = points(dist, n, 1);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool");
    for _ in 0..repeats {
        let (tree, times) = pool.install(|| build_tree(&pts, &options)).expect("tree");
        let leaves = match &tree {
            Tree::Narrow(b) => b.final_tree().leaves.len(),
            Tree::Wide(b) => b.final_tree().leaves.len(),
        };
        let per_point: Vec<String> = times
            .0
            .iter()
            .map(|(stage, d)| format!("{stage} {:.1}", d.as_secs_f64() * 1e9 / n as f64))
            .collect();
        println!(
            "{dist:?} n={n} t={threads} ns/pt: {} total {:.1} leaves/pt {:.2}",
            per_point.join(" "),
            times.total().as_secs_f64() * 1e9 / n as f64,
            leaves as f64 / n as f64
        );
    }
}
