//! The `quadmesh` binary end to end: input formats, error messages and exit codes, and the
//! leaves it writes checked against the input points.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::atomic::{AtomicUsize, Ordering};

/// A path in the temporary directory, unique to this test run, removed when dropped.
struct TempPath(PathBuf);

impl TempPath {
    fn new(name: &str) -> TempPath {
        static NEXT: AtomicUsize = AtomicUsize::new(0);
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        let unique = format!("quadmesh-cli-{}-{n}-{name}", std::process::id());
        TempPath(std::env::temp_dir().join(unique))
    }

    fn with(name: &str, contents: &str) -> TempPath {
        let path = TempPath::new(name);
        std::fs::write(&path.0, contents).unwrap();
        path
    }
}

impl Drop for TempPath {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

fn quadmesh(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_quadmesh"))
        .args(args)
        .output()
        .unwrap()
}

fn path_str(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Runs `quadmesh tree` on `input` and returns the CSV and the report.
fn tree(input: &Path, extra: &[&str]) -> (String, String) {
    let csv = TempPath::new("leaves.csv");
    let mut args = vec!["tree", path_str(input), "-o", path_str(&csv.0)];
    args.extend(extra);
    let out = quadmesh(&args);
    assert!(out.status.success(), "quadmesh failed: {}", stderr(&out));
    (std::fs::read_to_string(&csv.0).unwrap(), stderr(&out))
}

/// Runs `quadmesh tree` on `input`, expecting a one-line error, and returns it.
fn tree_error(input: &Path) -> String {
    let csv = TempPath::new("leaves.csv");
    let out = quadmesh(&["tree", path_str(input), "-o", path_str(&csv.0)]);
    let err = stderr(&out);
    assert!(!out.status.success(), "expected failure, got: {err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(
        err.starts_with("error: ") && err.trim_end().lines().count() == 1,
        "{err}"
    );
    assert!(!csv.0.exists(), "no output is written on failure");
    err
}

/// The value a report line gives, e.g. `leaves` → `"4"`.
fn reported<'a>(report: &'a str, label: &str) -> &'a str {
    report
        .lines()
        .find_map(|l| l.strip_prefix(label).filter(|rest| rest.starts_with(' ')))
        .unwrap_or_else(|| panic!("no '{label}' in report:\n{report}"))
        .trim()
}

/// One leaf of the CSV.
struct Row {
    x0: f64,
    y0: f64,
    size: f64,
    point: i64,
}

fn rows(csv: &str) -> Vec<Row> {
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("level,x0,y0,size,point"));
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            assert_eq!(f.len(), 5, "{l}");
            f[0].parse::<u8>().unwrap();
            Row {
                x0: f[1].parse().unwrap(),
                y0: f[2].parse().unwrap(),
                size: f[3].parse().unwrap(),
                point: f[4].parse().unwrap(),
            }
        })
        .collect()
}

/// The indices a merge keeps: the first occurrence of each distinct point.
fn first_occurrences(points: &[(f64, f64)]) -> Vec<i64> {
    let mut seen = HashMap::new();
    (0..points.len())
        .filter(|&i| {
            seen.insert((points[i].0.to_bits(), points[i].1.to_bits()), i)
                .is_none()
        })
        .map(|i| i as i64)
        .collect()
}

/// Checks the leaves against the input: the report's leaf count, each kept point in exactly one
/// leaf that contains it, and leaf areas summing to the area of the square they cover.
fn check_leaves(csv: &str, report: &str, points: &[(f64, f64)]) {
    let rows = rows(csv);
    assert_eq!(reported(report, "leaves"), rows.len().to_string());
    assert_eq!(reported(report, "input points"), points.len().to_string());
    let mut held: Vec<i64> = rows.iter().map(|r| r.point).filter(|&p| p >= 0).collect();
    held.sort_unstable();
    assert_eq!(held, first_occurrences(points));
    let root = root_side(&rows);
    for r in rows.iter().filter(|r| r.point >= 0) {
        let (x, y) = points[r.point as usize];
        let tol = 1e-9 * root.max(x.abs()).max(y.abs());
        assert!(
            r.x0 - tol <= x && x < r.x0 + r.size + tol,
            "x {x} outside [{}, +{})",
            r.x0,
            r.size
        );
        assert!(
            r.y0 - tol <= y && y < r.y0 + r.size + tol,
            "y {y} outside [{}, +{})",
            r.y0,
            r.size
        );
    }
    let area: f64 = rows.iter().map(|r| r.size * r.size).sum();
    assert!(
        (area - root * root).abs() <= 1e-9 * root * root,
        "area {area} vs root {}",
        root * root
    );
}

