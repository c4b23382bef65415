//! Warped meshes of a given rectangle: points may lie on its sides and corners, its sides need
//! not lie on the quadtree's grid, and every mesh keeps the warp's angle bounds and passes
//! `Mesh::validate`.

mod common;

use common::{
    COMPACT, FAMILIES, check_warped, check_warped_within, distinct_count, mixed_point_sets,
    on_threads, refused_beyond_f64,
};
use proptest::prelude::*;
use quadmesh::balance::{DomainSides, Separation, check_separated_in, separate_in};
use quadmesh::framework::build_framework;
use quadmesh::generate::{self, Distribution2d};
use quadmesh::mesh::{BoundarySide, Domain, Reflection};
use quadmesh::morton::MortonKey;
use quadmesh::morton::bounding_box;
use quadmesh::morton::{Morton, SortAlgorithm, morton_order_on};
use quadmesh::pipeline::{domain_reflections, separated_tree};
use quadmesh::quadtree::expand;
use quadmesh::{DVec2, Error, Mesh, MeshOptions, MeshReport, Tree, TreeBuild, mesh_points};

fn options(domain: Domain) -> MeshOptions {
    MeshOptions {
        domain: Some(domain),
        ..MeshOptions::default()
    }
}

fn compact(domain: Domain) -> MeshOptions {
    MeshOptions {
        separation: Separation::Corner,
        ..options(domain)
    }
}

/// The block warp's mesh of `points` on `domain`, checked: valid with the warp's bounds,
/// covering exactly the domain, and every point on a side a vertex of boundary edges on that
/// side; and the compact warp's, checked the same with its bounds.
fn mesh_in(points: &[DVec2], domain: Domain) -> (Mesh, MeshReport) {
    check_compact_in(points, domain);
    let (mesh, report) = mesh_points(points, &options(domain)).unwrap();
    check_warped(points, &mesh, &report);
    check_on_domain(points, &mesh, domain);
    (mesh, report)
}

/// The compact warp's mesh of `points` on `domain`, checked as [`mesh_in`] checks; or a
/// refusal that names a point f64 cannot place a mesh around at the domain's scale (its leaves
/// around the point's corner are finer than the block warp's 5×5 leaves need).
fn check_compact_in(points: &[DVec2], domain: Domain) {
    match mesh_points(points, &compact(domain)) {
        Ok((mesh, report)) => {
            check_warped_within(points, &mesh, &report, COMPACT);
            check_on_domain(points, &mesh, domain);
        }
        Err(error @ (Error::Unresolvable { .. } | Error::Inseparable { .. })) => {
            assert!(
                refused_beyond_f64(points, &error, domain.lo, domain.hi),
                "{error}"
            );
        }
        Err(error) => panic!("{error}"),
    }
}

/// The mesh covers `domain`, and every point on a side is a vertex of boundary edges there.
fn check_on_domain(points: &[DVec2], mesh: &Mesh, domain: Domain) {
    assert_eq!(mesh.domain, domain);
    for (v, &input) in mesh.vertex_input.iter().enumerate() {
        if input == u32::MAX {
            continue;
        }
        let p = points[input as usize];
        for side in sides_of(p, domain) {
            let on_edge = mesh
                .boundary
                .iter()
                .any(|e| e.side() == Some(side) && e.vertices.contains(&(v as u32)));
            assert!(
                on_edge,
                "point {input} {p} is on the {side:?} side but no edge there"
            );
        }
    }
}

/// Checks the well-separated tree of `points` on a domain at least as wide as tall: balanced,
/// linked, every point located, its block cut only at the sides the point lies on, and the band
/// along the top side (when that cuts the grid) of one level.
fn check_tree_in(points: &[DVec2], domain: Domain) {
    fn check<K: MortonKey>(build: &TreeBuild<K>, points: &[DVec2]) {
        let m = &build.morton;
        let tree = build.balanced.as_ref().unwrap();
        tree.check(&m.keys).unwrap();
        let sides = DomainSides::of(points, &m.order, &m.grid);
        check_separated_in(&tree.tree, &m.keys, sides.as_ref(), build.band).unwrap();
        assert_eq!(build.band.is_some(), m.grid.inner_top().is_some());
    }
    match separated_tree(points, &options(domain)).unwrap().0 {
        Tree::Narrow(b) => check(&b, points),
        Tree::Wide(b) => check(&b, points),
    }
}

