#!/usr/bin/env python3
"""Compare quadmesh with two peer meshers, Triangle and spade, on the same generated points,
and quadmesh with Triangle on planar straight-line graphs (.poly files).

Usage (from the repository root):

    pip install triangle numpy          # once; the script installs nothing itself
    python3 scripts/compare_peers.py [--sizes 100000,1000000] [--dists uniform,cluster,kuzmin]
        [--threads 1,2] [--repeats 3] [--angles 20,30] [--domain hull|square]
        [--tools triangle,spade,quadmesh,quadmesh-compact,quadmesh-block,quadmesh-nonobtuse,
         quadmesh-nonobtuse-split,quadmesh-refine]
        [--quadmesh-args='--some-flag value'] [--timeout 600] [--out results.json] [--markdown]
    python3 scripts/compare_peers.py [--pslg FILE.poly ...] [--pslg-examples]
        [--pslg-generated [--pslg-segments 200000] [--pslg-holes 2000] [--pslg-dir DIR]]
        [--threads 1,2] [--repeats 3] [--angles 20,30] [--markdown] [--out results.json]

Options that take a value beginning with '-' need the '=' form, as in --quadmesh-args above.

What it does:

* builds the release CLI and the spade example once
  (``cargo build --release --bin quadmesh --example spade_mesh``; ``--no-build`` skips this);
  the binaries are taken from ``$CARGO_TARGET_DIR`` when it is set, ``target/`` otherwise;
* for every distribution and size, writes the points with
  ``target/release/quadmesh generate --points N --dist D --seed 1`` into a temporary directory;
* meshes one of two regions, shown in each row's ``domain`` column, and every tool of a row
  group meshes the same one:

  - ``hull``, the points' convex hull: what Triangle meshes for a bare point set, and the
    region of quadmesh's Delaunay refinement by default. Triangle gets the points alone;
  - ``square``: centred on the centre of the points' bounding box, half-side equal to the box's
    larger extent (so side twice that extent), the region of quadmesh's warped mesh. Its four
    corners are added to the points given to Triangle and spade, so that for them too the
    square is the convex hull and the mesh covers it.

  ``--domain`` (``hull`` by default) picks the region of Triangle's plain Delaunay row and of
  every refinement row (Triangle ``qA``, spade at A, quadmesh's refinement). The warped mesh
  always covers the square: with ``--domain hull`` its rows come with rows of their own for
  Triangle's and spade's Delaunay triangulations of the points and the square's corners; with
  ``--domain square`` every row is on the square. spade's example ``spade_mesh`` takes
  ``--hull`` for the points alone (their convex hull) and ``--corners`` for the square;
* Triangle, through the ``triangle`` Python package, in a fresh Python process per run:
  switches ``Q`` (plain Delaunay triangulation) and ``q<A>Q`` for every angle A of ``--angles``
  (quality refinement, no angle below A degrees). Only the ``triangle.triangulate`` call is
  timed; it includes the package's copying of the input and output arrays. Above about 34
  degrees Triangle's refinement does not finish: it grows until the timeout or the system kills
  it (shown as "killed by SIGKILL (out of memory?)"). Its peak memory is the child's
  ``ru_maxrss`` taken right after that call, so it includes the Python interpreter, numpy and
  the numpy arrays of the input points (the raw results also give
  ``peak_rss_before_mesh_bytes``, the child's high-water mark just before the call);
* spade, through ``target/release/examples/spade_mesh --corners X0,Y0,X1,Y1`` (one process per
  run): plain Delaunay (bulk load) and ``--min-angle A`` for every angle A. Its time is the bulk
  load and refinement, not reading the file; its peak memory is the process's high-water mark,
  which includes the points as read (``peak_rss_before_mesh_bytes`` in the raw results is the
  mark after reading). The example uses mimalloc, as the quadmesh CLI does;
* quadmesh's warped quadtree mesh (tool ``quadmesh``), through ``target/release/quadmesh bench
  --points N --dist D --seed 1 --threads T --json --warp --domain square`` plus
  ``--quadmesh-args``, once per thread count of ``--threads``. It generates the same points in
  memory and prints one JSON object as its last line of output; its time is that object's
  ``total_s``. If the subcommand is missing or fails, quadmesh rows say so and the other tools
  still run;
* quadmesh's compact warp before coarsening (tool ``quadmesh-compact``), block warp (tool
  ``quadmesh-block``), nonobtuse mesh (tool ``quadmesh-nonobtuse``) and nonobtuse split before
  coarsening (tool ``quadmesh-nonobtuse-split``): the same command with ``--compact-warp``,
  ``--block-warp``, ``--nonobtuse`` or ``--nonobtuse-split`` in place of ``--warp``;
* quadmesh's quality Delaunay mesh (tool ``quadmesh-refine``, the CLI's default mode): the same
  command without ``--warp``, with ``--domain hull`` or ``--domain square`` (as ``--domain``
  says) and ``--min-angle A`` for every angle A of ``--angles`` and every thread count of
  ``--threads`` (``--quadmesh-args`` too). Above 20.7 degrees quadmesh warns on standard error
  that termination is not proven; the warning is kept in the raw results (``stderr``). If this
  quadmesh lacks an option these rows need, they say so.

Triangle and spade are sequential and run once per size and distribution, whatever ``--threads``
says.

Each run is repeated ``--repeats`` times; the tables give the median time and the largest peak
memory. Rows come in groups: the unrefined meshes (Triangle ``Q``, spade's Delaunay, quadmesh's
warped mesh; with ``--domain hull``, Triangle ``Q`` on the hull, then Triangle ``Q`` and spade
on the square beside the warp), then for each angle A Triangle ``qA``, spade at A and
quadmesh's refinement at A.
Columns: tool and mode, threads, domain, time (s, median), time relative to Triangle on the same
domain at the same angle (``qA`` for refinement rows, plain ``Q`` for the others), output
triangles per input point, triangles relative to that same Triangle row, smallest and largest
angle of the output (degrees), peak resident memory (MB, 10^6 bytes) and peak memory per output
triangle (bytes). A spade row marked "incomplete" ran out of its vertex allowance before meeting
the angle; a refinement row marked "below the bound" has a smaller angle than it was asked for
(on the hull that is also what a corner of the hull narrower than the bound gives: neither
Triangle nor quadmesh changes the angles of the input's boundary).

Below each table, for every angle A of ``--angles``, a line compares quadmesh's refinement at A
on the largest thread count of ``--threads`` with Triangle ``qA``: the ratio of their times and
their triangles per point (with its ratio). A last line checks quadmesh's target at 30 degrees
on 2 threads: time at most 0.25 times Triangle ``q30``'s and no more triangles per point than
Triangle ``q30``.

Every subprocess has a timeout (``--timeout``, 600 s by default); failures and timeouts are
shown in the tables and never stop the script. A configuration that timed out is skipped for
larger sizes of the same distribution (spade at 33 degrees, say, which may not finish at
10^6 points). ``--markdown`` prints GitHub markdown tables; ``--out FILE`` writes every raw run
as JSON, with the machine's description.

Triangle and spade see the points only after they were written as text and read back; the
``x y`` text that ``quadmesh generate`` writes reads back to the same doubles, so all three
tools mesh exactly the same points.

Planar straight-line graphs. Any of ``--pslg FILE ...`` (Triangle ``.poly`` files),
``--pslg-examples`` (Triangle's examples A, face, la, double_hex and square_circle_hole from the
``triangle`` package's data directory) and ``--pslg-generated`` (nested wavy rings with
``--pslg-segments`` segments and a block with ``--pslg-holes`` rectangular holes, written by
``quadmesh generate --pslg nested|holes --seed 1`` into ``--pslg-dir`` or a temporary
directory) runs this comparison instead of the point sets. For every file and every angle A of
``--angles``:

* Triangle, through the ``triangle`` package in a fresh Python process per run, on the file as
  Triangle reads it (a region line with one value after its seed takes it as both attribute and
  area bound), with switches ``pq<A>``, plus ``a`` when a region bounds the area of its
  triangles (quadmesh applies regional bounds always), plus ``A`` when there are regions
  (quadmesh always gives their triangles the attribute), plus ``Q``. Only the ``triangulate``
  call is timed; its peak memory is the child's ``ru_maxrss`` after it, interpreter and arrays
  included;
* quadmesh: ``quadmesh bench --input FILE --min-angle A --threads T --json`` for every T of
  ``--threads`` (plus ``--quadmesh-args``); its time is ``total_s`` (meshing, not reading the
  file), its peak memory the process's high-water mark, the file as read included. With
  ``--quadmesh-args=--warp`` it is the warp mode's mesh, which takes no angle, set beside
  Triangle's ``pq<A>``.

The runs alternate, Triangle then quadmesh on each thread count, ``--repeats`` rounds. One table
follows, a row per file, angle and thread count: triangles of each and their ratio
(quadmesh / Triangle), median times and their ratio, smallest angles (a corner of the input
narrower than A stays as it is in both) and peak memory per output triangle.
"""

