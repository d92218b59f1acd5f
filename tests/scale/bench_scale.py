"""make bench-scale: throughput of the Redis Streams queue with 1, 2 and 3 worker replicas and
the queue's own overhead per job against the in-process queue, in one run, on loopback.

Throughput: JOBS distinct small 3D jobs (about 0.1 s each with one thread) submitted at once,
wall time until all are done. Overhead: TINY distinct tiny 2D jobs (a few ms) one after the
other (submit, then poll every 1 ms until done), alternating between a single-node server and
a single Redis replica running side by side; the median time per job through Redis minus the
median through the in-process queue. Usage:
  python3 tests/scale/bench_scale.py [BUILD_DIR]"""

from __future__ import annotations

import os
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
BUILD = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.path.join(HERE, "..", "..", "build"))
os.environ.setdefault("GVD_SERVER", os.path.join(BUILD, "server", "gvd-server"))
os.environ.setdefault("GVD_TEST_OUTPUT_DIR", os.path.join(BUILD, "test-output"))
sys.path.insert(0, HERE)
from redis_scale_test import (Redis, Replica, ServerProcess, http, job_status,  # noqa: E402
                              slow_scene, small_scene, submit, wait_for)

JOBS = 24
TINY = 60


def run_batch(urls) -> float:
    """Seconds until JOBS distinct jobs, submitted round-robin to `urls`, are all done."""
    scene = slow_scene()
    t0 = time.monotonic()
    ids = []
    for k in range(JOBS):
        job, _ = submit(urls[k % len(urls)], scene,
                        {"contact_depth": 5 + k % 3, "max_depth": 10 + k // 3})
        ids.append(job["id"])
    for job_id in ids:
        wait_for("done", lambda: job_status(urls[0], job_id)["status"] == "done", 300, 0.005)
    return time.monotonic() - t0


def one_job(url: str, k: int) -> float:
    """Seconds from submission to done of one new tiny job."""
    t0 = time.monotonic()
    job, _ = submit(url, small_scene(k), {"max_depth": 5})
    wait_for("done", lambda: job_status(url, job["id"])["status"] == "done", 60, 0.001)
    return time.monotonic() - t0


def median(values):
    v = sorted(values)
    return v[len(v) // 2]


def main() -> int:
    os.makedirs(os.environ["GVD_TEST_OUTPUT_DIR"], exist_ok=True)
    work = tempfile.mkdtemp(prefix="bench-scale-", dir=os.environ["GVD_TEST_OUTPUT_DIR"])
    print(f"gvd bench-scale: {os.cpu_count()} cores; {JOBS} jobs per batch, {TINY} tiny jobs")
    single = ServerProcess("--job-threads", "1", name="bench-scale-single")
    try:
        inproc_batch = run_batch([single.url])
    except BaseException:
        single.stop()
        raise
    print(f"in-process queue, 1 worker:   {JOBS / inproc_batch:6.1f} jobs/s")
    redis = Redis(work)
    replicas = []
    try:
        rows = []
        for n in (1, 2, 3):
            store = os.path.join(work, f"store-{n}")
            redis.command("FLUSHALL")
            replicas = [Replica(f"b{n}-{i}", store, redis.port, work) for i in range(n)]
            for r in replicas:
                wait_for("ready", lambda r=r: http("GET", f"{r.url}/readyz")[0] == 200, 10)
            seconds = run_batch([r.url for r in replicas])
            rows.append((n, JOBS / seconds))
            print(f"redis queue, {n} worker replica{'s' if n > 1 else ' '}: {JOBS / seconds:6.1f} jobs/s")
            if n == 1:
                inproc, via_redis = [], []
                for k in range(TINY):  # alternating, side by side
                    inproc.append(one_job(single.url, 1000 + k))
                    via_redis.append(one_job(replicas[0].url, 2000 + k))
                inproc_tiny, redis_tiny = median(inproc), median(via_redis)
                single.stop()
            for r in replicas:
                r.kill()
            replicas = []
        print(f"tiny job, submit -> done (median of {TINY}): in-process {inproc_tiny * 1000:.2f} ms, "
              f"redis {redis_tiny * 1000:.2f} ms: queue overhead "
              f"{(redis_tiny - inproc_tiny) * 1000:+.2f} ms per job")
        print("(jobs/s cannot grow past the core count: here the replicas share "
              f"{os.cpu_count()} cores)")
    finally:
        for r in replicas:
            r.kill()
        redis.kill()
        single.stop()
    return 0


if __name__ == "__main__":
    sys.exit(main())