fn sides_of(p: DVec2, d: Domain) -> Vec<BoundarySide> {
    [
        (p.y == d.lo.y, BoundarySide::Bottom),
        (p.x == d.hi.x, BoundarySide::Right),
        (p.y == d.hi.y, BoundarySide::Top),
        (p.x == d.lo.x, BoundarySide::Left),
    ]
    .into_iter()
    .filter_map(|(on, side)| on.then_some(side))
    .collect()
}

/// The points' bounding box, widened along an axis where it has no extent.
fn bounding_domain(points: &[DVec2]) -> Domain {
    let (lo, hi) = bounding_box(points);
    let extent = match (hi - lo).max_element() {
        0.0 => 1.0,
        e => e,
    };
    let pad = DVec2::select(
        (hi - lo).cmpeq(DVec2::ZERO),
        DVec2::splat(extent),
        DVec2::ZERO,
    );
    Domain { lo, hi: hi + pad }
}

fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> Domain {
    Domain {
        lo: DVec2::new(x0, y0),
        hi: DVec2::new(x1, y1),
    }
}

#[test]
fn bounding_boxes_mesh_validly() {
    for dist in FAMILIES {
        for n in [2, 10, 200, 3000] {
            let points = generate::points(dist, n, 5);
            let domain = bounding_domain(&points);
            let (_, report) = mesh_in(&points, domain);
            assert_eq!(report.points, distinct_count(&points), "{dist:?}");
            let extent = domain.hi - domain.lo;
            if extent.x >= extent.y {
                check_tree_in(&points, domain);
            }
        }
    }
}

#[test]
fn square_wide_and_tall_domains() {
    let points = generate::points(Distribution2d::Uniform, 500, 3);
    for domain in [
        rect(0.0, 0.0, 1.0, 1.0),
        rect(-0.5, 0.0, 1.5, 1.0),
        rect(0.0, -0.5, 1.0, 1.5),
        rect(-3.0, -0.25, 1.25, 1.0),
        rect(-1e3, -1e3, 1e3, 1e3),
    ] {
        mesh_in(&points, domain);
    }
}

#[test]
fn points_on_every_side_and_corner() {
    let d = rect(-1.0, 2.0, 3.0, 4.5);
    let mut points = vec![
        d.lo,
        d.hi,
        DVec2::new(d.lo.x, d.hi.y),
        DVec2::new(d.hi.x, d.lo.y),
    ];
    for t in [0.1, 0.37, 0.5, 0.52, 0.9] {
        let x = d.lo.x + t * (d.hi.x - d.lo.x);
        let y = d.lo.y + t * (d.hi.y - d.lo.y);
        points.extend([
            DVec2::new(x, d.lo.y),
            DVec2::new(x, d.hi.y),
            DVec2::new(d.lo.x, y),
            DVec2::new(d.hi.x, y),
        ]);
    }
    points.extend(
        generate::points(Distribution2d::Cluster, 300, 9)
            .iter()
            .map(|p| d.lo + (d.hi - d.lo) * p.clamp(DVec2::ZERO, DVec2::ONE)),
    );
    mesh_in(&points, d);
    // The same points in the mirrored (tall) domain.
    let mirrored: Vec<DVec2> = points.iter().map(|p| DVec2::new(p.y, p.x)).collect();
    mesh_in(&mirrored, d.reflected(Reflection::Diagonal));
}

#[test]
fn many_points_on_the_inner_side() {
    // A domain wider than tall, so its top side cuts through the grid, lined with points.
    let d = rect(0.0, 0.0, 1.0, 0.3);
    let mut points: Vec<DVec2> = (0..=200)
        .map(|i| DVec2::new(i as f64 / 200.0, 0.3))
        .collect();
    points.extend(
        generate::points(Distribution2d::Uniform, 500, 4)
            .iter()
            .map(|p| *p * DVec2::new(1.0, 0.29)),
    );
    mesh_in(&points, d);
}

