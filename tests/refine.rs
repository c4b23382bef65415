//! Off-center Delaunay refinement: every mesh passes `Mesh::validate` with the bounds the mode
//! promises (every angle at least the bound A, hence at most 180 - 2A) and the exact
//! `Mesh::check_delaunay`, meets its area bound, agrees with its report, and 1 and 2 threads give
//! the same mesh. Bad options and impossible requests are typed errors, never hangs.

mod common;

use std::sync::mpsc;
use std::time::Duration;

use common::{FAMILIES, distinct_count, mesh_angles, mixed_point_sets, on_threads};
use proptest::prelude::*;
use quadmesh::generate::{self, Distribution2d};
use quadmesh::mesh::{AngleBounds, Domain, NONE};
use quadmesh::refine::{
    GUARANTEED_MIN_ANGLE_DEG, MAX_MIN_ANGLE_DEG, RefineDomain, RefineOptions, refine_points,
};
use quadmesh::{DVec2, Error, Mesh, MeshReport};

/// The bounds a mesh refined for `min_angle_deg` must meet.
fn bounds(min_angle_deg: f64) -> AngleBounds {
    AngleBounds {
        min_deg: min_angle_deg,
        max_deg: 180.0 - 2.0 * min_angle_deg,
    }
}

/// The options these tests start from: 30° on the square around the points (the hull, the
/// library's default region, is tested in `front.rs`).
fn square() -> RefineOptions {
    RefineOptions {
        min_angle_deg: 30.0,
        domain: RefineDomain::Square,
        ..RefineOptions::default()
    }
}

fn angle(min_angle_deg: f64) -> RefineOptions {
    RefineOptions {
        min_angle_deg,
        ..square()
    }
}

fn refine_checked(points: &[DVec2], options: &RefineOptions) -> (Mesh, MeshReport) {
    let (mesh, report) = refine_points(points, options).unwrap_or_else(|e| {
        panic!(
            "refining {} points with {options:?} failed: {e}",
            points.len()
        )
    });
    check(points, options, &mesh, &report);
    (mesh, report)
}

/// Every check a refined mesh goes through.
fn check(points: &[DVec2], options: &RefineOptions, mesh: &Mesh, report: &MeshReport) {
    let what = || format!("the mesh of {} points with {options:?}", points.len());
    if let Err(fault) = mesh.validate(points, bounds(options.min_angle_deg)) {
        panic!("{} is invalid: {fault}", what());
    }
    if let Err(fault) = mesh.check_delaunay() {
        panic!("{} is not Delaunay: {fault}", what());
    }
    if let Some(max_area) = options.max_area {
        check_areas(mesh, max_area);
    }
    check_report(mesh, report, options.min_angle_deg);
}

/// Every triangle's area is at most `max_area`, computed as refinement does (half the cross
/// product from the first corner), so the comparison needs no slack.
fn check_areas(mesh: &Mesh, max_area: f64) {
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let [a, b, c] = tri.map(|v| mesh.vertices[v as usize]);
        let area = 0.5 * (b - a).perp_dot(c - a);
        assert!(
            area <= max_area,
            "triangle {t} {tri:?} has area {area} > {max_area}"
        );
    }
}

/// The report's counts and angles are the mesh's.
fn check_report(mesh: &Mesh, report: &MeshReport, min_angle_deg: f64) {
    assert_eq!(report.vertices, mesh.vertices.len());
    assert_eq!(report.triangles, mesh.triangles.len());
    let inputs = mesh.vertex_input.iter().filter(|&&i| i != NONE).count();
    assert_eq!(report.points, inputs);
    let angles: u64 = report.histogram.iter().sum();
    assert_eq!(angles, 3 * mesh.triangles.len() as u64);
    let b = bounds(min_angle_deg);
    assert!(report.min_angle >= b.min_deg - 1e-9, "{}", report.min_angle);
    assert!(report.max_angle <= b.max_deg + 1e-9, "{}", report.max_angle);
    let (lo, hi) = mesh_angles(mesh).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
        (lo.min(x), hi.max(x))
    });
    assert!(
        (report.min_angle - lo).abs() < 1e-9,
        "{} vs {lo}",
        report.min_angle
    );
    assert!(
        (report.max_angle - hi).abs() < 1e-9,
        "{} vs {hi}",
        report.max_angle
    );
}

