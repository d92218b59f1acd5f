"""The Python client (clients/python/gvd_client.py) against a real gvd-server.

Answers are checked against the API itself (raw HTTP requests made here with urllib) and the
documents of docs/API.md, never against numbers printed by the client."""

from __future__ import annotations

import json
import os
import re
import socket
import subprocess
import sys
import threading
import time
import unittest
import urllib.error
import urllib.request

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from server_process import DATA, ROOT, ServerProcess, fresh_dir, slow_scene, validate_glb  # noqa: E402

sys.path.insert(0, os.path.join(ROOT, "clients", "python"))
import gvd_client as gc  # noqa: E402

GEARS = os.path.join(DATA, "scenes", "gears2d.json")


def raw_get(url: str):
    """GET without the client: (status, headers, body bytes)."""
    try:
        with urllib.request.urlopen(url, timeout=30) as r:
            return r.status, dict(r.headers), r.read()
    except urllib.error.HTTPError as e:
        return e.code, dict(e.headers), e.read()


class FinishedJob(unittest.TestCase):
    """One server, the gears2d scene computed once; outputs and queries."""

    @classmethod
    def setUpClass(cls):
        cls.server = ServerProcess(name="py-client")
        cls.client = gc.Client(cls.server.url, timeout=30, retries=2, backoff=0.05)
        cls.job = cls.client.submit(GEARS)
        cls.seen = []
        cls.final = cls.job.wait(progress=lambda s, f: cls.seen.append((s, f)), timeout=60)

    @classmethod
    def tearDownClass(cls):
        cls.client.close()
        cls.server.stop()

    def api(self, suffix: str):
        status, _, body = raw_get(f"{self.server.url}/v1/jobs/{self.job.id}{suffix}")
        self.assertEqual(status, 200, body[:300])
        return json.loads(body)

    def test_wait_reports_progress_then_done(self):
        self.assertEqual(self.final["status"], "done")
        self.assertEqual(self.final["id"], self.job.id)
        self.assertTrue(self.seen, "progress callback never called")
        self.assertEqual(self.seen[-1], ("done", 1.0))
        fractions = [f for _, f in self.seen]
        self.assertEqual(fractions, sorted(fractions), "progress went backwards")
        self.assertTrue(all(0.0 <= f <= 1.0 for f in fractions))
        self.assertEqual(self.job.status(), "done")
        self.assertEqual(self.job.info()["result"]["objects"], 3)

    def test_submitting_again_is_the_same_job(self):
        with open(GEARS) as f:
            scene = json.load(f)
        again = self.client.submit(scene)  # a dict this time: the same content, the same id
        self.assertEqual(again.id, self.job.id)
        self.assertFalse(again.created)
        self.assertEqual(again.document["status"], "done")

    def test_outputs_equal_the_api(self):
        glb = self.job.glb()
        self.assertEqual(glb[:4], b"glTF")
        status, headers, raw = raw_get(f"{self.server.url}/v1/jobs/{self.job.id}/gvd.glb")
        self.assertEqual(glb, raw)
        path = os.path.join(fresh_dir("py-glb"), "gvd.glb")
        with open(path, "wb") as f:
            f.write(glb)
        checked = validate_glb(path)
        if checked is not None:
            self.assertEqual(checked[0], 0, checked[1])
        self.assertEqual(self.job.graph(), self.api("/graph"))
        self.assertEqual(self.job.gvd_json(), self.api("/gvd.json"))
        gltf = self.job.gltf()
        self.assertEqual([n["name"] for n in gltf["nodes"]], ["gear_a", "gear_b", "frame"])
        self.assertEqual(self.job.result_file()[:6], b"GVDRES")

    def test_neighbors_equal_the_api_and_the_graph(self):
        for label in ("gear_a", "gear_b", "frame"):
            self.assertEqual(self.job.neighbors(label), self.api(f"/objects/{label}/neighbors?ring=1"))
        mine = {n["label"] for n in self.job.neighbors("gear_a", ring=1)["neighbors"]}
        graph = self.job.graph()
        labels = {n["object"]: n["label"] for n in graph["nodes"]}
        a = next(n["object"] for n in graph["nodes"] if n["label"] == "gear_a")
        expected = {labels[e["b"] if e["a"] == a else e["a"]] for e in graph["edges"]
                    if a in (e["a"], e["b"])}
        self.assertEqual(mine, expected)

    def test_nearest_one_and_many(self):
        one = self.job.nearest([0.5, 0.5])
        self.assertEqual(one, self.api("/nearest?point=0.5,0.5"))
        many = self.job.nearest([[0.5, 0.5], [-1.3, -2.3], [3.3, 2.3]])
        self.assertEqual(len(many), 3)
        self.assertEqual(many[0], one)
        self.assertEqual([a["point"] for a in many], [[0.5, 0.5], [-1.3, -2.3], [3.3, 2.3]])
        with self.assertRaises(gc.OutsideDomain) as e:
            self.job.nearest([100.0, 0.0])
        self.assertEqual(e.exception.status, 422)
        self.assertEqual(e.exception.type, "/problems/outside-domain")
        self.assertIn("outside", e.exception.detail)
        with self.assertRaises(gc.InvalidArgument):
            self.job.nearest([1.0, 2.0, 3.0])  # a 3D point on a 2D result

    def test_path_and_no_path(self):
        p = self.job.path([-1.3, -2.3], [3.3, 2.3])
        self.assertEqual(p["points"][0], [-1.3, -2.3])
        self.assertEqual(p["points"][-1], [3.3, 2.3])
        self.assertGreater(p["length"], 0)
        wide = self.job.path([-1.3, -2.3], [3.3, 2.3], cost="clearance")
        self.assertGreaterEqual(wide["min_clearance"], p["min_clearance"] - 1e-12)
        with self.assertRaises(gc.NoPath) as e:
            self.job.path([-1.3, -2.3], [3.3, 2.3], min_clearance=1e6)
        self.assertEqual(e.exception.status, 422)
        self.assertEqual(e.exception.path["points"], [])
        self.assertIsNone(e.exception.path["length"])
        self.assertTrue(e.exception.path["reason"])

    def test_explode_and_tight(self):
        view = self.job.explode("frame")
        self.assertEqual(view, self.api("/explode?anchor=frame"))
        self.assertEqual(len(view["objects"]), 3)
        self.assertEqual(self.job.explode("frame", glb=True)[:4], b"glTF")
        scaled = self.job.explode("frame", scale=2.0)
        self.assertEqual(scaled, self.api("/explode?anchor=frame&scale=2"))
        tight = self.job.tight(10.0)
        self.assertEqual(tight, self.api("/tight?below=10"))
        self.assertTrue(tight["pairs"])

    def test_problem_types_raise_their_classes(self):
        with self.assertRaises(gc.NotFound) as e:
            self.job.neighbors("no such label")
        self.assertEqual((e.exception.status, e.exception.type), (404, "/problems/not-found"))
        with self.assertRaises(gc.NotFound):
            self.client.job("0" * 32).status()
        with self.assertRaises(gc.InvalidScene) as e:
            self.client.submit(os.path.join(DATA, "malformed", "json_index_out_of_range.json"))
        self.assertEqual(e.exception.problem["object"]["label"], "tet")
        self.assertEqual(e.exception.problem["element"]["kind"], "triangle")
        with self.assertRaises(gc.UnsupportedFormat):
            self.client.submit(os.path.join(DATA, "malformed", "garbage.bin"))
        with self.assertRaises(gc.InvalidArgument):
            self.client.submit(GEARS, params={"max_depth": -3})
        with self.assertRaises(ValueError):
            self.client.submit(GEARS, params={"max_dpeth": 3})  # caught before sending
        self.assertTrue(all(issubclass(c, gc.GvdError) for c in gc.PROBLEM_TYPES.values()))

    def test_example_script_runs(self):
        out = os.path.join(fresh_dir("py-example"), "example.glb")
        p = subprocess.run([sys.executable, os.path.join(ROOT, "clients", "python", "example.py"),
                            "--server", self.server.url, "-o", out],
                           capture_output=True, text=True, timeout=60)
        self.assertEqual(p.returncode, 0, p.stdout + p.stderr)
        self.assertIn("gear_a - gear_b", p.stdout)
        self.assertIn("path:", p.stdout)
        with open(out, "rb") as f:
            self.assertEqual(f.read(), self.job.glb())

    def test_every_documented_problem_type_has_its_class(self):
        with open(os.path.join(ROOT, "docs", "API.md")) as f:
            documented = set(re.findall(r"^\| `(/problems/[a-z-]+)` \|", f.read(), re.M))
        self.assertEqual(len(documented), 28)
        self.assertEqual(documented, set(gc.PROBLEM_TYPES))
        classes = list(gc.PROBLEM_TYPES.values())
        self.assertEqual(len(set(classes)), len(classes), "one class per problem type")
        for t in documented:  # the server describes each type; the status matches the class
            status, _, body = raw_get(self.server.url + t)
            self.assertEqual(status, 200, t)
            err = gc.error_from_problem(json.loads(body))
            self.assertIsInstance(err, gc.PROBLEM_TYPES[t])
            if json.loads(body)["status"] in (429, 503):
                self.assertIsInstance(err, gc.ServerBusy)


