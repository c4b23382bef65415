//! Quality meshes of planar straight-line graphs through the library's front door: Triangle's
//! examples and inputs made here (many holes, nested regions with area bounds, segments meeting
//! at small angles, thousands of segments), each checked by the independent PSLG check, the
//! exact constrained Delaunay check and on 1 and 2 threads; and bad graphs refused by name.

mod common;

use quadmesh::mesh::{AngleBounds, validate_pslg, validate_pslg_with};
use quadmesh::{DVec2, Error, Input, Mesh, MeshReport, Options, Region, RegionSeed, Segment};

/// Meshes `input` on one and on two threads, checks that both give the same mesh, and checks
/// it as a mesh of the graph (`hull`: of its convex hull) with the options' angle bounds.
fn mesh_checked(input: &Input, options: Options, hull: bool) -> (Mesh, MeshReport) {
    let one = common::on_threads(1, || quadmesh::mesh(input, &options)).expect("a mesh");
    let two = common::on_threads(2, || quadmesh::mesh(input, &options)).expect("a mesh");
    assert_eq!(one.0, two.0, "1 and 2 threads give different meshes");
    let (mesh, report) = one;
    validate_pslg_with(&mesh, input, options.angle_bounds(), hull)
        .unwrap_or_else(|e| panic!("invalid mesh: {e}"));
    mesh.check_delaunay()
        .unwrap_or_else(|e| panic!("not constrained Delaunay: {e}"));
    (mesh, report)
}

fn closed_loop(
    points: &mut Vec<DVec2>,
    segments: &mut Vec<Segment>,
    corners: &[DVec2],
    marker: i32,
) {
    let first = points.len() as u32;
    let n = corners.len() as u32;
    points.extend_from_slice(corners);
    segments.extend((0..n).map(|k| Segment {
        ends: [first + k, first + (k + 1) % n],
        marker,
    }));
}

fn square(lo: DVec2, side: f64) -> [DVec2; 4] {
    [
        lo,
        lo + DVec2::new(side, 0.0),
        lo + DVec2::splat(side),
        lo + DVec2::new(0.0, side),
    ]
}

/// Three nested squares (sides 8, 4, 2 around the origin), each ring a region with attribute
/// 10, 20, 30 and the area bound returned for it.
fn nested_regions() -> (Input, [f64; 3]) {
    let mut input = Input::default();
    for (k, side) in [8.0, 4.0, 2.0].into_iter().enumerate() {
        let lo = DVec2::splat(-side / 2.0);
        closed_loop(
            &mut input.points,
            &mut input.segments,
            &square(lo, side),
            k as i32 + 1,
        );
    }
    let areas = [0.5, 0.05, 0.005];
    for (k, seed) in [3.5, 1.5, 0.0].into_iter().enumerate() {
        input.regions.push(RegionSeed {
            seed: DVec2::splat(seed),
            attribute: 10.0 * (k + 1) as f64,
            max_area: Some(areas[k]),
        });
    }
    (input, areas)
}

#[test]
fn triangle_examples_mesh_at_20_and_30_degrees() {
    let Some(dir) = common::triangle_examples() else {
        eprintln!("skipped: the Python package `triangle` is not installed");
        return;
    };
    for name in [
        "A",
        "face",
        "la",
        "double_hex",
        "double_hex2",
        "square_circle_hole",
    ] {
        let input = quadmesh::io::read_input(&dir.join(format!("{name}.poly"))).unwrap();
        for angle in [20.0, 30.0] {
            let (mesh, report) = mesh_checked(&input, Options::default().min_angle(angle), false);
            assert!(!mesh.segments.is_empty(), "{name}");
            assert_eq!(report.triangles, mesh.triangles.len());
            if !input.regions.is_empty() {
                assert_eq!(mesh.triangle_regions.len(), mesh.triangles.len(), "{name}");
            }
        }
    }
}

