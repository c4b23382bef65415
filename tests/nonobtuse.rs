//! Nonobtuse meshes of point sets: every mesh passes `Mesh::validate_nonobtuse` (every angle at
//! most 90° up to the rounding of its vertices), on every family, on grid-aligned, collinear and
//! domain-touching inputs, for every place of a point in its leaf; 1 and 2 threads give the same
//! mesh; the split's count stays within ten triangles per point of the warped mesh of the same
//! tree, and its coarsening keeps every input point, makes no angle under 20°, and takes
//! triangles away.

mod common;

use common::{FAMILIES, assert_report_extremes, mixed_point_sets, on_threads};
use proptest::prelude::*;
use quadmesh::generate::{self, Distribution2d};
use quadmesh::mesh::{Domain, angles_deg};
use quadmesh::warp::NONOBTUSE_COARSE_BOUNDS;
use quadmesh::{DVec2, Input, Mesh, MeshOptions, MeshReport, Mode, Options, Region, mesh_points};
use std::collections::HashSet;

/// The nonobtuse split's options.
fn nonobtuse(domain: Option<Domain>) -> MeshOptions {
    MeshOptions {
        domain,
        nonobtuse: true,
        ..MeshOptions::default()
    }
}

/// The coarsened nonobtuse mesh's options (the nonobtuse mode's).
fn coarsened(domain: Option<Domain>) -> MeshOptions {
    MeshOptions {
        coarsen: true,
        ..nonobtuse(domain)
    }
}

/// Triangle `t` of `mesh` by its corners' coordinates, from the least corner on.
fn corner_key(mesh: &Mesh, t: &[u32; 3]) -> [[u64; 2]; 3] {
    let k = t.map(|v| {
        let p = mesh.vertices[v as usize];
        [p.x.to_bits(), p.y.to_bits()]
    });
    let first = (0..3).min_by_key(|&i| k[i]).unwrap();
    [k[first], k[(first + 1) % 3], k[(first + 2) % 3]]
}

/// The coarsened nonobtuse mesh of `points`, checked against the split `split` of the same
/// points: valid, no more triangles, and in every triangle the split lacks no angle under the
/// coarsening's bound nor over 90° by more than 1e-5° (rounding, however loose the check's
/// allowance for small triangles in a large domain).
fn coarsened_checked(points: &[DVec2], domain: Option<Domain>, split: &Mesh) -> Mesh {
    let (mesh, report) = mesh_points(points, &coarsened(domain)).unwrap();
    if let Err(fault) = mesh.validate_nonobtuse(points) {
        panic!(
            "invalid coarsened nonobtuse mesh of {} points: {fault}",
            points.len()
        );
    }
    assert_eq!(report.triangles, mesh.triangles.len());
    assert_report_extremes(&mesh, &report);
    assert!(mesh.triangles.len() <= split.triangles.len());
    let kept: HashSet<_> = split
        .triangles
        .iter()
        .map(|t| corner_key(split, t))
        .collect();
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|v| mesh.vertices[v as usize]);
        if kept.contains(&corner_key(&mesh, t)) {
            continue;
        }
        let angles = angles_deg(a, b, c);
        let smallest = angles.into_iter().fold(180.0, f64::min);
        let largest = angles.into_iter().fold(0.0, f64::max);
        assert!(
            smallest >= NONOBTUSE_COARSE_BOUNDS.0 - 1e-9 && largest <= 90.0 + 1e-5,
            "a new triangle {a} {b} {c} with angles {angles:?}"
        );
    }
    mesh
}

/// The nonobtuse mesh of `points`, checked, and its report.
fn mesh_checked(points: &[DVec2], domain: Option<Domain>) -> (Mesh, MeshReport) {
    let (mesh, report) = mesh_points(points, &nonobtuse(domain)).unwrap();
    if let Err(fault) = mesh.validate_nonobtuse(points) {
        panic!("invalid nonobtuse mesh of {} points: {fault}", points.len());
    }
    assert_eq!(report.triangles, mesh.triangles.len());
    // The report's extremes are the mesh's: measured where the points split leaves, the
    // templates' elsewhere, which rounding moves by less than 0.01°.
    assert_report_extremes(&mesh, &report);
    (mesh, report)
}