class Submissions(unittest.TestCase):
    def test_mesh_files_as_multipart_are_labelled_by_stem(self):
        with ServerProcess(name="py-multipart") as server:
            client = gc.Client(server.url, retries=1, backoff=0.05)
            self.addCleanup(client.close)
            files = [os.path.join(DATA, "formats", f) for f in ("cube.off", "tetra_ascii.ply")]
            job = client.submit(files, params={"max_depth": 6, "contact_depth": 4})
            done = job.wait(timeout=60)
            self.assertEqual(done["scene"]["objects"], 2)
            self.assertEqual([n["label"] for n in job.graph()["nodes"]], ["cube", "tetra_ascii"])
            self.assertEqual(done["params"]["max_depth"], 6)
            # Meshes have no units unless given: then the job, its graph and answers say them.
            self.assertIsNone(job.units)
            self.assertNotIn("units", job.graph())
            in_mm = client.submit(files, params={"max_depth": 6, "contact_depth": 4,
                                                 "units": "mm"})
            self.assertNotEqual(in_mm.id, job.id)
            self.assertEqual(in_mm.wait(timeout=60)["units"], "mm")
            self.assertEqual(in_mm.units, "mm")
            self.assertEqual(in_mm.graph()["units"], "mm")
            self.assertEqual(in_mm.tight(10.0)["units"], "mm")
            # One STL file on its own: labelled by its stem through ?label=.
            one = client.submit(os.path.join(DATA, "formats", "tetra_ascii.stl"),
                                params={"max_depth": 5})
            one.wait(timeout=60)
            self.assertEqual([n["label"] for n in one.graph()["nodes"]], ["tetra_ascii"])

    def test_grid_job_and_labelled_volume(self):
        with ServerProcess(name="py-grid") as server:
            client = gc.Client(server.url, retries=1, backoff=0.05)
            self.addCleanup(client.close)
            job = client.submit(GEARS, params={"mode": "grid", "resolution": 32, "float64": True})
            done = job.wait(timeout=60)
            self.assertEqual(done["params"]["mode"], "grid")
            self.assertTrue(done["params"]["float64"])
            status, _, field = raw_get(f"{server.url}/v1/jobs/{job.id}/field.npy")
            self.assertEqual(status, 200)
            self.assertEqual(job.field_npy(), field)
            self.assertIn(b"'descr': '<f8'", field[:128])
            self.assertEqual(len(job.graph()["edges"]), len(self.api_graph(server, job.id)))
            with self.assertRaises(gc.AdaptiveOnly):
                job.glb()
            # A 2D volume: labels 1 | 2 | 3 in columns of 4 pixels, 8 rows, |u1.
            rows, cols = 8, 12
            data = bytes(1 + x // 4 for _ in range(rows) for x in range(cols))
            header = "{'descr': '|u1', 'fortran_order': False, 'shape': (%d, %d), }" % (rows, cols)
            header += " " * (63 - (10 + len(header)) % 64) + "\n"
            npy = b"\x93NUMPY\x01\x00" + len(header).to_bytes(2, "little") + header.encode() + data
            path = os.path.join(fresh_dir("py-volume"), "labels.npy")
            with open(path, "wb") as f:
                f.write(npy)
            vol = client.submit(path, params={"spacing": [1, 2], "mode": "grid", "resolution": 24})
            vol.wait(timeout=60)
            pairs = {tuple(sorted((e["a"], e["b"]))) for e in vol.graph()["edges"]}
            self.assertEqual(pairs, {(0, 1), (1, 2)})
            self.assertEqual([n["label"] for n in vol.graph()["nodes"]],
                             ["label_1", "label_2", "label_3"])
            with self.assertRaises(gc.InvalidArgument):
                client.submit(path, params={"mode": "grid", "resolution": 24})  # no spacing

    @staticmethod
    def api_graph(server, job_id):
        _, _, body = raw_get(f"{server.url}/v1/jobs/{job_id}/graph")
        return json.loads(body)["edges"]

    def test_connection_refused_is_a_network_error_after_retries(self):
        s = socket.socket()
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
        s.close()  # nobody listens there now
        client = gc.Client(f"http://127.0.0.1:{port}", timeout=2, retries=2, backoff=0.05)
        t0 = time.monotonic()
        with self.assertRaises(gc.GvdConnectionError) as e:
            client.submit(GEARS)
        self.assertIsNone(e.exception.status)
        self.assertGreaterEqual(time.monotonic() - t0, 0.05 + 0.1)  # two backoffs: 0.05, 0.1
        self.assertLess(time.monotonic() - t0, 5)


class SlowJobs(unittest.TestCase):
    """A server with one worker and a queue of one, and jobs that take seconds."""

    def setUp(self):
        # One thread per job: the running job stays slow (seconds) on any machine and leaves
        # the other cores to the tests that run alongside.
        self.server = ServerProcess("--workers", "1", "--queue", "1", "--retry-after", "1",
                                    "--max-streams", "1", "--job-threads", "1", name="py-busy")
        self.client = gc.Client(self.server.url, timeout=30, retries=0)
        self.scene = slow_scene()

    def tearDown(self):
        self.client.close()
        self.server.stop()

    def running_and_queued(self):
        running = self.client.submit(self.scene, {"contact_depth": 13})
        deadline = time.monotonic() + 20
        while running.status() != "running":
            self.assertLess(time.monotonic(), deadline)
            time.sleep(0.02)
        queued = self.client.submit(self.scene, {"contact_depth": 11})
        self.assertEqual(queued.document["status"], "queued")
        return running, queued

    def test_busy_queue_raises_server_busy_and_retries_honour_retry_after(self):
        running, queued = self.running_and_queued()
        with self.assertRaises(gc.QueueFull) as e:
            self.client.submit(self.scene, {"contact_depth": 10})
        self.assertIsInstance(e.exception, gc.ServerBusy)
        self.assertEqual(e.exception.status, 503)
        self.assertEqual(e.exception.retry_after, 1.0)
        # With retries: still busy after two waits of Retry-After = 1 s each.
        patient = gc.Client(self.server.url, retries=2, backoff=0.01)
        self.addCleanup(patient.close)
        t0 = time.monotonic()
        with self.assertRaises(gc.QueueFull):
            patient.submit(self.scene, {"contact_depth": 10})
        self.assertGreaterEqual(time.monotonic() - t0, 2.0)
        # The queue frees up while the client waits: the retry gets through.
        threading.Timer(0.3, queued.cancel).start()
        t0 = time.monotonic()
        third = patient.submit(self.scene, {"contact_depth": 9})
        self.assertGreaterEqual(time.monotonic() - t0, 1.0)
        self.assertEqual(third.document["status"], "queued")
        for job in (third, running):
            job.cancel()

    def test_outputs_of_an_unfinished_job_and_cancelling_it(self):
        running, queued = self.running_and_queued()
        with self.assertRaises(gc.JobNotFinished) as e:
            running.glb()
        self.assertEqual(e.exception.status, 409)
        with self.assertRaises(gc.WaitTimeout):
            running.wait(timeout=0.3)
        self.assertEqual(queued.cancel()["status"], "cancelled")
        with self.assertRaises(gc.JobCancelled):
            queued.wait(timeout=10)
        # Two waits at once: the second finds the one event stream taken and polls.
        results = []
        threading.Thread(target=lambda: results.append(self._wait_cancelled(running))).start()
        time.sleep(0.3)
        running.cancel()
        self.assertEqual(self._wait_cancelled(running), "JobCancelled")
        deadline = time.monotonic() + 10
        while not results and time.monotonic() < deadline:
            time.sleep(0.05)
        self.assertEqual(results, ["JobCancelled"])
        with self.assertRaises(gc.JobCancelled):
            running.graph()

    @staticmethod
    def _wait_cancelled(job):
        try:
            job.wait(timeout=15, poll_interval=0.05)
            return "done"
        except gc.GvdError as e:
            return type(e).__name__

    def test_a_job_over_a_limit_fails_with_limit_exceeded(self):
        with ServerProcess("--job-seconds", "0.3", name="py-limit") as server, \
                gc.Client(server.url) as client:
            job = client.submit(self.scene, {"contact_depth": 12})
            with self.assertRaises(gc.LimitExceeded) as e:
                job.wait(timeout=20)
            self.assertEqual(e.exception.type, "/problems/limit-exceeded")
            with self.assertRaises(gc.JobFailed):
                job.graph()


if __name__ == "__main__":
    unittest.main()
