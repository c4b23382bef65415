//! Helpers shared by the integration tests.
#![allow(dead_code, unused_macros, unused_imports)]

use quadmesh::generate::Distribution2d;

/// Every generated input family.
pub const FAMILIES: [Distribution2d; 4] = [
    Distribution2d::Uniform,
    Distribution2d::Cluster,
    Distribution2d::Kuzmin,
    Distribution2d::Grid,
];

/// Runs `f` on a rayon pool of `threads` threads.
pub fn on_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

/// Runs the generic function `$f` on the Morton keys of `$pts`, on whichever grid they need.
macro_rules! with_keys {
    ($pts:expr, $f:ident) => {
        match quadmesh::morton::morton_order(&$pts, quadmesh::morton::SortAlgorithm::default())
            .unwrap()
        {
            quadmesh::morton::Morton::Narrow(m) => $f(&m.keys),
            quadmesh::morton::Morton::Wide(m) => $f(&m.keys),
        }
    };
}
pub(crate) use with_keys;
