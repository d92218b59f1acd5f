#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "gvd/compute/compute_backend.h"

namespace gvd::server {

/// Everything gvd-server can be told, by flag (`--max-body 1000`) or by the matching
/// environment variable (`GVD_MAX_BODY=1000`); a flag wins over the environment.
struct ServerOptions {
  std::string host = "127.0.0.1";
  int port = 8080;  ///< 0 = pick a free port (printed on stdout)
  std::string store = "gvd-store";
  int workers = 1;                    ///< jobs computed at once
  int job_threads = 0;                ///< threads per job (0 = all cores)
  int http_threads = 128;             ///< requests served at once (header_gate.h)
  int queue = 64;                     ///< queued jobs before 503
  uint64_t max_body = 64ull << 20;    ///< request body limit, bytes
  int max_headers = 64;               ///< request header count limit
  uint64_t max_header_bytes = 16384;  ///< total size of the request headers, bytes
  uint64_t max_objects = 10000;
  uint64_t max_simplices = 2'000'000;
  int max_depth = 0;                ///< cap on octree depth (0 = the lattice limit)
  uint64_t max_leaves = 4'000'000;  ///< per job
  /// Cells of a grid sampled from a result (GET .../field.npy, labels.npy), checked before
  /// any work: 2^24 = 256^3 (~200 MB while it is built, 64 MB of float32 answer).
  uint64_t max_grid_cells = uint64_t{1} << 24;
  /// Points of one batch nearest query (POST .../nearest), checked before any is answered:
  /// 100,000 take ~1 s of one HTTP thread and ~8 MB of answer.
  uint64_t max_batch_points = 100'000;
  double job_seconds = 300;       ///< wall time per job
  uint64_t max_memory_mb = 4096;  ///< resident memory of the process; 0 = unlimited
  uint64_t job_memory_mb = 0;     ///< heap one job may hold itself; 0 = max_memory_mb
  int cache_entries = 16;         ///< finished results kept in memory
  std::string backend = "cpu";    ///< cpu | opencl | auto (as requested)
  /// Set at start-up from `backend` (gvd::kernels::choose_backend, once, before any job): the
  /// OpenCL backend, or null for the CPU twins, and why the CPU runs when auto found no device.
  std::shared_ptr<gvd::compute::ComputeBackend> compute;
  std::string backend_note;
  int read_timeout = 10;       ///< seconds
  int write_timeout = 10;      ///< seconds
  int keep_alive_max = 1000;   ///< requests per connection
  int keep_alive_timeout = 5;  ///< seconds idle
  /// Connections wait for their request headers outside the HTTP threads (header_gate.h):
  /// seconds from a request's first byte to the end of its headers, and how many may wait
  /// per remote address and in all (the oldest waiting one is closed to make room).
  double header_timeout = 10;
  int max_waiting_per_client = 64;
  int max_waiting = 4096;
  /// Requests whose headers have arrived and that wait for a busy HTTP thread; one more is
  /// answered at once with 503 /problems/overloaded + Retry-After (header_gate.h).
  int max_queued_requests = 256;
  /// Request bodies are read in the HTTP threads: at most this many threads read one at once
  /// (beyond, 503 /problems/overloaded + Retry-After before the body is read), so slow bodies
  /// cannot take every thread; 0 = half of http_threads. A body must arrive within
  /// body_seconds + its Content-Length / min_body_rate (bytes per second) of the moment its
  /// reading began, or 408 /problems/request-timeout and the connection is closed.
  int max_body_readers = 0;
  /// Of max_body_readers, how many bodies one remote address may be sending at once (beyond,
  /// 503 overloaded + Retry-After before the body); 0 = a quarter of them, at least 1.
  int max_body_readers_per_client = 0;
  /// Bytes of request bodies (their Content-Length) held at once, from before the body is
  /// read until its request is answered (beyond, 503 overloaded + Retry-After before the
  /// body); 0 = 4 x max_body. At least max_body otherwise.
  uint64_t body_budget = 0;
  double body_seconds = 30;
  uint64_t min_body_rate = 1 << 20;
  int max_streams = 4;        ///< concurrent SSE streams
  int retry_after = 5;        ///< seconds, on 503
  double grace_seconds = 10;  ///< SIGTERM: wait this long for running jobs
  bool quiet = false;         ///< no request log
  /// The web viewer's files (index.html, viewer/, vendor/); empty = found next to the binary
  /// (static_files.h), and resolved to a directory (or left empty: no viewer) at start-up.
  std::string web_root;

  // Scale-out (docs/DEPLOY.md): replicas sharing a Redis Streams queue and one store.
  std::string queue_url;      ///< empty = the in-process queue; redis://HOST:PORT/DB
  std::string role = "both";  ///< api (no workers) | worker | both
  std::string replica_id;     ///< consumer name in the group; empty = hostname-pid
  double reclaim_idle = 30;   ///< seconds a running job may go without a heartbeat
  int max_deliveries = 5;     ///< deliveries of one job before it fails
  /// Fairness: submissions per second per client (0 = no limit), bursts of rate_burst; a
  /// client is the value of the client_id_header header, or its remote address without it.
  double rate_limit = 0;
  double rate_burst = 20;
  std::string client_id_header = "X-Client-Id";
  /// Parsed from queue_url by parse_server_options.
  std::string redis_host;
  int redis_port = 6379;
  int redis_db = 0;
};

/// Bad command line or environment (the message says which option and why).
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Parses the environment (GVD_* variables in `env`) then argv. Throws UsageError.
/// `help` is set when --help was given.
ServerOptions parse_server_options(const std::vector<std::string>& args,
                                   const std::map<std::string, std::string>& env, bool& help);

/// The --help text (every flag with its variable and default).
std::string server_usage();

}  // namespace gvd::server