import argparse
import json
import os
import platform
import re
import shlex
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
# Cargo's target directory: $CARGO_TARGET_DIR (relative to the repository root) if set.
TARGET = REPO / os.environ.get("CARGO_TARGET_DIR", "target")
QUADMESH = TARGET / "release" / "quadmesh"
SPADE = TARGET / "release" / "examples" / "spade_mesh"

CHILD_MARK = "__triangle_child__"

# The --tools names.
TOOLS = ("triangle", "spade", "quadmesh", "quadmesh-compact", "quadmesh-block",
         "quadmesh-nonobtuse", "quadmesh-nonobtuse-split", "quadmesh-refine")
QUADTREE_MODES = {"quadmesh": "warp", "quadmesh-compact": "compact-warp",
                  "quadmesh-block": "block-warp", "quadmesh-nonobtuse": "nonobtuse",
                  "quadmesh-nonobtuse-split": "nonobtuse-split"}

# The --domain choices: the points' convex hull, or the square the warped mesh covers.
DOMAINS = ("hull", "square")

# The issue's target for quadmesh's refinement: at this angle and thread count, at most this
# fraction of Triangle's time and no more triangles per point than Triangle.
TARGET_ANGLE = 30.0
TARGET_THREADS = 2
TARGET_TIME_RATIO = 0.25


# --------------------------------------------------------------------------------------------
# Shared by the parent and the Triangle child.


def angle_range(vertices, triangles):
    """Smallest and largest angle, in degrees, over the given triangles (numpy arrays)."""
    import numpy as np

    if len(triangles) == 0:
        return None, None
    corners = [vertices[triangles[:, k]] for k in range(3)]
    lo, hi = np.inf, -np.inf
    for k in range(3):
        a, b, c = corners[k], corners[(k + 1) % 3], corners[(k + 2) % 3]
        u = b - a
        v = c - a
        cross = np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0])
        dot = u[:, 0] * v[:, 0] + u[:, 1] * v[:, 1]
        angle = np.degrees(np.arctan2(cross, dot))
        lo = min(lo, float(angle.min()))
        hi = max(hi, float(angle.max()))
    return lo, hi


def triangle_child(points_npy, switches, added):
    """Runs in a fresh interpreter: mesh with Triangle and print one JSON line. The last
    `added` vertices of the file are the square's corners, not input points."""
    import resource

    import numpy as np
    import triangle

    vertices = np.load(points_npy)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    start = time.perf_counter()
    out = triangle.triangulate({"vertices": vertices}, switches)
    elapsed = time.perf_counter() - start
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    tris = out.get("triangles", np.zeros((0, 3), dtype=np.int32))
    verts = out["vertices"]
    lo, hi = angle_range(verts, tris)
    print(
        json.dumps(
            {
                "tool": "triangle",
                "switches": switches,
                "points": int(len(vertices)) - int(added),
                "time_s": elapsed,
                "vertices": int(len(verts)),
                "triangles": int(len(tris)),
                "min_angle": lo,
                "max_angle": hi,
                "peak_rss_bytes": peak,
                "peak_rss_before_mesh_bytes": before,
            }
        )
    )


