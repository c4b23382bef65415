//! Settings and inputs shared by the bench binaries.
#![allow(dead_code)]

use std::time::Duration;

use criterion::measurement::WallTime;
use criterion::{BenchmarkGroup, SamplingMode, Throughput};
use quadmesh::generate::Distribution2d;
use rayon::ThreadPool;

/// Stages allocate large arrays; an allocator that keeps freed memory spares each iteration the
/// page faults of fresh memory, as it would in a long-running user.
#[cfg(feature = "mimalloc")]
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// The seed of every generated input.
pub const SEED: u64 = 1;

/// The distributions every bench runs on.
pub const DISTRIBUTIONS: [(&str, Distribution2d); 3] = [
    ("uniform", Distribution2d::Uniform),
    ("cluster", Distribution2d::Cluster),
    ("kuzmin", Distribution2d::Kuzmin),
];

/// A comma list of counts from `var` (`_` separators and `1e6` notation allowed), or `default`.
pub fn env_counts(var: &str, default: &str) -> Vec<usize> {
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

pub fn sizes() -> Vec<usize> {
    env_counts("QUADMESH_BENCH_SIZES", "100000,1000000")
}

pub fn pools() -> Vec<(usize, ThreadPool)> {
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
pub fn measurement_time(n: usize) -> Duration {
    Duration::from_secs_f64((2.0 + 0.6 * n as f64 / 1e6).min(8.0))
}

/// Settings for the next benchmark of `group`, on `n` points.
pub fn configure(group: &mut BenchmarkGroup<'_, WallTime>, n: usize) {
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(measurement_time(n))
        .throughput(Throughput::Elements(n as u64));
}
