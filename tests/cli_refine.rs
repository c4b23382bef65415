//! `quadmesh mesh --min-angle` and `quadmesh bench --min-angle` end to end: the files read back
//! as a valid mesh meeting the angle bound, the same on 1 and 2 threads; bad bounds and
//! an exhausted vertex budget are one-line errors that write nothing; the warning above the
//! proven bound appears exactly when it should.

mod cli_support;
mod common;

use cli_support::{
    TempDir, bench_json, generate, json_number, quadmesh, read_triangle_files, s, stderr,
};
use common::{convex_hull, mesh_area, narrow_corners, polygon_area};
use quadmesh::mesh::{AngleBounds, NONE, angles_deg};

/// The angle bounds `--min-angle a` promises.
fn bounds(a: f64) -> AngleBounds {
    AngleBounds {
        min_deg: a,
        max_deg: 180.0 - 2.0 * a,
    }
}

#[test]
fn min_angle_30_files_read_back_as_a_valid_mesh() {
    let dir = TempDir::new("valid");
    let (input, points) = generate(&dir, 500, "cluster");
    let prefix = dir.file("out");
    let out = quadmesh(&[
        "mesh",
        s(&input),
        "-o",
        s(&prefix),
        "--min-angle",
        "30",
        "--domain",
        "square",
        "--check",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stderr(&out).contains("check                   passed"));
    let mesh = read_triangle_files(&prefix);
    if let Err(fault) = mesh.validate(&points, bounds(30.0)) {
        panic!("mesh read back from files is invalid: {fault}");
    }
    let smallest = mesh
        .triangles
        .iter()
        .flat_map(|t| {
            let [a, b, c] = t.map(|v| mesh.vertices[v as usize]);
            angles_deg(a, b, c)
        })
        .fold(f64::INFINITY, f64::min);
    assert!(smallest >= 30.0 - 1e-9, "smallest angle {smallest}");
    // Every input point is a vertex; refinement added Steiner points for the bound.
    let inputs = mesh.vertex_input.iter().filter(|&&i| i != NONE).count();
    assert_eq!(inputs, points.len());
    assert!(mesh.vertices.len() > points.len() + 4);
}

#[test]
fn one_and_two_threads_write_the_same_bytes() {
    let dir = TempDir::new("threads");
    let (input, _) = generate(&dir, 2000, "kuzmin");
    let run = |threads: &str, name: &str| {
        let prefix = dir.file(name);
        let out = quadmesh(&[
            "mesh",
            s(&input),
            "-o",
            s(&prefix),
            "--min-angle",
            "30",
            "--format",
            "node,vtu,msh",
            "--threads",
            threads,
        ]);
        assert!(out.status.success(), "{}", stderr(&out));
        ["node", "ele", "neigh", "edge", "vtu", "msh"].map(|e| {
            (
                e,
                std::fs::read(format!("{}.{e}", prefix.display())).unwrap(),
            )
        })
    };
    let one = run("1", "one");
    let two = run("2", "two");
    for ((e, a), (_, b)) in one.iter().zip(&two) {
        assert!(!a.is_empty(), "{e} is empty");
        assert!(a == b, ".{e} files differ between 1 and 2 threads");
    }
}

#[test]
fn bad_bounds_are_a_one_line_error_and_write_nothing() {
    let dir = TempDir::new("bad");
    let (input, _) = generate(&dir, 100, "uniform");
    let prefix = dir.file("out");
    let mut faults = Vec::new();
    for (args, option) in [
        (["--min-angle", "50"], "--min-angle"),
        (["--min-angle", "-3"], "--min-angle"),
        (["--max-area", "0"], "--max-area"),
    ] {
        let out = quadmesh(&[&["mesh", s(&input), "-o", s(&prefix)][..], &args[..]].concat());
        let err = stderr(&out);
        let case = args.join(" ");
        if out.status.success() {
            faults.push(format!("{case}: succeeded"));
        }
        if err.contains("panicked") {
            faults.push(format!("{case}: panicked: {err}"));
        }
        if !(err.starts_with("error: ") && err.trim_end().lines().count() == 1) {
            faults.push(format!("{case}: not a one-line error: {err:?}"));
        }
        if !err.contains(option) {
            faults.push(format!("{case}: the error does not name {option}: {err:?}"));
        }
        if dir.names() != ["points.txt"] {
            faults.push(format!("{case}: wrote {:?}", dir.names()));
        }
    }
    assert!(faults.is_empty(), "{}", faults.join("\n"));
}

#[test]
fn only_bounds_above_the_proven_one_warn() {
    let dir = TempDir::new("warn");
    let (input, _) = generate(&dir, 200, "uniform");
    let run = |angle: &str| {
        let out = quadmesh(&[
            "mesh",
            s(&input),
            "-o",
            s(&dir.file(angle)),
            "--min-angle",
            angle,
        ]);
        assert!(out.status.success(), "{}", stderr(&out));
        stderr(&out)
    };
    let above = run("30");
    let warnings: Vec<&str> = above
        .lines()
        .filter(|l| l.starts_with("warning: "))
        .collect();
    assert_eq!(warnings.len(), 1, "{above}");
    assert!(warnings[0].contains("20.7"), "{above}");
    let below = run("20");
    assert!(!below.contains("warning"), "{below}");
}

#[test]
fn an_exhausted_vertex_budget_writes_the_mesh_reached_and_is_an_error() {
    let dir = TempDir::new("budget");
    let (input, _) = generate(&dir, 300, "cluster");
    let out = quadmesh(&[
        "mesh",
        s(&input),
        "-o",
        s(&dir.file("out")),
        "--format",
        "node,vtu,msh,svg",
        "--max-vertices",
        "10",
        "--min-angle",
        "30",
    ]);
    let err = stderr(&out);
    assert!(!out.status.success(), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    let errors: Vec<&str> = err.lines().filter(|l| l.starts_with("error: ")).collect();
    assert_eq!(errors.len(), 1, "{err}");
    assert_eq!(err.trim_end().lines().last(), Some(errors[0]), "{err}");
    assert!(
        errors[0].contains("budget") && errors[0].contains("near"),
        "{err}"
    );
    let mut names = dir.names();
    names.sort();
    assert_eq!(
        names,
        [
            "out.edge",
            "out.ele",
            "out.msh",
            "out.neigh",
            "out.node",
            "out.svg",
            "out.vtu",
            "points.txt"
        ],
        "{err}"
    );
}

#[test]
fn bench_min_angle_prints_one_json_object_last() {
    let last = bench_json(&[
        "--points",
        "2000",
        "--min-angle",
        "25",
        "--threads",
        "2",
        "--json",
    ]);
    for key in [
        "\"points\":2000",
        "\"threads\":2",
        "\"morton_s\":",
        "\"delaunay_s\":",
        "\"refine_s\":",
        "\"mesh_s\":",
        "\"angles_s\":",
        "\"total_s\":",
        "\"vertices\":",
        "\"triangles\":",
        "\"min_angle\":",
        "\"max_angle\":",
        "\"peak_rss_bytes\":",
    ] {
        assert!(last.contains(key), "{key} missing from {last}");
    }
    let field = |key: &str| json_number(&last, key);
    assert!(field("triangles") > 0.0, "{last}");
    assert!(field("vertices") >= 2000.0 + 4.0, "{last}");
    assert!(field("min_angle") >= 25.0 - 1e-9, "{last}");
    assert!(field("max_angle") <= 130.0 + 1e-9, "{last}");
    assert!(field("total_s") >= field("refine_s"), "{last}");
}

#[test]
fn a_domain_through_the_points_reads_back_as_that_rectangle() {
    let dir = TempDir::new("domain");
    let (input, points) = generate(&dir, 400, "uniform");
    let (lo, hi) = quadmesh::morton::bounding_box(&points);
    let rectangle = format!("{:?},{:?},{:?},{:?}", lo.x, lo.y, hi.x, hi.y);
    let prefix = dir.file("out");
    let out = quadmesh(&[
        "mesh",
        s(&input),
        "-o",
        s(&prefix),
        "--min-angle",
        "30",
        "--domain",
        &rectangle,
        "--check",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let mesh = read_triangle_files(&prefix);
    // The reader takes the domain from the vertices' extent: it is the bounding box itself.
    assert_eq!((mesh.domain.lo, mesh.domain.hi), (lo, hi));
    if let Err(fault) = mesh.validate(&points, bounds(30.0)) {
        panic!("mesh read back from files is invalid: {fault}");
    }
}

#[test]
fn bad_domains_are_one_line_errors() {
    let dir = TempDir::new("bad-domain");
    let (input, _) = generate(&dir, 100, "uniform");
    let prefix = dir.file("out");
    for (args, says) in [
        (&["--min-angle", "30", "--domain", "0,0,1"][..], "--domain"),
        (
            &["--min-angle", "30", "--domain", "0,0,1,x"][..],
            "--domain",
        ),
        (
            &["--min-angle", "30", "--domain", "0,0,1,0"][..],
            "--domain",
        ),
        (
            &["--min-angle", "30", "--domain", "0.1,0.1,0.2,0.2"][..],
            "outside the domain",
        ),
        (&["--domain", "0,0,1,0"][..], "--domain"),
        (&["--domain", "0.1,0.1,0.2,0.2"][..], "outside the domain"),
        (&["--warp", "--max-vertices", "9"][..], "--max-vertices"),
    ] {
        let out = quadmesh(&[&["mesh", s(&input), "-o", s(&prefix)][..], args].concat());
        let err = stderr(&out);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(
            err.lines()
                .any(|l| l.starts_with("error: ") && l.contains(says)),
            "{args:?}: {err}"
        );
        assert_eq!(dir.names(), ["points.txt"], "{args:?} wrote files");
    }
}

/// `quadmesh mesh` with no mode flag: the Delaunay mesh of the points' convex hull, its area the
/// hull's, every angle at least the default 20° except at a hull corner narrower than that.
#[test]
fn the_default_mesh_covers_the_convex_hull_at_20_degrees() {
    for dist in ["uniform", "cluster", "kuzmin"] {
        let dir = TempDir::new("default");
        let (input, points) = generate(&dir, 3000, dist);
        let prefix = dir.file("out");
        let out = quadmesh(&["mesh", s(&input), "-o", s(&prefix), "--check"]);
        assert!(out.status.success(), "{dist}: {}", stderr(&out));
        let mesh = read_triangle_files(&prefix);
        let hull = convex_hull(&points);
        let (want, got) = (polygon_area(&hull), mesh_area(&mesh));
        assert!(
            (got - want).abs() <= 1e-9 * want,
            "{dist}: area {got} vs hull {want}"
        );
        let narrow = narrow_corners(&hull, 20.0);
        for t in &mesh.triangles {
            let corners = t.map(|v| mesh.vertices[v as usize]);
            if corners.iter().any(|p| narrow.contains(p)) {
                continue;
            }
            let [a, b, c] = corners;
            let min = angles_deg(a, b, c).into_iter().fold(f64::MAX, f64::min);
            assert!(min >= 20.0 - 1e-9, "{dist}: {min}");
        }
        // Every input point is a vertex with its exact coordinates.
        let mapped = mesh.vertex_input.iter().filter(|&&i| i != NONE).count();
        assert_eq!(mapped, points.len(), "{dist}");
    }
}
