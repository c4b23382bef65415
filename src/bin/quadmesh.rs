//! The `quadmesh` command line: build the quadtree of a point file and write its leaves, or
//! generate point files to try it on.

/// The stages allocate large arrays one after another; mimalloc reuses freed ones instead of
/// returning them to the system and faulting in fresh pages.
#[cfg(feature = "mimalloc")]
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::num::NonZeroUsize;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use quadmesh::generate::{self, Distribution2d};
use quadmesh::io::{read_points, write_leaves_csv, write_points};
use quadmesh::morton::MortonKey;
use quadmesh::pipeline::StageTimes;
use quadmesh::{Refinement, Tree, TreeBuild, TreeOptions, build_tree};

/// Parallel quadtrees of point sets.
#[derive(Parser)]
#[command(version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Build the quadtree of a point file and write its leaves as CSV
    /// (`level,x0,y0,size,point`; `point` is the 0-based input index, -1 if empty).
    Tree {
        /// Points: Triangle `.node` / `.poly`, or text with one `x y` or `x,y` per line.
        input: PathBuf,
        /// Where to write the leaves; `-` for standard output.
        #[arg(short, long, value_name = "LEAVES.csv")]
        output: PathBuf,
        /// Worker threads [default: all cores].
        #[arg(long, value_name = "N")]
        threads: Option<NonZeroUsize>,
        /// Write the leaves of the 2:1 balanced tree (leaves sharing a side differ at most 2× in size).
        #[arg(long, conflicts_with = "separated")]
        balanced: bool,
        /// Write the leaves of the well-separated tree: balanced, and every point's leaf centred in
        /// a 5×5 block of same-size leaves holding no other point.
        #[arg(long)]
        separated: bool,
    },
    /// Write seeded random points as `x y` lines that read back exactly.
    Generate {
        /// How many points.
        #[arg(long, value_name = "N")]
        points: usize,
        /// Distribution: uniform, cluster, kuzmin or grid.
        #[arg(long, default_value = "uniform")]
        dist: Distribution2d,
        /// Seed; the same seed gives the same points on every machine.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Where to write the points; `-` for standard output.
        #[arg(short, long, value_name = "FILE")]
        output: PathBuf,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Tree {
            input,
            output,
            threads,
            balanced,
            separated,
        } => {
            let refinement = match (balanced, separated) {
                (_, true) => Refinement::Separated,
                (true, _) => Refinement::Balanced,
                _ => Refinement::Unbalanced,
            };
            tree(
                &input,
                &output,
                threads,
                TreeOptions::default().refinement(refinement),
            )
        }
        Command::Generate {
            points,
            dist,
            seed,
            output,
        } => {
            let points = generate::points(dist, points, seed);
            write_to(&output, |w| write_points(w, &points))
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // One line, with the causes joined by ": ".
            let _ = writeln!(io::stderr(), "error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// `quadmesh tree`: read, build and write on a pool of the requested size, then report.
fn tree(
    input: &Path,
    output: &Path,
    threads: Option<NonZeroUsize>,
    options: TreeOptions,
) -> Result<()> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.map_or(0, NonZeroUsize::get))
        .build()
        .context("cannot start the worker threads")?;
    pool.install(|| {
        let (points, read_time) = timed(|| read_points(input));
        let points = points?;
        let (built, _) = timed(|| build_tree(&points, &options));
        let (tree, times) = built.with_context(|| format!("{}", input.display()))?;
        let (written, write_time) = timed(|| write_to(output, |w| write_leaves_csv(w, &tree)));
        written?;
        report(points.len(), &tree, &times, read_time, write_time);
        Ok(())
    })
}

fn timed<T>(f: impl FnOnce() -> T) -> (T, Duration) {
    let start = Instant::now();
    let out = f();
    (out, start.elapsed())
}

/// Writes to `path`, or to standard output for `-`. A file left half-written by an error is
/// removed, so a failed run never leaves output that looks complete.
fn write_to(path: &Path, write: impl FnOnce(&mut dyn Write) -> io::Result<()>) -> Result<()> {
    if path.as_os_str() == "-" {
        let mut out = BufWriter::new(io::stdout().lock());
        return write(&mut out)
            .and_then(|()| out.flush())
            .context("cannot write to standard output");
    }
    let file = File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
    let mut out = BufWriter::new(file);
    let written = write(&mut out).and_then(|()| out.flush());
    if written.is_err() {
        let _ = std::fs::remove_file(path);
    }
    written.with_context(|| format!("cannot write {}", path.display()))
}

/// What the build found and how long each stage took, on standard error.
fn report(input_points: usize, tree: &Tree, times: &StageTimes, read: Duration, write: Duration) {
    let counts = match tree {
        Tree::Narrow(b) => Counts::of(b),
        Tree::Wide(b) => Counts::of(b),
    };
    let duplicates = tree.duplicates();
    let mut lines: Vec<(String, String)> = [
        ("input points", input_points.to_string()),
        ("distinct points", counts.distinct.to_string()),
        (
            "duplicates merged",
            duplicates_line(duplicates.count, &duplicates.examples),
        ),
        ("grid bits per axis", tree.grid().axis_bits().to_string()),
        ("framework nodes", counts.framework.to_string()),
        ("internal squares", counts.internal.to_string()),
        ("leaves", counts.leaves.to_string()),
        ("time read", millis(read)),
    ]
    .map(|(label, value)| (label.to_owned(), value))
    .into();
    lines.extend(
        times
            .0
            .iter()
            .map(|(stage, d)| (format!("time {stage}"), millis(*d))),
    );
    lines.push(("time write".into(), millis(write)));
    let mut err = io::stderr().lock();
    for (label, value) in lines {
        let _ = writeln!(err, "{label:<20}{value}");
    }
}

/// Sizes of the stages' outputs.
struct Counts {
    distinct: usize,
    framework: usize,
    internal: usize,
    leaves: usize,
}

impl Counts {
    fn of<K: MortonKey>(b: &TreeBuild<K>) -> Counts {
        Counts {
            distinct: b.morton.order.len(),
            framework: b.framework.len(),
            internal: b.final_tree().internal.len(),
            leaves: b.final_tree().leaves.len(),
        }
    }
}

/// `3, e.g. (kept, dropped) input indices (0, 2) (1, 4) ...`
fn duplicates_line(count: usize, examples: &[(u32, u32)]) -> String {
    if count == 0 {
        return "0".into();
    }
    let shown: Vec<String> = examples
        .iter()
        .map(|(kept, dropped)| format!("({kept}, {dropped})"))
        .collect();
    let more = if count > examples.len() { " ..." } else { "" };
    format!(
        "{count}, e.g. (kept, dropped) input indices {}{more}",
        shown.join(" ")
    )
}

fn millis(d: Duration) -> String {
    format!("{:.3} ms", d.as_secs_f64() * 1e3)
}
