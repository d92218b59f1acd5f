#include "server_options.h"

#include <charconv>
#include <cmath>
#include <functional>
#include <sstream>

namespace gvd::server {
namespace {

struct Spec {
  const char* flag;     ///< "--max-body"
  const char* meaning;  ///< one line of help
  std::function<void(ServerOptions&, const std::string&)> set;
  std::function<std::string(const ServerOptions&)> show;
};

template <class T>
T parse_number(const std::string& flag, const std::string& text, T lo, T hi) {
  T value{};
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (ec != std::errc() || ptr != end || text.empty()) {
    throw UsageError(flag + " expects a number, got \"" + text + "\"");
  }
  if constexpr (std::is_floating_point_v<T>) {
    if (!std::isfinite(value)) throw UsageError(flag + " must be finite");
  }
  if (value < lo || value > hi) {
    std::ostringstream s;
    s << flag << " must be between " << lo << " and " << hi << ", got " << text;
    throw UsageError(s.str());
  }
  return value;
}

template <class T>
Spec number(const char* flag, const char* meaning, T ServerOptions::*member, T lo, T hi) {
  return {
      flag, meaning,
      [=](ServerOptions& o, const std::string& v) { o.*member = parse_number<T>(flag, v, lo, hi); },
      [=](const ServerOptions& o) {
        std::ostringstream s;
        s << o.*member;
        return s.str();
      }};
}

Spec text(const char* flag, const char* meaning, std::string ServerOptions::*member) {
  return {flag, meaning, [=](ServerOptions& o, const std::string& v) { o.*member = v; },
          [=](const ServerOptions& o) { return o.*member; }};
}

const std::vector<Spec>& specs() {
  constexpr uint64_t kU64 = UINT64_MAX / 2;
  static const std::vector<Spec> table = {
      text("--host", "address to listen on", &ServerOptions::host),
      number("--port", "TCP port; 0 picks a free one and prints it", &ServerOptions::port, 0,
             65535),
      text("--store", "directory of the job and result store (created)", &ServerOptions::store),
      number("--workers", "jobs computed at once", &ServerOptions::workers, 1, 64),
      number("--job-threads", "threads per job (0 = all cores)", &ServerOptions::job_threads, 0,
             256),
      number("--http-threads",
             "requests served at once (connections wait for headers outside them)",
             &ServerOptions::http_threads, 2, 1024),
      // Two meanings, told apart by the value (both may be given: --queue redis://... --queue 200).
      {"--queue",
       "queued jobs before 503 + Retry-After (a number; with Redis, for the whole cluster), "
       "or the shared queue of a scale-out cluster: redis://HOST[:PORT][/DB]",
       [](ServerOptions& o, const std::string& v) {
         if (v.starts_with("redis://") || v.find("://") != std::string::npos) {
           o.queue_url = v;
         } else {
           o.queue = parse_number<int>("--queue", v, 0, 100000);
         }
       },
       [](const ServerOptions& o) {
         return o.queue_url.empty() ? std::to_string(o.queue) : o.queue_url;
       }},
      number("--max-body", "request body limit, bytes", &ServerOptions::max_body, uint64_t{1},
             kU64),
      number("--max-headers", "request header count limit", &ServerOptions::max_headers, 1, 10000),
      number("--max-header-bytes", "total request header size limit, bytes",
             &ServerOptions::max_header_bytes, uint64_t{256}, kU64),
      number("--max-objects", "objects per scene", &ServerOptions::max_objects, uint64_t{1}, kU64),
      number("--max-simplices", "simplices per scene", &ServerOptions::max_simplices, uint64_t{1},
             kU64),
      number("--max-depth", "deepest octree level a job may ask for (0 = lattice limit)",
             &ServerOptions::max_depth, 0, 31),
      number("--max-leaves",
             "octree leaves per job (up to ~1 KB of memory each; also 8 simplex references each)",
             &ServerOptions::max_leaves, uint64_t{1}, kU64),
      number("--max-grid-cells",
             "cells of a grid sampled from a finished job (field.npy, labels.npy)",
             &ServerOptions::max_grid_cells, uint64_t{1}, uint64_t{0xFFFFFFFF}),
      number("--max-batch-points", "points of one batch nearest query (POST .../nearest)",
             &ServerOptions::max_batch_points, uint64_t{1}, kU64),
      number("--job-seconds", "wall time per job, seconds", &ServerOptions::job_seconds, 0.01, 1e7),
      number("--max-memory-mb", "resident memory of the process, MB (0 = unlimited)",
             &ServerOptions::max_memory_mb, uint64_t{0}, kU64),
      number("--job-memory-mb",
             "memory one job may hold itself, MB (0 = --max-memory-mb; a job is charged for "
             "what it allocates, not for the process)",
             &ServerOptions::job_memory_mb, uint64_t{0}, kU64),
      number("--cache-entries", "finished results kept in memory", &ServerOptions::cache_entries, 1,
             100000),
      text("--backend", "compute backend: cpu | opencl | auto (OpenCL when a device exists)",
           &ServerOptions::backend),
      number("--read-timeout", "seconds one read of a request body may wait",
             &ServerOptions::read_timeout, 1, 3600),
      number("--write-timeout", "seconds to send a response", &ServerOptions::write_timeout, 1,
             3600),
      number("--keep-alive-max", "requests per connection", &ServerOptions::keep_alive_max, 1,
             1000000),
      number("--keep-alive-timeout", "idle seconds before a connection is closed",
             &ServerOptions::keep_alive_timeout, 1, 3600),
      number("--header-timeout",
             "seconds from a request's first byte to the end of its headers (then 408)",
             &ServerOptions::header_timeout, 0.1, 3600.0),
      number("--max-waiting-per-client",
             "connections of one remote address waiting with part of their headers (oldest "
             "closed; idle kept-alive ones are not counted)",
             &ServerOptions::max_waiting_per_client, 1, 1000000),
      number("--max-waiting",
             "connections waiting for a request in all, idle or not (the oldest of the address "
             "with the most is closed)",
             &ServerOptions::max_waiting, 1, 1000000),
      number("--max-queued-requests",
             "requests waiting for a busy HTTP thread; beyond, 503 overloaded at once",
             &ServerOptions::max_queued_requests, 0, 1000000),
      number("--max-body-readers",
             "HTTP threads reading a request body at once; beyond, 503 overloaded before the "
             "body (0 = half of --http-threads)",
             &ServerOptions::max_body_readers, 0, 1024),
      number("--max-body-readers-per-client",
             "of --max-body-readers, bodies one client address may send at once; beyond, 503 "
             "overloaded before the body (0 = a quarter of them, at least 1)",
             &ServerOptions::max_body_readers_per_client, 0, 1024),
      number("--body-budget",
             "bytes of request bodies held at once (read or being handled); beyond, 503 "
             "overloaded before the body (0 = 4 x --max-body; else at least --max-body)",
             &ServerOptions::body_budget, uint64_t{0}, kU64),
      number("--body-seconds",
             "seconds a request body may take, plus its length / --min-body-rate (then 408)",
             &ServerOptions::body_seconds, 0.1, 86400.0),
      number("--min-body-rate",
             "bytes per second a request body is allowed on top of --body-seconds",
             &ServerOptions::min_body_rate, uint64_t{1}, kU64),
      number("--max-streams", "concurrent event streams (SSE)", &ServerOptions::max_streams, 0,
             1024),
      number("--retry-after", "seconds a 503 asks the client to wait", &ServerOptions::retry_after,
             1, 3600),
      text("--web-root", "the web viewer's files (empty: found next to the binary)",
           &ServerOptions::web_root),
      number("--grace-seconds", "on SIGTERM, how long running jobs may finish",
             &ServerOptions::grace_seconds, 0.0, 3600.0),
      text("--role", "with --queue redis://...: api (no workers) | worker (no new jobs) | both",
           &ServerOptions::role),
      text("--replica-id", "this replica's name in the queue (empty: hostname-pid)",
           &ServerOptions::replica_id),
      number("--reclaim-idle",
             "seconds without a heartbeat before another replica takes a running job over",
             &ServerOptions::reclaim_idle, 0.2, 86400.0),
      number("--rate-limit",
             "job submissions per second per client, cluster-wide with Redis (0 = no limit)",
             &ServerOptions::rate_limit, 0.0, 1e6),
      number("--rate-burst", "submissions a client may make at once above --rate-limit",
             &ServerOptions::rate_burst, 1.0, 1e6),
      text("--client-id-header",
           "header naming the client for --rate-limit (empty or absent: the remote address)",
           &ServerOptions::client_id_header),
      number("--max-deliveries", "times a job is started before it fails (crashed workers)",
             &ServerOptions::max_deliveries, 1, 1000),
  };
  return table;
}

std::string env_name(const std::string& flag) {
  std::string name = "GVD_";
  for (char c : flag.substr(2)) name += c == '-' ? '_' : static_cast<char>(std::toupper(c));
  return name;
}

void check(ServerOptions& o) {
  if (o.backend != "cpu" && o.backend != "opencl" && o.backend != "auto") {
    throw UsageError("--backend must be cpu, opencl or auto, got \"" + o.backend + "\"");
  }
  if (o.store.empty()) throw UsageError("--store must not be empty");
  if (o.body_budget != 0 && o.body_budget < o.max_body) {
    throw UsageError("--body-budget " + std::to_string(o.body_budget) +
                     " is less than --max-body " + std::to_string(o.max_body) +
                     ": a body of the largest size allowed could never be read");
  }
  if (o.role != "api" && o.role != "worker" && o.role != "both") {
    throw UsageError("--role must be api, worker or both, got \"" + o.role + "\"");
  }
  if (o.queue_url.empty()) {
    if (o.role != "both") throw UsageError("--role " + o.role + " needs --queue redis://...");
    return;
  }
  // redis://HOST[:PORT][/DB]
  const std::string scheme = "redis://";
  if (!o.queue_url.starts_with(scheme)) {
    throw UsageError("--queue must be a number or look like redis://HOST:PORT/DB, got \"" +
                     o.queue_url + "\"");
  }
  std::string rest = o.queue_url.substr(scheme.size());
  if (const size_t slash = rest.find('/'); slash != std::string::npos) {
    const std::string db = rest.substr(slash + 1);
    if (!db.empty()) o.redis_db = parse_number<int>("--queue (database)", db, 0, 1000000);
    rest.resize(slash);
  }
  if (const size_t colon = rest.rfind(':'); colon != std::string::npos) {
    o.redis_port = parse_number<int>("--queue (port)", rest.substr(colon + 1), 1, 65535);
    rest.resize(colon);
  }
  if (rest.empty()) throw UsageError("--queue has no host: \"" + o.queue_url + "\"");
  o.redis_host = rest;
}

}  // namespace

ServerOptions parse_server_options(const std::vector<std::string>& args,
                                   const std::map<std::string, std::string>& env, bool& help) {
  ServerOptions o;
  help = false;
  for (const Spec& s : specs()) {
    const auto it = env.find(env_name(s.flag));
    if (it != env.end()) {
      try {
        s.set(o, it->second);
      } catch (const UsageError& e) {
        throw UsageError(env_name(s.flag) + ": " + e.what());
      }
    }
  }
  if (const auto it = env.find("GVD_QUIET"); it != env.end()) o.quiet = it->second == "1";
  for (size_t i = 0; i < args.size(); ++i) {
    std::string flag = args[i];
    if (flag == "--help" || flag == "-h") {
      help = true;
      continue;
    }
    if (flag == "--quiet" || flag == "-q") {
      o.quiet = true;
      continue;
    }
    std::string value;
    bool has_value = false;
    if (const size_t eq = flag.find('='); eq != std::string::npos && flag.starts_with("--")) {
      value = flag.substr(eq + 1);
      flag = flag.substr(0, eq);
      has_value = true;
    }
    const Spec* spec = nullptr;
    for (const Spec& s : specs()) {
      if (flag == s.flag) spec = &s;
    }
    if (spec == nullptr) throw UsageError("unknown option \"" + flag + "\"");
    if (!has_value) {
      if (i + 1 >= args.size()) throw UsageError(flag + " needs a value");
      value = args[++i];
    }
    spec->set(o, value);
  }
  check(o);
  return o;
}

std::string server_usage() {
  std::ostringstream s;
  s << "gvd-server — the gvd REST service (generalized Voronoi diagrams over HTTP)\n\n"
       "Usage: gvd-server [options]\n\n"
       "Every option can also be set by its environment variable; a flag wins.\n\n";
  const ServerOptions defaults;
  for (const Spec& spec : specs()) {
    const std::string flag = spec.flag;
    const char* metavar = flag == "--host"                                   ? " ADDR"
                          : flag == "--store"                                ? " DIR"
                          : flag == "--backend"                              ? " NAME"
                          : flag == "--web-root"                             ? " DIR"
                          : flag == "--queue"                                ? " N|URL"
                          : flag == "--role"                                 ? " ROLE"
                          : flag == "--replica-id"                           ? " NAME"
                          : flag == "--client-id-header"                     ? " NAME"
                          : flag == "--rate-limit" || flag == "--rate-burst" ? " R"
                                                                             : " N";
    std::string head = "  " + flag + metavar;
    head.resize(std::max<size_t>(head.size() + 1, 27), ' ');
    s << head << spec.meaning << " (" << env_name(spec.flag) << ", default " << spec.show(defaults)
      << ")\n";
  }
  s << "  -q, --quiet              no request log on stderr (GVD_QUIET=1)\n"
       "  -h, --help               this text\n\n"
       "API: GET /openapi.json, docs/API.md. Stop with SIGTERM (drains: /readyz answers 503,\n"
       "running jobs get --grace-seconds to finish, unfinished jobs resume at the next start).\n"
       "Scale-out: replicas with --queue redis://HOST:PORT/DB and one --store on a shared\n"
       "volume (docs/DEPLOY.md).\n";
  return s.str();
}

}  // namespace gvd::server
