"""Batch nearest on 10^6 numpy points: the Python module beside the C++ facade, in one run.

`make bench` runs it (PYTHONPATH = the build's python/ directory). It computes a lattice of
spheres, saves the result, and writes 10^6 random points in its bounding box; then, in
alternating rounds, gvd_bench_api_nearest (C++, gvd::api::Result::nearest on the loaded
result) and the module (gvd.load(...).nearest on a float64 C-order array) each time `repeats`
calls and keep their best. It checks that both gave the same answers and prints the
throughput of each and the ratio Python / C++, for all cores and for one thread.
  python_nearest_bench.py --cpp BUILD/tests/gvd_bench_api_nearest [--points N] [--rounds R]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

import gvd

here = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(here, "..", "python"))
import meshes  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--cpp", required=True, help="the gvd_bench_api_nearest binary")
    ap.add_argument("--points", type=int, default=1_000_000)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()

    work = tempfile.mkdtemp(prefix="gvd-pybench-")
    scene = gvd.Scene(3)
    objects = meshes.sphere_lattice(3, 0.02, 3)  # 27 spheres, 1,280 triangles each
    for label, v, f in objects:
        scene.add(label, v, f)
    t0 = time.monotonic()
    result = gvd.compute(scene)
    print(f"scene: 27 spheres, {27 * 1280} triangles, computed in "
          f"{time.monotonic() - t0:.1f} s; {result.info.get('leaves', '?')} leaves")
    saved = os.path.join(work, "lattice.gvd")
    result.save(saved)
    allv = np.concatenate([v for _, v, _ in objects])
    lo, hi = allv.min(axis=0), allv.max(axis=0)
    points = lo + np.random.default_rng(12).random((args.points, 3)) * (hi - lo)
    points_file = os.path.join(work, "points.f64")
    points.tofile(points_file)

    loaded = gvd.load(saved)
    loaded.nearest(points[:1000])  # builds the index, as the C++ program's warm-up does
    for threads in (0, 1):
        best_py, best_cpp, cpp = float("inf"), float("inf"), None
        repeats = args.repeats if threads == 0 else 1
        for _ in range(args.rounds):
            out = subprocess.run([args.cpp, saved, points_file, str(repeats), str(threads)],
                                 check=True, capture_output=True, text=True).stdout
            cpp = json.loads(out)
            best_cpp = min(best_cpp, cpp["best_s"])
            for _ in range(repeats):
                t = time.perf_counter()
                near = loaded.nearest(points, threads=threads)
                best_py = min(best_py, time.perf_counter() - t)
        same = (int(near.object.astype(np.int64).sum()) == cpp["object_sum"] and
                abs(float(np.nansum(np.abs(near.distance))) - cpp["distance_sum"]) <=
                1e-9 * abs(cpp["distance_sum"]))
        if not same:
            print("python_nearest_bench: the module and the facade answered differently",
                  file=sys.stderr)
            return 1
        n = args.points
        label = "all cores" if threads == 0 else "1 thread"
        print(f"nearest, {n:,} points, {label}: C++ facade {n / best_cpp / 1e6:.3f} M points/s "
              f"({best_cpp:.3f} s), Python module {n / best_py / 1e6:.3f} M points/s "
              f"({best_py:.3f} s): ratio Python / C++ = {best_cpp / best_py:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
