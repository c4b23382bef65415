#!/usr/bin/env python3
"""Measure dynamic warped meshes with `quadmesh replay --json`.

Usage (from the repository root, after `cargo build --release`):

    python3 scripts/dynamic_study.py [--points 100000] [--threads 2] [--dir /tmp/qm-dynamic]
        [--studies single,spread,batches,steps] [--warp compact|block]

Studies, each printed as a markdown table:

* single: one insert, delete and move at a time (1000 of each, on `--points` uniform points in
  the unit square), median seconds per edit against a rebuild of the final points;
* spread: the quadtree squares an insertion touches (median) when it puts a point at distance
  2^-k from one of 10 000 uniform points, for k from 4 to 32;
* batches: 0.1 %, 1 % and 10 % of the points edited (a third each inserted, deleted, moved
  anywhere), one by one and as one batch, against a rebuild;
* steps: a time step moving every point by a random displacement of a given size, one by one
  and as one batch, against a rebuild.

Every run is checked against a rebuild (`--verify`).
"""

import argparse
import json
import math
import os
import random
import statistics
import subprocess
import sys


def binary():
    target = os.environ.get("CARGO_TARGET_DIR", "target")
    return os.path.join(target, "release", "quadmesh")


def write_points(path, points):
    with open(path, "w") as f:
        for x, y in points:
            f.write(f"{x!r} {y!r}\n")


def write_edits(path, edits):
    with open(path, "w") as f:
        for e in edits:
            f.write(" ".join(e if isinstance(e, str) else repr(e) for e in e) + "\n")


WARP_FLAGS = {"compact": "--compact-warp", "block": "--block-warp"}
WARP = "compact"


def replay(points_path, edits_path, out_dir, threads, batch=1):
    """The per-edit (or per-batch) lines and the summary of one replay."""
    cmd = [binary(), "replay", points_path, edits_path, "-o", os.path.join(out_dir, "out"),
           "--domain", "0,0,1,1", "--format", "svg", "--json", "--verify", "--threads",
           str(threads), "--batch", str(batch), WARP_FLAGS[WARP]]
    run = subprocess.run(cmd, capture_output=True, text=True)
    if run.returncode != 0:
        sys.exit(f"replay failed: {run.stderr.strip()}")
    lines = [json.loads(line) for line in run.stdout.splitlines()]
    summary = lines.pop()
    assert summary["identical"], "the replayed mesh differs from a rebuild"
    return lines, summary


def uniform(rng, n):
    return [(rng.random(), rng.random()) for _ in range(n)]


def single(args, rng):
    points = uniform(rng, args.points)
    path = os.path.join(args.dir, "single.txt")
    write_points(path, points)
    print(f"\n### One edit at a time, {args.points} uniform points, {args.threads} threads\n")
    print("| edit | median s per edit | rebuild s | rebuild / edit |")
    print("|---|---:|---:|---:|")
    n = len(points)
    kinds = {
        "insert": [("i", rng.random(), rng.random()) for _ in range(1000)],
        "delete": [("d", str(i)) for i in rng.sample(range(n), 1000)],
        "move": [("m", str(i), rng.random(), rng.random()) for i in rng.sample(range(n), 1000)],
    }
    for kind, edits in kinds.items():
        edits_path = os.path.join(args.dir, f"single-{kind}.txt")
        write_edits(edits_path, edits)
        lines, summary = replay(path, edits_path, args.dir, args.threads)
        median = statistics.median(line["seconds"] for line in lines)
        rebuild = summary["rebuild_seconds"]
        print(f"| {kind} | {median:.6f} | {rebuild:.3f} | {rebuild / median:,.0f} |")


def spread(args, rng):
    print("\n### Squares touched by an insertion at distance 2^-k from a point (10 000 points)\n")
    print("| k: log2 of the new pair's spread | median squares per insertion | median s per insertion |")
    print("|---:|---:|---:|")
    # A pair 1e-12 apart keeps the tree on the wide grid, so that every insertion below is a
    # local update rather than a move between grids.
    base = uniform(rng, 10_000) + [(0.5, 0.5), (0.5 + 1e-12, 0.5)]
    path = os.path.join(args.dir, "spread.txt")
    write_points(path, base)
    ks = (4, 8, 12, 16, 20, 24, 28, 32)
    edits = []
    for k in ks:
        for _ in range(40):
            x, y = base[rng.randrange(10_000)]
            angle = rng.random() * 2 * math.pi
            d = 2.0 ** -k
            p = (min(1.0, max(0.0, x + d * math.cos(angle))), min(1.0, max(0.0, y + d * math.sin(angle))))
            edits.append(("i", p[0], p[1]))
            edits.append(("d", str(len(base))))
            base.append(p)
    edits_path = os.path.join(args.dir, "spread-edits.txt")
    write_edits(edits_path, edits)
    lines, _ = replay(path, edits_path, args.dir, args.threads)
    inserts = lines[0::2]
    for n, k in enumerate(ks):
        group = inserts[40 * n: 40 * (n + 1)]
        cells = statistics.median(line["cells"] for line in group)
        seconds = statistics.median(line["seconds"] for line in group)
        print(f"| {k} | {cells:.0f} | {seconds:.6f} |")


