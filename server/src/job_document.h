#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "gvd/scene/label_volume.h"
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
  int64_t memory_peak_bytes = 0;  ///< the most the job held itself so far (0: not known)
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

/// Stores a request for either queue's workers: its input first (`<base>.scene.json`, or a
/// labelled volume's bytes, `<base>.volume.npy`), then the request that points at it
/// (`<base>.json`: id, time, parameters, upload warnings, sizes, units, and a volume's
/// options); each file written atomically, so recovery trusts a request only with its input.
void write_stored_request(const std::string& base, const JobRequest& request, double submitted_at);

/// Whether the input of a stored request (`<base>.json`, whose text is `meta`) is complete:
/// its scene, or its volume when the request is a volume's.
bool stored_input_exists(const std::string& base, const nlohmann::json& meta);
/// Removes a stored request's files (request, scene, volume), quietly.
void remove_stored_request(const std::string& base);
/// The input files a stored request may have besides `<base>.json` (recovery lists them).
inline constexpr const char* kStoredInputSuffixes[] = {".scene.json", ".volume.npy"};

/// The scene of a stored request, what both queues' workers compute: `<base>.scene.json`
/// parsed within `limits`, with the warnings of its original upload that normalizing removed
/// (`<base>.json`: degenerate simplices); or a labelled volume's `<base>.volume.npy` turned
/// into a scene (read_label_volume_npy, scene_from_label_volume with the stored options and
/// units), reporting stage "volume" to `progress` (may be empty). `cancel` (may be null) is
/// read while the scene is validated and the volume converted: set, gvd::Error{kCancelled}.
/// Errors of the conversion are those the upload would have met had it been converted there.
scene::Scene read_stored_scene(
    const std::string& base, const scene::SceneLimits& limits,
    const std::atomic<bool>* cancel = nullptr,
    const std::function<void(const std::string&, double)>& progress = {});

/// The options of a labelled volume as stored with its request (JobRequest::volume_json):
/// {"spacing":[x,y(,z)],"background":label|null}, in a canonical text (part of the job id).
std::string volume_options_json(const scene::LabelVolumeOptions& options, int dimension);
scene::LabelVolumeOptions volume_options_from_json(const nlohmann::json& volume);

}  // namespace gvd::server
