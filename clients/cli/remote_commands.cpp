// `gvd --server URL compute | info | nearest | neighbors | path | explode | tight | contacts`:
// the same commands as the local ones, answered by gvd-server. Query answers are printed exactly as
// the local commands print them (the server builds them with the same functions), so scripts do not
// care where the answer came from.
#include "remote_commands.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <optional>
#include <string_view>
#include <thread>
#include <vector>

#include "cli_options.h"
#include "commands.h"
#include "gvd/common/json_depth.h"
#include "gvd/io/write_outputs.h"
#include "gvd/pipeline/parameters.h"
#include "gvd/scene/units.h"
#include "http_client.h"

namespace gvd::cli {

using namespace gvd::scene;
using namespace gvd::io;
using namespace gvd::pipeline;

namespace {

using Json = nlohmann::json;

// THE table: problem type (docs/API.md, server/src/problem.cpp) -> exit code.
struct ProblemExit {
  std::string_view type;
  int exit_code;
};
constexpr std::array<ProblemExit, 28> kProblemExits = {{
    {"/problems/invalid-scene", kExitBadInput},
    {"/problems/invalid-argument", kExitBadInput},
    {"/problems/unsupported-format", kExitBadInput},
    {"/problems/outside-domain", kExitBadInput},
    {"/problems/limit-exceeded", kExitLimit},
    {"/problems/not-found", kExitIo},
    {"/problems/io-error", kExitIo},
    {"/problems/cancelled", kExitCancelled},
    {"/problems/internal", kExitInternal},
    {"/problems/route-not-found", kExitIo},           // a server without this API (wrong URL?)
    {"/problems/method-not-allowed", kExitInternal},  // our bug
    {"/problems/length-required", kExitInternal},     // our bug
    {"/problems/body-too-large", kExitLimit},
    {"/problems/headers-too-large", kExitLimit},
    {"/problems/unsupported-media-type", kExitBadInput},
    {"/problems/unsupported-encoding", kExitInternal},  // our bug
    {"/problems/queue-full", kExitBusy},
    {"/problems/draining", kExitBusy},
    {"/problems/too-many-streams", kExitBusy},
    {"/problems/job-not-finished", kExitBusy},  // try again later
    {"/problems/job-failed", kExitLimit},       // (the job's own error is used when known)
    {"/problems/no-path", kExitNoPath},
    {"/problems/rate-limited", kExitBusy},
    {"/problems/queue-unavailable", kExitBusy},
    {"/problems/uri-too-long", kExitInternal},    // our bug: long lists go in POST bodies
    {"/problems/request-timeout", kExitNetwork},  // too slow for --header-timeout/--body-seconds
    {"/problems/overloaded", kExitBusy},          // every HTTP thread busy, queue full
    {"/problems/adaptive-only", kExitBadInput},   // a grid job asked for the octree's outputs
}};

// Flags that set a job parameter (sent as query parameters) are the table's job parameters
// (gvd/pipeline/parameters.h), the labelled volume's among them; these configure a
// computation the server does its own way (refused in remote mode rather than ignored).
constexpr std::array<std::pair<std::string_view, std::string_view>, 6> kServerSide = {{
    {"--threads", "--job-threads"},
    {"--backend", "--backend"},
    {"--max-leaves", "--max-leaves"},
    {"--max-objects", "--max-objects"},
    {"--max-simplices", "--max-simplices"},
    {"--max-cells", "--max-grid-cells"},
}};

constexpr std::array<std::pair<std::string_view, std::string_view>, 5> kSceneTypes = {{
    {".json", "application/json"},
    {".obj", "model/obj"},
    {".glb", "model/gltf-binary"},
    {".gltf", "model/gltf+json"},
    {".npy", "application/x-npy"},  // a labelled volume (--volume)
}};

const std::vector<std::string>& remote_value_flags() {
  static const std::vector<std::string> flags = {"--job", "--retries", "--timeout"};
  return flags;
}

/// A member of a JSON object, or `fallback` when it is missing, null or of another type
/// (nlohmann's value() throws on null: "finished_at": null, "stage": null while queued).
std::string text(const Json& j, const char* key, const std::string& fallback = "") {
  if (!j.is_object()) return fallback;
  const auto it = j.find(key);
  return it != j.end() && it->is_string() ? it->get<std::string>() : fallback;
}
double number(const Json& j, const char* key, double fallback = 0) {
  if (!j.is_object()) return fallback;
  const auto it = j.find(key);
  return it != j.end() && it->is_number() ? it->get<double>() : fallback;
}
Json member(const Json& j, const char* key, const Json& fallback) {
  if (!j.is_object()) return fallback;
  const auto it = j.find(key);
  return it != j.end() && it->type() == fallback.type() ? *it : fallback;
}

bool quiet(const Args& args) { return args.has("-q") || args.has("--quiet"); }

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

std::string read_text(const std::string& path) {
  if (path == "-") {
    return std::string(std::istreambuf_iterator<char>(std::cin), std::istreambuf_iterator<char>());
  }
  const std::vector<uint8_t> bytes = read_file_bytes(path);
  return std::string(bytes.begin(), bytes.end());
}

/// The server's problem document, or one made up from the status for a non-problem answer.
Json problem_of(const HttpAnswer& a) {
  Json doc = Json::parse(a.body, nullptr, false);
  if (!doc.is_object()) {
    doc = Json{{"type", "about:blank"}, {"status", a.status}, {"detail", a.body.substr(0, 200)}};
  }
  return doc;
}

[[noreturn]] void throw_problem(const Json& problem, int status, const std::string& prefix = "") {
  const std::string type = text(problem, "type", "");
  std::string message = prefix;
  message += text(problem, "title", type.empty() ? "HTTP " + std::to_string(status) : type);
  if (const std::string detail = text(problem, "detail", ""); !detail.empty()) {
    message += ": " + detail;
  }
  throw RemoteError{exit_code_for_problem(type, status), message};
}

/// A server, with the retries of 503 answers and the job-level operations.
class Remote {
 public:
  Remote(const std::string& url, const Args& args)
      : http_(url, timeout_of(args)),
        retries_(args.int_value("--retries", 5)),
        quiet_(quiet(args)) {
    if (retries_ < 0) throw UsageError{"--retries must be >= 0"};
  }

