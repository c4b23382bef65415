//! Times filling arrays the size of a mesh's output (vertices as `[f64; 2]` and `u32` input
//! indices, triangles and neighbours as `[u32; 3]`) in parallel, first in fresh memory, then in
//! memory freed just before: the least a mesher that returns them can take on this machine.
//! `cargo run --release --features mimalloc --example fresh_memory -- [VERTICES] [TRIANGLES]
//! [THREADS]` (defaults: the compact warp's 17 791 101 and 35 582 168 at 1e6 uniform points, 2).
//!
//! On a virtual machine whose host backs guest memory lazily, fresh pages can cost ten times what
//! reused ones do, and more when the pages were freed a few seconds before (returned to the
//! host); run it right after the mesher to see both.

#[cfg(feature = "mimalloc")]
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

use std::time::Instant;

use rayon::prelude::*;

/// `n` copies of `value`, written in parallel into one new vector.
fn filled<T: Copy + Send + Sync>(n: usize, value: T) -> Vec<T> {
    (0..n).into_par_iter().map(|_| value).collect()
}

/// A mesh's arrays: vertices, their input indices, triangles and neighbours, all `fill`.
type Output = (Vec<[f64; 2]>, Vec<u32>, Vec<[u32; 3]>, Vec<[u32; 3]>);

fn output(vertices: usize, triangles: usize, fill: u32) -> Output {
    (
        filled(vertices, [f64::from(fill); 2]),
        filled(vertices, fill),
        filled(triangles, [fill; 3]),
        filled(triangles, [fill; 3]),
    )
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let arg = |i: usize, default: usize| args.get(i).map_or(default, |s| s.parse().expect("count"));
    let (vertices, triangles, threads) = (arg(1, 17_791_101), arg(2, 35_582_168), arg(3, 2));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool");
    pool.install(|| {
        let start = Instant::now();
        let mesh = output(vertices, triangles, 1);
        let fresh = start.elapsed().as_secs_f64();
        let bytes = vertices * 20 + triangles * 24;
        drop(mesh);
        let start = Instant::now();
        let again = output(vertices, triangles, 3);
        let reused = start.elapsed().as_secs_f64();
        assert_eq!(again.2[triangles / 2], [3; 3]);
        println!(
            "{{\"threads\":{threads},\"bytes\":{bytes},\"fresh_s\":{fresh:.4},\"reused_s\":{reused:.4}}}"
        );
    });
}