/// The warped mesh's triangle count on the same points and domain.
fn warped_count(points: &[DVec2], domain: Option<Domain>) -> usize {
    let options = MeshOptions {
        domain,
        ..MeshOptions::default()
    };
    mesh_points(points, &options).unwrap().0.triangles.len()
}

/// Checks the split and that it adds at most ten triangles per point to the warped mesh's
/// count (six in the point's leaf, one in each of its four neighbours), and its coarsening.
fn check_against_warp(points: &[DVec2], domain: Option<Domain>) -> (Mesh, Mesh) {
    let (mesh, report) = mesh_checked(points, domain);
    let warped = warped_count(points, domain);
    let n = mesh.triangles.len();
    assert!(
        n >= warped && n <= warped + 10 * report.points,
        "{n} triangles against {warped} warped for {} points",
        report.points
    );
    let coarse = coarsened_checked(points, domain, &mesh);
    (mesh, coarse)
}

#[test]
fn every_family_meshes_nonobtuse() {
    for dist in FAMILIES {
        for n in [1, 10, 300, 4000] {
            let points = generate::points(dist, n, 11);
            let (split, coarse) = check_against_warp(&points, None);
            // The coarsening takes away about half the split's triangles.
            if n >= 300 {
                let (s, c) = (split.triangles.len(), coarse.triangles.len());
                assert!(c * 10 <= s * 6, "{dist:?} {n}: {c} of {s}");
            }
        }
    }
}

#[test]
fn a_point_anywhere_in_its_leaf() {
    // Three points far apart on a unit grid: the middle one's leaf is about as large as the
    // spacing allows, and its offset in the leaf sweeps the corners, sides, inside, and places
    // within rounding of a side.
    let near: Vec<f64> = (0..=32)
        .map(|i| i as f64 / 32.0)
        .chain([1e-15, 1e-9, 1.0 - 1e-9, 1.0 - 1e-15])
        .collect();
    for &dx in &near {
        for &dy in &near {
            let points = [
                DVec2::new(0.0, 0.0),
                DVec2::new(0.5 + dx / 64.0, 0.5 + dy / 64.0),
                DVec2::new(1.0, 1.0),
            ];
            let domain = Domain {
                lo: DVec2::ZERO,
                hi: DVec2::ONE,
            };
            let (split, _) = mesh_checked(&points, Some(domain));
            coarsened_checked(&points, Some(domain), &split);
            mesh_checked(&points, None);
        }
    }
}

#[test]
fn grid_aligned_and_collinear_points() {
    let lattice: Vec<DVec2> = (0..=16)
        .flat_map(|i| (0..=16).map(move |j| DVec2::new(i as f64 / 16.0, j as f64 / 16.0)))
        .collect();
    let unit = Domain {
        lo: DVec2::ZERO,
        hi: DVec2::ONE,
    };
    check_against_warp(&lattice, Some(unit));
    check_against_warp(&lattice, None);
    // On the lattice every point sits on a corner of its leaf: no lines, right isosceles
    // templates only.
    let (_, report) = mesh_checked(&lattice, Some(unit));
    assert!(report.min_angle >= 26.5, "{}", report.min_angle);
    let line: Vec<DVec2> = (0..500).map(|i| DVec2::new(i as f64 * 0.37, 2.0)).collect();
    check_against_warp(&line, None);
    let diagonal: Vec<DVec2> = (0..500).map(|i| DVec2::splat(i as f64 / 499.0)).collect();
    check_against_warp(&diagonal, None);
}