/// Side of the square the leaves tile: their bounding box, which must be a square.
fn root_side(rows: &[Row]) -> f64 {
    let min = |f: fn(&Row) -> f64| rows.iter().map(f).fold(f64::INFINITY, f64::min);
    let max = |f: fn(&Row) -> f64| rows.iter().map(f).fold(f64::NEG_INFINITY, f64::max);
    let width = max(|r| r.x0 + r.size) - min(|r| r.x0);
    let height = max(|r| r.y0 + r.size) - min(|r| r.y0);
    assert!(
        (width - height).abs() <= 1e-9 * width,
        "leaves cover {width} x {height}"
    );
    width
}

fn points_of_text(text: &str) -> Vec<(f64, f64)> {
    text.lines()
        .map(|l| {
            let (x, y) = l.split_once(' ').unwrap();
            (x.parse().unwrap(), y.parse().unwrap())
        })
        .collect()
}

#[test]
fn node_file_with_one_based_indices_attributes_and_markers() {
    let input = TempPath::with(
        "square.node",
        "# corners and centre\n5 2 2 1\n1 0 0 0.5 7 1\n2 4 0 0.5 7 1\n3 4 4 0.5 7 1 # top right\n\n4 0 4 0.5 7 1\n5 1 1 0.5 7 0\n",
    );
    let (csv, report) = tree(&input.0, &[]);
    check_leaves(
        &csv,
        &report,
        &[(0., 0.), (4., 0.), (4., 4.), (0., 4.), (1., 1.)],
    );
    assert_eq!(reported(&report, "distinct points"), "5");
    assert_eq!(reported(&report, "grid bits per axis"), "32");
}

#[test]
fn text_file_with_commas_and_a_header() {
    let input = TempPath::with("pts.csv", "x,y\n0.5,0.25\n-1, 2\n# comment\n3,3.75\n");
    let (csv, report) = tree(&input.0, &[]);
    check_leaves(&csv, &report, &[(0.5, 0.25), (-1., 2.), (3., 3.75)]);
}

#[test]
fn bad_number_names_its_line() {
    let input = TempPath::with("bad.txt", "0 0\n1 1\n2 2x\n3 3\n");
    let err = tree_error(&input.0);
    assert!(err.contains("bad.txt:3:"), "{err}");
    assert!(err.contains("'2x'"), "{err}");
}

#[test]
fn nan_is_refused_without_a_panic() {
    let input = TempPath::with("nan.txt", "0 0\nnan 1\n1 1\n");
    let err = tree_error(&input.0);
    assert!(err.contains("point 1 has a non-finite coordinate"), "{err}");
}

#[test]
fn empty_file_is_refused() {
    let input = TempPath::with("empty.txt", "");
    let err = tree_error(&input.0);
    assert!(err.contains("no points"), "{err}");
}

#[test]
fn missing_file_and_poly_without_vertices_are_refused() {
    let missing = TempPath::new("missing.txt");
    assert!(tree_error(&missing.0).contains("missing.txt"));
    // A .poly without vertices keeps them in the .node file of its name: missing here.
    let poly = TempPath::with("novertices.poly", "0 2 0 1\n1 0\n1 1 2\n");
    let err = tree_error(&poly.0);
    assert!(
        err.contains("novertices.node") && err.contains("cannot be read"),
        "{err}"
    );
}

#[test]
fn single_point_is_one_leaf() {
    let input = TempPath::with("one.txt", "3.5 -2\n");
    let (csv, report) = tree(&input.0, &[]);
    let rows = rows(&csv);
    assert_eq!(rows.len(), 1);
    assert_eq!(rows[0].point, 0);
    check_leaves(&csv, &report, &[(3.5, -2.)]);
}

#[test]
fn duplicates_are_merged_and_reported() {
    let points = [
        (1., 1.),
        (0., 0.),
        (1., 1.),
        (0.5, 0.25),
        (0., 0.),
        (1., 1.),
        (0.75, 0.5),
    ];
    let text: String = points.iter().map(|(x, y)| format!("{x} {y}\n")).collect();
    let input = TempPath::with("dups.txt", &text);
    let (csv, report) = tree(&input.0, &[]);
    check_leaves(&csv, &report, &points);
    let merged = reported(&report, "duplicates merged");
    assert!(merged.starts_with("3,"), "{merged}");
    for pair in ["(0, 2)", "(0, 5)", "(1, 4)"] {
        assert!(merged.contains(pair), "{merged}");
    }
    assert_eq!(reported(&report, "distinct points"), "4");
}

