//! Meshes a point file with spade's constrained Delaunay triangulation, as a reference to compare
//! quadmesh against, and prints one JSON line with the time, size, angles and peak memory.
//!
//! `cargo run --release --example spade_mesh -- POINTS_FILE [--min-angle DEG]
//! [--corners x0,y0,x1,y1 | --hull] [--max-additional-vertices N]`
//!
//! With `--hull` the points alone are meshed: their convex hull. Otherwise the four corners of the square `[x0, x1] × [y0, y1]` are added to the points, so the square is
//! the convex hull and the triangulation covers it. Without `--corners` the square is the one
//! quadmesh meshes: centred on the points' bounding box, of side twice its larger extent. With
//! `--min-angle` the triangulation is refined (Ruppert/Chew, splitting the square's sides as
//! needed) until no angle is below `DEG` degrees. `time_s` covers the bulk load and the refinement,
//! not reading the file; `peak_rss_bytes` is the process's high-water mark (`VmHWM`), so it
//! includes the points as read (`peak_rss_before_mesh_bytes` is the mark after reading them).

/// As in the CLI: an allocator that reuses freed memory, so memory figures are comparable.
#[cfg(feature = "mimalloc")]
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Parser;
use quadmesh::io::read_points;
use spade::{
    AngleLimit, ConstrainedDelaunayTriangulation, Point2, RefinementParameters, Triangulation,
};

/// Mesh a point file with spade and print one JSON line of figures.
#[derive(Parser)]
struct Args {
    /// Points: Triangle `.node` / `.poly`, or text with one `x y` or `x,y` per line.
    points: PathBuf,
    /// Refine until no angle is below this many degrees; no refinement without it.
    #[arg(long, value_name = "DEG")]
    min_angle: Option<f64>,
    /// The square to mesh, as `x0,y0,x1,y1`; its corners are added to the points.
    #[arg(long, value_name = "x0,y0,x1,y1", allow_hyphen_values = true)]
    corners: Option<String>,
    /// Mesh the points' convex hull: no corners are added.
    #[arg(long, conflicts_with = "corners")]
    hull: bool,
    /// How many Steiner points refinement may add [default: 50 × the vertices before it].
    #[arg(long, value_name = "N")]
    max_additional_vertices: Option<usize>,
}

/// An axis-aligned rectangle `[x0, x1] × [y0, y1]`.
struct Domain {
    x0: f64,
    y0: f64,
    x1: f64,
    y1: f64,
}

impl Domain {
    fn parse(text: &str) -> Result<Domain> {
        let values = text
            .split(',')
            .map(|v| v.trim().parse::<f64>())
            .collect::<Result<Vec<_>, _>>()
            .with_context(|| format!("--corners {text:?}: expected four numbers x0,y0,x1,y1"))?;
        let [x0, y0, x1, y1] = values[..] else {
            bail!("--corners {text:?}: expected four numbers x0,y0,x1,y1");
        };
        if !(x0 < x1 && y0 < y1) || values.iter().any(|v| !v.is_finite()) {
            bail!("--corners {text:?}: need finite x0 < x1 and y0 < y1");
        }
        Ok(Domain { x0, y0, x1, y1 })
    }

    /// The square quadmesh meshes: side twice the larger extent of the bounding box, same centre.
    fn around(points: &[Point2<f64>]) -> Result<Domain> {
        let Some(first) = points.first() else {
            bail!("no points and no --corners: the square is undefined");
        };
        let (mut lo, mut hi) = ((first.x, first.y), (first.x, first.y));
        for p in points {
            lo = (lo.0.min(p.x), lo.1.min(p.y));
            hi = (hi.0.max(p.x), hi.1.max(p.y));
        }
        let centre = ((lo.0 + hi.0) / 2.0, (lo.1 + hi.1) / 2.0);
        let mut half = (hi.0 - lo.0).max(hi.1 - lo.1);
        if half <= 0.0 {
            half = 1.0;
        }
        Ok(Domain {
            x0: centre.0 - half,
            y0: centre.1 - half,
            x1: centre.0 + half,
            y1: centre.1 + half,
        })
    }

    fn corners(&self) -> [Point2<f64>; 4] {
        [
            Point2::new(self.x0, self.y0),
            Point2::new(self.x1, self.y0),
            Point2::new(self.x1, self.y1),
            Point2::new(self.x0, self.y1),
        ]
    }
}

