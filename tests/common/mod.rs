//! Helpers shared by the integration tests.
#![allow(dead_code, unused_macros, unused_imports)]

use proptest::prelude::*;
use quadmesh::DVec2;
use quadmesh::generate::Distribution2d;

/// Every generated input family.
pub const FAMILIES: [Distribution2d; 4] = Distribution2d::ALL;

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

/// Small point sets mixing free coordinates, coordinates on a coarse grid (points on the
/// dyadic lines and corners of the quadtree), collinear runs, points very close together (the
/// wide grid) and exact duplicates.
pub fn mixed_point_sets() -> impl Strategy<Value = Vec<DVec2>> {
    let free = (-1e3f64..1e3, -1e3f64..1e3).prop_map(|(x, y)| DVec2::new(x, y));
    let on_grid =
        (0u8..=16, 0u8..=16).prop_map(|(i, j)| DVec2::new(i as f64 / 16.0, j as f64 / 16.0));
    let on_line = (0.0f64..1.0).prop_map(|t| DVec2::new(t, 0.25));
    let near = (0.0f64..1e-6).prop_map(|v| DVec2::new(0.25 + v, 0.5));
    let point = prop_oneof![free, on_grid, on_line, near];
    (prop::collection::vec(point, 1..60), 0usize..10).prop_map(|(mut pts, copies)| {
        let copies = copies.min(pts.len());
        pts.extend_from_within(..copies);
        pts
    })
}

/// How many distinct points there are (0.0 and -0.0 are the same coordinate).
pub fn distinct_count(points: &[DVec2]) -> usize {
    let distinct: std::collections::HashSet<(u64, u64)> = points
        .iter()
        .map(|p| ((p.x + 0.0).to_bits(), (p.y + 0.0).to_bits()))
        .collect();
    distinct.len()
}