#[test]
fn the_letter_a_keeps_its_hole() {
    let Some(dir) = common::triangle_examples() else {
        return;
    };
    let input = quadmesh::io::read_input(&dir.join("A.poly")).unwrap();
    let (mesh, _) = mesh_checked(&input, Options::default(), false);
    let hole = input.holes[0];
    let inside = |t: &[u32; 3]| {
        let [a, b, c] = t.map(|v| mesh.vertices[v as usize]);
        let side = |p: DVec2, q: DVec2| (q - p).perp_dot(hole - p) >= 0.0;
        side(a, b) && side(b, c) && side(c, a)
    };
    assert!(!mesh.triangles.iter().any(inside));
    // The letter's area is well below its bounding box's.
    let (lo, hi) = (mesh.domain.lo, mesh.domain.hi);
    assert!(common::mesh_area(&mesh) < 0.7 * (hi - lo).x * (hi - lo).y);
}

#[test]
fn a_square_with_a_hundred_holes() {
    let mut input = Input::default();
    closed_loop(
        &mut input.points,
        &mut input.segments,
        &square(DVec2::ZERO, 10.0),
        1,
    );
    for i in 0..10 {
        for j in 0..10 {
            let lo = DVec2::new(i as f64 + 0.3, j as f64 + 0.25);
            closed_loop(&mut input.points, &mut input.segments, &square(lo, 0.5), 2);
            input.holes.push(lo + DVec2::splat(0.25));
        }
    }
    let (mesh, _) = mesh_checked(&input, Options::default().min_angle(30.0), false);
    let expected = 100.0 - 100.0 * 0.25;
    assert!((common::mesh_area(&mesh) - expected).abs() < 1e-9);
    assert!(mesh.boundary.iter().all(|e| e.marker == 1 || e.marker == 2));
}

/// At 33° the block's segments are split with free vertices inside their diametral circles,
/// which refinement deletes first (as Triangle does): the mesh is still a valid constrained
/// Delaunay mesh of the graph with every angle at least the bound, the same on two threads, and
/// it keeps no deleted vertex.
#[test]
fn free_vertices_in_a_split_segments_circle_are_deleted_first() {
    let block = quadmesh::generate::block_with_holes(200, 1);
    let (mesh, report) = mesh_checked(&block, Options::default().min_angle(33.0), false);
    assert!(report.free_vertices_deleted > 0, "no vertex was deleted");
    let mut used = vec![false; mesh.vertices.len()];
    for t in &mesh.triangles {
        for &v in t {
            used[v as usize] = true;
        }
    }
    assert!(used.iter().all(|&u| u), "a vertex is in no triangle");
    assert_eq!(report.vertices, mesh.vertices.len());
}

/// Spare Steiner vertices taken out after refinement: the mesh is still a valid constrained
/// Delaunay mesh of the graph with every angle at least the bound (checked independently), the
/// same on two threads, with fewer triangles than refinement alone left.
#[test]
fn spare_vertices_removed_leave_a_smaller_mesh_that_meets_the_bounds() {
    let block = quadmesh::generate::block_with_holes(200, 1);
    for angle in [20.0, 30.0, 33.0] {
        let plain = Options::default().min_angle(angle);
        let (before, _) = mesh_checked(&block, plain, false);
        let (after, report) = mesh_checked(&block, plain.remove_spare_vertices(), false);
        assert!(
            report.spare_vertices_removed > 0,
            "none removed at {angle}°"
        );
        assert!(
            after.triangles.len() < before.triangles.len(),
            "{} triangles after, {} before, at {angle}°",
            after.triangles.len(),
            before.triangles.len()
        );
        assert_eq!(report.vertices, after.vertices.len());
        // Every input point stays, bit for bit, and only Steiner vertices went.
        let inputs = |m: &Mesh| {
            m.vertex_input
                .iter()
                .filter(|&&i| i != quadmesh::NONE)
                .count()
        };
        assert_eq!(inputs(&after), inputs(&before));
    }
}

/// Regions' area bounds and a global one still hold after spare vertices are taken out.
#[test]
fn spare_vertices_removed_keep_the_area_bounds() {
    let (input, areas) = nested_regions();
    let options = Options::default()
        .min_angle(30.0)
        .max_area(0.1)
        .remove_spare_vertices();
    let (mesh, report) = mesh_checked(&input, options, false);
    assert!(report.spare_vertices_removed > 0);
    for (t, &r) in mesh.triangle_regions.iter().enumerate() {
        let [a, b, c] = mesh.triangles[t].map(|v| mesh.vertices[v as usize]);
        let area = 0.5 * (b - a).perp_dot(c - a);
        assert!(
            area <= areas[r as usize].min(0.1),
            "triangle {t} of area {area}"
        );
        assert_eq!(mesh.triangle_attribute(t), 10.0 * (r + 1) as f64);
    }
}

