#include "redis_job_queue.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "gvd/common/error.h"
#include "gvd/io/result_file.h"
#include "gvd/io/write_outputs.h"
#include "gvd/octree/build_octree.h"
#include "gvd/pipeline/pipeline.h"
#include "gvd/scene/load_scene.h"
#include "job_compute.h"
#include "job_memory.h"
#include "job_params.h"
#include "problem.h"

namespace gvd::server {

using namespace gvd::scene;
using namespace gvd::octree;
using namespace gvd::result;
using namespace gvd::io;

namespace fs = std::filesystem;
using Json = nlohmann::json;
using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

namespace {

constexpr const char* kStream = "gvd:queue";
constexpr const char* kGroup = "gvd-workers";
constexpr const char* kIndex = "gvd:jobs";
constexpr const char* kChannel = "gvd:events";
/// GET /v1/jobs lists this many of the newest jobs (kListScript).
constexpr size_t kListed = 1000;

// KEYS: job hash, stream, index, channel. ARGV: id, queued document, capacity, submitted_at,
// 1 = only when Redis has no such job (recovery; else a failed or cancelled job runs again).
// Returns {0, status, doc} for an existing job, {2, depth} when full, {1} when queued.
// Atomic: two replicas submitting one scene at once make one job.
constexpr const char* kSubmitScript = R"lua(
local s = redis.call('HGET', KEYS[1], 'status')
if s == 'queued' or s == 'running' or s == 'done' or (s and ARGV[5] == '1') then
  return {0, s, redis.call('HGET', KEYS[1], 'doc')}
end
local depth = redis.call('XLEN', KEYS[2])
local ok, p = pcall(redis.call, 'XPENDING', KEYS[2], 'gvd-workers')
if ok then depth = depth - p[1] end
if depth >= tonumber(ARGV[3]) then return {2, depth} end
redis.call('DEL', KEYS[1])
local e = redis.call('XADD', KEYS[2], '*', 'id', ARGV[1])
redis.call('HSET', KEYS[1], 'status', 'queued', 'doc', ARGV[2], 'submitted_at', ARGV[4],
           'entry', e)
redis.call('ZADD', KEYS[3], ARGV[4], ARGV[1])
redis.call('PUBLISH', KEYS[4], ARGV[1])
return {1}
)lua";

// KEYS: job hash, channel. ARGV: id, running document, consumer. Returns the status before
// (the job starts only when it was queued or running: a crashed worker's job).
constexpr const char* kStartScript = R"lua(
local s = redis.call('HGET', KEYS[1], 'status')
if s ~= 'queued' and s ~= 'running' then return s or '' end
redis.call('HSET', KEYS[1], 'status', 'running', 'doc', ARGV[2], 'worker', ARGV[3])
redis.call('PUBLISH', KEYS[2], ARGV[1])
return s
)lua";

// KEYS: job hash, stream, index, channel. ARGV: id, status, doc, entry, submitted_at.
constexpr const char* kFinishScript = R"lua(
redis.call('HSET', KEYS[1], 'status', ARGV[2], 'doc', ARGV[3])
redis.call('HDEL', KEYS[1], 'cancel')
if ARGV[4] ~= '' then
  pcall(redis.call, 'XACK', KEYS[2], 'gvd-workers', ARGV[4])
  redis.call('XDEL', KEYS[2], ARGV[4])
end
redis.call('ZADD', KEYS[3], 'NX', ARGV[5], ARGV[1])
redis.call('PUBLISH', KEYS[4], ARGV[1])
return 1
)lua";

// KEYS: stream, job hash. ARGV: entry, consumer. Renews the entry when this consumer still
// owns it (XCLAIM JUSTID resets its idle time without counting a delivery). Returns
// {owned, cancel requested}.
constexpr const char* kHeartbeatScript = R"lua(
local owned = 0
local ok, p = pcall(redis.call, 'XPENDING', KEYS[1], 'gvd-workers', ARGV[1], ARGV[1], 1)
if ok and #p == 1 and p[1][2] == ARGV[2] then
  redis.call('XCLAIM', KEYS[1], 'gvd-workers', ARGV[2], 0, ARGV[1], 'JUSTID')
  owned = 1
end
local c = redis.call('HGET', KEYS[2], 'cancel')
return {owned, c == '1' and 1 or 0}
)lua";

// KEYS: job hash, stream, channel. ARGV: id, queued document, entry. A job stopped by a
// shutdown goes back to the queue at once (a new entry for the next free worker, the old one
// acknowledged), unless it ended otherwise meanwhile.
constexpr const char* kReleaseScript = R"lua(
pcall(redis.call, 'XACK', KEYS[2], 'gvd-workers', ARGV[3])
redis.call('XDEL', KEYS[2], ARGV[3])
if redis.call('HGET', KEYS[1], 'status') ~= 'running' then return 0 end
local e = redis.call('XADD', KEYS[2], '*', 'id', ARGV[1])
redis.call('HSET', KEYS[1], 'status', 'queued', 'doc', ARGV[2], 'entry', e)
redis.call('PUBLISH', KEYS[3], ARGV[1])
return 1
)lua";

// KEYS: job hash, stream. The place of a queued job's entry among the entries no worker has
// been given yet (1 = next; a job a worker was given but has not started yet is next too),
// or 0 when the job is not queued or its entry is unknown (queued before entries were kept).
constexpr const char* kPositionScript = R"lua(
if redis.call('HGET', KEYS[1], 'status') ~= 'queued' then return 0 end
local e = redis.call('HGET', KEYS[1], 'entry')
if not e then return 0 end
local last = '0-0'
local ok, groups = pcall(redis.call, 'XINFO', 'GROUPS', KEYS[2])
if ok then
  for _, g in ipairs(groups) do
    local name, delivered
    for i = 1, #g, 2 do
      if g[i] == 'name' then name = g[i + 1] end
      if g[i] == 'last-delivered-id' then delivered = g[i + 1] end
    end
    if name == 'gvd-workers' and delivered then last = delivered end
  end
end
return math.max(1, #redis.call('XRANGE', KEYS[2], '(' .. last, e))
)lua";