  /// Sends a request (again after a 503, waiting what Retry-After says, at most `retries_`
  /// times) and returns the answer if its status is in `ok`; otherwise throws its problem.
  HttpAnswer call(const std::string& method, const std::string& path, const std::string& body = "",
                  const std::string& content_type = "", std::initializer_list<int> ok = {200},
                  const std::vector<FilePart>* parts = nullptr) {
    for (int attempt = 0;; ++attempt) {
      HttpAnswer a = method == "GET"      ? http_.get(path)
                     : method == "DELETE" ? http_.del(path)
                     : parts != nullptr   ? http_.post_multipart(path, *parts)
                                          : http_.post(path, body, content_type);
      if (std::find(ok.begin(), ok.end(), a.status) != ok.end()) return a;
      if ((a.status == 503 || a.status == 429) && attempt < retries_) {
        wait_busy(a, attempt);
        continue;
      }
      const Json p = problem_of(a);
      if (a.status == 503 || a.status == 429) {
        throw_problem(p, a.status, "server busy after " + std::to_string(retries_) + " retries: ");
      }
      throw_problem(p, a.status);
    }
  }

  /// The job document; throws not-found (exit 5) for an unknown id.
  Json job(const std::string& id) { return Json::parse(call("GET", job_path(id)).body); }