/// Triangle's examples with spare vertices taken out, at 30° and 33° (`la` with its regions'
/// area bounds): valid, the same on two threads, and no larger than without.
#[test]
fn triangle_examples_with_spare_vertices_removed() {
    let Some(dir) = common::triangle_examples() else {
        eprintln!("skipped: the Python package `triangle` is not installed");
        return;
    };
    for name in ["A", "face", "la", "double_hex", "square_circle_hole"] {
        let input = quadmesh::io::read_input(&dir.join(format!("{name}.poly"))).unwrap();
        for angle in [30.0, 33.0] {
            let plain = Options::default().min_angle(angle);
            let (before, _) = mesh_checked(&input, plain, false);
            let (after, _) = mesh_checked(&input, plain.remove_spare_vertices(), false);
            assert!(
                after.triangles.len() <= before.triangles.len(),
                "{name} {angle}"
            );
            for (t, &r) in after.triangle_regions.iter().enumerate() {
                let Some(bound) = input.regions.get(r as usize).and_then(|g| g.max_area) else {
                    continue;
                };
                let [a, b, c] = after.triangles[t].map(|v| after.vertices[v as usize]);
                assert!(
                    0.5 * (b - a).perp_dot(c - a) <= bound,
                    "{name}: triangle {t}"
                );
            }
        }
    }
}

/// A quadrilateral 4.4e63 long and 2 wide, with a spike 4.4e40 high (found by fuzzing): the
/// check once found its domain's area 0, a fan of rounded triangles from the spike's tip
/// cancelling it, and refused the mesh.
#[test]
fn a_domain_far_longer_than_wide_has_its_area_checked() {
    let mut input = Input::default();
    let corners = [
        DVec2::ZERO,
        DVec2::new(2.0, 4.444_444_444_444_404e40),
        DVec2::new(3.0, 2.0),
        DVec2::new(4.444_444_444_444_444e63, 2.0),
    ];
    closed_loop(&mut input.points, &mut input.segments, &corners, 7);
    input.holes.push(DVec2::new(1.0, -1.0));
    let (mesh, _) = mesh_checked(&input, Options::default().min_angle(16.0), false);
    let area = common::mesh_area(&mesh);
    assert!(
        (area / 4.444_444_444_444_444e63 - 1.0).abs() < 1e-9,
        "{area}"
    );
}

/// Seeds exactly on loose input points: a hole seed on a point inside a hole eats the hole,
/// and a region seed on a point inside a room names the room.
#[test]
fn seeds_on_loose_points_find_their_holes_and_regions() {
    let mut input = Input::default();
    closed_loop(
        &mut input.points,
        &mut input.segments,
        &square(DVec2::ZERO, 10.0),
        1,
    );
    for i in 0..4 {
        let lo = DVec2::new(1.0 + 2.0 * i as f64, 4.0);
        closed_loop(&mut input.points, &mut input.segments, &square(lo, 1.0), 2);
        let centre = lo + DVec2::splat(0.5);
        input.points.push(centre);
        input.holes.push(centre);
    }
    let loose = DVec2::new(5.0, 8.5);
    input.points.push(loose);
    input.regions.push(RegionSeed {
        seed: loose,
        attribute: 7.0,
        max_area: None,
    });
    let (mesh, _) = mesh_checked(&input, Options::default().min_angle(25.0), false);
    assert!((common::mesh_area(&mesh) - (100.0 - 4.0)).abs() < 1e-9);
    assert!(mesh.triangles.iter().all(|t| {
        let [a, b, c] = t.map(|v| mesh.vertices[v as usize]);
        let at = (a + b + c) / 3.0;
        !(at.y > 4.0 && at.y < 5.0 && (at.x - 1.0).rem_euclid(2.0) < 1.0)
    }));
    assert!((0..mesh.triangles.len()).all(|t| mesh.triangle_attribute(t) == 7.0));
}

