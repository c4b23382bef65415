//! The inputs on which peer meshers run out of memory, assert, or refine without end, as
//! planar straight-line graphs: each must end within seconds in a mesh that passes the
//! independent check, or in a typed error naming the offending input; never a panic or a hang.

mod common;

use common::peer_cases;

use std::sync::mpsc;
use std::time::Duration;

use quadmesh::mesh::{AngleBounds, validate_pslg_with};
use quadmesh::pslg::CleanOptions;
use quadmesh::{DVec2, Error, Input, Mesh, Options, Region};

/// How long one case may take, its checks included.
const LIMIT: Duration = Duration::from_secs(60);

/// Meshes `input` on another thread, failing the test if it takes longer than [`LIMIT`].
fn within_limit(input: &Input, options: Options) -> Result<Mesh, Error> {
    let (send, receive) = mpsc::channel();
    let input = input.clone();
    std::thread::spawn(move || {
        let _ = send.send(quadmesh::mesh(&input, &options).map(|(m, _)| m));
    });
    receive
        .recv_timeout(LIMIT)
        .expect("meshing ended within the limit")
}

/// Meshes `points` with `options` within the time limit: a mesh must pass `validate` and the
/// Delaunay check, a partial mesh at the vertex budget the Delaunay check; with `resolution`,
/// refinement may also end where f64 cannot resolve it. Any other error fails.
fn meshes_or_stops(points: &[DVec2], options: Options, resolution: bool) {
    match within_limit(&Input::points(points.to_vec()), options) {
        Ok(mesh) => {
            mesh.validate(points, options.angle_bounds()).unwrap();
            mesh.check_delaunay().unwrap();
        }
        Err(Error::VertexBudget(partial)) => partial.mesh.check_delaunay().unwrap(),
        Err(Error::RefinementResolution { .. }) if resolution => {}
        Err(e) => panic!("{e}"),
    }
}

/// Meshes `input` at 20° and 30° (and the hull variant when `hull`), checking each mesh.
fn meshes_and_checks(input: &Input, hull: bool) {
    for angle in [20.0, 30.0] {
        let mut options = Options::default().min_angle(angle);
        if hull {
            options = options.region(Region::ConvexHull);
        }
        match within_limit(input, options) {
            Ok(mesh) => validate_pslg_with(&mesh, input, options.angle_bounds(), hull)
                .unwrap_or_else(|e| panic!("{angle}°: invalid mesh: {e}")),
            Err(Error::VertexBudget(partial)) => {
                panic!(
                    "{angle}°: stopped at the budget near {:?}",
                    partial.unmet.first()
                )
            }
            Err(e) => panic!("{angle}°: {e}"),
        }
    }
}

/// Meshes `input` at 20° and 30°: a checked mesh, or the vertex budget's error, whose partial
/// mesh is checked without the angle bound and whose unmet triangles say where it stopped.
fn meshes_or_stops_at_the_budget(input: &Input) {
    for angle in [20.0, 30.0] {
        let options = Options::default().min_angle(angle);
        match within_limit(input, options) {
            Ok(mesh) => validate_pslg_with(&mesh, input, options.angle_bounds(), false)
                .unwrap_or_else(|e| panic!("{angle}°: invalid mesh: {e}")),
            Err(Error::VertexBudget(partial)) => {
                assert!(!partial.unmet.is_empty());
                let loose = AngleBounds {
                    min_deg: 0.0,
                    max_deg: 180.0,
                };
                validate_pslg_with(&partial.mesh, input, loose, false)
                    .unwrap_or_else(|e| panic!("{angle}°: invalid partial mesh: {e}"));
            }
            Err(e) => panic!("{angle}°: {e}"),
        }
    }
}

#[test]
fn two_segments_2e_13_apart() {
    // Triangle at -pq20 allocates until killed on this: the strip between the segments needs
    // about 1e12 triangles. Here the vertex budget stops it and says where.
    meshes_or_stops_at_the_budget(&peer_cases::two_segments_2e_13_apart());
}

#[test]
fn a_polygon_with_a_spike_of_a_thousandth_of_a_degree() {
    meshes_and_checks(&peer_cases::a_spike_of_a_thousandth_of_a_degree(), false);
}

#[test]
fn a_crack_into_the_domain() {
    meshes_and_checks(&peer_cases::a_crack_into_the_domain(), false);
}

#[test]
fn six_near_collinear_points_joined_by_segments() {
    meshes_and_checks(&peer_cases::six_near_collinear_points(), false);
}

#[test]
fn a_duplicated_vertex_used_by_segments() {
    let input = peer_cases::a_duplicated_vertex_used_by_segments();
    let (mesh, report) = quadmesh::mesh(&input, &Options::default()).unwrap();
    assert_eq!(report.cleaning.unwrap().merged_points, 1);
    assert!(mesh.segments.iter().any(|s| s.segment == 4));
}