# --------------------------------------------------------------------------------------------
# The parent.


def log(message):
    print(message, file=sys.stderr, flush=True)


def int_list(text):
    try:
        values = [int(float(v)) for v in text.split(",") if v.strip()]
    except ValueError as e:
        raise argparse.ArgumentTypeError(f"expected comma-separated integers: {text!r}") from e
    if not values or any(v <= 0 for v in values):
        raise argparse.ArgumentTypeError(f"expected positive integers: {text!r}")
    return values


def float_list(text):
    try:
        return [float(v) for v in text.split(",") if v.strip()]
    except ValueError as e:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers: {text!r}") from e


def str_list(text):
    return [v.strip() for v in text.split(",") if v.strip()]


def parse_args():
    cores = os.cpu_count() or 1
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--sizes", type=int_list, default=[100_000, 1_000_000],
                        help="point counts, comma-separated (default 100000,1000000)")
    parser.add_argument("--dists", type=str_list, default=["uniform", "cluster", "kuzmin"],
                        help="distributions of `quadmesh generate` (default uniform,cluster,kuzmin)")
    parser.add_argument("--threads", type=int_list, default=sorted({1, cores}),
                        help=f"quadmesh thread counts (default 1,{cores})")
    parser.add_argument("--repeats", type=int, default=3, help="runs of each configuration")
    parser.add_argument("--angles", type=float_list, default=[20.0, 30.0],
                        help="minimum angles for Triangle's, spade's and quadmesh's refinement "
                             "(default 20,30)")
    parser.add_argument("--domain", choices=DOMAINS, default="hull",
                        help="region of the refinement rows: the points' convex hull (default; "
                             "spade's refinement is then left out) or the square around them; "
                             "the warped mesh's rows always use the square")
    parser.add_argument("--tools", type=str_list, default=list(TOOLS),
                        help=f"which tools to run (default {','.join(TOOLS)}; quadmesh is the "
                             f"warped mesh, quadmesh-compact it before coarsening, "
                             f"quadmesh-block the block warp, quadmesh-nonobtuse "
                             f"the nonobtuse quadtree mesh, quadmesh-nonobtuse-split it "
                             f"before coarsening, "
                             f"quadmesh-refine the Delaunay refinement)")
    parser.add_argument("--quadmesh-args", default="",
                        help="extra arguments for `quadmesh bench`, one shell-quoted string; "
                             "use the --quadmesh-args='...' form")
    parser.add_argument("--timeout", type=float, default=600.0,
                        help="seconds allowed to each subprocess (default 600)")
    parser.add_argument("--out", type=Path, help="write all raw results to this JSON file")
    parser.add_argument("--markdown", action="store_true", help="print GitHub markdown tables")
    parser.add_argument("--no-build", action="store_true", help="do not run cargo build")
    pslg = parser.add_argument_group(
        "planar straight-line graphs", "any of these compares quality meshes of .poly files "
        "instead of point sets (--angles, --threads, --repeats, --timeout, --quadmesh-args, "
        "--out and --markdown apply)")
    pslg.add_argument("--pslg", nargs="+", type=Path, default=[], metavar="FILE",
                      help="Triangle .poly files")
    pslg.add_argument("--pslg-examples", action="store_true",
                      help=f"Triangle's examples {', '.join(PSLG_EXAMPLES)} from the triangle "
                           f"package's data directory")
    pslg.add_argument("--pslg-generated", action="store_true",
                      help="nested rings and a block with holes from `quadmesh generate --pslg`")
    pslg.add_argument("--pslg-segments", type=int, default=200_000, metavar="N",
                      help="segments of the generated nested rings (default 200000)")
    pslg.add_argument("--pslg-holes", type=int, default=2_000, metavar="N",
                      help="holes of the generated block (default 2000)")
    pslg.add_argument("--pslg-dir", type=Path, metavar="DIR",
                      help="keep the generated .poly files in DIR (default: a temporary "
                           "directory)")
    args = parser.parse_args()
    args.pslg_mode = bool(args.pslg or args.pslg_examples or args.pslg_generated)
    if args.pslg_mode and args.pslg_segments < 16:
        parser.error("--pslg-segments must be at least 16")
    if args.repeats < 1:
        parser.error("--repeats must be at least 1")
    unknown = set(args.tools) - set(TOOLS)
    if unknown:
        parser.error(f"unknown tools: {', '.join(sorted(unknown))}")
    if any(not 0.0 < a < 60.0 for a in args.angles):
        parser.error("--angles must lie strictly between 0 and 60 degrees")
    return args


def machine():
    model = None
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    model = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return {
        "cpu": model or platform.processor(),
        "logical_cpus": os.cpu_count(),
        "platform": platform.platform(),
        "python": platform.python_version(),
    }


def tail(text, limit=400):
    text = (text or "").strip()
    return text if len(text) <= limit else "..." + text[-limit:]


