"""Child of module_test.Cancel's Ctrl-C tests: a long call that the parent interrupts.

`ctrl_c_child.py` computes a big lattice; `ctrl_c_child.py nearest` asks a finished result for
the nearest objects of 3 million points on one thread. Prints "started" once the long call is
under way, then "KeyboardInterrupt <seconds>" when Ctrl-C (SIGINT) ends it, or "finished" if
it ran to the end (the test then fails).
"""
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import gvd  # noqa: E402
import meshes  # noqa: E402

started = []


def progress(stage, fraction):
    if not started:
        started.append(time.monotonic())
        print("started", flush=True)


if len(sys.argv) > 1 and sys.argv[1] == "nearest":
    import numpy as np

    scene = gvd.Scene(3)
    for label, v, f in meshes.sphere_lattice(2, 0.1, 2):
        scene.add(label, v, f)
    result = gvd.compute(scene, threads=1)
    points = np.random.default_rng(1).uniform(0, 2, size=(3_000_000, 3))

    def call():
        print("started", flush=True)
        result.nearest(points, threads=1)
else:
    scene = gvd.Scene(3)
    for label, v, f in meshes.sphere_lattice(4, 1e-4, 3):
        scene.add(label, v, f)

    def call():
        gvd.compute(scene, progress=progress, threads=1)

t0 = time.monotonic()
try:
    call()
    print(f"finished in {time.monotonic() - t0:.1f} s", flush=True)
except KeyboardInterrupt:
    print(f"KeyboardInterrupt after {time.monotonic() - t0:.1f} s", flush=True)