#[test]
fn segments_crossing_where_no_float_lies_and_a_third_through_it() {
    // Two crossing segments whose intersection has no exact f64, and a third through it.
    let input = peer_cases::segments_crossing_where_no_float_lies();
    assert!(matches!(
        quadmesh::mesh(&input, &Options::default()),
        Err(Error::CrossingSegments { .. })
    ));
    // The three split points lie within a few ulps of each other: a mesh between them needs
    // splits closer than f64 places them, so refinement ends at the budget or with a resolution
    // error, naming the spot; a partial mesh still covers the square exactly.
    for angle in [20.0, 30.0] {
        let options = Options::default().min_angle(angle).split_crossings();
        let mesh = match within_limit(&input, options) {
            Ok(mesh) => mesh,
            Err(Error::VertexBudget(partial)) => {
                assert!(
                    partial
                        .unmet
                        .iter()
                        .any(|u| u.at.distance(DVec2::splat(1.5)) < 1e-6)
                );
                partial.mesh
            }
            // Or f64 cannot place a split there: refused, naming the point.
            Err(Error::RefinementResolution { x, y, .. }) => {
                assert!(DVec2::new(x, y).distance(DVec2::splat(1.5)) < 1e-6);
                continue;
            }
            Err(e) => panic!("{angle}°: {e}"),
        };
        assert!(
            (common::mesh_area(&mesh) - 9.0).abs() < 1e-9,
            "{angle}°: area {}",
            common::mesh_area(&mesh)
        );
        mesh.check_delaunay().unwrap();
    }
}

#[test]
fn a_polygon_of_side_1e_300_and_one_of_side_1e_minus_300() {
    for side in [1e300, 1e-300] {
        let input = peer_cases::a_polygon_of_side(side);
        // The exact predicates would overflow or underflow: refused by name, at the door.
        assert!(matches!(
            within_limit(&input, Options::default()),
            Err(Error::ScaleRange { .. })
        ));
    }
}

#[test]
fn hole_seeds_outside_the_domain_and_on_a_segment() {
    let mut input = peer_cases::hole_seeds_outside_and_on_a_segment();
    input.holes = vec![DVec2::new(5.0, 5.0)];
    let mesh = within_limit(&input, Options::default()).unwrap();
    assert!((common::mesh_area(&mesh) - 4.0).abs() < 1e-12);
    // A seed on a segment, or on a segment's end, could name either side: refused by name.
    for (k, seed) in [DVec2::new(1.0, 0.0), DVec2::new(2.0, 2.0)]
        .into_iter()
        .enumerate()
    {
        input.holes = vec![DVec2::splat(9.0), seed];
        assert_eq!(
            within_limit(&input, Options::default()).unwrap_err(),
            Error::SeedOnSegment {
                kind: "hole",
                index: 1,
                x: seed.x,
                y: seed.y
            },
            "case {k}"
        );
    }
}

#[test]
fn a_bow_tie_and_an_open_graph() {
    // The bow tie's sides cross at its waist: refused by name, or split and meshed.
    let bow = peer_cases::a_bow_tie();
    assert!(matches!(
        quadmesh::mesh(&bow, &Options::default()),
        Err(Error::CrossingSegments { a: 0, b: 2, .. })
    ));
    let mesh = within_limit(&bow, Options::default().split_crossings()).unwrap();
    assert!((common::mesh_area(&mesh) - 2.0).abs() < 1e-12);
    let open = peer_cases::an_open_graph();
    assert_eq!(
        quadmesh::mesh(&open, &Options::default()).unwrap_err(),
        Error::NothingEnclosed
    );
}

#[test]
fn all_vertices_collinear_with_segments() {
    let input = peer_cases::all_vertices_collinear();
    assert_eq!(
        quadmesh::mesh(&input, &Options::default()).unwrap_err(),
        Error::NothingEnclosed
    );
    assert!(matches!(
        quadmesh::mesh(&input, &Options::default().region(Region::ConvexHull)),
        Err(Error::Degenerate { .. })
    ));
}

#[test]
fn nested_holes_numbered_from_zero() {
    // Three nested squares in a zero-based .poly: the outer annulus meshed, the middle one a
    // hole, the inner square meshed again.
    let input =
        quadmesh::io::parse_poly_input(peer_cases::NESTED_HOLES_POLY, "nested.poly").unwrap();
    assert_eq!(input.segments[0].ends, [0, 1]);
    meshes_and_checks(&input, false);
    let mesh = within_limit(&input, Options::default()).unwrap();
    assert!((common::mesh_area(&mesh) - (36.0 - 16.0 + 4.0)).abs() < 1e-9);
}