def run_json(command, timeout):
    """Runs `command`; returns (record, None) from its last stdout line, or (None, error)."""
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return None, f"timeout after {timeout:g} s"
    except OSError as e:
        return None, f"could not start: {e}"
    if done.returncode < 0:
        try:
            name = signal.Signals(-done.returncode).name
        except ValueError:
            name = f"signal {-done.returncode}"
        hint = " (out of memory?)" if name == "SIGKILL" else ""
        return None, f"killed by {name}{hint}: {tail(done.stderr or done.stdout)}"
    if done.returncode != 0:
        # The error lines alone, when the tool marks them (quadmesh prints warnings first).
        errors = [line for line in (done.stderr or "").splitlines() if line.startswith("error")]
        text = "\n".join(errors) if errors else (done.stderr or done.stdout)
        return None, f"exit status {done.returncode}: {tail(text)}"
    lines = [line for line in done.stdout.splitlines() if line.strip()]
    if not lines:
        return None, f"no output; stderr: {tail(done.stderr)}"
    try:
        record = json.loads(lines[-1])
    except json.JSONDecodeError:
        return None, f"last output line is not JSON: {tail(lines[-1])}"
    if not isinstance(record, dict):
        return None, f"last output line is not a JSON object: {tail(lines[-1])}"
    if done.stderr.strip():
        record["stderr"] = tail(done.stderr)
    return record, None


def angle_text(angle):
    return f"{angle:g}"


class Config:
    """One row of a table: a tool, a mode, a thread count, a domain and the command that runs it.

    `selector` is the --tools name that asked for it; `angle` the minimum angle of a
    refinement, None for an unrefined mesh (Triangle Q, spade's Delaunay, quadmesh's warp);
    `domain` the region meshed, "hull" or "square"."""

    def __init__(self, tool, mode, threads, command, time_key="time_s", selector=None,
                 angle=None, domain="square"):
        self.tool = tool
        self.mode = mode
        self.threads = threads
        self.command = command
        self.time_key = time_key
        self.selector = selector or tool
        self.angle = angle
        self.domain = domain


def configs_for(args, dist, size, points_txt, npy, corners):
    """The rows of one table: the unrefined meshes first, then one group per angle, each with
    Triangle, spade and quadmesh side by side. `npy` maps a domain to Triangle's input file
    and the number of corners added to its points."""

    def child(domain, switches):
        path, added = npy[domain]
        return [sys.executable, str(Path(__file__).resolve()), CHILD_MARK, str(path), switches,
                str(added)]

    spade = [str(SPADE), str(points_txt), "--corners=" + ",".join(repr(c) for c in corners)]
    # spade on the points alone meshes their convex hull.
    spade_on = {"square": spade, "hull": [str(SPADE), str(points_txt), "--hull"]}
    extra = shlex.split(args.quadmesh_args)
    suffix = f" {args.quadmesh_args}" if extra else ""
    domain = args.domain

    def bench(t, more):
        return ([str(QUADMESH), "bench", "--points", str(size), "--dist", dist, "--seed", "1",
                 "--threads", str(t), "--json"] + more + extra)

    configs = []
    # Plain Delaunay on the refinement's domain, the reference of the table's first group.
    if "triangle" in args.tools:
        configs.append(Config("Triangle", "Delaunay", 1, child(domain, "Q"),
                              selector="triangle", domain=domain))
    if "spade" in args.tools:
        configs.append(Config("spade", "Delaunay", 1, spade_on[domain], selector="spade",
                              domain=domain))
    quadtree = [tool for tool in QUADTREE_MODES if tool in args.tools]
    if quadtree:
        # The quadtree meshes cover the square: on the hull, their peers get their own rows on
        # the square.
        if domain != "square":
            if "triangle" in args.tools:
                configs.append(Config("Triangle", "Delaunay", 1, child("square", "Q"),
                                      selector="triangle", domain="square"))
            if "spade" in args.tools:
                configs.append(Config("spade", "Delaunay", 1, spade, selector="spade",
                                      domain="square"))
        for tool in quadtree:
            mode = QUADTREE_MODES[tool]
            for t in args.threads:
                configs.append(Config("quadmesh", mode + suffix, t,
                                      bench(t, [f"--{mode}", "--domain", "square"]),
                                      time_key="total_s", selector=tool, domain="square"))
    for a in args.angles:
        if "triangle" in args.tools:
            configs.append(Config("Triangle", f"q{angle_text(a)}", 1,
                                  child(domain, f"q{a:g}Q"), selector="triangle", angle=a,
                                  domain=domain))
        if "spade" in args.tools:
            configs.append(Config("spade", f"refine {angle_text(a)}°", 1,
                                  spade_on[domain] + ["--min-angle", f"{a:g}"], selector="spade",
                                  angle=a, domain=domain))
        if "quadmesh-refine" in args.tools:
            for t in args.threads:
                configs.append(Config("quadmesh", f"refine {angle_text(a)}°{suffix}", t,
                                      bench(t, ["--domain", domain, "--min-angle", f"{a:g}"]),
                                      time_key="total_s", selector="quadmesh-refine", angle=a,
                                      domain=domain))
    return configs


def summarize(runs, time_key):
    """Median time, largest peak memory and the output figures of the last run."""
    times = [r[time_key] for r in runs if isinstance(r.get(time_key), (int, float))]
    peaks = [r["peak_rss_bytes"] for r in runs if isinstance(r.get("peak_rss_bytes"), int)]
    last = runs[-1]
    return {
        "median_time_s": statistics.median(times) if times else None,
        "max_peak_rss_bytes": max(peaks) if peaks else None,
        "vertices": last.get("vertices"),
        "triangles": last.get("triangles"),
        "min_angle": last.get("min_angle"),
        "max_angle": last.get("max_angle"),
        "refinement_complete": last.get("refinement_complete"),
    }


def measure(config, repeats, timeout, skip_note):
    """Runs one configuration `repeats` times; stops at the first failure."""
    result = {"tool": config.tool, "mode": config.mode, "threads": config.threads,
              "angle": config.angle, "domain": config.domain, "selector": config.selector,
              "command": config.command, "runs": [], "error": None}
    if skip_note:
        result["error"] = skip_note
        return result
    for i in range(repeats):
        log(f"  {config.tool} {config.mode} threads={config.threads} {config.domain} "
            f"run {i + 1}/{repeats}")
        record, error = run_json(config.command, timeout)
        if error is None and not isinstance(record.get(config.time_key), (int, float)):
            error = f"output has no numeric {config.time_key!r}: {tail(json.dumps(record))}"
        if error is not None:
            log(f"    failed: {error}")
            result["error"] = error
            break
        result["runs"].append(record)
    if result["runs"]:
        result.update(summarize(result["runs"], config.time_key))
    return result