// KEYS: job hash, channel. ARGV: id, cancelled document. Cancels a job that is still queued.
constexpr const char* kCancelQueuedScript = R"lua(
local s = redis.call('HGET', KEYS[1], 'status')
if s ~= 'queued' then return s or '' end
redis.call('HSET', KEYS[1], 'status', 'cancelled', 'doc', ARGV[2])
redis.call('PUBLISH', KEYS[2], ARGV[1])
return 'queued'
)lua";

// KEYS: index. The newest 1000 jobs: {id, score, status, ...}.
constexpr const char* kListScript = R"lua(
local ids = redis.call('ZREVRANGE', KEYS[1], 0, 999, 'WITHSCORES')
local out = {}
for i = 1, #ids, 2 do
  out[#out + 1] = ids[i]
  out[#out + 1] = ids[i + 1]
  out[#out + 1] = redis.call('HGET', 'gvd:job:' .. ids[i], 'status') or ''
end
return out
)lua";

// KEYS: job hash, index. ARGV: id, status, doc, submitted_at. A finished job of the store
// listed again after Redis lost it (never over what Redis knows of the job).
constexpr const char* kIndexScript = R"lua(
if redis.call('EXISTS', KEYS[1]) == 0 then
  redis.call('HSET', KEYS[1], 'status', ARGV[2], 'doc', ARGV[3], 'submitted_at', ARGV[4])
end
redis.call('ZADD', KEYS[2], 'NX', ARGV[4], ARGV[1])
return 1
)lua";

// KEYS: the client's bucket. ARGV: rate (tokens/s), burst. Returns "0" (a token taken) or the
// seconds until the next token. Redis' clock, so every replica counts alike.
constexpr const char* kTokenScript = R"lua(
local t = redis.call('TIME')
local now = tonumber(t[1]) + tonumber(t[2]) / 1e6
local rate, burst = tonumber(ARGV[1]), tonumber(ARGV[2])
local b = redis.call('HMGET', KEYS[1], 'tokens', 'at')
local tokens = tonumber(b[1]) or burst
local at = tonumber(b[2]) or now
tokens = math.min(burst, tokens + math.max(0, now - at) * rate)
if tokens < 1 then
  redis.call('HSET', KEYS[1], 'tokens', tokens, 'at', now)
  return tostring((1 - tokens) / rate)
end
redis.call('HSET', KEYS[1], 'tokens', tokens - 1, 'at', now)
redis.call('PEXPIRE', KEYS[1], math.ceil(burst / rate * 1000) + 1000)
return '0'
)lua";

std::string read_text(const std::string& path) {
  const std::vector<uint8_t> bytes = read_file_bytes(path);
  return std::string(bytes.begin(), bytes.end());
}

void remove_quietly(const std::string& path) {
  std::error_code ec;
  fs::remove(path, ec);
}

std::string default_replica_id() {
  char host[256] = {};
  if (gethostname(host, sizeof host - 1) != 0) std::snprintf(host, sizeof host, "gvd");
  return std::string(host) + "-" + std::to_string(::getpid());
}

std::string number_text(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.6f", v);
  return buf;
}

/// `doc` with a final status, the time and the problem (a queued or running document).
std::string final_document(const std::string& doc, JobStatus status, const std::string& problem) {
  Json s = Json::parse(doc);
  s["status"] = job_status_name(status);
  s["finished_at"] = iso_time(unix_now());
  s.erase("queue_position");
  if (!problem.empty()) s["error"] = Json::parse(problem);
  if (s.contains("progress")) s["progress"]["stage"] = nullptr;
  return s.dump(-1, ' ', false, Json::error_handler_t::replace);
}

}  // namespace

RedisJobQueue::RedisJobQueue(const ServerOptions& options, Metrics& metrics)
    : options_(options),
      metrics_(metrics),
      cache_(options.store + "/results", static_cast<size_t>(options.cache_entries),
             [&metrics](bool hit) {
               metrics.count(hit ? "gvd_result_cache_hits_total" : "gvd_result_cache_misses_total");
             }),
      replica_(options.replica_id.empty() ? default_replica_id() : options.replica_id),
      sub_redis_(options.redis_host, options.redis_port, options.redis_db, 0) {
  for (const char* sub : {"requests", "results", "failed"}) {
    std::error_code ec;
    fs::create_directories(dir(sub), ec);
    if (ec) {
      throw Error(ErrorCode::kIo,
                  "cannot create the store directory " + dir(sub) + ": " + ec.message());
    }
  }
  down_reason_ = "not connected yet";
  metrics_.gauge("gvd_queue_redis_up", "Redis queue: 1 while this replica reaches Redis.",
                 [this] { return up_ ? 1.0 : 0.0; });
  metrics_.gauge("gvd_queue_pending_entries",
                 "Redis queue: jobs delivered to this replica's workers, not yet acknowledged.",
                 [this] { return static_cast<double>(pending_here_.load()); });
  metrics_.gauge("gvd_queue_pending_entries_cluster",
                 "Redis queue: jobs delivered to any worker, not yet acknowledged.",
                 [this] { return static_cast<double>(pending_cluster_.load()); });
}

RedisJobQueue::~RedisJobQueue() { stop(); }

template <class Fn>
auto RedisJobQueue::api(Fn&& fn) const {
  std::unique_ptr<RedisConnection> redis;
  {
    std::lock_guard lock(api_mutex_);
    if (!api_pool_.empty()) {
      redis = std::move(api_pool_.back());
      api_pool_.pop_back();
    }
  }
  if (!redis) {
    redis = std::make_unique<RedisConnection>(options_.redis_host, options_.redis_port,
                                              options_.redis_db, 2.0);
  }
  struct GiveBack {
    const RedisJobQueue& self;
    std::unique_ptr<RedisConnection>& redis;
    ~GiveBack() {
      std::lock_guard lock(self.api_mutex_);
      if (self.api_pool_.size() < kPoolKept) self.api_pool_.push_back(std::move(redis));
    }
  } give_back{*this, redis};
  try {
    return fn(*redis);
  } catch (const RedisUnavailable& e) {
    set_down(e.what());
    throw ProblemError(ProblemKind::kQueueUnavailable,
                       std::string("the job queue is unreachable: ") + e.what());
  }
}