#[test]
fn points_spanning_fifty_five_orders_of_magnitude_end_without_a_panic() {
    // Found by the `poly_file` fuzz target. The corner at the far point is some 1e-55 radians
    // wide, and the narrow-corner rule took every short edge near the origin for one spanning
    // it (both its ends within 1e-9 radians of both sides), so refinement left a 15° triangle
    // there and called the mesh done.
    let points = [
        (0.0, 0.0),
        (3.0, 0.0),
        (3.0, 3.0),
        (0.0, 3.0),
        (0.1, 3.2),
        (4.0, 1.0),
        (5.0, 4.0),
        (7.0, 8.0),
        (8.0, 10.0),
        (5.555_555_555_555_556e55, 10.0),
    ];
    let input = Input::points(
        points
            .iter()
            .map(|&(x, y)| DVec2::new(x, y))
            .collect::<Vec<_>>(),
    );
    match within_limit(&input, Options::default()) {
        Ok(mesh) => mesh
            .validate(&input.points, Options::default().angle_bounds())
            .unwrap_or_else(|e| panic!("invalid mesh: {e}")),
        Err(e) => assert!(!e.to_string().is_empty()),
    }
}

#[test]
fn a_hull_spike_to_a_far_point_is_not_peeled_away() {
    // Found by the `poly_file` fuzz target: the hull side to the far point passes within its
    // 1e-11 of the points near the origin, and the sliver peeled off that side was the whole
    // spike, whose other side was a hull side too: its removal was undone twice and panicked.
    let points = [
        (0.0, 0.0),
        (3.0, 0.0),
        (3.0, 3.0),
        (0.0, 3.0),
        (0.1, 22_222_222_222_222.0),
    ];
    let input = Input::points(
        points
            .iter()
            .map(|&(x, y)| DVec2::new(x, y))
            .collect::<Vec<_>>(),
    );
    for angle in [0.0, 22.0, 30.0] {
        let options = Options::default().min_angle(angle);
        match within_limit(&input, options) {
            Ok(mesh) => mesh
                .validate(&input.points, options.angle_bounds())
                .unwrap_or_else(|e| panic!("invalid mesh at {angle}°: {e}")),
            Err(e) => assert!(!e.to_string().is_empty()),
        }
    }
}

#[test]
fn a_warped_mesh_whose_areas_overflow_is_refused() {
    // Found by the `point_sets` fuzz target: one point at -1e178 gave a warped mesh of a square
    // whose area is infinite in f64, so its areas could not be checked or used.
    for points in [
        vec![DVec2::new(
            -1.058_397_204_323_598_4e178,
            455_366.777_225_075_2,
        )],
        vec![DVec2::new(0.0, 0.0), DVec2::new(1e160, 1.0)],
    ] {
        let input = Input::points(points);
        let options = Options::default().warp();
        match within_limit(&input, options) {
            Ok(mesh) => panic!("a mesh of area {}", mesh.domain.area()),
            Err(e) => assert!(matches!(e, Error::CoordinateRange { .. }), "{e}"),
        }
    }
}

#[test]
fn a_warped_mesh_whose_areas_underflow_is_refused() {
    // Found by the `point_sets` fuzz target: two points 1e-158 apart gave a warped mesh whose
    // triangles' areas underflow f64, so their sum could not be checked against the square's.
    let points = vec![
        DVec2::new(4.180_672_277_983_657_4e-178, 4.180_672_277_983_657_4e-178),
        DVec2::new(4.203_566_516_702_135e-178, 7.711_979_156_801_684e-159),
    ];
    for options in [Options::default().warp(), Options::default().nonobtuse()] {
        match within_limit(&Input::points(points.clone()), options) {
            Ok(mesh) => panic!("a mesh of area {}", mesh.domain.area()),
            Err(e) => assert!(matches!(e, Error::CoordinateRange { .. }), "{e}"),
        }
    }
    // Points 1e-100 apart still mesh, with areas f64 measures.
    let small = vec![DVec2::ZERO, DVec2::new(1e-100, 3e-101)];
    let mesh = within_limit(&Input::points(small.clone()), Options::default().warp()).unwrap();
    mesh.validate(&small, Options::default().warp().angle_bounds())
        .unwrap();
}