#[test]
fn nested_regions_get_their_attributes_and_area_bounds() {
    let (input, areas) = nested_regions();
    let (mesh, _) = mesh_checked(&input, Options::default().min_angle(25.0), false);
    for (t, &r) in mesh.triangle_regions.iter().enumerate() {
        assert_ne!(r, quadmesh::NONE);
        let [a, b, c] = mesh.triangles[t].map(|v| mesh.vertices[v as usize]);
        let area = 0.5 * (b - a).perp_dot(c - a);
        assert!(
            area <= areas[r as usize],
            "triangle {t} of area {area} in region {r}"
        );
        assert_eq!(mesh.triangle_attribute(t), 10.0 * (r + 1) as f64);
    }
    // Finer regions hold more triangles per unit area.
    let count = |r: u32| mesh.triangle_regions.iter().filter(|&&x| x == r).count();
    assert!(count(2) as f64 / 4.0 > count(0) as f64 / 48.0);
    // A global bound applies together with the regions'.
    let options = Options::default().min_angle(25.0).max_area(0.1);
    let (mesh, _) = mesh_checked(&input, options, false);
    assert!(mesh.triangles.iter().all(|t| {
        let [a, b, c] = t.map(|v| mesh.vertices[v as usize]);
        0.5 * (b - a).perp_dot(c - a) <= 0.1
    }));
}

#[test]
fn segments_meeting_at_small_angles_keep_their_angles_and_finish() {
    for degrees in [1.0f64, 3.0, 5.0, 10.0] {
        // A square with a fan of segments from its lower-left corner, `degrees` apart.
        let mut input = Input::default();
        closed_loop(
            &mut input.points,
            &mut input.segments,
            &square(DVec2::ZERO, 10.0),
            1,
        );
        for k in 1..=3 {
            let a = (30.0 + degrees * k as f64).to_radians();
            input.points.push(DVec2::new(8.0 * a.cos(), 8.0 * a.sin()));
            let end = input.points.len() as u32 - 1;
            input.segments.push(Segment {
                ends: [0, end],
                marker: 5,
            });
        }
        for angle in [20.0, 30.0] {
            let options = Options::default().min_angle(angle).max_vertices(200_000);
            let (mesh, report) = mesh_checked(&input, options, false);
            assert!(report.min_angle < degrees + 1e-9, "{degrees}° at {angle}°");
            assert!(mesh.vertices.len() < 20_000, "{degrees}° at {angle}°");
        }
    }
}

#[test]
fn thousands_of_segments_on_a_wavy_outline_with_an_inner_ring() {
    let mut input = Input::default();
    let ring = |n: usize, radius: f64, wave: f64| -> Vec<DVec2> {
        (0..n)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / n as f64;
                let r = radius * (1.0 + wave * (7.0 * a).sin());
                DVec2::new(r * a.cos(), r * a.sin())
            })
            .collect()
    };
    closed_loop(
        &mut input.points,
        &mut input.segments,
        &ring(4000, 10.0, 0.1),
        1,
    );
    closed_loop(
        &mut input.points,
        &mut input.segments,
        &ring(1000, 4.0, 0.05),
        2,
    );
    input.holes.push(DVec2::ZERO);
    let (mesh, _) = mesh_checked(&input, Options::default().min_angle(30.0), false);
    assert!(mesh.segments.len() >= 5000);
}

#[test]
fn the_convex_hull_keeps_what_the_segments_do_not_enclose() {
    // An open polyline and a closed square hole inside the hull of scattered points.
    let mut input = Input::points(vec![
        DVec2::new(0.0, 0.0),
        DVec2::new(10.0, 0.0),
        DVec2::new(10.0, 8.0),
        DVec2::new(0.0, 8.0),
        DVec2::new(2.0, 2.0),
        DVec2::new(4.0, 5.0),
    ]);
    input.segments.push(Segment {
        ends: [4, 5],
        marker: 3,
    });
    closed_loop(
        &mut input.points,
        &mut input.segments,
        &square(DVec2::new(6.0, 2.0), 2.0),
        4,
    );
    input.holes.push(DVec2::new(7.0, 3.0));
    let options = Options::default().min_angle(30.0);
    assert!(matches!(
        quadmesh::mesh(&input, &options),
        Err(Error::NothingEnclosed)
    ));
    let (mesh, _) = mesh_checked(&input, options.region(Region::ConvexHull), true);
    assert!((common::mesh_area(&mesh) - 76.0).abs() < 1e-9);
    // The dangling segment is inside the domain, both its sides meshed.
    assert!(mesh.segments.iter().any(|s| s.marker == 3));
}

