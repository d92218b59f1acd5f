#include "http_server.h"

#include <httplib.h>
#include <malloc.h>
#include <sys/socket.h>

#include <algorithm>
#include <atomic>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <random>
#include <regex>
#include <string_view>

#include "gvd/common/error.h"
#include "gvd/common/json_depth.h"
#include "gvd/grid/compute_grid.h"
#include "gvd/io/write_outputs.h"
#include "gvd/pipeline/pipeline.h"
#include "gvd/scene/label_volume.h"
#include "gvd/scene/load_scene.h"
#include "header_gate.h"
#include "job_compute.h"
#include "job_manager.h"
#include "job_params.h"
#include "metrics.h"
#include "openapi_json.h"
#include "problem.h"
#include "query_handlers.h"
#include "redis_job_queue.h"
#include "routes.h"
#include "static_files.h"

namespace gvd::server {

using namespace gvd::scene;
using namespace gvd::result;
using namespace gvd::grid;
using namespace gvd::io;
using namespace gvd::pipeline;

namespace {

using Json = nlohmann::json;
using Clock = std::chrono::steady_clock;

/// What the pre-routing handler learns about a request, for the handler and the logger (all
/// three run on the same HTTP thread, one request at a time).
struct RequestContext {
  std::string id;
  std::string route = "unmatched";
  Clock::time_point start;
};
thread_local RequestContext t_request;

std::string new_request_id() {
  static std::atomic<uint64_t> counter{0};
  static const uint64_t prefix = std::random_device{}() & 0xffffff;
  char buf[32];
  std::snprintf(buf, sizeof buf, "%06llx-%08llx", static_cast<unsigned long long>(prefix),
                static_cast<unsigned long long>(counter.fetch_add(1) + 1));
  return buf;
}

bool is_safe_request_id(const std::string& s) {
  if (s.empty() || s.size() > 64) return false;
  return std::all_of(s.begin(), s.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '-' || c == '_' || c == '.' ||
           c == ':';
  });
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

/// The media type without parameters, lower case ("multipart/form-data").
std::string media_type(const httplib::Request& req) {
  std::string type = lower(req.get_header_value("Content-Type"));
  if (const size_t semi = type.find(';'); semi != std::string::npos) type.resize(semi);
  while (!type.empty() && type.back() == ' ') type.pop_back();
  return type;
}

/// Media types POST /v1/jobs accepts (the content itself is sniffed: scene JSON, OBJ, glTF,
/// GLB, PLY, STL, OFF).
bool is_scene_media_type(const std::string& type) {
  return type == "application/json" || type == "application/octet-stream" || type == "text/plain" ||
         type.starts_with("model/") || type == "application/sla" ||
         type == "application/vnd.ms-pki.stl" || type == "application/x-ply" ||
         type == "multipart/form-data" || type == "application/x-npy";
}

/// A numpy .npy file begins with these six bytes.
bool is_npy(std::string_view bytes) { return bytes.starts_with("\x93NUMPY"); }

struct Rejection {
  ProblemKind kind;
  std::string detail;
};

std::string json_text(const Json& j) {
  return j.dump(-1, ' ', false, Json::error_handler_t::replace);
}

}  // namespace

namespace {

/// `/` when the web viewer is not installed.
constexpr const char* kIndexHtml = R"(<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>gvd-server</title>
<style>body{font:15px/1.5 system-ui,sans-serif;max-width:46em;margin:2em auto;padding:0 1em}
code,pre{background:#f4f4f4;padding:.1em .3em}</style></head><body>
<h1>gvd-server</h1>
<p>Generalized Voronoi diagrams of labelled meshes over HTTP. The API is described in
<a href="/openapi.json">/openapi.json</a> (OpenAPI 3.1); health: <a href="/healthz">/healthz</a>,
<a href="/readyz">/readyz</a>, <a href="/metrics">/metrics</a>, jobs: <a href="/v1/jobs">/v1/jobs</a>.</p>
<p>The web viewer is not installed on this server: build it (<code>make build</code> copies
clients/web and three.js to build/web) or start gvd-server with <code>--web-root DIR</code>.</p>
<pre>curl -i -X POST -H 'Content-Type: application/json' --data-binary @scene.json http://HOST/v1/jobs
curl http://HOST/v1/jobs/ID
curl -o gvd.glb http://HOST/v1/jobs/ID/gvd.glb</pre>
</body></html>
)";

/// The in-process queue (the default), or the Redis Streams queue for --queue redis://...
std::unique_ptr<JobQueue> make_job_queue(const ServerOptions& o, Metrics& metrics) {
  if (o.queue_url.empty()) return std::make_unique<JobManager>(o, metrics);
  return std::make_unique<RedisJobQueue>(o, metrics);
}

}  // namespace

/// Set by the request log line when the body was large: the thread trims the heap once the
/// request is over (GatedServer::set_after_request).
constexpr size_t kTrimAfterBytes = size_t{4} << 20;
static thread_local bool t_large_request = false;

struct HttpServer::Impl {
  explicit Impl(const ServerOptions& o)
      : options(o),
        jobs_owner(make_job_queue(o, metrics)),
        jobs(*jobs_owner),
        queries(jobs, o.max_grid_cells, o.max_batch_points, o.job_threads),
        web(o.web_root),
        http(o.http_threads) {}

  ServerOptions options;
  Metrics metrics;
  std::unique_ptr<JobQueue> jobs_owner;
  JobQueue& jobs;
  QueryHandlers queries;
  StaticFiles web;
  GatedServer http;  ///< after web: members are initialised in this order
  std::atomic<bool> draining{false};
  std::atomic<bool> closing{false};
  std::atomic<int> streams{0};
  int port = 0;
  socket_t listen_socket = INVALID_SOCKET;
  std::string backend;  ///< the backend the warm-up computation actually used

  // ---- helpers ------------------------------------------------------------------------------

  /// `detail` with the store's directory written as "<store>": clients learn which file of
  /// the store failed, not where the server keeps it (the error log line has the full path).
  std::string without_store_path(std::string detail) const {
    std::error_code ec;
    const std::string absolute = std::filesystem::absolute(options.store, ec).lexically_normal();
    for (const std::string& dir : {absolute, options.store}) {
      if (dir.empty() || dir == "." || dir == "/") continue;
      for (size_t at = detail.find(dir); at != std::string::npos; at = detail.find(dir, at + 7)) {
        detail.replace(at, dir.size(), "<store>");
      }
    }
    return detail;
  }

  void send_problem(const httplib::Request& req, httplib::Response& res, ProblemKind kind,
                    const std::string& detail, const std::string& extra = {},
                    const ErrorLocation& where = {}) {
    const ProblemInfo& info = problem_info(kind);
    res.status = info.status;
    if (info.retryable && (info.status == 503 || info.status == 429) &&
        !res.has_header("Retry-After")) {
      res.set_header("Retry-After", std::to_string(options.retry_after));
    }
    res.set_content(problem_json(kind, detail, req.path, t_request.id, extra, where),
                    "application/problem+json");
  }

