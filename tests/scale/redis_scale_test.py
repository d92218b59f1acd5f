"""Scale-out with real parts: a private redis-server on loopback (a port of its own,
no persistence), three gvd-server replicas sharing one store directory, and a single-node
gvd-server as the reference for the outputs.

Checks: jobs spread over the workers; kill -9 of the worker running a job -> the job completes
on another within --reclaim-idle + its run time, outputs byte-identical to the single node;
Redis restarted mid-run -> /readyz says so, the replicas reconnect and every job submitted
before completes; duplicate submissions to three replicas at once are one job; SSE progress
through a replica that does not run the job; the queue metrics.

redis-server is required: without it the test fails (docker/install-deps.sh installs it)."""

from __future__ import annotations

import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
import unittest
import urllib.error
import urllib.request

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "clients"))
from server_process import (CLI, DATA, OUTPUT, SERVER, ServerProcess, fresh_dir,  # noqa: E402
                            slow_scene)

RECLAIM_IDLE = 2.0  # seconds (--reclaim-idle of the replicas)
SLOW = {"contact_depth": 11}
RATE, BURST = 20, 30  # --rate-limit, --rate-burst of the replicas  # about 1-3 s on this 2-core machine with one thread


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_for(what: str, predicate, timeout: float, every: float = 0.05):
    """Polls `predicate` until it returns a true value (returned) or fails after `timeout`."""
    deadline = time.monotonic() + timeout
    error = None
    while time.monotonic() < deadline:
        try:
            value = predicate()
            if value:
                return value
        except (OSError, RuntimeError) as e:  # a server or Redis not answering (yet)
            error = e
        time.sleep(every)
    raise AssertionError(f"timed out after {timeout} s waiting for {what} (last error: {error})")


class Redis:
    """A private redis-server on 127.0.0.1:<port>, and a minimal RESP2 client."""

    def __init__(self, directory: str):
        self.binary = shutil.which("redis-server")
        if not self.binary:
            raise AssertionError(
                "redis-server is not installed: the scale-out test needs it "
                "(docker/install-deps.sh installs the Debian package redis-server)")
        self.dir = directory
        self.port = free_port()
        self.proc = None
        self.start()

    def start(self) -> None:
        self.proc = subprocess.Popen(
            [self.binary, "--port", str(self.port), "--bind", "127.0.0.1", "--save", "",
             "--appendonly", "no", "--daemonize", "no", "--dir", self.dir],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        wait_for("redis-server to answer", lambda: self.command("PING") == "PONG", 10)

    def kill(self) -> None:
        if self.proc and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()

    def command(self, *args: str):
        with socket.create_connection(("127.0.0.1", self.port), timeout=2) as s:
            out = f"*{len(args)}\r\n"
            for a in args:
                b = str(a).encode()
                out += f"${len(b)}\r\n" + b.decode() + "\r\n"
            s.sendall(out.encode())
            return self._read(s.makefile("rb"))

    def _read(self, f):
        line = f.readline().rstrip(b"\r\n")
        kind, rest = line[:1], line[1:].decode()
        if kind == b"+":
            return rest
        if kind == b"-":
            raise RuntimeError(rest)
        if kind == b":":
            return int(rest)
        if kind == b"$":
            n = int(rest)
            if n < 0:
                return None
            data = f.read(n + 2)[:-2]
            return data.decode()
        if kind == b"*":
            n = int(rest)
            return None if n < 0 else [self._read(f) for _ in range(n)]
        raise RuntimeError(f"bad RESP line {line!r}")


class Replica:
    def __init__(self, name: str, store: str, redis_port: int, log_dir: str, db: int = 0,
                 extra=()):
        self.name = name
        self.db = db
        self.extra = list(extra)
        self.store = store
        self.redis_port = redis_port
        self.log = os.path.join(log_dir, name + ".log")
        self.start()

    def start(self) -> None:
        with open(self.log, "ab") as log:
            self.proc = subprocess.Popen(
                [SERVER, "--port", "0", "--host", "127.0.0.1", "--store", self.store,
                 "--queue", f"redis://127.0.0.1:{self.redis_port}/{self.db}", "--replica-id", self.name,
                 "--reclaim-idle", str(RECLAIM_IDLE), "--workers", "1", "--job-threads", "1",
                 "--rate-limit", str(RATE), "--rate-burst", str(BURST), "--grace-seconds", "0.3",
                 *self.extra],
                stdout=subprocess.PIPE, stderr=log, text=True)
        line = self.proc.stdout.readline()
        if "listening on" not in line:
            self.proc.kill()
            raise AssertionError(f"replica {self.name} did not start: {line!r}")
        self.url = line.split("listening on ")[1].split(" ")[0]

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGKILL)
        self.proc.wait()
        self.proc.stdout.close()

    def alive(self) -> bool:
        return self.proc.poll() is None


