"""gvd-server's compute backend: chosen once at start-up; `auto` uses OpenCL when a
device exists and otherwise the CPU twins, saying so in /readyz and in every job; an explicit
`opencl` without a platform refuses to start with a clear message. Run with the real PoCL
(GVD_OPENCL_EXPECTED=1 in CTest when a platform was found at configure time) and with
OCL_ICD_VENDORS pointing to an empty directory (no platform)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
import unittest
import urllib.request

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from server_process import DATA, SERVER, ServerProcess  # noqa: E402


def get(url: str):
    with urllib.request.urlopen(url, timeout=30) as r:
        return json.loads(r.read())


def compute(server: ServerProcess) -> dict:
    with open(os.path.join(DATA, "scenes", "gears2d.json"), "rb") as f:
        body = f.read()
    req = urllib.request.Request(server.url + "/v1/jobs?max_depth=9", data=body, method="POST",
                                 headers={"Content-Type": "application/json"})
    with urllib.request.urlopen(req, timeout=30) as r:
        job = json.loads(r.read())
    for _ in range(300):
        job = get(server.url + "/v1/jobs/" + job["id"])
        if job["status"] in ("done", "failed", "cancelled"):
            return job
        time.sleep(0.1)
    raise AssertionError("job did not finish")


class NoPlatform(unittest.TestCase):
    def setUp(self):
        self.empty = tempfile.mkdtemp(prefix="no-opencl-")
        self.env = dict(os.environ, OCL_ICD_VENDORS=self.empty)

    def test_auto_runs_on_the_cpu_and_says_why(self):
        old = os.environ.get("OCL_ICD_VENDORS")
        os.environ["OCL_ICD_VENDORS"] = self.empty
        try:
            with_server = ServerProcess("--backend", "auto", name="backend-auto")
        finally:
            if old is None:
                del os.environ["OCL_ICD_VENDORS"]
            else:
                os.environ["OCL_ICD_VENDORS"] = old
        try:
            ready = get(with_server.url + "/readyz")
            self.assertEqual(ready["backend_requested"], "auto")
            self.assertTrue(ready["backend"].startswith("cpu"), ready)
            self.assertIn("OpenCL", ready["backend"])
            job = compute(with_server)
            self.assertEqual(job["status"], "done", job)
        finally:
            with_server.stop()

    def test_explicit_opencl_refuses_to_start(self):
        store = tempfile.mkdtemp(prefix="backend-opencl-")
        p = subprocess.run([SERVER, "--port", "0", "--store", store, "--backend", "opencl"],
                           env=self.env, capture_output=True, text=True, timeout=60)
        self.assertNotEqual(p.returncode, 0)
        self.assertIn("OpenCL", p.stderr)


@unittest.skipUnless(os.environ.get("GVD_OPENCL_EXPECTED") == "1", "no OpenCL platform here")
class WithPlatform(unittest.TestCase):
    def test_opencl_backend_serves_jobs(self):
        server = ServerProcess("--backend", "opencl", name="backend-opencl")
        try:
            ready = get(server.url + "/readyz")
            self.assertTrue(ready["backend"].startswith("opencl"), ready)
            job = compute(server)
            self.assertEqual(job["status"], "done", job)
        finally:
            server.stop()


if __name__ == "__main__":
    unittest.main()