#[test]
fn generated_points_give_the_same_leaves_on_one_and_two_threads() {
    let input = TempPath::new("cluster.txt");
    let out = quadmesh(&[
        "generate",
        "--points",
        "20000",
        "--dist",
        "cluster",
        "--seed",
        "3",
        "-o",
        path_str(&input.0),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let points = points_of_text(&std::fs::read_to_string(&input.0).unwrap());
    assert_eq!(points.len(), 20000);
    let (one, report) = tree(&input.0, &["--threads", "1"]);
    let (two, _) = tree(&input.0, &["--threads", "2"]);
    assert!(one == two, "--threads 1 and --threads 2 differ");
    check_leaves(&one, &report, &points);
}

#[test]
fn leaves_go_to_standard_output() {
    let input = TempPath::with("two.txt", "0 0\n1 1\n");
    let out = quadmesh(&["tree", path_str(&input.0), "-o", "-"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let csv = String::from_utf8(out.stdout.clone()).unwrap();
    check_leaves(&csv, &stderr(&out), &[(0., 0.), (1., 1.)]);
}

#[test]
fn generate_is_seeded_and_refuses_unknown_distributions() {
    let run = |seed: &str| {
        quadmesh(&[
            "generate", "--points", "50", "--dist", "kuzmin", "--seed", seed, "-o", "-",
        ])
        .stdout
    };
    assert_eq!(run("4"), run("4"));
    assert_ne!(run("4"), run("5"));
    let out = quadmesh(&["generate", "--points", "5", "--dist", "spiral", "-o", "-"]);
    assert!(!out.status.success());
    assert!(
        stderr(&out).contains("unknown distribution 'spiral'"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn close_points_use_the_wide_grid() {
    let points = [(0., 0.), (1., 1.), (0.5, 0.5), (0.5 + 1e-12, 0.5)];
    let text: String = points.iter().map(|(x, y)| format!("{x} {y}\n")).collect();
    let input = TempPath::with("close.txt", &text);
    let (csv, report) = tree(&input.0, &[]);
    assert_eq!(reported(&report, "grid bits per axis"), "64");
    check_leaves(&csv, &report, &points);
}

#[test]
fn inseparable_points_are_named() {
    let input = TempPath::with("inseparable.txt", "0 0\n1 1\n0 0.5\n1e-30 0.5\n");
    let err = tree_error(&input.0);
    assert!(err.contains("points 2") && err.contains("and 3"), "{err}");
}

#[test]
fn balanced_and_separated_leaves_are_valid_and_thread_independent() {
    let input = TempPath::new("kuzmin.txt");
    let args = [
        "generate",
        "--points",
        "3000",
        "--dist",
        "kuzmin",
        "--seed",
        "5",
        "-o",
        path_str(&input.0),
    ];
    assert!(quadmesh(&args).status.success());
    let points = points_of_text(&std::fs::read_to_string(&input.0).unwrap());
    let (plain, _) = tree(&input.0, &[]);
    let mut previous = rows(&plain).len();
    for flag in ["--balanced", "--separated"] {
        let (one, report) = tree(&input.0, &[flag, "--threads", "1"]);
        let (two, _) = tree(&input.0, &[flag, "--threads", "2"]);
        assert!(one == two, "{flag}: --threads 1 and --threads 2 differ");
        check_leaves(&one, &report, &points);
        let leaves = rows(&one).len();
        assert!(
            leaves > previous,
            "{flag} should refine further ({leaves} leaves, {previous} before)"
        );
        previous = leaves;
    }
    // The warp's tree lies between: finer than the balanced one, coarser than the 5×5 blocks'.
    let (one, report) = tree(&input.0, &["--separated", "--corners", "--threads", "1"]);
    let (two, _) = tree(&input.0, &["--separated", "--corners", "--threads", "2"]);
    assert!(one == two, "--corners: --threads 1 and --threads 2 differ");
    check_leaves(&one, &report, &points);
    let (balanced, _) = tree(&input.0, &["--balanced"]);
    let corners = rows(&one).len();
    assert!(rows(&balanced).len() < corners && 2 * corners < previous);
    let both = quadmesh(&[
        "tree",
        path_str(&input.0),
        "-o",
        "-",
        "--balanced",
        "--separated",
    ]);
    assert!(
        !both.status.success(),
        "--balanced and --separated together are refused"
    );
}
