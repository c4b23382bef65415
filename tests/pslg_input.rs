//! Reading planar straight-line graphs from Triangle's files and cleaning them.

mod common;

use std::path::{Path, PathBuf};

use quadmesh::io::{read_input, read_points};
use quadmesh::pslg::{CleanOptions, clean};
use quadmesh::{DVec2, Error, Input, Options, Segment};

/// A file in a fresh temporary directory, removed with it when dropped.
struct TempDir(PathBuf);

impl TempDir {
    fn new(name: &str) -> TempDir {
        let dir = std::env::temp_dir().join(format!("quadmesh-pslg-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        TempDir(dir)
    }

    fn file(&self, name: &str, text: &str) -> PathBuf {
        let path = self.0.join(name);
        std::fs::write(&path, text).unwrap();
        path
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

#[test]
fn a_poly_file_reads_cleans_and_is_refused_by_the_mesher() {
    let dir = TempDir::new("square");
    let path = dir.file(
        "square.poly",
        "# a square, a duplicate corner, a point on the bottom side\n\
         6 2 0 1\n1 0 0 1\n2 2 0 1\n3 2 2 1\n4 0 2 1\n5 2 2 0\n6 1 0 0\n\
         4 1\n1 1 2 7\n2 2 5 7\n3 3 4 7\n4 4 1 7\n\
         1\n1 1 1\n",
    );
    let input = read_input(&path).unwrap();
    assert_eq!(
        (input.points.len(), input.segments.len(), input.holes.len()),
        (6, 4, 1)
    );
    assert_eq!(read_points(&path).unwrap(), input.points);
    let (cleaned, report) = clean(&input, CleanOptions::default()).unwrap();
    assert_eq!(report.merged_points, 1);
    assert_eq!(report.merged_examples, vec![[4, 2]]);
    assert_eq!(report.vertex_splits, 1);
    let ends: Vec<[u32; 2]> = cleaned.segments.iter().map(|s| s.ends).collect();
    assert_eq!(ends, vec![[0, 4], [4, 1], [1, 2], [2, 3], [3, 0]]);
    assert!(cleaned.segments.iter().all(|s| s.marker == 7));
    // The hole seed lies in the square's only face: nothing is left to mesh.
    assert_eq!(
        quadmesh::mesh(&cleaned, &Options::default()).unwrap_err(),
        Error::NothingEnclosed
    );
    let mut no_hole = cleaned.clone();
    no_hole.holes.clear();
    let (mesh, _) = quadmesh::mesh(&no_hole, &Options::default()).unwrap();
    quadmesh::validate_pslg(&mesh, &no_hole, Options::default().angle_bounds()).unwrap();
    assert!(mesh.segments.iter().all(|s| s.marker == 7));
}

#[test]
fn malformed_files_name_file_and_line() {
    let dir = TempDir::new("bad");
    let cases = [
        (
            "truncated.poly",
            "3\n1 0 0\n2 1 0\n3 0 1\n3 0\n1 1 2\n",
            6,
            "declares 3 segments",
        ),
        (
            "range.poly",
            "2\n1 0 0\n2 1 0\n1 0\n1 1 3\n0\n",
            5,
            "names no vertex",
        ),
        (
            "holes.poly",
            "2\n1 0 0\n2 1 0\n1 0\n1 1 2\n",
            5,
            "before the hole section",
        ),
        (
            "extra.poly",
            "1\n1 0 0\n0\n0\n0\n1 2\n",
            6,
            "after the regions",
        ),
        ("orphan.poly", "0 2 0 1\n0 0\n0\n", 1, "orphan.node"),
    ];
    for (name, text, line, message) in cases {
        let path = dir.file(name, text);
        match read_input(&path) {
            Err(Error::Parse {
                source_name,
                line: l,
                message: m,
            }) => {
                assert!(source_name.ends_with(name), "{source_name}");
                assert!(l == line && m.contains(message), "{name}: line {l}: {m}");
            }
            other => panic!("{name}: unexpected {other:?}"),
        }
    }
}

#[test]
fn crossing_segments_are_named_or_split() {
    let input = Input {
        points: vec![
            DVec2::ZERO,
            DVec2::new(2.0, 2.0),
            DVec2::new(0.0, 2.0),
            DVec2::new(2.0, 0.0),
        ],
        segments: vec![
            Segment {
                ends: [0, 1],
                marker: 1,
            },
            Segment {
                ends: [2, 3],
                marker: 2,
            },
        ],
        ..Input::default()
    };
    assert_eq!(
        clean(&input, CleanOptions::default()).unwrap_err(),
        Error::CrossingSegments {
            a: 0,
            b: 1,
            at: [1.0, 1.0]
        }
    );
    let (cleaned, report) = clean(
        &input,
        CleanOptions {
            split_crossings: true,
        },
    )
    .unwrap();
    assert_eq!(report.crossing_splits, 1);
    assert_eq!(cleaned.points.len(), 5);
    assert_eq!(cleaned.points[4], DVec2::ONE);
    // The two halves of each segment meet at the new point.
    let ends: Vec<[u32; 2]> = cleaned.segments.iter().map(|s| s.ends).collect();
    assert_eq!(ends, vec![[0, 4], [4, 1], [2, 4], [4, 3]]);
    let markers: Vec<i32> = cleaned.segments.iter().map(|s| s.marker).collect();
    assert_eq!(markers, vec![1, 1, 2, 2]);
}

/// The significant lines of a Triangle file, split into fields.
fn significant(path: &Path) -> Vec<Vec<String>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| {
            l.split('#')
                .next()
                .unwrap()
                .split_whitespace()
                .map(str::to_owned)
                .collect::<Vec<_>>()
        })
        .filter(|f: &Vec<String>| !f.is_empty())
        .collect()
}

/// Points, segments, holes and regions of a `.poly` file, counted from its section headers.
fn counts(path: &Path) -> [usize; 4] {
    let lines = significant(path);
    let count = |k: usize| lines[k][0].parse::<usize>().unwrap();
    let mut points = count(0);
    let mut k = 1 + points;
    if points == 0 {
        points = significant(&path.with_extension("node"))[0][0]
            .parse()
            .unwrap();
    }
    let segments = count(k);
    k += 1 + segments;
    let holes = count(k);
    k += 1 + holes;
    let regions = if k < lines.len() { count(k) } else { 0 };
    [points, segments, holes, regions]
}

#[test]
fn triangles_example_files_read_and_clean() {
    let Some(dir) = common::triangle_examples() else {
        eprintln!("Triangle's Python package is not installed; its example files are skipped");
        return;
    };
    let mut paths: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "poly"))
        .collect();
    paths.sort();
    assert!(paths.len() >= 5, "{paths:?}");
    for path in &paths {
        let input = read_input(path).unwrap_or_else(|e| panic!("{e}"));
        let got = [
            input.points.len(),
            input.segments.len(),
            input.holes.len(),
            input.regions.len(),
        ];
        assert_eq!(got, counts(path), "{}", path.display());
        let (cleaned, report) = clean(&input, CleanOptions::default())
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(cleaned.points.len() <= input.points.len());
        assert_eq!(cleaned.holes, input.holes);
        assert_eq!(cleaned.regions, input.regions);
        assert_eq!(report.segment_origin.len(), cleaned.segments.len());
        eprintln!(
            "{}: {got:?}, {report:?}",
            path.file_name().unwrap().to_string_lossy()
        );
        // Every example meshes but box.poly, whose hole seed lies in its only enclosed face
        // (Triangle leaves it empty too).
        let options = Options::default();
        match quadmesh::mesh(&cleaned, &options) {
            Ok((mesh, _)) => quadmesh::validate_pslg(&mesh, &cleaned, options.angle_bounds())
                .unwrap_or_else(|e| panic!("{}: {e}", path.display())),
            Err(Error::NothingEnclosed) => assert!(path.ends_with("box.poly")),
            Err(e) => panic!("{}: {e}", path.display()),
        }
    }
    let names: Vec<_> = paths
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    for name in [
        "A.poly",
        "face.poly",
        "la.poly",
        "double_hex.poly",
        "box.poly",
    ] {
        assert!(
            names.iter().any(|n| n == name),
            "{name} missing from {}",
            dir.display()
        );
    }
}