void RedisJobQueue::set_down(const std::string& why) const {
  std::lock_guard lock(mutex_);
  if (up_) metrics_.count("gvd_queue_redis_reconnects_total");
  up_ = false;
  down_reason_ = why;
}

bool RedisJobQueue::available(std::string* why) const {
  std::lock_guard lock(mutex_);
  if (why != nullptr) *why = down_reason_;
  return up_;
}

std::string RedisJobQueue::readiness_json() const {
  std::string why;
  const bool up = available(&why);
  Json j = {{"queue", "redis"},
            {"replica", replica_},
            {"role", options_.role},
            {"redis", up ? "up" : "down"},
            {"pending", pending_here_.load()}};
  if (!up) j["redis_error"] = why;
  return j.dump();
}

void RedisJobQueue::log_event(const char* level, const char* event, const std::string& id,
                              const std::string& detail) const {
  if (options_.quiet) return;
  Json line = {{"ts", unix_now()}, {"level", level}, {"event", event}, {"replica", replica_}};
  if (!id.empty()) line["job"] = id;
  if (!detail.empty()) line["detail"] = detail;
  std::fprintf(stderr, "%s\n", line.dump(-1, ' ', false, Json::error_handler_t::replace).c_str());
}

void RedisJobQueue::pause(milliseconds d) const {
  std::unique_lock lock(mutex_);
  changed_cv_.wait_for(lock, d, [&] { return stopping_; });
}

void RedisJobQueue::start() {
  std::lock_guard lock(mutex_);
  threads_.emplace_back([this] { maintenance_loop(); });
  threads_.emplace_back([this] { subscriber_loop(); });
  if (options_.role != "api") {
    for (int i = 0; i < options_.workers; ++i) threads_.emplace_back([this, i] { worker_loop(i); });
  }
}

// ---- lookups --------------------------------------------------------------------------------

std::optional<RedisJobQueue::Found> RedisJobQueue::lookup_store(const std::string& id,
                                                                bool requests) const {
  std::error_code ec;
  try {
    if (fs::exists(cache_.path_of(id), ec)) {
      const std::string path = dir("results") + "/" + id + ".json";
      if (fs::exists(path, ec)) return Found{JobStatus::kDone, read_text(path)};
    }
    const std::string failed = dir("failed") + "/" + id + ".json";
    if (fs::exists(failed, ec)) return Found{JobStatus::kFailed, read_text(failed)};
    // Submitted, unfinished, and unknown to Redis (it restarted empty; the job is queued again
    // within a second, or is still running somewhere): queued, as far as anyone can tell.
    const std::string request = dir("requests") + "/" + id + ".json";
    if (requests && fs::exists(request, ec)) {
      const Json meta = Json::parse(read_text(request));
      JobRecord job;
      job.id = id;
      job.params_json = meta.at("params").dump();
      job.dimension = meta.value("dimension", 3);
      job.objects = meta.value("objects", uint64_t{0});
      job.simplices = meta.value("simplices", uint64_t{0});
      job.units = meta.value("units", std::string());
      job.submitted_at = meta.value("submitted_at", 0.0);
      job.recovered = true;
      return Found{JobStatus::kQueued, job_document(job, JobStatus::kQueued, std::nullopt)};
    }
  } catch (const std::exception&) {
    // A file removed while being read: as if it were not there.
  }
  return std::nullopt;
}

std::optional<RedisJobQueue::Found> RedisJobQueue::lookup(RedisConnection& redis,
                                                          const std::string& id,
                                                          bool requests) const {
  RedisReply r = redis.command({"HMGET", key(id), "status", "doc"});
  if (r.size() == 2 && !reply_is_nil(r.at(0)) && !reply_is_nil(r.at(1))) {
    if (const auto s = job_status_from_name(reply_str(r.at(0)))) {
      return Found{*s, reply_str(r.at(1))};
    }
  }
  return lookup_store(id, requests);
}

std::optional<std::string> RedisJobQueue::status_json(const std::string& id) const {
  try {
    return api([&](RedisConnection& redis) -> std::optional<std::string> {
      const auto found = lookup(redis, id);
      if (!found) return std::nullopt;
      if (found->status != JobStatus::kQueued) return found->doc;
      // Where it waits in the cluster's queue, counted in Redis when asked.
      const RedisReply r = redis.command({"EVAL", kPositionScript, "2", key(id), kStream});
      if (r.is_error() || r.integer() <= 0) return found->doc;
      Json doc = Json::parse(found->doc);
      doc["queue_position"] = r.integer();
      return doc.dump(-1, ' ', false, Json::error_handler_t::replace);
    });
  } catch (const ProblemError&) {
    // Redis away: finished jobs are still known from the store.
    if (const auto found = lookup_store(id)) return found->doc;
    throw;
  }
}

std::optional<RedisJobQueue::Found> RedisJobQueue::find(const std::string& id) const {
  try {
    return api([&](RedisConnection& redis) { return lookup(redis, id); });
  } catch (const ProblemError&) {
    if (auto found = lookup_store(id)) return found;
    throw;
  }
}

std::optional<JobStatus> RedisJobQueue::status(const std::string& id) const {
  const auto found = find(id);
  if (!found) return std::nullopt;
  return found->status;
}

