//! The `quadmesh` command line: mesh a point file, build its quadtree and write the leaves,
//! time meshing on generated points, or generate point files to try it on.

/// The stages allocate large arrays one after another; mimalloc reuses freed ones instead of
/// returning them to the system and faulting in fresh pages.
#[cfg(feature = "mimalloc")]
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

use std::fs::File;
use std::io::{self, BufWriter, IsTerminal, Write};
use std::num::NonZeroUsize;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use quadmesh::balance::Separation;
use quadmesh::dynamic::{
    BatchReport, DynamicDelaunay, DynamicMesh, Edit, RefinedEdit, TriangleChanges,
};
use quadmesh::generate::{self, Distribution2d};
use quadmesh::io::{
    read_input, read_points, with_extension_appended, write_graph_leaves_csv, write_input_poly,
    write_leaves_csv, write_msh, write_points, write_svg, write_triangle_files, write_vtu,
};
use quadmesh::mesh::{Domain, validate_pslg_with};
use quadmesh::morton::MortonKey;
use quadmesh::pipeline::{GraphTree, GraphTreeOptions, StageTimes, graph_tree};
use quadmesh::pslg::{CleanOptions, clean, cut_acute_corners};
use quadmesh::refine::{RefineDomain, RefineOptions, refine_points_in_order};
use quadmesh::{
    DVec2, GUARANTEED_MIN_ANGLE_DEG, Input, Mesh, MeshReport, Mode, Options, Refinement, Region,
    Tree, TreeBuild, TreeOptions, build_tree,
};

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
        /// a 5×5 block of same-size leaves holding no other point (the block warp's tree).
        #[arg(long)]
        separated: bool,
        /// With `--separated`: separate the points by the 2×2 blocks around their leaves'
        /// nearest corners instead (the warp's tree).
        #[arg(long, requires = "separated")]
        corners: bool,
        /// Read a planar straight-line graph (`.poly`), cut off its corners below 90°, and write
        /// the leaves of the balanced tree in which no leaf has, within three sides of it, two
        /// vertices, a vertex and an edge not ending at it, or two edges without a common end
        /// (the first stages of meshing a graph in the quadtree). `point` indexes the input's
        /// points, then the cut points.
        #[arg(long, conflicts_with_all = ["balanced", "separated"])]
        graph: bool,
        /// With `--graph`: refuse a graph whose tree needs more split squares than this (two
        /// long edges at a tiny angle must be kept apart all along, and can ask for more
        /// squares than memory holds).
        #[arg(
            long,
            requires = "graph",
            value_name = "N",
            default_value_t = 20_000_000
        )]
        max_squares: usize,
    },
    /// Mesh a point file or a planar straight-line graph (`.poly`): a Delaunay mesh with every
    /// angle at least `--min-angle` (of the points' convex hull, or of what the segments
    /// enclose, holes removed and regions marked), or the warped quadtree mesh (`--warp`);
    /// every input point a vertex with its exact coordinates, every segment a union of mesh
    /// edges carrying its marker.
    Mesh {
        /// Input: Triangle `.poly` (points, segments, holes, regions), `.node` (points), or
        /// text with one `x y` or `x,y` per line.
        input: PathBuf,
        /// Output prefix: writes PREFIX.node/.ele/.neigh/.edge (and PREFIX.poly for a graph), PREFIX.vtu, PREFIX.msh or
        /// PREFIX.svg as `--format` asks.
        #[arg(short, long, value_name = "PREFIX")]
        output: PathBuf,
        /// Output formats, comma-separated: node (Triangle's files), vtu (ParaView), msh
        /// (Gmsh 4.1), svg (a picture).
        #[arg(long, value_delimiter = ',', default_value = "node")]
        format: Vec<Format>,
        /// Worker threads [default: all cores].
        #[arg(long, value_name = "N")]
        threads: Option<NonZeroUsize>,
        /// Run the full validity check on the mesh before writing it (and, for a refined mesh,
        /// the exact in-circle test on every edge).
        #[arg(long)]
        check: bool,
        /// The most triangles an SVG shows (a window around the centre beyond that).
        #[arg(long, default_value_t = 200_000, value_name = "N")]
        svg_max_triangles: usize,
        #[command(flatten)]
        quality: QualityArgs,
    },
    /// Generate points in memory (or read a file) and mesh them, for timing and scaling studies.
    #[command(mut_arg("points", |a| a.required_unless_present("input")))]
    Bench {
        #[command(flatten)]
        points: PointsArgs,
        /// Mesh this file instead of generated points: Triangle `.poly` (a planar
        /// straight-line graph) or `.node`, or `x y` text. Reading is not timed.
        #[arg(long, value_name = "FILE", conflicts_with_all = ["points", "dist", "seed"])]
        input: Option<PathBuf>,
        /// Worker threads [default: all cores].
        #[arg(long, value_name = "N")]
        threads: Option<NonZeroUsize>,
        /// Print one JSON object as the last line.
        #[arg(long)]
        json: bool,
        /// Time a dynamic warped mesh of the points instead (on the square `--warp` takes by
        /// default, or a `--domain X0,Y0,X1,Y1` rectangle; the compact warp, or with
        /// `--block-warp` the block warp): `--edits` insertions (uniform in the points'
        /// bounding box), then as many deletions and moves there, one at a time, medians per
        /// kind against a build of the final points from scratch and its mesh.
        #[arg(long, conflicts_with_all = ["nonobtuse", "nonobtuse_split", "min_angle", "max_area", "max_vertices"])]
        dynamic: bool,
        /// With `--dynamic`: how many edits of each kind.
        #[arg(long, value_name = "K", default_value_t = 1000, requires = "dynamic")]
        edits: usize,
        #[command(flatten)]
        quality: QualityArgs,
    },
    /// Build the warped mesh of a point file on a fixed rectangle, apply a file of edits
    /// to it one by one, and write the final mesh: the same files `mesh --warp --domain` (or
    /// `--block-warp`, `--nonobtuse`) writes for the live points in id order. The input points
    /// have ids 0..n-1 in file order.
    Replay {
        /// The initial points: Triangle `.node`, or text with one `x y` or `x,y` per line.
        points: PathBuf,
        /// The edits, one a line: `i X Y` inserts a point (it takes the next id), `d ID`
        /// deletes one, `m ID X Y` moves one; `#` starts a comment line.
        edits: PathBuf,
        /// Output prefix, as for `mesh`.
        #[arg(short, long, value_name = "PREFIX")]
        output: PathBuf,
        /// The rectangle `X0,Y0,X1,Y1`, holding every point at every step (a square for
        /// `--block-warp` and `--nonobtuse`).
        #[arg(long, value_name = "X0,Y0,X1,Y1", value_parser = parse_box, allow_hyphen_values = true)]
        domain: Domain,
        /// Write the final mesh coarsened, as `mesh --warp` would (the dynamic mesh keeps the
        /// compact warp, written by default as `mesh --compact-warp` would; `--changes` reports
        /// its triangles).
        #[arg(long)]
        warp: bool,
        /// Write the compact warp, as `mesh --compact-warp` would (the default; accepted for
        /// clarity).
        #[arg(long, conflicts_with = "warp")]
        compact_warp: bool,
        /// Keep the block warp's tree and write its mesh instead, as `mesh --block-warp` would.
        #[arg(long, conflicts_with_all = ["warp", "compact_warp"])]
        block_warp: bool,
        /// Keep the block warp's tree and write its nonobtuse mesh instead, coarsened, as `mesh
        /// --nonobtuse` would (`--changes` reports the split's triangles).
        #[arg(long, conflicts_with_all = ["warp", "compact_warp", "block_warp"])]
        nonobtuse: bool,
        /// Keep the block warp's tree and write its nonobtuse split instead, as `mesh
        /// --nonobtuse-split` would.
        #[arg(long, conflicts_with_all = ["warp", "compact_warp", "block_warp", "nonobtuse"])]
        nonobtuse_split: bool,
        /// Keep a quality Delaunay mesh with every angle at least DEG instead
        /// (`DynamicDelaunay`): the final mesh is refinement in order of the live points
        /// (`--verify` compares it with one), and the JSON lines carry `windows`,
        /// `steiner_removed` and `steiner_added` instead of `cells`.
        #[arg(long, value_name = "DEG", conflicts_with_all = ["warp", "compact_warp", "block_warp", "nonobtuse", "nonobtuse_split"])]
        min_angle: Option<f64>,
        /// Output formats, comma-separated, as for `mesh`.
        #[arg(long, value_delimiter = ',', default_value = "node")]
        format: Vec<Format>,
        /// Worker threads [default: all cores].
        #[arg(long, value_name = "N")]
        threads: Option<NonZeroUsize>,
        /// Print a JSON line per edit or batch (`edit`: the first one's number, `edits`,
        /// `seconds`, `cells`, `rebuilt`) and one at the end
        /// (`build_seconds`, `mesh_seconds`, and with `--verify` `rebuild_seconds` and
        /// `identical`).
        #[arg(long)]
        json: bool,
        /// Build the final mesh from scratch too and compare the two.
        #[arg(long)]
        verify: bool,
        /// With `--json`: also print how many triangles each edit or batch removed and added
        /// (`triangles_removed`, `triangles_added`), found only around the change
        /// (`DynamicMesh::take_changes` warps the tree there; with `--min-angle`,
        /// `DynamicDelaunay::take_changes` triangulates the vertices there), in
        /// `changes_seconds`, apart from `seconds`, with the work it took (`changes_leaves`:
        /// the leaves warped, or the vertices triangulated).
        #[arg(long, requires = "json")]
        changes: bool,
        /// Apply the edits in batches of N (one tree update per batch, its moves in
        /// parallel), with a JSON line per batch.
        #[arg(long, value_name = "N", default_value_t = NonZeroUsize::MIN)]
        batch: NonZeroUsize,
    },
    /// Write seeded random points as `x y` lines, or a seeded planar straight-line graph as a
    /// Triangle `.poly` file (`--pslg`), that read back exactly.
    #[command(mut_arg("points", |a| a.required_unless_present("pslg")))]
    Generate {
        #[command(flatten)]
        points: PointsArgs,
        /// A planar straight-line graph instead of points.
        #[arg(long, value_name = "nested|holes", conflicts_with_all = ["points", "dist"])]
        pslg: Option<PslgShape>,
        /// For `--pslg nested`: how many segments (at least 16).
        #[arg(long, value_name = "N", requires = "pslg", conflicts_with = "holes")]
        segments: Option<usize>,
        /// For `--pslg holes`: how many holes.
        #[arg(long, value_name = "N", requires = "pslg")]
        holes: Option<usize>,
        /// Where to write the points or the `.poly` file; `-` for standard output.
        #[arg(short, long, value_name = "FILE")]
        output: PathBuf,
    },
}

