#!/usr/bin/env python3
"""The static side of a dynamic quality Delaunay mesh against Triangle, in one process: on
uniform points in the unit square (Triangle gets the square's corners too), the time and
triangles of Triangle `-q<angle>`, of quadmesh's default refinement (`quadmesh.mesh`), and of
a `quadmesh.DynamicDelaunay` build (refinement in order, with its stamps) and its first
`mesh()`. Medians of `--repeats` runs, threads as the pool gives (`RAYON_NUM_THREADS`).

    python3 scripts/dynamic_delaunay_vs_triangle.py --sizes 100000 1000000 --angle 30
"""
import argparse
import statistics
import time

import numpy as np
import quadmesh
import triangle


def timed(run, repeats):
    times, out = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        out = run()
        times.append(time.perf_counter() - start)
    return statistics.median(times), out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[100_000])
    parser.add_argument("--angle", type=float, default=30.0)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    corners = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    print("| points | Triangle -q | quadmesh.mesh | DynamicDelaunay build | + mesh() |")
    print("|---|---:|---:|---:|---:|")
    for n in args.sizes:
        points = np.random.default_rng(1).random((n, 2))
        with_corners = np.vstack([points, corners])
        a = args.angle
        t_tri, tri = timed(lambda: triangle.triangulate({"vertices": with_corners}, f"q{a:g}Q"),
                           args.repeats)
        t_static, static = timed(lambda: quadmesh.mesh(with_corners, min_angle=a), args.repeats)
        t_build, dynamic = timed(lambda: quadmesh.DynamicDelaunay(points, (0, 0, 1, 1),
                                                                  min_angle=a), args.repeats)
        t_mesh, mesh = timed(dynamic.mesh, args.repeats)
        counts = [len(tri["triangles"]), len(static.triangles), len(mesh.triangles)]
        base = counts[0]
        print(f"| {n:.0e} | {t_tri:.2f} s, {counts[0]} | {t_static:.2f} s, {counts[1]} "
              f"({counts[1] / base:.3f}) | {t_build:.2f} s ({t_build / t_tri:.2f}) | "
              f"{t_mesh:.2f} s, {counts[2]} ({counts[2] / base:.3f}); total "
              f"{(t_build + t_mesh) / t_tri:.2f} of Triangle |")


if __name__ == "__main__":
    main()