#[test]
fn without_boundary_steiner_points_the_boundary_stays_whole() {
    let mut input = Input::default();
    closed_loop(
        &mut input.points,
        &mut input.segments,
        &[
            DVec2::new(0.0, 0.0),
            DVec2::new(6.0, 0.0),
            DVec2::new(6.0, 1.0),
            DVec2::new(0.0, 1.0),
        ],
        1,
    );
    let options = Options::default().min_angle(20.0).no_boundary_steiner();
    let (mesh, _) = quadmesh::mesh(&input, &options).unwrap();
    assert_eq!(mesh.boundary.len(), 4);
    assert_eq!(mesh.segments.len(), 4);
    let free = Options::default().min_angle(20.0);
    let (split, _) = mesh_checked(&input, free, false);
    assert!(split.segments.len() > 4);
}

#[test]
fn duplicates_and_points_on_segments_are_cleaned_and_reported() {
    let mut input = Input::default();
    closed_loop(
        &mut input.points,
        &mut input.segments,
        &square(DVec2::ZERO, 4.0),
        1,
    );
    // A duplicate of corner 2, and a point in the middle of the bottom side.
    input.points.push(DVec2::new(4.0, 4.0));
    input.points.push(DVec2::new(2.0, 0.0));
    let (mesh, report) = quadmesh::mesh(&input, &Options::default()).unwrap();
    let cleaning = report
        .cleaning
        .expect("a graph's report says what cleaning did");
    assert_eq!(cleaning.merged_points, 1);
    assert_eq!(cleaning.vertex_splits, 1);
    // Input indices refer to the input as given: the duplicate is merged into point 2.
    assert!(mesh.vertex_input.contains(&5));
    assert!(!mesh.vertex_input.contains(&4));
    let bottom: Vec<_> = mesh.segments.iter().filter(|s| s.segment == 0).collect();
    assert!(bottom.len() >= 2);
    assert_eq!(mesh.vertices[bottom[0].vertices[0] as usize], DVec2::ZERO);
}

#[test]
fn bad_graphs_are_refused_by_name() {
    let base = || {
        let mut input = Input::default();
        closed_loop(
            &mut input.points,
            &mut input.segments,
            &square(DVec2::ZERO, 1.0),
            1,
        );
        input
    };
    let options = Options::default();
    let mut out_of_range = base();
    out_of_range.segments.push(Segment {
        ends: [0, 9],
        marker: 0,
    });
    assert!(matches!(
        quadmesh::mesh(&out_of_range, &options),
        Err(Error::SegmentIndex {
            segment: 4,
            index: 9,
            ..
        })
    ));
    let mut zero = base();
    zero.segments.push(Segment {
        ends: [2, 2],
        marker: 0,
    });
    assert!(matches!(
        quadmesh::mesh(&zero, &options),
        Err(Error::ZeroLengthSegment { segment: 4 })
    ));
    let mut crossing = base();
    crossing.segments.extend([
        Segment {
            ends: [0, 2],
            marker: 0,
        },
        Segment {
            ends: [1, 3],
            marker: 0,
        },
    ]);
    assert!(matches!(
        quadmesh::mesh(&crossing, &options),
        Err(Error::CrossingSegments { a: 4, b: 5, .. })
    ));
    let (mesh, report) = quadmesh::mesh(&crossing, &options.split_crossings()).unwrap();
    assert_eq!(report.cleaning.unwrap().crossing_splits, 1);
    assert!(mesh.vertices.contains(&DVec2::splat(0.5)));
    let mut nan = base();
    nan.points[1].x = f64::NAN;
    assert!(matches!(
        quadmesh::mesh(&nan, &options),
        Err(Error::NonFinite { index: 1, .. })
    ));
    let mut open = base();
    open.segments.pop();
    assert!(matches!(
        quadmesh::mesh(&open, &options),
        Err(Error::NothingEnclosed)
    ));
    let mut all_hole = base();
    all_hole.holes.push(DVec2::splat(0.5));
    assert!(matches!(
        quadmesh::mesh(&all_hole, &options),
        Err(Error::NothingEnclosed)
    ));
    assert!(matches!(
        quadmesh::mesh(&base(), &options.block_warp()),
        Err(Error::Unsupported { .. })
    ));
    assert!(matches!(
        quadmesh::mesh(&base(), &options.warp().region(Region::ConvexHull)),
        Err(Error::InvalidOption {
            option: "region",
            ..
        })
    ));
    assert!(matches!(
        quadmesh::mesh(&base(), &options.region(Region::Square)),
        Err(Error::InvalidOption {
            option: "region",
            ..
        })
    ));
}

