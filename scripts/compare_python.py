#!/usr/bin/env python3
"""From Python: quadmesh.triangulate against triangle.triangulate with the same options on the
same input, side by side (alternating runs, medians), and the Python package's overhead
against the Rust CLI (`quadmesh bench --input`) on the same input.

    python3 -m pip install ./python triangle
    cargo build --release
    python3 scripts/compare_python.py --points 1000000 --poly /tmp/pslg/nested-200000.poly

Each measurement runs in a fresh child process, so its peak memory (ru_maxrss) is its own.
"""

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile

CHILD = r"""
import json, resource, sys, time
import numpy as np
tool, path, opts, threads = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
if path.endswith(".npy"):
    tri = {"vertices": np.load(path)}
else:
    import triangle
    tri = triangle.load(*path.rsplit("/", 1)[0:1], path.rsplit("/", 1)[1][:-5])
if tool == "triangle":
    import triangle
    start = time.perf_counter()
    out = triangle.triangulate(tri, opts)
else:
    import quadmesh
    start = time.perf_counter()
    if threads == "all":
        out = quadmesh.triangulate(tri, opts)
    else:
        m = quadmesh.mesh(tri["vertices"], tri.get("segments") if "p" in opts else None,
                          tri.get("segment_markers") if "p" in opts else None,
                          tri.get("holes") if "p" in opts else None,
                          min_angle=float(opts.split("q")[1].rstrip("Q") or 20), threads=int(threads))
        out = {"triangles": m.triangles}
seconds = time.perf_counter() - start
print(json.dumps({"seconds": seconds, "triangles": len(out["triangles"]),
                  "peak_rss_bytes": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024}))
"""


def child(tool, path, opts, threads):
    out = subprocess.run(
        [sys.executable, "-c", CHILD, tool, path, opts, threads],
        check=True, capture_output=True, text=True,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def cli(binary, path, angle, threads):
    out = subprocess.run(
        [binary, "bench", "--input", path, "--min-angle", str(angle), "--threads", str(threads), "--json"],
        check=True, capture_output=True, text=True,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--points", type=int, default=1_000_000)
    parser.add_argument("--poly", help="a .poly file for the graph rows")
    parser.add_argument("--angles", default="20,30")
    parser.add_argument("--threads", default="2")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--binary", default="target/release/quadmesh")
    args = parser.parse_args()

    import numpy as np

    tmp = tempfile.mkdtemp()
    points_npy = os.path.join(tmp, "points.npy")
    np.save(points_npy, np.random.default_rng(1).random((args.points, 2)))
    points_txt = os.path.join(tmp, "points.txt")
    np.savetxt(points_txt, np.load(points_npy), fmt="%.17g")
    inputs = [("uniform %d" % args.points, points_npy, points_txt, "")]
    if args.poly:
        inputs.append((os.path.basename(args.poly), args.poly, args.poly, "p"))

    print("| input | angle | threads | triangles Triangle / quadmesh | time Triangle / quadmesh (Python) / quadmesh (CLI), s | ratio to Triangle | Python overhead | peak MB Triangle / quadmesh |")
    print("|---|---|---|---|---|---|---|---|")
    for name, path, cli_path, p in inputs:
        for angle in args.angles.split(","):
            for threads in args.threads.split(","):
                opts = f"{p}q{angle}Q"
                runs = {"triangle": [], "quadmesh": [], "cli": []}
                for _ in range(args.repeats):
                    runs["triangle"].append(child("triangle", path, opts, threads))
                    runs["quadmesh"].append(child("quadmesh", path, opts, threads))
                    runs["cli"].append(cli(args.binary, cli_path, angle, threads))
                t = statistics.median(r["seconds"] for r in runs["triangle"])
                q = statistics.median(r["seconds"] for r in runs["quadmesh"])
                c = statistics.median(r["total_s"] for r in runs["cli"])
                print(
                    f"| {name} | {angle} | {threads} | {runs['triangle'][0]['triangles']} / {runs['quadmesh'][0]['triangles']} "
                    f"| {t:.3f} / {q:.3f} / {c:.3f} | {q / t:.2f} | {q / c:.2f} "
                    f"| {max(r['peak_rss_bytes'] for r in runs['triangle']) / 1e6:.0f} / "
                    f"{max(r['peak_rss_bytes'] for r in runs['quadmesh']) / 1e6:.0f} |",
                    flush=True,
                )


if __name__ == "__main__":
    main()