std::shared_ptr<LoadedResult> RedisJobQueue::result(const std::string& id) {
  bool recent = false;
  {
    std::lock_guard lock(mutex_);
    const auto it = done_seen_.find(id);
    recent = it != done_seen_.end() && Clock::now() - it->second < std::chrono::seconds(1);
  }
  if (recent) {
    if (auto loaded = cache_.cached(id)) return loaded;
  }
  const auto found = find(id);
  if (!found) throw ProblemError(ProblemKind::kNotFound, "no job " + id);
  switch (found->status) {
    case JobStatus::kQueued:
    case JobStatus::kRunning:
      throw ProblemError(ProblemKind::kJobNotFinished,
                         "job " + id + " is " + std::string(job_status_name(found->status)) +
                             "; poll /v1/jobs/" + id + " or follow /v1/jobs/" + id + "/events");
    case JobStatus::kFailed:
      throw ProblemError(ProblemKind::kJobFailed, "job " + id + " failed; see /v1/jobs/" + id);
    case JobStatus::kCancelled:
      throw ProblemError(ProblemKind::kCancelled, "job " + id + " was cancelled");
    case JobStatus::kDone:
      break;
  }
  // The parameters the id was made of, to check that the stored file belongs to it.
  const Json doc = Json::parse(found->doc, nullptr, false);
  const std::string params_json =
      doc.is_object() ? doc.value("params", Json::object()).dump() : std::string("{}");
  auto loaded = cache_.get(id, params_json);
  if (!loaded) throw ProblemError(ProblemKind::kNotFound, "the result of job " + id + " is gone");
  std::lock_guard lock(mutex_);
  if (done_seen_.size() > 10000) done_seen_.clear();
  done_seen_[id] = Clock::now();
  return loaded;
}

std::string RedisJobQueue::list_json() const {
  Json list = Json::array();
  api([&](RedisConnection& redis) {
    RedisReply r = redis.command({"EVAL", kListScript, "1", kIndex});
    for (size_t i = 0; i + 2 < r.size(); i += 3) {
      const std::string id = reply_str(r.at(i));
      std::string status = reply_str(r.at(i + 2));
      if (status.empty()) continue;
      list.push_back({{"id", id},
                      {"status", status},
                      {"submitted_at", iso_time(std::stod(reply_str(r.at(i + 1))))},
                      {"href", "/v1/jobs/" + id}});
    }
    return 0;
  });
  return Json{{"jobs", list}}.dump();
}

double RedisJobQueue::take_token(const std::string& client, double rate, double burst) {
  const RedisReply r = api([&](RedisConnection& redis) {
    return redis.command(
        {"EVAL", kTokenScript, "1", "gvd:bucket:" + client, number_text(rate), number_text(burst)});
  });
  if (r.is_error()) throw Error(ErrorCode::kInternal, "redis token bucket: " + r.str());
  try {
    return std::stod(r.str());
  } catch (const std::exception&) {
    return 0;
  }
}

// ---- submit and delete ----------------------------------------------------------------------

SubmitOutcome RedisJobQueue::submit(const JobRequest& request) {
  if (options_.role == "worker") {
    throw ProblemError(ProblemKind::kRouteNotFound,
                       "this replica only runs jobs (--role worker): submit to an api replica");
  }
  // Known already (in Redis, or finished in the store): one job per content.
  // (An unfinished request in the store that Redis does not know is queued again below.)
  const auto existing =
      api([&](RedisConnection& redis) { return lookup(redis, request.id, false); });
  if (existing && existing->status != JobStatus::kFailed &&
      existing->status != JobStatus::kCancelled) {
    metrics_.count("gvd_job_cache_hits_total");
    return {false, existing->status, existing->doc};
  }
  JobRecord job;
  job.id = request.id;
  job.params_json = request.params_json;
  job.dimension = request.dimension;
  job.objects = request.objects;
  job.simplices = request.simplices;
  job.units = request.units;
  job.submitted_at = unix_now();
  // The request goes to the shared store first (a worker of any replica reads it there): the
  // scene, then the request that points at it.
  write_stored_request(dir("requests") + "/" + request.id, request, job.submitted_at);
  remove_quietly(dir("failed") + "/" + request.id + ".json");
  const std::string doc = job_document(job, JobStatus::kQueued, std::nullopt);
  RedisReply r = api([&](RedisConnection& redis) {
    return redis.command({"EVAL", kSubmitScript, "4", key(request.id), kStream, kIndex, kChannel,
                          request.id, doc, std::to_string(options_.queue),
                          number_text(job.submitted_at), "0"});
  });
  if (r.is_error()) throw Error(ErrorCode::kInternal, "redis submit: " + r.str());
  const int64_t outcome = reply_integer(r.at(0));
  if (outcome == 2) {
    metrics_.count("gvd_jobs_rejected_total");
    throw QueueFull("the cluster's job queue is full (" + std::to_string(options_.queue) +
                    " jobs)");
  }
  if (outcome == 0) {  // submitted by another request at the same time
    metrics_.count("gvd_job_cache_hits_total");
    const auto s = job_status_from_name(reply_str(r.at(1))).value_or(JobStatus::kQueued);
    return {false, s, reply_str(r.at(2))};
  }
  metrics_.count("gvd_jobs_submitted_total");
  log_event("info", "job_queued", request.id);
  return {true, JobStatus::kQueued, doc};
}

JobQueue::DeleteOutcome RedisJobQueue::remove(const std::string& id) {
  for (int attempt = 0; attempt < 3; ++attempt) {
    const auto found = api([&](RedisConnection& redis) { return lookup(redis, id); });
    if (!found) return DeleteOutcome::kUnknown;
    switch (found->status) {
      case JobStatus::kQueued: {
        const std::string problem = problem_json(
            ProblemKind::kCancelled, "cancelled by DELETE before it started", "/v1/jobs/" + id, "");
        const std::string doc = final_document(found->doc, JobStatus::kCancelled, problem);
        RedisReply r = api([&](RedisConnection& redis) {
          return redis.command({"EVAL", kCancelQueuedScript, "2", key(id), kChannel, id, doc});
        });
        if (r.str() != "queued") continue;  // started meanwhile: look again
        remove_stored_request(dir("requests") + "/" + id);
        log_event("warn", "job_cancelled", id);
        return DeleteOutcome::kCancelled;
      }
      case JobStatus::kRunning:
        // The replica running it sees the flag at its next heartbeat and stops the job.
        api([&](RedisConnection& redis) {
          return redis.command({"HSET", key(id), "cancel", "1"});
        });
        return DeleteOutcome::kCancelling;
      case JobStatus::kDone:
      case JobStatus::kFailed:
      case JobStatus::kCancelled:
        api([&](RedisConnection& redis) {
          redis.command({"DEL", key(id)});
          redis.command({"ZREM", kIndex, id});
          return redis.command({"PUBLISH", kChannel, id});
        });
        remove_quietly(cache_.path_of(id));
        remove_quietly(grid_field_path(dir("results"), id));
        remove_quietly(grid_labels_path(dir("results"), id));
        remove_quietly(dir("results") + "/" + id + ".json");
        remove_quietly(dir("failed") + "/" + id + ".json");
        cache_.erase(id);
        {
          std::lock_guard lock(mutex_);
          done_seen_.erase(id);
        }
        return DeleteOutcome::kForgotten;
    }
  }
  return DeleteOutcome::kCancelling;
}