#[test]
fn a_vertex_budget_returns_the_mesh_reached() {
    let mut input = Input::default();
    closed_loop(
        &mut input.points,
        &mut input.segments,
        &square(DVec2::ZERO, 1.0),
        1,
    );
    let options = Options::default().max_area(1e-4).max_vertices(200);
    match quadmesh::mesh(&input, &options) {
        Err(Error::VertexBudget(partial)) => {
            assert!(partial.mesh.vertices.len() > 200);
            assert!(!partial.unmet.is_empty());
            // The partial mesh is a valid mesh of the domain, without the quality.
            let loose = AngleBounds {
                min_deg: 0.0,
                max_deg: 180.0,
            };
            validate_pslg(&partial.mesh, &input, loose).unwrap();
        }
        other => panic!("expected the budget error, got {other:?}"),
    }
}

#[test]
fn crossings_split_while_the_points_are_triangulated_give_the_cleaned_graphs_mesh() {
    // A square crossed by a lattice of chords: cleaning adds a point at each of the 15 x 15
    // crossings, so the triangulation of the merged points, made alongside, is made again.
    let mut input = Input::default();
    closed_loop(
        &mut input.points,
        &mut input.segments,
        &square(DVec2::ZERO, 16.0),
        1,
    );
    for k in 1..16 {
        let at = k as f64 + 0.25 * (k % 3) as f64;
        for (a, b) in [
            (DVec2::new(at, 0.5), DVec2::new(at, 15.5)),
            (DVec2::new(0.5, at), DVec2::new(15.5, at)),
        ] {
            let first = input.points.len() as u32;
            input.points.extend([a, b]);
            input.segments.push(Segment {
                ends: [first, first + 1],
                marker: 2,
            });
        }
    }
    let options = Options::default().min_angle(25.0);
    let (split, report) = quadmesh::mesh(&input, &options.split_crossings()).unwrap();
    assert_eq!(report.cleaning.unwrap().crossing_splits, 15 * 15);
    validate_pslg_with(&split, &input, options.angle_bounds(), false)
        .unwrap_or_else(|e| panic!("invalid mesh: {e}"));
    let clean_options = quadmesh::pslg::CleanOptions {
        split_crossings: true,
    };
    let (cleaned, _) = quadmesh::pslg::clean(&input, clean_options).unwrap();
    assert_eq!(cleaned.points.len(), input.points.len() + 15 * 15);
    let (mesh, _) = mesh_checked(&cleaned, options, false);
    assert_eq!(split.vertices, mesh.vertices);
    assert_eq!(split.triangles, mesh.triangles);
}

#[test]
fn large_graphs_refine_in_tiles_the_same_on_any_thread_count() {
    // Enough points for the parallel tiles: nested rings with holes and regions, and a block
    // with rectangular holes.
    let rings = quadmesh::generate::nested_curves(40_000, 3);
    let (mesh, _) = mesh_checked(&rings, Options::default().min_angle(30.0), false);
    assert!(mesh.triangles.len() > 40_000);
    let three = common::on_threads(3, || {
        quadmesh::mesh(&rings, &Options::default().min_angle(30.0))
    })
    .unwrap();
    assert_eq!(mesh, three.0);
    let block = quadmesh::generate::block_with_holes(3_000, 5);
    let (mesh, _) = mesh_checked(
        &block,
        Options::default().min_angle(25.0).max_area(0.05),
        false,
    );
    assert!(mesh.triangles.len() > 20_000);
}

