//! The library's front door: `quadmesh::mesh` with default options meshes the points' convex
//! hull with every angle at least the default bound; extreme spreads; the vertex budget.

mod common;

use common::{convex_hull, mesh_area, narrow_corners, on_threads, polygon_area};
use quadmesh::generate::{Distribution2d, points as generated};
use quadmesh::{
    DEFAULT_MIN_ANGLE_DEG, DVec2, Error, GUARANTEED_MIN_ANGLE_DEG, Input, Mesh, Mode, Options,
    Region, mesh,
};

/// The mesh of `points` with `options`, validated against the input and the mode's bounds,
/// and checked Delaunay in the Delaunay mode.
fn checked(points: &[DVec2], options: &Options) -> (Mesh, quadmesh::MeshReport) {
    let (m, report) = mesh(&Input::points(points), options).expect("meshed");
    m.validate(points, options.angle_bounds())
        .expect("a valid mesh");
    if options.mode() == Mode::Delaunay {
        m.check_delaunay().expect("a Delaunay mesh");
    }
    (m, report)
}

#[test]
fn the_default_is_a_delaunay_mesh_of_the_convex_hull_with_a_proven_bound() {
    let options = Options::default();
    assert_eq!(options.mode(), Mode::Delaunay);
    assert_eq!(options.min_angle_deg(), DEFAULT_MIN_ANGLE_DEG);
    const { assert!(DEFAULT_MIN_ANGLE_DEG <= GUARANTEED_MIN_ANGLE_DEG) };
    assert!(options.termination_proven());
    for dist in [
        Distribution2d::Uniform,
        Distribution2d::Cluster,
        Distribution2d::Kuzmin,
    ] {
        for n in [2_000, 70_000] {
            let points = generated(dist, n, 7);
            let (m, report) = checked(&points, &options);
            let hull = convex_hull(&points);
            let (want, got) = (polygon_area(&hull), mesh_area(&m));
            assert!(
                (got - want).abs() <= 1e-9 * want,
                "{dist:?} {n}: {got} vs hull {want}"
            );
            let outline = m.outline.as_ref().expect("a hull mesh has its outline");
            assert!(outline.len() >= 3);
            assert!(
                report.min_angle >= DEFAULT_MIN_ANGLE_DEG
                    || !narrow_corners(&hull, DEFAULT_MIN_ANGLE_DEG).is_empty(),
                "{dist:?} {n}: {}",
                report.min_angle
            );
            assert_eq!(report.points, n, "{dist:?}");
        }
    }
}

#[test]
fn narrow_hull_corners_keep_their_angle_and_the_rest_meets_the_bound() {
    // Thin triangles of points with tips of 35 down to 0.08 degrees: the splits beside a tip
    // lie on circles around it, a triangle whose shortest edge spans the tip between it and the
    // tip is left as it is, and every other angle meets the bound.
    for tip_x in [2.0, 4.5, 10.0, 100.0, 1000.0] {
        let tip = DVec2::new(tip_x, 0.0);
        let mut points = vec![DVec2::ZERO, DVec2::new(0.0, 1.4), tip];
        points.extend(
            (1..40).map(|k| DVec2::new(0.2 * k as f64 / 40.0, 0.3 + (k % 7) as f64 / 10.0)),
        );
        let tip_angle = (1.4f64 / tip_x).atan().to_degrees();
        for angle in [20.0, 30.0, 33.0] {
            let options = Options::default().min_angle(angle);
            let (m, report) = checked(&points, &options);
            let want = if tip_angle < angle { tip_angle } else { angle };
            assert!(
                report.min_angle >= want - 1e-6,
                "{tip_x} {angle}: {}",
                report.min_angle
            );
            // Away from the tip every angle meets the bound.
            let tip_vertex = m.vertices.iter().position(|&p| p == tip).unwrap() as u32;
            for t in m.triangles.iter().filter(|t| !t.contains(&tip_vertex)) {
                let [a, b, c] = t.map(|v| m.vertices[v as usize]);
                let min = quadmesh::mesh::angles_deg(a, b, c)
                    .into_iter()
                    .fold(f64::MAX, f64::min);
                assert!(min >= angle - 1e-9, "{tip_x} {angle}: {min}");
            }
        }
    }
}

