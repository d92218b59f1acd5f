#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "gvd/common/memory_account.h"
#include "job_document.h"
#include "job_queue.h"
#include "job_stop.h"
#include "metrics.h"
#include "redis_client.h"
#include "result_cache.h"
#include "server_options.h"

namespace gvd::server {

/// The job queue of a scale-out cluster: many gvd-server replicas, one Redis (Streams), one
/// store directory on a volume they all mount (docs/DEPLOY.md).
///
/// Redis keys (prefix `gvd:`):
///   gvd:queue         stream of job ids ({"id": ID}); consumer group `gvd-workers`, one
///                     consumer per worker thread (`<replica>-<n>`); XACK + XDEL when finished
///   gvd:job:<id>      hash: status, doc (the status document of docs/API.md, kept current by
///                     the worker), submitted_at, cancel (1 = DELETE asked to stop it), worker
///   gvd:jobs          sorted set of job ids by submission time (GET /v1/jobs)
///   gvd:events        pub/sub channel: a job id whenever that job's document changed
/// The store directory has the layout of JobManager (requests/, results/, failed/); a worker
/// reads the request there and writes the result there (atomic: temporary file, fsync, rename;
/// two workers finishing one job write identical bytes). Any replica serves results from it
/// through its own LRU.
///
/// A running job's entry stays pending in the group; its worker's replica renews it (XCLAIM
/// JUSTID, which does not count as a delivery) every third of --reclaim-idle. An entry idle
/// longer than that belongs to a stopped worker and is taken over by an idle worker of any
/// replica (XAUTOCLAIM); after --max-deliveries starts the job fails with that reason. When
/// Redis comes back empty (restarted without persistence) the first replica to recreate the
/// group queues the unfinished requests of the store again, and finished jobs are answered
/// from the store.
class RedisJobQueue final : public JobQueue {
 public:
  RedisJobQueue(const ServerOptions& options, Metrics& metrics);
  ~RedisJobQueue() override;
  RedisJobQueue(const RedisJobQueue&) = delete;
  RedisJobQueue& operator=(const RedisJobQueue&) = delete;

  void start() override;
  SubmitOutcome submit(const JobRequest& request) override;
  std::optional<std::string> status_json(const std::string& id) const override;
  std::optional<JobStatus> status(const std::string& id) const override;
  DeleteOutcome remove(const std::string& id) override;
  std::shared_ptr<LoadedResult> result(const std::string& id) override;
  std::string result_path(const std::string& id) const override { return cache_.path_of(id); }
  uint64_t wait_for_change(uint64_t seen, std::chrono::milliseconds timeout) const override;
  uint64_t version() const override;
  void drain(std::chrono::milliseconds grace) override;
  void stop() override;
  size_t queue_depth() const override { return queue_depth_.load(); }
  size_t running() const override;
  size_t cached_results() const override { return cache_.size(); }
  std::string list_json() const override;
  double take_token(const std::string& client, double rate, double burst) override;
  bool available(std::string* why) const override;
  std::string readiness_json() const override;

 private:
  struct Running : JobRecord {
    std::string entry;     ///< stream entry id
    std::string consumer;  ///< the worker's consumer name
    std::atomic<bool> cancel{false};
    MemoryAccount memory;  ///< what the job holds itself (its limit sets `cancel`)
    StopReason reason = StopReason::kNone;
    bool dirty = false;  ///< progress not yet published
    std::chrono::steady_clock::time_point run_start;
    std::chrono::steady_clock::time_point last_heartbeat;
  };

  /// Runs `fn(connection)` on a connection of the HTTP threads' pool; a lost Redis
  /// becomes ProblemError{kQueueFull} (503 + Retry-After; the detail says Redis is unreachable).
  template <class Fn>
  auto api(Fn&& fn) const;
  /// The status and document of a job from Redis, or from the store when Redis has none
  /// (finished files; with `requests`, an unfinished request shows as queued).
  struct Found {
    JobStatus status;
    std::string doc;
  };
  std::optional<Found> lookup(RedisConnection& redis, const std::string& id,
                              bool requests = true) const;
  std::optional<Found> lookup_store(const std::string& id, bool requests = true) const;
  /// lookup through Redis, or the store alone while Redis is away (throws when neither knows).
  std::optional<Found> find(const std::string& id) const;

  void worker_loop(int index);
  void maintenance_loop();
  void subscriber_loop();
  /// Takes the job of stream entry `entry` (delivered `deliveries` times) and runs it.
  void process(RedisConnection& redis, const std::string& entry, const std::string& id,
               const std::string& consumer, int64_t deliveries);
  void compute(RedisConnection& redis, const std::shared_ptr<Running>& job);
  /// Publishes a final state: the hash, XACK + XDEL, the event. Retries while Redis is away.
  void finish(RedisConnection& redis, const std::string& id, const std::string& entry,
              JobStatus status, const std::string& doc);
  /// Creates the consumer group; true when it did not exist (an empty Redis).
  bool ensure_group(RedisConnection& redis);
  /// Lists the newest finished jobs of the store (kListed of them, by their status files'
  /// times) in Redis' index again after it lost its data, so that GET /v1/jobs shows them.
  void reindex_store(RedisConnection& redis);
  /// Queues the unfinished requests of the store again when Redis does not know them (after
  /// it lost its data); only request files older than `min_age`.
  void requeue_store(RedisConnection& redis, std::chrono::seconds min_age);
  /// Sleeps up to `d`, less when stopping.
  void pause(std::chrono::milliseconds d) const;
  void set_down(const std::string& why) const;
  void log_event(const char* level, const char* event, const std::string& id,
                 const std::string& detail = {}) const;
  std::string dir(const char* sub) const { return options_.store + "/" + sub; }
  std::string key(const std::string& id) const { return "gvd:job:" + id; }
  bool owns_consumer(const std::string& consumer) const;

  const ServerOptions options_;
  Metrics& metrics_;
  ResultCache cache_;
  std::string replica_;

  mutable std::mutex api_mutex_;
  /// Idle connections of the HTTP threads (one per concurrent request, up to kPoolKept kept).
  mutable std::vector<std::unique_ptr<RedisConnection>> api_pool_;
  static constexpr size_t kPoolKept = 16;
  RedisConnection sub_redis_;

  mutable std::mutex mutex_;
  mutable std::condition_variable changed_cv_;  ///< any job changed, or stopping
  std::map<std::string, std::shared_ptr<Running>> running_;
  uint64_t version_ = 0;
  bool draining_ = false;
  bool stopping_ = false;
  mutable std::string down_reason_;  ///< empty while Redis answers

  /// Jobs seen done lately: the query routes skip the Redis round trip for a second (a job
  /// forgotten by DELETE on another replica may be served here for that long).
  mutable std::map<std::string, std::chrono::steady_clock::time_point> done_seen_;

  std::atomic<size_t> queue_depth_{0};
  std::atomic<size_t> pending_cluster_{0};
  std::atomic<size_t> pending_here_{0};
  mutable std::atomic<bool> up_{false};
  std::vector<std::thread> threads_;
};

}  // namespace gvd::server