// ---- change notification --------------------------------------------------------------------

uint64_t RedisJobQueue::version() const {
  std::lock_guard lock(mutex_);
  return version_;
}

uint64_t RedisJobQueue::wait_for_change(uint64_t seen, milliseconds timeout) const {
  std::unique_lock lock(mutex_);
  changed_cv_.wait_for(lock, timeout, [&] { return version_ != seen || stopping_; });
  return version_;
}

void RedisJobQueue::subscriber_loop() {
  auto backoff = milliseconds(100);
  for (;;) {
    {
      std::lock_guard lock(mutex_);
      if (stopping_) return;
    }
    try {
      RedisReply r = sub_redis_.command({"SUBSCRIBE", kChannel});
      if (r.is_error()) throw RedisUnavailable("SUBSCRIBE: " + r.str());
      backoff = milliseconds(100);
      {
        // Messages may have been missed while not subscribed: every stream looks again.
        std::lock_guard lock(mutex_);
        ++version_;
        changed_cv_.notify_all();
      }
      for (;;) {
        RedisReply m = sub_redis_.read_push();
        std::lock_guard lock(mutex_);
        if (stopping_) return;
        ++version_;
        changed_cv_.notify_all();
      }
    } catch (const RedisUnavailable&) {
      sub_redis_.close();
      {
        std::lock_guard lock(mutex_);
        if (stopping_) return;
        ++version_;
        changed_cv_.notify_all();
      }
      pause(backoff);
      backoff = std::min(backoff * 2, milliseconds(2000));
    }
  }
}

// ---- workers --------------------------------------------------------------------------------

bool RedisJobQueue::ensure_group(RedisConnection& redis) {
  RedisReply r = redis.command({"XGROUP", "CREATE", kStream, kGroup, "0", "MKSTREAM"});
  if (r.is_error()) {
    if (r.str().starts_with("BUSYGROUP")) return false;
    throw RedisUnavailable("XGROUP CREATE: " + r.str());
  }
  return true;
}

void RedisJobQueue::reindex_store(RedisConnection& redis) {
  // The newest finished jobs of the store (their status documents), newest first.
  std::vector<std::pair<fs::file_time_type, fs::path>> docs;
  std::error_code ec;
  for (const char* sub : {"results", "failed"}) {
    for (const auto& entry : fs::directory_iterator(dir(sub), ec)) {
      const std::string name = entry.path().filename().string();
      if (!name.ends_with(".json") || name.find(".tmp.") != std::string::npos) continue;
      docs.emplace_back(fs::last_write_time(entry.path(), ec), entry.path());
    }
  }
  const size_t keep = std::min<size_t>(docs.size(), kListed);
  std::partial_sort(docs.begin(), docs.begin() + static_cast<std::ptrdiff_t>(keep), docs.end(),
                    [](const auto& x, const auto& y) { return x.first > y.first; });
  size_t listed = 0;
  for (size_t i = 0; i < keep; ++i) {
    try {
      const std::string doc = read_text(docs[i].second.string());
      const Json s = Json::parse(doc);
      const std::string id = docs[i].second.stem().string();
      const std::string status = s.at("status").get<std::string>();
      redis.command({"EVAL", kIndexScript, "2", key(id), kIndex, id, status, doc,
                     number_text(unix_from_iso(s.value("submitted_at", Json())))});
      ++listed;
    } catch (const RedisUnavailable&) {
      throw;
    } catch (const std::exception&) {
      // Removed or being replaced meanwhile: its next reader answers for it.
    }
  }
  if (listed > 0) log_event("info", "jobs_reindexed", std::to_string(listed));
}

void RedisJobQueue::requeue_store(RedisConnection& redis, std::chrono::seconds min_age) {
  const auto now = fs::file_time_type::clock::now();
  std::vector<std::pair<double, std::string>> pending;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir("requests"), ec)) {
    const std::string name = entry.path().filename().string();
    if (!name.ends_with(".json") || name.ends_with(".scene.json") ||
        name.find(".tmp.") != std::string::npos) {
      continue;
    }
    const std::string id = entry.path().stem().string();
    if (fs::exists(cache_.path_of(id), ec)) continue;  // finished; the request is a leftover
    if (min_age.count() > 0) {
      const auto written = fs::last_write_time(entry.path(), ec);
      if (ec || now - written < min_age) continue;  // being submitted right now
    }
    try {
      const Json meta = Json::parse(read_text(entry.path().string()));
      if (!stored_input_exists(dir("requests") + "/" + id, meta)) continue;
      pending.emplace_back(meta.value("submitted_at", 0.0), id);
    } catch (const std::exception&) {
      // Being written or damaged: its submitter answers for it.
    }
  }
  std::sort(pending.begin(), pending.end());
  for (const auto& [submitted_at, id] : pending) {
    try {
      const Json meta = Json::parse(read_text(dir("requests") + "/" + id + ".json"));
      JobRecord job;
      job.id = id;
      job.params_json = meta.at("params").dump();
      job.dimension = meta.value("dimension", 3);
      job.objects = meta.value("objects", uint64_t{0});
      job.simplices = meta.value("simplices", uint64_t{0});
      job.units = meta.value("units", std::string());
      job.submitted_at = submitted_at;
      job.recovered = true;
      const std::string doc = job_document(job, JobStatus::kQueued, std::nullopt);
      RedisReply r = redis.command({"EVAL", kSubmitScript, "4", key(id), kStream, kIndex, kChannel,
                                    id, doc, "1000000000", number_text(submitted_at), "1"});
      if (reply_integer(r.at(0)) == 1) {
        metrics_.count("gvd_jobs_recovered_total");
        log_event("info", "job_recovered", id);
      }
    } catch (const RedisUnavailable&) {
      throw;
    } catch (const std::exception&) {
      // Finished meanwhile (its files removed): nothing to queue.
    }
  }
}

