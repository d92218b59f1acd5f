#!/usr/bin/env bash
# Load test of gvd-server on loopback (make bench-server): starts the server on a free port
# with a temporary store, computes a bundled scene, then runs wrk (bounded: DURATION seconds
# per route, CONNECTIONS connections, 127.0.0.1 only) against /healthz, a cached k-ring
# neighbour query and a nearest-object query (as fast as they go), then the neighbour query at
# about 5,000 requests per second. Prints wrk's latency distribution per run.
#
#   tests/service/bench_server.sh BUILD_DIR [DURATION] [CONNECTIONS]
set -euo pipefail
build=${1:?usage: bench_server.sh BUILD_DIR [DURATION] [CONNECTIONS]}
duration=${2:-10}
connections=${3:-8}
here=$(cd "$(dirname "$0")/../.." && pwd)
command -v wrk >/dev/null || { echo "bench_server: wrk is not installed (docker/install-deps.sh)"; exit 2; }

# shellcheck source=tests/service/bench_common.sh
. "$here/tests/service/bench_common.sh"
trap bench_stop_server EXIT
bench_start_server "$build" --http-threads 16

scene="$here/tests/data/scenes/balls_on_plate.json"
bench_compute "$scene"
label=$(curl -sS "$base/v1/jobs/$id/graph" | sed 's/.*"nodes":\[{"label":"\([^"]*\)".*/\1/')
# Warm the result cache and the query index.
curl -sS -o /dev/null "$base/v1/jobs/$id/objects/$label/neighbors?ring=1"
echo "gvd-server load test: $(nproc) cores, wrk -t2 -c$connections -d${duration}s, job $id ($scene), label $label"
for path in "/healthz" "/v1/jobs/$id/objects/$label/neighbors?ring=1" "/v1/jobs/$id/nearest?point=0.1,0.2,0.3"; do
  echo "== GET $path"
  wrk -t2 -c"$connections" -d"${duration}s" --latency "$base$path" | sed -n '/Latency Distribution/,/Transfer/p'
done
# At a fixed offered rate (the issue's target: p99 below 2 ms at 5,000 requests per second):
# 12 connections, each sending a request every 2 ms (plus the answer time).
echo "== GET /v1/jobs/$id/objects/$label/neighbors?ring=1 at ~5000 requests/s (12 connections, 1 per 2 ms each)"
PACE_MS=2 wrk -t2 -c12 -d"${duration}s" --latency -s "$here/tests/service/pace.lua" \
  "$base/v1/jobs/$id/objects/$label/neighbors?ring=1" | sed -n '/Latency Distribution/,/Transfer/p'
echo "== errors in /metrics (status >= 400):"
curl -sS "$base/metrics" | grep '^gvd_http_requests_total' | grep -v 'status="[23]' || echo "none"