#[test]
fn split_points_near_the_end_of_a_long_segment_are_in_order() {
    // Found by the `poly_file` fuzz target (at 20°): a segment 1e30 long, nearly horizontal,
    // split near its end (x about 8e13) at points whose fractions of the way along round to
    // the same f64. The mesher listed the pieces by that fraction, out of order, and the check
    // ordered them the same way. Both order them by their coordinates now. Split vertices near
    // the far end, rounded off the line by 1e-4, move the area by 5e-8 of this thin domain's;
    // the check allows what that rounding explains.
    let text =
        "4 2 0 0\n1 0 0\n2 04 05 0\n7 1e30 0592e9\n4 0 1e3 0\n4 0\n0 1 2\n2 2 3\n3 3 4\n4 4 1\n0\n";
    let input = quadmesh::io::parse_poly_input(text, "long.poly").unwrap();
    meshes_or_stops_at_the_budget(&input);
}

/// Found twice by the `point_sets` fuzz target (Delaunay mode, 29°, the square around the
/// points): points 4e-178 apart near the origin with a third 134 051 away, and points 1.7e-115
/// and 4.9e-313 from the origin in an extent of 2.8e-23. Refinement split toward the tiny gap,
/// where the exact predicates' products underflow f64: the first stopped at the vertex budget
/// with a partial mesh that failed the Delaunay check, the second failed the angle check. Points
/// within 1e-70 of each other are refused now, by name, as extents below 1e-70 are.
#[test]
fn points_closer_than_1e_minus_70_are_refused_by_name() {
    let inputs = [
        vec![
            DVec2::new(4.925_663_354_239_428e-198, 1.119_055_691_525_303e-309),
            DVec2::new(4.179_403_526_067_301_6e-178, 1.744_012_190_584_675_8e-307),
            DVec2::new(1.999_502_279_906_807e-184, 134_051.388_326_198_36),
        ],
        vec![
            DVec2::new(2.829_930_847_549_25e-23, 1.33e-322),
            DVec2::new(4.880_590_319_2e-313, 0.0),
            DVec2::new(1.731_451_335_505_099_3e-115, 2.110_658_851_827_719_5e-177),
        ],
    ];
    for (points, angle) in inputs
        .iter()
        .flat_map(|p| [20.0, 29.0].map(|a| (p.clone(), a)))
    {
        let input = Input::points(points.clone());
        let options = Options::default()
            .min_angle(angle)
            .region(Region::Square)
            .max_vertices(20_000);
        match within_limit(&input, options) {
            Err(Error::TooClose { a, pa, b, pb }) => {
                assert!(a < b);
                let gap = (DVec2::from(pa) - DVec2::from(pb)).abs().max_element();
                assert!(gap < 1e-70 && gap > 0.0, "{gap}");
            }
            other => panic!("{:?}", other.map(|m| m.triangles.len())),
        }
    }
    // The same gap 1e-60 wide meshes, and so do points 1e-19 apart at a coordinate of 1.
    for points in [
        vec![DVec2::ZERO, DVec2::new(1e-60, 0.0), DVec2::new(1.0, 1.0)],
        vec![DVec2::ONE, DVec2::new(1.0 + 1e-15, 1.0), DVec2::ZERO],
    ] {
        let options = Options::default().region(Region::Square);
        let mesh = within_limit(&Input::points(points.clone()), options).unwrap();
        mesh.validate(&points, options.angle_bounds()).unwrap();
        mesh.check_delaunay().unwrap();
    }
}

/// Found by the `point_sets` fuzz target (Delaunay mode, 23°, the hull). Three points make a
/// hull 5.6e-45 long and 1.8e-49 wide, a corner of 0.004° at the origin. Refinement leaves
/// triangles whose shortest edge joins the corner's two sides (Shewchuk's rule: no triangle on
/// such an edge meets the bound), midway along the sliver and at its wide end. The check
/// exempted only triangles at the corner itself; it now exempts these too, as the graph check
/// does for narrow input angles.
#[test]
fn a_hull_sliver_of_four_thousandths_of_a_degree_meets_the_bound() {
    let points = vec![
        DVec2::new(-3.978_230_430_592_166e-45, -3.978_588_581_063_402e-45),
        DVec2::new(-3.978_588_581_063_402e-45, -3.978_588_581_063_402e-45),
        DVec2::new(9.096_286_435_814_833e-175, 4.287_729_418_748_103e-178),
    ];
    let options = Options::default().min_angle(23.0).max_vertices(20_000);
    meshes_or_stops(&points, options, false);
}

#[test]
fn a_hull_sliver_keeps_its_area_within_the_rounding_of_its_split_points() {
    // Found by the `point_sets` fuzz target (Delaunay mode, 20°, the hull): a hull 3.8e-11
    // long and 4e-20 wide. The points refinement puts on its sides round by about 1e-27, a
    // 1e-7 part of its width, and the mesh's area came out 1.5e-8 relative below the hull's,
    // beyond the 1e-9 allowed. The check now also allows what that rounding (the outline
    // check's tolerance) can move the area by, as the graph check does.
    let points = vec![
        DVec2::new(3.785_767_235_486_057e-270, 2.172_977_569_596_57e-310),
        DVec2::new(-2.704_944_238_432_848_3e-11, -2.704_944_242_449_367_5e-11),
        DVec2::new(-2.704_944_242_449_367_5e-11, -2.704_944_242_449_367_5e-11),
    ];
    let options = Options::default().min_angle(20.0).max_vertices(20_000);
    meshes_or_stops(&points, options, false);
}

