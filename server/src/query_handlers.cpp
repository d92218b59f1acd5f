#include "query_handlers.h"

#include <httplib.h>

#include <charconv>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "gvd/common/error.h"
#include "gvd/common/json_depth.h"
#include "gvd/grid/sample_result_grid.h"
#include "gvd/io/write_grid.h"
#include "gvd/io/write_outputs.h"
#include "gvd/query/contact_report.h"
#include "gvd/query/gvd_index.h"
#include "gvd/scene/units.h"
#include "job_compute.h"
#include "job_params.h"
#include "job_queue.h"
#include "problem.h"

namespace gvd::server {

using namespace gvd::scene;
using namespace gvd::result;
using namespace gvd::query;
using namespace gvd::grid;
using namespace gvd::io;
using namespace gvd::pipeline;

namespace {

using Json = nlohmann::json;

[[noreturn]] void bad(const std::string& detail) {
  throw Error(ErrorCode::kInvalidArgument, detail);
}

double parse_double(const std::string& name, const std::string& text) {
  double v = 0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, v);
  if (text.empty() || ec != std::errc() || ptr != end || !std::isfinite(v)) {
    bad("\"" + name + "\" must be a finite number, got \"" + text + "\"");
  }
  return v;
}

/// "x,y" (2D) or "x,y,z" (3D).
Vec3 parse_point(const std::string& name, const std::string& text, int dimension) {
  Vec3 p;
  size_t start = 0;
  int n = 0;
  while (start <= text.size()) {
    size_t comma = text.find(',', start);
    if (comma == std::string::npos) comma = text.size();
    if (n >= dimension)
      bad("\"" + name + "\" needs " + std::to_string(dimension) + " numbers for a " +
          std::to_string(dimension) + "D result, got \"" + text + "\"");
    p[n++] = parse_double(name, text.substr(start, comma - start));
    start = comma + 1;
  }
  if (n != dimension) {
    bad("\"" + name + "\" needs " + std::to_string(dimension) + " numbers for a " +
        std::to_string(dimension) + "D result, got \"" + text + "\"");
  }
  return p;
}

Vec3 json_point(const Json& doc, const char* key, int dimension) {
  if (!doc.contains(key)) bad(std::string("missing \"") + key + "\"");
  const std::vector<Vec3> one = parse_points_json("[" + doc[key].dump() + "]", dimension);
  return one.at(0);
}

std::string param(const httplib::Request& req, const char* name, bool required) {
  if (!req.has_param(name)) {
    if (required) bad(std::string("missing query parameter \"") + name + "\"");
    return {};
  }
  return req.get_param_value(name);
}

void send_json(httplib::Response& res, std::string body) {
  res.set_header("Cache-Control", "no-store");
  res.set_content(std::move(body), "application/json");
}

}  // namespace

void QueryHandlers::neighbors(const httplib::Request& req, httplib::Response& res) {
  const auto result = jobs_.result(req.matches[1].str());
  require_adaptive(result->result(), req.matches[1].str(), "neighbors");
  const GvdIndex& index = result->index();
  int ring = 1;
  if (const std::string r = param(req, "ring", false); !r.empty()) {
    const auto [ptr, ec] = std::from_chars(r.data(), r.data() + r.size(), ring);
    if (ec != std::errc() || ptr != r.data() + r.size() || ring < 1 || ring > 1'000'000) {
      bad("\"ring\" must be a positive integer, got \"" + r + "\"");
    }
  }
  const ObjectId object = index.object(req.matches[2].str());
  const std::vector<RingNeighbor> found = index.neighbors(object, ring);
  send_json(res, neighbors_to_json(index, object, ring, found));
}

// `fast=true`: the paper's rule alone away from objects (GvdIndex::nearest, approximate).
bool fast_mode(const httplib::Request& req) {
  const std::string fast = param(req, "fast", false);
  if (fast.empty() || fast == "false" || fast == "0") return false;
  if (fast == "true" || fast == "1") return true;
  bad("query parameter \"fast\" is true or false, not \"" + fast + "\"");
}

void QueryHandlers::nearest(const httplib::Request& req, httplib::Response& res) {
  const auto result = jobs_.result(req.matches[1].str());
  require_adaptive(result->result(), req.matches[1].str(), "nearest");
  const GvdIndex& index = result->index();
  const Vec3 p = parse_point("point", param(req, "point", true), index.dimension());
  send_json(res, nearest_to_json(index, index.nearest(p, fast_mode(req))));
}