def http(method: str, url: str, body: bytes | None = None, headers=None):
    """(status, headers, body bytes); HTTP errors are answers too."""
    req = urllib.request.Request(url, data=body, method=method, headers=headers or {})
    try:
        with urllib.request.urlopen(req, timeout=30) as r:
            return r.status, dict(r.headers), r.read()
    except urllib.error.HTTPError as e:
        with e:
            return e.code, dict(e.headers), e.read()


def submit(base: str, scene: dict, params: dict):
    query = "&".join(f"{k}={v}" for k, v in params.items())
    status, headers, body = http("POST", f"{base}/v1/jobs?{query}", json.dumps(scene).encode(),
                                 {"Content-Type": "application/json"})
    if status not in (200, 202):
        raise AssertionError(f"submit to {base}: {status} {body[:300]!r}")
    return json.loads(body), headers


def job_status(base: str, job_id: str) -> dict:
    status, _, body = http("GET", f"{base}/v1/jobs/{job_id}")
    if status != 200:
        raise AssertionError(f"GET job {job_id} from {base}: {status} {body[:200]!r}")
    return json.loads(body)


def metric(base: str, name: str) -> float:
    _, _, body = http("GET", f"{base}/metrics")
    for line in body.decode().splitlines():
        if line.startswith(name + " "):
            return float(line.split()[1])
    raise AssertionError(f"no metric {name} at {base}")


def small_scene(k: int) -> dict:
    """Two segments, a little apart: k makes each scene (and its job id) different."""
    return {"dimension": 2, "objects": [
        {"label": "a", "vertices": [[0, 0], [1, 0.1 * k]], "segments": [[0, 1]]},
        {"label": "b", "vertices": [[0, 1], [1, 1]], "segments": [[0, 1]]}]}


