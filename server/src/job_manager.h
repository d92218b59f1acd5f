#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "metrics.h"
#include "result_cache.h"
#include "server_options.h"

namespace gvd::server {

/// Life of a job: queued -> running -> done | failed | cancelled (documented in docs/API.md).
enum class JobStatus { kQueued, kRunning, kDone, kFailed, kCancelled };
std::string_view job_status_name(JobStatus status);

/// What a submission carries besides the id (all of it is persisted before the answer).
struct JobRequest {
  std::string id;           ///< job_id(scene_json, params_json)
  std::string scene_json;   ///< the normalized scene (scene_to_json of the validated scene)
  std::string params_json;  ///< normalized compute parameters (JSON object)
  std::string warnings_json = "[]";  ///< warnings found while parsing (JSON array)
  int dimension = 3;
  uint64_t objects = 0;
  uint64_t simplices = 0;
};

/// The content address of a job: SHA-256 (first 128 bits, hex) of the algorithm version, the
/// normalized parameters and the normalized scene.
std::string job_id(std::string_view scene_json, std::string_view params_json);

struct SubmitOutcome {
  bool created = false;  ///< false: the same job already existed (a cache hit)
  JobStatus status = JobStatus::kQueued;
  std::string status_json;
};

/// Thrown by submit when the queue is full.
struct QueueFull : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// The jobs: a bounded queue, a worker pool (separate from the HTTP threads), a watchdog for
/// per-job limits (time, memory), and the on-disk store:
///   <store>/requests/<id>.json  a submitted, unfinished job (written before the 202)
///   <store>/results/<id>.gvd    a finished result (the engine's result file)
///   <store>/results/<id>.json   its status document
///   <store>/failed/<id>.json    the status document of a failed job
/// Every write is atomic (temporary file + rename). At start-up finished and failed jobs are
/// listed from disk and unfinished requests are queued again, oldest first.
class JobManager {
 public:
  JobManager(const ServerOptions& options, Metrics& metrics);
  ~JobManager();
  JobManager(const JobManager&) = delete;
  JobManager& operator=(const JobManager&) = delete;

  /// Starts the workers and the watchdog.
  void start();

  /// Persists and queues a new job, or returns the existing one with the same id. Throws
  /// QueueFull, or gvd::Error{kIo} when the request cannot be persisted.
  SubmitOutcome submit(const JobRequest& request);

  /// The status document (docs/API.md), nullopt for an unknown job.
  std::optional<std::string> status_json(const std::string& id) const;
  std::optional<JobStatus> status(const std::string& id) const;

  enum class DeleteOutcome { kUnknown, kCancelled, kCancelling, kForgotten };
  /// Queued: cancelled at once. Running: asked to stop (the worker marks it cancelled).
  /// Finished (done, failed, cancelled): forgotten, its files removed.
  DeleteOutcome remove(const std::string& id);

  /// The result of a done job. Throws ProblemError: kNotFound (unknown), kJobNotFinished
  /// (queued/running), kJobFailed, kCancelled.
  std::shared_ptr<LoadedResult> result(const std::string& id);
  std::string result_path(const std::string& id) const { return cache_.path_of(id); }

  /// A counter that changes whenever any job changes; waits up to `timeout` for it to
  /// differ from `seen` (for event streams). Returns the current value.
  uint64_t wait_for_change(uint64_t seen, std::chrono::milliseconds timeout) const;
  uint64_t version() const;

  /// Shutdown, in two steps: `drain` stops starting queued jobs and waits up to `grace` for
  /// running jobs to finish; `stop` cancels what still runs (their requests stay on disk and
  /// run again at the next start) and joins the threads.
  void drain(std::chrono::milliseconds grace);
  void stop();

  size_t queue_depth() const;
  size_t running() const;
  size_t cached_results() const { return cache_.size(); }
  std::string list_json() const;  ///< {"jobs":[{"id","status"}]}, newest first

 private:
  enum class StopReason { kNone, kUser, kTimeout, kMemory, kShutdown };
  struct StageTime {
    std::string name;
    double fraction = 0;
    double seconds = 0;
  };
  struct Job {
    std::string id;
    JobStatus status = JobStatus::kQueued;
    std::string params_json;
    int dimension = 3;
    uint64_t objects = 0;
    uint64_t simplices = 0;
    double submitted_at = 0;  ///< unix seconds
    double started_at = 0;
    double finished_at = 0;
    std::vector<StageTime> stages;  ///< while running: stages seen so far
    std::string result_info;        ///< done: result_info_json
    std::string error;              ///< failed/cancelled: problem document
    bool recovered = false;
    bool persisting = false;  ///< submitted, its request still being written to disk
    std::atomic<bool> cancel{false};
    StopReason reason = StopReason::kNone;
    std::chrono::steady_clock::time_point run_start;
    std::chrono::steady_clock::time_point stage_start;
  };

  std::string status_json_locked(const Job& job) const {
    return status_json_locked(job, job.status);
  }
  /// The document of `job` as if its status were `shown` (to persist a final document
  /// before the final status becomes visible).
  std::string status_json_locked(const Job& job, JobStatus shown) const;
  void recover();
  void worker_loop();
  void watchdog_loop();
  void run(const std::shared_ptr<Job>& job);
  /// Makes a final status visible (no I/O: files are written before, outside the lock).
  void finish_locked(Job& job, JobStatus status);
  void remove_request_files(const std::string& id) const;
  /// One JSON line on stderr about a job (unless --quiet).
  void log_event(const char* level, const char* event, const std::string& id, double seconds) const;
  std::string dir(const char* sub) const { return options_.store + "/" + sub; }

  const ServerOptions options_;
  Metrics& metrics_;
  ResultCache cache_;

  mutable std::mutex mutex_;
  mutable std::condition_variable work_cv_;     ///< queue changed or stopping
  mutable std::condition_variable changed_cv_;  ///< any job changed
  std::map<std::string, std::shared_ptr<Job>> jobs_;
  std::deque<std::string> queue_;
  size_t running_ = 0;
  size_t persisting_ = 0;  ///< submissions being written (count against the queue bound)
  uint64_t version_ = 0;
  bool draining_ = false;
  bool stopping_ = false;
  std::vector<std::thread> workers_;
  std::thread watchdog_;
};

}  // namespace gvd::server