/// The three angles of triangle `abc`, in degrees.
fn angles(p: [Point2<f64>; 3]) -> [f64; 3] {
    let angle_at = |a: Point2<f64>, b: Point2<f64>, c: Point2<f64>| {
        let (ux, uy) = (b.x - a.x, b.y - a.y);
        let (vx, vy) = (c.x - a.x, c.y - a.y);
        (ux * vy - uy * vx)
            .abs()
            .atan2(ux * vx + uy * vy)
            .to_degrees()
    };
    [
        angle_at(p[0], p[1], p[2]),
        angle_at(p[1], p[2], p[0]),
        angle_at(p[2], p[0], p[1]),
    ]
}

/// The process's peak resident set size in bytes, from `VmHWM` in `/proc/self/status`.
fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// A JSON number, or `null` when there is none or it is not finite.
fn json_number(value: Option<f64>) -> String {
    match value {
        Some(v) if v.is_finite() => format!("{v}"),
        _ => "null".to_string(),
    }
}

/// A byte count as JSON, `null` when unknown.
fn json_bytes(value: Option<u64>) -> String {
    value.map_or_else(|| "null".to_string(), |b| b.to_string())
}

fn run(args: &Args) -> Result<()> {
    let read =
        read_points(&args.points).with_context(|| format!("reading {}", args.points.display()))?;
    let input_points = read.len();
    let mut vertices: Vec<Point2<f64>> = read.into_iter().map(|p| Point2::new(p.x, p.y)).collect();
    if !args.hull {
        let domain = match &args.corners {
            Some(text) => Domain::parse(text)?,
            None => Domain::around(&vertices)?,
        };
        vertices.extend(domain.corners());
    }
    if let Some(deg) = args.min_angle
        && !(deg.is_finite() && (0.0..60.0).contains(&deg))
    {
        bail!("--min-angle {deg}: expected degrees in [0, 60)");
    }

    let peak_before_mesh = peak_rss_bytes();
    let start = Instant::now();
    let mut cdt = ConstrainedDelaunayTriangulation::<Point2<f64>>::bulk_load(vertices)
        .context("spade bulk load")?;
    // No constraint edges: the square's corners (or, with `--hull`, the points) make the convex
    // hull, whose edges refinement treats as fixed segments and splits where they are encroached. (`exclude_outer_faces`
    // would exclude every face here, as no constraint edge separates inside from outside.)
    let refinement_complete = args.min_angle.map(|deg| {
        let extra = args
            .max_additional_vertices
            .unwrap_or_else(|| cdt.num_vertices().saturating_mul(50));
        let parameters = RefinementParameters::<f64>::new()
            .with_angle_limit(AngleLimit::from_deg(deg))
            .with_max_additional_vertices(extra);
        cdt.refine(parameters).refinement_complete
    });
    let time_s = start.elapsed().as_secs_f64();

    let (mut min_angle, mut max_angle) = (f64::INFINITY, f64::NEG_INFINITY);
    let mut below_limit = 0usize;
    for face in cdt.inner_faces() {
        let [a, b, c] = angles(face.positions());
        let (lo, hi) = (a.min(b).min(c), a.max(b).max(c));
        min_angle = min_angle.min(lo);
        max_angle = max_angle.max(hi);
        if args.min_angle.is_some_and(|deg| lo < deg) {
            below_limit += 1;
        }
    }
    let triangles = cdt.num_inner_faces();
    let some_faces = |v: f64| (triangles > 0).then_some(v);

    let mut line = format!(
        "{{\"tool\":\"spade\",\"points\":{input_points},\"min_angle_limit\":{},\"time_s\":{time_s},\
         \"vertices\":{},\"triangles\":{triangles},\"min_angle\":{},\"max_angle\":{},\
         \"peak_rss_bytes\":{},\"peak_rss_before_mesh_bytes\":{}",
        json_number(args.min_angle),
        cdt.num_vertices(),
        json_number(some_faces(min_angle)),
        json_number(some_faces(max_angle)),
        json_bytes(peak_rss_bytes()),
        json_bytes(peak_before_mesh),
    );
    if let Some(complete) = refinement_complete {
        line.push_str(&format!(
            ",\"refinement_complete\":{complete},\"triangles_below_limit\":{below_limit}"
        ));
    }
    line.push('}');
    println!("{line}");
    if refinement_complete == Some(false) {
        eprintln!(
            "spade_mesh: refinement ran out of additional vertices; raise --max-additional-vertices"
        );
    }
    if below_limit > 0 {
        eprintln!(
            "spade_mesh: {below_limit} triangles still have an angle below {} degrees",
            args.min_angle.unwrap_or_default()
        );
    }
    Ok(())
}

fn main() -> ExitCode {
    let args = Args::parse();
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("spade_mesh: {e:#}");
            ExitCode::FAILURE
        }
    }
}