def square_of(points):
    """Corners (x0, y0, x1, y1) of the square quadmesh meshes around `points`."""
    lo = points.min(axis=0)
    hi = points.max(axis=0)
    centre = (lo + hi) / 2.0
    half = float(max(hi - lo))
    if half <= 0.0:
        half = 1.0
    return (float(centre[0] - half), float(centre[1] - half),
            float(centre[0] + half), float(centre[1] + half))


HEADER = ["tool / mode", "threads", "domain", "time s (median)", "vs Triangle", "triangles/point",
          "triangles vs Triangle", "min angle", "max angle", "peak MB", "bytes/triangle"]


def ratio_of(value, base):
    if isinstance(value, (int, float)) and isinstance(base, (int, float)) and base > 0:
        return value / base
    return None


def format_row(result, size, baseline):
    """One table row; `baseline` is Triangle's result on the row's domain at its angle, or
    None."""
    name = f"{result['tool']} {result['mode']}"
    if not result["runs"]:
        error = " ".join(result["error"].split())
        status = error if error.startswith("skipped") else "failed: " + error
        return ([name, str(result["threads"]), result["domain"], status]
                + [""] * (len(HEADER) - 4))
    t = result["median_time_s"]
    tris = result["triangles"]
    peak = result["max_peak_rss_bytes"]

    def num(value, fmt):
        return format(value, fmt) if isinstance(value, (int, float)) else "-"

    base_time = baseline["median_time_s"] if baseline else None
    base_tris = baseline["triangles"] if baseline else None
    cells = [
        name,
        str(result["threads"]),
        result["domain"],
        num(t, ".3f"),
        num(ratio_of(t, base_time), ".2f"),
        num(tris / size if isinstance(tris, int) else None, ".3f"),
        num(ratio_of(tris, base_tris), ".2f"),
        num(result["min_angle"], ".2f"),
        num(result["max_angle"], ".2f"),
        num(peak / 1e6 if peak is not None else None, ".1f"),
        num(peak / tris if peak is not None and tris else None, ".0f"),
    ]
    if result.get("refinement_complete") is False:
        cells[0] += " (incomplete)"
    elif (result.get("angle") is not None and isinstance(result["min_angle"], (int, float))
          and result["min_angle"] < result["angle"] - 1e-6):
        cells[0] += " (below the bound)"
    if result["error"]:
        cells[0] += f" (then failed: {' '.join(result['error'].split())})"
    return cells


def triangle_baselines(results):
    """Triangle's successful results by (domain, angle), angle None for plain Delaunay."""
    return {(r["domain"], r["angle"]): r for r in results if r["tool"] == "Triangle" and r["runs"]}


def versus_triangle(size, results, angle, threads):
    """quadmesh's refinement at `angle` on `threads` threads and Triangle q`angle` on the same
    domain: (time ratio, quadmesh's triangles per point, Triangle's), or None."""
    ours = [r for r in results if r["selector"] == "quadmesh-refine" and r["runs"]
            and r["angle"] == angle and r["threads"] == threads]
    if not ours:
        return None
    ours = ours[0]
    base = triangle_baselines(results).get((ours["domain"], angle))
    if base is None:
        return None
    time_ratio = ratio_of(ours["median_time_s"], base["median_time_s"])
    ours_tpp = ours["triangles"] / size if isinstance(ours["triangles"], int) else None
    base_tpp = base["triangles"] / size if isinstance(base["triangles"], int) else None
    if time_ratio is None or ours_tpp is None or base_tpp is None:
        return None
    return time_ratio, ours_tpp, base_tpp


def target_verdict(time_ratio, ours_tpp, base_tpp):
    """Whether quadmesh's refinement meets the target, in words."""
    time_ok = time_ratio <= TARGET_TIME_RATIO
    tris_ok = ours_tpp <= base_tpp
    return (f"target (time <= {TARGET_TIME_RATIO:g}x, no more triangles/point): time "
            f"{'met' if time_ok else 'NOT met'}, triangles {'met' if tris_ok else 'NOT met'}")


def check_lines(size, results, angles, threads):
    """Below a table: quadmesh's refinement against Triangle at every angle on the largest
    thread count, and the target at TARGET_ANGLE on TARGET_THREADS threads (on the line of
    that angle when the largest thread count is TARGET_THREADS, on a line of its own
    otherwise)."""
    lines = []
    target_done = False
    for angle in angles:
        found = versus_triangle(size, results, angle, threads)
        if found is None:
            continue
        time_ratio, ours_tpp, base_tpp = found
        a = angle_text(angle)
        line = (f"quadmesh refine {a}° on {threads} threads vs Triangle q{a}: "
                f"time {time_ratio:.2f}x, triangles/point {ours_tpp:.3f} vs {base_tpp:.3f} "
                f"({ours_tpp / base_tpp:.2f}x)")
        if angle == TARGET_ANGLE and threads == TARGET_THREADS:
            line += "; " + target_verdict(*found)
            target_done = True
        lines.append(line)
    found = versus_triangle(size, results, TARGET_ANGLE, TARGET_THREADS)
    if found is not None and not target_done:
        time_ratio, ours_tpp, base_tpp = found
        a = angle_text(TARGET_ANGLE)
        lines.append(f"quadmesh refine {a}° on {TARGET_THREADS} threads vs Triangle q{a}: "
                     f"time {time_ratio:.2f}x, triangles/point {ours_tpp:.3f} vs "
                     f"{base_tpp:.3f}; " + target_verdict(*found))
    return lines