/// Which mesh: a quality Delaunay mesh (the default) or the warped quadtree mesh.
#[derive(clap::Args, Clone)]
struct QualityArgs {
    /// The warped quadtree mesh instead: the compact warp coarsened, every angle in [20°, 120°],
    /// about 7 triangles per point, on the points' bounding box centred in a square twice its
    /// larger side, or on a `--domain` rectangle (`bbox` or given). For a `.poly` graph: what
    /// its segments enclose, from a quadtree bent onto the graph, its thin triangles' Steiner
    /// corners moved, coarsened, and what is left under 20° refined: every angle in
    /// [20°, 140°] outside input corners narrower than 20°.
    #[arg(long, conflicts_with_all = ["min_angle", "max_area", "max_vertices"])]
    warp: bool,
    /// The compact warp, not coarsened: every angle in [26°, 120°], about 36 triangles per
    /// point, on a rectangle as for `--warp`; several times faster than `--warp`. For a `.poly`
    /// graph, the warp before coarsening, refined as `--warp` is: every angle in [20°, 140°].
    #[arg(long, conflicts_with_all = ["warp", "min_angle", "max_area", "max_vertices"])]
    compact_warp: bool,
    /// The block warp instead: every angle in [22.5°, 112.5°], about 104 triangles per point,
    /// on a rectangle as for `--warp`.
    #[arg(long, conflicts_with_all = ["warp", "compact_warp", "min_angle", "max_area", "max_vertices"])]
    block_warp: bool,
    /// A nonobtuse mesh instead: every angle at most 90° (none bounded below; a point near a
    /// grid line of its leaf makes thin triangles), about 47–57 triangles per point, on a
    /// rectangle as for `--warp`: `--nonobtuse-split` coarsened, no new angle under 20°.
    #[arg(long, conflicts_with_all = ["warp", "compact_warp", "block_warp", "min_angle", "max_area", "max_vertices"])]
    nonobtuse: bool,
    /// The block warp's quadtree split into right triangles at the points, not coarsened: every
    /// angle at most 90°, about 114 triangles per point; several times faster than
    /// `--nonobtuse`.
    #[arg(long, conflicts_with_all = ["warp", "compact_warp", "block_warp", "nonobtuse", "min_angle", "max_area", "max_vertices"])]
    nonobtuse_split: bool,
    /// Every angle at least A degrees (0 to 45) [default: 20, below the 20.7° up to which
    /// termination is proven]. Above 20.7° refinement usually finishes up to about 34° and
    /// stops at the vertex budget otherwise. Input angles smaller than A (narrow corners of the
    /// convex hull) stay as they are.
    #[arg(long, value_name = "A", allow_negative_numbers = true)]
    min_angle: Option<f64>,
    /// Every triangle's area at most X.
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    max_area: Option<f64>,
    /// The region to mesh: `hull` (the points' convex hull, the default of the Delaunay mode),
    /// `bbox` (their bounding box), `square` (the bounding box centred in a square twice its
    /// larger side, the default of `--warp`) or `X0,Y0,X1,Y1`, a rectangle holding every point
    /// (points on its sides become boundary vertices).
    #[arg(long, value_name = "hull|bbox|square|X0,Y0,X1,Y1", value_parser = parse_domain, allow_hyphen_values = true)]
    domain: Option<Region>,
    /// Refinement stops past N vertices, input points included, writes the mesh reached and
    /// exits with an error naming where it stopped [default: 100 per point + 10000].
    #[arg(long, value_name = "N")]
    max_vertices: Option<usize>,
    /// For a `.poly` file: mesh the convex hull of its points minus its holes (Triangle's `-c`)
    /// instead of what its segments enclose; the same as `--domain hull`.
    #[arg(long, conflicts_with = "domain")]
    convex_hull: bool,
    /// For a `.poly` file: never split a boundary segment (Triangle's `-Y`); angles beside the
    /// boundary may then stay below the bound.
    #[arg(long)]
    no_boundary_steiner: bool,
    /// For a `.poly` file: split crossing segments at their intersection instead of refusing
    /// them.
    #[arg(long)]
    split_crossings: bool,
    /// For a `.poly` file (Delaunay mode): after refinement, take out the Steiner vertices on
    /// no segment wherever the mesh left, with free vertices beside them moved, still meets
    /// every bound; a smaller constrained Delaunay mesh, for more time.
    #[arg(long)]
    remove_spare_vertices: bool,
}