def closest_pair(points):
    """The smallest distance between two points: a sweep in x order."""
    xs = sorted(points)
    best = float("inf")
    for i in range(len(xs)):
        for j in range(i + 1, len(xs)):
            dx = xs[j][0] - xs[i][0]
            if dx >= best:
                break
            best = min(best, math.hypot(dx, xs[j][1] - xs[i][1]))
    return best


def batches(args, rng):
    points = uniform(rng, args.points)
    path = os.path.join(args.dir, "batches.txt")
    write_points(path, points)
    n = len(points)
    print(f"\n### Batches of edits, {n} uniform points, {args.threads} threads\n")
    print("| share of points | edits | one by one s | as one batch s | rebuild s | one by one / rebuild | batch / rebuild |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for share in (0.001, 0.01, 0.1):
        count = int(n * share)
        ids = rng.sample(range(n), 2 * (count // 3) + 2)
        edits = []
        for k in range(count):
            if k % 3 == 0:
                edits.append(("i", rng.random(), rng.random()))
            elif k % 3 == 1:
                edits.append(("d", str(ids.pop())))
            else:
                edits.append(("m", str(ids.pop()), rng.random(), rng.random()))
        edits_path = os.path.join(args.dir, f"batch-{count}.txt")
        write_edits(edits_path, edits)
        lines, summary = replay(path, edits_path, args.dir, args.threads)
        total = sum(line["seconds"] for line in lines)
        batched, _ = replay(path, edits_path, args.dir, args.threads, batch=count)
        together = sum(line["seconds"] for line in batched)
        rebuild = summary["rebuild_seconds"]
        print(f"| {share:.1%} | {count} | {total:.3f} | {together:.3f} | {rebuild:.3f} | "
              f"{total / rebuild:.2f} | {together / rebuild:.2f} |")


def steps(args, rng):
    points = uniform(rng, args.points)
    path = os.path.join(args.dir, "steps.txt")
    write_points(path, points)
    n = len(points)
    print(f"\n### A time step moving every point, {n} uniform points, {args.threads} threads\n")
    print("| displacement | moves in their leaf | one by one s | as one batch s | rebuild s | one by one / rebuild | batch / rebuild |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for size in (1e-7, 1e-5, 1e-3):
        edits = []
        for i, (x, y) in enumerate(points):
            nx = min(1.0, max(0.0, x + (rng.random() - 0.5) * size))
            ny = min(1.0, max(0.0, y + (rng.random() - 0.5) * size))
            edits.append(("m", str(i), nx, ny))
        edits_path = os.path.join(args.dir, f"step-{size}.txt")
        write_edits(edits_path, edits)
        lines, summary = replay(path, edits_path, args.dir, args.threads)
        total = sum(line["seconds"] for line in lines)
        within = sum(1 for line in lines if line["cells"] == 0)
        batched, _ = replay(path, edits_path, args.dir, args.threads, batch=n)
        together = sum(line["seconds"] for line in batched)
        rebuild = summary["rebuild_seconds"]
        print(f"| {size:g} | {within / n:.1%} | {total:.3f} | {together:.3f} | {rebuild:.3f} | "
              f"{total / rebuild:.2f} | {together / rebuild:.2f} |")


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--points", type=int, default=100_000)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--dir", default="/tmp/qm-dynamic")
    parser.add_argument("--studies", default="single,spread,batches,steps")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--warp", choices=sorted(WARP_FLAGS), default="compact",
                        help="the dynamic mesh's warp (default: compact)")
    args = parser.parse_args()
    global WARP
    WARP = args.warp
    os.makedirs(args.dir, exist_ok=True)
    rng = random.Random(args.seed)
    studies = {"single": single, "spread": spread, "batches": batches, "steps": steps}
    for name in args.studies.split(","):
        studies[name](args, rng)


if __name__ == "__main__":
    main()