void QueryHandlers::nearest_batch(const httplib::Request& req, httplib::Response& res) {
  const auto result = jobs_.result(req.matches[1].str());
  require_adaptive(result->result(), req.matches[1].str(), "nearest");
  const GvdIndex& index = result->index();
  const std::vector<Vec3> points = parse_points_json(req.body, index.dimension());
  if (points.size() > max_batch_points_) {
    throw Error(ErrorCode::kLimitExceeded,
                std::to_string(points.size()) + " points exceed the batch limit of " +
                    std::to_string(max_batch_points_) +
                    " (--max-batch-points): send them in several requests");
  }
  const bool fast = fast_mode(req);
  std::string out = "{\"answers\":[";
  for (size_t i = 0; i < points.size(); ++i) {
    if (i > 0) out += ',';
    try {
      out += nearest_to_json(index, index.nearest(points[i], fast));
    } catch (const Error& e) {
      // Outside the domain: this point's entry says so; the others are answered.
      if (e.code() != ErrorCode::kOutsideDomain) {
        throw Error(e.code(), "point " + std::to_string(i) + ": " + e.detail(),
                    {.element = "point", .index = static_cast<int64_t>(i)});
      }
      out += nearest_error_to_json(index, points[i], e);
    }
  }
  out += "]}";
  send_json(res, std::move(out));
}

void QueryHandlers::paths(const httplib::Request& req, httplib::Response& res) {
  const auto result = jobs_.result(req.matches[1].str());
  require_adaptive(result->result(), req.matches[1].str(), "paths");
  const GvdIndex& index = result->index();
  check_json_depth(req.body, "the body", ErrorCode::kInvalidArgument);
  const Json doc = Json::parse(req.body);
  if (!doc.is_object()) bad("the body must be a JSON object {\"from\":[..],\"to\":[..]}");
  PathQuery q;
  q.from = json_point(doc, "from", index.dimension());
  q.to = json_point(doc, "to", index.dimension());
  if (doc.contains("min_clearance")) {
    if (!doc["min_clearance"].is_number() || !(doc["min_clearance"].get<double>() >= 0) ||
        !std::isfinite(doc["min_clearance"].get<double>())) {
      bad("\"min_clearance\" must be a non-negative number");
    }
    q.min_clearance = doc["min_clearance"].get<double>();
  }
  if (doc.contains("cost")) {
    const std::string cost = doc["cost"].is_string() ? doc["cost"].get<std::string>() : "";
    if (cost == "shortest")
      q.cost = PathCost::kShortest;
    else if (cost == "clearance")
      q.cost = PathCost::kClearance;
    else
      bad("\"cost\" must be \"shortest\" or \"clearance\"");
  }
  const PathAnswer path = index.path(q);
  const std::string body = path_to_json(index, q, path);
  if (!path.found) {
    throw ProblemError(ProblemKind::kNoPath,
                       path.reason.empty() ? "no path joins start and goal" : path.reason,
                       "{\"path\":" + body + "}");
  }
  send_json(res, body);
}

void QueryHandlers::explode(const httplib::Request& req, httplib::Response& res) {
  const auto result = jobs_.result(req.matches[1].str());
  require_adaptive(result->result(), req.matches[1].str(), "explode");
  const GvdIndex& index = result->index();
  ExplodeOptions options;
  if (const std::string s = param(req, "scale", false); !s.empty())
    options.scale = parse_double("scale", s);
  const std::string format = req.has_param("format") ? req.get_param_value("format") : "json";
  if (format != "json" && format != "glb")
    bad("\"format\" must be json or glb, got \"" + format + "\"");
  const ExplodedView view = index.explode(index.object(param(req, "anchor", true)), options);
  if (format == "glb") {
    std::vector<Vec3> displacement(result->result().scene.objects.size());
    for (const ExplodedObject& o : view.objects) {
      if (o.object < displacement.size()) displacement[o.object] = o.displacement;
    }
    const std::vector<uint8_t> glb = exploded_to_glb(result->result().scene, displacement);
    res.set_content(reinterpret_cast<const char*>(glb.data()), glb.size(), "model/gltf-binary");
    return;
  }
  send_json(res, exploded_to_json(index, view));
}

void QueryHandlers::tight(const httplib::Request& req, httplib::Response& res) {
  const auto result = jobs_.result(req.matches[1].str());
  require_adaptive(result->result(), req.matches[1].str(), "tight");
  const GvdIndex& index = result->index();
  const double below = parse_double("below", param(req, "below", true));
  if (below < 0) bad("\"below\" must be >= 0");
  const std::vector<TightSpot> spots = index.tight(below);
  send_json(res, tight_to_json(index, below, spots));
}