/// `hull`, `bbox`, `square` or `x0,y0,x1,y1`.
fn parse_domain(text: &str) -> Result<Region, String> {
    match text.trim() {
        "hull" => return Ok(Region::ConvexHull),
        "bbox" => return Ok(Region::BoundingBox),
        "square" => return Ok(Region::Square),
        _ => {}
    }
    let [x0, y0, x1, y1] = parse_rectangle(text)?;
    Ok(Region::Rectangle(Domain {
        lo: DVec2::new(x0, y0),
        hi: DVec2::new(x1, y1),
    }))
}

/// `x0,y0,x1,y1`, a rectangle.
fn parse_box(text: &str) -> Result<Domain, String> {
    let [x0, y0, x1, y1] = parse_rectangle(text)?;
    Ok(Domain {
        lo: DVec2::new(x0, y0),
        hi: DVec2::new(x1, y1),
    })
}

/// `x0,y0,x1,y1` as four numbers.
fn parse_rectangle(text: &str) -> Result<[f64; 4], String> {
    let numbers: Vec<f64> = text
        .split(',')
        .map(|t| t.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("{text:?}: {e}"))?;
    numbers
        .try_into()
        .map_err(|_| format!("{text:?}: four numbers x0,y0,x1,y1 expected"))
}

impl QualityArgs {
    /// The library's options for these arguments.
    fn options(&self) -> Options {
        let mut options = Options::default();
        if self.warp {
            options = options.warp();
        }
        if self.compact_warp {
            options = options.compact_warp();
        }
        if self.block_warp {
            options = options.block_warp();
        }
        if self.nonobtuse {
            options = options.nonobtuse();
        }
        if self.nonobtuse_split {
            options = options.nonobtuse_split();
        }
        if let Some(a) = self.min_angle {
            options = options.min_angle(a);
        }
        if let Some(x) = self.max_area {
            options = options.max_area(x);
        }
        if let Some(n) = self.max_vertices {
            options = options.max_vertices(n);
        }
        if let Some(region) = self.domain {
            options = options.region(region);
        }
        if self.convex_hull {
            options = options.region(Region::ConvexHull);
        }
        if self.no_boundary_steiner {
            options = options.no_boundary_steiner();
        }
        if self.split_crossings {
            options = options.split_crossings();
        }
        if self.remove_spare_vertices {
            options = options.remove_spare_vertices();
        }
        options
    }

    /// Refuses options out of range before any work, and warns about an angle bound beyond
    /// the proven one.
    fn check(&self) -> Result<()> {
        let options = self.options();
        options
            .check()
            .map_err(|e| anyhow::anyhow!(cli_terms(&e)))?;
        if !options.termination_proven() {
            let _ = writeln!(
                io::stderr(),
                "warning: termination is proven up to {GUARANTEED_MIN_ANGLE_DEG:.1}°; at {}° \
                 refinement may stop at the vertex budget",
                options.min_angle_deg()
            );
        }
        Ok(())
    }

    /// Meshes `input` the way these arguments ask.
    fn mesh(&self, input: Input) -> (Input, Result<(Mesh, MeshReport), quadmesh::Error>) {
        let result = quadmesh::mesh(&input, &self.options());
        (input, result)
    }
}

/// An option error in the command line's terms.
fn cli_terms(e: &quadmesh::Error) -> String {
    match e {
        quadmesh::Error::InvalidOption { option, message } => {
            let flag = match *option {
                "min_angle" => "--min-angle",
                "max_area" => "--max-area",
                "region" | "domain" => "--domain",
                "mode" => "--warp/--compact-warp/--block-warp/--nonobtuse/--nonobtuse-split",
                other => other,
            };
            format!("{flag}: {message}")
        }
        other => other.to_string(),
    }
}

