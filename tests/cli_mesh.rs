//! `quadmesh mesh` and `quadmesh bench` end to end: the files they write read back as a valid
//! mesh of the input, the same on 1 and 2 threads; bad input is a one-line error.

mod cli_support;

use cli_support::{
    TempDir, bench_json, generate, json_number, quadmesh, read_triangle_files, s, stderr,
};
use quadmesh::mesh::AngleBounds;
use quadmesh::warp::{ANGLE_BOUNDS, COARSE_ANGLE_BOUNDS, COMPACT_ANGLE_BOUNDS};

/// The block warp's bounds, which `--warp` keeps on a given domain.
const WARP: AngleBounds = AngleBounds {
    min_deg: ANGLE_BOUNDS.0,
    max_deg: ANGLE_BOUNDS.1,
};

/// The compact warp's bounds, `--compact-warp`.
const COMPACT: AngleBounds = AngleBounds {
    min_deg: COMPACT_ANGLE_BOUNDS.0,
    max_deg: COMPACT_ANGLE_BOUNDS.1,
};

/// The coarsened warp's bounds, `--warp`.
const COARSE: AngleBounds = AngleBounds {
    min_deg: COARSE_ANGLE_BOUNDS.0,
    max_deg: COARSE_ANGLE_BOUNDS.1,
};