# Columns aligned left (the others are numbers, aligned right), and the time column, which holds
# the whole message of a failed row.
LEFT_COLUMNS = (0, 2)
TIME_COLUMN = 3


def print_table(dist, size, results, markdown, angles, threads):
    baselines = triangle_baselines(results)
    rows = [format_row(r, size, baselines.get((r["domain"], r["angle"]))) for r in results]
    title = f"{dist}, {size:,} points"
    if markdown:
        print(f"\n#### {title}\n")
        print("| " + " | ".join(HEADER) + " |")
        print("|" + "|".join("---" if i in LEFT_COLUMNS else "---:"
                             for i in range(len(HEADER))) + "|")
        for row in rows:
            print("| " + " | ".join(cell.replace("|", "\\|") for cell in row) + " |")
    else:
        print(f"\n{title}")
        widths = [max([len(HEADER[i])] + [len(row[i]) for row in rows if row[i] != ""])
                  if i != TIME_COLUMN else len(HEADER[i]) for i in range(len(HEADER))]

        def line(cells):
            return "  ".join(c.ljust(widths[i]) if i in LEFT_COLUMNS else c.rjust(widths[i])
                             for i, c in enumerate(cells)).rstrip()

        print(line(HEADER))
        for row in rows:
            if row[TIME_COLUMN + 1] == "" and row[TIME_COLUMN] != "":
                print(line(row[:TIME_COLUMN]) + "  " + row[TIME_COLUMN])
            else:
                print(line(row))
    checks = check_lines(size, results, angles, threads)
    if checks:
        print()
        for check in checks:
            print(f"- {check}" if markdown else check)
    sys.stdout.flush()


# --------------------------------------------------------------------------------------------
# Planar straight-line graphs (--pslg, --pslg-examples, --pslg-generated).

PSLG_CHILD_MARK = "__triangle_pslg_child__"

# Triangle's example .poly files (from the `triangle` package's data directory) of
# --pslg-examples.
PSLG_EXAMPLES = ("A", "face", "la", "double_hex", "square_circle_hole")


def poly_lines(path):
    """The significant lines of a Triangle file, as lists of fields ('#' starts a comment)."""
    with open(path) as f:
        for line in f:
            fields = line.split("#", 1)[0].split()
            if fields:
                yield fields


def read_poly(path):
    """A Triangle .poly file as the `triangle` package's input dictionary, read the way
    Triangle reads it: indices in the base of the first vertex, the vertices in the .node file
    of the same name when the header declares none, and a region line with one value after its
    seed taking it as both attribute and area bound. Regions are [x, y, attribute, area]."""
    import numpy as np

    lines = poly_lines(path)
    header = next(lines)
    count = int(header[0])
    source = lines
    if count == 0:
        source = poly_lines(Path(path).with_suffix(".node"))
        count = int(next(source)[0])
    rows = [next(source) for _ in range(count)]
    base = int(rows[0][0]) if rows else 0
    data = {"vertices": np.array([[float(r[1]), float(r[2])] for r in rows], dtype=np.float64)}
    head = next(lines)
    rows = [next(lines) for _ in range(int(head[0]))]
    data["segments"] = np.array([[int(r[1]) - base, int(r[2]) - base] for r in rows],
                                dtype=np.int32).reshape(-1, 2)
    if len(head) > 1 and int(head[1]) > 0:
        data["segment_markers"] = np.array([int(r[3]) if len(r) > 3 else 0 for r in rows],
                                           dtype=np.int32).reshape(-1, 1)
    rows = [next(lines) for _ in range(int(next(lines)[0]))]
    if rows:
        data["holes"] = np.array([[float(r[1]), float(r[2])] for r in rows], dtype=np.float64)
    head = next(lines, None)
    rows = [next(lines) for _ in range(int(head[0]))] if head else []
    if rows:
        data["regions"] = np.array(
            [[float(r[1]), float(r[2]), float(r[3]), float(r[4] if len(r) > 4 else r[3])]
             for r in rows], dtype=np.float64)
    return data


def triangle_switches(data, angle):
    """Triangle's switches for a quality mesh of the graph `data` at `angle`: `pq<A>`, `a` when
    a region bounds its triangles' area (quadmesh applies regional bounds always), `A` when
    there are regions (quadmesh always gives their triangles the attribute), `Q`."""
    regions = data.get("regions")
    has_regions = regions is not None and len(regions) > 0
    bounded = has_regions and bool((regions[:, 3] > 0).any())
    return f"pq{angle:g}" + ("a" if bounded else "") + ("A" if has_regions else "") + "Q"


def triangle_pslg_child(poly, switches):
    """Runs in a fresh interpreter: mesh the .poly file with Triangle and print one JSON line.
    Only the triangulate call is timed."""
    import resource

    import numpy as np
    import triangle

    data = read_poly(poly)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    start = time.perf_counter()
    out = triangle.triangulate(data, switches)
    elapsed = time.perf_counter() - start
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    tris = out.get("triangles", np.zeros((0, 3), dtype=np.int32))
    verts = out["vertices"]
    lo, hi = angle_range(verts, tris)
    print(json.dumps({"tool": "triangle", "switches": switches, "time_s": elapsed,
                      "vertices": int(len(verts)), "triangles": int(len(tris)),
                      "min_angle": lo, "max_angle": hi, "peak_rss_bytes": peak,
                      "peak_rss_before_mesh_bytes": before}))