#[test]
fn a_thin_hull_with_far_corners_keeps_its_area_in_the_check() {
    // Found by the `point_sets` fuzz target (Delaunay mode, no angle bound, the hull): three
    // nearly collinear points 3.6e59 apart around the origin. The check's plain cross products
    // lost the triangles' areas (1.5e-6 in all) to cancellation and summed them to 0; it uses
    // the adaptive determinant now, and the mesh passes.
    let points = vec![
        DVec2::new(3.264_657_368_216e-311, 0.0),
        DVec2::new(3.552_594_197_366_691e59, 3.552_593_419_155_010_6e59),
        DVec2::new(-1.226_055_464_348_490_6e-59, -1.226_056_029_646_053_8e-59),
    ];
    let options = Options::default().min_angle(0.0).max_vertices(20_000);
    let mesh = within_limit(&Input::points(points.clone()), options).unwrap();
    mesh.validate(&points, options.angle_bounds()).unwrap();
    mesh.check_delaunay().unwrap();
}

#[test]
fn a_point_8e_minus_90_inside_a_hull_side() {
    // Found by the `point_sets` fuzz target (Delaunay mode, 26°, the hull): a point near the
    // origin lies 7.8e-90 inside the hull side from (-4e-16, 0) to (131 060, -2.6e-69). The
    // boundary bent only through points nearer a side than f64 resolves at their magnitude, so
    // refinement split the side toward the point, down to edges near 1e-81 whose squared
    // lengths' products underflow f64: both sides of the angle test came out as the smallest
    // subnormal, and a 23.7° triangle stayed. A point within 1e-70 of a side (where points
    // within 1e-70 of each other are refused) now bends the boundary through it.
    let points = vec![
        DVec2::new(-3.988_095_257_084_783e-16, 482_131_132.737_254_86),
        DVec2::new(-3.878_752_941_027_104_5e-270, 2.505_65e-319),
        DVec2::new(-3.988_095_257_084_792e-16, 7.876_760_780_058_298e-306),
        DVec2::new(131_060.062_499_046_33, -2.563_716_015_901_356_6e-69),
    ];
    for angle in [20.0, 26.0] {
        let options = Options::default().min_angle(angle).max_vertices(20_000);
        let mesh = within_limit(&Input::points(points.clone()), options).unwrap();
        mesh.validate(&points, options.angle_bounds()).unwrap();
        mesh.check_delaunay().unwrap();
        assert!(mesh.outline.as_ref().unwrap().contains(&points[1]));
    }
}

/// Found by the `point_sets` fuzz target (Delaunay mode, 20°, the hull): a hull 8.2e62 tall
/// and 1.1e59 wide with a 0.007° corner at the top, whose left side runs on, bent by 3e-117
/// radians at a hull corner, to a right-angled corner at the origin. Refinement took that
/// corner for a point on the narrow corner's side, as it lies on the side's line, and left the
/// 16.5° triangle on the bottom side, which joins it to the narrow corner's other side, as one
/// it cannot improve (Shewchuk's rule); the check, which goes by the outline's sides, did not
/// exempt it. A point on a side now also lies no further out than the side's far end.
#[test]
fn a_hull_corner_in_line_with_the_side_of_a_narrow_one() {
    let points = vec![
        DVec2::new(7.605_332_331_225_54e-310, 3.552_593_556_086_262e59),
        DVec2::new(1.054_184_527_482_481_1e59, 1.112_578_345_627_666_4e-307),
        DVec2::new(2.400_594_055_870_013_2e-211, 8.229_510_678_521_401e62),
        DVec2::new(1.075_337_771_657_209_4e-57, 8.046_680_848_777_6e-58),
    ];
    for angle in [20.0, 30.0] {
        let options = Options::default().min_angle(angle).max_vertices(20_000);
        let mesh = within_limit(&Input::points(points.clone()), options).unwrap();
        mesh.validate(&points, options.angle_bounds()).unwrap();
        mesh.check_delaunay().unwrap();
    }
}

