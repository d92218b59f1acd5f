#include "job_params.h"

#include <charconv>
#include <cmath>
#include <nlohmann/json.hpp>
#include <sstream>

#include "gvd/common/error.h"
#include "gvd/common/json_input.h"
#include "gvd/pipeline/pipeline.h"
#include "gvd/scene/units.h"

namespace gvd::server {
namespace {

const char* const kNames[] = {
    "max_depth", "contact_depth", "ambiguity_levels", "ambiguity_rounds", "unseen_rounds",
    "domain",    "refine",        "resolution",       "curved_tolerance", "frame",
    "mode",      "metric",        "float64",          "unsigned",         "range_cells",
    "units"};

[[noreturn]] void bad(const std::string& detail) {
  throw Error(ErrorCode::kInvalidArgument, detail);
}

int parse_int(const std::string& name, const std::string& text, int lo, int hi) {
  int v = 0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, v);
  if (text.empty() || ec != std::errc() || ptr != end) {
    bad("parameter \"" + name + "\" must be an integer, got \"" + text + "\"");
  }
  if (v < lo || v > hi) {
    bad("parameter \"" + name + "\" must be between " + std::to_string(lo) + " and " +
        std::to_string(hi) + ", got " + text);
  }
  return v;
}

bool parse_flag(const std::string& name, const std::string& text) {
  if (text == "1" || text == "true") return true;
  if (text == "0" || text == "false") return false;
  bad("parameter \"" + name + "\" is true or false (1 or 0), got \"" + text + "\"");
}

}  // namespace

bool is_job_param(const std::string& name) {
  for (const char* n : kNames) {
    if (name == n) return true;
  }
  return false;
}

void JobParams::set(const std::string& name, const std::string& value) {
  if (name == "max_depth") {
    max_depth = parse_int(name, value, 0, 31);
  } else if (name == "contact_depth") {
    contact_depth = parse_int(name, value, 0, 31);
  } else if (name == "ambiguity_levels") {
    ambiguity_levels = parse_int(name, value, -1, 31);
  } else if (name == "ambiguity_rounds") {
    ambiguity_rounds = parse_int(name, value, -1, 1000);
  } else if (name == "unseen_rounds") {
    unseen_rounds = parse_int(name, value, -1, 1000);
  } else if (name == "refine") {
    if (value != "certified" && value != "paper") {
      bad("parameter \"refine\" must be certified or paper, got \"" + value + "\"");
    }
    refine = value;
  } else if (name == "resolution") {
    if (value == "compact" || value == "full") {
      resolution = value;
    } else if (!value.empty() && value.find_first_not_of("0123456789") == std::string::npos) {
      grid_resolution = parse_int(name, value, 1, 1 << 20);  // mode=grid: cells (check())
    } else {
      bad("parameter \"resolution\" must be compact or full (mode=adaptive), or a number of "
          "cells along the longest side (mode=grid), got \"" +
          value + "\"");
    }
  } else if (name == "mode") {
    if (value != "adaptive" && value != "grid") {
      bad("parameter \"mode\" must be adaptive or grid, got \"" + value + "\"");
    }
    mode = value;
  } else if (name == "metric") {
    (void)parse_grid_metric(value);  // l2, l1 or linf; the error names the choices
    metric = value;
  } else if (name == "float64") {
    float64 = parse_flag(name, value);
  } else if (name == "unsigned") {
    unsigned_distance = parse_flag(name, value);
  } else if (name == "range_cells") {
    range_cells = parse_int(name, value, 0, 4096);
  } else if (name == "units") {
    units = parse_units(value, "parameter \"units\"", ErrorCode::kInvalidArgument);
  } else if (name == "curved_tolerance") {
    double v = -1;
    const char* end = value.data() + value.size();
    const auto [ptr, ec] = std::from_chars(value.data(), end, v);
    if (value.empty() || ec != std::errc() || ptr != end || !(v >= 0 && v < 1)) {
      bad("parameter \"curved_tolerance\" must be a number in [0, 1), got \"" + value + "\"");
    }
    curved_tolerance = v;
  } else if (name == "frame") {
    if (value != "auto" && value != "world") {
      bad("parameter \"frame\" must be auto or world, got \"" + value + "\"");
    }
    frame = value;
  } else if (name == "domain") {
    std::vector<double> box;
    std::stringstream s(value);
    std::string item;
    while (std::getline(s, item, ',')) {
      double v = 0;
      const char* end = item.data() + item.size();
      const auto [ptr, ec] = std::from_chars(item.data(), end, v);
      if (item.empty() || ec != std::errc() || ptr != end || !std::isfinite(v)) {
        bad("parameter \"domain\" must be numbers x0,y0[,z0],x1,y1[,z1], got \"" + value + "\"");
      }
      box.push_back(v);
    }
    if (box.size() != 4 && box.size() != 6) {
      bad("parameter \"domain\" needs 4 (2D) or 6 (3D) numbers, got " + std::to_string(box.size()));
    }
    domain = std::move(box);
  } else {
    bad("unknown parameter \"" + name +
        "\" (known: max_depth, contact_depth, ambiguity_levels, ambiguity_rounds, "
        "unseen_rounds, domain, frame, refine, resolution, curved_tolerance, mode, metric, "
        "float64, unsigned, range_cells, units)");
  }
}