  /// Refuses a request before its body is read, and closes the connection: whatever body the
  /// client sends next must not be parsed as a request. cpp-httplib 0.11.4 closes a
  /// connection only when the response fails to write, so the body is written by a content
  /// provider that then reports failure.
  void reject(const httplib::Request& req, httplib::Response& res, const Rejection& r) {
    t_request.route = "rejected";
    send_problem(req, res, r.kind, r.detail);
    auto body = std::make_shared<std::string>(std::move(res.body));
    res.body.clear();
    res.headers.erase("Content-Type");  // set_content_provider sets it again
    res.set_header("Connection", "close");
    res.set_content_provider(body->size(), "application/problem+json",
                             [body](size_t offset, size_t length, httplib::DataSink& sink) {
                               sink.write(body->data() + offset, length);
                               return false;  // ends the connection after the answer
                             });
  }

  std::optional<Rejection> check_request(const httplib::Request& req) const {
    // cpp-httplib adds REMOTE_ADDR and REMOTE_PORT to the request's headers: not counted.
    const size_t header_count = req.headers.size() - req.get_header_value_count("REMOTE_ADDR") -
                                req.get_header_value_count("REMOTE_PORT");
    if (header_count > static_cast<size_t>(options.max_headers)) {
      return Rejection{ProblemKind::kHeadersTooLarge, std::to_string(header_count) +
                                                          " headers, more than the limit of " +
                                                          std::to_string(options.max_headers)};
    }
    uint64_t header_bytes = 0;
    for (const auto& [k, v] : req.headers) {
      if (k != "REMOTE_ADDR" && k != "REMOTE_PORT") header_bytes += k.size() + v.size() + 4;
    }
    if (header_bytes > options.max_header_bytes) {
      return Rejection{ProblemKind::kHeadersTooLarge, "the headers take " +
                                                          std::to_string(header_bytes) +
                                                          " bytes, more than the limit of " +
                                                          std::to_string(options.max_header_bytes)};
    }
    if (req.has_header("Transfer-Encoding")) {
      return Rejection{ProblemKind::kLengthRequired,
                       "chunked (Transfer-Encoding) request bodies are not accepted; send the "
                       "body with a Content-Length"};
    }
    if (req.has_header("Content-Encoding") &&
        lower(req.get_header_value("Content-Encoding")) != "identity") {
      return Rejection{ProblemKind::kUnsupportedEncoding,
                       "Content-Encoding \"" + req.get_header_value("Content-Encoding") +
                           "\" is not accepted; send the body uncompressed"};
    }
    const bool has_body_method =
        req.method == "POST" || req.method == "PUT" || req.method == "PATCH";
    if (req.get_header_value_count("Content-Length") > 1) {
      return Rejection{ProblemKind::kInvalidArgument, "more than one Content-Length header"};
    }
    if (req.has_header("Content-Length")) {
      const std::string text = req.get_header_value("Content-Length");
      if (text.empty() || text.size() > 19 ||
          !std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; })) {
        return Rejection{ProblemKind::kInvalidArgument,
                         "Content-Length \"" + text + "\" is not a number"};
      }
      const uint64_t length = std::stoull(text);
      if (length > options.max_body) {
        return Rejection{ProblemKind::kBodyTooLarge, "the body has " + std::to_string(length) +
                                                         " bytes, more than the limit of " +
                                                         std::to_string(options.max_body)};
      }
    } else if (has_body_method) {
      return Rejection{ProblemKind::kLengthRequired, req.method + " needs a Content-Length"};
    }
    if (req.method == "POST") {
      const std::string type = media_type(req);
      if (req.path == "/v1/jobs") {
        if (!is_scene_media_type(type)) {
          return Rejection{ProblemKind::kUnsupportedMediaType,
                           "Content-Type \"" + req.get_header_value("Content-Type") +
                               "\" is not a scene: send application/json (scene JSON or glTF), "
                               "model/gltf-binary, model/obj, model/stl, model/x-ply, "
                               "application/octet-stream (sniffed), multipart/form-data (one "
                               "mesh per part, part name = label) or application/x-npy (a "
                               "labelled volume)"};
        }
      } else if (type != "application/json" && type != "text/plain" && !type.empty() &&
                 type != "application/x-www-form-urlencoded") {
        // The query routes read the body as JSON whatever it is labelled: `curl -d '{...}'`
        // sends it as a form. Anything else (multipart, XML, ...) is a mistake.
        return Rejection{ProblemKind::kUnsupportedMediaType,
                         "Content-Type \"" + req.get_header_value("Content-Type") +
                             "\": this route takes a JSON body (application/json)"};
      }
    }
    return std::nullopt;
  }

  void begin_request(const httplib::Request& req, httplib::Response& res) {
    t_request.start = Clock::now();
    t_request.route = "unmatched";
    const std::string given = req.get_header_value("X-Request-Id");
    t_request.id = is_safe_request_id(given) ? given : new_request_id();
    res.set_header("X-Request-Id", t_request.id);
  }

  void log(const httplib::Request& req, const httplib::Response& res) {
    const double seconds = std::chrono::duration<double>(Clock::now() - t_request.start).count();
    if (req.body.size() >= kTrimAfterBytes) t_large_request = true;
    metrics.request(t_request.route, req.method, res.status, seconds);
    if (options.quiet) return;
    const Json line = {
        {"ts", std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch())
                   .count()},
        {"level", res.status >= 500 ? "error" : "info"},
        {"request_id", t_request.id},
        {"remote", req.remote_addr},
        {"method", req.method},
        {"path", req.path},
        {"route", t_request.route},
        {"status", res.status},
        {"bytes", res.body.empty() ? res.content_length_ : res.body.size()},
        {"ms", seconds * 1000}};
    std::fprintf(stderr, "%s\n", json_text(line).c_str());
  }

  using Fn = std::function<void(const httplib::Request&, httplib::Response&)>;

  /// The one catch boundary of a request: every error becomes a problem document.
  httplib::Server::Handler wrap(std::string route, Fn fn) {
    return [this, route = std::move(route), fn = std::move(fn)](const httplib::Request& req,
                                                                httplib::Response& res) {
      t_request.route = route;
      try {
        fn(req, res);
      } catch (const ProblemError& e) {
        send_problem(req, res, e.kind(), e.detail(), e.extra_json());
      } catch (const QueueFull& e) {
        send_problem(req, res, ProblemKind::kQueueFull, e.what());
      } catch (const InternalError& e) {
        std::fprintf(stderr, "{\"level\":\"error\",\"request_id\":\"%s\",\"internal\":%s}\n",
                     t_request.id.c_str(), json_text(Json(e.what())).c_str());
        send_problem(req, res, ProblemKind::kInternal,
                     "internal error (request " + t_request.id + ")");
      } catch (const Error& e) {
        send_problem(req, res, problem_kind(e.code()), without_store_path(e.detail()), {},
                     e.where());
        // A server-side failure (a store that does not read back, a full disk): the access
        // line says 5xx, this one says what broke, for the operator.
        if (res.status >= 500 && !options.quiet)
          std::fprintf(stderr, "{\"level\":\"error\",\"request_id\":\"%s\",\"error\":%s}\n",
                       t_request.id.c_str(), json_text(Json(e.detail())).c_str());
      } catch (const Json::exception& e) {
        send_problem(req, res, ProblemKind::kInvalidArgument,
                     std::string("malformed JSON: ") + e.what());
      } catch (const std::bad_alloc&) {
        send_problem(req, res, ProblemKind::kLimitExceeded, "out of memory for this request");
      } catch (const std::exception& e) {
        std::fprintf(stderr, "{\"level\":\"error\",\"request_id\":\"%s\",\"internal\":%s}\n",
                     t_request.id.c_str(), json_text(Json(e.what())).c_str());
        send_problem(req, res, ProblemKind::kInternal,
                     "internal error (request " + t_request.id + ")");
      }
    };
  }

  void route(std::string_view method, std::string_view openapi_path, Fn fn) {
    const Route* found = nullptr;
    for (const Route& r : kRoutes) {
      if (r.method == method && r.openapi_path == openapi_path) found = &r;
    }
    GVD_CHECK(found != nullptr, "route missing from routes.h");
    const std::string pattern(found->pattern);
    auto handler = wrap(std::string(method) + " " + std::string(openapi_path), std::move(fn));
    if (method == "GET")
      http.Get(pattern, handler);
    else if (method == "POST")
      http.Post(pattern, handler);
    else if (method == "DELETE")
      http.Delete(pattern, handler);
    registered.push_back(found);
  }
  std::vector<const Route*> registered;
  /// kRoutes' patterns, compiled once (for the Allow header of 405 answers).
  std::vector<std::regex> route_patterns = [] {
    std::vector<std::regex> v;
    for (const Route& r : kRoutes) v.emplace_back(std::string(r.pattern));
    return v;
  }();

  // ---- handlers -----------------------------------------------------------------------------

  void submit(const httplib::Request& req, httplib::Response& res) {
    if (draining) throw ProblemError(ProblemKind::kDraining, "the server is shutting down");
    if (options.rate_limit > 0) admit(req, res);
    JobParams params;
    std::string label = "object";
    std::string volume_param;  // a volume's parameter given (a query's, even at its default)
    for (const auto& [key, value] : req.params) {
      if (key == "label") {
        label = value;
      } else {
        params.set(key, value);
        if (const ParamSpec* p = find_parameter(key); p != nullptr && p->of_volume)
          volume_param = key;
      }
    }
    SceneLimits limits;
    limits.max_objects = options.max_objects;
    limits.max_simplices = options.max_simplices;
    Scene scene;
    // A labelled volume is only checked here (its header and parameters): the worker turns it
    // into a scene, where the job's progress shows it and DELETE stops it.
    const std::string* volume_bytes = nullptr;
    if (req.is_multipart_form_data() && req.has_file("volume")) {
      if (const auto p = req.files.find("params"); p != req.files.end()) {
        if (!Json::accept(p->second.content))
          throw Error(ErrorCode::kInvalidArgument, "the \"params\" part is not valid JSON");
        params_from_json("{\"params\":" + p->second.content + "}", params);
      }
      for (const auto& [name, part] : req.files) {
        if (name != "volume" && name != "params")
          throw Error(ErrorCode::kInvalidArgument,
                      "a multipart body with a \"volume\" part holds only it and \"params\", "
                      "not part \"" +
                          name + "\"");
      }
      volume_bytes = &req.files.find("volume")->second.content;
    } else if (req.is_multipart_form_data()) {
      scene = scene_from_parts(req, limits, params);
    } else if (media_type(req) == "application/x-npy" || is_npy(req.body)) {
      volume_bytes = &req.body;
    } else {
      // The scene first: its parse refuses a body over the limits early, where the params'
      // parse reads all of it.
      const auto* data = reinterpret_cast<const uint8_t*>(req.body.data());
      scene = parse_scene_bytes({data, req.body.size()}, SceneFormat::kAuto, label, limits);
      if (req.body.find("\"params\"") != std::string::npos) params_from_json(req.body, params);
    }
    for (const ParamSpec& p : pipeline_parameters()) {
      if (p.of_volume && !params.is_default(p)) volume_param = p.name;
    }
    const bool volume = volume_bytes != nullptr;
    if (!volume && !volume_param.empty()) {
      throw Error(ErrorCode::kInvalidArgument,
                  "parameter \"" + volume_param +
                      "\" goes with a labelled volume (an .npy body, application/x-npy, or a "
                      "multipart part named \"volume\")");
    }
    JobRequest job;
    if (volume) {
      const LabelVolumeHeader header = read_label_volume_header(
          {reinterpret_cast<const uint8_t*>(volume_bytes->data()), volume_bytes->size()},
          "the volume");
      if (params.spacing.empty()) {
        throw Error(ErrorCode::kInvalidArgument,
                    "parameter \"spacing\" is required for a labelled volume: the voxel size on "
                    "each axis, " +
                        std::string(header.dimension == 2 ? "x,y" : "x,y,z") + " in scene units");
      }
      job.volume_json = volume_options_json(
          label_volume_options(params, header.dimension, ParamSpelling::kServer), header.dimension);
      job.volume_npy = *volume_bytes;
      job.dimension = header.dimension;
      // The scene's bounds, and with them the grid's cells and a user box's fit, are known
      // once the worker has the scene: those limits fail the job then (the same problem).
      params.check(job.dimension, options);
      job.units = params.units;
    } else {
      params.check(scene.dimension, options);
      if (!params.units.empty()) scene.units = params.units;  // the request's word over the file's
      if (params.is_grid()) {
        // The cell count (--max-grid-cells) and the box, before the job is queued.
        (void)make_grid_spec(scene, params.grid_options(options));
      } else if (const DomainOptions domain = params.pipeline_options(options).domain; domain.box) {
        (void)make_domain(scene, domain);  // a user box must fit (no frame is searched for it)
      }
      job.scene_json = scene_to_json(scene);
      job.dimension = scene.dimension;
      job.objects = scene.objects.size();
      job.simplices = scene.simplex_count();
      job.units = scene.units;
      job.warnings_json = warnings_to_json(scene.warnings);
    }
    job.params_json = params.to_json();
    job.id = volume ? volume_job_id(job.volume_json, job.volume_npy, job.params_json)
                    : job_id(job.scene_json, job.params_json);
    const SubmitOutcome outcome = jobs.submit(job);
    res.set_header("Location", "/v1/jobs/" + job.id);
    res.set_header("X-Gvd-Cache", outcome.created ? "miss" : "hit");
    res.status = outcome.status == JobStatus::kDone ? 200 : 202;
    res.set_content(outcome.status_json, "application/json");
  }

  /// The per-client token bucket (--rate-limit): refused with 503 + Retry-After (the
  /// retryable "busy" answer every client already honours) when the client has no token.
  void admit(const httplib::Request& req, httplib::Response& res) {
    std::string client;
    if (!options.client_id_header.empty())
      client = req.get_header_value(options.client_id_header.c_str());
    if (client.empty() || client.size() > 128) client = "addr:" + req.remote_addr;
    const double wait = jobs.take_token(client, options.rate_limit, options.rate_burst);
    if (wait <= 0) return;
    metrics.count("gvd_jobs_rate_limited_total");
    res.set_header("Retry-After", std::to_string(std::max(1, static_cast<int>(std::ceil(wait)))));
    throw ProblemError(ProblemKind::kRateLimited,
                       "client \"" + client + "\" is over its limit of " +
                           Json(options.rate_limit).dump() + " submissions per second (burst " +
                           Json(options.rate_burst).dump() + "); retry in " + Json(wait).dump() +
                           " s");
  }

  /// Compute parameters given inside a scene JSON: {"params": {"max_depth": 12, ...}}.
  static void params_from_json(const std::string& body, JobParams& params) {
    check_json_depth(body, "the scene", ErrorCode::kInvalidScene);
    // Only the top level's "params" is built: the rest of a scene body (up to --max-body of
    // vertices, ~100 bytes of DOM per value) is read and dropped.
    const Json doc = Json::parse(
        body,
        [](int depth, Json::parse_event_t event, Json& parsed) {
          return depth != 1 || event != Json::parse_event_t::key || parsed == "params";
        },
        false);
    if (!doc.is_object() || !doc.contains("params")) return;
    const Json& p = doc["params"];
    if (!p.is_object())
      throw Error(ErrorCode::kInvalidArgument, "\"params\" must be a JSON object");
    for (const auto& [key, value] : p.items()) {
      if (value.is_array()) {
        std::string joined;
        for (const Json& v : value) joined += (joined.empty() ? "" : ",") + v.dump();
        params.set(key, joined);
      } else {
        params.set(key, value.is_string() ? value.get<std::string>() : value.dump());
      }
    }
  }

  /// multipart/form-data: one mesh per part (PLY/STL/OFF/OBJ...), part name = label; a part
  /// named "params" holds the parameters as JSON. The meshes are the core's to assemble
  /// (parse_scene_parts, as the CLI's several files): the server only hands over the bytes.
  Scene scene_from_parts(const httplib::Request& req, const SceneLimits& limits,
                         JobParams& params) const {
    std::vector<ScenePart> parts;
    for (const auto& [name, part] : req.files) {
      if (name == "params") {
        if (!Json::accept(part.content)) {
          throw Error(ErrorCode::kInvalidArgument, "the \"params\" part is not valid JSON");
        }
        params_from_json("{\"params\":" + part.content + "}", params);
        continue;
      }
      parts.push_back({name,
                       {reinterpret_cast<const uint8_t*>(part.content.data()), part.content.size()},
                       SceneFormat::kAuto,
                       name.empty() ? std::string("a multipart part") : "part \"" + name + "\""});
    }
    if (parts.empty())
      throw Error(ErrorCode::kInvalidScene, "the multipart body has no mesh parts");
    return parse_scene_parts(parts, limits);
  }

  void status(const httplib::Request& req, httplib::Response& res) {
    const std::string id = req.matches[1].str();
    const auto s = jobs.status_json(id);
    if (!s) throw ProblemError(ProblemKind::kNotFound, "no job " + id);
    res.set_header("Cache-Control", "no-store");
    res.set_content(*s, "application/json");
  }

  void remove(const httplib::Request& req, httplib::Response& res) {
    const std::string id = req.matches[1].str();
    switch (jobs.remove(id)) {
      case JobQueue::DeleteOutcome::kUnknown:
        throw ProblemError(ProblemKind::kNotFound, "no job " + id);
      case JobQueue::DeleteOutcome::kCancelled:
        res.status = 200;
        res.set_content(jobs.status_json(id).value_or("{}"), "application/json");
        return;
      case JobQueue::DeleteOutcome::kCancelling:
        res.status = 202;
        res.set_content(jobs.status_json(id).value_or("{}"), "application/json");
        return;
      case JobQueue::DeleteOutcome::kForgotten:
        res.status = 204;
        return;
    }
  }

  /// ETag = the job id (a job's GLB, glTF, JSON and graph are the same bytes whenever it is
  /// computed), or `own_tag` when given. True when the client's copy is current.
  static bool not_modified(const httplib::Request& req, httplib::Response& res,
                           const std::string& id, const std::string& own_tag = "") {
    const std::string etag = "\"" + (own_tag.empty() ? id : own_tag) + "\"";
    res.set_header("ETag", etag);
    res.set_header("Cache-Control", "public, max-age=86400");
    const std::string inm = req.get_header_value("If-None-Match");
    if (inm.empty()) return false;
    size_t start = 0;
    while (start <= inm.size()) {
      size_t comma = inm.find(',', start);
      if (comma == std::string::npos) comma = inm.size();
      std::string tag = inm.substr(start, comma - start);
      tag.erase(0, tag.find_first_not_of(' '));
      tag.erase(tag.find_last_not_of(' ') + 1);
      if (tag.starts_with("W/")) tag = tag.substr(2);
      if (tag == etag || tag == "*") {
        res.status = 304;
        return true;
      }
      start = comma + 1;
    }
    return false;
  }

  static void send_bytes(httplib::Response& res, const LoadedResult::Bytes& bytes,
                         const char* type) {
    res.set_content_provider(bytes->size(), type,
                             [bytes](size_t offset, size_t length, httplib::DataSink& sink) {
                               const size_t n = std::min(length, bytes->size() - offset);
                               return sink.write(bytes->data() + offset, n);
                             });
  }

  enum class Output { kGlb, kGltf, kJson, kGraph };

  void output(const httplib::Request& req, httplib::Response& res, Output what) {
    const std::string id = req.matches[1].str();
    if (what == Output::kGlb && req.has_param("format")) {
      const std::string f = req.get_param_value("format");
      if (f == "json")
        what = Output::kJson;
      else if (f == "gltf")
        what = Output::kGltf;
      else if (f != "glb")
        throw Error(ErrorCode::kInvalidArgument,
                    "format must be glb, gltf or json, got \"" + f + "\"");
    }
    if (jobs.status(id) == JobStatus::kDone && not_modified(req, res, id)) return;
    const std::shared_ptr<LoadedResult> r = jobs.result(id);
    if (what != Output::kGraph && is_grid_result(r->result())) {
      res.headers.erase("ETag");  // set by the conditional check above: not for a refusal
      res.headers.erase("Cache-Control");
      require_adaptive(r->result(), id, "the GVD surface (gvd.glb, gvd.gltf, gvd.json)");
    }
    not_modified(req, res, id);
    switch (what) {
      case Output::kGlb:
        send_bytes(res, r->glb(), "model/gltf-binary");
        break;
      case Output::kGltf:
        send_bytes(res, r->gltf(), "model/gltf+json");
        break;
      case Output::kJson:
        send_bytes(res, r->json(), "application/json");
        break;
      case Output::kGraph:
        send_bytes(res, r->graph(), "application/json");
        break;
    }
  }

  /// The saved result holds the run's stage times, so a job computed again (after DELETE, or
  /// on another replica) has other bytes: its strong ETag is the id and the file's own
  /// checksum (its last 8 bytes, save_result's FNV-1a trailer), not the id alone.
  static std::string result_file_tag(const std::string& id, const std::string& path) {
    std::ifstream in(path, std::ios::binary | std::ios::ate);
    if (!in || in.tellg() < 8) return "";
    in.seekg(-8, std::ios::end);
    unsigned char trailer[8] = {};
    in.read(reinterpret_cast<char*>(trailer), 8);
    if (!in) return "";
    std::string tag = id + "-";
    for (int i = 7; i >= 0; --i) {
      static constexpr char kHex[] = "0123456789abcdef";
      tag += kHex[trailer[i] >> 4];
      tag += kHex[trailer[i] & 15];
    }
    return tag;
  }

  void result_file(const httplib::Request& req, httplib::Response& res) {
    const std::string id = req.matches[1].str();
    const std::string path = jobs.result_path(id);
    // The status checks, and the file reads back.
    require_adaptive(jobs.result(id)->result(), id, "result.gvd");
    const std::string tag = result_file_tag(id, path);
    if (!tag.empty() && not_modified(req, res, id, tag)) return;
    const std::vector<uint8_t> bytes = read_file_bytes(path);
    res.set_header("Content-Disposition", "attachment; filename=\"" + id + ".gvd\"");
    res.set_content(reinterpret_cast<const char*>(bytes.data()), bytes.size(),
                    "application/octet-stream");
  }

  /// Server-sent events: one "status" event per change of the job (the status document as
  /// data), then an event named after the final status, then the stream ends.
  void events(const httplib::Request& req, httplib::Response& res) {
    const std::string id = req.matches[1].str();
    if (!jobs.status(id)) throw ProblemError(ProblemKind::kNotFound, "no job " + id);
    if (streams.fetch_add(1) >= options.max_streams) {
      streams.fetch_sub(1);
      throw ProblemError(ProblemKind::kTooManyStreams,
                         "already " + std::to_string(options.max_streams) +
                             " event streams open; poll /v1/jobs/" + id + " instead");
    }
    struct State {
      explicit State(std::atomic<int>& c) : count(c) {}
      ~State() { count.fetch_sub(1); }
      std::atomic<int>& count;
      uint64_t seen = 0;
      bool started = false;
      bool ended = false;
      std::string last;
      Clock::time_point last_write = Clock::now();
    };
    auto state = std::make_shared<State>(streams);
    res.set_header("Cache-Control", "no-store");
    res.set_header("X-Accel-Buffering", "no");
    res.set_chunked_content_provider(
        "text/event-stream", [this, id, state](size_t, httplib::DataSink& sink) {
          if (state->ended || closing) {
            sink.done();
            return true;
          }
          state->seen = state->started ? jobs.wait_for_change(state->seen, std::chrono::seconds(1))
                                       : jobs.version();
          state->started = true;
          const auto s = jobs.status_json(id);
          if (!s) {
            const std::string gone = "event: gone\ndata: {\"id\":\"" + id + "\"}\n\n";
            sink.write(gone.data(), gone.size());
            state->ended = true;
            return true;
          }
          const Json doc = Json::parse(*s);
          const std::string status = doc.value("status", "");
          const bool final = status == "done" || status == "failed" || status == "cancelled";
          std::string out;
          // Progress documents differ in their running stage time: send at most one per
          // change of stage/fraction/status, plus a comment as heartbeat.
          Json key = doc["progress"];
          for (Json& st : key["stages"]) st.erase("seconds");
          const std::string summary = status + key.dump();
          if (summary != state->last) {
            out += "event: " + std::string(final ? status : "status") + "\ndata: " + *s + "\n\n";
            state->last = summary;
          } else if (Clock::now() - state->last_write > std::chrono::seconds(10)) {
            out += ": keep-alive\n\n";
          }
          if (!out.empty()) {
            if (!sink.write(out.data(), out.size())) return false;
            state->last_write = Clock::now();
          }
          if (final) state->ended = true;
          return true;
        });
  }

  /// The web viewer (clients/web, copied with three.js into the build): index.html at `/`,
  /// its modules under /viewer/, three.js under /vendor/. Without a web root, `/` is a page
  /// of links.
  void web_file(const httplib::Request& req, httplib::Response& res, const std::string& relative) {
    if (web.serve(req, res, relative)) return;
    if (relative == "index.html") {
      res.set_content(kIndexHtml, "text/html; charset=utf-8");
      return;
    }
    throw ProblemError(ProblemKind::kNotFound,
                       web.available() ? "no file " + req.path + " in the web viewer"
                                       : "the web viewer is not installed on this server");
  }

  void readyz(const httplib::Request& req, httplib::Response& res) {
    // Probes have their own threads: say so when the others are all busy and their queue is
    // full, as the gate does when it answers a probe itself.
    const GateCounts gate = http.gate_counts();
    if (!draining && gate.busy >= static_cast<uint64_t>(options.http_threads) &&
        gate.queued >= static_cast<uint64_t>(options.max_queued_requests)) {
      t_request.route = "overloaded";
      metrics.count("gvd_http_requests_overloaded_total");
      log_overload(req.path);
      res.status = 503;
      res.set_header("Retry-After", std::to_string(options.retry_after));
      res.set_header("Cache-Control", "no-store");
      res.set_content(overloaded_readyz(), "application/json");
      return;
    }
    std::string why;
    const bool queue_up = jobs.available(&why);
    Json body = {{"status", draining   ? "draining"
                            : queue_up ? "ready"
                                       : "queue-unavailable"},
                 {"backend", backend},
                 {"backend_requested", options.backend},
                 {"algorithm_version", kAlgorithmVersion},
                 {"workers", options.workers},
                 {"queue_depth", jobs.queue_depth()},
                 {"queue_capacity", options.queue},
                 {"running", jobs.running()}};
    const Json extra = Json::parse(jobs.readiness_json());
    for (const auto& [k, v] : extra.items()) body[k] = v;
    const bool ready = !draining && queue_up;
    res.status = ready ? 200 : 503;
    if (!ready) res.set_header("Retry-After", std::to_string(options.retry_after));
    res.set_header("Cache-Control", "no-store");
    res.set_content(body.dump(), "application/json");
  }

  void problem_doc(const httplib::Request& req, httplib::Response& res) {
    const std::string name = "/problems/" + req.matches[1].str();
    for (int k = 0; k < kProblemKindCount; ++k) {
      const ProblemInfo& info = problem_info(static_cast<ProblemKind>(k));
      if (info.type == name) {
        res.set_content(Json{{"type", info.type},
                             {"title", info.title},
                             {"status", info.status},
                             {"retryable", info.retryable},
                             {"documentation", "docs/API.md#errors"}}
                            .dump(),
                        "application/json");
        return;
      }
    }
    throw ProblemError(ProblemKind::kRouteNotFound, "no problem type " + name);
  }

  /// /readyz while every HTTP thread is busy and --max-queued-requests requests wait.
  std::string overloaded_readyz() const {
    return json_text(Json{{"status", "overloaded"},
                          {"http_threads", options.http_threads},
                          {"max_queued_requests", options.max_queued_requests}});
  }

  /// The answer to a request that finds every HTTP thread busy and --max-queued-requests
  /// requests waiting: the gate sends it at once, built from the request line alone (no
  /// thread runs it, so nothing here may block). Health probes are still answered: /healthz
  /// says the process lives (200: an orchestrator must not restart a server for being busy),
  /// /readyz says it is overloaded (503: a balancer sends the traffic elsewhere until it is
  /// not). Anything else is 503 /problems/overloaded + Retry-After.
  std::string overloaded_answer(std::string_view method, std::string_view path) {
    const std::string id = new_request_id();
    const bool get = method == "GET";
    int status = 503;
    std::string type = "application/json";
    std::string body;
    if (get && path == "/healthz") {
      status = 200;
      body = "{\"status\":\"ok\"}";
    } else if (get && path == "/readyz") {
      body = overloaded_readyz();
    } else {
      type = "application/problem+json";
      body = problem_json(
          ProblemKind::kOverloaded,
          "all " + std::to_string(options.http_threads) + " HTTP threads are busy and " +
              std::to_string(options.max_queued_requests) +
              " requests wait for one (--max-queued-requests); retry after Retry-After",
          path, id);
    }
    // The method as a metrics label: only the ones a route can have (it is not escaped).
    static constexpr std::string_view kMethods[] = {"GET",     "POST", "DELETE", "PUT",
                                                    "OPTIONS", "HEAD", "PATCH"};
    const bool known =
        std::find(std::begin(kMethods), std::end(kMethods), method) != std::end(kMethods);
    metrics.request("overloaded", known ? std::string(method) : "other", status, 0.0);
    if (status == 503) {
      metrics.count("gvd_http_requests_overloaded_total");
      log_overload(path);
    }
    std::string head =
        "HTTP/1.1 " + std::string(status == 200 ? "200 OK" : "503 Service Unavailable") +
        "\r\nContent-Type: " + type + "\r\nContent-Length: " + std::to_string(body.size()) +
        "\r\nCache-Control: no-store\r\nX-Request-Id: " + id;
    if (status == 503) head += "\r\nRetry-After: " + std::to_string(options.retry_after);
    return head + "\r\nConnection: close\r\n\r\n" + body;
  }

  /// One warn line when the server starts refusing for overload, then at most one a second
  /// while it goes on (a line per refusal would slow the gate that sends them); each says how
  /// many were refused since the last. gvd_http_requests_overloaded_total counts every one.
  void log_overload(std::string_view path) {
    if (options.quiet) return;
    std::lock_guard lock(overload_log_mutex);
    ++overload_unlogged;
    const auto now = Clock::now();
    if (overload_logged != Clock::time_point{} && now - overload_logged < std::chrono::seconds(1))
      return;
    const Json line = {
        {"ts", std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch())
                   .count()},
        {"level", "warn"},
        {"event", "overloaded"},
        {"refused", overload_unlogged},
        {"http_threads", options.http_threads},
        {"max_queued_requests", options.max_queued_requests},
        {"path", path},
        {"msg",
         "every HTTP thread is busy and the request queue is full: answering 503 overloaded "
         "(at most one such line a second; refused = since the last one)"}};
    std::fprintf(stderr, "%s\n", json_text(line).c_str());
    overload_logged = now;
    overload_unlogged = 0;
  }
  std::mutex overload_log_mutex;
  Clock::time_point overload_logged{};
  uint64_t overload_unlogged = 0;

  /// --max-body-readers, or half of the HTTP threads when it is 0.
  int max_body_readers() const {
    return options.max_body_readers > 0 ? options.max_body_readers
                                        : std::max(1, options.http_threads / 2);
  }
  /// --max-body-readers-per-client, or a quarter of max_body_readers() (at least 1) when 0.
  int max_body_readers_per_client() const {
    return options.max_body_readers_per_client > 0
               ? std::min(options.max_body_readers_per_client, max_body_readers())
               : std::max(1, max_body_readers() / 4);
  }
  /// --body-budget, or four bodies of --max-body when it is 0.
  uint64_t body_budget() const {
    if (options.body_budget > 0) return options.body_budget;
    return options.max_body > UINT64_MAX / 4 ? UINT64_MAX : options.max_body * 4;
  }

  /// Before a body is read (check_request has passed: its Content-Length is a number within
  /// --max-body): a slot among --max-body-readers (and its address's share of them), its
  /// bytes within --body-budget and the body's deadline, or a refusal.
  std::optional<Rejection> begin_body(const httplib::Request& req) {
    const bool has_body_method =
        req.method == "POST" || req.method == "PUT" || req.method == "PATCH";
    if (!has_body_method || !req.has_header("Content-Length")) return std::nullopt;
    const uint64_t length = std::stoull(req.get_header_value("Content-Length"));
    switch (http.begin_body(length)) {
      case BodyAdmission::kAdmitted:
        return std::nullopt;
      case BodyAdmission::kTooManyReaders:
        return Rejection{ProblemKind::kOverloaded,
                         std::to_string(max_body_readers()) +
                             " HTTP threads are reading request bodies, the most that may "
                             "(--max-body-readers); retry after Retry-After"};
      case BodyAdmission::kTooManyForClient:
        return Rejection{ProblemKind::kOverloaded,
                         "this client address (" + req.remote_addr + ") is sending " +
                             std::to_string(max_body_readers_per_client()) +
                             " request bodies already, the most one address may "
                             "(--max-body-readers-per-client); retry after Retry-After"};
      case BodyAdmission::kOverBudget:
        return Rejection{ProblemKind::kOverloaded,
                         "the request bodies being read and handled and this one (" +
                             std::to_string(length) + " bytes) would exceed " +
                             std::to_string(body_budget()) +
                             " bytes (--body-budget); retry after Retry-After"};
    }
    return std::nullopt;
  }

  std::string body_timeout_detail(const httplib::Request& req) const {
    const std::string length = req.get_header_value("Content-Length");
    const double seconds =
        options.body_seconds + static_cast<double>(length.empty() ? 0 : std::stoull(length)) /
                                   static_cast<double>(options.min_body_rate);
    char detail[256];
    std::snprintf(detail, sizeof detail,
                  "the request body of %s bytes did not arrive within %.3g s (--body-seconds "
                  "%g + Content-Length / --min-body-rate %llu bytes/s)",
                  length.empty() ? "0" : length.c_str(), seconds, options.body_seconds,
                  static_cast<unsigned long long>(options.min_body_rate));
    return detail;
  }

  void setup();
};

