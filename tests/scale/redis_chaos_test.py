"""A batch of 50 jobs through three replicas while workers and Redis are killed at random
times (kill -9, then started again; Redis comes back empty; GVD_CHAOS_DEPTH and
GVD_CHAOS_SECONDS make the jobs longer and the chaos last longer): every job ends done, each output
byte-identical to a single-node run. The client retries what a real client retries (503 with
Retry-After, refused connections) on another replica. Seeded (GVD_CHAOS_SEED) for replays."""

from __future__ import annotations

import json
import os
import random
import sys
import time
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from redis_scale_test import (Redis, Replica, ServerProcess, fresh_dir, http,  # noqa: E402
                              slow_scene, small_scene, wait_for)

JOBS = 50
CHAOS_SECONDS = float(os.environ.get("GVD_CHAOS_SECONDS", "12"))
DEPTH = int(os.environ.get("GVD_CHAOS_DEPTH", "5"))  # 3D jobs: contact_depth DEPTH..DEPTH+4


def job_spec(k: int):
    """Half small 2D jobs, half 3D jobs of 0.05-0.5 s."""
    if k % 2 == 0:
        return small_scene(k + 1), {"max_depth": 8}
    return slow_scene(), {"contact_depth": DEPTH + (k // 2) % 5, "max_depth": 10 + k // 10}


class Chaos(unittest.TestCase):
    def test_fifty_jobs_survive_killed_workers_and_redis(self):
        seed = int(os.environ.get("GVD_CHAOS_SEED", str(int(time.time()))))
        rng = random.Random(seed)
        print(f"GVD_CHAOS_SEED={seed}", file=sys.stderr)
        directory = fresh_dir("redis-chaos")
        store = os.path.join(directory, "shared-store")
        redis = Redis(directory)
        replicas = [Replica(f"c{i}", store, redis.port, directory) for i in range(3)]
        single = ServerProcess("--job-threads", "1", name="redis-chaos-single")
        try:
            specs = [job_spec(k) for k in range(JOBS)]
            self.assertEqual(len({json.dumps(s, sort_keys=True) for s in specs}), JOBS)
            pending = list(range(JOBS))
            ids = {}
            t_end = time.monotonic() + CHAOS_SECONDS
            next_fault = time.monotonic() + rng.uniform(0.3, 1.5)
            redis_down_until = None
            next_submit = time.monotonic()  # spread over the chaos: faults hit running jobs
            while pending or time.monotonic() < t_end:
                now = time.monotonic()
                if redis_down_until and now >= redis_down_until:
                    redis.start()
                    redis_down_until = None
                if now < t_end and now >= next_fault and not redis_down_until:
                    victim = rng.randrange(4)
                    if victim == 3:
                        redis.kill()
                        redis_down_until = now + rng.uniform(0.2, 1.5)
                    else:
                        replicas[victim].kill()
                        replicas[victim].start()
                    next_fault = now + rng.uniform(0.3, 1.5)
                if pending and now >= next_submit:
                    k = pending[0]
                    scene, params = specs[k]
                    r = rng.choice(replicas)
                    query = "&".join(f"{a}={b}" for a, b in params.items())
                    try:
                        status, _, body = http("POST", f"{r.url}/v1/jobs?{query}",
                                               json.dumps(scene).encode(),
                                               {"Content-Type": "application/json"})
                    except OSError:
                        status, body = 0, b""
                    if status in (200, 202):
                        ids[k] = json.loads(body)["id"]
                        pending.pop(0)
                        next_submit = now + 0.8 * CHAOS_SECONDS / JOBS
                    elif status not in (0, 503):
                        self.fail(f"submission {k}: {status} {body[:300]!r}")
                time.sleep(0.02)
            if redis_down_until:
                redis.start()

            def all_done():
                for k, job_id in ids.items():
                    try:
                        status, _, body = http("GET", f"{rng.choice(replicas).url}/v1/jobs/{job_id}")
                    except OSError:
                        return False
                    if status != 200:
                        return False
                    doc = json.loads(body)
                    self.assertNotIn(doc["status"], ("failed", "cancelled"), json.dumps(doc)[:600])
                    if doc["status"] != "done":
                        return False
                return True
            wait_for("all 50 jobs done", all_done, 120, 0.25)
            # Each output equals a single-node run.
            for k in range(JOBS):
                scene, params = specs[k]
                query = "&".join(f"{a}={b}" for a, b in params.items())
                status, _, body = http("POST", f"{single.url}/v1/jobs?{query}",
                                       json.dumps(scene).encode(),
                                       {"Content-Type": "application/json"})
                self.assertIn(status, (200, 202))
                self.assertEqual(json.loads(body)["id"], ids[k])
            for k in range(JOBS):
                wait_for("reference", lambda k=k: json.loads(
                    http("GET", f"{single.url}/v1/jobs/{ids[k]}")[2])["status"] == "done", 120)
                mine = http("GET", f"{replicas[k % 3].url}/v1/jobs/{ids[k]}/gvd.glb")
                theirs = http("GET", f"{single.url}/v1/jobs/{ids[k]}/gvd.glb")
                self.assertEqual(mine[0], 200)
                self.assertEqual(mine[2], theirs[2], f"job {k} ({ids[k]}), seed {seed}")
        finally:
            for r in replicas:
                r.kill()
            single.stop()
            redis.kill()


if __name__ == "__main__":
    unittest.main()
