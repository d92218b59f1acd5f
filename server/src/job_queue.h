#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

#include "result_cache.h"

namespace gvd::server {

/// Life of a job: queued -> running -> done | failed | cancelled (documented in docs/API.md).
enum class JobStatus { kQueued, kRunning, kDone, kFailed, kCancelled };
std::string_view job_status_name(JobStatus status);
/// The inverse of job_status_name; nullopt for any other text.
std::optional<JobStatus> job_status_from_name(std::string_view name);

/// What a submission carries besides the id (all of it is persisted before the answer).
struct JobRequest {
  std::string id;  ///< job_id(scene_json, params_json), or volume_job_id for a volume
  /// The normalized scene (scene_to_json of the validated scene); empty for a volume.
  std::string scene_json;
  /// A labelled volume: the .npy bytes as uploaded (only their header checked) and the
  /// options to convert them with (volume_options_json); the worker turns them into the scene
  /// (read_stored_scene). Empty for a scene. The bytes are a view (of the request's body, up
  /// to --max-body): valid while JobQueue::submit runs, which stores them.
  std::string_view volume_npy;
  std::string volume_json;
  std::string params_json;           ///< normalized compute parameters (JSON object)
  std::string warnings_json = "[]";  ///< warnings found while parsing (JSON array)
  int dimension = 3;
  uint64_t objects = 0;    ///< 0 for a volume until the worker has converted it
  uint64_t simplices = 0;  ///< as objects
  std::string units;       ///< the scene's length unit (Scene::units), empty: none
};

/// The content address of a job: SHA-256 (first 128 bits, hex) of the algorithm version, the
/// normalized parameters and the normalized scene.
std::string job_id(std::string_view scene_json, std::string_view params_json);
/// The job a stored result belongs to: the one it names (ResultStats::job, written by the
/// server), else, for a file written before results named their job (when every job's id
/// was its scene's), the job of its scene with `params_json`.
std::string result_owner(const result::GvdResult& result, std::string_view params_json);
/// The content address of a labelled volume's job: as job_id, over the volume's options and
/// its .npy bytes as uploaded (so one volume with one set of parameters is one job; a volume
/// and the same scene sent as meshes are two).
std::string volume_job_id(std::string_view volume_json, std::string_view npy,
                          std::string_view params_json);

struct SubmitOutcome {
  bool created = false;  ///< false: the same job already existed (a cache hit)
  JobStatus status = JobStatus::kQueued;
  std::string status_json;
};

/// Thrown by submit when the queue is full.
struct QueueFull : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// The jobs as the HTTP front sees them, whoever queues and runs them: JobManager (one
/// process: an in-memory queue and worker pool over the on-disk store, the default) or
/// RedisJobQueue (replicas sharing a Redis Streams queue and one store directory).
class JobQueue {
 public:
  virtual ~JobQueue() = default;

  /// Starts the workers (and whatever background threads the implementation needs).
  virtual void start() = 0;

  /// Persists and queues a new job, or returns the existing one with the same id. Throws
  /// QueueFull, gvd::Error{kIo} when the request cannot be persisted, or
  /// ProblemError{kQueueFull} (503 + Retry-After; the detail says Redis is unreachable) when the
  /// shared queue cannot be reached.
  virtual SubmitOutcome submit(const JobRequest& request) = 0;

  /// The status document (docs/API.md), nullopt for an unknown job.
  virtual std::optional<std::string> status_json(const std::string& id) const = 0;
  virtual std::optional<JobStatus> status(const std::string& id) const = 0;

  enum class DeleteOutcome { kUnknown, kCancelled, kCancelling, kForgotten };
  /// Queued: cancelled at once. Running: asked to stop (the worker marks it cancelled).
  /// Finished (done, failed, cancelled): forgotten, its files removed.
  virtual DeleteOutcome remove(const std::string& id) = 0;

  /// The result of a done job. Throws ProblemError: kNotFound (unknown), kJobNotFinished
  /// (queued/running), kJobFailed, kCancelled.
  virtual std::shared_ptr<LoadedResult> result(const std::string& id) = 0;
  virtual std::string result_path(const std::string& id) const = 0;

  /// A counter that changes whenever any job changes; waits up to `timeout` for it to
  /// differ from `seen` (for event streams). Returns the current value.
  virtual uint64_t wait_for_change(uint64_t seen, std::chrono::milliseconds timeout) const = 0;
  virtual uint64_t version() const = 0;

  /// Shutdown, in two steps: `drain` stops starting queued jobs and waits up to `grace` for
  /// running jobs to finish; `stop` cancels what still runs (those jobs run again later: at
  /// the next start, or on another replica) and joins the threads.
  virtual void drain(std::chrono::milliseconds grace) = 0;
  virtual void stop() = 0;

  virtual size_t queue_depth() const = 0;
  virtual size_t running() const = 0;  ///< jobs running in this process
  virtual size_t cached_results() const = 0;
  virtual std::string list_json() const = 0;  ///< {"jobs":[{"id","status"}]}, newest first

  /// Per-client fairness (a token bucket per `client`: `rate` submissions per second, bursts
  /// of `burst`): takes one token and returns 0, or returns the seconds until the next token
  /// (the submission is refused). Cluster-wide for the Redis queue.
  virtual double take_token(const std::string& client, double rate, double burst) = 0;

  /// False while a service the queue depends on (Redis) is unreachable; `why` says what.
  virtual bool available(std::string* why) const {
    (void)why;
    return true;
  }
  /// Extra members for /readyz (a JSON object text; "{}" for none).
  virtual std::string readiness_json() const { return "{}"; }
};

}  // namespace gvd::server