def pslg_inputs(args, directory):
    """(name, path) of every graph asked for; generated ones are written to `directory`."""
    inputs = [(Path(p).stem, Path(p)) for p in args.pslg]
    if args.pslg_examples:
        import triangle

        data = Path(triangle.__file__).resolve().parent / "data"
        inputs += [(name, data / f"{name}.poly") for name in PSLG_EXAMPLES]
    if args.pslg_generated:
        generated = [(f"nested-{args.pslg_segments}", ["--pslg", "nested", "--segments",
                                                      str(args.pslg_segments)]),
                     (f"holes-{args.pslg_holes}", ["--pslg", "holes", "--holes",
                                                   str(args.pslg_holes)])]
        for name, how in generated:
            path = directory / f"{name}.poly"
            log(f"generating {path}")
            subprocess.run([str(QUADMESH), "generate"] + how + ["--seed", "1", "-o", str(path)],
                           check=True, timeout=args.timeout)
            inputs.append((name, path))
    return inputs


def pslg_runs(args, path, angle, switches):
    """Triangle and quadmesh on each thread count, alternating, `--repeats` rounds; each run
    list stops at its first failure. Returns {label: (runs, error)}."""
    extra = shlex.split(args.quadmesh_args)
    commands = {"Triangle": [sys.executable, str(Path(__file__).resolve()), PSLG_CHILD_MARK,
                             str(path), switches]}
    for t in args.threads:
        # The warp mode takes no angle: it is compared as it is with Triangle's pq<A>.
        angle_args = [] if "--warp" in extra else ["--min-angle", f"{angle:g}"]
        commands[t] = ([str(QUADMESH), "bench", "--input", str(path)] + angle_args
                       + ["--threads", str(t), "--json"] + extra)
    results = {label: ([], None) for label in commands}
    for i in range(args.repeats):
        for label, command in commands.items():
            runs, error = results[label]
            if error is not None:
                continue
            log(f"  {path.name} q{angle:g} {label if label == 'Triangle' else f'quadmesh {label}T'}"
                f" run {i + 1}/{args.repeats}")
            record, error = run_json(command, args.timeout)
            if error is None:
                runs.append(record)
            else:
                log(f"    failed: {error}")
            results[label] = (runs, error)
    return results


def pslg_summary(runs, error, time_key):
    if not runs:
        return {"error": error}
    summary = summarize(runs, time_key)
    summary["error"] = error
    return summary


def pslg_rows(args, name, path):
    """One row per angle and quadmesh thread count."""
    data = read_poly(path)
    rows = []
    for angle in args.angles:
        switches = triangle_switches(data, angle)
        results = pslg_runs(args, path, angle, switches)
        base = pslg_summary(*results.pop("Triangle"), "time_s")
        for t, (runs, error) in results.items():
            rows.append({"input": name, "path": str(path), "segments": int(len(data["segments"])),
                         "angle": angle, "threads": t, "switches": switches, "triangle": base,
                         "quadmesh": pslg_summary(runs, error, "total_s")})
    return rows


PSLG_HEADER = ["input", "segments", "angle", "quadmesh threads", "Triangle switches",
               "triangles Triangle", "triangles quadmesh", "ratio", "time Triangle s",
               "time quadmesh s", "ratio", "min angle Triangle / quadmesh",
               "bytes/triangle Triangle / quadmesh"]


def pslg_cells(row):
    base, ours = row["triangle"], row["quadmesh"]

    def num(value, fmt):
        return format(value, fmt) if isinstance(value, (int, float)) else "-"

    def per_triangle(summary):
        peak, tris = summary.get("max_peak_rss_bytes"), summary.get("triangles")
        return peak / tris if isinstance(peak, int) and tris else None

    def failed(summary):
        return "failed: " + " ".join(summary["error"].split()) if summary.get("error") else ""

    cells = [row["input"], f"{row['segments']:,}", f"{row['angle']:g}", str(row["threads"]),
             row["switches"],
             num(base.get("triangles"), ",") + (f" ({failed(base)})" if failed(base) else ""),
             num(ours.get("triangles"), ",") + (f" ({failed(ours)})" if failed(ours) else ""),
             num(ratio_of(ours.get("triangles"), base.get("triangles")), ".2f"),
             num(base.get("median_time_s"), ".4f"), num(ours.get("median_time_s"), ".4f"),
             num(ratio_of(ours.get("median_time_s"), base.get("median_time_s")), ".2f"),
             f"{num(base.get('min_angle'), '.2f')} / {num(ours.get('min_angle'), '.2f')}",
             f"{num(per_triangle(base), '.0f')} / {num(per_triangle(ours), '.0f')}"]
    return cells


def print_pslg_table(rows, markdown):
    cells = [pslg_cells(r) for r in rows]
    if markdown:
        print("| " + " | ".join(PSLG_HEADER) + " |")
        print("|" + "|".join("---" if i in (0, 4) else "---:"
                             for i in range(len(PSLG_HEADER))) + "|")
        for row in cells:
            print("| " + " | ".join(c.replace("|", "\\|") for c in row) + " |")
    else:
        widths = [max(len(c) for c in column) for column in zip(PSLG_HEADER, *cells)]
        for row in [PSLG_HEADER] + cells:
            print("  ".join(c.ljust(w) if i in (0, 4) else c.rjust(w)
                            for i, (c, w) in enumerate(zip(row, widths))).rstrip())
    sys.stdout.flush()


def as_json(value):
    """An argument as JSON takes it: paths, alone or in a list, as strings."""
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, list):
        return [as_json(v) for v in value]
    return value


def main_pslg(args):
    """The PSLG comparison: one table, written at the end."""
    everything = {"machine": machine(), "arguments": {k: as_json(v) for k, v in vars(args).items()},
                  "pslg": []}
    with tempfile.TemporaryDirectory(prefix="compare-peers-pslg-") as tmp:
        directory = args.pslg_dir or Path(tmp)
        directory.mkdir(parents=True, exist_ok=True)
        for name, path in pslg_inputs(args, directory):
            log(f"{name}: {path}")
            everything["pslg"] += pslg_rows(args, name, path)
            if args.out:
                args.out.write_text(json.dumps(everything, indent=1) + "\n")
    print_pslg_table(everything["pslg"], args.markdown)
    if args.out:
        log(f"raw results written to {args.out}")


