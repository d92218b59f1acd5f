# shellcheck shell=bash
# Shared by the gvd-server load tests (bench_server.sh, bench_overload.sh); sourced, not run.
# bench_start_server BUILD ARGS...: gvd-server on a free loopback port with a temporary store
# (pid, store, out, base set; bench_stop_server removes them). bench_compute SCENE: posts the
# scene and waits until its job is done (id set).

bench_start_server() {
  local build=$1
  shift
  store=$(mktemp -d)
  out=$(mktemp)
  "$build/server/gvd-server" --port 0 --store "$store" --quiet "$@" >"$out" 2>&1 &
  pid=$!
  for _ in $(seq 50); do grep -q listening "$out" && break; sleep 0.1; done
  port=$(grep -o 'http://[^ ]*' "$out" | sed 's/.*://')
  base="http://127.0.0.1:$port"
}

bench_stop_server() {
  kill "$pid" 2>/dev/null || true
  wait "$pid" 2>/dev/null || true
  rm -rf "$store" "$out"
}

bench_compute() {
  id=$(curl -sS -X POST -H 'Content-Type: application/json' --data-binary "@$1" "$base/v1/jobs" |
       sed 's/.*"id":"\([0-9a-f]*\)".*/\1/')
  for _ in $(seq 300); do
    curl -sS "$base/v1/jobs/$id" | grep -q '"status":"done"' && break
    sleep 0.1
  done
}