  /// Submits the scene files with the job parameters of `args`; returns the job document.
  Json submit(const std::vector<std::string>& files, const Args& args) {
    std::string query;
    for (const ParamSpec& p : pipeline_parameters()) {
      if (!p.on(kJobParam) || !p.on(kCliFlag) || find_parameter(p.name) != &p) continue;
      const std::string flag = flag_name(p);
      if (p.kind == ParamKind::kFlag) {
        if (args.has(flag)) query += (query.empty() ? "?" : "&") + std::string(p.name) + "=true";
      } else if (const auto v = args.value(flag)) {
        query += (query.empty() ? "?" : "&") + std::string(p.name) + "=" + url_encode(*v);
      }
    }
    for (const auto& [flag, server_flag] : kServerSide) {
      if (args.has(std::string(flag))) {
        throw UsageError{std::string(flag) +
                         " is not a job parameter: the server sets it (gvd-server " +
                         std::string(server_flag) + ")"};
      }
    }
    // Choices the server does not offer: refused rather than silently ignored.
    for (const char* flag : {"--distance", "--octree-build"}) {
      if (args.has(flag)) {
        throw UsageError{std::string(flag) +
                         " is not available from a server (it computes exact distances "
                         "with the level-by-level octree build); run without --server"};
      }
    }
    HttpAnswer a;
    if (files.size() == 1) {
      const std::string ext = lower_extension(files[0]);
      // The server recognises formats by their bytes; the type only has to be a scene type.
      std::string type = "application/octet-stream";
      for (const auto& [e, t] : kSceneTypes) {
        if (ext == e) type = t;
      }
      if (ext == ".ply" || ext == ".stl" || ext == ".off") {
        query += (query.empty() ? "?" : "&") + std::string("label=") +
                 url_encode(std::filesystem::path(files[0]).stem().string());
      }
      a = call("POST", "/v1/jobs" + query, read_text(files[0]), type, {200, 201, 202, 303});
    } else {
      std::vector<FilePart> parts;
      for (const std::string& f : files) {
        const std::filesystem::path p(f);
        parts.push_back({p.stem().string(), p.filename().string(), read_text(f)});
      }
      a = call("POST", "/v1/jobs" + query, "", "", {200, 201, 202, 303}, &parts);
    }
    if (a.status == 303 || a.body.empty()) return Json::parse(call("GET", a.location).body);
    return Json::parse(a.body);
  }

  /// Waits for the job to finish, following its event stream (polling when streams are not
  /// available), with a progress display unless quiet. Returns the final document of a done
  /// job; throws the job's error otherwise.
  Json wait(const std::string& id) {
    auto progress = progress_display(!quiet_);
    std::string last;
    auto report = [&](const Json& doc) {
      const std::string status = text(doc, "status", "");
      const Json p = member(doc, "progress", Json::object());
      const std::string stage = status == "done" ? "done" : text(p, "stage", status);
      const double fraction = status == "done" ? 1.0 : number(p, "fraction", 0.0);
      const std::string key = stage + std::to_string(fraction);
      if (key != last) progress(stage, fraction);
      last = key;
    };
    auto is_final = [](const Json& doc) {
      const std::string s = text(doc, "status", "");
      return s == "done" || s == "failed" || s == "cancelled";
    };
    std::optional<Json> final;
    try {
      const HttpAnswer a = http_.events(job_path(id) + "/events", 30,
                                        [&](const std::string& event, const std::string& data) {
                                          if (event == "gone") return false;
                                          const Json doc = Json::parse(data, nullptr, false);
                                          if (!doc.is_object()) return true;
                                          report(doc);
                                          if (is_final(doc)) final = doc;
                                          return !final;
                                        });
      if (a.status == 404) throw_problem(problem_of(a), a.status);
    } catch (const NetworkError&) {
      // The stream broke (or never started): polling below says whether the server is gone.
    }
    while (!final) {
      const Json doc = job(id);
      report(doc);
      if (is_final(doc)) {
        final = doc;
      } else {
        std::this_thread::sleep_for(std::chrono::milliseconds(250));
      }
    }
    return finished(*final);
  }

  /// A finished job's document if it is done; its error otherwise.
  static Json finished(const Json& doc) {
    const std::string status = text(doc, "status", "");
    if (status == "done") return doc;
    if (status == "failed" || status == "cancelled") {
      const Json error = member(doc, "error", Json::object());
      throw_problem(error.empty() ? Json{{"type", status == "failed" ? "/problems/job-failed"
                                                                     : "/problems/cancelled"}}
                                  : error,
                    static_cast<int>(number(error, "status", 409)),
                    "job " + text(doc, "id", "") + " " + status + ": ");
    }
    throw RemoteError{
        kExitBusy, "job " + text(doc, "id", "") + " is " + status + " (try again when it is done)"};
  }

