#include "job_params.h"

#include <charconv>
#include <cmath>
#include <nlohmann/json.hpp>
#include <sstream>

#include "gvd/common/error.h"
#include "gvd/common/json_input.h"
#include "gvd/pipeline/pipeline.h"

namespace gvd::server {
namespace {

const char* const kNames[] = {
    "max_depth", "contact_depth", "ambiguity_levels", "ambiguity_rounds", "unseen_rounds",
    "domain",    "refine",        "resolution",       "curved_tolerance", "frame"};

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
    if (value != "compact" && value != "full") {
      bad("parameter \"resolution\" must be compact or full, got \"" + value + "\"");
    }
    resolution = value;
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
        "unseen_rounds, domain, frame, refine, resolution, curved_tolerance)");
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

}  // namespace gvd::server
