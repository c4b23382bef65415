//! `quadmesh mesh --min-angle` and `quadmesh bench --min-angle` end to end: the files read back
//! as a valid mesh meeting the angle bound, the same on 1 and 2 threads; bad bounds and
//! an exhausted vertex budget are one-line errors that write nothing; the warning above the
//! proven bound appears exactly when it should.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::atomic::{AtomicUsize, Ordering};

use quadmesh::DVec2;
use quadmesh::mesh::{AngleBounds, BoundaryEdge, BoundarySide, Domain, Mesh, NONE, angles_deg};

/// A directory in the temporary directory, unique to this test, removed when dropped.
struct TempDir(PathBuf);

impl TempDir {
    fn new(name: &str) -> TempDir {
        static NEXT: AtomicUsize = AtomicUsize::new(0);
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        let dir =
            std::env::temp_dir().join(format!("quadmesh-refine-{}-{n}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        TempDir(dir)
    }

    fn file(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }

    /// The names of the files in the directory, sorted.
    fn names(&self) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(&self.0)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
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

/// The mesh in Triangle's files at `prefix`, read back (1-based numbering). The domain is the
/// vertices' bounding box, the boundary the marked edges of the .edge file, each oriented as
/// the triangle that holds it.
fn read_triangle_files(prefix: &Path) -> Mesh {
    let ext = |e: &str| PathBuf::from(format!("{}.{e}", prefix.display()));
    let [node, ele, neigh, edge] = ["node", "ele", "neigh", "edge"].map(|e| rows(&ext(e)));
    let index = |t: &str| -> u32 {
        match t.parse::<i64>().unwrap() {
            -1 => NONE,
            i => u32::try_from(i - 1).unwrap(),
        }
    };
    let corners = |rows: &[Vec<String>]| -> Vec<[u32; 3]> {
        rows[1..]
            .iter()
            .map(|r| [index(&r[1]), index(&r[2]), index(&r[3])])
            .collect()
    };
    assert_eq!(node[0][0].parse::<usize>().unwrap(), node.len() - 1);
    assert_eq!(ele[0][0].parse::<usize>().unwrap(), ele.len() - 1);
    let vertices: Vec<DVec2> = node[1..]
        .iter()
        .map(|r| DVec2::new(r[1].parse().unwrap(), r[2].parse().unwrap()))
        .collect();
    let vertex_input = node[1..]
        .iter()
        .map(|r| match r[3].parse::<i64>().unwrap() {
            -1 => NONE,
            i => u32::try_from(i).unwrap(),
        })
        .collect();
    let triangles = corners(&ele);
    let neighbours = corners(&neigh);
    let lo = vertices.iter().fold(DVec2::INFINITY, |a, &b| a.min(b));
    let hi = vertices.iter().fold(DVec2::NEG_INFINITY, |a, &b| a.max(b));
    let boundary = edge[1..]
        .iter()
        .filter(|r| r[3] != "0")
        .map(|r| {
            let (a, b) = (index(&r[1]), index(&r[2]));
            let side = match r[3].as_str() {
                "1" => BoundarySide::Bottom,
                "2" => BoundarySide::Right,
                "3" => BoundarySide::Top,
                _ => BoundarySide::Left,
            };
            let forward = triangles
                .iter()
                .any(|t: &[u32; 3]| (0..3).any(|i| t[i] == a && t[(i + 1) % 3] == b));
            let vertices = if forward { [a, b] } else { [b, a] };
            BoundaryEdge { vertices, side }
        })
        .collect();
    Mesh {
        vertices,
        vertex_input,
        triangles,
        neighbours,
        boundary,
        domain: Domain { lo, hi },
    }
}

/// The angle bounds `--min-angle a` promises.
fn bounds(a: f64) -> AngleBounds {
    AngleBounds {
        min_deg: a,
        max_deg: 180.0 - 2.0 * a,
    }
}

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
fn an_exhausted_vertex_budget_is_an_error_and_writes_nothing() {
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
    assert!(errors[0].contains("budget"), "{err}");
    assert_eq!(dir.names(), ["points.txt"], "wrote output: {err}");
}

#[test]
fn bench_min_angle_prints_one_json_object_last() {
    let out = quadmesh(&[
        "bench",
        "--points",
        "2000",
        "--min-angle",
        "25",
        "--threads",
        "2",
        "--json",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let stdout = String::from_utf8(out.stdout).unwrap();
    let last = stdout.trim_end().lines().last().unwrap();
    assert!(last.starts_with('{') && last.ends_with('}'), "{last}");
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
    let field = |key: &str| -> f64 {
        let key = format!("\"{key}\":");
        let rest = &last[last.find(&key).unwrap() + key.len()..];
        rest[..rest.find([',', '}']).unwrap()].parse().unwrap()
    };
    assert!(field("triangles") > 0.0, "{last}");
    assert!(field("vertices") >= 2000.0 + 4.0, "{last}");
    assert!(field("min_angle") >= 25.0 - 1e-9, "{last}");
    assert!(field("max_angle") <= 130.0 + 1e-9, "{last}");
    assert!(field("total_s") >= field("refine_s"), "{last}");
}