/// Which generated points: the same arguments give the same points on every machine.
#[derive(clap::Args)]
struct PointsArgs {
    /// How many points.
    #[arg(long, value_name = "N")]
    points: Option<usize>,
    /// Distribution: uniform, cluster, kuzmin or grid.
    #[arg(long, default_value = "uniform")]
    dist: Distribution2d,
    /// Seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

/// Turns transparent huge pages off for this process. mimalloc asks for them on every region
/// it maps, and the first touch of a 2 MiB page zeroes all of it, used or not, after compacting
/// memory where another process has fragmented it. On 1e6 points at 30° zeroing pages took
/// 22 % of the run with them and under 1 % without; the run, and the block of 50 000 holes run
/// right after Triangle, took 7 % and 27 % less time without them, and no run was slower.
#[cfg(target_os = "linux")]
#[allow(unsafe_code)]
fn decline_transparent_huge_pages() {
    // SAFETY: PR_SET_THP_DISABLE takes one integer and only sets a flag of this process that
    // the kernel reads at later page faults; it touches no memory of the program. Failure (an
    // old kernel) leaves huge pages on, which is harmless.
    unsafe { libc::prctl(libc::PR_SET_THP_DISABLE, 1, 0, 0, 0) };
}

#[cfg(not(target_os = "linux"))]
fn decline_transparent_huge_pages() {}

fn main() -> ExitCode {
    decline_transparent_huge_pages();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Tree {
            input,
            output,
            threads,
            balanced,
            separated,
            corners,
            graph,
            max_squares,
        } => {
            let refinement = match (balanced, separated) {
                (_, true) if corners => Refinement::CornerSeparated,
                (_, true) => Refinement::Separated,
                (true, _) => Refinement::Balanced,
                _ => Refinement::Unbalanced,
            };
            if graph {
                graph_tree_leaves(&input, &output, threads, max_squares)
            } else {
                tree(
                    &input,
                    &output,
                    threads,
                    TreeOptions::default().refinement(refinement),
                )
            }
        }
        Command::Mesh {
            input,
            output,
            format,
            threads,
            check,
            svg_max_triangles,
            quality,
        } => mesh(
            &input,
            &output,
            &format,
            threads,
            (check, svg_max_triangles),
            quality,
        ),
        Command::Bench {
            points,
            input,
            threads,
            json,
            dynamic,
            edits,
            quality,
        } => match dynamic {
            true => {
                // The dynamic mesh keeps the compact warp's tree unless the block warp's is
                // asked for.
                let separation = match quality.block_warp {
                    true => Separation::Block,
                    false => Separation::Corner,
                };
                let domain = quality.domain;
                bench_dynamic(points, input, threads, json, (edits, separation, domain))
            }
            false => bench(points, input, threads, json, quality),
        },
        Command::Replay {
            points,
            edits,
            output,
            domain,
            min_angle: Some(angle),
            format,
            threads,
            json,
            verify,
            changes,
            batch,
            ..
        } => replay_delaunay(
            (&points, &edits),
            &output,
            (domain, angle),
            &format,
            threads,
            (json, verify, changes, batch.get()),
        ),
        Command::Replay {
            points,
            edits,
            output,
            domain,
            warp,
            compact_warp: _,
            block_warp,
            nonobtuse,
            nonobtuse_split,
            min_angle: None,
            format,
            threads,
            json,
            verify,
            changes,
            batch,
        } => replay(
            (&points, &edits),
            &output,
            domain,
            &format,
            threads,
            (json, verify, changes, batch.get()),
            match (warp, block_warp, nonobtuse, nonobtuse_split) {
                (_, _, _, true) => Mode::NonobtuseSplit,
                (_, _, true, _) => Mode::Nonobtuse,
                (_, true, _, _) => Mode::BlockWarp,
                (true, _, _, _) => Mode::Warp,
                _ => Mode::CompactWarp,
            },
        ),
        Command::Generate {
            points,
            pslg,
            segments,
            holes,
            output,
        } => generate(points, pslg.map(|shape| (shape, segments, holes)), &output),
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

/// A generated planar straight-line graph.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum PslgShape {
    /// Nested wavy rings, every other annulus a hole (`--segments`).
    Nested,
    /// A square block with rectangular holes (`--holes`).
    Holes,
}

/// A mesh output format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum Format {
    /// Triangle's .node, .ele, .neigh and .edge files.
    Node,
    /// VTK unstructured grid for ParaView.
    Vtu,
    /// Gmsh MSH 4.1.
    Msh,
    /// An SVG picture.
    Svg,
}

fn pool(threads: Option<NonZeroUsize>) -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads.map_or(0, NonZeroUsize::get))
        .build()
        .context("cannot start the worker threads")
}

/// The mesh a refinement reached before it stopped short, taken out of the error that
/// carries one; any other error back.
fn reached(e: quadmesh::Error) -> Result<quadmesh::Incomplete, quadmesh::Error> {
    match e {
        quadmesh::Error::VertexBudget(partial)
        | quadmesh::Error::RefinementResolution {
            reached: Some(partial),
            ..
        } => Ok(*partial),
        e => Err(e),
    }
}

/// A spinner on standard error while `f` runs, when standard error is a terminal.
fn with_spinner<T>(message: &'static str, f: impl FnOnce() -> T) -> T {
    let spinner = if io::stderr().is_terminal() {
        ProgressBar::new_spinner()
    } else {
        ProgressBar::hidden()
    };
    spinner.set_style(
        ProgressStyle::with_template("{spinner} {msg} {elapsed}").expect("a valid template"),
    );
    spinner.set_message(message);
    spinner.enable_steady_tick(Duration::from_millis(100));
    let out = f();
    spinner.finish_and_clear();
    out
}

/// `quadmesh mesh`: read, mesh, optionally check, write each format, report.
fn mesh(
    input: &Path,
    prefix: &Path,
    formats: &[Format],
    threads: Option<NonZeroUsize>,
    (check, svg_max_triangles): (bool, usize),
    quality: QualityArgs,
) -> Result<()> {
    quality.check()?;
    refuse_overwriting(input, prefix)?;
    pool(threads)?.install(|| {
        let (read, read_time) = timed(|| with_spinner("reading", || read_input(input)));
        let read = read?;
        let ((input_points, meshed), _) = timed(|| with_spinner("meshing", || quality.mesh(read)));
        // A refinement stopped at its budget, or where f64 cannot place a vertex, still
        // writes the mesh it reached, then fails.
        let (mesh, report, unfinished) = match meshed {
            Ok((mesh, report)) => (mesh, report, None),
            Err(e) => {
                let message = e.to_string();
                match reached(e) {
                    Ok(partial) => (partial.mesh, partial.report, Some(message)),
                    Err(e) => return Err(anyhow::anyhow!("{}: {e}", input.display())),
                }
            }
        };
        let options = quality.options();
        if check && unfinished.is_none() {
            with_spinner("checking", || {
                if input_points.is_graph() {
                    let hull = options.region_choice() == Region::ConvexHull;
                    let bounds = options.angle_bounds_of(&input_points);
                    validate_pslg_with(&mesh, &input_points, bounds, hull)?;
                } else if matches!(options.mode(), Mode::Nonobtuse | Mode::NonobtuseSplit) {
                    mesh.validate_nonobtuse(&input_points.points)?;
                } else {
                    mesh.validate(&input_points.points, options.angle_bounds())?;
                }
                // A Delaunay mesh is also checked edge by edge.
                if options.mode() == Mode::Delaunay {
                    mesh.check_delaunay()?;
                }
                Ok::<_, quadmesh::InvalidMesh>(())
            })
            .map_err(|fault| anyhow::anyhow!("the mesh failed its check: {fault}"))?;
        }
        let (written, write_time) = timed(|| {
            with_spinner("writing", || {
                write_formats(&mesh, prefix, formats, svg_max_triangles)
            })
        });
        let files = written?;
        let mut err = io::stderr().lock();
        let _ = writeln!(err, "{:<24}{}", "input points", input_points.points.len());
        let _ = writeln!(err, "{:<24}{}", "time read", millis(read_time));
        print_report(&mut err, &report, &mesh);
        if check && unfinished.is_none() {
            let _ = writeln!(err, "{:<24}passed", "check");
        }
        let _ = writeln!(err, "{:<24}{}", "time write", millis(write_time));
        for file in files {
            let _ = writeln!(err, "{:<24}{}", "wrote", file.display());
        }
        match unfinished {
            None => Ok(()),
            Some(message) => Err(anyhow::anyhow!("{}: {message}", input.display())),
        }
    })
}

