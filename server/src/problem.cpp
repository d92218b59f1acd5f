#include "problem.h"

#include <array>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <optional>

namespace gvd::server {
namespace {

// THE table (one table maps ErrorCode -> status, type, title, retryable, so
// that no handler picks its own). Keep the
// order of ProblemKind; docs/API.md lists the same rows.
constexpr std::array<ProblemInfo, kProblemKindCount> kTable = {{
    {422, "/problems/invalid-scene", "Invalid scene", false},
    {400, "/problems/invalid-argument", "Invalid argument", false},
    {415, "/problems/unsupported-format", "Unsupported input format", false},
    {422, "/problems/outside-domain", "Point outside the domain", false},
    {422, "/problems/limit-exceeded", "Limit exceeded", false},
    {404, "/problems/not-found", "Not found", false},
    {500, "/problems/io-error", "Storage error", true},
    {409, "/problems/cancelled", "Job cancelled", false},
    {500, "/problems/internal", "Internal error", false},
    {404, "/problems/route-not-found", "No such route", false},
    {405, "/problems/method-not-allowed", "Method not allowed", false},
    {411, "/problems/length-required", "Content-Length required", false},
    {413, "/problems/body-too-large", "Request body too large", false},
    {431, "/problems/headers-too-large", "Request headers too large", false},
    {415, "/problems/unsupported-media-type", "Unsupported media type", false},
    {415, "/problems/unsupported-encoding", "Content-Encoding not accepted", false},
    {503, "/problems/queue-full", "Job queue full", true},
    {503, "/problems/draining", "Server shutting down", true},
    {503, "/problems/too-many-streams", "Too many event streams", true},
    {409, "/problems/job-not-finished", "Job not finished", true},
    {409, "/problems/job-failed", "Job failed", false},
    {422, "/problems/no-path", "No path", false},
    {429, "/problems/rate-limited", "Too many submissions", true},
    {503, "/problems/queue-unavailable", "Job queue unavailable", true},
    {414, "/problems/uri-too-long", "Request line too long", false},
    {408, "/problems/request-timeout", "Request too slow", true},
    {503, "/problems/overloaded", "Server overloaded", true},
    {409, "/problems/adaptive-only", "Needs the adaptive result", false},
}};

static_assert(static_cast<int>(ErrorCode::kInternal) == static_cast<int>(ProblemKind::kInternal),
              "ProblemKind starts with the core error codes in their order");

// Where in the input, from the core's structured location.
void add_location(nlohmann::json& doc, const ErrorLocation& where) {
  if (where.object >= 0 || !where.label.empty()) {
    nlohmann::json object = nlohmann::json::object();
    if (where.object >= 0) object["index"] = where.object;
    if (!where.label.empty()) object["label"] = where.label;
    doc["object"] = std::move(object);
  }
  if (!where.element.empty()) {
    nlohmann::json element = {{"kind", where.element}};
    if (where.index >= 0) element["index"] = where.index;
    doc["element"] = std::move(element);
  }
  if (!where.pointer.empty()) doc["pointer"] = where.pointer;
  if (where.line >= 0) doc["line"] = where.line;
  if (where.offset >= 0) doc["offset"] = where.offset;
}

}  // namespace

const ProblemInfo& problem_info(ProblemKind kind) { return kTable.at(static_cast<size_t>(kind)); }

ProblemKind problem_kind(ErrorCode code) {
  return static_cast<ProblemKind>(static_cast<int>(code));
}

std::string problem_json(ProblemKind kind, std::string_view detail, std::string_view instance,
                         std::string_view request_id, std::string_view extra_json,
                         const ErrorLocation& where) {
  const ProblemInfo& info = problem_info(kind);
  nlohmann::json doc = {{"type", info.type},
                        {"title", info.title},
                        {"status", info.status},
                        {"detail", detail},
                        {"instance", instance}};
  if (!request_id.empty()) doc["request_id"] = request_id;  // absent for a job's own error
  if (kind <= ProblemKind::kInternal) {
    doc["code"] = error_code_name(static_cast<ErrorCode>(static_cast<int>(kind)));
  }
  add_location(doc, where);
  if (!extra_json.empty()) {
    const nlohmann::json extra = nlohmann::json::parse(extra_json, nullptr, false);
    if (extra.is_object()) {
      for (const auto& [key, value] : extra.items()) doc[key] = value;
    }
  }
  return doc.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

std::string seconds_text(double seconds) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", seconds);
  return text;
}

}  // namespace gvd::server
