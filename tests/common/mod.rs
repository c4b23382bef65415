//! Helpers shared by the integration tests.
#![allow(dead_code, unused_macros, unused_imports)]

use proptest::prelude::*;
use quadmesh::generate::Distribution2d;
use quadmesh::mesh::{AngleBounds, angles_deg};
use quadmesh::warp::{ANGLE_BOUNDS, COMPACT_ANGLE_BOUNDS};
use quadmesh::{DVec2, Error, Mesh, MeshReport};

pub mod graphs;
pub mod peer_cases;

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

/// The angles every warped mesh keeps.
pub const WARP: AngleBounds = AngleBounds {
    min_deg: ANGLE_BOUNDS.0,
    max_deg: ANGLE_BOUNDS.1,
};

/// The compact warp's angle bounds.
#[allow(dead_code)]
pub const COMPACT: AngleBounds = AngleBounds {
    min_deg: COMPACT_ANGLE_BOUNDS.0,
    max_deg: COMPACT_ANGLE_BOUNDS.1,
};

/// Checks a warped mesh of `points` and its report: the mesh passes `Mesh::validate` with the
/// warp's bounds, and the report's counts and angles are the mesh's.
pub fn check_warped(points: &[DVec2], mesh: &Mesh, report: &MeshReport) {
    check_warped_within(points, mesh, report, WARP);
}

/// [`check_warped`] with the angle bounds `bounds`.
pub fn check_warped_within(
    points: &[DVec2],
    mesh: &Mesh,
    report: &MeshReport,
    bounds: AngleBounds,
) {
    if let Err(fault) = mesh.validate(points, bounds) {
        panic!("invalid mesh of {} points: {fault}", points.len());
    }
    assert_eq!(report.triangles, mesh.triangles.len());
    assert_eq!(report.vertices, mesh.vertices.len());
    assert!(
        report.min_angle >= bounds.min_deg - 1e-9,
        "{}",
        report.min_angle
    );
    assert!(
        report.max_angle <= bounds.max_deg + 1e-9,
        "{}",
        report.max_angle
    );
    let angles: u64 = report.histogram.iter().sum();
    assert_eq!(angles, 3 * mesh.triangles.len() as u64);
    assert_report_measures(mesh, report);
}

/// The report's angles, taken from templates and from the diagonals' choice, are those of the
/// mesh's triangles. The templates give the angles of ideal squares, and f64 corners bend the
/// leaves the report takes them for by up to some 0.005° (0.01° on a domain's far side; finer
/// leaves are measured), so its extremes may differ from the measure by up to `TOLERANCE_DEG`,
/// its histogram only by angles that close to a bin's edge.
fn assert_report_measures(mesh: &Mesh, report: &MeshReport) {
    const TOLERANCE_DEG: f64 = 0.01;
    let (mut min, mut max, mut histogram) = (f64::INFINITY, f64::NEG_INFINITY, [0u64; 18]);
    let mut near_edges = 0;
    for angle in mesh_angles(mesh) {
        min = min.min(angle);
        max = max.max(angle);
        histogram[((angle / 10.0) as usize).min(17)] += 1;
        let edge = (angle / 10.0).round() * 10.0;
        near_edges += u64::from((angle - edge).abs() < TOLERANCE_DEG);
    }
    let close = |reported: f64, measured: f64| (reported - measured).abs() < TOLERANCE_DEG;
    assert!(close(report.min_angle, min), "{} {min}", report.min_angle);
    assert!(close(report.max_angle, max), "{} {max}", report.max_angle);
    let moved: u64 = (report.histogram.iter().zip(histogram))
        .map(|(&r, m)| r.abs_diff(m))
        .sum();
    assert!(
        moved <= 2 * near_edges,
        "report {:?}, measured {histogram:?}",
        report.histogram
    );
}

/// The report's smallest and largest angle are the mesh's, measured, to 0.01° (where the report
/// takes a leaf's angles from its template, rounding bends them by less).
pub fn assert_report_extremes(mesh: &Mesh, report: &MeshReport) {
    let (lo, hi) = mesh_angles(mesh).fold((f64::INFINITY, 0.0f64), |(lo, hi), a| {
        (lo.min(a), hi.max(a))
    });
    assert!(
        (report.min_angle - lo).abs() < 0.01,
        "{} {lo}",
        report.min_angle
    );
    assert!(
        (report.max_angle - hi).abs() < 0.01,
        "{} {hi}",
        report.max_angle
    );
}

/// Every angle of every triangle of `mesh`, in degrees, measured on its f64 vertices.
pub fn mesh_angles(mesh: &Mesh) -> impl Iterator<Item = f64> + '_ {
    mesh.triangles.iter().flat_map(|t| {
        let [a, b, c] = t.map(|v| mesh.vertices[v as usize]);
        angles_deg(a, b, c)
    })
}