/// `quadmesh replay`: build, apply the edits one by one (timing each), write the final mesh,
/// and with `verify` compare it with a build from scratch.
fn replay(
    (points_path, edits_path): (&Path, &Path),
    prefix: &Path,
    domain: Domain,
    formats: &[Format],
    threads: Option<NonZeroUsize>,
    (json, verify, changes, batch): (bool, bool, bool, usize),
    mode: Mode,
) -> Result<()> {
    let (points, edits) = replay_inputs((points_path, edits_path), prefix)?;
    pool(threads)?.install(|| {
        let separation = match mode {
            Mode::Warp | Mode::CompactWarp => Separation::Corner,
            _ => Separation::Block,
        };
        let (built, build_time) =
            timed(|| DynamicMesh::with_separation(&points, domain, separation));
        let mut dynamic = built.map_err(|e| anyhow::anyhow!("{}: {e}", points_path.display()))?;
        let mut out = io::stdout().lock();
        let mut seconds = Vec::with_capacity(edits.len());
        let mesh_of = |dynamic: &DynamicMesh| match mode {
            Mode::Nonobtuse => dynamic.coarsened_nonobtuse_mesh(),
            Mode::NonobtuseSplit => dynamic.mesh_nonobtuse(),
            Mode::Warp => dynamic.coarsened_mesh(),
            _ => dynamic.mesh(),
        };
        dynamic.track_changes(changes);
        for (b, group) in edits.chunks(batch).enumerate() {
            // A single edit takes the single-edit path, which updates the arrays in place.
            let (done, time) = timed(|| match group {
                [edit] => dynamic.apply(&[*edit]).map(|r| BatchReport {
                    ids: vec![r[0].id],
                    cells: r[0].cells,
                    rebuilt: r[0].rebuilt,
                }),
                _ => dynamic.apply_batch(group),
            });
            let report = done.map_err(|(k, e)| refused_edit(edits_path, &edits, b * batch + k, e))?;
            seconds.push(time.as_secs_f64());
            let mut triangles = String::new();
            if changes {
                let (found, time) = timed(|| match mode {
                    Mode::Nonobtuse | Mode::NonobtuseSplit => dynamic.take_nonobtuse_changes(),
                    _ => dynamic.take_changes(),
                });
                triangles = changes_json(found, time)?;
            }
            if json {
                writeln!(
                    out,
                    "{{\"edit\":{},\"edits\":{},\"seconds\":{},\"cells\":{},\"rebuilt\":{}{triangles}}}",
                    b * batch + 1,
                    group.len(),
                    time.as_secs_f64(),
                    report.cells,
                    report.rebuilt
                )?;
            }
        }
        let (meshed, mesh_time) = timed(|| mesh_of(&dynamic));
        let mesh = meshed.map_err(|e| anyhow::anyhow!("the final mesh: {e}"))?;
        let rebuild = || {
            let (_, live) = dynamic.live_points();
            let options = Options::default()
                .with_mode(mode)
                .region(Region::Rectangle(domain));
            quadmesh::mesh(&Input::points(live), &options).map(|(m, _)| m)
        };
        let times = (build_time, mesh_time, &mut seconds[..]);
        finish_replay(
            &mut out,
            &mesh,
            (dynamic.len(), edits.len(), times),
            verify.then_some(rebuild),
            (prefix, formats, json),
        )
    })
}

/// `quadmesh replay --min-angle`: as [`replay`] for a dynamic quality Delaunay mesh.
fn replay_delaunay(
    (points_path, edits_path): (&Path, &Path),
    prefix: &Path,
    (domain, angle): (Domain, f64),
    formats: &[Format],
    threads: Option<NonZeroUsize>,
    (json, verify, changes, batch): (bool, bool, bool, usize),
) -> Result<()> {
    let (points, edits) = replay_inputs((points_path, edits_path), prefix)?;
    let options = RefineOptions {
        min_angle_deg: angle,
        domain: RefineDomain::Rectangle(domain),
        ..RefineOptions::default()
    };
    pool(threads)?.install(|| {
        let (built, build_time) = timed(|| DynamicDelaunay::new(&points, &options));
        let mut dynamic = built.map_err(|e| anyhow::anyhow!("{}: {e}", points_path.display()))?;
        let mut out = io::stdout().lock();
        let mut seconds = Vec::with_capacity(edits.len());
        dynamic.track_changes(changes);
        for (b, group) in edits.chunks(batch).enumerate() {
            let (done, time) = timed(|| dynamic.apply(group));
            let reports =
                done.map_err(|(k, e)| refused_edit(edits_path, &edits, b * batch + k, e))?;
            seconds.push(time.as_secs_f64());
            let mut triangles = String::new();
            if changes {
                let (found, time) = timed(|| dynamic.take_changes());
                triangles = changes_json(found, time)?;
            }
            if json {
                let sum = |f: fn(&RefinedEdit) -> usize| reports.iter().map(f).sum::<usize>();
                writeln!(
                    out,
                    "{{\"edit\":{},\"edits\":{},\"seconds\":{},\"windows\":{},\"steiner_removed\":{},\"steiner_added\":{},\"rebuilt\":{}{triangles}}}",
                    b * batch + 1,
                    group.len(),
                    time.as_secs_f64(),
                    sum(|r| r.windows as usize),
                    sum(|r| r.steiner_removed),
                    sum(|r| r.steiner_added),
                    reports.iter().any(|r| r.rebuilt)
                )?;
            }
        }
        let (meshed, mesh_time) = timed(|| dynamic.mesh());
        let mesh = meshed.map_err(|e| anyhow::anyhow!("the final mesh: {e}"))?;
        let live = dynamic.live_points();
        let rebuild = || refine_points_in_order(&live, &options).map(|(m, _)| m);
        let times = (build_time, mesh_time, &mut seconds[..]);
        finish_replay(
            &mut out,
            &mesh,
            (live.len(), edits.len(), times),
            verify.then_some(rebuild),
            (prefix, formats, json),
        )
    })
}

/// The error for edit `at` (from 0) of the file at `edits_path`, refused for `e`.
fn refused_edit(edits_path: &Path, edits: &[Edit], at: usize, e: quadmesh::Error) -> anyhow::Error {
    let edit = edits[at];
    anyhow::anyhow!("{}: edit {} ({edit:?}): {e}", edits_path.display(), at + 1)
}

/// The JSON fields of the changes one edit or batch made, found in `time`.
fn changes_json(found: Result<TriangleChanges, quadmesh::Error>, time: Duration) -> Result<String> {
    let change = found.map_err(|e| anyhow::anyhow!("the changes: {e}"))?;
    Ok(format!(
        ",\"triangles_removed\":{},\"triangles_added\":{},\"changes_seconds\":{},\"changes_leaves\":{}",
        change.removed.len(),
        change.added.len(),
        time.as_secs_f64(),
        change.leaves
    ))
}

