//! Warped meshes of point sets: every mesh passes `Mesh::validate` with the warp's angle bounds,
//! and 1 and 2 threads give the same mesh.

mod common;

use common::{
    FAMILIES, WARP, check_warped, distinct_count, mesh_angles, mixed_point_sets, on_threads,
    refused_beyond_f64,
};
use proptest::prelude::*;
use quadmesh::generate::{self, Distribution2d};
use quadmesh::mesh::AngleBounds;
use quadmesh::{DVec2, Error, Input, Mesh, MeshOptions, MeshReport, Options, mesh_points};

fn mesh_checked(points: &[DVec2]) -> (Mesh, MeshReport) {
    let (mesh, report) = mesh_points(points, &MeshOptions::default()).unwrap();
    check_warped(points, &mesh, &report);
    (mesh, report)
}

#[test]
fn single_point() {
    let points = [DVec2::new(3.0, -2.0)];
    let (mesh, _) = mesh_checked(&points);
    assert_eq!(mesh.vertex_input.iter().filter(|&&i| i == 0).count(), 1);
}

#[test]
fn two_and_three_points() {
    mesh_checked(&[DVec2::new(0.0, 0.0), DVec2::new(1.0, 0.0)]);
    mesh_checked(&[
        DVec2::new(0.0, 0.0),
        DVec2::new(1.0, 0.5),
        DVec2::new(0.25, 0.75),
    ]);
}

#[test]
fn every_family_meshes_validly() {
    for dist in FAMILIES {
        for n in [10, 200, 3000] {
            let points = generate::points(dist, n, 7);
            let (_, report) = mesh_checked(&points);
            assert_eq!(report.points, n, "{dist:?}");
        }
    }
}

#[test]
fn collinear_points() {
    let points: Vec<DVec2> = (0..500).map(|i| DVec2::new(i as f64 * 0.37, 2.0)).collect();
    mesh_checked(&points);
    let diagonal: Vec<DVec2> = (0..500).map(|i| DVec2::splat(i as f64 / 499.0)).collect();
    mesh_checked(&diagonal);
}

#[test]
fn duplicates_are_merged_and_reported() {
    let mut points = generate::points(Distribution2d::Uniform, 400, 3);
    points.extend_from_within(..50);
    let (mesh, report) = mesh_checked(&points);
    assert_eq!(report.duplicates, 50);
    assert_eq!(report.points, 400);
    // The first occurrence is the one kept.
    assert!(mesh.vertex_input.iter().all(|&i| i == u32::MAX || i < 400));
}

#[test]
fn points_closer_than_the_narrow_grid_resolves() {
    // Two points a few narrow-grid quanta apart, far from the rest: their leaves go below the
    // narrow grid's resolution, so the mesh moves to the wide grid.
    let quantum = 2.0 / (1u64 << 28) as f64;
    let mut points = generate::points(Distribution2d::Uniform, 100, 5);
    points.push(DVec2::new(0.5, 0.5));
    points.push(DVec2::new(0.5 + 2.5 * quantum, 0.5));
    mesh_checked(&points);
}

#[test]
fn bad_input_is_a_typed_error() {
    assert_eq!(
        mesh_points(&[], &MeshOptions::default()).unwrap_err(),
        Error::Empty
    );
    let nan = [DVec2::new(0.0, 0.0), DVec2::new(f64::NAN, 1.0)];
    assert!(matches!(
        mesh_points(&nan, &MeshOptions::default()),
        Err(Error::NonFinite { index: 1, .. })
    ));
}

#[test]
fn one_and_two_threads_give_the_same_mesh() {
    for dist in FAMILIES {
        let points = generate::points(dist, 20_000, 11);
        let one = on_threads(1, || {
            mesh_points(&points, &MeshOptions::default()).unwrap().0
        });
        let two = on_threads(2, || {
            mesh_points(&points, &MeshOptions::default()).unwrap().0
        });
        assert!(one == two, "{dist:?}");
    }
}

#[test]
fn validate_catches_a_corrupted_mesh() {
    let points = generate::points(Distribution2d::Uniform, 300, 2);
    let (mesh, _) = mesh_checked(&points);
    let mut flipped = mesh.clone();
    flipped.triangles[7].swap(0, 1);
    assert!(flipped.validate(&points, WARP).is_err());
    let mut moved = mesh.clone();
    let v = moved
        .vertex_input
        .iter()
        .position(|&i| i != u32::MAX)
        .unwrap();
    moved.vertices[v].x = f64::from_bits(moved.vertices[v].x.to_bits() + 1);
    assert!(moved.validate(&points, WARP).is_err());
    let mut rewired = mesh.clone();
    rewired.neighbours[3][0] = rewired.neighbours[3][1];
    assert!(rewired.validate(&points, WARP).is_err());
    let tight = AngleBounds {
        min_deg: 30.0,
        max_deg: 90.0,
    };
    assert!(mesh.validate(&points, tight).is_err());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn random_point_sets_mesh_validly(points in mixed_point_sets()) {
        // Points closer together than f64 can place a mesh between, or the grid can tell
        // apart, at the scale of the square around them, are refused, naming them.
        let options = MeshOptions::default();
        if let Err(error @ (Error::Unresolvable { .. } | Error::Inseparable { .. })) = mesh_points(&points, &options) {
            let (lo, hi) = points.iter().fold((points[0], points[0]), |(lo, hi), &p| (lo.min(p), hi.max(p)));
            let half = (hi - lo).max_element();
            let centre = (lo + hi) / 2.0;
            prop_assert!(
                refused_beyond_f64(&points, &error, centre - half, centre + half),
                "{error}"
            );
            return Ok(());
        }
        let (_, report) = mesh_checked(&points);
        prop_assert_eq!(report.points, distinct_count(&points));
    }
}

