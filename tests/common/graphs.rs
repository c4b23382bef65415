//! Graphs made for the tests of the graph stages: Delaunay triangulations of random points
//! (almost every wedge acute), fans of spokes and thin triangles.

use quadmesh::{DVec2, Input, Segment};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use spade::{DelaunayTriangulation, Point2, Triangulation};

/// A segment with marker 1.
pub fn segment(ends: [u32; 2]) -> Segment {
    Segment { ends, marker: 1 }
}

/// The edges of the Delaunay triangulation of `n` random points, as a graph: almost every wedge
/// acute.
pub fn delaunay_graph(n: usize, seed: u64) -> Input {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let points: Vec<DVec2> = (0..n)
        .map(|_| DVec2::new(rng.random(), rng.random()))
        .collect();
    let dt = DelaunayTriangulation::<Point2<f64>>::bulk_load_stable(
        points.iter().map(|p| Point2::new(p.x, p.y)).collect(),
    )
    .expect("a triangulation");
    let segments = dt
        .undirected_edges()
        .map(|e| {
            let [a, b] = e.vertices();
            segment([a.index() as u32, b.index() as u32])
        })
        .collect();
    Input {
        points,
        segments,
        ..Input::default()
    }
}

/// Spokes from the origin to a ring of `k` points, the ring closed, and loose points around.
pub fn fan(k: usize) -> Input {
    let mut points = vec![DVec2::ZERO];
    let mut segments = Vec::new();
    for i in 0..k {
        let a = std::f64::consts::TAU * i as f64 / k as f64;
        points.push(DVec2::new(a.cos(), a.sin()) * (1.0 + 0.1 * (i % 3) as f64));
        segments.push(segment([0, i as u32 + 1]));
        segments.push(segment([i as u32 + 1, (i + 1) as u32 % k as u32 + 1]));
    }
    points.extend([DVec2::new(3.0, 0.5), DVec2::new(-2.5, 2.5)]);
    Input {
        points,
        segments,
        ..Input::default()
    }
}

/// A thin triangle with an angle of `degrees` at the origin, a segment passing near its tip and
/// a point beside it.
pub fn sliver(degrees: f64) -> Input {
    let a = degrees.to_radians();
    let points = vec![
        DVec2::ZERO,
        DVec2::new(10.0, 0.0),
        DVec2::new(10.0 * a.cos(), 10.0 * a.sin()),
        DVec2::new(-0.5, -1.0),
        DVec2::new(-0.5, 1.0),
        DVec2::new(4.0, 2.0),
    ];
    Input {
        points,
        segments: vec![
            segment([0, 1]),
            segment([1, 2]),
            segment([2, 0]),
            segment([3, 4]),
        ],
        ..Input::default()
    }
}