/// The initial points and the edits of a replay, after refusing an output prefix that would
/// overwrite the points.
fn replay_inputs(
    (points_path, edits_path): (&Path, &Path),
    prefix: &Path,
) -> Result<(Vec<DVec2>, Vec<Edit>)> {
    refuse_overwriting(points_path, prefix)?;
    let points = read_points(points_path)?;
    let text = std::fs::read_to_string(edits_path)
        .with_context(|| format!("cannot read {}", edits_path.display()))?;
    let edits = quadmesh::io::parse_edits(&text, &edits_path.display().to_string())?;
    Ok((points, edits))
}

/// The end of a replay of either mode: the summary line (with `rebuild`'s mesh compared, when
/// given), the files, and the report on stderr.
fn finish_replay(
    out: &mut impl Write,
    mesh: &Mesh,
    (live, edits, (build_time, mesh_time, seconds)): (
        usize,
        usize,
        (Duration, Duration, &mut [f64]),
    ),
    rebuild: Option<impl FnOnce() -> Result<Mesh, quadmesh::Error>>,
    (prefix, formats, json): (&Path, &[Format], bool),
) -> Result<()> {
    let mut summary = format!(
        "{{\"points\":{live},\"edits\":{edits},\"build_seconds\":{},\"mesh_seconds\":{},\"edit_seconds_median\":{}",
        build_time.as_secs_f64(),
        mesh_time.as_secs_f64(),
        median(seconds)
    );
    if let Some(rebuild) = rebuild {
        let (rebuilt, rebuild_time) = timed(rebuild);
        let rebuilt = rebuilt.map_err(|e| anyhow::anyhow!("the rebuild: {e}"))?;
        let identical = rebuilt == *mesh;
        summary += &format!(
            ",\"rebuild_seconds\":{},\"identical\":{identical}",
            rebuild_time.as_secs_f64()
        );
        if !identical {
            anyhow::bail!("the replayed mesh differs from a build from scratch");
        }
    }
    let files = write_formats(mesh, prefix, formats, 200_000)?;
    if json {
        writeln!(out, "{summary}}}")?;
    }
    let mut err = io::stderr().lock();
    let _ = writeln!(err, "{:<24}{live}", "live points");
    let _ = writeln!(err, "{:<24}{edits}", "edits");
    let _ = writeln!(err, "{:<24}{}", "time build", millis(build_time));
    let _ = writeln!(err, "{:<24}{:.3} ms", "edit median", median(seconds) * 1e3);
    let _ = writeln!(err, "{:<24}{}", "time mesh", millis(mesh_time));
    let _ = writeln!(err, "{:<24}{}", "triangles", mesh.triangles.len());
    for file in files {
        let _ = writeln!(err, "{:<24}{}", "wrote", file.display());
    }
    Ok(())
}

/// The median of `values` (0 for none).
fn median(values: &mut [f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

/// Refuses an output prefix whose files would replace the input file.
fn refuse_overwriting(input: &Path, prefix: &Path) -> Result<()> {
    let same = |a: &Path, b: &Path| match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    };
    let extensions = ["node", "ele", "neigh", "edge", "poly", "vtu", "msh", "svg"];
    match extensions
        .into_iter()
        .map(|e| with_extension_appended(prefix, e))
        .find(|out| same(out, input))
    {
        Some(out) => Err(anyhow::anyhow!(
            "{}: the output would replace the input; choose another prefix",
            out.display()
        )),
        None => Ok(()),
    }
}

fn write_formats(
    mesh: &Mesh,
    prefix: &Path,
    formats: &[Format],
    svg_max_triangles: usize,
) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for &format in formats {
        match format {
            Format::Node => files.extend(
                write_triangle_files(mesh, prefix)
                    .with_context(|| format!("cannot write {}.*", prefix.display()))?,
            ),
            Format::Vtu => files.push(write_file(prefix, "vtu", |w| write_vtu(mesh, w))?),
            Format::Msh => files.push(write_file(prefix, "msh", |w| write_msh(mesh, w))?),
            Format::Svg => files.push(write_file(prefix, "svg", |w| {
                write_svg(mesh, w, svg_max_triangles)
            })?),
        }
    }
    Ok(files)
}