#[test]
fn thin_domains() {
    let points: Vec<DVec2> = generate::points(Distribution2d::Uniform, 300, 8)
        .iter()
        .map(|p| DVec2::new(p.x * 1000.0, p.y))
        .collect();
    mesh_in(&points, bounding_domain(&points));
    mesh_in(&points, rect(-1.0, -0.5, 1001.0, 1.5));
}

/// The uniform band's shapes: the side keeps the crossed row (its top moves down onto the side),
/// drops it (the row below stretches up), or lies on a grid line.
#[derive(Debug, PartialEq, Eq, PartialOrd, Ord)]
enum BandShape {
    Keeps,
    Drops,
    Exact,
}

/// The uniform band that lines the top side of `domain` (at least as wide as tall) on a root as
/// wide as the domain, the fallback when no root width grades the side; the tree is checked.
fn uniform_band_shape(points: &[DVec2], domain: Domain) -> BandShape {
    let frame = Some((domain.lo, domain.hi, quadmesh::morton::DomainLayout::Root));
    let Morton::Narrow(m) = morton_order_on(points, frame, SortAlgorithm::default()).unwrap()
    else {
        panic!("narrow grid expected")
    };
    let quadtree = expand(&build_framework(&m.keys), &m.keys);
    let sides = DomainSides::of(points, &m.order, &m.grid);
    let (tree, band) =
        separate_in(&quadtree, &m.keys, sides.as_ref(), 60, Separation::Block).unwrap();
    tree.check(&m.keys).unwrap();
    check_separated_in(&tree.tree, &m.keys, sides.as_ref(), band).unwrap();
    let (band, top) = (band.unwrap(), m.grid.inner_top().unwrap());
    assert_eq!(band.finest, band.level);
    match (band.top_row as f64).partial_cmp(&top).unwrap() {
        std::cmp::Ordering::Greater => BandShape::Keeps,
        std::cmp::Ordering::Less => BandShape::Drops,
        std::cmp::Ordering::Equal => BandShape::Exact,
    }
}

#[test]
fn the_uniform_band_takes_both_shapes() {
    let base = generate::points(Distribution2d::Uniform, 300, 12);
    let mut shapes = Vec::new();
    for k in 0..40 {
        let height = 0.3 + 0.0173 * k as f64;
        let points: Vec<DVec2> = base.iter().map(|p| *p * DVec2::new(1.0, height)).collect();
        shapes.push(uniform_band_shape(&points, rect(0.0, 0.0, 1.0, height)));
    }
    shapes.sort();
    shapes.dedup();
    assert!(shapes.contains(&BandShape::Keeps), "{shapes:?}");
    assert!(shapes.contains(&BandShape::Drops), "{shapes:?}");
    // A dyadic height puts the side on a grid line.
    let points: Vec<DVec2> = base.iter().map(|p| *p * DVec2::new(1.0, 0.375)).collect();
    let d = rect(0.0, 0.0, 1.0, 0.375);
    assert_eq!(uniform_band_shape(&points, d), BandShape::Exact);
    mesh_in(&points, d);
}

#[test]
fn graded_leaves_meet_the_inner_side_of_uniform_points() {
    // Uniform points come within about 1/n of their bounding box's sides; a row of equal leaves
    // that fine along the top side would double the mesh, graded leaves cost what the points
    // near the four sides refine (about 10% at this size, 2.5% at 1e6 points).
    let points = generate::points(Distribution2d::Uniform, 20_000, 21);
    let domain = bounding_domain(&points);
    let (_, report) = mesh_in(&points, domain);
    let (_, square) = mesh_points(&points, &MeshOptions::default()).unwrap();
    let per_point = |r: &MeshReport| r.triangles as f64 / r.points as f64;
    assert!(
        per_point(&report) < 1.2 * per_point(&square),
        "{} against {}",
        per_point(&report),
        per_point(&square)
    );
    let reflections = domain_reflections(&points, domain);
    let image: Vec<DVec2> = points
        .iter()
        .map(|&p| reflections.iter().fold(p, |p, r| r.point(p)))
        .collect();
    let wide = reflections.iter().fold(domain, |d, &r| d.reflected(r));
    let (tree, _) = separated_tree(&image, &options(wide)).unwrap();
    let Tree::Narrow(build) = tree else {
        panic!("uniform points fit the narrow grid")
    };
    let band = build.band.expect("a band");
    assert!(band.finest > band.level, "{band:?}");
    check_tree_in(&image, wide);
}