/// Runs `f` on its own thread and fails if it takes longer than `secs` (a hang).
fn within<T: Send + 'static>(secs: u64, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (send, receive) = mpsc::channel();
    std::thread::spawn(move || send.send(f()));
    receive
        .recv_timeout(Duration::from_secs(secs))
        .unwrap_or_else(|_| panic!("no answer within {secs} s"))
}

#[test]
fn angle_constants() {
    let proven = (1.0 / (2.0 * 2f64.sqrt())).asin().to_degrees();
    assert!((GUARANTEED_MIN_ANGLE_DEG - proven).abs() < 1e-12);
    assert_eq!(MAX_MIN_ANGLE_DEG, 45.0);
    assert_eq!(
        RefineOptions::default().min_angle_deg,
        quadmesh::DEFAULT_MIN_ANGLE_DEG
    );
    assert_eq!(RefineOptions::default().domain, RefineDomain::ConvexHull);
}

#[test]
fn every_family_refines_validly() {
    for dist in FAMILIES {
        for n in [10, 300, 3000] {
            let points = generate::points(dist, n, 7);
            for a in [0.0, 20.0, 25.0, 30.0, 33.0] {
                let (_, report) = refine_checked(&points, &angle(a));
                assert_eq!(report.points, n, "{dist:?}");
            }
        }
    }
}

/// Ignored: exposes a bug. `RefineOptions::min_angle_deg` promises that zero, without an area
/// bound, gives the Delaunay triangulation of the points and the square's corners, but
/// refinement still splits every boundary edge an apex sees at 90° or more (encroached edges are
/// queued whatever the bounds), so Steiner points appear on the boundary. Smallest case: the one
/// point (0.3, 0.6) gives 9 vertices, the 4 corners, the point and the 4 sides' midpoints.
#[test]
fn angle_zero_is_the_delaunay_triangulation_of_the_points_and_corners() {
    let one = [DVec2::new(0.3, 0.6)];
    let (mesh, _) = refine_checked(&one, &angle(0.0));
    assert_eq!(mesh.vertices.len(), 5, "{:?}", mesh.vertices);
    let points = generate::points(Distribution2d::Uniform, 300, 4);
    let (mesh, report) = refine_checked(&points, &angle(0.0));
    assert_eq!(mesh.vertices.len(), report.points + 4);
    assert_eq!(mesh.triangles.len(), 2 * report.points + 2);
}

#[test]
fn area_bound_alone_and_with_an_angle() {
    let points = generate::points(Distribution2d::Uniform, 300, 5);
    let domain = refine_checked(&points, &angle(0.0)).0.domain;
    let max_area = domain.area() / 2000.0;
    for a in [0.0, 30.0] {
        let options = RefineOptions {
            max_area: Some(max_area),
            ..angle(a)
        };
        let (mesh, _) = refine_checked(&points, &options);
        assert!(mesh.triangles.len() as f64 * max_area >= domain.area());
    }
    // The bound alone on a single point, down to many times more triangles than points.
    let one = [DVec2::new(0.3, 0.6)];
    let domain = refine_checked(&one, &angle(0.0)).0.domain;
    let options = RefineOptions {
        max_area: Some(domain.area() / 5000.0),
        ..angle(0.0)
    };
    refine_checked(&one, &options);
}

#[test]
fn collinear_points() {
    let line: Vec<DVec2> = (0..500).map(|i| DVec2::new(i as f64 * 0.37, 2.0)).collect();
    let diagonal: Vec<DVec2> = (0..500).map(|i| DVec2::splat(i as f64 / 499.0)).collect();
    for points in [line, diagonal] {
        for a in [0.0, 30.0] {
            refine_checked(&points, &angle(a));
        }
    }
}

#[test]
fn duplicates_are_merged_and_reported() {
    let mut points = generate::points(Distribution2d::Uniform, 400, 3);
    points.extend_from_within(..50);
    points.push(DVec2::new(-0.0, 0.5));
    points.push(DVec2::new(0.0, 0.5));
    let (mesh, report) = refine_checked(&points, &angle(30.0));
    assert_eq!(report.duplicates, 51);
    assert_eq!(report.points, 401);
    // The first occurrence is the one kept: -0.0 at 450 before 0.0 at 451.
    assert!(
        mesh.vertex_input
            .iter()
            .all(|&i| i == NONE || i < 400 || i == 450)
    );
}

