#pragma once

#include <chrono>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "gvd/scene/scene.h"
#include "job_queue.h"

namespace gvd::server {

/// What the status document of a job is made of (docs/API.md), shared by the in-process and
/// the Redis queue so that both speak the same wire format.
struct JobRecord {
  struct StageTime {
    std::string name;
    double fraction = 0;
    double seconds = 0;
  };
  std::string id;
  JobStatus status = JobStatus::kQueued;
  std::string params_json;
  int dimension = 3;
  uint64_t objects = 0;
  uint64_t simplices = 0;
  std::string units;        ///< the scene's length unit; empty: none (no "units" key)
  double submitted_at = 0;  ///< unix seconds
  double started_at = 0;
  double finished_at = 0;
  std::vector<StageTime> stages;  ///< while running: stages seen so far
  std::string result_info;        ///< done: result_info_json
  std::string error;              ///< failed/cancelled: problem document
  bool recovered = false;
  std::chrono::steady_clock::time_point stage_start;  ///< of the running stage
};

/// The status document of `job` as if its status were `shown`; `queue_position` (1 = next)
/// is included for a queued job when given.
std::string job_document(const JobRecord& job, JobStatus shown,
                         std::optional<size_t> queue_position);

/// Records a progress report (`stage`, fraction of it done) in `job.stages`. Returns false
/// when nothing worth telling changed (less than 1 % more of the same stage).
bool record_progress(JobRecord& job, const std::string& stage, double fraction);

/// Seconds since the Unix epoch.
double unix_now();

/// "2026-01-02T03:04:05.678Z" (UTC), or null for 0.
nlohmann::json iso_time(double unix_seconds);
/// The seconds since the Unix epoch of an iso_time text; 0 for null or anything else.
double unix_from_iso(const nlohmann::json& text);

/// Stores a request for either queue's workers: the scene (`<base>.scene.json`) first, then the
/// request that points at it (`<base>.json`: id, time, parameters, upload warnings, sizes and
/// units); each file written atomically, so recovery trusts a request only with its scene.
void write_stored_request(const std::string& base, const JobRequest& request, double submitted_at);

/// The scene of a stored request (`<base>.scene.json`, parsed within `limits`) with the
/// warnings of its original upload that normalizing removed (`<base>.json`: degenerate
/// simplices): what both queues' workers compute.
Scene read_stored_scene(const std::string& base, const SceneLimits& limits);

}  // namespace gvd::server