#[test]
fn a_point_3e_minus_17_inside_the_end_of_a_hull_side_8e49_long() {
    // Found by the `point_sets` fuzz target (Delaunay mode, 20°, the hull): a hull sliver from
    // (-5.6e49, -5.6e49) to the origin, 98 304 wide there, with a point 2.9e-17 inside its long
    // side next to the origin. Measured from the side's far end, the point rounded onto the
    // near one, so the boundary bent through it, 1e10 times further out than f64 needs; and
    // refinement, measuring from the sliver's far corner, took all three points at the wide
    // end for points on both its sides and left a triangle of 2e-19° there (Shewchuk's rule).
    // Both measure with the exact determinant now. Refinement then has to split the long side
    // where f64 cannot tell it from the other (58 000 apart at coordinates of 2e49), and says
    // so.
    let points = vec![
        DVec2::new(2.634_172_311_275_772_3e-178, 98_303.999_999_624_14),
        DVec2::new(-3.988_095_257_061_079_7e-16, -3.571_761_622_850_442e-16),
        DVec2::new(7.738_694_5e-317, 1.295_163e-318),
        DVec2::new(-5.630_506_713_171_445e49, -5.630_506_717_317_518e49),
    ];
    for angle in [20.0, 30.0] {
        let options = Options::default().min_angle(angle).max_vertices(20_000);
        match within_limit(&Input::points(points.clone()), options) {
            Ok(mesh) => {
                mesh.validate(&points, options.angle_bounds()).unwrap();
                mesh.check_delaunay().unwrap();
            }
            Err(Error::RefinementResolution { .. }) => {}
            Err(e) => panic!("{e}"),
        }
    }
}

#[test]
fn a_hull_corner_1e_minus_78_from_the_opposite_side() {
    // Found by the `point_sets` fuzz target (Delaunay mode, 23°, the hull): three nearly
    // collinear points make a hull 0.124 long whose corner near the origin lies 1.07e-78 from
    // the opposite side. Refinement split the sides until split points lay one f64 step apart
    // (3e-73 along, 4e-79 across), where the exact in-circle products underflow: at the vertex
    // budget, the partial mesh failed the Delaunay check. Refinement now stops with
    // `RefinementResolution` rather than put a vertex within 1e-70 of others, the gap at which
    // input points are refused as `TooClose`.
    let points = vec![
        DVec2::new(-1.071_054_237_770_489_6e-78, 1.254_806_211_341_005_5e-250),
        DVec2::new(1.224_167_783_418_391e-250, -0.124_019_566_003_014_06),
        DVec2::new(8.196_267_093_326_839e-308, 3.328_175_055_833_161e-57),
    ];
    for angle in [20.0, 23.0] {
        let options = Options::default().min_angle(angle).max_vertices(20_000);
        meshes_or_stops(&points, options, true);
    }
}

#[test]
fn a_hull_sliver_6e37_long_and_2e_minus_35_wide() {
    // Found by the `point_sets` fuzz target (Delaunay mode, 29°, the hull): five points make a
    // hull from -6.3e37 on the x axis to a cluster 1.8e-35 wide at the origin, its top side
    // at y = 1.7e-218. Refinement near the wide end made rectangles 5e-23 by 1.8e-35 with a
    // corner one step of 2e-234 off; their exact in-circle determinant, -4e-326, lies below
    // f64's range, and the check read it as 5e-324: at the vertex budget, the partial mesh was
    // not Delaunay. Where coordinates leave the range in which the adaptive predicates are
    // exact, they are now recomputed on the points scaled by a power of two.
    let points = vec![
        DVec2::new(3.035e-320, -1.805_774_942_692_359e-35),
        DVec2::new(5.006_758_791_663_446_4e-226, -1.805_559_323_337_826_5e-35),
        DVec2::new(-1.859_844_112_962_183_4e-35, 1.699_710_172_822_999_8e-218),
        DVec2::new(6.756_127_006_185_585e-305, -2.490_185_727_705_79e-69),
        DVec2::new(-6.321_912_601_123_859e37, 7.195_711_188_979_87e-175),
    ];
    let options = Options::default().min_angle(29.0).max_vertices(20_000);
    meshes_or_stops(&points, options, true);
}

