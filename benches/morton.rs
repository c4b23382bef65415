//! Morton stage benchmarks.
//!
//! * `morton/<dist>/t<threads>`: quantize + encode + sort + merge, end to end, through
//!   [`morton_order`], once per [`SortAlgorithm`]. When the narrow grid cannot separate the
//!   points, `morton_order` runs again on the wide one and both passes are timed; with seed 1
//!   that happens for cluster and Kuzmin already at 2e4 points.
//! * `sort64/<dist>/t<threads>`: the bare sort of pre-encoded narrow (u64) pairs, per algorithm
//!   (for cluster and Kuzmin these hold the equal keys the narrow pass would find).
//! * `sort128/kuzmin/t<threads>`: the same for wide (u128) pairs of the Kuzmin points.
//!
//! Ids are `<algorithm>/<n>`; throughput is `n` points. Sizes come from `QUADMESH_BENCH_SIZES`
//! (comma list, default `100000,1000000`), thread counts from `QUADMESH_BENCH_THREADS` (comma
//! list, default `1,2`); every measurement runs inside a rayon pool of that many threads.
//! Points are generated with seed 1, lazily, so a criterion filter skips the set-up too.
//! `scripts/bench_stages.sh` runs this and `framework` and tabulates ns per point.

mod common;

use common::{DISTRIBUTIONS, SEED, configure, pools, sizes};
use std::cell::OnceCell;

use criterion::measurement::WallTime;
use criterion::{
    BatchSize, BenchmarkGroup, BenchmarkId, Criterion, criterion_group, criterion_main,
};
use quadmesh::DVec2;
use quadmesh::generate::{Distribution2d, points};
use quadmesh::morton::{Grid, MortonKey, Pair, SortAlgorithm, bounding_box, morton_order};
use rayon::ThreadPool;
use rayon::prelude::*;

const ALGORITHMS: [(&str, SortAlgorithm); 3] = [
    ("radsort", SortAlgorithm::Radsort),
    ("voracious", SortAlgorithm::Voracious),
    ("rayon_unstable", SortAlgorithm::RayonUnstable),
];

/// The inputs of one (distribution, size), built on first use.
struct Inputs {
    dist: Distribution2d,
    n: usize,
    points: OnceCell<Vec<DVec2>>,
    narrow: OnceCell<Vec<Pair<u64>>>,
    wide: OnceCell<Vec<Pair<u128>>>,
}

impl Inputs {
    fn new(dist: Distribution2d, n: usize) -> Self {
        Inputs {
            dist,
            n,
            points: OnceCell::new(),
            narrow: OnceCell::new(),
            wide: OnceCell::new(),
        }
    }

    fn points(&self) -> &[DVec2] {
        self.points.get_or_init(|| points(self.dist, self.n, SEED))
    }

    fn narrow(&self) -> &[Pair<u64>] {
        self.narrow.get_or_init(|| encode(self.points()))
    }

    fn wide(&self) -> &[Pair<u128>] {
        self.wide.get_or_init(|| encode(self.points()))
    }
}

/// The (key, index) pairs of `points` in input order, on the grid [`morton_order`] would use for
/// keys of type `K` (the root square around their bounding box).
fn encode<K: MortonKey>(points: &[DVec2]) -> Vec<Pair<K>> {
    let (lo, hi) = bounding_box(points);
    let grid = Grid::around(lo, hi, K::AXIS_BITS).expect("generated points fit a grid");
    points
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            let (x, y) = grid.quantize(*p);
            Pair::new(K::encode(x, y), i as u32)
        })
        .collect()
}

/// Times sorting fresh clones of `pairs` (the clone is not timed) on `pool`.
fn bench_sort<K: MortonKey>(
    group: &mut BenchmarkGroup<'_, WallTime>,
    pool: &ThreadPool,
    inputs: &Inputs,
    pairs: fn(&Inputs) -> &[Pair<K>],
) {
    for (name, algorithm) in ALGORITHMS {
        configure(group, inputs.n);
        group.bench_function(BenchmarkId::new(name, inputs.n), |b| {
            let pairs = pairs(inputs);
            pool.install(|| {
                b.iter_batched(
                    || pairs.to_vec(),
                    |mut v| {
                        K::sort_pairs(&mut v, algorithm);
                        v
                    },
                    BatchSize::LargeInput,
                )
            })
        });
    }
}

fn morton_benches(c: &mut Criterion) {
    let sizes = sizes();
    let pools = pools();
    for (dist_name, dist) in DISTRIBUTIONS {
        let inputs: Vec<Inputs> = sizes.iter().map(|&n| Inputs::new(dist, n)).collect();
        for (t, pool) in &pools {
            let mut group = c.benchmark_group(format!("morton/{dist_name}/t{t}"));
            for inputs in &inputs {
                for (name, algorithm) in ALGORITHMS {
                    configure(&mut group, inputs.n);
                    group.bench_function(BenchmarkId::new(name, inputs.n), |b| {
                        let points = inputs.points();
                        pool.install(|| {
                            b.iter_batched(
                                || (),
                                |()| {
                                    morton_order(points, algorithm).expect("generated points order")
                                },
                                BatchSize::PerIteration,
                            )
                        })
                    });
                }
            }
            group.finish();

            let mut group = c.benchmark_group(format!("sort64/{dist_name}/t{t}"));
            for inputs in &inputs {
                bench_sort(&mut group, pool, inputs, Inputs::narrow);
            }
            group.finish();

            if dist == Distribution2d::Kuzmin {
                let mut group = c.benchmark_group(format!("sort128/{dist_name}/t{t}"));
                for inputs in &inputs {
                    bench_sort(&mut group, pool, inputs, Inputs::wide);
                }
                group.finish();
            }
        }
    }
}

criterion_group!(benches, morton_benches);
criterion_main!(benches);
