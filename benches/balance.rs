//! Balance (closure, leaves, cross links, point location) and well-separation benchmarks, on
//! the unbalanced tree built beforehand.
//!
//! Group `balance/<dist>/t<threads>`, id `balance/<n>` (and `separate/<n>` for sizes up to
//! `QUADMESH_BENCH_SEPARATE_MAX`, default 1e5). Throughput is the number of output leaves, so
//! criterion's rate is leaves per second; the unbalanced tree, the keys and the output sizes are
//! printed to stderr. Sizes and threads come from the same variables as the other benches.
//!
//! Each iteration's output is dropped outside the timing, and mimalloc hands large freed arrays
//! back to the kernel a second after the free, so iterations that take about that long or more
//! pay for fresh pages (how many varies with timing, and on a virtual machine that reports free
//! memory to its host, how much each costs). `MIMALLOC_PURGE_DELAY=-1` keeps them for reuse
//! instead, which times the algorithm without the kernel's page clearing.
//!
//! Sampling is flat, so the time criterion prints is the mean of the iterations;
//! `scripts/bench_stages.sh --table-only` prints the medians of the results on disk.

mod common;

use common::{DISTRIBUTIONS, SEED, configure, env_counts, pools, sizes};
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use quadmesh::balance::{BalancedTree, balance, separate};
use quadmesh::framework::build_framework;
use quadmesh::generate::points;
use quadmesh::morton::{Morton, MortonKey, SortAlgorithm, morton_order};
use quadmesh::quadtree::{Quadtree, expand};
use rayon::ThreadPool;

type Refine<K> = fn(&Quadtree<K>, &[K]) -> BalancedTree<K>;

fn bench_refinement<K: MortonKey>(
    c: &mut Criterion,
    name: &str,
    refine: Refine<K>,
    keys: &[K],
    group_name: &str,
    pool: &ThreadPool,
) {
    let tree = expand(&build_framework(keys), keys);
    let leaves = pool.install(|| refine(&tree, keys)).tree.leaves.len();
    eprintln!(
        "{group_name} {name}: {} points, {leaves} leaves",
        keys.len()
    );
    let mut group = c.benchmark_group(group_name);
    configure(&mut group, keys.len());
    group.throughput(Throughput::Elements(leaves as u64));
    group.bench_function(BenchmarkId::new(name, keys.len()), |b| {
        b.iter_with_large_drop(|| pool.install(|| refine(&tree, keys)))
    });
    group.finish();
}

fn run<K: MortonKey>(c: &mut Criterion, keys: &[K], dist: &str, separate_max: usize) {
    for (threads, pool) in pools() {
        let group = format!("balance/{dist}/t{threads}");
        bench_refinement(c, "balance", balance::<K>, keys, &group, &pool);
        if keys.len() <= separate_max {
            bench_refinement(c, "separate", separate::<K>, keys, &group, &pool);
        }
    }
}

fn balance_benches(c: &mut Criterion) {
    let separate_max = env_counts("QUADMESH_BENCH_SEPARATE_MAX", "100000")[0];
    for n in sizes() {
        for (dist_name, dist) in DISTRIBUTIONS {
            let pts = points(dist, n, SEED);
            match morton_order(&pts, SortAlgorithm::default()).expect("generated points are valid")
            {
                Morton::Narrow(m) => run(c, &m.keys, dist_name, separate_max),
                Morton::Wide(m) => run(c, &m.keys, dist_name, separate_max),
            }
        }
    }
}

criterion_group!(benches, balance_benches);
criterion_main!(benches);