  /// The job a query is about: --job ID (must be done), or the scene files submitted now.
  std::string query_job(const Args& args) {
    const auto id = args.value("--job");
    if (id && !args.positional.empty()) throw UsageError{"give --job ID or scene files, not both"};
    if (id) {
      finished(job(*id));
      return *id;
    }
    if (args.positional.empty()) {
      throw UsageError{"give --job ID (a job on the server) or scene files to submit"};
    }
    for (const std::string& f : args.positional) {
      if (lower_extension(f) == ".gvd") {
        throw UsageError{f + " is a saved result: query it locally (without --server)"};
      }
    }
    const std::string submitted = text(submit(args.positional, args), "id", "");
    if (!quiet_) std::fprintf(stderr, "gvd: job %s\n", submitted.c_str());
    wait(submitted);
    return submitted;
  }

  static std::string job_path(const std::string& id) { return "/v1/jobs/" + url_encode(id); }

 private:
  static double timeout_of(const Args& args) {
    double t = 60;
    if (const auto v = args.numbers("--timeout")) {
      if (v->size() != 1 || !((*v)[0] > 0)) throw UsageError{"--timeout expects seconds > 0"};
      t = (*v)[0];
    }
    return t;
  }

  void wait_busy(const HttpAnswer& a, int attempt) {
    double seconds = std::min(30.0, std::pow(2.0, attempt));
    if (!a.retry_after.empty()) {
      char* end = nullptr;
      const double s = std::strtod(a.retry_after.c_str(), &end);
      if (end != a.retry_after.c_str() && std::isfinite(s) && s >= 0) seconds = std::min(s, 300.0);
    }
    const Json p = problem_of(a);
    std::fprintf(stderr, "gvd: server busy (%s), retrying in %g s (%d of %d)\n",
                 text(p, "title", std::string("503")).c_str(), seconds, attempt + 1, retries_);
    std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
  }