bool RedisJobQueue::owns_consumer(const std::string& consumer) const {
  return consumer.starts_with(replica_ + "-");
}

void RedisJobQueue::maintenance_loop() {
  RedisConnection redis(options_.redis_host, options_.redis_port, options_.redis_db, 2.0);
  auto backoff = milliseconds(100);
  auto last_stats = Clock::time_point{};
  auto last_group = Clock::time_point{};
  auto last_sweep = Clock::now();
  const auto heartbeat_every =
      std::max(milliseconds(50), milliseconds(static_cast<int64_t>(options_.reclaim_idle * 333)));
  for (;;) {
    {
      std::lock_guard lock(mutex_);
      if (stopping_) return;
    }
    try {
      const auto now = Clock::now();
      const bool reconnect = !redis.connected();
      if (reconnect || now - last_group > std::chrono::seconds(1)) {
        last_group = now;
        if (ensure_group(redis)) {
          log_event("info", "queue_group_created", "");
          reindex_store(redis);
          requeue_store(redis, std::chrono::seconds(0));
        }
      }
      if (now - last_sweep > std::chrono::seconds(5)) {
        // Requests of the store that Redis does not know (it lost them, and the replica that
        // recreated the group died before queueing them again): queued again.
        last_sweep = now;
        requeue_store(redis, std::chrono::seconds(5));
      }
      // The jobs running here: heartbeat, cancel flag, time limit, progress.
      std::vector<std::shared_ptr<Running>> jobs;
      {
        std::lock_guard lock(mutex_);
        for (const auto& [id, job] : running_) jobs.push_back(job);
      }
      const auto limit = std::chrono::duration<double>(options_.job_seconds);
      if (!jobs.empty() && options_.max_memory_mb > 0 &&
          resident_memory_bytes() > options_.max_memory_mb * (1ull << 20)) {
        // Over the memory limit: cached results go first, then a job.
        if (cache_.size() > 0) {
          cache_.clear();
          log_event("warn", "memory_limit_cache_cleared", "");
        } else {
          // The job that holds the most itself (as in one process).
          std::lock_guard lock(mutex_);
          if (Running* job = job_to_stop_for_memory(jobs)) {
            job->reason = StopReason::kMemory;
            job->cancel = true;
          }
        }
      }
      for (const auto& job : jobs) {
        if (now - job->last_heartbeat >= heartbeat_every) {
          job->last_heartbeat = now;
          RedisReply r = redis.command(
              {"EVAL", kHeartbeatScript, "2", kStream, key(job->id), job->entry, job->consumer});
          if (reply_integer(r.at(1)) == 1 && !job->cancel) {
            std::lock_guard lock(mutex_);
            job->reason = StopReason::kUser;
            job->cancel = true;
          }
        }
        std::string doc;
        {
          std::lock_guard lock(mutex_);
          if (!job->cancel && now - job->run_start > limit) {
            job->reason = StopReason::kTimeout;
            job->cancel = true;
          }
          if (job->dirty) {
            job->dirty = false;
            doc = job_document(*job, JobStatus::kRunning, std::nullopt);
          }
        }
        if (!doc.empty()) {
          // Only while it is still running (a DELETE or another worker may have ended it).
          redis.command({"EVAL",
                         "if redis.call('HGET', KEYS[1], 'status') == 'running' then "
                         "redis.call('HSET', KEYS[1], 'doc', ARGV[1]) "
                         "redis.call('PUBLISH', KEYS[2], ARGV[2]) end return 1",
                         "2", key(job->id), kChannel, doc, job->id});
        }
      }
      if (now - last_stats > milliseconds(500)) {
        last_stats = now;
        const int64_t length = redis.command({"XLEN", kStream}).integer();
        RedisReply p = redis.command({"XPENDING", kStream, kGroup});
        int64_t pending = 0;
        int64_t here = 0;
        if (p.is_array()) {
          pending = reply_integer(p.at(0));
          const redisReply* consumers = p.at(3);
          for (size_t i = 0; i < reply_size(consumers); ++i) {
            const redisReply* c = reply_at(consumers, i);
            if (owns_consumer(reply_str(reply_at(c, 0)))) here += reply_integer(reply_at(c, 1));
          }
        }
        queue_depth_ = static_cast<size_t>(std::max<int64_t>(0, length - pending));
        pending_cluster_ = static_cast<size_t>(pending);
        pending_here_ = static_cast<size_t>(here);
        std::lock_guard lock(mutex_);
        if (!up_) log_event("info", "queue_connected", "", options_.queue_url);
        up_ = true;
        down_reason_.clear();
      }
      backoff = milliseconds(100);
      pause(milliseconds(50));
    } catch (const RedisUnavailable& e) {
      redis.close();
      {
        std::lock_guard lock(mutex_);
        if (up_) {
          metrics_.count("gvd_queue_redis_reconnects_total");
          log_event("warn", "queue_disconnected", "", e.what());
        }
        up_ = false;
        down_reason_ = e.what();
      }
      pause(backoff);
      backoff = std::min(backoff * 2, milliseconds(2000));
    }
  }
}

