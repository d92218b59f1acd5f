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

#include "gvd/common/memory_account.h"
#include "job_document.h"
#include "job_queue.h"
#include "job_stop.h"
#include "metrics.h"
#include "result_cache.h"
#include "server_options.h"

namespace gvd::server {

/// The jobs: a bounded queue, a worker pool (separate from the HTTP threads), a watchdog for
/// per-job limits (time, memory), and the on-disk store:
///   <store>/requests/<id>.json  a submitted, unfinished job (written before the 202), after
///                               its input: <id>.scene.json, or a volume's <id>.volume.npy
///   <store>/results/<id>.gvd    a finished result (the engine's result file)
///   <store>/results/<id>.json   its status document
///   <store>/failed/<id>.json    the status document of a failed job
/// Every write is atomic (temporary file + rename). At start-up finished and failed jobs are
/// listed from disk and unfinished requests are queued again, oldest first.
class JobManager final : public JobQueue {
 public:
  JobManager(const ServerOptions& options, Metrics& metrics);
  ~JobManager() override;
  JobManager(const JobManager&) = delete;
  JobManager& operator=(const JobManager&) = delete;

  /// Starts the workers and the watchdog.
  void start() override;

  /// Persists and queues a new job, or returns the existing one with the same id. Throws
  /// QueueFull, or gvd::Error{kIo} when the request cannot be persisted.
  SubmitOutcome submit(const JobRequest& request) override;

  /// The status document (docs/API.md), nullopt for an unknown job.
  std::optional<std::string> status_json(const std::string& id) const override;
  std::optional<JobStatus> status(const std::string& id) const override;

  /// Queued: cancelled at once. Running: asked to stop (the worker marks it cancelled).
  /// Finished (done, failed, cancelled): forgotten, its files removed.
  DeleteOutcome remove(const std::string& id) override;

  /// The result of a done job. Throws ProblemError: kNotFound (unknown), kJobNotFinished
  /// (queued/running), kJobFailed, kCancelled.
  std::shared_ptr<LoadedResult> result(const std::string& id) override;
  std::string result_path(const std::string& id) const override { return cache_.path_of(id); }

  /// A counter that changes whenever any job changes; waits up to `timeout` for it to
  /// differ from `seen` (for event streams). Returns the current value.
  uint64_t wait_for_change(uint64_t seen, std::chrono::milliseconds timeout) const override;
  uint64_t version() const override;

  /// Shutdown, in two steps: `drain` stops starting queued jobs and waits up to `grace` for
  /// running jobs to finish; `stop` cancels what still runs (their requests stay on disk and
  /// run again at the next start) and joins the threads.
  void drain(std::chrono::milliseconds grace) override;
  void stop() override;

  size_t queue_depth() const override;
  size_t running() const override;
  size_t cached_results() const override { return cache_.size(); }
  std::string list_json() const override;
  double take_token(const std::string& client, double rate,
                    double burst) override;  ///< {"jobs":[{"id","status"}]}, newest first

 private:
  struct Job : JobRecord {
    bool persisting = false;  ///< submitted, its request still being written to disk
    std::atomic<bool> cancel{false};
    MemoryAccount memory;  ///< what the job holds itself (its limit sets `cancel`)
    StopReason reason = StopReason::kNone;
    std::chrono::steady_clock::time_point run_start;
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
  /// One JSON log line on stderr (none with --quiet); `detail` says why, where there is a why.
  void log_event(const char* level, const char* event, const std::string& id, double seconds,
                 const std::string& detail = "") const;
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
  struct Bucket {
    double tokens = 0;
    std::chrono::steady_clock::time_point at;
  };
  std::mutex buckets_mutex_;
  std::map<std::string, Bucket> buckets_;
};

}  // namespace gvd::server