#[test]
fn mesh_files_read_back_as_a_valid_mesh() {
    let dir = TempDir::new("valid");
    let (input, points) = generate(&dir, 300, "cluster");
    let prefix = dir.file("out");
    let out = quadmesh(&["mesh", s(&input), "-o", s(&prefix), "--check", "--warp"]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stderr(&out).contains("check                   passed"));
    let coarse = read_triangle_files(&prefix);
    if let Err(fault) = coarse.validate(&points, COARSE) {
        panic!("mesh read back from files is invalid: {fault}");
    }
    // The compact warp before coarsening keeps the narrower range, with several times the
    // triangles.
    let compact = dir.file("compact");
    let out = quadmesh(&[
        "mesh",
        s(&input),
        "-o",
        s(&compact),
        "--check",
        "--compact-warp",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let mesh = read_triangle_files(&compact);
    if let Err(fault) = mesh.validate(&points, COMPACT) {
        panic!("compact-warped mesh read back from files is invalid: {fault}");
    }
    assert!(
        mesh.triangles.len() > 3 * coarse.triangles.len(),
        "{} compact-warped triangles, {} coarsened",
        mesh.triangles.len(),
        coarse.triangles.len()
    );
    // The block warp keeps the narrower range, with about three times the triangles.
    let block = dir.file("block");
    let out = quadmesh(&["mesh", s(&input), "-o", s(&block), "--block-warp"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let block = read_triangle_files(&block);
    if let Err(fault) = block.validate(&points, WARP) {
        panic!("block-warped mesh read back from files is invalid: {fault}");
    }
    assert!(
        block.triangles.len() > 2 * mesh.triangles.len(),
        "{} block-warped triangles, {} compact",
        block.triangles.len(),
        mesh.triangles.len()
    );
}

#[test]
fn a_given_domain_is_meshed_exactly() {
    let dir = TempDir::new("domain");
    let (input, points) = generate(&dir, 300, "uniform");
    let prefix = dir.file("out");
    let (lo, hi) = quadmesh::morton::bounding_box(&points);
    let wider = format!("{},{},{},{}", lo.x - 0.5, lo.y, hi.x, hi.y + 2.0);
    for (domain, bounds) in [
        ("bbox", COARSE),
        (wider.as_str(), COARSE),
        (
            "bbox",
            AngleBounds {
                min_deg: 25.0,
                max_deg: 130.0,
            },
        ),
    ] {
        let mut args = vec![
            "mesh",
            s(&input),
            "-o",
            s(&prefix),
            "--check",
            "--domain",
            domain,
        ];
        if bounds.min_deg == 25.0 {
            args.extend(["--min-angle", "25"]);
        } else {
            args.push("--warp");
        }
        let out = quadmesh(&args);
        assert!(out.status.success(), "{domain}: {}", stderr(&out));
        let mesh = read_triangle_files(&prefix);
        if let Err(fault) = mesh.validate(&points, bounds) {
            panic!("{domain}: mesh read back from files is invalid: {fault}");
        }
        let expected = if domain == "bbox" {
            (lo, hi)
        } else {
            (
                lo - quadmesh::DVec2::new(0.5, 0.0),
                hi + quadmesh::DVec2::new(0.0, 2.0),
            )
        };
        assert_eq!((mesh.domain.lo, mesh.domain.hi), expected, "{domain}");
    }
}

#[test]
fn every_format_is_written_and_one_and_two_threads_agree() {
    let dir = TempDir::new("formats");
    let (input, _) = generate(&dir, 2000, "kuzmin");
    let run = |threads: &str, name: &str| {
        let prefix = dir.file(name);
        let out = quadmesh(&[
            "mesh",
            s(&input),
            "-o",
            s(&prefix),
            "--warp",
            "--format",
            "node,vtu,msh,svg",
            "--threads",
            threads,
        ]);
        assert!(out.status.success(), "{}", stderr(&out));
        ["node", "ele", "neigh", "edge", "vtu", "msh", "svg"]
            .map(|e| std::fs::read(format!("{}.{e}", prefix.display())).unwrap())
    };
    let one = run("1", "one");
    let two = run("2", "two");
    for (a, b) in one.iter().zip(&two) {
        assert!(!a.is_empty());
        assert!(a == b, "files differ between 1 and 2 threads");
    }
}

#[test]
fn bad_input_is_a_one_line_error_and_writes_nothing() {
    let dir = TempDir::new("bad");
    for (name, contents) in [
        ("empty.txt", ""),
        ("nan.txt", "0 0\nnan 1\n"),
        ("malformed.txt", "0 0\n1 x\n"),
        ("inf.node", "2 2 0 0\n1 0 0\n2 inf 1\n"),
    ] {
        let input = dir.file(name);
        std::fs::write(&input, contents).unwrap();
        let prefix = dir.file("out");
        let out = quadmesh(&["mesh", s(&input), "-o", s(&prefix)]);
        let err = stderr(&out);
        assert!(!out.status.success(), "{name}: expected failure");
        assert!(!err.contains("panicked"), "{name}: {err}");
        assert!(
            err.starts_with("error: ") && err.trim_end().lines().count() == 1,
            "{err}"
        );
        assert!(!dir.file("out.node").exists(), "{name}: wrote output");
    }
    let missing = quadmesh(&["mesh", s(&dir.file("missing.txt")), "-o", s(&dir.file("o"))]);
    assert!(!missing.status.success());
}

#[test]
fn bench_prints_one_json_object_last() {
    let last = bench_json(&[
        "--points",
        "3000",
        "--dist",
        "uniform",
        "--threads",
        "2",
        "--json",
        "--warp",
    ]);
    for key in [
        "\"points\":3000",
        "\"threads\":2",
        "\"total_s\":",
        "\"vertices\":",
        "\"triangles\":",
        "\"min_angle\":",
        "\"max_angle\":",
        "\"peak_rss_bytes\":",
        "\"warp_vertices_s\":",
        "\"separate_s\":",
    ] {
        assert!(last.contains(key), "{key} missing from {last}");
    }
    let field = |key: &str| json_number(&last, key);
    assert!(field("min_angle") >= COARSE_ANGLE_BOUNDS.0 - 1e-9);
    assert!(field("max_angle") <= COARSE_ANGLE_BOUNDS.1 + 1e-9);
    assert!(field("triangles") > 3000.0);
}

#[test]
fn nonobtuse_meshes_read_back_valid_and_the_modes_exclude_each_other() {
    let dir = TempDir::new("nonobtuse");
    let (input, points) = generate(&dir, 400, "kuzmin");
    let prefix = dir.file("out");
    for flag in ["--nonobtuse", "--nonobtuse-split"] {
        let out = quadmesh(&["mesh", s(&input), "-o", s(&prefix), "--check", flag]);
        assert!(out.status.success(), "{flag}: {}", stderr(&out));
        assert!(stderr(&out).contains("check                   passed"));
        let mesh = read_triangle_files(&prefix);
        if let Err(fault) = mesh.validate_nonobtuse(&points) {
            panic!("{flag}: nonobtuse mesh read back from files is invalid: {fault}");
        }
        let others = ["--warp", "--min-angle=25", "--max-area=0.1", "--nonobtuse"];
        for other in others.into_iter().filter(|&o| o != flag) {
            let out = quadmesh(&["mesh", s(&input), "-o", s(&prefix), flag, other]);
            assert!(!out.status.success(), "{flag} with {other} was accepted");
            assert!(
                stderr(&out).contains("cannot be used with"),
                "{}",
                stderr(&out)
            );
        }
    }
}