void JobParams::check(int dimension, const ServerOptions& server) const {
  if (!domain.empty() && domain.size() != static_cast<size_t>(2 * dimension)) {
    bad("parameter \"domain\" needs " + std::to_string(2 * dimension) + " numbers for a " +
        std::to_string(dimension) + "D scene");
  }
  for (size_t i = 0; i < domain.size() / 2; ++i) {
    if (!(domain[i] < domain[i + domain.size() / 2])) {
      bad("parameter \"domain\": the lower corner must be below the upper corner");
    }
  }
  if (is_grid()) {
    if (grid_resolution < 1) {
      bad("parameter \"resolution\": mode=grid needs resolution=N, the number of cells along "
          "the longest side of the domain");
    }
    const JobParams defaults;
    const auto adaptive_only = [](const char* name) {
      bad(std::string("parameter \"") + name +
          "\" applies to the adaptive octree; mode=grid computes on a uniform grid");
    };
    if (max_depth != defaults.max_depth) adaptive_only("max_depth");
    if (contact_depth != defaults.contact_depth) adaptive_only("contact_depth");
    if (ambiguity_levels != defaults.ambiguity_levels) adaptive_only("ambiguity_levels");
    if (ambiguity_rounds != defaults.ambiguity_rounds) adaptive_only("ambiguity_rounds");
    if (unseen_rounds != defaults.unseen_rounds) adaptive_only("unseen_rounds");
    if (frame != defaults.frame) adaptive_only("frame");
    if (refine != defaults.refine) adaptive_only("refine");
    if (resolution != defaults.resolution) adaptive_only("resolution (compact/full)");
    if (curved_tolerance != defaults.curved_tolerance) adaptive_only("curved_tolerance");
    return;
  }
  if (grid_resolution != 0) {
    bad("parameter \"resolution\" = " + std::to_string(grid_resolution) +
        " (a cell count) needs mode=grid; the adaptive mode takes compact or full");
  }
  {
    const JobParams defaults;
    const auto grid_only = [](const char* name) {
      bad(std::string("parameter \"") + name + "\" goes with mode=grid");
    };
    if (metric != defaults.metric) grid_only("metric");
    if (float64 != defaults.float64) grid_only("float64");
    if (unsigned_distance != defaults.unsigned_distance) grid_only("unsigned");
    if (range_cells != defaults.range_cells) grid_only("range_cells");
  }
  const int limit = lattice_bits(dimension);
  if (max_depth > limit) {
    bad("max_depth " + std::to_string(max_depth) + " is beyond the lattice limit " +
        std::to_string(limit) + " of a " + std::to_string(dimension) + "D scene");
  }
  if (server.max_depth > 0 && max_depth > server.max_depth) {
    throw Error(ErrorCode::kLimitExceeded, "max_depth " + std::to_string(max_depth) +
                                               " is above this server's limit of " +
                                               std::to_string(server.max_depth));
  }
}