void HttpServer::Impl::setup() {
  GateLimits gate;
  gate.header_seconds = options.header_timeout;
  gate.idle_seconds = options.keep_alive_timeout;
  gate.max_header_bytes =
      static_cast<size_t>(std::min<uint64_t>(options.max_header_bytes, 1u << 20)) + 8192;
  gate.max_waiting_per_client = options.max_waiting_per_client;
  gate.max_waiting = options.max_waiting;
  gate.max_queued = options.max_queued_requests;
  // Probes have a lane of their own (they need no body and little state): an orchestrator's
  // /healthz must not time out behind slow requests and restart a server that is only busy.
  gate.priority_paths = {"/healthz", "/readyz", "/metrics"};
  gate.priority_threads = 2;
  gate.max_body_readers = max_body_readers();
  gate.max_body_readers_per_client = max_body_readers_per_client();
  gate.max_body_bytes = body_budget();
  gate.body_seconds = options.body_seconds;
  gate.min_body_rate = static_cast<double>(options.min_body_rate);
  gate.overloaded = [this](std::string_view method, std::string_view path) {
    return overloaded_answer(method, path);
  };
  const double header_timeout = options.header_timeout;
  const uint64_t max_header_bytes = options.max_header_bytes;
  gate.answer = [header_timeout, max_header_bytes](int status) {
    const bool slow = status == 408;
    char detail[160];
    if (slow) {
      std::snprintf(detail, sizeof detail,
                    "the request headers did not arrive within %g s of their first byte "
                    "(--header-timeout)",
                    header_timeout);
    } else {
      std::snprintf(detail, sizeof detail,
                    "a header line is longer than 8192 bytes, or the headers are larger than "
                    "%llu bytes (--max-header-bytes)",
                    static_cast<unsigned long long>(max_header_bytes));
    }
    const std::string body = problem_json(
        slow ? ProblemKind::kRequestTimeout : ProblemKind::kHeadersTooLarge, detail, "", "");
    return "HTTP/1.1 " +
           std::string(slow ? "408 Request Timeout" : "431 Request Header Fields Too Large") +
           "\r\nContent-Type: application/problem+json\r\nContent-Length: " +
           std::to_string(body.size()) + "\r\nConnection: close\r\n\r\n" + body;
  };
  http.set_gate_limits(gate);
  // glibc keeps what a large body and its parse freed (a rejected 66 MB scene left 1.4 GB
  // resident, which the memory watchdog then blamed on the next jobs): give it back.
  http.set_after_request([] {
    if (!t_large_request) return;
    t_large_request = false;
    malloc_trim(0);
  });
  http.set_tcp_nodelay(true);
  // cpp-httplib 0.11.4 listens with a backlog of 5: a burst of new connections overflows it
  // and the kernel drops SYNs (clients retry after 1 s). Keep its SO_REUSEADDR, remember the
  // socket, and raise the backlog after binding (listen() again on Linux only changes it).
  http.set_socket_options([this](socket_t sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    listen_socket = sock;
  });
  http.set_payload_max_length(options.max_body);
  http.set_read_timeout(options.read_timeout, 0);
  http.set_write_timeout(options.write_timeout, 0);
  http.set_keep_alive_max_count(static_cast<size_t>(options.keep_alive_max));
  http.set_keep_alive_timeout(options.keep_alive_timeout);
  http.set_file_extension_and_mimetype_mapping("glb", "model/gltf-binary");
  http.set_file_extension_and_mimetype_mapping("gltf", "model/gltf+json");

  http.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
    begin_request(req, res);
    if (auto r = check_request(req); r || (r = begin_body(req))) {
      reject(req, res, *r);
      return httplib::Server::HandlerResponse::Handled;
    }
    return httplib::Server::HandlerResponse::Unhandled;
  });
  // "Expect: 100-continue" is answered before routing: refuse there too, before the body.
  http.set_expect_100_continue_handler([this](const httplib::Request& req, httplib::Response& res) {
    begin_request(req, res);
    if (auto r = check_request(req); r || (r = begin_body(req))) {
      reject(req, res, *r);
      return res.status;
    }
    return 100;
  });
  http.set_error_handler(httplib::Server::HandlerWithResponse([this](const httplib::Request& req,
                                                                     httplib::Response& res) {
    if (!res.body.empty() || res.content_provider_) {
      return httplib::Server::HandlerResponse::Unhandled;
    }
    if (GatedServer::body_timed_out()) {
      // The read failed at the body's deadline (httplib says 400): say so; the gate closes
      // the connection after this answer.
      res.set_header("Connection", "close");
      send_problem(req, res, ProblemKind::kRequestTimeout, body_timeout_detail(req));
      return httplib::Server::HandlerResponse::Handled;
    }
    const int status = res.status;
    if (status == 404) {
      std::string allow;
      for (size_t i = 0; i < kRoutes.size(); ++i) {
        if (std::regex_match(req.path, route_patterns[i])) {
          allow += (allow.empty() ? "" : ", ") + std::string(kRoutes[i].method);
        }
      }
      if (!allow.empty()) {
        res.set_header("Allow", allow);
        send_problem(req, res, ProblemKind::kMethodNotAllowed,
                     req.method + " is not allowed on " + req.path + " (allowed: " + allow + ")");
      } else {
        send_problem(req, res, ProblemKind::kRouteNotFound, "no route " + req.path);
      }
    } else if (status == 413) {
      send_problem(req, res, ProblemKind::kBodyTooLarge, "the request body is too large");
    } else if (status == 414) {
      send_problem(req, res, ProblemKind::kUriTooLong,
                   "the request line is longer than 8192 bytes; send long point lists in the "
                   "body of a POST");
    } else if (status == 400 &&
               req.get_header_value("Content-Type").starts_with("multipart/form-data")) {
      // cpp-httplib's multipart reader says no more than that it failed.
      send_problem(req, res, ProblemKind::kInvalidArgument,
                   "malformed multipart body: its parts must be separated by the boundary "
                   "named in Content-Type and end with --boundary--; a part header is at most "
                   "8192 bytes and a body at most 1024 parts (cpp-httplib's limits)");
    } else if (status == 400) {
      send_problem(req, res, ProblemKind::kInvalidArgument, "malformed HTTP request");
    } else {
      res.set_content(json_text(Json{{"type", "about:blank"},
                                     {"status", status},
                                     {"title", "HTTP error " + std::to_string(status)},
                                     {"instance", req.path},
                                     {"request_id", t_request.id}}),
                      "application/problem+json");
    }
    return httplib::Server::HandlerResponse::Handled;
  }));
  // Reached only when the catch boundary of `wrap` itself failed (or before routing): nothing
  // may escape from here, it would end the HTTP thread.
  http.set_exception_handler(
      [this](const httplib::Request& req, httplib::Response& res, std::exception_ptr) {
        try {
          send_problem(req, res, ProblemKind::kInternal,
                       "internal error (request " + t_request.id + ")");
        } catch (...) {
          res.status = 500;
          res.body.clear();
        }
      });
  http.set_logger(
      [this](const httplib::Request& req, const httplib::Response& res) { log(req, res); });

  // cpp-httplib tries the routes in this order, one regex match each: the hot query routes
  // first (the patterns are anchored and disjoint, so the order changes nothing else).
  route("GET", "/v1/jobs/{id}/objects/{label}/neighbors",
        [this](const auto& req, auto& res) { queries.neighbors(req, res); });
  route("GET", "/v1/jobs/{id}/nearest",
        [this](const auto& req, auto& res) { queries.nearest(req, res); });
  route("GET", "/", [this](const auto& req, auto& res) { web_file(req, res, "index.html"); });
  route("GET", "/viewer/{path}", [this](const auto& req, auto& res) {
    web_file(req, res, "viewer/" + req.matches[1].str());
  });
  route("GET", "/vendor/{path}", [this](const auto& req, auto& res) {
    web_file(req, res, "vendor/" + req.matches[1].str());
  });
  route("GET", "/healthz", [](const auto&, auto& res) {
    res.set_header("Cache-Control", "no-store");
    res.set_content("{\"status\":\"ok\"}", "application/json");
  });
  route("GET", "/readyz", [this](const auto& req, auto& res) { readyz(req, res); });
  route("GET", "/metrics", [this](const auto&, auto& res) {
    res.set_content(metrics.render(), "text/plain; version=0.0.4; charset=utf-8");
  });
  route("GET", "/openapi.json",
        [](const auto&, auto& res) { res.set_content(kOpenApiJson, "application/json"); });
  route("POST", "/v1/jobs", [this](const auto& req, auto& res) { submit(req, res); });
  route("GET", "/v1/jobs", [this](const auto&, auto& res) {
    res.set_header("Cache-Control", "no-store");
    res.set_content(jobs.list_json(), "application/json");
  });
  route("GET", "/v1/jobs/{id}", [this](const auto& req, auto& res) { status(req, res); });
  route("DELETE", "/v1/jobs/{id}", [this](const auto& req, auto& res) { remove(req, res); });
  route("GET", "/v1/jobs/{id}/events", [this](const auto& req, auto& res) { events(req, res); });
  route("GET", "/v1/jobs/{id}/gvd.glb",
        [this](const auto& req, auto& res) { output(req, res, Output::kGlb); });
  route("GET", "/v1/jobs/{id}/gvd.gltf",
        [this](const auto& req, auto& res) { output(req, res, Output::kGltf); });
  route("GET", "/v1/jobs/{id}/gvd.json",
        [this](const auto& req, auto& res) { output(req, res, Output::kJson); });
  route("GET", "/v1/jobs/{id}/graph",
        [this](const auto& req, auto& res) { output(req, res, Output::kGraph); });
  route("GET", "/v1/jobs/{id}/result.gvd",
        [this](const auto& req, auto& res) { result_file(req, res); });
  route("POST", "/v1/jobs/{id}/nearest",
        [this](const auto& req, auto& res) { queries.nearest_batch(req, res); });
  route("POST", "/v1/jobs/{id}/paths",
        [this](const auto& req, auto& res) { queries.paths(req, res); });
  route("GET", "/v1/jobs/{id}/explode",
        [this](const auto& req, auto& res) { queries.explode(req, res); });
  route("GET", "/v1/jobs/{id}/tight",
        [this](const auto& req, auto& res) { queries.tight(req, res); });
  route("GET", "/v1/jobs/{id}/contacts",
        [this](const auto& req, auto& res) { queries.contacts(req, res); });
  route("GET", "/v1/jobs/{id}/field.npy",
        [this](const auto& req, auto& res) { queries.grid(req, res, false); });
  route("GET", "/v1/jobs/{id}/labels.npy",
        [this](const auto& req, auto& res) { queries.grid(req, res, true); });
  route("GET", "/problems/{name}", [this](const auto& req, auto& res) { problem_doc(req, res); });
  GVD_CHECK(registered.size() == kRoutes.size(), "every route of routes.h has a handler");

  metrics.gauge("gvd_queue_depth", "Jobs waiting in the queue.",
                [this] { return static_cast<double>(jobs.queue_depth()); });
  metrics.gauge("gvd_queue_capacity", "Jobs the queue holds before 503.",
                [this] { return static_cast<double>(options.queue); });
  metrics.gauge("gvd_jobs_running", "Jobs being computed.",
                [this] { return static_cast<double>(jobs.running()); });
  metrics.gauge("gvd_results_cached", "Finished results held in memory.",
                [this] { return static_cast<double>(jobs.cached_results()); });
  metrics.gauge("gvd_event_streams", "Open server-sent event streams.",
                [this] { return static_cast<double>(streams.load()); });
  metrics.gauge("gvd_http_waiting_connections",
                "Connections waiting for their request headers (not holding a thread).",
                [this] { return static_cast<double>(http.gate_counts().waiting); });
  metrics.gauge("gvd_http_header_timeouts",
                "Connections closed since start because their headers did not arrive in time.",
                [this] { return static_cast<double>(http.gate_counts().timed_out); });
  metrics.gauge("gvd_http_connections_evicted",
                "Waiting connections closed since start to make room (per-client or total cap).",
                [this] { return static_cast<double>(http.gate_counts().evicted); });
  metrics.gauge("gvd_http_threads_busy", "HTTP threads running a request now.",
                [this] { return static_cast<double>(http.gate_counts().busy); });
  metrics.gauge("gvd_http_queued_requests",
                "Requests with complete headers waiting for a busy HTTP thread now.",
                [this] { return static_cast<double>(http.gate_counts().queued); });
  metrics.gauge("gvd_http_body_readers", "HTTP threads reading a request body now.",
                [this] { return static_cast<double>(http.gate_counts().body_readers); });
  metrics.gauge("gvd_http_max_body_readers",
                "HTTP threads that may read request bodies at once (--max-body-readers).",
                [this] { return static_cast<double>(max_body_readers()); });
  metrics.gauge(
      "gvd_http_body_readers_refused",
      "Requests refused since start (503 overloaded) because --max-body-readers bodies were read.",
      [this] { return static_cast<double>(http.gate_counts().body_refused); });
  metrics.gauge("gvd_http_max_body_readers_per_client",
                "Request bodies one client address may send at once "
                "(--max-body-readers-per-client).",
                [this] { return static_cast<double>(max_body_readers_per_client()); });
  metrics.gauge("gvd_http_body_readers_refused_client",
                "Requests refused since start (503 overloaded) because their address was reading "
                "--max-body-readers-per-client bodies.",
                [this] { return static_cast<double>(http.gate_counts().body_refused_client); });
  metrics.gauge("gvd_http_body_bytes", "Bytes of the request bodies being read or handled now.",
                [this] { return static_cast<double>(http.gate_counts().body_bytes); });
  metrics.gauge("gvd_http_body_budget_bytes",
                "Bytes of request bodies that may be held at once (--body-budget).",
                [this] { return static_cast<double>(body_budget()); });
  metrics.gauge("gvd_http_body_budget_refused",
                "Requests refused since start (503 overloaded) because their body would have "
                "exceeded --body-budget.",
                [this] { return static_cast<double>(http.gate_counts().body_refused_bytes); });
  metrics.gauge("gvd_http_body_timeouts",
                "Request bodies since start that did not arrive within their deadline (408).",
                [this] { return static_cast<double>(http.gate_counts().body_timed_out); });
  metrics.gauge("gvd_http_probes_served",
                "Requests since start served in the probes' lane (/healthz, /readyz, /metrics).",
                [this] { return static_cast<double>(http.gate_counts().priority_served); });
  metrics.gauge(
      "gvd_http_max_queued_requests",
      "Requests that may wait for a thread before 503 overloaded (--max-queued-requests).",
      [this] { return static_cast<double>(options.max_queued_requests); });
  metrics.gauge("gvd_draining", "1 while shutting down.", [this] { return draining ? 1.0 : 0.0; });
  metrics.gauge("process_resident_memory_bytes", "Resident memory of the server.",
                [] { return static_cast<double>(resident_memory_bytes()); });
}