#[test]
fn points_no_grid_separates_are_meshed_in_the_default_mode() {
    // Points 1e-19 apart in an extent of 1.
    let mut close = vec![DVec2::ZERO, DVec2::new(1e-19, 0.0), DVec2::new(0.0, 1e-19)];
    close.extend([
        DVec2::new(1.0, 0.0),
        DVec2::new(1.0, 1.0),
        DVec2::new(0.0, 1.0),
    ]);
    let (m, _) = checked(&close, &Options::default());
    assert_eq!(
        m.vertex_input
            .iter()
            .filter(|&&i| i != quadmesh::NONE)
            .count(),
        6
    );
    // A logarithmic spiral winding in to 1e-19 of an extent of 2.
    let spiral: Vec<DVec2> = (0..400)
        .map(|k| {
            let t = k as f64 * 19.0 * std::f64::consts::LN_10 / 399.0;
            let r = (-t).exp();
            DVec2::new(r * (3.0 * t).cos(), r * (3.0 * t).sin())
        })
        .collect();
    checked(&spiral, &Options::default());
    // The warp mode keeps its typed error for points its grid cannot separate.
    assert!(matches!(
        mesh(&Input::points(spiral), &Options::default().warp()),
        Err(Error::Inseparable { .. } | Error::Unresolvable { .. })
    ));
}

#[test]
fn the_vertex_budget_returns_the_mesh_reached_and_where_it_stopped() {
    let points = generated(Distribution2d::Uniform, 3_000, 3);
    let options = Options::default().min_angle(30.0).max_vertices(4_000);
    let Err(Error::VertexBudget(partial)) = mesh(&Input::points(&points[..]), &options) else {
        panic!("the budget stops refinement")
    };
    assert_eq!(partial.limit, 4_000);
    let any_angle = quadmesh::AngleBounds {
        min_deg: 0.0,
        max_deg: 180.0,
    };
    partial
        .mesh
        .validate(&points, any_angle)
        .expect("the partial mesh is valid");
    partial.mesh.check_delaunay().expect("and Delaunay");
    assert!(!partial.unmet.is_empty());
    for u in &partial.unmet {
        let t = partial.mesh.triangles[u.triangle as usize];
        let [a, b, c] = t.map(|v| partial.mesh.vertices[v as usize]);
        assert!((u.at - (a + b + c) / 3.0).length() < 1e-12);
        assert!(u.min_angle < 30.0);
    }
    assert_eq!(partial.report.triangles, partial.mesh.triangles.len());
    let message = Error::VertexBudget(partial).to_string();
    assert!(
        message.contains("4000") && message.contains("near"),
        "{message}"
    );
}

#[test]
fn every_region_meshes_and_the_output_does_not_depend_on_the_thread_count() {
    let points = generated(Distribution2d::Cluster, 40_000, 5);
    let rect = quadmesh::Domain {
        lo: DVec2::splat(-10.0),
        hi: DVec2::splat(10.0),
    };
    for region in [
        Region::Auto,
        Region::BoundingBox,
        Region::Square,
        Region::Rectangle(rect),
    ] {
        let options = Options::default().region(region).min_angle(28.0);
        let one = on_threads(1, || checked(&points, &options).0);
        let three = on_threads(3, || checked(&points, &options).0);
        assert!(one == three, "{region:?}: 1 and 3 threads differ");
        assert_eq!(one.outline.is_some(), region == Region::Auto);
    }
}

