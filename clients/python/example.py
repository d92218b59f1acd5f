#!/usr/bin/env python3
"""Submit a scene to gvd-server, wait with a progress line, print neighbours and a path, save
the GVD as GLB.

    make run &                                     # gvd-server on 127.0.0.1:8080
    python3 clients/python/example.py              # the bundled gears2d scene
    python3 clients/python/example.py --server http://host:8080 --scene my_scene.glb \
        --object gear_a --from -1.3,-2.3 --to 3.3,2.3 -o gvd.glb
"""

import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import gvd_client  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
GEARS = os.path.join(HERE, "..", "..", "tests", "data", "scenes", "gears2d.json")


def numbers(text):
    return [float(v) for v in text.split(",")]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--server", default=os.environ.get("GVD_SERVER", "http://127.0.0.1:8080"))
    ap.add_argument("--scene", nargs="+", default=[GEARS],
                    help="a scene file, or several PLY/STL/OFF meshes (one object each)")
    ap.add_argument("--object", default="gear_a", help="whose neighbours to print")
    ap.add_argument("--from", dest="start", type=numbers, default=[-1.3, -2.3])
    ap.add_argument("--to", dest="goal", type=numbers, default=[3.3, 2.3])
    ap.add_argument("-o", "--output", default="gvd.glb")
    args = ap.parse_args()

    def progress(stage, fraction):
        bar = "#" * int(fraction * 30)
        print(f"\r  {stage:<10} [{bar:<30}] {fraction * 100:3.0f}%", end="", file=sys.stderr,
              flush=True)

    with gvd_client.Client(args.server) as client:
        scene = args.scene[0] if len(args.scene) == 1 else args.scene
        try:
            job = client.submit(scene)
            print(f"job {job.id}", file=sys.stderr)
            done = job.wait(progress=progress)
            print(file=sys.stderr)
        except gvd_client.GvdError as e:  # InvalidScene, ServerBusy, GvdConnectionError, ...
            print(f"\nerror: {e}", file=sys.stderr)
            return 1
        r = done["result"]
        print(f"{r['objects']} objects, octree depth {r['depth']}, {r['leaves']} leaves, "
              f"{r['total_seconds']:.2f} s")

        for n in job.neighbors(args.object, ring=1)["neighbors"]:
            print(f"  {args.object} - {n['label']}: interface {n['area']:.4g}, "
                  f"clearance {n['min_clearance']:.4g}")
        try:
            path = job.path(args.start, args.goal, cost="clearance")
            print(f"path: {len(path['points'])} points, length {path['length']:.4g}, "
                  f"min clearance {path['min_clearance']:.4g}")
        except gvd_client.NoPath as e:
            print(f"no path: {e.path['reason']}")

        with open(args.output, "wb") as f:
            f.write(job.glb())
        print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
