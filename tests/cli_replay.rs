//! `quadmesh replay`: the final files equal, byte for byte, what `quadmesh mesh --warp` (or
//! `--compact-warp`, `--block-warp`, `--nonobtuse`) writes for the live points in id order on the same domain; bad edits are one-line errors that
//! name the edit and write nothing.

mod cli_support;

use std::path::{Path, PathBuf};

use cli_support::{TempDir, bench_json, json_number, quadmesh, s, stderr};

const POINTS: &str = "0.1 0.2\n0.8 0.3\n0.45 0.9\n0.5 0.5\n0 0.75\n";
const EDITS: &str = "# a few edits\ni 0.3 0.3\nd 1\nm 3 0.52 0.48\ni 1 1\nm 0 0.9 0.1\n";
/// The live points after the edits, in id order: 0 (moved), 2, 3 (moved), 4, 5, 6.
const LIVE: &str = "0.9 0.1\n0.45 0.9\n0.52 0.48\n0 0.75\n0.3 0.3\n1 1\n";

/// The initial points, the edits and the live points after them, written into `dir`.
fn written_inputs(dir: &TempDir) -> (PathBuf, PathBuf, PathBuf) {
    let files = (dir.file("p.txt"), dir.file("e.txt"), dir.file("l.txt"));
    for (path, text) in [(&files.0, POINTS), (&files.1, EDITS), (&files.2, LIVE)] {
        std::fs::write(path, text).unwrap();
    }
    files
}

/// The bytes of the file `PREFIX.extension` a command wrote.
fn output(prefix: &Path, extension: &str) -> Vec<u8> {
    std::fs::read(format!("{}.{extension}", prefix.display())).unwrap()
}

#[test]
fn replayed_files_equal_those_of_a_mesh_of_the_live_points() {
    // The warp (the compact warp coarsened), the compact warp (the default) and the block
    // warp on a square, the warp and the compact warp on a rectangle.
    for (warp, domain) in [
        ("--warp", "0,0,1,1"),
        ("--compact-warp", "0,0,1,1"),
        ("--block-warp", "0,0,1,1"),
        ("--warp", "0,0,1,1.3"),
        ("--compact-warp", "0,0,1,1.3"),
    ] {
        replayed_files_equal_a_mesh(warp, domain);
    }
}