#[test]
fn bad_domains_are_typed_errors() {
    let points = generate::points(Distribution2d::Uniform, 100, 2);
    let run = |d: Domain| mesh_points(&points, &options(d)).map(|_| ());
    assert!(matches!(
        run(rect(0.1, 0.1, 0.9, 0.9)),
        Err(Error::OutsideDomain { .. })
    ));
    for bad in [
        rect(0.0, 0.0, 0.0, 1.0),
        rect(0.0, 1.0, 1.0, 0.0),
        rect(f64::NAN, 0.0, 1.0, 1.0),
        rect(0.0, 0.0, f64::INFINITY, 1.0),
    ] {
        assert!(
            matches!(
                run(bad),
                Err(Error::InvalidOption {
                    option: "domain",
                    ..
                })
            ),
            "{bad:?}"
        );
    }
    let mut nan = points.clone();
    nan[7].x = f64::NAN;
    assert!(matches!(
        mesh_points(&nan, &options(rect(0.0, 0.0, 1.0, 1.0))),
        Err(Error::NonFinite { index: 7, .. })
    ));
}

#[test]
fn a_needle_of_a_domain_is_an_error() {
    let points = [DVec2::new(0.0, 0.0), DVec2::new(1.0, 1e-7)];
    let needle = rect(0.0, 0.0, 1.0, 1e-7);
    assert!(matches!(
        mesh_points(&points, &options(needle)),
        Err(Error::ThinDomain { .. })
    ));
    let mirrored = [DVec2::new(0.0, 0.0), DVec2::new(1e-7, 1.0)];
    match mesh_points(&mirrored, &options(needle.reflected(Reflection::Diagonal))) {
        Err(Error::ThinDomain { width, height }) => assert_eq!((width, height), (1e-7, 1.0)),
        other => panic!("{:?}", other.map(|_| ())),
    }
}

#[test]
fn points_nearly_on_both_long_sides_are_an_error_naming_one() {
    // A height no choice of root puts near a grid line to within 1e-13 (the golden ratio's
    // multiples keep away from integers), so the side needs a row of equal leaves.
    let height = (5f64.sqrt() - 1.0) / 4.0;
    let mut points: Vec<DVec2> = generate::points(Distribution2d::Uniform, 100, 6)
        .iter()
        .map(|p| DVec2::new(p.x, 0.01 + (height - 0.02) * p.y))
        .collect();
    let wide = rect(0.0, 0.0, 1.0, height);
    // Nearly on the top side only: the mesh lines the bottom side instead.
    points.push(DVec2::new(0.3, height - 1e-13));
    mesh_in(&points, wide);
    // Nearly on both: the side with the more distant point is lined, and that point named.
    points.push(DVec2::new(0.6, 2e-13));
    match mesh_points(&points, &options(wide)) {
        Err(Error::NearDomainSide { index, side, .. }) => {
            assert_eq!((index, side), (101, BoundarySide::Bottom));
        }
        other => panic!("{:?}", other.map(|_| ())),
    }
    let mirrored: Vec<DVec2> = points.iter().map(|p| DVec2::new(p.y, p.x)).collect();
    match mesh_points(&mirrored, &options(wide.reflected(Reflection::Diagonal))) {
        Err(Error::NearDomainSide {
            index, side, x, y, ..
        }) => {
            assert_eq!((index, side), (101, BoundarySide::Left));
            assert_eq!(DVec2::new(x, y), mirrored[101]);
        }
        other => panic!("{:?}", other.map(|_| ())),
    }
    // On the sides themselves, the points are boundary vertices like any other.
    points[100].y = height;
    points[101].y = 0.0;
    mesh_in(&points, wide);
}

