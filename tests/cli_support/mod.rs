//! What the command-line tests share: a temporary directory, running the binary, and reading
//! Triangle's files back into a mesh.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::atomic::{AtomicUsize, Ordering};

use quadmesh::DVec2;
use quadmesh::mesh::{BoundaryEdge, Domain, Mesh, NONE};

/// A directory in the temporary directory, unique to this test, removed when dropped.
pub struct TempDir(PathBuf);

impl TempDir {
    pub fn new(name: &str) -> TempDir {
        static NEXT: AtomicUsize = AtomicUsize::new(0);
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        let dir =
            std::env::temp_dir().join(format!("quadmesh-cli-{}-{n}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        TempDir(dir)
    }

    pub fn file(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }

    /// The names of the files in the directory, sorted.
    pub fn names(&self) -> Vec<String> {
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

pub fn quadmesh(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_quadmesh"))
        .args(args)
        .output()
        .unwrap()
}

pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Data lines of a Triangle file: comments and blank lines dropped, header first.
pub fn rows(path: &Path) -> Vec<Vec<String>> {
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
pub fn read_triangle_files(prefix: &Path) -> Mesh {
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
    let (lo, hi) = quadmesh::morton::bounding_box(&vertices);
    let boundary = edge[1..]
        .iter()
        .filter(|r| r[3] != "0")
        .map(|r| {
            let (a, b) = (index(&r[1]), index(&r[2]));
            let marker: i32 = r[3].parse().expect("an integer marker");
            let forward = triangles
                .iter()
                .any(|t: &[u32; 3]| (0..3).any(|i| t[i] == a && t[(i + 1) % 3] == b));
            let vertices = if forward { [a, b] } else { [b, a] };
            BoundaryEdge { vertices, marker }
        })
        .collect();
    Mesh {
        outline: None,
        vertices,
        vertex_input,
        triangles,
        neighbours,
        boundary,
        domain: Domain { lo, hi },
        ..Mesh::default()
    }
}

pub fn generate(dir: &TempDir, n: usize, dist: &str) -> (PathBuf, Vec<DVec2>) {
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

/// The number after `"key":` in a one-line JSON object.
pub fn json_number(line: &str, key: &str) -> f64 {
    let key = format!("\"{key}\":");
    let rest = &line[line.find(&key).unwrap() + key.len()..];
    rest[..rest.find([',', '}']).unwrap()].parse().unwrap()
}

/// Runs `quadmesh bench` with `args` and returns the last line of its output, checked to be one
/// JSON object.
pub fn bench_json(args: &[&str]) -> String {
    let out = quadmesh(&[&["bench"], args].concat());
    assert!(out.status.success(), "{}", stderr(&out));
    let stdout = String::from_utf8(out.stdout).unwrap();
    let last = stdout.trim_end().lines().last().unwrap().to_owned();
    assert!(last.starts_with('{') && last.ends_with('}'), "{last}");
    last
}
