#!/usr/bin/env bash
# Runs the stage benchmarks (benches/morton.rs, benches/framework.rs) and prints a table of
# criterion medians in ns per point, one row per (bench, dist, stage, n), one column per thread
# count, plus the speedup of each thread count over the single-threaded run.
#
# Usage:
#   scripts/bench_stages.sh [CRITERION_ARGS...]   run the benches, then print the table
#   scripts/bench_stages.sh --table-only          print the table of every result on disk
#
# Environment (passed through to the benches):
#   QUADMESH_BENCH_SIZES    comma list of point counts (default 100000,1000000; add 10000000
#                           only on purpose: about 20 s per benchmark)
#   QUADMESH_BENCH_THREADS  comma list of rayon thread counts (default 1,2)
#   CRITERION_HOME / CARGO_TARGET_DIR  where criterion writes (default target/criterion)
#
# Examples:
#   QUADMESH_BENCH_SIZES=1000000 QUADMESH_BENCH_THREADS=1,2,4 scripts/bench_stages.sh
#   scripts/bench_stages.sh 'sort64/kuzmin'      # criterion filter: only those benchmarks
#
# After a run the table shows only results written by that run; --table-only shows all of them.
set -euo pipefail

cd "$(dirname "$0")/.."

criterion_dir="${CRITERION_HOME:-${CARGO_TARGET_DIR:-target}/criterion}"

if [[ "${1:-}" == "--table-only" ]]; then
    since=0
else
    echo "sizes: ${QUADMESH_BENCH_SIZES:-100000,1000000 (default)}  threads: ${QUADMESH_BENCH_THREADS:-1,2 (default)}" >&2
    since="$(python3 -c 'import time; print(time.time())')"
    cargo bench --bench morton --bench framework --bench balance -- "$@"
fi

python3 - "$criterion_dir" "$since" <<'PY'
import json
import os
import re
import signal
import sys

signal.signal(signal.SIGPIPE, signal.SIG_DFL)  # quiet when piped into head

root, since = sys.argv[1], float(sys.argv[2])
GROUP = re.compile(r"(.+)/([^/]+)/t(\d+)")
GROUP_DIR = re.compile(r"^([^_]+)_([^_]+)_t(\d+)$")
BENCH_ORDER = ["morton", "sort64", "sort128", "framework"]
DIST_ORDER = ["uniform", "cluster", "kuzmin"]
STAGE_ORDER = ["radsort", "voracious", "rayon_unstable", "framework", "expand", "framework+expand"]


def load(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


def rank(order, value):
    return (order.index(value), "") if value in order else (len(order), value)


results = {}  # (bench, dist, stage, n) -> {threads: ns per point}
threads_seen = set()
for dirpath, _dirs, files in os.walk(root):
    if os.path.basename(dirpath) != "new" or "estimates.json" not in files:
        continue
    est_path = os.path.join(dirpath, "estimates.json")
    try:
        if os.path.getmtime(est_path) < since:
            continue
        median_ns = float(load(est_path)["median"]["point_estimate"])
    except (OSError, TypeError, KeyError, ValueError):
        continue
    meta = load(os.path.join(dirpath, "benchmark.json")) or {}
    group, stage, value = meta.get("group_id"), meta.get("function_id"), meta.get("value_str")
    if group is None:  # no benchmark.json: fall back on the directory names
        parts = os.path.relpath(os.path.dirname(dirpath), root).split(os.sep)
        if len(parts) != 3:
            continue
        group, stage, value = parts  # criterion writes the group's '/' as '_'
        group = GROUP_DIR.sub(r"\1/\2/t\3", group)
    m = GROUP.fullmatch(group or "")
    if not m or stage is None:
        continue
    bench, dist, threads = m.group(1), m.group(2), int(m.group(3))
    n = None
    throughput = meta.get("throughput")
    if isinstance(throughput, dict) and "Elements" in throughput:
        n = throughput["Elements"]
    if n is None:
        try:
            n = int(value)
        except (TypeError, ValueError):
            continue
    if not n:
        continue
    results.setdefault((bench, dist, stage, int(n)), {})[threads] = median_ns / n
    threads_seen.add(threads)

if not results:
    print(f"no criterion results found under {root}" + (" from this run" if since else ""), file=sys.stderr)
    sys.exit(1)

threads = sorted(threads_seen)
base = 1 if 1 in threads else threads[0]
others = [t for t in threads if t != base]
header = ["bench", "dist", "stage", "n"] + [f"t{t} ns/pt" for t in threads] + [f"t{t}/t{base}" for t in others]
rows = []
for key in sorted(
    results,
    key=lambda k: (rank(BENCH_ORDER, k[0]), rank(DIST_ORDER, k[1]), k[3], rank(STAGE_ORDER, k[2])),
):
    by_t = results[key]
    cells = [key[0], key[1], key[2], str(key[3])]
    cells += [f"{by_t[t]:.2f}" if t in by_t else "-" for t in threads]
    for t in others:
        ok = t in by_t and base in by_t and by_t[t] > 0
        cells.append(f"{by_t[base] / by_t[t]:.2f}x" if ok else "-")
    rows.append(cells)

widths = [max(len(r[i]) for r in rows + [header]) for i in range(len(header))]
left = 3  # bench, dist, stage: left-aligned; numbers right-aligned


def fmt(cells):
    return "  ".join(c.ljust(w) if i < left else c.rjust(w) for i, (c, w) in enumerate(zip(cells, widths)))


print(f"median ns per point (criterion, {root}); speedup = t{base} time / tN time")
print(fmt(header))
print(fmt(["-" * w for w in widths]))
prev = None
for r in rows:
    if prev is not None and (r[0], r[1]) != prev:
        print()
    prev = (r[0], r[1])
    print(fmt(r))
PY