void RedisJobQueue::worker_loop(int index) {
  const std::string consumer = replica_ + "-" + std::to_string(index);
  RedisConnection redis(options_.redis_host, options_.redis_port, options_.redis_db, 5.0);
  const auto idle_ms = static_cast<int64_t>(options_.reclaim_idle * 1000);
  const auto reclaim_every = std::max(milliseconds(100), milliseconds(idle_ms / 4));
  auto last_reclaim = Clock::time_point{};
  auto backoff = milliseconds(100);
  for (;;) {
    {
      std::unique_lock lock(mutex_);
      if (stopping_) return;
      if (draining_) {
        changed_cv_.wait_for(lock, milliseconds(200));
        continue;
      }
    }
    try {
      std::string entry;
      std::string id;
      int64_t deliveries = 1;
      const redisReply* fields = nullptr;
      RedisReply r(nullptr);
      if (Clock::now() - last_reclaim >= reclaim_every) {
        // A stopped worker's job first: entries nobody renewed for --reclaim-idle.
        last_reclaim = Clock::now();
        r = redis.command({"XAUTOCLAIM", kStream, kGroup, consumer, std::to_string(idle_ms), "0-0",
                           "COUNT", "1"});
        if (r.is_error()) {
          // NOGROUP: Redis came back empty; the maintenance thread recreates the group (and
          // queues the store's unfinished requests again).
          pause(milliseconds(200));
          continue;
        }
        const redisReply* claimed = reply_at(reply_at(r.raw(), 1), 0);
        if (claimed != nullptr) {
          entry = reply_str(reply_at(claimed, 0));
          fields = reply_at(claimed, 1);
          RedisReply info = redis.command({"XPENDING", kStream, kGroup, entry, entry, "1"});
          deliveries = reply_integer(reply_at(info.at(0), 3));
          metrics_.count("gvd_queue_reclaimed_total");
          log_event("warn", "job_reclaimed", "",
                    entry + " (delivery " + std::to_string(deliveries) + ")");
        }
      }
      if (entry.empty()) {
        r = redis.command({"XREADGROUP", "GROUP", kGroup, consumer, "COUNT", "1", "BLOCK", "1000",
                           "STREAMS", kStream, ">"});
        if (r.is_error()) {
          if (!r.str().starts_with("NOGROUP")) throw RedisUnavailable("XREADGROUP: " + r.str());
          pause(milliseconds(200));  // as above
          continue;
        }
        const redisReply* message = reply_at(reply_at(reply_at(r.raw(), 0), 1), 0);
        if (message == nullptr) continue;  // nothing within the block time
        entry = reply_str(reply_at(message, 0));
        fields = reply_at(message, 1);
      }
      for (size_t i = 0; i + 1 < reply_size(fields); i += 2) {
        if (reply_str(reply_at(fields, i)) == "id") id = reply_str(reply_at(fields, i + 1));
      }
      process(redis, entry, id, consumer, deliveries);
      backoff = milliseconds(100);
    } catch (const RedisUnavailable&) {
      redis.close();
      pause(backoff);
      backoff = std::min(backoff * 2, milliseconds(2000));
    }
  }
}

void RedisJobQueue::process(RedisConnection& redis, const std::string& entry, const std::string& id,
                            const std::string& consumer, int64_t deliveries) {
  const auto drop = [&] {
    redis.command({"XACK", kStream, kGroup, entry});
    redis.command({"XDEL", kStream, entry});
  };
  if (id.empty()) {  // not ours, or deleted meanwhile
    drop();
    return;
  }
  if (deliveries > options_.max_deliveries) {
    const auto found = lookup(redis, id);
    if (!found || (found->status != JobStatus::kQueued && found->status != JobStatus::kRunning)) {
      drop();
      return;
    }
    const std::string detail =
        "the job was started " + std::to_string(deliveries - 1) +
        " time(s) and each time its worker stopped (crashed, killed or cut off from Redis) before "
        "it finished; given up after --max-deliveries " +
        std::to_string(options_.max_deliveries);
    const std::string doc =
        final_document(found->doc, JobStatus::kFailed,
                       problem_json(ProblemKind::kInternal, detail, "/v1/jobs/" + id, ""));
    try {
      write_file_atomic(dir("failed") + "/" + id + ".json", doc);
    } catch (const std::exception&) {
      // Redis still has it.
    }
    remove_stored_request(dir("requests") + "/" + id);
    finish(redis, id, entry, JobStatus::kFailed, doc);
    log_event("warn", "job_failed", id, detail);
    return;
  }
  if (const auto stored = lookup_store(id); stored && stored->status == JobStatus::kDone) {
    // Its worker stopped after saving the result (or another worker finished it): publish.
    remove_stored_request(dir("requests") + "/" + id);
    finish(redis, id, entry, JobStatus::kDone, stored->doc);
    return;
  }
  auto job = std::make_shared<Running>();
  job->id = id;
  job->entry = entry;
  job->consumer = consumer;
  const std::string base = dir("requests") + "/" + id;
  Json meta;
  try {
    meta = Json::parse(read_text(base + ".json"));
  } catch (const std::exception&) {
    // No request in the store: finished meanwhile (its result there), or forgotten.
    drop();
    return;
  }
  job->params_json = meta.value("params", Json::object()).dump();
  job->dimension = meta.value("dimension", 3);
  job->objects = meta.value("objects", uint64_t{0});
  job->simplices = meta.value("simplices", uint64_t{0});
  job->units = meta.value("units", std::string());
  job->submitted_at = meta.value("submitted_at", 0.0);
  job->recovered = deliveries > 1;
  job->started_at = unix_now();
  job->run_start = job->stage_start = job->last_heartbeat = Clock::now();
  RedisReply before =
      redis.command({"EVAL", kStartScript, "2", key(id), kChannel, id,
                     job_document(*job, JobStatus::kRunning, std::nullopt), consumer});
  const std::string was = before.str();
  if (was != "queued" && was != "running") {  // done, cancelled, failed or forgotten
    drop();
    return;
  }
  log_event("info", "job_started", id, consumer);
  {
    std::lock_guard lock(mutex_);
    running_[id] = job;
  }
  try {
    compute(redis, job);
  } catch (...) {
    std::lock_guard lock(mutex_);
    running_.erase(id);
    changed_cv_.notify_all();
    throw;
  }
  std::lock_guard lock(mutex_);
  running_.erase(id);
  changed_cv_.notify_all();  // drain() waits for running_ to empty
}