def main():
    args = parse_args()
    if "triangle" in args.tools:
        try:
            import numpy  # noqa: F401
            import triangle  # noqa: F401
        except ImportError as e:
            sys.exit(f"compare_peers: cannot import {e.name!r}; install it with "
                     f"`pip install triangle numpy` (or leave Triangle out with --tools)")
    import numpy as np

    if not args.no_build:
        targets = ["--bin", "quadmesh"] + ([] if args.pslg_mode else ["--example", "spade_mesh"])
        log(f"building: cargo build --release {' '.join(targets)}")
        build = subprocess.run(["cargo", "build", "--release"] + targets, cwd=REPO)
        if build.returncode != 0:
            sys.exit("compare_peers: cargo build failed")
    if args.pslg_mode:
        if not QUADMESH.exists():
            sys.exit(f"compare_peers: {QUADMESH} is missing; build it or drop --no-build")
        main_pslg(args)
        return
    needed = [QUADMESH] + ([SPADE] if "spade" in args.tools else [])
    for binary in needed:
        if not binary.exists():
            sys.exit(f"compare_peers: {binary} is missing; build it or drop --no-build")

    everything = {"machine": machine(), "arguments": {k: (str(v) if isinstance(v, Path) else v)
                                                      for k, v in vars(args).items()},
                  "tables": []}
    # Notes that skip every later row of a --tools name: quadmesh without `bench`, or without
    # `--min-angle` for its refinement.
    skips = {}
    # Sizes at which a row (distribution, tool, mode, threads) timed out: larger sizes skip it.
    timed_out = {}
    with tempfile.TemporaryDirectory(prefix="compare-peers-") as tmp:
        tmp = Path(tmp)
        for dist in args.dists:
            for size in args.sizes:
                log(f"{dist}, {size} points")
                points_txt = tmp / f"{dist}-{size}.txt"
                points_npy = tmp / f"{dist}-{size}.npy"
                square_npy = tmp / f"{dist}-{size}-square.npy"
                generated = None
                try:
                    done = subprocess.run(
                        [str(QUADMESH), "generate", "--points", str(size), "--dist", dist,
                         "--seed", "1", "-o", str(points_txt)],
                        capture_output=True, text=True, timeout=args.timeout)
                    if done.returncode != 0:
                        generated = f"quadmesh generate failed: {tail(done.stderr)}"
                except subprocess.TimeoutExpired:
                    generated = f"quadmesh generate: timeout after {args.timeout:g} s"
                table = {"dist": dist, "points": size, "results": []}
                if generated is not None:
                    log(f"  {generated}")
                    table["error"] = generated
                    everything["tables"].append(table)
                    print(f"\n{dist}, {size:,} points: {generated}")
                    continue
                points = np.loadtxt(points_txt, dtype=np.float64, ndmin=2)
                corners = square_of(points)
                x0, y0, x1, y1 = corners
                # Triangle's input on each domain: the points alone mesh their convex hull; with
                # the square's corners they mesh the square.
                np.save(points_npy, points)
                np.save(square_npy,
                        np.vstack([points, [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]]))
                npy = {"hull": (points_npy, 0), "square": (square_npy, 4)}
                table["domain"] = args.domain
                table["square"] = list(corners)
                del points
                for config in configs_for(args, dist, size, points_txt, npy, corners):
                    key = (dist, config.tool, config.mode, config.threads, config.domain)
                    skip = skips.get(config.selector)
                    if skip is None and key in timed_out and size >= timed_out[key]:
                        skip = (f"skipped: timed out at {timed_out[key]:,} points "
                                f"(--timeout {args.timeout:g})")
                    result = measure(config, args.repeats, args.timeout, skip)
                    error = result["error"] or ""
                    if config.tool == "quadmesh" and not result["runs"] and error:
                        unknown = re.search(r"unexpected argument '(--[\w-]+)'", error)
                        if "unrecognized subcommand" in error:
                            note = ("skipped: this quadmesh has no `bench` subcommand yet "
                                    "(`quadmesh bench ... --json` failed)")
                            for selector in (*QUADTREE_MODES, "quadmesh-refine"):
                                skips[selector] = note
                            result["error"] = note
                        elif unknown:
                            what = {"quadmesh": "warped mesh",
                                    "quadmesh-compact": "compact warp",
                                    "quadmesh-block": "block warp",
                                    "quadmesh-nonobtuse": "nonobtuse mesh",
                                    "quadmesh-nonobtuse-split": "nonobtuse split"}.get(
                                        config.selector, "refinement")
                            note = (f"skipped: this quadmesh's `bench` has no "
                                    f"`{unknown.group(1)}`, which its {what} rows need")
                            skips[config.selector] = note
                            result["error"] = note
                    if error.startswith("timeout"):
                        timed_out[key] = min(size, timed_out.get(key, size))
                    table["results"].append(result)
                everything["tables"].append(table)
                print_table(dist, size, table["results"], args.markdown, args.angles,
                            max(args.threads))
                points_txt.unlink(missing_ok=True)
                points_npy.unlink(missing_ok=True)
                square_npy.unlink(missing_ok=True)
                if args.out:
                    args.out.write_text(json.dumps(everything, indent=1) + "\n")
    if args.out:
        args.out.write_text(json.dumps(everything, indent=1) + "\n")
        log(f"raw results written to {args.out}")
    for note in dict.fromkeys(skips.values()):
        print(f"\nnote: quadmesh {note}")


if __name__ == "__main__":
    if len(sys.argv) == 5 and sys.argv[1] == CHILD_MARK:
        triangle_child(sys.argv[2], sys.argv[3], sys.argv[4])
    elif len(sys.argv) == 4 and sys.argv[1] == PSLG_CHILD_MARK:
        triangle_pslg_child(sys.argv[2], sys.argv[3])
    else:
        main()
