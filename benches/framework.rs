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

/// Stages allocate large arrays; an allocator that keeps freed memory spares each iteration the
/// page faults of fresh memory, as it would in a long-running user.
#[cfg(feature = "mimalloc")]
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

use std::cell::OnceCell;
use std::time::Duration;

use criterion::measurement::WallTime;
use criterion::{
    BatchSize, Bencher, BenchmarkGroup, BenchmarkId, Criterion, SamplingMode, Throughput,
    criterion_group, criterion_main,
};
use quadmesh::framework::{Framework, build_framework};
use quadmesh::generate::{Distribution2d, points};
use quadmesh::morton::{Morton, MortonKey, SortAlgorithm, morton_order};
use quadmesh::quadtree::expand;
use rayon::ThreadPool;

const SEED: u64 = 1;

const DISTRIBUTIONS: [(&str, Distribution2d); 3] = [
    ("uniform", Distribution2d::Uniform),
    ("cluster", Distribution2d::Cluster),
    ("kuzmin", Distribution2d::Kuzmin),
];

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

/// A comma list of counts from `var` (`_` separators and `1e6` notation allowed), or `default`.
fn env_counts(var: &str, default: &str) -> Vec<usize> {
    let raw = std::env::var(var).unwrap_or_else(|_| default.to_string());
    let counts: Vec<usize> = raw
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| {
            let s = s.replace('_', "");
            s.parse::<usize>()
                .ok()
                .or_else(|| {
                    s.parse::<f64>()
                        .ok()
                        .filter(|v| *v >= 1.0 && v.fract() == 0.0)
                        .map(|v| v as usize)
                })
                .filter(|&v| v > 0)
                .unwrap_or_else(|| panic!("{var}: '{s}' is not a positive count"))
        })
        .collect();
    assert!(!counts.is_empty(), "{var} names no counts");
    counts
}

fn sizes() -> Vec<usize> {
    env_counts("QUADMESH_BENCH_SIZES", "100000,1000000")
}

fn pools() -> Vec<(usize, ThreadPool)> {
    env_counts("QUADMESH_BENCH_THREADS", "1,2")
        .into_iter()
        .map(|t| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .expect("rayon pool");
            (t, pool)
        })
        .collect()
}

/// Target measurement time: a few seconds, growing with `n` but capped so that, with flat
/// sampling of 10 samples, a 1e7-point benchmark stays near 20 s (an iteration that alone takes
/// longer than 0.8 s runs once per sample: 10 iterations).
fn measurement_time(n: usize) -> Duration {
    Duration::from_secs_f64((2.0 + 0.6 * n as f64 / 1e6).min(8.0))
}

/// Settings for the next benchmark of `group`, on `n` points.
fn configure(group: &mut BenchmarkGroup<'_, WallTime>, n: usize) {
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(measurement_time(n))
        .throughput(Throughput::Elements(n as u64));
}

/// Sorted distinct keys and their framework.
struct Prepared<K> {
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