/// Whether another point lies closer to point `index` than 2^-30 of the extent of the domain
/// `lo..hi`: the mesh's leaves there need about a 2^-40 of it, where f64 rounds vertices by
/// 2^-52 of it, so `Error::Unresolvable` naming that point is the right answer.
pub fn beyond_f64(points: &[DVec2], index: usize, lo: DVec2, hi: DVec2) -> bool {
    let p = points[index];
    points
        .iter()
        .any(|&q| q != p && closer_than_f64_resolves(p, q, lo, hi))
}

/// Whether `p` and `q` lie closer together than 2^-30 of the extent of the domain `lo..hi` (see
/// [`beyond_f64`]).
fn closer_than_f64_resolves(p: DVec2, q: DVec2, lo: DVec2, hi: DVec2) -> bool {
    let extent = (hi - lo).max_element().max(lo.abs().max_element());
    (q - p).abs().max_element() < extent * (2.0f64).powi(-30)
}

/// Whether `error` is the right refusal of points too close together for f64 at the scale of
/// the domain `lo..hi`: `Unresolvable` naming a point that has another that close, or
/// `Inseparable` naming two distinct points that close (the grid's coordinates, worked out in
/// f64 at that scale, cannot tell them apart).
pub fn refused_beyond_f64(points: &[DVec2], error: &Error, lo: DVec2, hi: DVec2) -> bool {
    match *error {
        Error::Unresolvable { index, .. } => beyond_f64(points, index, lo, hi),
        Error::Inseparable { a, b, .. } => {
            let (p, q) = (points[a], points[b]);
            p != q && closer_than_f64_resolves(p, q, lo, hi)
        }
        _ => false,
    }
}

/// 128-bit key sets at the edges of the key space: the finest level at the corners, and chains
/// of squares from the root down to the finest level at both ends (sorted, distinct).
pub fn extreme_wide_keys() -> Vec<Vec<u128>> {
    vec![
        vec![0, 1],
        vec![0, u128::MAX],
        vec![u128::MAX - 1, u128::MAX],
        vec![0, 1, u128::MAX - 1, u128::MAX],
        std::iter::once(0)
            .chain((0..64).map(|k| 1u128 << (2 * k)))
            .collect(),
        (0..64)
            .map(|k| u128::MAX - (1u128 << (2 * k)))
            .rev()
            .chain([u128::MAX])
            .collect(),
    ]
}

/// The convex hull of `points`, counter-clockwise, collinear points left out: a monotone chain
/// of the tests' own, independent of the library's.
pub fn convex_hull(points: &[DVec2]) -> Vec<DVec2> {
    let mut p = points.to_vec();
    p.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    p.dedup();
    let cross = |o: DVec2, a: DVec2, b: DVec2| (a - o).perp_dot(b - o);
    let mut hull: Vec<DVec2> = Vec::new();
    for pass in [p.clone(), p.iter().rev().copied().collect()] {
        let start = hull.len();
        for q in pass {
            while hull.len() >= start + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], q) <= 0.0
            {
                hull.pop();
            }
            hull.push(q);
        }
        hull.pop();
    }
    hull
}

/// The area of a counter-clockwise polygon.
pub fn polygon_area(corners: &[DVec2]) -> f64 {
    (0..corners.len())
        .map(|k| 0.5 * corners[k].perp_dot(corners[(k + 1) % corners.len()]))
        .sum()
}

/// The summed area of a mesh's triangles.
pub fn mesh_area(m: &Mesh) -> f64 {
    m.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| m.vertices[v as usize]);
            0.5 * (b - a).perp_dot(c - a)
        })
        .sum()
}

/// The corners of a convex counter-clockwise polygon narrower than `min_deg`.
pub fn narrow_corners(convex: &[DVec2], min_deg: f64) -> Vec<DVec2> {
    let n = convex.len();
    (0..n)
        .filter(|&k| {
            let (a, b) = (
                convex[(k + 1) % n] - convex[k],
                convex[(k + n - 1) % n] - convex[k],
            );
            a.perp_dot(b).atan2(a.dot(b)).to_degrees() < min_deg
        })
        .map(|k| convex[k])
        .collect()
}

/// The folder of example inputs that Triangle's Python package (`pip install triangle`) ships,
/// when it is installed; the tests read them there and never copy them.
pub fn triangle_examples() -> Option<std::path::PathBuf> {
    let found = std::process::Command::new("python3")
        .args([
            "-c",
            "import os, triangle; print(os.path.join(os.path.dirname(triangle.__file__), 'data'))",
        ])
        .output();
    let dir = found
        .ok()
        .filter(|out| out.status.success())
        .map(|out| String::from_utf8_lossy(&out.stdout).trim().into());
    // CI sets this where the package installed: there the tests must run, not skip.
    if dir.is_none() && std::env::var_os("QUADMESH_REQUIRE_TRIANGLE").is_some() {
        panic!("QUADMESH_REQUIRE_TRIANGLE is set but `import triangle` fails in python3");
    }
    dir
}