#[test]
fn options_out_of_range_and_unsupported_input_are_typed_errors() {
    let points = Input::points(vec![DVec2::ZERO, DVec2::X, DVec2::Y]);
    let bad = [
        (Options::default().min_angle(50.0), "min_angle"),
        (Options::default().max_area(-1.0), "max_area"),
        (Options::default().warp().max_area(1.0), "mode"),
        (
            Options::default().warp().region(Region::ConvexHull),
            "region",
        ),
    ];
    for (options, name) in bad {
        match mesh(&points, &options) {
            Err(Error::InvalidOption { option, .. }) => assert_eq!(option, name),
            other => panic!("{name}: {other:?}"),
        }
    }
    let mut with_segments = points.clone();
    with_segments.segments.push(quadmesh::Segment {
        ends: [0, 1],
        marker: 1,
    });
    // The block warp does not mesh segments; the warp and Delaunay modes refuse a lone open
    // segment as enclosing nothing.
    assert_eq!(
        mesh(&with_segments, &Options::default().block_warp()),
        Err(Error::Unsupported { what: "segments" })
    );
    assert_eq!(
        mesh(&with_segments, &Options::default().warp()),
        Err(Error::NothingEnclosed)
    );
    assert_eq!(
        mesh(&with_segments, &Options::default()),
        Err(Error::NothingEnclosed)
    );
    let collinear = Input::points(vec![DVec2::ZERO, DVec2::X, DVec2::new(2.0, 0.0)]);
    assert!(matches!(
        mesh(&collinear, &Options::default()),
        Err(Error::Degenerate { .. })
    ));
    assert!(mesh(&collinear, &Options::default().region(Region::Square)).is_ok());
    assert_eq!(
        mesh(&Input::default(), &Options::default()),
        Err(Error::Empty)
    );
}

#[test]
fn the_warp_mode_is_one_option_away() {
    let points = generated(Distribution2d::Uniform, 500, 1);
    let (coarse, report) = checked(&points, &Options::default().warp());
    assert!(report.min_angle >= 20.0 - 1e-9 && report.max_angle <= 120.0 + 1e-9);
    assert!(coarse.outline.is_none());
    let (m, report) = checked(&points, &Options::default().compact_warp());
    assert!(report.min_angle >= 26.0 - 1e-9 && report.max_angle <= 120.0 + 1e-9);
    assert!(m.triangles.len() > 3 * coarse.triangles.len());
    let (block, report) = checked(&points, &Options::default().block_warp());
    assert!(report.min_angle >= 22.5 - 1e-9 && report.max_angle <= 112.5 + 1e-9);
    assert!(block.triangles.len() > 2 * m.triangles.len());
}

#[test]
fn a_point_a_rounding_inside_a_hull_side_becomes_a_boundary_vertex() {
    // The middle point is the two ends' midpoint written in decimal: a rounding off their side
    // (Triangle's spiral example has it). Splitting that side would need a vertex where the
    // point already is; the outline bends through the point instead.
    let (a, b) = (DVec2::new(0.005, 1.963), DVec2::new(-1.35, 0.436));
    let middle = DVec2::new(-0.6725, 1.1995);
    let points = vec![
        a,
        middle,
        b,
        DVec2::new(0.0, 0.0),
        DVec2::new(1.0, 0.2),
        DVec2::new(0.3, 0.9),
    ];
    for angle in [20.0, 30.0] {
        let (m, _) = checked(&points, &Options::default().min_angle(angle));
        let outline = m.outline.as_ref().unwrap();
        assert!(outline.contains(&middle), "{outline:?}");
    }
}

#[test]
fn the_default_mesh_with_strips_and_tiles_is_the_same_on_one_and_three_threads() {
    // 100 000 points: two strips glued at a seam, the hull cut out of them, refined by tiles.
    let points = generated(Distribution2d::Kuzmin, 100_000, 11);
    let options = Options::default();
    let one = on_threads(1, || checked(&points, &options).0);
    let three = on_threads(3, || checked(&points, &options).0);
    assert!(one == three, "1 and 3 threads differ");
}