#[test]
fn one_and_two_points() {
    let one = [DVec2::new(3.0, -2.0)];
    let two = [DVec2::new(0.0, 0.0), DVec2::new(1.0, 0.0)];
    for a in [0.0, 30.0, 33.0] {
        let (mesh, report) = refine_checked(&one, &angle(a));
        assert_eq!(report.points, 1);
        let v = mesh.vertex_input.iter().position(|&i| i == 0).unwrap();
        assert_eq!(mesh.vertices[v], one[0]);
        let (_, report) = refine_checked(&two, &angle(a));
        assert_eq!(report.points, 2);
    }
}

#[test]
fn one_and_two_threads_give_the_same_mesh() {
    for dist in FAMILIES {
        let points = generate::points(dist, 20_000, 11);
        let options = square();
        let run = |threads| on_threads(threads, || refine_points(&points, &options).unwrap());
        let (one, _) = run(1);
        let (two, report) = run(2);
        assert!(one == two, "{dist:?}");
        check(&points, &options, &two, &report);
    }
}

#[test]
fn bad_input_is_a_typed_error() {
    let options = square();
    assert_eq!(refine_points(&[], &options).unwrap_err(), Error::Empty);
    let nan = [DVec2::new(0.0, 0.0), DVec2::new(f64::NAN, 1.0)];
    assert!(matches!(
        refine_points(&nan, &options),
        Err(Error::NonFinite { index: 1, .. })
    ));
    let infinite = [DVec2::new(f64::INFINITY, 0.0)];
    assert!(matches!(
        refine_points(&infinite, &options),
        Err(Error::NonFinite { index: 0, .. })
    ));
}

#[test]
fn bad_options_are_typed_errors() {
    let points = generate::points(Distribution2d::Uniform, 20, 1);
    let refused = |options: RefineOptions| match refine_points(&points, &options) {
        Err(Error::InvalidOption { option, message }) => {
            assert!(!message.is_empty());
            option
        }
        other => panic!("{options:?} gave {other:?}"),
    };
    for a in [-1.0, 46.0, f64::NAN, f64::INFINITY, -0.1, 45.000001] {
        assert_eq!(refused(angle(a)), "min-angle", "{a}");
    }
    for area in [0.0, -1.0, f64::INFINITY, f64::NAN, -0.0] {
        let options = RefineOptions {
            max_area: Some(area),
            ..square()
        };
        assert_eq!(refused(options), "max-area", "{area}");
    }
    // Options are checked before the points.
    assert!(matches!(
        refine_points(&[], &angle(50.0)),
        Err(Error::InvalidOption { .. })
    ));
}

/// Refining `points` at 30° with a budget of `extra` vertices more than the points ends in
/// `VertexBudget` naming that budget, not in a hang.
fn assert_budget_error(points: Vec<DVec2>, extra: usize) {
    let limit = points.len() + extra;
    let options = RefineOptions {
        max_vertices: Some(limit),
        ..angle(30.0)
    };
    match within(120, move || refine_points(&points, &options)) {
        Err(Error::VertexBudget(partial)) => {
            assert_eq!(partial.limit, limit);
            assert!(!partial.unmet.is_empty());
        }
        other => panic!("expected a vertex budget error, got {other:?}"),
    }
}

#[test]
fn a_small_vertex_budget_is_an_error_not_a_hang() {
    assert_budget_error(generate::points(Distribution2d::Uniform, 300, 6), 10);
}

#[test]
fn an_area_bound_beyond_the_budget_is_an_error() {
    let points = generate::points(Distribution2d::Uniform, 10, 6);
    let options = RefineOptions {
        max_area: Some(1e-9),
        max_vertices: Some(5000),
        ..angle(0.0)
    };
    assert!(matches!(
        within(120, move || refine_points(&points, &options)),
        Err(Error::VertexBudget(partial)) if partial.limit == 5000
    ));
}

