#!/usr/bin/env python3
"""Time and peak memory of quadmesh and Triangle on the graphs that make peer meshers fail.

Usage (from the repository root; Triangle from `pip install triangle numpy`):

    python3 scripts/peer_failures.py [--no-build] [--timeout 60] [--memory-gib 4] [--markdown]

What it does:

* builds the release CLI and the example that writes the cases
  (``cargo build --release --bin quadmesh --example peer_failure_cases``; ``--no-build`` skips
  this), and writes every case of ``tests/peer_failures.rs`` as a ``.poly`` file into a
  temporary directory;
* meshes each with quadmesh at 20° and 30° (``quadmesh mesh F -o OUT --min-angle A``), in the
  warp mode (``--warp``), and with Triangle (``pq20``, ``pq30``, through the ``triangle``
  package in a child interpreter), crossings split where the case says so (Triangle always
  splits them);
* runs every command as a child with its address space limited to ``--memory-gib`` and killed
  after ``--timeout`` seconds, and reports its outcome (a mesh and its triangles, the first
  line of an error, killed), its wall time and its peak resident memory (``ru_maxrss`` of the
  child, interpreter included for Triangle).
"""

import argparse
import json
import os
import resource
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import compare_peers  # noqa: E402  (shares the .poly reader and the binaries' location)

CHILD_MARK = "__triangle_child__"
EXAMPLE = compare_peers.TARGET / "release" / "examples" / "peer_failure_cases"


def triangle_child(poly, switches):
    """Runs in a fresh interpreter: mesh the .poly file with Triangle, print one JSON line."""
    import triangle

    out = triangle.triangulate(compare_peers.read_poly(poly), switches)
    print(json.dumps({"triangles": int(len(out.get("triangles", [])))}))


def limited(memory_bytes):
    """A pre-exec hook capping the child's address space."""
    def hook():
        resource.setrlimit(resource.RLIMIT_AS, (memory_bytes, memory_bytes))
    return hook


def run(command, timeout, memory_bytes):
    """(return code or signal name, stdout, stderr, seconds, peak bytes) of `command`."""
    start = time.perf_counter()
    child = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             preexec_fn=limited(memory_bytes), start_new_session=True)
    killed = threading.Event()

    def kill():
        killed.set()
        os.killpg(child.pid, signal.SIGKILL)

    timer = threading.Timer(timeout, kill)
    timer.start()
    out, err = b"", b""
    try:
        out, err = child.communicate()
    finally:
        timer.cancel()
    seconds = time.perf_counter() - start
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024
    code = child.returncode
    if killed.is_set():
        code = "timeout"
    elif code is not None and code < 0:
        code = signal.Signals(-code).name
    return code, out.decode(errors="replace"), err.decode(errors="replace"), seconds, peak


def peak_of_one(command, timeout, memory_bytes):
    """`run` in a fresh helper process, so that ru_maxrss is this command's alone."""
    helper = [sys.executable, str(Path(__file__).resolve()), "__run__", json.dumps(
        {"command": command, "timeout": timeout, "memory": memory_bytes})]
    done = subprocess.run(helper, capture_output=True, text=True, check=True)
    return json.loads(done.stdout)


def repeated(command, args, memory, triangles_of):
    """(outcome, median seconds, largest peak) over `args.repeats` runs of `command`; differing
    outcomes are listed with their counts."""
    results = [peak_of_one(command, args.timeout, memory) for _ in range(args.repeats)]
    outcomes = [outcome(r, triangles_of) for r in results]
    counted = {o: outcomes.count(o) for o in outcomes}
    text = outcomes[0] if len(counted) == 1 else "; ".join(
        f"{o} ({n} of {len(outcomes)})" for o, n in counted.items())
    seconds = sorted(r["seconds"] for r in results)[len(results) // 2]
    return text, {"seconds": seconds, "peak": max(r["peak"] for r in results)}


def run_helper(spec):
    spec = json.loads(spec)
    code, out, err, seconds, peak = run(spec["command"], spec["timeout"], spec["memory"])
    print(json.dumps({"code": code, "out": out, "err": err, "seconds": seconds, "peak": peak}))


def outcome(result, triangles_of):
    """A short description of what a run gave."""
    code = result["code"]
    if code == "timeout":
        return "killed at the time limit"
    if isinstance(code, str):
        return f"killed ({code})"
    if code != 0:
        lines = [line for line in result["err"].splitlines() if line.strip()]
        message = lines[-1] if lines else f"exit {code}"
        if "MemoryError" in message:
            return "out of memory (the limit)"
        # The CLI's "error: FILE: message" and Python's "RuntimeError: message", shortened.
        message = message.removeprefix("error: ").split(".poly:", 1)[-1].strip()
        return "error: " + message[:100]
    return f"{triangles_of(result):,} triangles"


def quadmesh_triangles(result):
    """The triangle count from the CLI's report (on standard error)."""
    for line in (result["out"] + result["err"]).splitlines():
        if line.startswith("triangles"):
            return int(line.split()[1])
    return 0


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--no-build", action="store_true")
    parser.add_argument("--timeout", type=float, default=60)
    parser.add_argument("--memory-gib", type=float, default=4)
    parser.add_argument("--repeats", type=int, default=1,
                        help="runs of each command: the outcomes counted where they differ "
                             "(Triangle crashes on some inputs now and then), the median time "
                             "and the largest peak")
    parser.add_argument("--markdown", action="store_true")
    args = parser.parse_args()
    if not args.no_build:
        subprocess.run(["cargo", "build", "--release", "--bin", "quadmesh", "--example",
                        "peer_failure_cases"], check=True)
    memory = int(args.memory_gib * 2**30)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        listing = subprocess.run([str(EXAMPLE), tmp], capture_output=True, text=True, check=True)
        for line in listing.stdout.splitlines():
            path, *flags = line.split()
            split = "split" in flags
            name = Path(path).stem
            out = str(Path(tmp) / "out")
            extra = ["--split-crossings"] if split else []
            runs = {}
            for label, mode in [("quadmesh 20°", ["--min-angle", "20"]),
                                ("quadmesh 30°", ["--min-angle", "30"]),
                                ("quadmesh warp", ["--warp"])]:
                command = [str(compare_peers.QUADMESH), "mesh", path, "-o", out] + mode + extra
                runs[label] = repeated(command, args, memory, quadmesh_triangles)
            for angle in (20, 30):
                command = [sys.executable, str(Path(__file__).resolve()), CHILD_MARK, path,
                           f"pq{angle}Q"]
                runs[f"Triangle pq{angle}"] = repeated(
                    command, args, memory, lambda r: json.loads(r["out"])["triangles"])
            rows.append((name, runs))
            print(name, {k: v[0] for k, v in runs.items()}, file=sys.stderr)
    labels = list(rows[0][1]) if rows else []
    if args.markdown:
        print("| case | " + " | ".join(labels) + " |")
        print("|---|" + "---|" * len(labels))
        for name, runs in rows:
            cells = [f"{text}; {r['seconds']:.2f} s, {r['peak'] / 2**20:.0f} MB"
                     for text, r in runs.values()]
            print(f"| {name} | " + " | ".join(cells) + " |")
    else:
        print(json.dumps([{"case": name, **{k: {"outcome": t, "seconds": r["seconds"],
                                                 "peak_bytes": r["peak"]}
                                             for k, (t, r) in runs.items()}}
                          for name, runs in rows], indent=1))


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == CHILD_MARK:
        triangle_child(sys.argv[2], sys.argv[3])
    elif len(sys.argv) > 1 and sys.argv[1] == "__run__":
        run_helper(sys.argv[2])
    else:
        main()