#[test]
fn huge_and_tiny_coordinates_in_one_hull() {
    // Found three times by the `point_sets` fuzz target (Delaunay mode, 20° and 29°, the
    // hull): points with x up to 1.7e40 or 2.7e42 beside y near 1e-306. At the vertex budget,
    // the partial mesh had triangles with corners near 5e12 in x and 1e-6 or 1e-300 in y whose
    // in-circle products fell below f64's range, so the adaptive test read 5e-324 and the
    // triangulation was not Delaunay. No power of two brings such a mixture into range; the
    // predicates now decide it in integers.
    let cases: [(f64, &[(f64, f64)]); 3] = [
        (
            20.0,
            &[
                (-0.001_815_496_706_484_509_6, -1.832_550_647_212_064e-6),
                (-0.122_112_259_210_324_74, 4.378_247_291_155_157e-305),
                (1.652_571_306_654_006_5e40, 2.736_752_922_471_602_2e-306),
                (1.780_059_086_818_712_7e-307, 2.187_337_306_634_809_3e-303),
            ],
        ),
        (
            20.0,
            &[
                (-0.120_098_039_215_008_61, 2.784_641_362_005e-310),
                (2.535_835_848_624_214_6e-153, -1.832_549_970_284_820_6e-6),
                (-0.124_004_289_215_686_26, -1.145_489_966_767_375_8e-7),
                (2.700_734_407_608_94e42, -1.169_603_529_244_374_1e-306),
                (4.384_157_988_265_719e-193, -3.051_757_812_500_001e-5),
            ],
        ),
        (
            29.0,
            &[
                (3.035e-320, -1.805_774_942_692_495_8e-35),
                (5.006_758_791_663_446_4e-226, -1.805_559_323_337_826_5e-35),
                (-1.859_844_112_962_183_4e-35, -1.859_844_112_962_183_4e-35),
                (1.699_710_172_822_999_8e-218, 6.756_127_006_185_585e-305),
                (-2.284_495_008_020_583_3e37, 1.085_268_860_110_754e-309),
            ],
        ),
    ];
    for (angle, coordinates) in cases {
        let points: Vec<DVec2> = coordinates.iter().map(|&(x, y)| DVec2::new(x, y)).collect();
        let options = Options::default().min_angle(angle).max_vertices(20_000);
        meshes_or_stops(&points, options, true);
    }
}

/// Meshes the graph `input` within the time limit: a mesh must pass the PSLG check and the
/// Delaunay check, as must the mesh reached where refinement stops short (at the vertex budget,
/// or where f64 cannot place a vertex), but for the angle bound. The checks go by the graph as
/// cleaned, meshed again. Returns where f64 could not place a vertex, if it stopped there; any
/// other error fails.
fn graph_meshes_or_stops(input: &Input, options: Options, split_crossings: bool) -> Option<DVec2> {
    let first = within_limit(input, options);
    let (graph, _) = quadmesh::pslg::clean(input, CleanOptions { split_crossings }).unwrap();
    let cleaned = within_limit(&graph, options);
    assert_eq!(
        first.as_ref().map(|_| ()).map_err(std::mem::discriminant),
        cleaned.as_ref().map(|_| ()).map_err(std::mem::discriminant),
        "the graph and its cleaned copy end alike"
    );
    let any_angle = AngleBounds {
        min_deg: 0.0,
        max_deg: 180.0,
    };
    let (mesh, bounds, stop) = match cleaned {
        Ok(mesh) => (mesh, options.angle_bounds(), None),
        Err(Error::VertexBudget(partial)) => (partial.mesh, any_angle, None),
        Err(Error::RefinementResolution {
            x,
            y,
            reached: Some(partial),
        }) => {
            assert!(!partial.unmet.is_empty());
            (partial.mesh, any_angle, Some(DVec2::new(x, y)))
        }
        Err(e) => panic!("{e}"),
    };
    validate_pslg_with(&mesh, &graph, bounds, false).unwrap();
    mesh.check_delaunay().unwrap();
    stop
}

/// The distance from `p` to the line through `a` and `b`.
fn off_line(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    (b - a).perp_dot(p - a).abs() / a.distance(b)
}

#[test]
fn a_vertex_within_rounding_of_a_side_split_by_a_crossing() {
    // Found by the `poly_file` fuzz target (20°, crossings split): the square-like polygon
    // (0, 0), (2, 0), (3, 3), (0, 3) with a point at (2.9, 2.7), on the side from (2, 0) to
    // (3, 3) but for rounding, and a segment crossing that side to (227, 1.1). Refinement
    // split the side toward the point until a split point fell within rounding of it: the
    // cavity held the point inside, the fan from the split point dropped it and left a
    // triangle marked as in a cavity, and the angle scan read the mark as a vertex number and
    // panicked. A cavity must now be a disk, and a split point must lie in the circumcircles
    // of the triangles on the side it splits; refinement stops where f64 cannot split it so.
    let mut input = peer_cases::polygon(&[(0.0, 0.0), (2.0, 0.0), (3.0, 3.0), (0.0, 3.0)], 1);
    input.points.push(DVec2::new(2.9, 2.7));
    peer_cases::push_segment(&mut input, DVec2::new(0.1, 0.3), DVec2::new(227.0, 1.1));
    let options = Options::default()
        .min_angle(20.0)
        .max_vertices(20_000)
        .split_crossings();
    let stop =
        graph_meshes_or_stops(&input, options, true).expect("refinement reaches f64's resolution");
    let side = (DVec2::new(2.0, 0.0), DVec2::new(3.0, 3.0));
    assert!(off_line(stop, side.0, side.1) < 1e-12, "{stop}");
    assert!(stop.distance(DVec2::new(2.9, 2.7)) < 0.1, "{stop}");
}

