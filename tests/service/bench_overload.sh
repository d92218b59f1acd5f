#!/usr/bin/env bash
# Overload test of gvd-server on loopback: the server with its defaults (128 HTTP
# threads) holds the bundled balls_on_plate result, then
#   1. wrk -c256 on the cached neighbour query, as fast as it goes (256 connections, twice
#      the threads);
#   2. the same query at ~5,000 requests/s over 256 connections: (a) as independent clients
#      (exponential gaps), (b) in step (fixed gaps: bursts);
#   3. HOLD connections (default 500) each send the headers of a POST and then one body byte
#      a second, which holds a thread per connection reading it (request bodies are read in
#      the threads); meanwhile curl probes /healthz and /readyz and wrk -c8 asks for the
#      neighbour query. At most --max-body-readers threads (default 64, half of them) read
#      bodies, and the holders, all from 127.0.0.1, only --max-body-readers-per-client of
#      them (default 16, a quarter): the other POSTs are refused at once (503 + Retry-After,
#      before their body), and the query is served by the free threads. With
#      EXTRA_ARGS="--max-body-readers 128 --max-body-readers-per-client 128" the
#      bodies take every thread and fill the queue (500 > 128 threads + 256 queued): then the
#      excess must be answered at once (503 overloaded), not queued behind bodies that take
#      minutes, and the probes still answered (they have threads of their own).
# Bounded runs, 127.0.0.1 only. EXTRA_ARGS are added to the server's command line.
#
#   tests/service/bench_overload.sh BUILD_DIR [DURATION] [HOLD]
set -euo pipefail
build=${1:?usage: bench_overload.sh BUILD_DIR [DURATION] [HOLD]}
duration=${2:-10}
hold=${3:-500}
here=$(cd "$(dirname "$0")/../.." && pwd)
command -v wrk >/dev/null || { echo "bench_overload: wrk is not installed"; exit 2; }

# shellcheck source=tests/service/bench_common.sh
. "$here/tests/service/bench_common.sh"
holder=
cleanup() {
  [ -n "$holder" ] && { kill "$holder" 2>/dev/null || true; wait "$holder" 2>/dev/null || true; }
  bench_stop_server
}
trap cleanup EXIT
# shellcheck disable=SC2086
bench_start_server "$build" ${EXTRA_ARGS:-}

bench_compute "$here/tests/data/scenes/balls_on_plate.json"
query="$base/v1/jobs/$id/objects/ball_0/neighbors?ring=1"
curl -sS -o /dev/null "$query"
echo "gvd-server overload test: $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg), job $id"

echo "== 1. GET neighbors?ring=1, wrk -t2 -c256 -d${duration}s (as fast as possible)"
wrk -t2 -c256 -d"${duration}s" --latency "$query" | sed -n '/Latency Distribution/,/Transfer/p'

echo "== 2a. the same at ~5,000 requests/s from 256 independent clients (each connection waits"
echo "   an exponentially distributed time of mean 51 ms between requests: Poisson arrivals)"
PACE_GAPS=exponential PACE_MS=51 wrk -t2 -c256 -d"${duration}s" --latency \
  -s "$here/tests/service/pace.lua" "$query" | sed -n '/Latency Distribution/,/Transfer/p'

for gap in 25 13; do
  echo "== 2a'. independent clients beyond: mean gap $gap ms, ~$((256 * 1000 / gap)) requests/s offered"
  PACE_GAPS=exponential PACE_MS=$gap wrk -t2 -c256 -d"${duration}s" --latency \
    -s "$here/tests/service/pace.lua" "$query" | sed -n '/Latency Distribution/,/Transfer/p'
done

echo "== 2b. ~5,000 requests/s in bursts (each connection waits exactly 51 ms; wrk starts them"
echo "   at once, so the 256 connections send in step: bursts of up to 256 requests)"
PACE_MS=51 wrk -t2 -c256 -d"${duration}s" --latency -s "$here/tests/service/pace.lua" "$query" |
  sed -n '/Latency Distribution/,/Transfer/p'

echo "== 3. $hold connections holding a thread each (a body byte a second), for ${duration}s"
python3 - "$port" "$hold" "$((duration + 30))" <<'EOF' &
import socket, sys, time
port, n, seconds = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3])
head = (b"POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
        b"Content-Length: 100000\r\n\r\n{")
socks = []
for _ in range(n):
    s = socket.create_connection(("127.0.0.1", port))
    s.sendall(head)
    socks.append(s)
end = time.time() + seconds
while time.time() < end:
    time.sleep(1)
    for s in socks:
        try:
            s.send(b" ")
        except OSError:
            pass
EOF
holder=$!
sleep 2
for probe in /healthz /readyz; do
  for _ in 1 2 3; do
    # 000 = no answer within 2 s
    curl -sS -o /dev/null -m 2 -w "$probe: %{http_code} in %{time_total} s\n" "$base$probe" 2>/dev/null ||
      true
  done
done
curl -sS -D - -o /dev/null -m 2 "$query" 2>/dev/null | grep -i -E '^(HTTP|retry-after)' ||
  echo "neighbors: no answer within 2 s"
wrk -t2 -c8 -d"${duration}s" --timeout 2s --latency "$query" |
  sed -n '/Latency Distribution/,/Non-2xx/p'
kill "$holder" 2>/dev/null || true
wait "$holder" 2>/dev/null || true
holder=
sleep 1
curl -sS -o /dev/null -m 5 -w "after the load: neighbors %{http_code} in %{time_total} s\n" "$query"
echo "== /metrics afterwards (overload counters):"
curl -sS -m 5 "$base/metrics" | grep -E '^gvd_http_(requests_overloaded_total|queued|busy|max_queued|connections_evicted|body_|probes)' ||
  echo "(none)"