std::string JobParams::to_json() const {
  if (is_grid()) {
    // Only what a grid job uses; an adaptive job's text (and so its id) is as before.
    const nlohmann::json g = {
        {"mode", mode},       {"resolution", grid_resolution}, {"metric", metric},
        {"float64", float64}, {"unsigned", unsigned_distance}, {"range_cells", range_cells},
        {"domain", domain}};
    return g.dump();
  }
  nlohmann::json j = {{"max_depth", max_depth},
                      {"contact_depth", contact_depth},
                      {"ambiguity_levels", ambiguity_levels},
                      {"ambiguity_rounds", ambiguity_rounds},
                      {"unseen_rounds", unseen_rounds},
                      {"domain", domain},
                      {"frame", frame},
                      {"refine", refine},
                      {"resolution", resolution},
                      {"curved_tolerance", curved_tolerance}};
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
  try {
    p.mode = j.value("mode", std::string("adaptive"));
    if (p.is_grid()) {
      p.grid_resolution = j.at("resolution").get<int>();
      p.metric = j.value("metric", std::string("l2"));
      p.float64 = j.value("float64", false);
      p.unsigned_distance = j.value("unsigned", false);
      p.range_cells = j.value("range_cells", 0);
      p.domain = j.value("domain", std::vector<double>{});
      return p;
    }
    p.max_depth = j.value("max_depth", 0);
    p.contact_depth = j.value("contact_depth", 0);
    p.ambiguity_levels = j.value("ambiguity_levels", -1);
    p.ambiguity_rounds = j.value("ambiguity_rounds", -1);
    p.unseen_rounds = j.value("unseen_rounds", -1);
    p.domain = j.value("domain", std::vector<double>{});
    p.frame = j.value("frame", std::string("auto"));
    p.refine = j.value("refine", std::string("certified"));
    p.resolution = j.value("resolution", std::string("compact"));
    p.curved_tolerance = j.value("curved_tolerance", 0.0);
  } catch (const nlohmann::json::exception& e) {
    throw Error(ErrorCode::kInvalidArgument,
                "the job parameters: " + std::string(plain_json_message(e.what())));
  }
  return p;
}

PipelineOptions JobParams::pipeline_options(const ServerOptions& server) const {
  PipelineOptions o;
  o.max_depth = max_depth;
  if (server.max_depth > 0 && (o.max_depth == 0 || o.max_depth > server.max_depth)) {
    o.max_depth = server.max_depth;
  }
  o.contact_depth = contact_depth;
  o.ambiguity_levels = ambiguity_levels;
  o.ambiguity_rounds = ambiguity_rounds;
  o.unseen_rounds = unseen_rounds;
  o.refine = refine;
  o.resolution = resolution;
  o.curved_tolerance = curved_tolerance;
  o.domain.frame = parse_domain_frame(frame);
  o.threads = server.job_threads;
  o.backend = server.compute ? "opencl" : "cpu";
  o.compute = server.compute;
  o.backend_note = server.backend_note;
  // The engine needs about 1 KB per octree leaf: the memory limit caps the leaves too.
  o.max_leaves = server.max_leaves;
  if (server.max_memory_mb > 0) {
    o.max_leaves = std::min<uint64_t>(o.max_leaves, server.max_memory_mb * 1024);
  }
  if (!domain.empty()) {
    const size_t d = domain.size() / 2;
    Vec3 lo, hi;
    for (size_t i = 0; i < d; ++i) {
      lo[static_cast<int>(i)] = domain[i];
      hi[static_cast<int>(i)] = domain[d + i];
    }
    Box b;
    b.extend(lo);
    b.extend(hi);
    o.domain.box = b;
  }
  return o;
}

GridOptions JobParams::grid_options(const ServerOptions& server) const {
  GridOptions o;
  o.resolution = grid_resolution;
  o.metric = parse_grid_metric(metric);
  o.signed_distance = !unsigned_distance;
  o.range_cells = range_cells;
  o.max_cells = server.max_grid_cells;
  o.threads = server.job_threads;
  o.compute = server.compute;
  if (!domain.empty()) {
    const size_t d = domain.size() / 2;
    Box b;
    for (size_t i = 0; i < d; ++i) {
      b.lo[static_cast<int>(i)] = domain[i];
      b.hi[static_cast<int>(i)] = domain[d + i];
    }
    if (d == 2) b.lo.z = b.hi.z = 0;
    o.box = b;
  }
  return o;
}

}  // namespace gvd::server