#[test]
fn a_segment_split_where_rounding_leaves_a_thin_triangle_beyond_it() {
    // Found by the `poly_file` fuzz target (20°): a quadrilateral 1.24e9 tall and 4 wide at
    // the base, its corner at the top 1e-9 radians wide, with a segment from inside to that
    // corner. Splitting the segment 6.8e8 up, where f64's step is 1.2e-7, put the split point
    // off the segment, on one side; the fan on the other side then had an edge that was not
    // locally Delaunay (the triangle it replaced, 0.5 wide and 6.8e8 long, did not have the
    // point in its circumcircle), and at the vertex budget the partial mesh failed the exact
    // Delaunay check. Such a split is now refused, naming the point.
    let mut input = peer_cases::polygon(
        &[(0.0, 0.0), (3.0, 0.0), (3.0, 3.0), (4.0, 1_240_111_034.0)],
        1,
    );
    input.points.push(DVec2::new(0.1, 5.3));
    let corner = input.points[3];
    let from = DVec2::new(0.3, 4.9);
    input.points.push(from);
    input.segments.push(quadmesh::Segment {
        ends: [5, 3],
        marker: 7,
    });
    let options = Options::default().min_angle(20.0).max_vertices(20_000);
    if let Some(stop) = graph_meshes_or_stops(&input, options, false) {
        assert!(off_line(stop, from, corner) < 1e-6, "{stop}");
    }
}

/// Every case above in the warp mode: within the time limit, a mesh that passes the PSLG check
/// with the graph warp's angle bounds, or a typed error that names the input's fault; never a
/// panic or a hang.
#[test]
fn every_case_in_the_warp_mode_ends_in_a_checked_mesh_or_a_named_error() {
    let mut meshed = Vec::new();
    for case in peer_cases::peer_failure_cases() {
        let mut options = Options::default().warp();
        if case.split_crossings {
            options = options.split_crossings();
        }
        match within_limit(&case.input, options) {
            Ok(mesh) => {
                // A graph that cleaning changed is checked as cleaned: the mesh's input
                // indices name the points as given, of which merged ones are no vertices.
                let clean = CleanOptions {
                    split_crossings: case.split_crossings,
                };
                let (graph, report) = quadmesh::pslg::clean(&case.input, clean).unwrap();
                let checked = if report.is_clean() {
                    mesh
                } else {
                    let of_cleaned = within_limit(&graph, options).unwrap();
                    assert_eq!(of_cleaned.triangles.len(), mesh.triangles.len());
                    of_cleaned
                };
                let bounds = options.angle_bounds_of(&graph);
                validate_pslg_with(&checked, &graph, bounds, false)
                    .unwrap_or_else(|e| panic!("{}: invalid mesh: {e}", case.name));
                meshed.push(case.name);
            }
            // Beyond f64's range for areas, as the Delaunay mode's exact predicates refuse them.
            Err(Error::CoordinateRange { .. }) => {
                assert!(case.name.starts_with("side_1e"), "{}", case.name);
            }
            // The seed outside the square names nothing; the one on its side is refused.
            Err(Error::SeedOnSegment { kind, index, .. }) => {
                assert_eq!(case.name, "hole_seeds_outside_and_on_segment");
                assert_eq!((kind, index), ("hole", 1));
            }
            // The two segments 2e-13 apart need a square as small as their gap all along
            // them: the budget stops it, naming a point of each.
            Err(Error::SquareBudget { pa, pb, .. }) => {
                assert_eq!(case.name, "segments_2e-13_apart");
                let mut heights = [pa[1], pb[1]];
                heights.sort_by(f64::total_cmp);
                assert_eq!(heights, [0.5, 0.5 + 2e-13]);
            }
            Err(
                Error::NothingEnclosed
                | Error::ZeroLengthSegment { .. }
                | Error::SegmentIndex { .. }
                | Error::WarpStuck { .. }
                | Error::Unresolvable { .. }
                | Error::TooLarge { .. },
            ) => {}
            Err(e) => panic!("{}: {e}", case.name),
        }
    }
    // The plain domains among them are meshed, not refused.
    for name in [
        "spike_0.001_degrees",
        "crack",
        "six_near_collinear",
        "duplicated_vertex",
        "bow_tie",
        "nested_holes_zero_based",
    ] {
        assert!(meshed.contains(&name), "{name} was not meshed: {meshed:?}");
    }
}