  HttpClient http_;
  int retries_;
  bool quiet_;
};

Args parse_remote(int argc, char** argv, std::vector<std::string> value_flags,
                  std::vector<std::string> boolean = {}) {
  value_flags.insert(value_flags.end(), compute_value_flags().begin(), compute_value_flags().end());
  value_flags.insert(value_flags.end(), remote_value_flags().begin(), remote_value_flags().end());
  boolean.insert(boolean.end(), {"-q", "--quiet"});
  return parse_args(argc, argv, 2, value_flags, boolean);
}

/// "x,y[,z]" as a JSON array, with the dimension checked like the local commands do.
Json point_arg(const std::string& flag, const std::string& text, int dimension) {
  return Json(point_value(flag, text, dimension));
}

int dimension_of(Remote& remote, const std::string& id) {
  return static_cast<int>(number(remote.job(id)["scene"], "dimension", 3));
}

void print_summary(const Json& doc, std::FILE* out) {
  const Json r = member(doc, "result", Json::object());
  auto num = [&](const char* k) { return number(r, k, 0.0); };
  // The units of the job (top level of its status) or of its result (older servers: none).
  const std::string units = text(doc, "units", text(r, "units", ""));
  std::fprintf(out, "  objects %.0f, simplices %.0f, dimension %.0f%s%s\n", num("objects"),
               num("simplices"), num("dimension"), units.empty() ? "" : ", units ", units.c_str());
  std::fprintf(out, "  backend %s, %.0f threads\n", text(r, "backend", "?").c_str(),
               num("threads"));
  const Json domain = member(r, "domain", Json::object());
  const Json origin = member(domain, "origin", Json::array());
  if (origin.is_array() && !origin.empty()) {
    std::fprintf(out, "  domain: a %s of side %.9g from (", origin.size() == 2 ? "square" : "cube",
                 number(domain, "side", 0.0));
    for (size_t i = 0; i < origin.size(); ++i)
      std::fprintf(out, "%s%.9g", i > 0 ? ", " : "",
                   origin[i].is_number() ? origin[i].get<double>() : 0.0);
    std::fprintf(out, ")%s", units_suffix(units).c_str());
    const Json axes = member(domain, "axes", Json::array());
    if (axes.is_array() && !axes.empty()) {
      std::fprintf(out, ", its edges along the scene's faces:");
      for (const Json& a : axes) {
        if (!a.is_array() || a.size() != 3 || !a[0].is_number() || !a[1].is_number() ||
            !a[2].is_number())
          continue;
        std::fprintf(out, " (%.6f, %.6f, %.6f)", a[0].get<double>(), a[1].get<double>(),
                     a[2].get<double>());
      }
    }
    std::fprintf(out, "\n");
  }
  bool grid_job = false;
  for (const Json& st : member(r, "stages", Json::array()))
    grid_job = grid_job || text(st, "name", "") == "grid";
  if (grid_job) {
    std::fprintf(out, "  grid job (mode=grid): %.0f neighbour pairs\n", num("graph_edges"));
  } else {
    std::fprintf(out,
                 "  octree: depth %.0f (limit %.0f), %.0f leaves (%.0f in certified pair cells), "
                 "%.0f vertices, %.1f bytes/leaf\n",
                 num("depth"), num("max_depth"), num("leaves"), num("certified_leaves"),
                 num("vertices"), num("bytes_per_leaf"));
    std::fprintf(
        out, "  gvd: %.0f simplices (both sides), %.0f neighbour pairs, %.0f refinement rounds\n",
        num("gvd_simplices"), num("graph_edges"), num("refine_rounds"));
  }
  std::fprintf(out, "  stages:");
  for (const Json& st : member(r, "stages", Json::array())) {
    std::fprintf(out, " %s %.3f s;", text(st, "name", "").c_str(), number(st, "seconds", 0.0));
  }
  std::fprintf(out, " total %.3f s\n", num("total_seconds"));
  if (num("peak_rss_bytes") > 0) {
    std::fprintf(out,
                 "  peak memory %.1f MB (the server process's high-water mark), %.0f bytes/leaf\n",
                 num("peak_rss_bytes") / 1e6,
                 num("leaves") > 0 ? num("peak_rss_bytes") / num("leaves") : 0.0);
  }
  for (const Json& w : member(r, "warnings", Json::array())) {
    const std::string object = text(w, "object", "");
    std::fprintf(out, "  warning [%s]%s%s (%.0f): %s\n", text(w, "kind", "").c_str(),
                 object.empty() ? "" : " ", object.c_str(), number(w, "count", 0.0),
                 text(w, "detail", "").c_str());
  }
}

void download(Remote& remote, const std::string& id, const std::string& what,
              const std::string& path) {
  const HttpAnswer a = remote.call("GET", Remote::job_path(id) + "/" + what);
  write_file_atomic(path, a.body.data(), a.body.size());
}

int remote_compute(const std::string& url, int argc, char** argv) {
  // compute's flags, and those of its grid mode (the parameter table's, as locally).
  std::vector<std::string> value_flags = {"-o",     "--output", "--graph",
                                          "--json", "--save",   "--mode"};
  value_flags.insert(value_flags.end(), grid_mode_value_flags().begin(),
                     grid_mode_value_flags().end());
  std::vector<std::string> boolean = {"--no-wait"};
  boolean.insert(boolean.end(), grid_mode_boolean_flags().begin(), grid_mode_boolean_flags().end());
  const Args args = parse_remote(argc, argv, value_flags, boolean);
  std::vector<std::string> files = args.positional;
  if (args.has("--volume-faces")) {
    throw UsageError{
        "--volume-faces is not a job parameter: the server's volumes take merged faces"};
  }
  if (const auto volume = args.value("--volume")) {
    if (!files.empty()) throw UsageError{"--volume takes the place of the scene files"};
    files = {*volume};
  } else if (args.has("--spacing") || args.has("--background")) {
    throw UsageError{"--spacing and --background go with --volume LABELS.npy"};
  }
  if (files.empty()) throw UsageError{"compute needs at least one scene file"};
  if (args.has("--job")) throw UsageError{"compute submits scene files; --job is for queries"};
  const bool grid = args.value("--mode").value_or("adaptive") == "grid";
  const auto out_path = args.value("-o") ? args.value("-o") : args.value("--output");
  if (grid) {
    // A grid job's outputs: its graph and grid (docs/API.md, "Grid jobs").
    for (const char* flag : {"--json", "--save"}) {
      if (args.has(flag))
        throw UsageError{std::string(flag) +
                         " needs the adaptive result; a grid job (--mode grid) has --graph, "
                         "-o FIELD.npy and --labels LABELS.npy"};
    }
    for (const auto& p : {out_path, args.value("--labels")}) {
      if (p && !p->ends_with(".npy"))
        throw UsageError{"a grid job's grids come from a server as .npy (got " + *p +
                         "); gvd grid writes NRRD locally"};
    }
  } else {
    // The grid mode's flags; a server-side one (--max-cells) is refused as such by submit.
    for (const std::vector<std::string>* flags :
         {&grid_mode_value_flags(), &grid_mode_boolean_flags()}) {
      for (const std::string& flag : *flags) {
        const bool server_side = std::any_of(kServerSide.begin(), kServerSide.end(),
                                             [&](const auto& s) { return s.first == flag; });
        if (args.has(flag) && !server_side) throw UsageError{flag + " goes with --mode grid"};
      }
    }
  }
  // The flags' values are read here as locally (a bad one is a usage error, exit 2); the
  // server checks them again, with what only it knows (the scene's bounds, its limits).
  (void)params_from_flags(args);
  Remote remote(url, args);
  const Json submitted = remote.submit(files, args);
  const std::string id = text(submitted, "id", "");
  std::printf("%s\n", id.c_str());
  std::fflush(stdout);
  if (!quiet(args)) {
    std::fprintf(stderr, "gvd: job %s on %s (%s)\n", id.c_str(), url.c_str(),
                 text(submitted, "status", "").c_str());
  }
  if (args.has("--no-wait")) return kExitOk;
  const Json done = remote.wait(id);

  std::vector<std::string> written;
  if (grid && out_path) {
    download(remote, id, "field.npy", *out_path);
    written.push_back(*out_path + " (distance per cell)");
  } else if (out_path) {
    download(remote, id, "gvd.glb", *out_path);
    written.push_back(*out_path + " (GVD, binary glTF)");
  }
  if (const auto p = args.value("--labels")) {
    download(remote, id, "labels.npy", *p);
    written.push_back(*p + " (nearest object per cell)");
  }
  if (const auto p = args.value("--graph")) {
    download(remote, id, "graph", *p);
    written.push_back(*p + " (dual graph)");
  }
  if (const auto p = args.value("--json")) {
    download(remote, id, "gvd.json", *p);
    written.push_back(*p + " (GVD, float64 JSON)");
  }
  if (const auto p = args.value("--save")) {
    download(remote, id, "result.gvd", *p);
    written.push_back(*p + " (result, for gvd info and later queries)");
  }
  if (!quiet(args)) {
    print_summary(done, stderr);
    for (const std::string& w : written) std::fprintf(stderr, "  wrote %s\n", w.c_str());
  }
  return kExitOk;
}

int remote_info(const std::string& url, int argc, char** argv) {
  const Args args = parse_remote(argc, argv, {}, {"--json"});
  if (!args.positional.empty()) throw UsageError{"info against a server takes --job ID"};
  Remote remote(url, args);
  const Json doc = remote.job(required_value(args, "--job"));
  const std::string status = text(doc, "status", "");
  if (args.has("--json")) {
    std::cout << Remote::finished(doc)["result"].dump() << "\n";
    return kExitOk;
  }
  std::printf("%s: %s", text(doc, "id", "").c_str(), status.c_str());
  if (status == "queued" || status == "running") {
    const Json p = member(doc, "progress", Json::object());
    std::printf(" (%s, %.0f%%)", text(p, "stage", "").c_str(), 100 * number(p, "fraction", 0.0));
  }
  std::printf("\n");
  if (status == "done") print_summary(doc, stdout);
  if (doc.contains("error")) {
    std::printf("  error: %s\n", text(doc["error"], "detail", "").c_str());
  }
  return kExitOk;
}

int remote_nearest(const std::string& url, int argc, char** argv) {
  const Args args = parse_remote(argc, argv, {"--points", "--point"}, {"--fast"});
  if (!args.has("--points") && !args.has("--point")) {
    throw UsageError{"nearest needs --points FILE.json or --point x,y[,z]"};
  }
  const std::string fast = args.has("--fast") ? "fast=true" : "";
  Remote remote(url, args);
  const std::string id = remote.query_job(args);
  const int dimension = dimension_of(remote, id);
  Json points = Json::array();
  if (const auto file = args.value("--points")) {
    const std::string text = read_text(*file);
    check_json_depth(text, *file, ErrorCode::kInvalidArgument);
    const Json doc = Json::parse(text, nullptr, false);
    const Json list = doc.is_object() && doc.contains("points") ? doc["points"] : doc;
    if (!list.is_array()) {  // let the server say what is wrong, as the local command would
      remote.call("POST", Remote::job_path(id) + "/nearest" + (fast.empty() ? "" : "?" + fast),
                  read_text(*file), "application/json");
    } else {
      for (const Json& p : list) points.push_back(p);
    }
  }
  if (args.has("--point")) {
    for (const std::string& text : args.flags.at("--point")) {
      points.push_back(point_arg("--point", text, dimension));
    }
  }
  if (points.size() == 1 && points[0].is_array()) {  // one point: the single-point route
    std::string query;
    for (const Json& v : points[0]) query += (query.empty() ? "" : ",") + v.dump();
    const HttpAnswer a =
        remote.call("GET", Remote::job_path(id) + "/nearest?" + (fast.empty() ? "" : fast + "&") +
                               "point=" + url_encode(query));
    std::printf("%s\n", a.body.c_str());
    return kExitOk;
  }
  const HttpAnswer a =
      remote.call("POST", Remote::job_path(id) + "/nearest" + (fast.empty() ? "" : "?" + fast),
                  Json{{"points", points}}.dump(), "application/json");
  const Json answers = Json::parse(a.body).at("answers");
  std::string out;
  size_t outside = 0;
  for (size_t i = 0; i < answers.size(); ++i) {
    out += answers[i].dump() + "\n";
    if (answers[i].contains("error")) {
      std::fprintf(stderr, "gvd: point %zu: %s\n", i,
                   text(answers[i]["error"], "detail", "").c_str());
      ++outside;
    }
  }
  std::fwrite(out.data(), 1, out.size(), stdout);
  return outside > 0 ? kExitBadInput : kExitOk;
}

int remote_neighbors(const std::string& url, int argc, char** argv) {
  const Args args = parse_remote(argc, argv, {"--object", "--ring"});
  const std::string label = required_value(args, "--object");
  const int ring = args.int_value("--ring", 1);
  if (ring < 1) throw UsageError{"--ring must be at least 1"};
  Remote remote(url, args);
  const std::string id = remote.query_job(args);
  const HttpAnswer a = remote.call("GET", Remote::job_path(id) + "/objects/" + url_encode(label) +
                                              "/neighbors?ring=" + std::to_string(ring));
  std::printf("%s\n", a.body.c_str());
  return kExitOk;
}

int remote_path(const std::string& url, int argc, char** argv) {
  const Args args = parse_remote(argc, argv, {"--from", "--to", "--min-clearance", "--cost"});
  const std::string from = required_value(args, "--from"), to = required_value(args, "--to");
  Json body;
  if (const auto r = args.numbers("--min-clearance")) {
    if (r->size() != 1 || (*r)[0] < 0) throw UsageError{"--min-clearance expects one number >= 0"};
    body["min_clearance"] = (*r)[0];
  }
  const std::string cost = args.value("--cost").value_or("shortest");
  if (cost != "shortest" && cost != "clearance") {
    throw UsageError{"--cost is shortest or clearance, not \"" + cost + "\""};
  }
  body["cost"] = cost;
  Remote remote(url, args);
  const std::string id = remote.query_job(args);
  const int dimension = dimension_of(remote, id);
  body["from"] = point_arg("--from", from, dimension);
  body["to"] = point_arg("--to", to, dimension);
  const HttpAnswer a = remote.call("POST", Remote::job_path(id) + "/paths", body.dump(),
                                   "application/json", {200, 422});
  if (a.status == 422) {
    const Json p = problem_of(a);
    if (text(p, "type", "") != "/problems/no-path" || !p.contains("path")) throw_problem(p, 422);
    std::printf("%s\n", p["path"].dump().c_str());
    std::fprintf(stderr, "gvd: no path: %s\n", text(p["path"], "reason", "").c_str());
    return kExitNoPath;
  }
  std::printf("%s\n", a.body.c_str());
  return kExitOk;
}

int remote_explode(const std::string& url, int argc, char** argv) {
  const Args args =
      parse_remote(argc, argv, {"--anchor", "-o", "--output", "--scale", "--seconds"});
  const std::string anchor = required_value(args, "--anchor");
  std::string query = "?anchor=" + url_encode(anchor);
  if (const auto s = args.numbers("--scale")) {
    if (s->size() != 1 || (*s)[0] <= 0) throw UsageError{"--scale expects one number > 0"};
    query += "&scale=" + url_encode(*args.value("--scale"));
  }
  if (args.has("--seconds")) {
    throw UsageError{"--seconds is not available against a server (its animation lasts 2 s)"};
  }
  Remote remote(url, args);
  const std::string id = remote.query_job(args);
  const HttpAnswer a = remote.call("GET", Remote::job_path(id) + "/explode" + query);
  std::printf("%s\n", a.body.c_str());
  const auto glb_path = args.value("-o") ? args.value("-o") : args.value("--output");
  if (glb_path) {
    download(remote, id, "explode" + query + "&format=glb", *glb_path);
    if (!quiet(args)) {
      std::fprintf(stderr, "gvd: wrote %s (animated exploded view, 2 s)\n", glb_path->c_str());
    }
  }
  return kExitOk;
}

int remote_tight(const std::string& url, int argc, char** argv) {
  const Args args = parse_remote(argc, argv, {"--below"});
  const auto below = args.numbers("--below");
  if (!below || below->size() != 1 || (*below)[0] < 0) {
    throw UsageError{"tight needs --below B (a distance >= 0)"};
  }
  Remote remote(url, args);
  const std::string id = remote.query_job(args);
  const HttpAnswer a = remote.call(
      "GET", Remote::job_path(id) + "/tight?below=" + url_encode(*args.value("--below")));
  std::printf("%s\n", a.body.c_str());
  return kExitOk;
}

int remote_contacts(const std::string& url, int argc, char** argv) {
  const Args args = parse_remote(argc, argv, {"--max-gap"});
  const auto bound = args.numbers("--max-gap");
  if (!bound || bound->size() != 1 || !((*bound)[0] >= 0)) {
    throw UsageError{"contacts needs --max-gap G (a distance >= 0)"};
  }
  Remote remote(url, args);
  const std::string id = remote.query_job(args);
  const HttpAnswer a = remote.call(
      "GET", Remote::job_path(id) + "/contacts?max_gap=" + url_encode(*args.value("--max-gap")));
  std::printf("%s\n", a.body.c_str());
  return kExitOk;
}

}  // namespace

int exit_code_for_problem(const std::string& type, int status) {
  for (const ProblemExit& row : kProblemExits) {
    if (row.type == type) return row.exit_code;
  }
  if (status == 503 || status == 429) return kExitBusy;
  if (status == 404) return kExitIo;
  if (status == 413) return kExitLimit;
  if (status >= 400 && status < 500) return kExitBadInput;
  return kExitInternal;
}

int run_remote(const std::string& url, int argc, char** argv) {
  const std::string command = argv[1];
  if (command == "compute") return remote_compute(url, argc, argv);
  if (command == "info") return remote_info(url, argc, argv);
  if (command == "nearest") return remote_nearest(url, argc, argv);
  if (command == "neighbors" || command == "neighbours") return remote_neighbors(url, argc, argv);
  if (command == "path") return remote_path(url, argc, argv);
  if (command == "explode") return remote_explode(url, argc, argv);
  if (command == "tight") return remote_tight(url, argc, argv);
  if (command == "contacts") return remote_contacts(url, argc, argv);
  throw UsageError{"unknown command \"" + command + "\""};
}

}  // namespace gvd::cli