fn write_file(
    prefix: &Path,
    extension: &str,
    write: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> Result<PathBuf> {
    let path = with_extension_appended(prefix, extension);
    write_to(&path, write)?;
    Ok(path)
}

/// Counts, angles and stage times, one per line.
fn print_report(err: &mut dyn Write, report: &MeshReport, mesh: &Mesh) {
    let domain = mesh.domain;
    let mut lines = vec![
        ("distinct points", report.points.to_string()),
        ("duplicates merged", report.duplicates.to_string()),
        (
            "domain",
            format!(
                "[{}, {}] x [{}, {}]",
                domain.lo.x, domain.hi.x, domain.lo.y, domain.hi.y
            ),
        ),
        ("vertices", report.vertices.to_string()),
        (
            "triangles",
            format!(
                "{} ({:.1} per point)",
                report.triangles,
                report.triangles as f64 / report.points.max(1) as f64
            ),
        ),
        (
            "angles",
            format!("{:.2}° .. {:.2}°", report.min_angle, report.max_angle),
        ),
    ];
    if let Some(b) = report.angle_bounds {
        let bounds = format!("{:.2}° .. {:.2}° guaranteed", b.min_deg, b.max_deg);
        lines.push(("angle bounds", bounds));
    }
    lines.push(("angle histogram", histogram_line(&report.histogram)));
    for (label, value) in lines {
        let _ = writeln!(err, "{label:<24}{value}");
    }
    if let Some(cleaning) = &report.cleaning {
        let graph = [
            ("splits at points", cleaning.vertex_splits),
            ("crossings split", cleaning.crossing_splits),
            ("repeated segments", cleaning.repeated_segments),
            ("segment pieces", mesh.segments.len()),
            ("holes", mesh.holes.len()),
            ("regions", mesh.region_attributes.len()),
            ("free vertices deleted", report.free_vertices_deleted),
            ("spare vertices removed", report.spare_vertices_removed),
        ];
        for (label, value) in graph {
            let _ = writeln!(err, "{label:<24}{value}");
        }
    }
    for (stage, d) in &report.stages {
        let _ = writeln!(err, "{:<24}{}", format!("time {stage}"), millis(*d));
    }
}

/// The nonzero 10° bins: `20-30°: 1234, ...`.
fn histogram_line(histogram: &[u64; 18]) -> String {
    let bins: Vec<String> = histogram
        .iter()
        .enumerate()
        .filter(|(_, c)| **c > 0)
        .map(|(i, c)| format!("{}-{}°: {c}", 10 * i, 10 * (i + 1)))
        .collect();
    bins.join(", ")
}

/// `quadmesh bench`: generate (or read), mesh, report; with `json`, one JSON object as the last
/// line.
fn bench(
    points: PointsArgs,
    input: Option<PathBuf>,
    threads: Option<NonZeroUsize>,
    json: bool,
    quality: QualityArgs,
) -> Result<()> {
    quality.check()?;
    let pool = pool(threads)?;
    let (source, geometry) = match &input {
        Some(path) => {
            let read = pool.install(|| read_input(path))?;
            let source = format!(
                "\"input\":{},\"points\":{},\"segments\":{}",
                json_string(&path.display().to_string()),
                read.points.len(),
                read.segments.len()
            );
            (source, read)
        }
        None => {
            let PointsArgs { points, dist, seed } = points;
            let n = points.context("--points N or --input FILE is required")?;
            let source = format!("\"points\":{n},\"dist\":\"{dist:?}\",\"seed\":{seed}");
            (
                source,
                Input::points(pool.install(|| generate::points(dist, n, seed))),
            )
        }
    };
    let ((_, meshed), wall) = timed(|| pool.install(|| quality.mesh(geometry)));
    let (mesh, report) = match (meshed, &input) {
        (Ok(done), _) => done,
        (Err(e), Some(path)) => return Err(anyhow::anyhow!("{}: {e}", path.display())),
        (Err(e), None) => return Err(e.into()),
    };
    let mut out = io::stdout().lock();
    print_report(&mut out, &report, &mesh);
    let _ = writeln!(out, "{:<24}{}", "time total", millis(wall));
    if json {
        writeln!(
            out,
            "{{{source},\"threads\":{},{},\"total_s\":{},\"vertices\":{},\"triangles\":{},\"min_angle\":{},\"max_angle\":{},\"peak_rss_bytes\":{}}}",
            pool.current_num_threads(),
            stage_seconds_json(&report),
            wall.as_secs_f64(),
            report.vertices,
            report.triangles,
            report.min_angle,
            report.max_angle,
            peak_rss_bytes().unwrap_or(0),
        )?;
    }
    Ok(())
}

/// `quadmesh bench --dynamic`: single insertions, deletions and moves on a dynamic warped mesh
/// of the points, each timed, against a build from scratch of the final points.
fn bench_dynamic(
    points: PointsArgs,
    input: Option<PathBuf>,
    threads: Option<NonZeroUsize>,
    json: bool,
    (edits, separation, domain): (usize, Separation, Option<Region>),
) -> Result<()> {
    let pool = pool(threads)?;
    let seed = points.seed;
    let (source, initial) = match &input {
        Some(path) => (
            format!("\"input\":{}", json_string(&path.display().to_string())),
            read_points(path)?,
        ),
        None => {
            let n = points
                .points
                .context("--points N or --input FILE is required")?;
            let dist = points.dist;
            (
                format!("\"points\":{n},\"dist\":\"{dist:?}\",\"seed\":{seed}"),
                pool.install(|| generate::points(dist, n, seed)),
            )
        }
    };
    // A given rectangle, or the square the warp takes by default.
    let domain = match domain {
        Some(Region::Rectangle(domain)) => domain,
        Some(_) => anyhow::bail!("--dynamic takes a rectangle X0,Y0,X1,Y1 as --domain"),
        None => square_around(&initial)?,
    };
    pool.install(|| {
        let (built, build) =
            timed(|| DynamicMesh::with_separation(&initial, domain, separation));
        let mut dynamic = built?;
        let n = initial.len() as u64;
        // New places, uniform in the points' bounding box (where the points are, whatever
        // room the domain leaves around them); ids to delete and to move, in a seeded order.
        let (lo, hi) = quadmesh::morton::bounding_box(&initial);
        let places: Vec<DVec2> = generate::points(Distribution2d::Uniform, 2 * edits, seed + 1)
            .into_iter()
            .map(|u| lo + u * (hi - lo))
            .collect();
        let mut ids: Vec<u32> = (0..initial.len() as u32).collect();
        ids.sort_by_key(|&id| (u64::from(id) ^ seed).wrapping_mul(0x9E37_79B9_7F4A_7C15) % n.max(1));
        // Per kind: seconds and squares touched per edit, and seconds and leaves warped to
        // find the triangles it changed.
        let mut timings: [Vec<(f64, usize, f64, usize)>; 3] = Default::default();
        dynamic.track_changes(true);
        let mut run = |kind: usize, edit: Edit| -> Result<()> {
            let (done, time) = timed(|| dynamic.apply(&[edit]));
            // A random place can repeat a live point's: that edit is refused and not counted.
            if let Ok(reports) = done {
                let (changes, changes_time) = timed(|| dynamic.take_changes());
                timings[kind].push((
                    time.as_secs_f64(),
                    reports[0].cells,
                    changes_time.as_secs_f64(),
                    changes?.leaves,
                ));
            }
            Ok(())
        };
        for &p in &places[..edits] {
            run(0, Edit::Insert(p))?;
        }
        for &id in ids.iter().take(edits) {
            run(1, Edit::Delete(id))?;
        }
        for (&id, &p) in ids.iter().skip(edits).zip(&places[edits..]) {
            run(2, Edit::Move(id, p))?;
        }
        let (_, live) = dynamic.live_points();
        let (rebuilt, rebuild) =
            timed(|| DynamicMesh::with_separation(&live, domain, separation));
        rebuilt?;
        let (meshed, mesh) = timed(|| dynamic.mesh());
        let triangles = meshed?.triangles.len();
        let mut out = io::stdout().lock();
        let warp = match separation {
            Separation::Corner => "compact",
            Separation::Block => "block",
        };
        writeln!(out, "{:<24}{warp}, {triangles} triangles", "warp")?;
        let mut fields = format!(",\"warp\":\"{warp}\",\"triangles\":{triangles}");
        for (kind, name) in ["insert", "delete", "move"].into_iter().enumerate() {
            let column = |f: fn(&(f64, usize, f64, usize)) -> f64| {
                median(&mut timings[kind].iter().map(f).collect::<Vec<f64>>())
            };
            let (seconds, cells) = (column(|t| t.0), column(|t| t.1 as f64));
            let (changes, leaves) = (column(|t| t.2), column(|t| t.3 as f64));
            writeln!(
                out,
                "{:<24}{} median, {cells} squares touched ({} edits); its triangles {} median, {leaves} leaves warped",
                name,
                millis(Duration::from_secs_f64(seconds)),
                timings[kind].len(),
                millis(Duration::from_secs_f64(changes)),
            )?;
            fields += &format!(
                ",\"{name}_s\":{seconds},\"{name}_cells\":{cells},\"{name}_changes_s\":{changes},\"{name}_changes_leaves\":{leaves}"
            );
        }
        writeln!(out, "{:<24}{}", "tree from scratch", millis(rebuild))?;
        writeln!(out, "{:<24}{}", "mesh()", millis(mesh))?;
        if json {
            writeln!(
                out,
                "{{{source},\"threads\":{},\"edits\":{edits},\"build_s\":{}{fields},\"rebuild_s\":{},\"mesh_s\":{},\"peak_rss_bytes\":{}}}",
                rayon::current_num_threads(),
                build.as_secs_f64(),
                rebuild.as_secs_f64(),
                mesh.as_secs_f64(),
                peak_rss_bytes().unwrap_or(0),
            )?;
        }
        Ok(())
    })
}

/// A square around the points, as the warp mode's default one is (the bounding box near its
/// middle), whose sides are exactly equal in f64 as a dynamic mesh needs: its side a power of
/// two from twice to four times the box's larger side, its corner on a grid of 2^-20 of that.
fn square_around(points: &[DVec2]) -> Result<Domain> {
    anyhow::ensure!(!points.is_empty(), "no points");
    let (lo, hi) = quadmesh::morton::bounding_box(points);
    let extent = (hi - lo).max_element();
    let side = if extent > 0.0 {
        (2.0 * extent).log2().ceil().exp2()
    } else {
        2.0
    };
    let quantum = side / f64::from(1u32 << 20);
    let corner = (((lo + hi) * 0.5 - DVec2::splat(side / 2.0)) / quantum).floor() * quantum;
    let domain = Domain {
        lo: corner,
        hi: corner + DVec2::splat(side),
    };
    let extents = domain.hi - domain.lo;
    anyhow::ensure!(
        extents.x == side && extents.y == side && domain.contains(lo) && domain.contains(hi),
        "no square with exactly equal sides in f64 holds these points"
    );
    Ok(domain)
}

/// `"<stage>_s":seconds` for each stage, comma-separated; a stage that ran twice (a domain's
/// graded attempt given up) counts once, summed.
fn stage_seconds_json(report: &MeshReport) -> String {
    let mut totals: Vec<(&str, f64)> = Vec::new();
    for (stage, d) in &report.stages {
        match totals.iter_mut().find(|(name, _)| name == stage) {
            Some((_, total)) => *total += d.as_secs_f64(),
            None => totals.push((stage, d.as_secs_f64())),
        }
    }
    let stages: Vec<String> = totals
        .iter()
        .map(|(stage, s)| format!("\"{}_s\":{s}", stage.replace(' ', "_")))
        .collect();
    stages.join(",")
}

/// `text` as a JSON string literal.
fn json_string(text: &str) -> String {
    let mut out = String::with_capacity(text.len() + 2);
    out.push('"');
    for c in text.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if c.is_control() => out.push_str(&format!("\\u{:04x}", u32::from(c))),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// `quadmesh generate`: seeded points as `x y` text, or, with `pslg` (a shape and its
/// `--segments` or `--holes`), a seeded planar straight-line graph as a `.poly` file.
fn generate(
    points: PointsArgs,
    pslg: Option<(PslgShape, Option<usize>, Option<usize>)>,
    output: &Path,
) -> Result<()> {
    let seed = points.seed;
    let input = match pslg {
        None => {
            let n = points.points.context("--points N or --pslg is required")?;
            let points = generate::points(points.dist, n, seed);
            return write_to(output, |w| write_points(w, &points));
        }
        Some((PslgShape::Nested, Some(n), None)) if n >= 16 => generate::nested_curves(n, seed),
        Some((PslgShape::Nested, Some(n), None)) => {
            anyhow::bail!("--segments: --pslg nested needs at least 16, got {n}")
        }
        Some((PslgShape::Nested, ..)) => anyhow::bail!("--pslg nested needs --segments N"),
        Some((PslgShape::Holes, None, Some(n))) => generate::block_with_holes(n, seed),
        Some((PslgShape::Holes, ..)) => anyhow::bail!("--pslg holes needs --holes N"),
    };
    write_to(output, |w| write_input_poly(&input, w))
}

/// The process's peak resident memory (Linux `VmHWM`), if the system reports it.
fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// `quadmesh tree`: read, build and write on a pool of the requested size, then report.
fn tree(
    input: &Path,
    output: &Path,
    threads: Option<NonZeroUsize>,
    options: TreeOptions,
) -> Result<()> {
    pool(threads)?.install(|| {
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

/// `tree --graph`: the graph read, cleaned and cut, its separated tree's leaves written.
fn graph_tree_leaves(
    input: &Path,
    output: &Path,
    threads: Option<NonZeroUsize>,
    max_squares: usize,
) -> Result<()> {
    pool(threads)?.install(|| {
        let context = || format!("{}", input.display());
        let (read, read_time) = timed(|| read_input(input));
        let read = read.with_context(context)?;
        let mut times = StageTimes::default();
        let (graph, _) = times
            .time("clean", || clean(&read, CleanOptions::default()))
            .with_context(context)?;
        let cut = times
            .time("cut", || cut_acute_corners(&graph))
            .with_context(context)?;
        let tree = graph_tree(
            &cut,
            GraphTreeOptions {
                max_squares: Some(max_squares),
                ..GraphTreeOptions::default()
            },
            &mut times,
        )
        .with_context(context)?;
        let (written, write_time) =
            timed(|| write_to(output, |w| write_graph_leaves_csv(w, &tree)));
        written?;
        let (bits, leaves, pieces) = match &tree {
            GraphTree::Narrow(b) => (32, b.tree.tree.leaves.len(), b.pieces.pieces.len()),
            GraphTree::Wide(b) => (64, b.tree.tree.leaves.len(), b.pieces.pieces.len()),
        };
        let counts = [
            ("input points", read.points.len().to_string()),
            ("segments", graph.segments.len().to_string()),
            ("caps", cut.caps.len().to_string()),
            (
                "cut points",
                (cut.points.len() - graph.points.len()).to_string(),
            ),
            ("graph edges", cut.edges.len().to_string()),
            ("grid bits per axis", bits.to_string()),
            ("leaves", leaves.to_string()),
            ("edge pieces", pieces.to_string()),
            ("time read", millis(read_time)),
        ];
        print_tree_report(&counts, &times, write_time);
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
    let counts = [
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
    ];
    print_tree_report(&counts, times, write);
}

/// Prints `counts`, then each stage's time and the write time, one `label value` line each, to
/// standard error.
fn print_tree_report(counts: &[(&str, String)], times: &StageTimes, write: Duration) {
    let stages = times
        .0
        .iter()
        .map(|(stage, d)| (format!("time {stage}"), millis(*d)));
    let lines = counts
        .iter()
        .map(|(label, value)| ((*label).to_owned(), value.clone()))
        .chain(stages)
        .chain([("time write".to_owned(), millis(write))]);
    let mut err = io::stderr().lock();
    for (label, value) in lines {
        let _ = writeln!(err, "{label:<24}{value}");
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