#[test]
fn points_on_a_given_rectangle_and_its_sides() {
    let mut points = generate::points(Distribution2d::Uniform, 1500, 5)
        .into_iter()
        .map(|p| DVec2::new(3.0 * p.x, p.y))
        .collect::<Vec<_>>();
    for i in 1..40 {
        let t = i as f64 / 40.0;
        points.extend([
            DVec2::new(3.0 * t, 0.0),
            DVec2::new(3.0 * t + 0.01, 1.0),
            DVec2::new(0.0, t),
            DVec2::new(3.0, t + 0.005),
        ]);
    }
    points.extend([DVec2::ZERO, DVec2::new(3.0, 1.0), DVec2::new(3.0, 0.0)]);
    let wide = Domain {
        lo: DVec2::ZERO,
        hi: DVec2::new(3.0, 1.0),
    };
    check_against_warp(&points, Some(wide));
    // The same points in a tall rectangle (meshed as the mirror image).
    let tall: Vec<DVec2> = points.iter().map(|p| DVec2::new(p.y, p.x)).collect();
    let domain = Domain {
        lo: DVec2::ZERO,
        hi: DVec2::new(1.0, 3.0),
    };
    check_against_warp(&tall, Some(domain));
}

#[test]
fn one_and_two_threads_give_the_same_mesh() {
    for dist in FAMILIES {
        let points = generate::points(dist, 3000, 2);
        let one = on_threads(1, || mesh_checked(&points, None).0);
        let two = on_threads(2, || mesh_checked(&points, None).0);
        assert_eq!(one, two, "{dist:?}");
        // Several chunks of the coarsening, and its rounds.
        let coarse_one = on_threads(1, || coarsened_checked(&points, None, &one));
        let coarse_two = on_threads(2, || coarsened_checked(&points, None, &one));
        assert!(one.vertices.len() > 3 * (1 << 14), "{dist:?}");
        assert_eq!(coarse_one, coarse_two, "{dist:?}");
    }
}

#[test]
fn front_door_mode() {
    let points = generate::points(Distribution2d::Kuzmin, 500, 4);
    let options = Options::default().nonobtuse();
    assert_eq!(options.mode(), Mode::Nonobtuse);
    let (mesh, _) = quadmesh::mesh(&Input::points(points.clone()), &options).unwrap();
    mesh.validate_nonobtuse(&points).unwrap();
    let split = mesh_checked(&points, None).0;
    assert_eq!(mesh, coarsened_checked(&points, None, &split));
    let split_mode = Options::default().nonobtuse_split();
    let (mesh, _) = quadmesh::mesh(&Input::points(points.clone()), &split_mode).unwrap();
    assert_eq!(mesh, split);
    // The quadtree modes take no area bound, and mesh rectangles only.
    assert!(quadmesh::mesh(&Input::points(points.clone()), &options.max_area(0.1)).is_err());
    let hull = options.region(Region::ConvexHull);
    assert!(quadmesh::mesh(&Input::points(points), &hull).is_err());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn mixed_inputs_mesh_nonobtuse_or_fail_cleanly(points in mixed_point_sets()) {
        match mesh_points(&points, &nonobtuse(None)) {
            Ok((mesh, _)) => {
                if let Err(fault) = mesh.validate_nonobtuse(&points) {
                    panic!("{fault}");
                }
                coarsened_checked(&points, None, &mesh);
            }
            // Points too close for f64 are refused by name, as in the warp mode.
            Err(quadmesh::Error::Unresolvable { .. }) => {}
            Err(e) => panic!("unexpected error {e}"),
        }
    }
}

/// Fuzzing found a single point 2.8e-310 from a grid line of its leaf: the strip between
/// them had triangles whose areas underflow. A point that close to a line counts as on it.
#[test]
fn a_point_a_subnormal_distance_from_a_grid_line() {
    let point = DVec2::new(2.83583534408754e-310, 2.622116294214786e-178);
    let options = Options::default().nonobtuse().region(Region::Square);
    let (mesh, _) = quadmesh::mesh(&Input::points(vec![point]), &options).unwrap();
    mesh.validate_nonobtuse(&[point]).unwrap();
    // Near a line relative to the leaf but not by 2^-40: a thin strip, still valid.
    let near = [DVec2::new(0.5 + 1e-11, 0.5 + 1e-3), DVec2::ZERO, DVec2::ONE];
    mesh_checked(&near, None);
}