/// Refinement for 45° on a few hundred points: a valid mesh (every angle 45°, 45° or 90°) or
/// `VertexBudget` within the budget, or `RefinementResolution`, quickly.
fn refine_45(dist: Distribution2d, n: usize) -> Result<(Mesh, MeshReport), Error> {
    let points = generate::points(dist, n, 8);
    let options = RefineOptions {
        max_vertices: Some(20_000),
        ..angle(45.0)
    };
    let answer = within(120, {
        let points = points.clone();
        move || refine_points(&points, &options)
    });
    match &answer {
        Ok((mesh, report)) => check(&points, &options, mesh, report),
        Err(Error::VertexBudget(partial)) => {
            assert_eq!(partial.limit, 20_000);
            assert!(!partial.unmet.is_empty());
        }
        Err(_) => {}
    }
    answer
}

const FAMILIES_45: [(Distribution2d, usize); 2] =
    [(Distribution2d::Uniform, 300), (Distribution2d::Grid, 200)];

/// 45° is accepted but out of reach: refinement ends, validly, with an error or a mesh.
#[test]
fn angle_45_ends() {
    for (dist, n) in FAMILIES_45 {
        match refine_45(dist, n) {
            Ok(_) | Err(Error::VertexBudget(_) | Error::RefinementResolution { .. }) => {}
            Err(other) => panic!("{dist:?}: unexpected error {other}"),
        }
    }
}

