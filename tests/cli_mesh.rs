//! `quadmesh mesh` and `quadmesh bench` end to end: the files they write read back as a valid
//! mesh of the input, the same on 1 and 2 threads; bad input is a one-line error.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::atomic::{AtomicUsize, Ordering};

use quadmesh::DVec2;
use quadmesh::mesh::{AngleBounds, BoundaryEdge, BoundarySide, Domain, Mesh, NONE};
use quadmesh::warp::ANGLE_BOUNDS;

/// A directory in the temporary directory, unique to this test, removed when dropped.
struct TempDir(PathBuf);

impl TempDir {
    fn new(name: &str) -> TempDir {
        static NEXT: AtomicUsize = AtomicUsize::new(0);
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        let dir =
            std::env::temp_dir().join(format!("quadmesh-mesh-{}-{n}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        TempDir(dir)
    }

    fn file(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn quadmesh(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_quadmesh"))
        .args(args)
        .output()
        .unwrap()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Data lines of a Triangle file: comments and blank lines dropped, header first.
fn rows(path: &Path) -> Vec<Vec<String>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| l.split('#').next().unwrap().trim())
        .filter(|l| !l.is_empty())
        .map(|l| l.split_whitespace().map(str::to_owned).collect())
        .collect()
}

/// The mesh in Triangle's files at `prefix`, read back (1-based numbering).
fn read_triangle_files(prefix: &Path) -> Mesh {
    let ext = |e: &str| PathBuf::from(format!("{}.{e}", prefix.display()));
    let node = rows(&ext("node"));
    let ele = rows(&ext("ele"));
    let neigh = rows(&ext("neigh"));
    let edge = rows(&ext("edge"));
    let index = |t: &str| -> u32 {
        match t.parse::<i64>().unwrap() {
            -1 => NONE,
            i => (i - 1) as u32,
        }
    };
    let vertices: Vec<DVec2> = node[1..]
        .iter()
        .map(|r| DVec2::new(r[1].parse().unwrap(), r[2].parse().unwrap()))
        .collect();
    let vertex_input = node[1..]
        .iter()
        .map(|r| match r[3].parse::<i64>().unwrap() {
            -1 => NONE,
            i => i as u32,
        })
        .collect();
    let triangles = ele[1..]
        .iter()
        .map(|r| [index(&r[1]), index(&r[2]), index(&r[3])])
        .collect();
    let neighbours = neigh[1..]
        .iter()
        .map(|r| [index(&r[1]), index(&r[2]), index(&r[3])])
        .collect::<Vec<_>>();
    let mut mesh = Mesh {
        vertices,
        vertex_input,
        triangles,
        neighbours,
        boundary: Vec::new(),
        domain: Domain::default(),
    };
    // The domain and the boundary come from the boundary edges of the .edge file, oriented by
    // the triangle that holds them.
    let lo = mesh.vertices.iter().fold(DVec2::INFINITY, |a, &b| a.min(b));
    let hi = mesh
        .vertices
        .iter()
        .fold(DVec2::NEG_INFINITY, |a, &b| a.max(b));
    mesh.domain = Domain { lo, hi };
    let mut boundary = Vec::new();
    for r in &edge[1..] {
        let marker: u8 = r[3].parse().unwrap();
        if marker == 0 {
            continue;
        }
        let (a, b) = (index(&r[1]), index(&r[2]));
        let side = match marker {
            1 => BoundarySide::Bottom,
            2 => BoundarySide::Right,
            3 => BoundarySide::Top,
            _ => BoundarySide::Left,
        };
        let forward = mesh
            .triangles
            .iter()
            .any(|t| (0..3).any(|i| t[i] == a && t[(i + 1) % 3] == b));
        let vertices = if forward { [a, b] } else { [b, a] };
        boundary.push(BoundaryEdge { vertices, side });
    }
    mesh.boundary = boundary;
    mesh
}

const WARP: AngleBounds = AngleBounds {
    min_deg: ANGLE_BOUNDS.0,
    max_deg: ANGLE_BOUNDS.1,
};

fn generate(dir: &TempDir, n: usize, dist: &str) -> (PathBuf, Vec<DVec2>) {
    let input = dir.file("points.txt");
    let out = quadmesh(&[
        "generate",
        "--points",
        &n.to_string(),
        "--dist",
        dist,
        "--seed",
        "4",
        "-o",
        s(&input),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let points = quadmesh::io::read_points(&input).unwrap();
    (input, points)
}

#[test]
fn mesh_files_read_back_as_a_valid_mesh() {
    let dir = TempDir::new("valid");
    let (input, points) = generate(&dir, 300, "cluster");
    let prefix = dir.file("out");
    let out = quadmesh(&["mesh", s(&input), "-o", s(&prefix), "--check"]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stderr(&out).contains("check                   passed"));
    let mesh = read_triangle_files(&prefix);
    if let Err(fault) = mesh.validate(&points, WARP) {
        panic!("mesh read back from files is invalid: {fault}");
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
    let out = quadmesh(&[
        "bench",
        "--points",
        "3000",
        "--dist",
        "uniform",
        "--threads",
        "2",
        "--json",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let stdout = String::from_utf8(out.stdout).unwrap();
    let last = stdout.trim_end().lines().last().unwrap();
    assert!(last.starts_with('{') && last.ends_with('}'), "{last}");
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
    let field = |key: &str| -> f64 {
        let rest = &last[last.find(key).unwrap() + key.len()..];
        rest[..rest.find([',', '}']).unwrap()].parse().unwrap()
    };
    assert!(field("\"min_angle\":") >= ANGLE_BOUNDS.0 - 1e-9);
    assert!(field("\"max_angle\":") <= ANGLE_BOUNDS.1 + 1e-9);
    assert!(field("\"triangles\":") > 3000.0);
}
