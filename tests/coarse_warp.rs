//! The warp mode (`Mode::Warp`): the compact warp coarsened by edge collapses. Every mesh passes
//! `Mesh::validate` with the mode's bounds ([20°, 120°]: every input point a vertex with its
//! coordinates, the domain covered exactly), is the same on 1 and 2 threads, and has a small
//! fraction of the compact warp's triangles.

mod common;

use common::{FAMILIES, assert_report_extremes, mixed_point_sets, on_threads};
use proptest::prelude::*;
use quadmesh::generate::{Distribution2d, points};
use quadmesh::mesh::{AngleBounds, Domain};
use quadmesh::warp::COARSE_ANGLE_BOUNDS;
use quadmesh::{DVec2, Input, Mesh, MeshReport, Options, Region, mesh};

const COARSE: AngleBounds = AngleBounds {
    min_deg: COARSE_ANGLE_BOUNDS.0,
    max_deg: COARSE_ANGLE_BOUNDS.1,
};

/// The warp of `points` with `options`, checked: valid with the mode's bounds, its report
/// measuring the mesh, and the same bytes on 1 and 2 threads.
fn coarse_with(points: &[DVec2], options: Options) -> (Mesh, MeshReport) {
    let input = Input::points(points.to_vec());
    assert_eq!(options.angle_bounds(), COARSE);
    let (one, report) = on_threads(1, || mesh(&input, &options)).expect("meshed");
    let (two, _) = on_threads(2, || mesh(&input, &options)).expect("meshed");
    assert!(one == two, "1 and 2 threads differ");
    if let Err(fault) = one.validate(points, COARSE) {
        panic!("invalid coarsened warp of {} points: {fault}", points.len());
    }
    assert_report_extremes(&one, &report);
    assert_eq!(report.triangles, one.triangles.len());
    (one, report)
}

fn coarse(points: &[DVec2]) -> (Mesh, MeshReport) {
    coarse_with(points, Options::default().warp())
}

/// The compact warp's triangle count of `points` with `options` (its own bounds checked).
fn compact_triangles(points: &[DVec2], options: Options) -> usize {
    let options = options.compact_warp();
    let (m, _) = mesh(&Input::points(points.to_vec()), &options).expect("meshed");
    m.validate(points, options.angle_bounds()).expect("valid");
    m.triangles.len()
}

#[test]
fn every_family_coarsens_within_the_bounds_to_a_fraction_of_the_triangles() {
    for dist in FAMILIES {
        for n in [1, 10, 300, 4000] {
            let pts = points(dist, n, n as u64 + 11);
            let (m, _) = coarse(&pts);
            if n >= 300 {
                let compact = compact_triangles(&pts, Options::default());
                assert!(
                    m.triangles.len() * 3 < compact,
                    "{dist:?} {n}: {} coarsened, {compact} compact",
                    m.triangles.len()
                );
            }
        }
    }
}

#[test]
fn uniform_points_take_under_ten_triangles_each() {
    let pts = points(Distribution2d::Uniform, 20_000, 5);
    let (m, report) = coarse(&pts);
    let per_point = m.triangles.len() as f64 / pts.len() as f64;
    assert!(per_point < 10.0, "{per_point} triangles per point");
    assert!(report.min_angle >= 20.0 && report.max_angle <= 120.0);
}

#[test]
fn grid_aligned_collinear_and_close_points() {
    let lattice: Vec<DVec2> = (0..=16)
        .flat_map(|i| (0..=16).map(move |j| DVec2::new(i as f64 / 16.0, j as f64 / 16.0)))
        .collect();
    coarse(&lattice);
    let centres: Vec<DVec2> = (0..16)
        .flat_map(|i| {
            (0..16).map(move |j| DVec2::new((i as f64 + 0.5) / 16.0, (j as f64 + 0.5) / 16.0))
        })
        .collect();
    coarse(&centres);
    let line: Vec<DVec2> = (0..500).map(|i| DVec2::new(i as f64 * 0.37, 2.0)).collect();
    coarse(&line);
    let diagonal: Vec<DVec2> = (0..500).map(|i| DVec2::splat(i as f64 / 499.0)).collect();
    coarse(&diagonal);
    let pair = [DVec2::new(0.5, 0.5), DVec2::new(0.5 + 1e-7, 0.5)];
    coarse(&pair);
}

#[test]
fn on_a_given_rectangle_the_sides_stay_straight_and_points_on_them_stay() {
    let domain = Domain {
        lo: DVec2::new(-1.0, 2.0),
        hi: DVec2::new(3.0, 3.5),
    };
    let (lo, hi) = (domain.lo, domain.hi);
    let at = |t: DVec2| lo + (hi - lo) * t;
    let mut pts: Vec<DVec2> = points(Distribution2d::Uniform, 400, 9)
        .into_iter()
        .map(at)
        .collect();
    pts.extend([lo, hi, DVec2::new(lo.x, hi.y), DVec2::new(hi.x, lo.y)]);
    for k in 1..12 {
        let t = k as f64 / 12.0 + 0.013 * (k % 3) as f64;
        pts.extend([
            at(DVec2::new(t, 0.0)),
            at(DVec2::new(1.0, t)),
            at(DVec2::new(t, 1e-3)),
        ]);
    }
    let options = Options::default().warp().region(Region::Rectangle(domain));
    let (m, _) = coarse_with(&pts, options);
    assert_eq!(m.domain, domain);
    // Every boundary edge lies on one side of the rectangle.
    for edge in &m.boundary {
        let [a, b] = edge.vertices.map(|v| m.vertices[v as usize]);
        let on_one_side = (a.x == b.x && (a.x == lo.x || a.x == hi.x))
            || (a.y == b.y && (a.y == lo.y || a.y == hi.y));
        assert!(on_one_side, "{a} – {b}");
    }
    let compact = compact_triangles(&pts, Options::default().region(Region::Rectangle(domain)));
    assert!(
        m.triangles.len() * 3 < compact,
        "{} / {compact}",
        m.triangles.len()
    );
}

#[test]
fn a_point_whose_coordinates_square_past_f64_coarsens_within_the_bounds() {
    // Found by fuzzing: the cosine of a flat triangle 1e133 across, taken from products that
    // overflowed, read as a right angle, and the collapse made it.
    coarse(&[DVec2::new(-1.9836442359630618e-301, 6.212171904918606e132)]);
    coarse(&[DVec2::new(1e150, -3e149), DVec2::new(-2e150, 1e-300)]);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(100))]

    #[test]
    fn mixed_inputs_coarsen_valid_or_are_refused_as_the_compact_warp_is(pts in mixed_point_sets()) {
        let input = Input::points(pts.clone());
        let compact = mesh(&input, &Options::default().compact_warp());
        match (mesh(&input, &Options::default().warp()), compact) {
            (Ok((m, _)), Ok((c, _))) => {
                prop_assert!(m.validate(&pts, COARSE).is_ok());
                prop_assert!(m.triangles.len() <= c.triangles.len());
            }
            (Err(a), Err(b)) => prop_assert_eq!(a.to_string(), b.to_string()),
            (a, b) => prop_assert!(false, "{:?} against {:?}", a.err(), b.err()),
        }
    }
}