fn replayed_files_equal_a_mesh(warp: &str, domain: &str) {
    let dir = TempDir::new("replay");
    let (points, edits, live) = written_inputs(&dir);
    let (replayed, meshed) = (dir.file("replayed"), dir.file("meshed"));
    let out = quadmesh(&[
        "replay",
        s(&points),
        s(&edits),
        "-o",
        s(&replayed),
        "--domain",
        domain,
        "--json",
        "--verify",
        warp,
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let json = String::from_utf8(out.stdout).unwrap();
    let lines: Vec<&str> = json.lines().collect();
    assert_eq!(lines.len(), 6, "a line per edit and a summary: {json}");
    assert!(
        lines[0].starts_with("{\"edit\":1,\"edits\":1,\"seconds\":"),
        "{}",
        lines[0]
    );
    assert!(lines[5].contains("\"identical\":true"), "{}", lines[5]);
    let out = quadmesh(&["mesh", s(&live), "-o", s(&meshed), warp, "--domain", domain]);
    assert!(out.status.success(), "{}", stderr(&out));
    // The same edits in batches of two.
    let batched = dir.file("batched");
    let out = quadmesh(&[
        "replay",
        s(&points),
        s(&edits),
        "-o",
        s(&batched),
        "--domain",
        domain,
        "--batch",
        "2",
        "--json",
        warp,
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(String::from_utf8(out.stdout).unwrap().lines().count(), 4);
    for extension in ["node", "ele", "neigh", "edge"] {
        let mesh = output(&meshed, extension);
        assert_eq!(
            output(&replayed, extension),
            mesh,
            "{warp}: the .{extension} files differ"
        );
        assert_eq!(
            output(&batched, extension),
            mesh,
            "{warp}: the batched .{extension} files differ"
        );
    }
}

#[test]
fn a_bad_edit_is_named_and_nothing_is_written() {
    let dir = TempDir::new("replay-bad");
    let (points, edits) = (dir.file("p.txt"), dir.file("e.txt"));
    std::fs::write(&points, POINTS).unwrap();
    for (text, expected) in [
        ("i 0.3 0.3\nd 9\n", "edit 2"),
        ("i 2 0.5\n", "outside the domain"),
        ("m 1 0.1 0.2\n", "already point 0"),
        ("i 0.3\n", "e.txt:1:"),
    ] {
        std::fs::write(&edits, text).unwrap();
        let prefix = dir.file("out");
        let out = quadmesh(&[
            "replay",
            s(&points),
            s(&edits),
            "-o",
            s(&prefix),
            "--domain",
            "0,0,1,1",
        ]);
        assert!(!out.status.success(), "{text:?} was accepted");
        let message = stderr(&out);
        assert_eq!(message.lines().count(), 1, "{message}");
        assert!(message.contains(expected), "{text:?}: {message}");
        assert!(
            !dir.names().iter().any(|n| n.starts_with("out")),
            "{text:?} wrote files"
        );
    }
    // A rectangle that is not a square takes the compact warp only.
    std::fs::write(&edits, EDITS).unwrap();
    let out = quadmesh(&[
        "replay",
        s(&points),
        s(&edits),
        "-o",
        "x",
        "--domain",
        "0,0,2,1",
        "--block-warp",
    ]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("square"), "{}", stderr(&out));
}

#[test]
fn a_nonobtuse_replay_equals_a_nonobtuse_mesh_of_the_live_points() {
    let dir = TempDir::new("replay-nonobtuse");
    let (points, edits, live) = written_inputs(&dir);
    let mut counts = Vec::new();
    for flag in ["--nonobtuse", "--nonobtuse-split"] {
        let (replayed, meshed) = (dir.file("replayed"), dir.file("meshed"));
        let replay = [
            "replay",
            s(&points),
            s(&edits),
            "-o",
            s(&replayed),
            "--domain",
            "0,0,1,1",
            flag,
            "--verify",
            "--json",
        ];
        let out = quadmesh(&replay);
        assert!(out.status.success(), "{flag}: {}", stderr(&out));
        let json = String::from_utf8(out.stdout).unwrap();
        assert!(json.contains("\"identical\":true"), "{flag}: {json}");
        let mesh = [
            "mesh",
            s(&live),
            "-o",
            s(&meshed),
            flag,
            "--domain",
            "0,0,1,1",
        ];
        let out = quadmesh(&mesh);
        assert!(out.status.success(), "{flag}: {}", stderr(&out));
        for extension in ["node", "ele", "neigh", "edge"] {
            assert_eq!(
                output(&replayed, extension),
                output(&meshed, extension),
                "{flag}: the .{extension} files differ"
            );
        }
        counts.push(triangle_count(&replayed));
        // The warped files differ: the two modes are not the same mesh.
        let warped = dir.file("warped");
        let out = quadmesh(&[
            "mesh",
            s(&live),
            "-o",
            s(&warped),
            "--warp",
            "--domain",
            "0,0,1,1",
        ]);
        assert!(out.status.success(), "{}", stderr(&out));
        assert_ne!(output(&replayed, "ele"), output(&warped, "ele"));
    }
    // The coarsened mesh is the smaller.
    assert!(counts[0] < counts[1], "{counts:?}");
}

/// The number of triangles in `PREFIX.ele` (the first field of its first line that is not a
/// comment).
fn triangle_count(prefix: &Path) -> i64 {
    let text = String::from_utf8(output(prefix, "ele")).unwrap();
    let header = text.lines().find(|l| !l.starts_with('#')).unwrap();
    header.split_whitespace().next().unwrap().parse().unwrap()
}

#[test]
fn the_triangles_each_edit_changes_add_up_to_the_final_mesh() {
    let dir = TempDir::new("replay-changes");
    let (points, edits, _) = written_inputs(&dir);
    let (first, last) = (dir.file("first"), dir.file("last"));
    let out = quadmesh(&[
        "mesh",
        s(&points),
        "-o",
        s(&first),
        "--compact-warp",
        "--domain",
        "0,0,1,1",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let replay = [
        "replay",
        s(&points),
        s(&edits),
        "-o",
        s(&last),
        "--domain",
        "0,0,1,1",
        "--json",
        "--changes",
    ];
    let out = quadmesh(&replay);
    assert!(out.status.success(), "{}", stderr(&out));
    let json = String::from_utf8(out.stdout).unwrap();
    let lines: Vec<&str> = json.lines().collect();
    let mut count = triangle_count(&first);
    for (k, line) in lines[..lines.len() - 1].iter().enumerate() {
        let removed = json_number(line, "triangles_removed") as i64;
        let added = json_number(line, "triangles_added") as i64;
        // Every edit here moves, adds or takes out a point: some triangles change, not all;
        // but the fourth puts a point on the domain's corner, a vertex of the compact warp
        // already, whose tree it leaves as it was.
        if k == 3 {
            assert!(removed == 0 && added == 0, "{line}");
        } else {
            assert!(removed > 0 && added > 0 && removed < count, "{line}");
        }
        count += added - removed;
    }
    assert_eq!(count, triangle_count(&last));
    // Without --json there is nowhere to print them.
    let out = quadmesh(&["replay", s(&points), s(&edits), "-o", s(&last), "--changes"]);
    assert!(!out.status.success());
}

#[test]
fn bench_dynamic_times_each_kind_of_edit() {
    let line = bench_json(&[
        "--points",
        "3000",
        "--dist",
        "cluster",
        "--dynamic",
        "--edits",
        "40",
        "--threads",
        "2",
        "--json",
    ]);
    for kind in ["insert", "delete", "move"] {
        assert!(json_number(&line, &format!("{kind}_s")) > 0.0, "{line}");
        // A median count of squares (an insertion into a large empty leaf may touch none).
        assert!(
            json_number(&line, &format!("{kind}_cells")) >= 0.0,
            "{line}"
        );
    }
    for key in ["build_s", "rebuild_s", "mesh_s"] {
        assert!(json_number(&line, key) > 0.0, "{line}");
    }
    assert_eq!(json_number(&line, "edits"), 40.0);
    // Only the warp mode is dynamic.
    let out = quadmesh(&["bench", "--points", "10", "--dynamic", "--min-angle", "25"]);
    assert!(!out.status.success());
    // On a given rectangle with room around the points; a region that is not one is refused.
    let roomy = bench_json(&[
        "--points",
        "2000",
        "--dynamic",
        "--edits",
        "20",
        "--domain",
        "-1,-1,4,3",
        "--json",
    ]);
    assert_eq!(json_number(&roomy, "edits"), 20.0);
    assert!(json_number(&roomy, "delete_s") > 0.0, "{roomy}");
    for region in ["bbox", "0.5,0,1,1"] {
        let out = quadmesh(&["bench", "--points", "100", "--dynamic", "--domain", region]);
        assert!(!out.status.success(), "{region}");
    }
}

#[test]
fn a_quality_delaunay_mesh_replays_to_refinement_in_order_of_the_live_points() {
    let dir = TempDir::new("replay-delaunay");
    let (points, edits, _) = written_inputs(&dir);
    let replayed = dir.file("replayed");
    let out = quadmesh(&[
        "replay",
        s(&points),
        s(&edits),
        "-o",
        s(&replayed),
        "--domain",
        "0,0,1,1",
        "--min-angle",
        "30",
        "--json",
        "--verify",
        "--changes",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let json = String::from_utf8(out.stdout).unwrap();
    let lines: Vec<&str> = json.lines().collect();
    assert_eq!(lines.len(), 6, "a line per edit and a summary: {json}");
    assert!(lines[0].contains("\"windows\":"), "{}", lines[0]);
    for (k, line) in lines[..5].iter().enumerate() {
        // Every edit changes the mesh but the fourth, a point on a corner of the domain.
        let none = line.contains("\"triangles_removed\":0,\"triangles_added\":0,");
        assert_eq!(none, k == 3, "{line}");
    }
    assert!(lines[5].contains("\"identical\":true"), "{}", lines[5]);
    assert!(!output(&replayed, "ele").is_empty());
    // A bad edit names itself and writes nothing.
    let bad = dir.file("bad.txt");
    std::fs::write(&bad, "i 0.3 0.3\nd 42\n").unwrap();
    let refused = dir.file("refused");
    let out = quadmesh(&[
        "replay",
        s(&points),
        s(&bad),
        "-o",
        s(&refused),
        "--domain",
        "0,0,1,1",
        "--min-angle",
        "30",
    ]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("edit 2"), "{}", stderr(&out));
    assert!(!Path::new(&format!("{}.ele", refused.display())).exists());
}