void QueryHandlers::contacts(const httplib::Request& req, httplib::Response& res) {
  const auto result = jobs_.result(req.matches[1].str());
  require_adaptive(result->result(), req.matches[1].str(), "contacts");
  const GvdIndex& index = result->index();
  const double max_gap = parse_double("max_gap", param(req, "max_gap", true));
  if (!(max_gap >= 0)) bad("\"max_gap\" must be >= 0");
  send_json(res, contacts_to_json(index, max_gap, find_contacts(index, max_gap)));
}

namespace {

// A grid's .npy bytes as an attachment, with its geometry in headers for clients that read
// only the array; `etag` when the bytes are fixed for the job.
void send_grid_npy(httplib::Response& res, const GridSpec& s, const std::string& metric,
                   const std::string& units, bool labels,
                   std::shared_ptr<std::vector<uint8_t>> body, const std::string& etag = "") {
  char origin[160];
  std::snprintf(origin, sizeof origin, "%.17g,%.17g,%.17g", s.origin.x, s.origin.y, s.origin.z);
  char h[40];
  std::snprintf(h, sizeof h, "%.17g", s.h);
  res.set_header("X-Gvd-Grid-Origin", origin);
  res.set_header("X-Gvd-Grid-Cell", h);
  res.set_header("X-Gvd-Grid-Metric", metric);
  if (!units.empty()) res.set_header("X-Gvd-Grid-Units", ascii_units(units));
  res.set_header("Content-Disposition",
                 std::string("attachment; filename=\"") + (labels ? "labels" : "field") + ".npy\"");
  if (!etag.empty()) res.set_header("ETag", "\"" + etag + "\"");
  res.set_header("Cache-Control", "public, max-age=86400");
  res.set_content_provider(body->size(), "application/octet-stream",
                           [body](size_t offset, size_t length, httplib::DataSink& sink) {
                             const size_t n = std::min(length, body->size() - offset);
                             return sink.write(reinterpret_cast<const char*>(body->data()) + offset,
                                               n);
                           });
}

}  // namespace

void QueryHandlers::grid_job_file(const httplib::Request& req, httplib::Response& res,
                                  const JobParams& params, bool labels) {
  // A grid job's own grid, computed with the job: its parameters are the job's.
  for (const auto& [key, value] : req.params) {
    bad("query parameter \"" + key + "\": a grid job's " + (labels ? "labels" : "field") +
        ".npy is the grid computed with the job (resolution " +
        std::to_string(params.grid_resolution) + ", metric " + grid_metric_name(params.metric) +
        "); its parameters are fixed when the job is submitted");
  }
  const std::string id = req.matches[1].str();
  const auto result = jobs_.result(id);
  const std::string dir = std::filesystem::path(jobs_.result_path(id)).parent_path().string();
  const std::string path = labels ? grid_labels_path(dir, id) : grid_field_path(dir, id);
  auto body = std::make_shared<std::vector<uint8_t>>(read_file_bytes(path));
  GridOptions options = grid_options(params);
  options.max_cells = ~uint64_t{0} >> 32;
  const Scene& scene = result->result().scene;
  send_grid_npy(res, make_grid_spec(scene, options), grid_metric_name(params.metric), scene.units,
                labels, std::move(body), id);
}

void QueryHandlers::grid(const httplib::Request& req, httplib::Response& res, bool labels) {
  if (const auto doc = jobs_.status_json(req.matches[1].str())) {
    const Json j = Json::parse(*doc, nullptr, false);
    if (j.is_object() && j.contains("params") && j["params"].value("mode", "") == "grid") {
      grid_job_file(req, res, JobParams::from_json(j["params"].dump()), labels);
      return;
    }
  }
  // The query parameters through the parameter table (those it puts on kGridQuery): each is
  // checked before the result is loaded or any cell is sampled, the box against the job's
  // dimension once it is. An empty value is no value.
  PipelineParams params;
  params.mode = ComputeMode::kGrid;
  for (const auto& [key, value] : req.params) {
    if (!value.empty()) params.set(key, value, ParamSpelling::kServer, kGridQuery);
  }
  if (params.grid_resolution == 0) {
    bad("parameter \"resolution\" is required: the number of cells along the longest side of "
        "the box");
  }
  const auto result = jobs_.result(req.matches[1].str());
  const GvdResult& gvd = result->result();
  params.check(gvd.scene.dimension, ParamSpelling::kServer);
  ResultGridOptions options = result_grid_options(params);
  options.max_cells = max_grid_cells_;
  options.threads = grid_threads_;
  (void)make_result_grid_spec(gvd, options);  // the limits, before any work
  const DistanceGrid grid = sample_result_grid(gvd, options);
  send_grid_npy(
      res, grid.spec, grid_metric_name(grid.metric), grid.units, labels,
      std::make_shared<std::vector<uint8_t>>(grid_npy_bytes(grid, labels, params.float64)));
}

}  // namespace gvd::server