#[test]
fn a_side_on_a_grid_line_needs_no_row_of_equal_leaves() {
    // Half as tall as wide: the top side is a grid line, and points nearly on it only refine
    // locally.
    let mut points: Vec<DVec2> = generate::points(Distribution2d::Uniform, 100, 6)
        .iter()
        .map(|p| DVec2::new(p.x, 0.01 + 0.48 * p.y))
        .collect();
    points.extend([DVec2::new(0.3, 0.5 - 1e-13), DVec2::new(0.6, 2e-13)]);
    let (_, report) = mesh_in(&points, rect(0.0, 0.0, 1.0, 0.5));
    assert!(report.triangles < 100 * 1000, "{}", report.triangles);
}

#[test]
fn one_and_two_threads_give_the_same_mesh() {
    for dist in FAMILIES {
        let points = generate::points(dist, 20_000, 13);
        let domain = bounding_domain(&points);
        let one = on_threads(1, || mesh_points(&points, &options(domain)).unwrap().0);
        let two = on_threads(2, || mesh_points(&points, &options(domain)).unwrap().0);
        assert!(one == two, "{dist:?}");
    }
}

/// A domain around `points`: their bounding box, each side pushed out by its own margin (zero
/// for some, so that points lie on them).
fn around(points: &[DVec2], margins: [f64; 4]) -> Domain {
    let tight = bounding_domain(points);
    let extent = (tight.hi - tight.lo).max_element();
    Domain {
        lo: tight.lo - DVec2::new(margins[0], margins[1]) * extent,
        hi: tight.hi + DVec2::new(margins[2], margins[3]) * extent,
    }
}

/// Two points 3.4e-12 apart near the middle of a domain some 900 wide (a proptest case): the
/// block warp places its mesh between them, the compact warp refuses them by name, as f64
/// cannot place its finer leaves there.
#[test]
fn points_too_close_for_the_compact_warps_leaves_are_refused_by_name() {
    let points = [
        DVec2::new(0.250_000_727_541_611_96, 0.5),
        DVec2::new(0.0, 0.0),
        DVec2::new(0.250_000_727_538_237_65, 0.5),
        DVec2::new(-327.000_848_064_645_25, 508.986_838_234_969_2),
    ];
    let domain = around(
        &points,
        [0.615_947_943_773_719_1, 0.0, 0.0, 0.189_171_023_658_362_9],
    );
    mesh_in(&points, domain);
    let error = mesh_points(&points, &compact(domain)).unwrap_err();
    assert!(
        matches!(error, Error::Unresolvable { index: 2, .. }),
        "{error}"
    );
}

/// A point on the top side (inside the root, for a wide domain) a hair from a corner needs
/// fine leaves where the side meets the corner; the graded root reckons with them instead of
/// falling back to a row of equal cells, which would need 2^21 of them here.
#[test]
fn a_point_on_the_inner_side_next_to_a_corner() {
    let points = [
        DVec2::new(0.2500009153300934, 0.5),
        DVec2::new(0.6875, 0.25),
        DVec2::new(0.25, 0.0),
    ];
    let domain = Domain {
        lo: DVec2::new(0.25, 0.0),
        hi: DVec2::new(0.6875 + 0.18944410957037244 * 0.5, 0.5),
    };
    let (_, report) = mesh_in(&points, domain);
    assert_eq!(report.points, 3);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn random_point_sets_mesh_validly_in_random_domains(
        points in mixed_point_sets(),
        margins in prop::array::uniform4(prop_oneof![Just(0.0), 0.0f64..0.7]),
    ) {
        let domain = around(&points, margins);
        // Points closer together than f64 can place a mesh between, or the grid can tell
        // apart, at the domain's scale, are refused, naming them.
        if let Err(error @ (Error::Unresolvable { .. } | Error::Inseparable { .. })) = mesh_points(&points, &options(domain)) {
            prop_assert!(refused_beyond_f64(&points, &error, domain.lo, domain.hi), "{error}");
            return Ok(());
        }
        let (_, report) = mesh_in(&points, domain);
        prop_assert_eq!(report.points, distinct_count(&points));
        // The tree of the mirror image the mesh was made in.
        let reflections = domain_reflections(&points, domain);
        let image: Vec<DVec2> = points
            .iter()
            .map(|&p| reflections.iter().fold(p, |p, r| r.point(p)))
            .collect();
        check_tree_in(&image, reflections.iter().fold(domain, |d, &r| d.reflected(r)));
    }
}