class RedisScaleOut(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.dir = fresh_dir("redis-scale")
        cls.store = os.path.join(cls.dir, "shared-store")
        cls.redis = Redis(cls.dir)
        cls.replicas = []
        try:
            cls.replicas = [Replica(f"r{i}", cls.store, cls.redis.port, cls.dir) for i in range(3)]
            cls.single = ServerProcess("--job-threads", "1", name="redis-scale-single")
            for r in cls.replicas:
                wait_for(f"{r.name} ready", lambda r=r: http("GET", f"{r.url}/readyz")[0] == 200, 10)
        except BaseException:
            cls.tearDownClass()
            raise

    @classmethod
    def tearDownClass(cls):
        for r in getattr(cls, "replicas", []):
            r.kill()
        if getattr(cls, "single", None):
            cls.single.stop()
        cls.redis.kill()

    # ---- helpers ----------------------------------------------------------------------------

    def live(self):
        return [r for r in self.replicas if r.alive()]

    def wait_done(self, base: str, job_id: str, timeout: float) -> dict:
        def done():
            s = job_status(base, job_id)
            self.assertNotIn(s["status"], ("failed", "cancelled"), json.dumps(s)[:500])
            return s if s["status"] == "done" else None
        return wait_for(f"job {job_id} done", done, timeout)

    def reference(self, scene: dict, params: dict):
        """The single-node outputs of a job ({name: bytes}) and its run time, seconds."""
        t0 = time.monotonic()
        job, _ = submit(self.single.url, scene, params)
        self.wait_done(self.single.url, job["id"], 60)
        return self.outputs(self.single.url, job["id"]), time.monotonic() - t0

    @staticmethod
    def outputs(base: str, job_id: str) -> dict:
        out = {}
        for name in ("gvd.glb", "graph", "gvd.json"):
            status, _, body = http("GET", f"{base}/v1/jobs/{job_id}/{name}")
            assert status == 200, (name, status, body[:200])
            out[name] = body
        return out

    def worker_of(self, job_id: str):
        w = self.redis.command("HGET", f"gvd:job:{job_id}", "worker")
        return w.rsplit("-", 1)[0] if w else None

    # ---- tests (run in this order) ----------------------------------------------------------

    def test_1_jobs_spread_over_workers_and_match_a_single_node(self):
        scene = slow_scene()
        jobs = []
        for k, depth in enumerate((7, 8, 7, 8, 7, 8)):
            base = self.replicas[k % 3].url
            job, _ = submit(base, scene, {"contact_depth": depth, "max_depth": 12 + k})
            jobs.append((job["id"], {"contact_depth": depth, "max_depth": 12 + k}))
        workers = set()
        for job_id, _ in jobs:
            self.wait_done(self.replicas[2].url, job_id, 60)
            workers.add(self.worker_of(job_id))
        self.assertEqual(workers, {"r0", "r1", "r2"}, "six jobs submitted at once ran on every worker")
        # Any replica serves the outputs from the shared store; they equal a single node's.
        job_id, params = jobs[0]
        expected, _ = self.reference(scene, params)
        for r in self.replicas:
            self.assertEqual(self.outputs(r.url, job_id), expected, r.name)

    def test_2_duplicate_submissions_to_three_replicas_are_one_job(self):
        scene = small_scene(3)
        params = {"max_depth": 9}
        before = sum(metric(r.url, "gvd_jobs_submitted_total") for r in self.replicas)
        answers = []
        barrier = threading.Barrier(3)

        def post(r):
            barrier.wait()
            answers.append(submit(r.url, scene, params))
        threads = [threading.Thread(target=post, args=(r,)) for r in self.replicas]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        ids = {job["id"] for job, _ in answers}
        self.assertEqual(len(ids), 1)
        misses = [h.get("X-Gvd-Cache") for _, h in answers].count("miss")
        self.assertEqual(misses, 1, "exactly one submission created the job")
        after = sum(metric(r.url, "gvd_jobs_submitted_total") for r in self.replicas)
        self.assertEqual(after - before, 1)
        self.wait_done(self.replicas[0].url, ids.pop(), 30)

    def test_2b_queued_jobs_know_their_place_in_the_cluster_queue(self):
        # Every worker busy with a long job; three more wait, and any replica says where.
        scene = slow_scene()
        long_jobs = []
        for k in range(3):
            job, _ = submit(self.replicas[k].url, scene, {"contact_depth": 12, "max_depth": 17 - k})
            long_jobs.append(job["id"])
        for job_id in long_jobs:
            wait_for("the long jobs to start", lambda j=job_id: self.worker_of(j), 20)
        waiting = []
        for k in range(3):
            job, _ = submit(self.replicas[(k + 1) % 3].url, small_scene(20 + k), {"max_depth": 9})
            waiting.append(job["id"])
        try:
            for position, job_id in enumerate(waiting, 1):
                for r in self.replicas:
                    s = job_status(r.url, job_id)
                    self.assertEqual(s["status"], "queued", json.dumps(s)[:300])
                    self.assertEqual(s.get("queue_position"), position, (r.name, json.dumps(s)[:300]))
        finally:
            for job_id in long_jobs:
                http("DELETE", f"{self.replicas[0].url}/v1/jobs/{job_id}")
        for job_id in waiting:
            done = self.wait_done(self.replicas[0].url, job_id, 60)
            self.assertNotIn("queue_position", done)

    def test_2c_a_labelled_volume_is_converted_by_the_worker_that_runs_it(self):
        # 12^3 uint8 labels: 1 below z = 4, 3 above z = 8 for x < 6, 2 elsewhere.
        n = 12
        voxels = bytes(1 if z < 4 else (3 if z >= 8 and x < 6 else 2)
                       for z in range(n) for y in range(n) for x in range(n))
        header = "{'descr': '|u1', 'fortran_order': False, 'shape': (%d, %d, %d), }" % (n, n, n)
        header += " " * ((64 - (10 + len(header) + 1) % 64) % 64) + "\n"
        npy = b"\x93NUMPY\x01\x00" + len(header).to_bytes(2, "little") + header.encode() + voxels
        query = "spacing=1,1,2&max_depth=6"
        ids = set()
        for base in (self.replicas[0].url, self.single.url):
            status, _, body = http("POST", f"{base}/v1/jobs?{query}", npy,
                                   {"Content-Type": "application/x-npy"})
            self.assertEqual(status, 202, body[:300])
            job = json.loads(body)
            self.assertEqual(job["scene"]["objects"], 0, "converted before it was queued")
            ids.add(job["id"])
        self.assertEqual(len(ids), 1, "one volume and one set of parameters: one job id")
        job_id = ids.pop()
        done = self.wait_done(self.replicas[2].url, job_id, 60)
        self.assertEqual(done["scene"]["objects"], 3, json.dumps(done)[:500])
        self.wait_done(self.single.url, job_id, 60)
        graph = lambda base: json.loads(http("GET", f"{base}/v1/jobs/{job_id}/graph")[2])
        self.assertEqual(graph(self.replicas[1].url)["edges"], graph(self.single.url)["edges"])

    def test_3_progress_events_through_a_replica_that_does_not_run_the_job(self):
        scene = slow_scene()
        params = dict(SLOW, max_depth=14)
        job, _ = submit(self.replicas[0].url, scene, params)
        wait_for("the job to start", lambda: self.worker_of(job["id"]), 20)
        worker = self.worker_of(job["id"])
        other = next(r for r in self.replicas if r.name != worker)
        events = []
        with urllib.request.urlopen(f"{other.url}/v1/jobs/{job['id']}/events", timeout=60) as r:
            name = None
            for raw in r:
                line = raw.decode().rstrip("\n")
                if line.startswith("event: "):
                    name = line[7:]
                elif line.startswith("data: "):
                    events.append((name, json.loads(line[6:])))
                    if name in ("done", "failed", "cancelled"):
                        break
        self.assertEqual(events[-1][0], "done", [e[0] for e in events])
        running = [d for n, d in events if n == "status" and d["status"] == "running"]
        self.assertTrue(running, "running documents were relayed")
        fractions = [d["progress"]["fraction"] for d in running]
        self.assertTrue(any(f > 0 for f in fractions), fractions)
        self.assertEqual(fractions, sorted(fractions), "progress never goes back")

    def test_4_kill_9_of_the_worker_running_a_job(self):
        scene = slow_scene()
        params = dict(SLOW, max_depth=15)
        expected, run_seconds = self.reference(scene, params)
        job, _ = submit(self.replicas[1].url, scene, params)
        wait_for("the job to start", lambda: self.worker_of(job["id"]), 20)
        victim_name = self.worker_of(job["id"])
        victim = next(r for r in self.replicas if r.name == victim_name)
        # Killed while it runs (its stages show progress).
        wait_for("progress", lambda: job_status(victim.url, job["id"])["progress"]["stages"], 20)
        reclaimed_before = sum(metric(r.url, "gvd_queue_reclaimed_total") for r in self.live())
        victim.kill()
        killed_at = time.monotonic()
        survivor = next(r for r in self.live())
        done = self.wait_done(survivor.url, job["id"], 60)
        took = time.monotonic() - killed_at
        self.assertNotEqual(self.worker_of(job["id"]), victim_name)
        self.assertTrue(done.get("recovered"), "the document says the job was taken over")
        # --reclaim-idle, plus a quarter of it (how often idle workers look), plus the run
        # time (with a margin: two other replicas share the two cores).
        self.assertLess(took, 1.25 * RECLAIM_IDLE + 2 * run_seconds + 2,
                        f"taken over within the idle time + its run time ({run_seconds:.1f} s)")
        reclaimed_after = sum(metric(r.url, "gvd_queue_reclaimed_total") for r in self.live())
        self.assertGreaterEqual(reclaimed_after - reclaimed_before, 1)
        for r in self.live():
            self.assertEqual(self.outputs(r.url, job["id"]), expected, r.name)
        # Nothing pending is left behind: the stream holds no entry of a finished job.
        self.assertEqual(self.redis.command("XLEN", "gvd:queue"), 0)
        victim.start()  # back to three replicas
        wait_for("restarted replica ready",
                 lambda: http("GET", f"{victim.url}/readyz")[0] == 200, 10)

    def test_4b_sigterm_hands_a_running_job_back_at_once(self):
        scene = slow_scene()
        params = {"contact_depth": 12, "max_depth": 15}
        job, _ = submit(self.replicas[0].url, scene, params)
        wait_for("the job to start", lambda: self.worker_of(job["id"]), 20)
        leaving = next(r for r in self.replicas if r.name == self.worker_of(job["id"]))
        wait_for("progress", lambda: job_status(leaving.url, job["id"])["progress"]["stages"], 20)
        survivors = [r for r in self.replicas if r is not leaving]
        reclaimed_before = sum(metric(r.url, "gvd_queue_reclaimed_total") for r in survivors)
        leaving.proc.send_signal(signal.SIGTERM)
        self.assertEqual(leaving.proc.wait(timeout=20), 0)
        leaving.proc.stdout.close()
        # Started again elsewhere well before --reclaim-idle: queued again, not reclaimed.
        wait_for("another worker", lambda: self.worker_of(job["id"]) not in (None, leaving.name),
                 RECLAIM_IDLE * 0.75)
        self.wait_done(survivors[0].url, job["id"], 60)
        reclaimed_after = sum(metric(r.url, "gvd_queue_reclaimed_total") for r in survivors)
        self.assertEqual(reclaimed_after, reclaimed_before)
        leaving.start()
        wait_for("restarted replica ready",
                 lambda: http("GET", f"{leaving.url}/readyz")[0] == 200, 10)

    def test_5_redis_restarted_mid_run(self):
        scene = slow_scene()
        # The jobs listed before (all finished by now): listed again after the restart.
        status, _, body = http("GET", f"{self.replicas[0].url}/v1/jobs")
        self.assertEqual(status, 200)
        listed_before = {j["id"]: j["status"] for j in json.loads(body)["jobs"]
                         if j["status"] in ("done", "failed")}
        self.assertGreater(len(listed_before), 3)
        first, _ = submit(self.replicas[0].url, scene, dict(SLOW, max_depth=16))
        queued = [submit(self.replicas[k % 3].url, small_scene(10 + k), {"max_depth": 9})[0]
                  for k in range(4)]
        wait_for("the first job to start", lambda: self.worker_of(first["id"]), 20)
        self.redis.kill()
        # Every replica says it cannot reach the queue, and keeps running.
        for r in self.replicas:
            wait_for(f"{r.name} /readyz 503",
                     lambda r=r: http("GET", f"{r.url}/readyz")[0] == 503, 10)
            status, headers, body = http("POST", f"{r.url}/v1/jobs",
                                         json.dumps(small_scene(99)).encode(),
                                         {"Content-Type": "application/json"})
            self.assertEqual(status, 503, body[:200])
            self.assertIn("Retry-After", headers)
            problem = json.loads(body)
            self.assertEqual(problem["type"], "/problems/queue-unavailable")
            self.assertIn("unreachable", problem["detail"])
        self.redis.start()  # empty: no persistence
        for r in self.replicas:
            wait_for(f"{r.name} ready again",
                     lambda r=r: http("GET", f"{r.url}/readyz")[0] == 200, 15)
            self.assertTrue(r.alive())
        for job in [first] + queued:
            self.wait_done(self.replicas[1].url, job["id"], 60)
        for r in self.replicas:
            status, _, body = http("GET", f"{r.url}/v1/jobs")
            listed = {j["id"]: j["status"] for j in json.loads(body)["jobs"]}
            for job_id, was in listed_before.items():
                self.assertEqual(listed.get(job_id), was, (r.name, job_id))
        # A new job after the restart.
        new, _ = submit(self.replicas[2].url, small_scene(42), {"max_depth": 9})
        self.wait_done(self.replicas[0].url, new["id"], 30)
        # Duplicate entries (queued again from the store while still running) are dropped.
        wait_for("an empty stream", lambda: self.redis.command("XLEN", "gvd:queue") == 0, 10)

    def test_6_cancel_reaches_the_worker_through_another_replica(self):
        scene = slow_scene()
        job, _ = submit(self.replicas[0].url, scene, {"contact_depth": 12, "max_depth": 17})
        wait_for("the job to start", lambda: self.worker_of(job["id"]), 20)
        worker = self.worker_of(job["id"])
        other = next(r for r in self.replicas if r.name != worker)
        status, _, body = http("DELETE", f"{other.url}/v1/jobs/{job['id']}")
        self.assertIn(status, (200, 202), body[:200])
        cancelled = wait_for(
            "the worker to stop the job",
            lambda: (lambda s: s if s["status"] == "cancelled" else None)(
                job_status(other.url, job["id"])), 10)
        self.assertIn("DELETE", cancelled["error"]["detail"])
        status, _, _ = http("GET", f"{other.url}/v1/jobs/{job['id']}/gvd.glb")
        self.assertEqual(status, 409)
        # Forgotten by a second DELETE, on every replica.
        self.assertEqual(http("DELETE", f"{other.url}/v1/jobs/{job['id']}")[0], 204)
        for r in self.replicas:
            self.assertEqual(http("GET", f"{r.url}/v1/jobs/{job['id']}")[0], 404)

    def test_7_one_client_cannot_starve_others_across_replicas(self):
        scene, params = small_scene(3), {"max_depth": 9}  # done already: cheap cache hits
        body = json.dumps(scene).encode()
        query = "&".join(f"{k}={v}" for k, v in params.items())

        def post(r, client):
            return http("POST", f"{r.url}/v1/jobs?{query}", body,
                        {"Content-Type": "application/json", "X-Client-Id": client})
        t0 = time.monotonic()
        answers = [post(self.replicas[k % 3], "greedy") for k in range(2 * BURST)]
        elapsed = time.monotonic() - t0
        admitted = sum(1 for status, _, _ in answers if status in (200, 202))
        refused = [a for a in answers if a[0] == 429]
        self.assertEqual(admitted + len(refused), 2 * BURST)
        # One bucket for the cluster, not one per replica (that would admit all 60).
        self.assertGreaterEqual(admitted, BURST)
        self.assertLessEqual(admitted, BURST + RATE * elapsed + 1)
        status, headers, problem = refused[0]
        self.assertIn("Retry-After", headers)
        self.assertIn("greedy", json.loads(problem)["detail"])
        self.assertEqual(json.loads(problem)["type"], "/problems/rate-limited")
        # Another client is served at once.
        self.assertEqual(post(self.replicas[0], "patient")[0], 200)

    def test_9_a_job_whose_workers_keep_dying_fails_after_max_deliveries(self):
        # A cluster of its own: Redis database 1, its own store, --max-deliveries 1.
        store = os.path.join(self.dir, "store-db1")
        pair = [Replica(f"m{i}", store, self.redis.port, self.dir, db=1,
                        extra=["--max-deliveries", "1"]) for i in range(2)]
        try:
            for r in pair:
                wait_for(f"{r.name} ready", lambda r=r: http("GET", f"{r.url}/readyz")[0] == 200, 10)
            job, _ = submit(pair[0].url, slow_scene(), {"contact_depth": 12, "max_depth": 13})
            worker = lambda: self.redis.command("EVAL", "redis.call('SELECT', 1) return "
                                                "redis.call('HGET', KEYS[1], 'worker')", "1",
                                                f"gvd:job:{job['id']}")
            wait_for("the job to start", worker, 20)
            victim = next(r for r in pair if worker().startswith(r.name + "-"))
            survivor = next(r for r in pair if r is not victim)
            victim.kill()
            failed = wait_for(
                "the job to fail",
                lambda: (lambda s: s if s["status"] == "failed" else None)(
                    job_status(survivor.url, job["id"])), RECLAIM_IDLE * 1.25 + 5)
            self.assertIn("--max-deliveries 1", failed["error"]["detail"])
            self.assertIn("stopped", failed["error"]["detail"])
        finally:
            for r in pair:
                r.kill()

    def test_10_the_cli_works_against_any_replica(self):
        scene = os.path.join(DATA, "scenes", "gears2d.json")
        out = os.path.join(self.dir, "cli")
        os.makedirs(out, exist_ok=True)
        for r in (self.replicas[2], self.single):
            glb = os.path.join(out, ("replica" if r is not self.single else "single") + ".glb")
            p = subprocess.run([CLI, "--server", r.url, "compute", scene, "-o", glb],
                               capture_output=True, text=True, timeout=60)
            self.assertEqual(p.returncode, 0, p.stderr[-2000:])
        with open(os.path.join(out, "replica.glb"), "rb") as a, \
                open(os.path.join(out, "single.glb"), "rb") as b:
            self.assertEqual(a.read(), b.read())

    def test_8_metrics_and_readiness(self):
        for r in self.replicas:
            status, _, body = http("GET", f"{r.url}/readyz")
            self.assertEqual(status, 200)
            doc = json.loads(body)
            self.assertEqual(doc["queue"], "redis")
            self.assertEqual(doc["replica"], r.name)
            self.assertEqual(metric(r.url, "gvd_queue_redis_up"), 1)
            # Refreshed twice a second: nothing stays pending once every job is done.
            wait_for(f"{r.name} pending 0",
                     lambda r=r: metric(r.url, "gvd_queue_pending_entries") == 0, 5)
            self.assertGreaterEqual(metric(r.url, "gvd_queue_redis_reconnects_total"), 1)


class InProcessTokenBucket(unittest.TestCase):
    """--rate-limit without Redis: one bucket per client in the process."""

    def test_a_client_over_its_rate_is_refused_others_are_not(self):
        with ServerProcess("--rate-limit", "1", "--rate-burst", "3", name="bucket") as server:
            body = json.dumps(small_scene(7)).encode()

            def post(client):
                return http("POST", f"{server.url}/v1/jobs?max_depth=6", body,
                            {"Content-Type": "application/json", "X-Client-Id": client})
            statuses = [post("a")[0] for _ in range(5)]
            self.assertTrue(all(s in (200, 202) for s in statuses[:3]), statuses)
            self.assertEqual(statuses[3:], [429, 429])
            status, headers, _ = post("a")
            self.assertEqual(status, 429)
            self.assertEqual(headers.get("Retry-After"), "1")
            self.assertIn(post("b")[0], (200, 202))


if __name__ == "__main__":
    os.makedirs(OUTPUT, exist_ok=True)
    unittest.main()