/// Points so small that the triangles' areas underflow f64 are refused, as in the warp mode,
/// never meshed into degenerate triangles: a square of area below 1e-240 outright, and a
/// triangle f64 cannot orient, near a point, by name.
#[test]
fn points_at_a_scale_whose_areas_underflow_are_refused() {
    let points = [
        DVec2::new(1e-200, 2e-200),
        DVec2::new(3e-200, 1e-200),
        DVec2::new(2.5e-200, 2.7e-200),
    ];
    let refused = mesh_points(&points, &nonobtuse(None));
    assert!(
        matches!(refused, Err(quadmesh::Error::CoordinateRange { .. })),
        "{refused:?}"
    );
    // Points 1e-21 apart in a square of side 1e-110: areas down to 1e-262, still normal.
    let close = [
        DVec2::ZERO,
        DVec2::new(1e-110, 1e-110),
        DVec2::new(5e-111, 5e-111 + 1e-131),
    ];
    match mesh_points(&close, &nonobtuse(None)) {
        Ok((mesh, _)) => mesh.validate_nonobtuse(&close).unwrap(),
        Err(e) => assert!(matches!(e, quadmesh::Error::Unresolvable { .. }), "{e}"),
    }
}

/// Found twice by the `point_sets` fuzz target (nonobtuse, the square): points spanning
/// 1e-322 to 4e-45, and 1e-321 to 1e120. The orientation test, exact in sign, had begun to
/// return the determinant of the points scaled by a power of two where the coordinates span
/// more than the adaptive test keeps exact, and the area check summed those scaled values.
/// The value now keeps the adaptive test's magnitude with the exact sign.
#[test]
fn points_spanning_f64s_range_keep_their_areas() {
    let cases: [&[(f64, f64)]; 2] = [
        &[
            (3.895_711_326_229_54e-310, -9.237_074_837_998_974e-48),
            (9e-322, -3.978_588_581_034_294e-45),
            (-3.978_588_581_063_402e-45, -3.978_613_408_541_841_6e-45),
            (-4.022_061_095_618_272e-45, -1.896_250_047_369_692_4e-47),
        ],
        &[
            (-8.181_669_322_272_966e106, -1.002_520_540_885_467_1e120),
            (1.067e-321, 0.0),
            (-2.145_553_806_265_876_5e110, -1.002_519_304_762_958_2e120),
            (-1.581_904_604_033_067_6e110, -1.581_904_603_990_005_5e110),
        ],
    ];
    for coordinates in cases {
        let points: Vec<DVec2> = coordinates.iter().map(|&(x, y)| DVec2::new(x, y)).collect();
        let options = Options::default().nonobtuse().region(Region::Square);
        match quadmesh::mesh(&Input::points(points.clone()), &options) {
            Ok((mesh, _)) => mesh.validate_nonobtuse(&points).unwrap(),
            Err(e) => assert!(
                matches!(
                    e,
                    quadmesh::Error::CoordinateRange { .. } | quadmesh::Error::Unresolvable { .. }
                ),
                "{e}"
            ),
        }
    }
}

/// Found by the `point_sets` fuzz target (nonobtuse, the square on the points): two points, a
/// square 1.5e11 across, leaves a millimetre wide at its corner. The check's allowance for
/// rounding there is 18°, and the coarsening, admitting what the check allows, made a triangle
/// of 108.4°. An admitted angle now passes 90° by at most 1e-7 rad.
#[test]
fn small_leaves_in_a_large_square_coarsen_without_obtuse_angles() {
    let points = [
        DVec2::new(-1.368_455_531_567_204_2e-48, 3.101_484_621_703_763_6e-5),
        DVec2::new(154_761_725_060.507_9, 3.131_738_314_720_716_4e-52),
    ];
    let (lo, hi) = (points[0].min(points[1]), points[0].max(points[1]));
    let square = Domain {
        lo,
        hi: lo + DVec2::splat((hi - lo).max_element()),
    };
    let (split, _) = mesh_checked(&points, Some(square));
    coarsened_checked(&points, Some(square), &split);
}
