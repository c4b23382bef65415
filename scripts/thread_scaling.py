#!/usr/bin/env python3
"""Thread scaling of `quadmesh bench`: the same jobs on 1, 2, 4, ... threads, one process per run.

Usage (from the repository root, after `cargo build --release`):

    python3 scripts/thread_scaling.py [--threads 1,2,4,8,16] [--repeats 3] [--dir /tmp/qm-scaling]
        [--jobs uniform-q30,kuzmin-q30,uniform-warp,nested-q30,holes-q30] [--binary PATH]

Prints a markdown table: per job and thread count the median `total_s` (meshing, not reading
or writing), the speed-up over the first thread count and the parallel efficiency (speed-up per added
thread, in percent).
The PSLG jobs generate their `.poly` files with `quadmesh generate` first. Runs alternate
thread counts round by round, so a slow spell of the machine spreads over all of them.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys

POINT_JOBS = {
    # name: bench arguments
    "uniform-q30": ["--points", "1000000", "--dist", "uniform", "--min-angle", "30"],
    "kuzmin-q30": ["--points", "1000000", "--dist", "kuzmin", "--min-angle", "30"],
    "uniform-q20": ["--points", "1000000", "--dist", "uniform", "--min-angle", "20"],
    "uniform-warp": ["--points", "300000", "--dist", "uniform", "--warp"],
    "uniform-nonobtuse": ["--points", "300000", "--dist", "uniform", "--nonobtuse"],
}
PSLG_JOBS = {
    # name: (generate arguments, file name, bench arguments)
    "nested-q30": (["--pslg", "nested", "--segments", "200000"], "nested-200000.poly", ["--min-angle", "30"]),
    "holes-q30": (["--pslg", "holes", "--holes", "2000"], "holes-2000.poly", ["--min-angle", "30"]),
}


def default_binary():
    target = os.environ.get("CARGO_TARGET_DIR", "target")
    return os.path.join(target, "release", "quadmesh")


def job_arguments(name, binary, directory):
    if name in POINT_JOBS:
        return POINT_JOBS[name]
    generate, file_name, bench = PSLG_JOBS[name]
    path = os.path.join(directory, file_name)
    if not os.path.exists(path):
        subprocess.run([binary, "generate", *generate, "--seed", "1", "-o", path], check=True,
                       stdout=subprocess.DEVNULL)
    return ["--input", path, *bench]


def run_once(binary, arguments, threads):
    done = subprocess.run([binary, "bench", *arguments, "--threads", str(threads), "--json"],
                          capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"bench {' '.join(arguments)} --threads {threads}: {done.stderr.strip()}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--threads", default="1,2,4,8,16")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--dir", default="/tmp/qm-scaling")
    parser.add_argument("--jobs", default="uniform-q30,kuzmin-q30,uniform-warp,nested-q30,holes-q30")
    parser.add_argument("--binary", default=default_binary())
    args = parser.parse_args()
    threads = [int(t) for t in args.threads.split(",")]
    os.makedirs(args.dir, exist_ok=True)

    print("| job | triangles | " + " | ".join(f"{t} thr s" for t in threads)
          + " | " + " | ".join(f"speed-up {t}" for t in threads[1:]) + " |")
    print("|---" * (2 + 2 * len(threads) - 1) + "|")
    for name in args.jobs.split(","):
        arguments = job_arguments(name, args.binary, args.dir)
        times = {t: [] for t in threads}
        triangles = None
        for _ in range(args.repeats):
            for t in threads:
                result = run_once(args.binary, arguments, t)
                times[t].append(result["total_s"])
                if triangles is not None and triangles != result["triangles"]:
                    raise RuntimeError(f"{name}: {t} threads gave {result['triangles']} triangles, "
                                       f"another count gave {triangles}")
                triangles = result["triangles"]
        medians = {t: statistics.median(times[t]) for t in threads}
        first = threads[0]
        cells = [f"{medians[t]:.3f}" for t in threads]
        cells += [f"{medians[first] / medians[t]:.2f} ({medians[first] / medians[t] * first / t:.0%})"
                  for t in threads[1:]]
        print(f"| {name} | {triangles} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    sys.exit(main())
