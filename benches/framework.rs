//! Framework and quadtree stage benchmarks, on keys already in Morton order.
//!
//! Group `framework/<dist>/t<threads>`, ids `<stage>/<n>` with stage one of
//! * `framework`: [`build_framework`] of the sorted distinct keys;
//! * `expand`: [`expand`] of a framework built beforehand;
//! * `framework+expand`: both, as the pipeline runs them.
//!
//! The keys come from [`morton_order`] (not timed) on whichever grid it picks (with seed 1,
//! cluster and Kuzmin need the wide one already at 2e4 points; the choice is printed to stderr);
//! the same generic code runs on either key width. Throughput is
//! the `n` input points. Sizes come from `QUADMESH_BENCH_SIZES` (comma list, default
//! `100000,1000000`), thread counts from `QUADMESH_BENCH_THREADS` (comma list, default `1,2`);
//! every measurement runs inside a rayon pool of that many threads. Points are generated with
//! seed 1, lazily, so a criterion filter skips the set-up too.
//! `scripts/bench_stages.sh` runs this and `morton` and tabulates ns per point.

mod common;

use common::{DISTRIBUTIONS, SEED, configure, pools, sizes};
use std::cell::OnceCell;

use criterion::{BatchSize, Bencher, BenchmarkId, Criterion, criterion_group, criterion_main};
use quadmesh::framework::{Framework, build_framework};
use quadmesh::generate::{Distribution2d, points};
use quadmesh::morton::{Morton, MortonKey, SortAlgorithm, morton_order};
use quadmesh::quadtree::expand;
use rayon::ThreadPool;

/// What one benchmark times.
#[derive(Clone, Copy)]
enum Stage {
    Framework,
    Expand,
    Both,
}

const STAGES: [(&str, Stage); 3] = [
    ("framework", Stage::Framework),
    ("expand", Stage::Expand),
    ("framework+expand", Stage::Both),
];

/// Sorted distinct keys and their framework.
struct Prepared<K: Copy> {
    keys: Vec<K>,
    framework: Framework<K>,
}

/// [`Prepared`] on the grid [`morton_order`] picked.
enum Keys {
    Narrow(Prepared<u64>),
    Wide(Prepared<u128>),
}

fn prepared<K: MortonKey>(keys: Vec<K>) -> Prepared<K> {
    let framework = build_framework(&keys);
    Prepared { keys, framework }
}

/// The inputs of one (distribution, size), built on first use.
struct Inputs {
    name: &'static str,
    dist: Distribution2d,
    n: usize,
    keys: OnceCell<Keys>,
}

impl Inputs {
    fn keys(&self) -> &Keys {
        self.keys.get_or_init(|| {
            let pts = points(self.dist, self.n, SEED);
            let morton =
                morton_order(&pts, SortAlgorithm::default()).expect("generated points order");
            let (width, keys) = match morton {
                Morton::Narrow(m) => ("narrow (u64)", Keys::Narrow(prepared(m.keys))),
                Morton::Wide(m) => ("wide (u128)", Keys::Wide(prepared(m.keys))),
            };
            let distinct = match &keys {
                Keys::Narrow(p) => p.keys.len(),
                Keys::Wide(p) => p.keys.len(),
            };
            eprintln!(
                "{} n={}: {width} keys, {distinct} distinct",
                self.name, self.n
            );
            keys
        })
    }
}

/// Times `stage` on `input` inside `pool`; outputs are dropped outside the timing.
fn time_stage<K: MortonKey>(
    b: &mut Bencher<'_>,
    pool: &ThreadPool,
    stage: Stage,
    input: &Prepared<K>,
) {
    let keys = &input.keys;
    pool.install(|| match stage {
        Stage::Framework => {
            b.iter_batched(|| (), |()| build_framework(keys), BatchSize::PerIteration)
        }
        Stage::Expand => b.iter_batched(
            || (),
            |()| expand(&input.framework, keys),
            BatchSize::PerIteration,
        ),
        Stage::Both => b.iter_batched(
            || (),
            |()| {
                let framework = build_framework(keys);
                let quadtree = expand(&framework, keys);
                (framework, quadtree)
            },
            BatchSize::PerIteration,
        ),
    })
}

/// Times `stage` on the keys of `inputs`, whichever their width.
fn time_input(b: &mut Bencher<'_>, pool: &ThreadPool, stage: Stage, inputs: &Inputs) {
    match inputs.keys() {
        Keys::Narrow(p) => time_stage(b, pool, stage, p),
        Keys::Wide(p) => time_stage(b, pool, stage, p),
    }
}

fn framework_benches(c: &mut Criterion) {
    let sizes = sizes();
    let pools = pools();
    for (name, dist) in DISTRIBUTIONS {
        let inputs: Vec<Inputs> = sizes
            .iter()
            .map(|&n| Inputs {
                name,
                dist,
                n,
                keys: OnceCell::new(),
            })
            .collect();
        for (t, pool) in &pools {
            let mut group = c.benchmark_group(format!("framework/{name}/t{t}"));
            for inputs in &inputs {
                for (stage_name, stage) in STAGES {
                    configure(&mut group, inputs.n);
                    group.bench_function(BenchmarkId::new(stage_name, inputs.n), |b| {
                        time_input(b, pool, stage, inputs)
                    });
                }
            }
            group.finish();
        }
    }
}

criterion_group!(benches, framework_benches);
criterion_main!(benches);
