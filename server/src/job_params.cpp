#include "job_params.h"

#include <algorithm>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "gvd/common/error.h"
#include "gvd/common/json_input.h"
#include "gvd/pipeline/pipeline.h"

namespace gvd::server {

using namespace gvd::grid;
using namespace gvd::pipeline;

namespace {

// The job parameters of a job's normalized text: those of its mode (and of any mode); "units"
// and a volume's "spacing" and "background" travel with the scene; an adaptive job's text has
// no "mode" (its ids predate mode=grid).
bool in_normalized_text(const ParamSpec& p, bool grid) {
  if (!p.on(kJobParam) || p.of_scene()) return false;
  if (p.mode == (grid ? ParamMode::kAdaptive : ParamMode::kGrid)) return false;
  return grid || p.name != "mode";
}

// A member of a stored job document as the text set() reads (numbers exactly: %.17g).
std::string member_text(const nlohmann::json& v) {
  if (v.is_string()) return v.get<std::string>();
  if (v.is_boolean()) return v.get<bool>() ? "true" : "false";
  if (v.is_number_integer()) return v.dump();
  if (v.is_number()) {
    char text[40];
    std::snprintf(text, sizeof text, "%.17g", v.get<double>());
    return text;
  }
  if (v.is_array()) {
    std::string out;
    for (const nlohmann::json& x : v) out += (out.empty() ? "" : ",") + member_text(x);
    return out;
  }
  throw Error(ErrorCode::kInvalidArgument, "the job parameters: " + v.dump() + " is no value");
}

}  // namespace

bool is_job_param(const std::string& name) {
  const ParamSpec* p = find_parameter(name);
  return p != nullptr && p->on(kJobParam);
}

void JobParams::set(const std::string& name, const std::string& value) {
  PipelineParams::set(name, value, ParamSpelling::kServer);
}

void JobParams::check(int dimension, const ServerOptions& server) const {
  PipelineParams::check(dimension, ParamSpelling::kServer);
  if (!is_grid() && server.max_depth > 0 && max_depth > server.max_depth) {
    throw Error(ErrorCode::kLimitExceeded, "max_depth " + std::to_string(max_depth) +
                                               " is above this server's limit of " +
                                               std::to_string(server.max_depth));
  }
}

std::string JobParams::to_json() const {
  nlohmann::json j = nlohmann::json::object();
  for (const ParamSpec& p : pipeline_parameters()) {
    if (!in_normalized_text(p, is_grid())) continue;
    nlohmann::json& v = j[std::string(p.name)];
    switch (p.kind) {
      case ParamKind::kInt:
        v = static_cast<int>(number_of(p));
        break;
      case ParamKind::kCount:
        v = static_cast<uint64_t>(number_of(p));
        break;
      case ParamKind::kNumber:
        v = number_of(p);
        break;
      case ParamKind::kFlag:
        v = number_of(p) != 0;
        break;
      case ParamKind::kChoice:
        v = std::string(choice_of(p));
        break;
      case ParamKind::kBox:
        v = domain;
        break;
      case ParamKind::kUnits:
      case ParamKind::kSpacing:
      case ParamKind::kLabel:
        break;  // of the scene: not in the text (in_normalized_text)
    }
  }
  return j.dump();  // nlohmann::json sorts object keys: a stable text
}

JobParams JobParams::from_json(const std::string& text) {
  // Read back from a job document (the store, Redis), which can be damaged: anything but
  // to_json's form is a gvd::Error saying so, never a library exception.
  const nlohmann::json j =
      parse_json_input(text, "the job parameters", ErrorCode::kInvalidArgument);
  if (!j.is_object())
    throw Error(ErrorCode::kInvalidArgument, "the job parameters must be a JSON object");
  JobParams p;
  if (const auto mode = j.find("mode"); mode != j.end()) p.set("mode", member_text(*mode));
  if (p.is_grid() && !j.contains("resolution")) {
    throw Error(ErrorCode::kInvalidArgument, "the job parameters: a grid job has no resolution");
  }
  for (const ParamSpec& spec : pipeline_parameters()) {
    if (!in_normalized_text(spec, p.is_grid()) || spec.name == "mode") continue;
    const auto it = j.find(std::string(spec.name));
    if (it == j.end() || it->is_null()) continue;
    if (spec.kind == ParamKind::kBox && it->is_array() && it->empty()) continue;
    p.set(std::string(spec.name), member_text(*it));
  }
  return p;
}

PipelineOptions JobParams::pipeline_options(const ServerOptions& server) const {
  PipelineOptions o = gvd::pipeline::pipeline_options(*this);
  if (server.max_depth > 0 && (o.max_depth == 0 || o.max_depth > server.max_depth)) {
    o.max_depth = server.max_depth;
  }
  o.threads = server.job_threads;
  o.backend = server.compute ? BackendRequest::kOpenCl : BackendRequest::kCpu;
  o.compute = server.compute;
  o.backend_note = server.backend_note;
  // Memory is not bounded through the leaves (it was, at 1 KB a leaf, which refused jobs that
  // fit: balls_on_plate holds 20-30 MB at 117k leaves): the job is charged for what it
  // allocates and stopped at --job-memory-mb (job_memory.h).
  o.max_leaves = server.max_leaves;
  return o;
}

GridOptions JobParams::grid_options(const ServerOptions& server) const {
  GridOptions o = gvd::pipeline::grid_options(*this);
  o.max_cells = server.max_grid_cells;
  o.threads = server.job_threads;
  o.compute = server.compute;
  return o;
}

}  // namespace gvd::server