/// Ignored: exposes a bug. Above about 35° off-centers spiral into one spot until the triangle's
/// edges are one ulp long, so refinement stops with `RefinementResolution` ("the points span too
/// many orders of magnitude") long before the vertex budget, on inputs that span none:
/// `generate::points(Uniform, 300, 8)` at 45° (and at 36°) fails after about 700 of the 20 000
/// vertices allowed, near (0.36, 0.19); `generate::points(Grid, 200, 8)` after about 640.
#[test]
fn unreachable_angles_say_so() {
    for (dist, n) in FAMILIES_45 {
        match refine_45(dist, n) {
            Ok(_) | Err(Error::VertexBudget(_)) => {}
            Err(e @ Error::RefinementResolution { .. }) => {
                assert!(
                    e.to_string().contains("cannot reach the angle bound"),
                    "{e}"
                );
            }
            Err(other) => panic!("{dist:?}: unexpected error {other}"),
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn random_point_sets_refine_validly(points in mixed_point_sets()) {
        let (_, report) = refine_checked(&points, &angle(30.0));
        let distinct = distinct_count(&points);
        prop_assert_eq!(report.points, distinct);
        prop_assert_eq!(report.duplicates, points.len() - distinct);
    }
}

/// The bounding box of `points` as a domain.
fn bounding_box(points: &[DVec2]) -> Domain {
    let (lo, hi) = quadmesh::morton::bounding_box(points);
    Domain { lo, hi }
}

#[test]
fn a_domain_through_the_points_is_meshed_exactly() {
    // The bounding box touches the extreme points (and, for the grid, whole rows of points):
    // they become boundary vertices and the mesh covers the box exactly.
    for dist in FAMILIES {
        for n in [300, 3000] {
            let points = generate::points(dist, n, 6);
            let domain = bounding_box(&points);
            for a in [0.0, 20.0, 30.0] {
                let options = RefineOptions {
                    domain: RefineDomain::Rectangle(domain),
                    ..angle(a)
                };
                let (mesh, report) = refine_checked(&points, &options);
                assert_eq!(mesh.domain, domain);
                assert_eq!(report.points, n);
            }
        }
    }
}

#[test]
fn points_on_domain_corners_are_those_corners() {
    let points = [
        DVec2::new(0.0, 0.0),
        DVec2::new(2.0, 1.0),
        DVec2::new(0.5, 0.25),
        DVec2::new(2.0, 0.5),
    ];
    let domain = Domain {
        lo: DVec2::ZERO,
        hi: DVec2::new(2.0, 1.0),
    };
    for a in [0.0, 30.0] {
        let options = RefineOptions {
            domain: RefineDomain::Rectangle(domain),
            ..angle(a)
        };
        let (mesh, report) = refine_checked(&points, &options);
        assert_eq!(report.points, 4);
        let inputs = mesh.vertex_input.iter().filter(|&&i| i != NONE).count();
        assert_eq!(inputs, 4, "every input point is exactly one vertex");
        // Two of the points are domain corners, so the plain triangulation has 6 vertices.
        if a == 0.0 {
            assert_eq!(mesh.vertices.len(), 6);
            assert_eq!(mesh.triangles.len(), 5);
        }
    }
}

#[test]
fn a_wide_domain_far_from_the_points() {
    let points = generate::points(Distribution2d::Cluster, 500, 3);
    let domain = Domain {
        lo: DVec2::new(-40.0, -3.0),
        hi: DVec2::new(60.0, 4.0),
    };
    let options = RefineOptions {
        domain: RefineDomain::Rectangle(domain),
        ..angle(30.0)
    };
    let (mesh, _) = refine_checked(&points, &options);
    assert_eq!(mesh.domain, domain);
}

#[test]
fn bad_domains_are_typed_errors() {
    let points = [DVec2::new(0.5, 0.5), DVec2::new(0.25, 1.5)];
    let unit = Domain {
        lo: DVec2::ZERO,
        hi: DVec2::ONE,
    };
    let options = RefineOptions {
        domain: RefineDomain::Rectangle(unit),
        ..angle(30.0)
    };
    assert_eq!(
        refine_points(&points, &options).unwrap_err(),
        Error::OutsideDomain {
            index: 1,
            x: 0.25,
            y: 1.5
        }
    );
    for bad in [
        Domain {
            lo: DVec2::ZERO,
            hi: DVec2::new(0.0, 1.0),
        },
        Domain {
            lo: DVec2::ONE,
            hi: DVec2::ZERO,
        },
        Domain {
            lo: DVec2::ZERO,
            hi: DVec2::new(f64::NAN, 1.0),
        },
    ] {
        let options = RefineOptions {
            domain: RefineDomain::Rectangle(bad),
            ..angle(30.0)
        };
        match refine_points(&points, &options) {
            Err(Error::InvalidOption { option, .. }) => assert_eq!(option, "domain"),
            other => panic!("{bad:?}: expected an invalid domain, got {other:?}"),
        }
    }
}

/// Enough points that the Delaunay triangulation is built in strips, and refinement runs by
/// tiles in parallel before the sequential loop.
const TILED: usize = 70_000;

#[test]
fn tiled_refinement_is_valid_on_every_family() {
    for dist in FAMILIES {
        let points = generate::points(dist, TILED, 21);
        for a in [20.0, 30.0, 33.0] {
            let (_, report) = refine_checked(&points, &angle(a));
            assert_eq!(report.points, distinct_count(&points), "{dist:?} at {a}°");
        }
    }
}

/// The same mesh, byte for byte, whatever the number of threads, for every kind of work the
/// tiles share: angle and area bounds, and boundary edges of a domain through the points.
#[test]
fn tiled_refinement_does_not_depend_on_the_thread_count() {
    for dist in FAMILIES {
        let points = generate::points(dist, TILED, 22);
        let box_area = {
            let d = bounding_box(&points);
            (d.hi - d.lo).x * (d.hi - d.lo).y
        };
        let variants = [
            angle(30.0),
            RefineOptions {
                max_area: Some(box_area / 100_000.0),
                ..angle(25.0)
            },
            RefineOptions {
                domain: RefineDomain::Rectangle(bounding_box(&points)),
                ..angle(30.0)
            },
        ];
        for options in variants {
            let run = |threads| on_threads(threads, || refine_points(&points, &options).unwrap());
            let (one, report) = run(1);
            check(&points, &options, &one, &report);
            for threads in [2, 3] {
                let (other, _) = run(threads);
                assert!(one == other, "{dist:?}, {options:?}, {threads} threads");
            }
        }
    }
}

#[test]
fn tiled_refinement_with_an_area_bound_meets_it() {
    let points = generate::points(Distribution2d::Kuzmin, TILED, 23);
    let domain = bounding_box(&points);
    let options = RefineOptions {
        max_area: Some((domain.hi - domain.lo).x * (domain.hi - domain.lo).y / 200_000.0),
        domain: RefineDomain::Rectangle(domain),
        ..angle(28.0)
    };
    refine_checked(&points, &options);
}

#[test]
fn tiled_refinement_stops_at_the_vertex_budget() {
    assert_budget_error(generate::points(Distribution2d::Uniform, TILED, 24), 5_000);
}