/// The example inputs shipped with Triangle's Python package (`pip install triangle`), read from
/// the installed copy when there is one: every `.node` file and every `.poly` file that carries
/// its own vertices meshes validly.
#[test]
fn triangle_package_examples_mesh_validly() {
    let Some(dir) = common::triangle_examples() else {
        eprintln!("Triangle's Python package is not installed; its examples are skipped");
        return;
    };
    let mut meshed = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let extension = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        if extension != "node" && extension != "poly" {
            continue;
        }
        // A .poly file whose vertices live in a .node file is refused with a clear error.
        let Ok(points) = quadmesh::io::read_points(&path) else {
            assert_eq!(extension, "poly", "{}", path.display());
            continue;
        };
        let (mesh, _) = mesh_points(&points, &MeshOptions::default()).unwrap();
        if let Err(fault) = mesh.validate(&points, WARP) {
            panic!("{}: {fault}", path.display());
        }
        // The default mode (the convex hull at 20°) and 30°, each checked Delaunay too.
        for options in [Options::default(), Options::default().min_angle(30.0)] {
            let input = Input::points(points.clone());
            let (mesh, _) = quadmesh::mesh(&input, &options)
                .unwrap_or_else(|e| panic!("{} {options:?}: {e}", path.display()));
            let checked = mesh
                .validate(&points, options.angle_bounds())
                .and_then(|()| mesh.check_delaunay());
            if let Err(fault) = checked {
                panic!("{} {options:?}: {fault}", path.display());
            }
        }
        meshed += 1;
    }
    assert!(meshed > 0, "no examples found in {}", dir.display());
}

/// A single point, worked out by hand. The root is [0, 6] × [-5, 1] (side 2 · max(|centre|, 1)
/// around the point) and the point is its centre, a grid vertex, so nothing warps. Separation
/// splits the root (its block leaves the root), the point's level-1 and level-2 squares with
/// their same-size neighbours (R3b), and stops at level 3, where the point's 5×5 block first fits
/// in the root: the inner 3×3 level-2 squares are split into 36 level-3 leaves (2 triangles
/// each), and the 7 level-2 leaves along the bottom and left are the corner one (no midpoint, 2
/// triangles) and six with one midpoint (3 triangles each): 92 triangles, angles from 26.57°
/// (arctan 1/2) to 90°.
#[test]
fn single_point_mesh_by_hand() {
    let points = [DVec2::new(3.0, -2.0)];
    let (mesh, report) = mesh_checked(&points);
    assert_eq!(mesh.domain.lo, DVec2::new(0.0, -5.0));
    assert_eq!(mesh.domain.hi, DVec2::new(6.0, 1.0));
    assert_eq!(report.triangles, 36 * 2 + 2 + 6 * 3);
    assert!((report.min_angle - 0.5f64.atan().to_degrees()).abs() < 1e-9);
    assert!((report.max_angle - 90.0).abs() < 1e-9);
    let point = mesh.vertex_input.iter().position(|&i| i == 0).unwrap();
    assert_eq!(mesh.vertices[point], points[0]);
}

/// Two points 5e-9 apart at a span of 1000 need leaves whose f64 corners are squares only to
/// some 1e-4 of their side: their templates' angles are off by 0.003°, so the report measures
/// them, and its smallest angle is the mesh's (the property test found this input).
#[test]
fn the_report_measures_leaves_that_rounding_bends() {
    let points = [
        DVec2::new(0.2500009258344418, 0.5),
        DVec2::new(874.2861093044031, 0.0),
        DVec2::new(0.2500009310293854, 0.5),
        DVec2::new(-129.99731019170375, -480.309997512667),
    ];
    let (mesh, report) = mesh_checked(&points);
    let smallest = mesh_angles(&mesh).fold(f64::INFINITY, f64::min);
    assert!(smallest < 0.5f64.atan().to_degrees() - 1e-3, "{smallest}");
    assert_eq!(report.min_angle, smallest);
}

#[test]
fn points_closer_than_f64_can_mesh_between_are_an_error() {
    // Adjacent floats next to a point a unit away: the grid separates them, but the leaves
    // between them would need corners f64 cannot place apart.
    let next = f64::from_bits(1.0f64.to_bits() + 1);
    let points = [
        DVec2::new(0.0, 0.0),
        DVec2::new(1.0, 1.0),
        DVec2::new(next, 1.0),
    ];
    match mesh_points(&points, &MeshOptions::default()) {
        Err(Error::Unresolvable { index, .. }) => assert!(index == 1 || index == 2, "{index}"),
        Err(other) => panic!("unexpected error {other}"),
        Ok((mesh, _)) => panic!(
            "expected an error, got a mesh of {} triangles ({:?})",
            mesh.triangles.len(),
            mesh.validate(&points, WARP)
        ),
    }
}
