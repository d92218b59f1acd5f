"""A real gvd-server on an ephemeral port for the client tests (the Python twin of
tests/service/server_process.h). Paths come from the environment CTest sets:
GVD_SERVER (binary), GVD_CLI (the gvd binary), GVD_TEST_DATA_DIR, GVD_TEST_OUTPUT_DIR,
GVD_TEST_JS_DIR."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile
import threading

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
SERVER = os.environ.get("GVD_SERVER", os.path.join(ROOT, "build", "server", "gvd-server"))
CLI = os.environ.get("GVD_CLI", os.path.join(ROOT, "build", "clients", "gvd"))
DATA = os.environ.get("GVD_TEST_DATA_DIR", os.path.join(ROOT, "tests", "data"))
JS = os.environ.get("GVD_TEST_JS_DIR", os.path.join(ROOT, "tests", "js"))
OUTPUT = os.environ.get("GVD_TEST_OUTPUT_DIR", os.path.join(ROOT, "build", "test-output"))


def fresh_dir(name: str) -> str:
    """A new empty directory under the test output directory."""
    os.makedirs(OUTPUT, exist_ok=True)
    return tempfile.mkdtemp(prefix=name + "-", dir=OUTPUT)


class ServerProcess:
    """``gvd-server --port 0 --store <fresh dir> --quiet <args>``; ``url`` is read from the
    "listening on" line. Use as a context manager or call ``stop()``."""

    def __init__(self, *args: str, name: str = "server"):
        self.store = os.path.join(fresh_dir(name), "store")
        self.proc = subprocess.Popen(
            [SERVER, "--port", "0", "--store", self.store, "--quiet", *args],
            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        line = ""
        timer = threading.Timer(20, self.proc.kill)  # never hang on a server that fails to start
        timer.start()
        try:
            line = self.proc.stdout.readline()
        finally:
            timer.cancel()
        m = re.search(r"listening on (http://[^ ]+)", line)
        if not m:
            self.stop()
            raise RuntimeError(f"gvd-server did not start: {line!r}")
        self.url = m.group(1)
        self.port = int(self.url.rsplit(":", 1)[1])

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait()
        if self.proc.stdout:
            self.proc.stdout.close()
        shutil.rmtree(os.path.dirname(self.store), ignore_errors=True)

    def __enter__(self) -> "ServerProcess":
        return self

    def __exit__(self, *exc) -> None:
        self.stop()


def slow_scene() -> dict:
    """Two interpenetrating unit cubes: the octree refines along their contact down to
    ``contact_depth``, so the run time grows ~2x per level (about 4 s at 12 on a 2-core
    machine) — a slow job on demand (the same scene as tests/service/service_test.cpp)."""
    tris = [[0, 2, 1], [1, 2, 3], [4, 5, 6], [5, 7, 6], [0, 1, 4], [1, 5, 4],
            [2, 6, 3], [3, 6, 7], [0, 4, 2], [2, 4, 6], [1, 3, 5], [3, 7, 5]]
    objects = []
    for k in range(2):
        verts = [[0.5 * k + (i & 1), 0.5 * k + ((i >> 1) & 1), 0.5 * k + ((i >> 2) & 1)]
                 for i in range(8)]
        objects.append({"label": f"cube{k}", "vertices": verts, "triangles": tris})
    return {"dimension": 3, "objects": objects}


def validate_glb(path: str):
    """Runs the Khronos glTF validator (tests/js/validate_glb.mjs) on a file; None when node or
    the validator is not installed, else (exit code, output)."""
    node = shutil.which("node")
    if not node or not os.path.isdir(os.path.join(JS, "node_modules", "gltf-validator")):
        return None
    p = subprocess.run([node, os.path.join(JS, "validate_glb.mjs"), path],
                       capture_output=True, text=True, timeout=120)
    return p.returncode, p.stdout + p.stderr