HttpServer::HttpServer(const ServerOptions& options) : impl_(std::make_unique<Impl>(options)) {
  impl_->setup();
  // One small computation with the configured backend before serving: it fails early and
  // loudly when the backend is unusable, and initialises it once on one thread (OpenCL
  // platforms must not see their first calls from several workers at once).
  const Scene probe = parse_scene_json(R"({"dimension":2,"objects":[
      {"label":"a","vertices":[[0,0],[1,0]],"segments":[[0,1]]},
      {"label":"b","vertices":[[0,1],[1,1]],"segments":[[0,1]]}]})");
  PipelineOptions o;
  o.backend = options.compute ? BackendRequest::kOpenCl : BackendRequest::kCpu;
  o.compute = options.compute;
  o.backend_note = options.backend_note;
  o.threads = 1;
  o.max_depth = 6;
  impl_->backend = compute_gvd(probe, o).stats.backend;
}

HttpServer::~HttpServer() {
  impl_->closing = true;
  impl_->http.stop();
  impl_->jobs.stop();
}

const std::string& HttpServer::backend() const { return impl_->backend; }

int HttpServer::bind() {
  Impl& s = *impl_;
  if (s.options.port == 0) {
    s.port = s.http.bind_to_any_port(s.options.host);
    if (s.port <= 0) return -1;
  } else {
    if (!s.http.bind_to_port(s.options.host.c_str(), s.options.port)) return -1;
    s.port = s.options.port;
  }
  if (s.listen_socket != INVALID_SOCKET) ::listen(s.listen_socket, SOMAXCONN);
  return s.port;
}

bool HttpServer::serve() {
  impl_->jobs.start();
  return impl_->http.listen_after_bind();
}

void HttpServer::shutdown() {
  Impl& s = *impl_;
  s.draining = true;
  s.jobs.drain(std::chrono::milliseconds(static_cast<int64_t>(s.options.grace_seconds * 1000)));
  s.closing = true;
  s.http.stop();
  s.jobs.stop();
}

}  // namespace gvd::server