#[test]
fn a_graph_of_many_points_is_triangulated_in_strips_the_same_on_any_thread_count() {
    // Over 65 536 points, crowding every seam: the points are triangulated in strips.
    let block = quadmesh::generate::block_with_holes(17_000, 7);
    assert!(block.points.len() > 1 << 16);
    let (mesh, _) = mesh_checked(&block, Options::default().min_angle(20.0), false);
    assert!(mesh.triangles.len() > block.points.len());
}

/// A polygon star-shaped around `centre`: corners at the given angles (radians, increasing in
/// [0, 2π)) and radii.
fn star(centre: DVec2, corners: &[(f64, f64)]) -> Vec<DVec2> {
    corners
        .iter()
        .map(|&(a, r)| centre + r * DVec2::new(a.cos(), a.sin()))
        .collect()
}

/// `n` corners (in the range) of a star polygon: at angles `2π (k + jitter) / n` with jitter in
/// [0, 0.8), so consecutive angles are less than `3.6π / n` apart, and radii in the range.
fn star_corners(
    n: std::ops::Range<usize>,
    radii: std::ops::Range<f64>,
) -> impl Strategy<Value = Vec<(f64, f64)>> {
    n.prop_flat_map(move |n| {
        proptest::collection::vec((0.0..0.8f64, radii.clone()), n).prop_map(move |c| {
            c.iter()
                .enumerate()
                .map(|(k, &(jitter, r))| {
                    (std::f64::consts::TAU * (k as f64 + jitter) / n as f64, r)
                })
                .collect()
        })
    })
}

use proptest::prelude::*;

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// Random star-shaped domains with a star-shaped hole, at random bounds: every mesh passes
    /// the independent check and is the same on 1 and 2 threads.
    #[test]
    fn random_domains_with_a_hole_mesh_and_check(
        outer in star_corners(9..40, 0.5..1.5),
        inner in star_corners(4..16, 0.1..0.3),
        angle in 0.0..30.0f64,
        area in proptest::option::of(0.001..0.5f64),
    ) {
        // With 9 corners or more, the outer star's sides (radii at least 0.5, angles less than
        // 1.26 apart) stay further than 0.5 cos 0.63 > 0.4 from the centre, outside the inner
        // star (radii at most 0.3), whose 4 corners or more keep it simple.
        let mut input = Input::default();
        closed_loop(&mut input.points, &mut input.segments, &star(DVec2::ZERO, &outer), 1);
        closed_loop(&mut input.points, &mut input.segments, &star(DVec2::ZERO, &inner), 2);
        input.holes.push(DVec2::ZERO);
        let mut options = Options::default().min_angle(angle).max_vertices(100_000);
        if let Some(a) = area {
            options = options.max_area(a);
        }
        let (mesh, _) = mesh_checked(&input, options, false);
        prop_assert!(mesh.segments.len() >= input.segments.len());
    }

    /// Random segments thrown into a square, crossing or not: with crossings split the mesh is
    /// made or refused with a typed error, never a panic.
    #[test]
    fn random_crossing_segments_never_panic(
        ends in proptest::collection::vec(((0.0..4.0f64, 0.0..4.0f64), (0.0..4.0f64, 0.0..4.0f64)), 1..12),
        angle in 0.0..30.0f64,
    ) {
        let mut input = Input::default();
        closed_loop(&mut input.points, &mut input.segments, &square(DVec2::ZERO, 4.0), 1);
        for ((ax, ay), (bx, by)) in ends {
            let first = input.points.len() as u32;
            input.points.extend([DVec2::new(ax, ay), DVec2::new(bx, by)]);
            input.segments.push(Segment { ends: [first, first + 1], marker: 3 });
        }
        let options = Options::default().min_angle(angle).split_crossings().max_vertices(50_000);
        match quadmesh::mesh(&input, &options) {
            Ok((mesh, _)) => {
                prop_assert!((common::mesh_area(&mesh) - 16.0).abs() < 1e-9);
                mesh.check_delaunay().unwrap();
            }
            Err(Error::ZeroLengthSegment { .. } | Error::VertexBudget(_)) => {}
            Err(e) => prop_assert!(false, "unexpected error {e}"),
        }
    }
}
