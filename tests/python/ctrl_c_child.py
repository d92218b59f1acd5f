"""Child of module_test.Cancel.test_ctrl_c: a long compute that the parent interrupts.

Prints "started" once the computation reports progress, then "KeyboardInterrupt <seconds>"
when Ctrl-C (SIGINT) ends it, or "finished" if it ran to the end (the test then fails).
"""
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import gvd  # noqa: E402
import meshes  # noqa: E402

scene = gvd.Scene(3)
for label, v, f in meshes.sphere_lattice(4, 1e-4, 3):
    scene.add(label, v, f)
started = []


def progress(stage, fraction):
    if not started:
        started.append(time.monotonic())
        print("started", flush=True)


t0 = time.monotonic()
try:
    gvd.compute(scene, progress=progress, threads=1)
    print(f"finished in {time.monotonic() - t0:.1f} s", flush=True)
except KeyboardInterrupt:
    print(f"KeyboardInterrupt after {time.monotonic() - t0:.1f} s", flush=True)