void RedisJobQueue::compute(RedisConnection& redis, const std::shared_ptr<Running>& job) {
  const std::string base = dir("requests") + "/" + job->id;
  const std::string instance = "/v1/jobs/" + job->id;
  JobFailure failure;
  // As in one process (JobManager::run): the job is charged for what it allocates.
  job->memory.set_limit(static_cast<int64_t>(job_memory_limit_bytes(options_)), &job->cancel);
  const ScopedMemoryAccount charge(&job->memory);
  try {
    SceneLimits limits;
    limits.max_objects = options_.max_objects;
    limits.max_simplices = options_.max_simplices;
    const ProgressFn progress = [this, job](const std::string& stage, double fraction) {
      std::lock_guard lock(mutex_);
      job->memory_peak_bytes = job->memory.peak();
      if (record_progress(*job, stage, fraction)) job->dirty = true;
    };
    Scene scene = read_stored_scene(base, limits, &job->cancel, progress);
    {
      // A volume's objects are known from here on (published at the next heartbeat).
      std::lock_guard lock(mutex_);
      job->dimension = scene.dimension;
      job->objects = scene.objects.size();
      job->simplices = scene.simplex_count();
      job->dirty = true;
    }
    const std::shared_ptr<const GvdResult> result =
        compute_job(std::move(scene), JobParams::from_json(job->params_json), options_,
                    &job->cancel, progress, dir("results"), job->id);
    // The result file (atomic; a second worker finishing the same job writes the same bytes),
    // then its status document, then the request goes.
    const std::vector<uint8_t> bytes = result_to_bytes(*result);
    write_file_atomic(cache_.path_of(job->id), bytes.data(), bytes.size());
    std::string doc;
    {
      std::lock_guard lock(mutex_);
      job->memory_peak_bytes = job->memory.peak();
      job->result_info = result_info_json(*result);
      job->finished_at = unix_now();
      doc = job_document(*job, JobStatus::kDone, std::nullopt);
    }
    try {
      write_file_atomic(dir("results") + "/" + job->id + ".json", doc);
    } catch (const std::exception&) {
      // The hash in Redis has it.
    }
    remove_stored_request(base);
    cache_.put(job->id, result);
    for (const StageStats& st : result->stats.stages) metrics_.stage(st.name, st.seconds);
    metrics_.job_finished("done", job->finished_at - job->started_at);
    finish(redis, job->id, job->entry, JobStatus::kDone, doc);
    log_event("info", "job_done", job->id);
    return;
  } catch (const RedisUnavailable&) {
    throw;
  } catch (const std::exception&) {
    failure = current_job_failure();
  }
  StopReason reason;
  {
    std::lock_guard lock(mutex_);
    job->memory_peak_bytes = job->memory.peak();
    if (failure.kind == ProblemKind::kCancelled)
      job->reason = stop_reason(job->reason, job->memory);
    reason = job->reason;
  }
  if (failure.kind == ProblemKind::kCancelled) {
    if (reason == StopReason::kShutdown) {
      // Back to the queue for another replica now; if Redis is away the entry stays
      // pending and is taken over after --reclaim-idle.
      JobRecord queued = *job;
      queued.stages.clear();
      queued.started_at = 0;
      queued.recovered = true;
      try {
        redis.command({"EVAL", kReleaseScript, "3", key(job->id), kStream, kChannel, job->id,
                       job_document(queued, JobStatus::kQueued, std::nullopt), job->entry});
      } catch (const RedisUnavailable&) {
        // As said.
      }
      log_event("info", "job_released", job->id);
      return;
    }
    failure = explain_stop(std::move(failure), reason, job->memory, options_);
  }
  const JobStatus final =
      failure.kind == ProblemKind::kCancelled ? JobStatus::kCancelled : JobStatus::kFailed;
  std::string doc;
  {
    std::lock_guard lock(mutex_);
    job->error = problem_json(failure.kind, failure.detail, instance, "");
    job->finished_at = unix_now();
    doc = job_document(*job, final, std::nullopt);
  }
  if (final == JobStatus::kFailed) {
    try {
      write_file_atomic(dir("failed") + "/" + job->id + ".json", doc);
    } catch (const std::exception&) {
      // Redis has it.
    }
  }
  remove_stored_request(base);
  metrics_.job_finished(std::string(job_status_name(final)), job->finished_at - job->started_at);
  finish(redis, job->id, job->entry, final, doc);
  log_event("warn", final == JobStatus::kFailed ? "job_failed" : "job_cancelled", job->id,
            failure.detail);
}

void RedisJobQueue::finish(RedisConnection& redis, const std::string& id, const std::string& entry,
                           JobStatus status, const std::string& doc) {
  // The index keeps its first score (NX); a job re-created after a Redis restart gets now.
  const double submitted = unix_now();
  auto backoff = milliseconds(100);
  for (;;) {
    try {
      redis.command({"EVAL", kFinishScript, "4", key(id), kStream, kIndex, kChannel, id,
                     std::string(job_status_name(status)), doc, entry, number_text(submitted)});
      return;
    } catch (const RedisUnavailable&) {
      redis.close();
      {
        std::lock_guard lock(mutex_);
        // Stopping: the result is in the store already (done and failed jobs are answered
        // from there; a cancelled one is simply gone).
        if (stopping_) return;
      }
      pause(backoff);
      backoff = std::min(backoff * 2, milliseconds(2000));
    }
  }
}

// ---- shutdown -------------------------------------------------------------------------------

size_t RedisJobQueue::running() const {
  std::lock_guard lock(mutex_);
  return running_.size();
}

void RedisJobQueue::drain(milliseconds grace) {
  std::unique_lock lock(mutex_);
  draining_ = true;
  changed_cv_.notify_all();
  changed_cv_.wait_for(lock, grace, [&] { return running_.empty(); });
}

void RedisJobQueue::stop() {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ && threads_.empty()) return;
    draining_ = true;
    stopping_ = true;
    for (auto& [id, job] : running_) {
      job->reason = StopReason::kShutdown;
      job->cancel = true;
    }
    changed_cv_.notify_all();
  }
  sub_redis_.interrupt();
  for (std::thread& t : threads_) t.join();
  threads_.clear();
}

}  // namespace gvd::server
