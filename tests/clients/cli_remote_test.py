"""`gvd --server URL ...` (the CLI's remote mode) against a real gvd-server: submit with
progress, downloads, queries by job id printing exactly what the local commands print, and
the exit codes of `gvd --help`."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import threading
import time
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from server_process import (CLI, DATA, ROOT, ServerProcess, fresh_dir, slow_scene,  # noqa: E402
                            validate_glb)

sys.path.insert(0, os.path.join(ROOT, "clients", "python"))
import gvd_client as gc  # noqa: E402

GEARS = os.path.join(DATA, "scenes", "gears2d.json")
# Exit codes (clients/cli/cli_options.h, gvd --help).
OK, USAGE, BAD_INPUT, LIMIT, NOT_FOUND, CANCELLED, NO_PATH, BUSY, NETWORK = 0, 2, 3, 4, 5, 6, 7, 8, 9


def gvd(*args: str, env=None, timeout: float = 120):
    """Runs the gvd CLI; returns (exit code, stdout, stderr)."""
    e = dict(os.environ)
    e.pop("GVD_SERVER", None)
    e.update(env or {})
    p = subprocess.run([CLI, *args], capture_output=True, text=True, timeout=timeout, env=e)
    return p.returncode, p.stdout, p.stderr


class RemoteCli(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.server = ServerProcess(name="cli-remote")
        cls.url = cls.server.url
        cls.out = fresh_dir("cli-remote")
        cls.paths = {k: os.path.join(cls.out, k) for k in ("gvd.glb", "graph.json", "gvd.json",
                                                           "result.gvd", "local.glb")}
        cls.compute = gvd("--server", cls.url, "compute", GEARS, "-o", cls.paths["gvd.glb"],
                          "--graph", cls.paths["graph.json"], "--json", cls.paths["gvd.json"],
                          "--save", cls.paths["result.gvd"])
        cls.id = cls.compute[1].strip()

    @classmethod
    def tearDownClass(cls):
        cls.server.stop()

    def remote(self, *args: str):
        return gvd("--server", self.url, *args)

    def test_compute_prints_the_job_id_shows_progress_and_downloads(self):
        rc, out, err = self.compute
        self.assertEqual(rc, OK, err)
        self.assertRegex(self.id, r"^[0-9a-f]{32}$")
        self.assertIn("stage: done", err)  # stderr is not a terminal: one line per stage
        self.assertGreater(len(re.findall(r"stage: ", err)), 1, err)
        self.assertIn("wrote " + self.paths["gvd.glb"], err)
        with gc.Client(self.url) as client:
            job = client.job(self.id)
            with open(self.paths["gvd.glb"], "rb") as f:
                self.assertEqual(f.read(), job.glb())
            with open(self.paths["graph.json"]) as f:
                self.assertEqual(json.load(f), job.graph())
            with open(self.paths["gvd.json"]) as f:
                self.assertEqual(json.load(f), job.gvd_json())
        # The same GVD as a local computation, and a valid glTF.
        rc, _, err = gvd("compute", GEARS, "-o", self.paths["local.glb"], "-q")
        self.assertEqual(rc, OK, err)
        self.assertEqual(os.path.getsize(self.paths["gvd.glb"]),
                         os.path.getsize(self.paths["local.glb"]))
        checked = validate_glb(self.paths["gvd.glb"])
        if checked is not None:
            self.assertEqual(checked[0], 0, checked[1])
        # The saved result works locally and says what the server says.
        rc, local_info, err = gvd("info", self.paths["result.gvd"], "--json")
        self.assertEqual(rc, OK, err)
        rc, remote_info, err = self.remote("info", "--job", self.id, "--json")
        self.assertEqual(rc, OK, err)
        self.assertEqual(json.loads(remote_info), json.loads(local_info))
        rc, text, _ = self.remote("info", "--job", self.id)
        self.assertEqual(rc, OK)
        self.assertIn(f"{self.id}: done", text)

    def test_queries_by_job_id_print_what_the_local_commands_print(self):
        result = self.paths["result.gvd"]
        points = os.path.join(self.out, "points.json")
        with open(points, "w") as f:
            json.dump({"points": [[0.5, 0.5], [1, 1], [-1.3, -2.3]]}, f)
        queries = [
            ["neighbors", "--object", "gear_a"],
            ["neighbors", "--object", "frame", "--ring", "2"],
            ["nearest", "--point", "0.5,0.5"],
            ["nearest", "--points", points, "--point", "3,2"],
            ["path", "--from", "-1.3,-2.3", "--to", "3.3,2.3"],
            ["path", "--from", "-1.3,-2.3", "--to", "3.3,2.3", "--cost", "clearance",
             "--min-clearance", "0.01"],
            ["explode", "--anchor", "frame"],
            ["explode", "--anchor", "frame", "--scale", "0.5"],
            ["tight", "--below", "0.05"],
        ]
        for q in queries:
            with self.subTest(q=q):
                local = gvd(q[0], result, *q[1:])
                remote = self.remote(q[0], "--job", self.id, *q[1:])
                self.assertEqual(local[0], OK, local[2])
                self.assertEqual(remote[0], OK, remote[2])
                self.assertEqual(remote[1], local[1])
        # GVD_SERVER works as --server does.
        rc, out, _ = gvd("neighbors", "--job", self.id, "--object", "gear_a",
                         env={"GVD_SERVER": self.url})
        self.assertEqual((rc, out), (OK, gvd("neighbors", result, "--object", "gear_a")[1]))
        # The animated exploded view.
        glb = os.path.join(self.out, "exploded.glb")
        rc, _, err = self.remote("explode", "--job", self.id, "--anchor", "frame", "-o", glb)
        self.assertEqual(rc, OK, err)
        with open(glb, "rb") as f:
            self.assertEqual(f.read(4), b"glTF")

    def test_exit_codes(self):
        result = self.paths["result.gvd"]
        # No path: exit 7, the same path document as locally.
        no_path = ["path", "--from", "-1.3,-2.3", "--to", "3.3,2.3", "--min-clearance", "100"]
        local = gvd(no_path[0], result, *no_path[1:])
        remote = self.remote(no_path[0], "--job", self.id, *no_path[1:])
        self.assertEqual((remote[0], remote[1]), (NO_PATH, local[1]))
        self.assertEqual(json.loads(remote[1])["points"], [])
        cases = [
            (NOT_FOUND, ["neighbors", "--job", "0" * 32, "--object", "gear_a"]),
            (NOT_FOUND, ["neighbors", "--job", self.id, "--object", "no_such_object"]),
            (NOT_FOUND, ["info", "--job", "0" * 32]),
            (BAD_INPUT, ["nearest", "--job", self.id, "--point", "100,0"]),
            (BAD_INPUT, ["compute", os.path.join(DATA, "malformed", "json_index_out_of_range.json")]),
            (BAD_INPUT, ["compute", os.path.join(DATA, "malformed", "garbage.bin")]),
            (BAD_INPUT, ["compute", GEARS, "--domain", "0,0,1,1"]),  # does not hold the scene
            (USAGE, ["nearest", "--job", self.id, "--point", "1,2,3"]),
            (USAGE, ["neighbors", "--object", "gear_a"]),
            (USAGE, ["compute", GEARS, "--threads", "2"]),
            (USAGE, ["compute", GEARS, "--units", "furlong"]),  # a bad value: as locally
            (USAGE, ["compute", GEARS, "--max-depth", "deep"]),
            (USAGE, ["compute", GEARS, "--distance", "wavefront"]),  # the server cannot
            (USAGE, ["compute", GEARS, "--octree-build", "data-parallel"]),
            (USAGE, ["neighbors", result, "--object", "gear_a"]),
            (NOT_FOUND, ["compute", os.path.join(self.out, "missing.json")]),
        ]
        for code, args in cases:
            with self.subTest(args=args):
                rc, _, err = self.remote(*args)
                self.assertEqual(rc, code, err)
                self.assertIn("gvd: ", err)
        # Nobody listening: a network error, at once.
        t0 = time.monotonic()
        rc, _, err = gvd("--server", "http://127.0.0.1:1", "compute", GEARS)
        self.assertEqual(rc, NETWORK, err)
        self.assertIn("network error", err)
        self.assertLess(time.monotonic() - t0, 10)
        # URLs: a trailing slash or no scheme is fine; something that is not a URL is a usage
        # error, not a network error.
        for url in (self.url + "/", self.url.replace("http://", "")):
            self.assertEqual(gvd("--server", url, "info", "--job", self.id)[0], OK, url)
        self.assertEqual(gvd("--server", "not a url", "info", "--job", self.id)[0], USAGE)
        self.assertEqual(gvd("--server", "ftp://example.org", "info", "--job", self.id)[0], USAGE)
        # --local ignores GVD_SERVER.
        rc, _, err = gvd("--local", "neighbors", result, "--object", "gear_a",
                         env={"GVD_SERVER": "http://127.0.0.1:1"})
        self.assertEqual(rc, OK, err)

    def test_no_wait_and_scene_queries_and_mesh_files(self):
        meshes = [os.path.join(DATA, "formats", f) for f in ("cube.off", "tetra_ascii.ply")]
        rc, out, err = self.remote("compute", *meshes, "--max-depth", "6", "--contact-depth", "4",
                                   "--no-wait")
        self.assertEqual(rc, OK, err)
        job_id = out.strip()
        self.assertRegex(job_id, r"^[0-9a-f]{32}$")
        with gc.Client(self.url) as client:
            job = client.job(job_id)
            job.wait(timeout=60)
            self.assertEqual([n["label"] for n in job.graph()["nodes"]], ["cube", "tetra_ascii"])
            self.assertEqual(job.info()["params"]["max_depth"], 6)
        # A query on scene files: submitted (the same content: the same job), waited for.
        rc, out, err = self.remote("neighbors", *meshes, "--max-depth", "6", "--contact-depth",
                                   "4", "--object", "cube", "-q")
        self.assertEqual(rc, OK, err)
        self.assertEqual(json.loads(out)["neighbors"][0]["label"], "tetra_ascii")

    def test_grid_job_outputs_are_the_local_grid_and_volumes_go_up(self):
        d = fresh_dir("cli-remote-grid")
        common = ["--mode", "grid", "--resolution", "40", "--metric", "l1", "--float64"]
        rc, out, err = self.remote("compute", GEARS, *common, "--graph", f"{d}/g.json",
                                   "-o", f"{d}/f.npy", "--labels", f"{d}/l.npy")
        self.assertEqual(rc, OK, err)
        self.assertIn("grid job (mode=grid)", err)
        rc, _, err = gvd("compute", GEARS, *common, "--graph", f"{d}/lg.json", "-o",
                         f"{d}/lf.npy", "--labels", f"{d}/ll.npy", "-q")
        self.assertEqual(rc, OK, err)
        for remote, local in (("f.npy", "lf.npy"), ("l.npy", "ll.npy")):
            with open(f"{d}/{remote}", "rb") as a, open(f"{d}/{local}", "rb") as b:
                self.assertEqual(a.read(), b.read(), remote)
        with open(f"{d}/g.json") as a, open(f"{d}/lg.json") as b:
            self.assertEqual(json.load(a)["edges"], json.load(b)["edges"])
        # Outputs a grid job does not have are refused before submitting.
        rc, _, err = self.remote("compute", GEARS, *common, "--save", f"{d}/r.gvd")
        self.assertEqual(rc, USAGE, err)
        # The grid mode's flags (the parameter table's) without it, and the server's own limit.
        for flag in (["--metric", "l1"], ["--range-cells", "4"], ["--unsigned"],
                     ["--labels", f"{d}/x.npy"]):
            rc, _, err = self.remote("compute", GEARS, *flag)
            self.assertEqual(rc, USAGE, err)
            self.assertIn(f"{flag[0]} goes with --mode grid", err)
        rc, _, err = self.remote("compute", GEARS, "--max-cells", "100")
        self.assertEqual(rc, USAGE, err)
        self.assertIn("--max-cells is not a job parameter", err)
        # A labelled volume (2D, labels 1 | 2 | 3 in columns), spacing required by the server.
        rows, cols = 6, 9
        data = bytes(1 + x // 3 for _ in range(rows) for x in range(cols))
        header = "{'descr': '|u1', 'fortran_order': False, 'shape': (%d, %d), }" % (rows, cols)
        header += " " * (63 - (10 + len(header)) % 64) + "\n"
        with open(f"{d}/v.npy", "wb") as f:
            f.write(b"\x93NUMPY\x01\x00" + len(header).to_bytes(2, "little") + header.encode()
                    + data)
        rc, _, err = self.remote("compute", "--volume", f"{d}/v.npy", "--spacing", "1,2",
                                 "--mode", "grid", "--resolution", "20", "--graph",
                                 f"{d}/vg.json", "-q")
        self.assertEqual(rc, OK, err)
        with open(f"{d}/vg.json") as f:
            graph = json.load(f)
        self.assertEqual({(e["a"], e["b"]) for e in graph["edges"]}, {(0, 1), (1, 2)})
        rc, _, err = self.remote("compute", "--volume", f"{d}/v.npy", "--mode", "grid",
                                 "--resolution", "20", "-q")
        self.assertEqual(rc, BAD_INPUT, err)
        self.assertIn("spacing", err)
        # A float .npy is no label volume: invalid input naming the dtype (422 on the server),
        # the exit code of the same mistake made locally.
        rc, _, err = self.remote("compute", "--volume", f"{d}/f.npy", "--spacing", "1,1", "-q")
        self.assertEqual(rc, BAD_INPUT, err)
        self.assertIn("dtype <f8", err)
        rc, _, err = gvd("compute", "--volume", f"{d}/f.npy", "--spacing", "1,1", "-q")
        self.assertEqual(rc, BAD_INPUT, err)
        self.assertIn("dtype <f8", err)


class NoEventStreams(unittest.TestCase):
    def test_compute_polls_when_the_server_has_no_stream_to_spare(self):
        with ServerProcess("--max-streams", "0", name="cli-poll") as server:
            glb = os.path.join(fresh_dir("cli-poll"), "gvd.glb")
            rc, out, err = gvd("--server", server.url, "compute", GEARS, "-o", glb)
            self.assertEqual(rc, OK, err)
            self.assertIn("stage: done", err)
            with open(glb, "rb") as f:
                self.assertEqual(f.read(4), b"glTF")
            with gc.Client(server.url) as client:  # and the Python client polls too
                job = client.submit(GEARS)
                self.assertEqual(job.id, out.strip())
                seen = []
                self.assertEqual(job.wait(progress=lambda s, f: seen.append(s))["status"], "done")
                self.assertEqual(seen[-1], "done")


class FailedJob(unittest.TestCase):
    def test_a_job_over_the_time_limit_exits_with_the_limit_code(self):
        with ServerProcess("--job-seconds", "0.3", "--max-body", "20000",
                           name="cli-limit") as server:
            scene = os.path.join(fresh_dir("cli-limit"), "slow.json")
            with open(scene, "w") as f:
                json.dump(slow_scene(), f)
            rc, out, err = gvd("--server", server.url, "compute", scene, "--contact-depth", "12")
            self.assertEqual(rc, LIMIT, err)
            self.assertIn("failed", err)
            rc, _, err = gvd("--server", server.url, "tight", "--job", out.strip(), "--below", "1")
            self.assertEqual(rc, LIMIT, err)
            # A scene over --max-body (58 KB > 20 KB): 413, exit 4; BodyTooLarge in Python.
            big = os.path.join(DATA, "scenes", "balls_on_plate.json")
            rc, _, err = gvd("--server", server.url, "compute", big)
            self.assertEqual(rc, LIMIT, err)
            self.assertIn("too large", err)
            with gc.Client(server.url) as client, self.assertRaises(gc.BodyTooLarge) as e:
                client.submit(big)
            self.assertEqual(e.exception.status, 413)
            # Regression: a body far over the limit is refused before the server reads it and
            # the connection closed while we still send; that killed gvd with SIGPIPE. Now: a
            # network error that names the likely cause (or the 413, if the whole body got
            # out before the server closed). Python reads the 413 either way.
            huge = os.path.join(fresh_dir("cli-limit"), "huge.json")
            with open(huge, "wb") as f:
                f.write(b"{" + b" " * 4_000_000 + b"}")
            rc, _, err = gvd("--server", server.url, "compute", huge)
            self.assertIn(rc, (LIMIT, NETWORK), err)
            if rc == NETWORK and "while the request was sent" in err:
                self.assertIn("--max-body", err)
            with gc.Client(server.url) as client, self.assertRaises(gc.BodyTooLarge):
                client.submit(huge)


class ExitCodeTable(unittest.TestCase):
    def test_every_documented_problem_type_has_one_exit_code(self):
        with open(os.path.join(ROOT, "docs", "API.md")) as f:
            documented = re.findall(r"^\| `(/problems/[a-z-]+)` \|", f.read(), re.M)
        with open(os.path.join(ROOT, "clients", "cli", "remote_commands.cpp")) as f:
            rows = re.findall(r'\{"(/problems/[a-z-]+)", (kExit\w+)\}', f.read())
        self.assertEqual(len(documented), 28)
        self.assertEqual(sorted(t for t, _ in rows), sorted(documented))
        codes = dict(rows)
        self.assertEqual(codes["/problems/queue-full"], "kExitBusy")
        self.assertEqual(codes["/problems/rate-limited"], "kExitBusy")
        self.assertEqual(codes["/problems/queue-unavailable"], "kExitBusy")
        self.assertEqual(codes["/problems/overloaded"], "kExitBusy")
        self.assertEqual(codes["/problems/no-path"], "kExitNoPath")
        rc, out, _ = gvd("--help")
        self.assertEqual(rc, OK)
        for code in ("8 server busy", "9 network error"):
            self.assertIn(code, " ".join(out.split()))


class BusyServer(unittest.TestCase):
    """One worker, a queue of one, Retry-After 1 s, and jobs that take seconds."""

    def test_busy_cancelled_and_unfinished(self):
        with ServerProcess("--workers", "1", "--queue", "1", "--retry-after", "1",
                           "--job-threads", "1", name="cli-busy") as server, \
                gc.Client(server.url) as client:
            scene = os.path.join(fresh_dir("cli-busy"), "slow.json")
            with open(scene, "w") as f:
                json.dump(slow_scene(), f)
            running = client.submit(scene, {"contact_depth": 13})
            deadline = time.monotonic() + 20
            while running.status() != "running":
                self.assertLess(time.monotonic(), deadline)
                time.sleep(0.02)
            queued = client.submit(scene, {"contact_depth": 11})
            self.assertEqual(queued.document["status"], "queued")

            # Queue full: retried after Retry-After (1 s), then exit 8.
            t0 = time.monotonic()
            rc, out, err = gvd("--server", server.url, "--retries", "1", "compute", scene,
                               "--contact-depth", "10")
            self.assertEqual(rc, BUSY, err)
            self.assertGreaterEqual(time.monotonic() - t0, 1.0)
            self.assertIn("retrying in 1 s", err)
            self.assertEqual(out, "")
            # A query on a job that is not done yet: exit 8 too.
            rc, _, err = gvd("--server", server.url, "neighbors", "--job", running.id,
                             "--object", "cube0")
            self.assertEqual(rc, BUSY, err)
            rc, out, _ = gvd("--server", server.url, "info", "--job", running.id)
            self.assertEqual(rc, OK)
            self.assertIn("running", out)

            # Waiting on a job that gets cancelled: exit 6. (The same scene and parameters:
            # the queued job itself, so no 503.)
            timer = threading.Timer(0.5, queued.cancel)
            timer.start()
            rc, out, err = gvd("--server", server.url, "compute", scene, "--contact-depth", "11")
            timer.join()
            self.assertEqual(rc, CANCELLED, err)
            self.assertEqual(out.strip(), queued.id)
            running.cancel()


if __name__ == "__main__":
    unittest.main()
