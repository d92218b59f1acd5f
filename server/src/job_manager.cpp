#include "job_manager.h"

#include <openssl/evp.h>

#include <algorithm>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <nlohmann/json.hpp>

#include "gvd/common/error.h"
#include "gvd/io/result_file.h"
#include "gvd/io/write_outputs.h"
#include "gvd/octree/build_octree.h"
#include "gvd/pipeline/pipeline.h"
#include "gvd/scene/load_scene.h"
#include "job_compute.h"
#include "job_document.h"
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

namespace {

std::string read_text(const std::string& path) {
  const std::vector<uint8_t> bytes = read_file_bytes(path);
  return std::string(bytes.begin(), bytes.end());
}

void remove_quietly(const std::string& path) {
  std::error_code ec;
  fs::remove(path, ec);
}

}  // namespace

namespace {

/// SHA-256 (first 128 bits, hex) of the algorithm version and `parts` in order.
std::string content_id(std::initializer_list<std::string_view> parts) {
  EVP_MD_CTX* ctx = EVP_MD_CTX_new();
  GVD_CHECK(ctx != nullptr, "EVP_MD_CTX_new");
  const std::string head = "gvd-job\nalgorithm " + std::to_string(kAlgorithmVersion) + "\n";
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  bool ok = EVP_DigestInit_ex(ctx, EVP_sha256(), nullptr) == 1 &&
            EVP_DigestUpdate(ctx, head.data(), head.size()) == 1;
  for (const std::string_view part : parts)
    ok = ok && EVP_DigestUpdate(ctx, part.data(), part.size()) == 1;
  ok = ok && EVP_DigestFinal_ex(ctx, digest, &length) == 1;
  EVP_MD_CTX_free(ctx);
  GVD_CHECK(ok && length >= 16, "SHA-256 failed");
  static constexpr char kHex[] = "0123456789abcdef";
  std::string id;
  for (unsigned i = 0; i < 16; ++i) {
    id += kHex[digest[i] >> 4];
    id += kHex[digest[i] & 15];
  }
  return id;
}

}  // namespace

std::string job_id(std::string_view scene_json, std::string_view params_json) {
  return content_id({params_json, "\n", scene_json});
}

std::string result_owner(const GvdResult& result, std::string_view params_json) {
  if (!result.stats.job.empty()) return result.stats.job;
  return job_id(scene_to_json(result.scene), params_json);
}

std::string volume_job_id(std::string_view volume_json, std::string_view npy,
                          std::string_view params_json) {
  // A scene's JSON starts with '{': no volume's text can equal a scene's.
  return content_id({params_json, "\nvolume ", volume_json, "\n", npy});
}

JobManager::JobManager(const ServerOptions& options, Metrics& metrics)
    : options_(options),
      metrics_(metrics),
      cache_(options.store + "/results", static_cast<size_t>(options.cache_entries),
             [&metrics](bool hit) {
               metrics.count(hit ? "gvd_result_cache_hits_total" : "gvd_result_cache_misses_total");
             }) {
  for (const char* sub : {"requests", "results", "failed"}) {
    std::error_code ec;
    fs::create_directories(dir(sub), ec);
    if (ec) {
      throw Error(ErrorCode::kIo,
                  "cannot create the store directory " + dir(sub) + ": " + ec.message());
    }
  }
  recover();
}

JobManager::~JobManager() { stop(); }

void JobManager::recover() {
  const auto list = [](const std::string& d) {
    std::vector<fs::path> files;
    for (const auto& entry : fs::directory_iterator(d)) files.push_back(entry.path());
    return files;
  };
  // Leftovers of writes interrupted by a crash.
  for (const char* sub : {"requests", "results", "failed"}) {
    for (const fs::path& p : list(dir(sub))) {
      if (p.filename().string().find(".tmp.") != std::string::npos) remove_quietly(p);
    }
  }
  const auto restore = [](const Json& s, JobStatus status) {
    auto job = std::make_shared<Job>();
    job->id = s.at("id").get<std::string>();
    job->status = status;
    job->params_json = s.value("params", Json::object()).dump();
    job->dimension = s.value("scene", Json::object()).value("dimension", 3);
    job->objects = s.value("scene", Json::object()).value("objects", uint64_t{0});
    job->simplices = s.value("scene", Json::object()).value("simplices", uint64_t{0});
    job->units = s.value("units", std::string());
    job->submitted_at = unix_from_iso(s.value("submitted_at", Json()));
    job->started_at = unix_from_iso(s.value("started_at", Json()));
    job->finished_at = unix_from_iso(s.value("finished_at", Json()));
    if (s.contains("result")) job->result_info = s["result"].dump();
    if (s.contains("error")) job->error = s["error"].dump();
    return job;
  };
  // Finished results: the result file is what counts; its status document says the rest.
  for (const fs::path& p : list(dir("results"))) {
    if (p.extension() != ".gvd") continue;
    const std::string id = p.stem().string();
    const std::string status_path = dir("results") + "/" + id + ".json";
    try {
      jobs_[id] = restore(Json::parse(read_text(status_path)), JobStatus::kDone);
    } catch (const std::exception&) {
      // The result without its status document (killed between the two writes): rebuild it.
      // Its parameters are in the stored request, removed only after the status document was
      // written; without them the file cannot be told from another job's.
      try {
        const GvdResult r = load_result(p.string());
        std::string params_json;
        try {
          params_json =
              Json::parse(read_text(dir("requests") + "/" + id + ".json")).at("params").dump();
        } catch (const std::exception&) {
          log_event("warn", "store_entry_dropped", id, 0,
                    "results/" + id +
                        ".gvd has no status document, and no stored request holds its "
                        "parameters (requests/" +
                        id + ".json): the job is not listed, submit it again");
          continue;
        }
        if (const std::string owner = result_owner(r, params_json); owner != id) {
          log_event("warn", "store_entry_dropped", id, 0,
                    "results/" + id + ".gvd has no status document and belongs to another job (" +
                        owner + "): the job is not listed, submit it again");
          continue;
        }
        auto job = std::make_shared<Job>();
        job->id = id;
        job->status = JobStatus::kDone;
        job->params_json = params_json;
        job->dimension = r.scene.dimension;
        job->objects = r.scene.objects.size();
        job->simplices = r.scene.simplex_count();
        job->units = r.scene.units;
        job->result_info = result_info_json(r);
        jobs_[id] = job;
        write_file_atomic(status_path, status_json_locked(*job));
      } catch (const std::exception& e) {
        log_event("error", "store_result_unreadable", id, 0,
                  "results/" + id + ".gvd has no status document and does not read back (" +
                      std::string(e.what()) + "): the job is not listed");
      }
    }
    remove_stored_request(dir("requests") + "/" + id);
  }
  for (const fs::path& p : list(dir("results"))) {
    const std::string name = p.filename().string();
    if (p.extension() != ".json" || name.find(".tmp") != std::string::npos) continue;
    const std::string id = p.stem().string();
    if (jobs_.count(id) == 0 && !fs::exists(dir("results") + "/" + id + ".gvd")) {
      log_event("warn", "store_entry_dropped", id, 0,
                "results/" + name + " is a status document without its result (results/" + id +
                    ".gvd): the job is not listed");
    }
  }
  for (const fs::path& p : list(dir("failed"))) {
    if (p.extension() != ".json") continue;
    try {
      const std::string id = p.stem().string();
      if (jobs_.count(id) == 0)
        jobs_[id] = restore(Json::parse(read_text(p.string())), JobStatus::kFailed);
    } catch (const std::exception& e) {
      log_event("warn", "store_entry_dropped", p.stem().string(), 0,
                "failed/" + p.filename().string() + " does not read back (" +
                    std::string(e.what()) + "): removed, the failed job is forgotten");
      remove_quietly(p);
    }
  }
  // Unfinished requests: queued again, oldest first.
  std::vector<std::shared_ptr<Job>> pending;
  for (const fs::path& p : list(dir("requests"))) {
    const std::string name = p.filename().string();
    if (!name.ends_with(".json") || name.ends_with(".scene.json")) continue;
    const std::string id = p.stem().string();
    try {
      const Json r = Json::parse(read_text(p.string()));
      if (!stored_input_exists(dir("requests") + "/" + id, r)) {
        throw std::runtime_error("its input, requests/" + id +
                                 (r.contains("volume") ? ".volume.npy" : ".scene.json") +
                                 ", is missing");
      }
      auto job = std::make_shared<Job>();
      job->id = id;
      job->status = JobStatus::kQueued;
      job->params_json = r.at("params").dump();
      job->dimension = r.value("dimension", 3);
      job->objects = r.value("objects", uint64_t{0});
      job->simplices = r.value("simplices", uint64_t{0});
      job->units = r.value("units", std::string());
      job->submitted_at = r.value("submitted_at", 0.0);
      job->recovered = true;
      jobs_.erase(id);  // a failed job submitted again
      pending.push_back(job);
    } catch (const std::exception& e) {
      log_event("warn", "store_entry_dropped", id, 0,
                "the pending request requests/" + name + " cannot be queued again (" +
                    std::string(e.what()) + "): removed, submit the job again");
      remove_quietly(p);
    }
  }
  for (const fs::path& p : list(dir("requests"))) {
    const std::string name = p.filename().string();
    for (const std::string_view suffix : kStoredInputSuffixes) {
      if (!name.ends_with(suffix) || name.find(".tmp.") != std::string::npos) continue;
      const std::string id = name.substr(0, name.size() - suffix.size());
      if (!fs::exists(dir("requests") + "/" + id + ".json")) {  // its request was dropped
        log_event("info", "store_entry_dropped", id, 0,
                  "requests/" + name + " belongs to no pending request: removed");
        remove_quietly(p);
      }
    }
  }
  std::sort(pending.begin(), pending.end(),
            [](const auto& a, const auto& b) { return a->submitted_at < b->submitted_at; });
  for (const auto& job : pending) {
    jobs_[job->id] = job;
    queue_.push_back(job->id);
    metrics_.count("gvd_jobs_recovered_total");
    log_event("info", "job_recovered", job->id, 0);
  }
}

void JobManager::start() {
  std::lock_guard lock(mutex_);
  for (int i = 0; i < options_.workers; ++i) workers_.emplace_back([this] { worker_loop(); });
  watchdog_ = std::thread([this] { watchdog_loop(); });
}

SubmitOutcome JobManager::submit(const JobRequest& request) {
  std::unique_lock lock(mutex_);
  for (;;) {
    const auto it = jobs_.find(request.id);
    if (it == jobs_.end()) break;
    const Job& job = *it->second;
    if (job.persisting) {  // the same job, being submitted by another request right now
      changed_cv_.wait(lock);
      continue;
    }
    if (job.status == JobStatus::kQueued || job.status == JobStatus::kRunning ||
        job.status == JobStatus::kDone) {
      metrics_.count("gvd_job_cache_hits_total");
      return {false, job.status, status_json_locked(job)};
    }
    break;  // failed or cancelled: computed again
  }
  if (queue_.size() + persisting_ >= static_cast<size_t>(options_.queue)) {
    metrics_.count("gvd_jobs_rejected_total");
    throw QueueFull("the job queue is full (" + std::to_string(options_.queue) + " jobs)");
  }
  auto job = std::make_shared<Job>();
  job->id = request.id;
  job->params_json = request.params_json;
  job->dimension = request.dimension;
  job->objects = request.objects;
  job->simplices = request.simplices;
  job->units = request.units;
  job->submitted_at = unix_now();
  job->persisting = true;
  jobs_[request.id] = job;
  ++persisting_;
  lock.unlock();
  // Persist before answering (outside the lock: the writes are fsynced): the scene first, then
  // the request that points at it (recovery only trusts a request whose scene is complete).
  try {
    write_stored_request(dir("requests") + "/" + request.id, request, job->submitted_at);
    remove_quietly(dir("failed") + "/" + request.id + ".json");
  } catch (...) {
    lock.lock();
    --persisting_;
    if (const auto it = jobs_.find(request.id); it != jobs_.end() && it->second == job)
      jobs_.erase(it);
    changed_cv_.notify_all();
    throw;
  }
  lock.lock();
  --persisting_;
  job->persisting = false;
  queue_.push_back(request.id);
  metrics_.count("gvd_jobs_submitted_total");
  log_event("info", "job_queued", request.id, 0);
  ++version_;
  work_cv_.notify_one();
  changed_cv_.notify_all();
  return {true, job->status, status_json_locked(*job)};
}

std::optional<std::string> JobManager::status_json(const std::string& id) const {
  std::lock_guard lock(mutex_);
  const auto it = jobs_.find(id);
  if (it == jobs_.end()) return std::nullopt;
  return status_json_locked(*it->second);
}

std::optional<JobStatus> JobManager::status(const std::string& id) const {
  std::lock_guard lock(mutex_);
  const auto it = jobs_.find(id);
  if (it == jobs_.end()) return std::nullopt;
  return it->second->status;
}

std::string JobManager::status_json_locked(const Job& job, JobStatus shown) const {
  std::optional<size_t> position;
  if (shown == JobStatus::kQueued) {
    const auto pos = std::find(queue_.begin(), queue_.end(), job.id);
    position = pos == queue_.end() ? 0 : static_cast<size_t>(pos - queue_.begin()) + 1;
  }
  return job_document(job, shown, position);
}

JobManager::DeleteOutcome JobManager::remove(const std::string& id) {
  std::unique_lock lock(mutex_);
  changed_cv_.wait(lock, [&] {
    const auto it = jobs_.find(id);
    return it == jobs_.end() || !it->second->persisting;
  });
  const auto it = jobs_.find(id);
  if (it == jobs_.end()) return DeleteOutcome::kUnknown;
  Job& job = *it->second;
  switch (job.status) {
    case JobStatus::kQueued: {
      queue_.erase(std::remove(queue_.begin(), queue_.end(), id), queue_.end());
      job.error = problem_json(ProblemKind::kCancelled, "cancelled by DELETE before it started",
                               "/v1/jobs/" + id, "");
      remove_request_files(id);  // unlinks only: quick enough under the lock
      finish_locked(job, JobStatus::kCancelled);
      return DeleteOutcome::kCancelled;
    }
    case JobStatus::kRunning:
      job.reason = StopReason::kUser;
      job.cancel = true;
      return DeleteOutcome::kCancelling;
    case JobStatus::kDone:
    case JobStatus::kFailed:
    case JobStatus::kCancelled:
      remove_quietly(cache_.path_of(id));
      remove_quietly(grid_field_path(dir("results"), id));
      remove_quietly(grid_labels_path(dir("results"), id));
      remove_quietly(dir("results") + "/" + id + ".json");
      remove_quietly(dir("failed") + "/" + id + ".json");
      cache_.erase(id);
      jobs_.erase(it);
      ++version_;
      changed_cv_.notify_all();
      return DeleteOutcome::kForgotten;
  }
  return DeleteOutcome::kUnknown;
}

std::shared_ptr<LoadedResult> JobManager::result(const std::string& id) {
  std::string params_json;
  {
    std::lock_guard lock(mutex_);
    const auto it = jobs_.find(id);
    if (it == jobs_.end()) throw ProblemError(ProblemKind::kNotFound, "no job " + id);
    const Job& job = *it->second;
    switch (job.status) {
      case JobStatus::kQueued:
      case JobStatus::kRunning:
        throw ProblemError(ProblemKind::kJobNotFinished,
                           "job " + id + " is " + std::string(job_status_name(job.status)) +
                               "; poll /v1/jobs/" + id + " or follow /v1/jobs/" + id + "/events");
      case JobStatus::kFailed:
        throw ProblemError(ProblemKind::kJobFailed, "job " + id + " failed; see /v1/jobs/" + id);
      case JobStatus::kCancelled:
        throw ProblemError(ProblemKind::kCancelled, "job " + id + " was cancelled");
      case JobStatus::kDone:
        break;
    }
    params_json = job.params_json;
  }
  auto loaded = cache_.get(id, params_json);
  if (!loaded) throw ProblemError(ProblemKind::kNotFound, "the result of job " + id + " is gone");
  return loaded;
}

uint64_t JobManager::version() const {
  std::lock_guard lock(mutex_);
  return version_;
}

uint64_t JobManager::wait_for_change(uint64_t seen, std::chrono::milliseconds timeout) const {
  std::unique_lock lock(mutex_);
  changed_cv_.wait_for(lock, timeout, [&] { return version_ != seen || stopping_; });
  return version_;
}

size_t JobManager::queue_depth() const {
  std::lock_guard lock(mutex_);
  return queue_.size();
}

size_t JobManager::running() const {
  std::lock_guard lock(mutex_);
  return running_;
}

std::string JobManager::list_json() const {
  std::lock_guard lock(mutex_);
  std::vector<const Job*> all;
  for (const auto& [id, job] : jobs_) all.push_back(job.get());
  std::sort(all.begin(), all.end(),
            [](const Job* a, const Job* b) { return a->submitted_at > b->submitted_at; });
  Json list = Json::array();
  for (const Job* job : all) {
    if (list.size() >= 1000) break;
    list.push_back({{"id", job->id},
                    {"status", job_status_name(job->status)},
                    {"submitted_at", iso_time(job->submitted_at)},
                    {"href", "/v1/jobs/" + job->id}});
  }
  return Json{{"jobs", list}}.dump();
}

double JobManager::take_token(const std::string& client, double rate, double burst) {
  std::lock_guard lock(buckets_mutex_);
  const auto now = Clock::now();
  if (buckets_.size() > 100000) buckets_.clear();  // many clients: start them all afresh
  auto [it, fresh] = buckets_.try_emplace(client, Bucket{burst, now});
  Bucket& b = it->second;
  if (!fresh) {
    b.tokens = std::min(burst, b.tokens + std::chrono::duration<double>(now - b.at).count() * rate);
    b.at = now;
  }
  if (b.tokens < 1) return (1 - b.tokens) / rate;
  b.tokens -= 1;
  return 0;
}

void JobManager::log_event(const char* level, const char* event, const std::string& id,
                           double seconds, const std::string& detail) const {
  if (options_.quiet) return;
  Json line = {{"ts", unix_now()}, {"level", level}, {"event", event}};
  if (!id.empty()) line["job"] = id;
  if (seconds > 0) line["seconds"] = seconds;
  if (!detail.empty()) line["detail"] = detail;
  // Replace, not throw, on invalid UTF-8: a detail can quote bytes of a broken store file.
  std::fprintf(stderr, "%s\n", line.dump(-1, ' ', false, Json::error_handler_t::replace).c_str());
}

void JobManager::remove_request_files(const std::string& id) const {
  remove_stored_request(dir("requests") + "/" + id);
}

void JobManager::finish_locked(Job& job, JobStatus status) {
  job.status = status;
  if (job.finished_at == 0) job.finished_at = unix_now();
  const double seconds = job.started_at > 0 ? job.finished_at - job.started_at : 0;
  metrics_.job_finished(std::string(job_status_name(status)), seconds);
  log_event(status == JobStatus::kDone ? "info" : "warn",
            status == JobStatus::kDone     ? "job_done"
            : status == JobStatus::kFailed ? "job_failed"
                                           : "job_cancelled",
            job.id, seconds);
  ++version_;
  changed_cv_.notify_all();
}

void JobManager::worker_loop() {
  for (;;) {
    std::shared_ptr<Job> job;
    {
      std::unique_lock lock(mutex_);
      work_cv_.wait(lock, [&] { return stopping_ || (!draining_ && !queue_.empty()); });
      if (stopping_) return;
      job = jobs_.at(queue_.front());
      queue_.pop_front();
      job->status = JobStatus::kRunning;
      job->started_at = unix_now();
      job->run_start = job->stage_start = Clock::now();
      job->stages.clear();
      job->cancel = false;
      job->reason = StopReason::kNone;
      job->finished_at = 0;
      job->error.clear();
      log_event("info", "job_started", job->id, 0);
      ++running_;
      ++version_;
      changed_cv_.notify_all();
    }
    run(job);
    std::lock_guard lock(mutex_);
    --running_;
    work_cv_.notify_all();  // drain() waits for running_ == 0
  }
}

void JobManager::run(const std::shared_ptr<Job>& job) {
  const std::string base = dir("requests") + "/" + job->id;
  const std::string instance = "/v1/jobs/" + job->id;
  JobFailure failure;
  // Everything this thread and the threads working for it allocate from here is the job's;
  // past its limit the allocator sets the cancel flag, which every stage reads.
  job->memory.set_limit(static_cast<int64_t>(job_memory_limit_bytes(options_)), &job->cancel);
  const ScopedMemoryAccount charge(&job->memory);
  try {
    SceneLimits limits;
    limits.max_objects = options_.max_objects;
    limits.max_simplices = options_.max_simplices;
    const ProgressFn progress = [this, job](const std::string& stage, double fraction) {
      std::lock_guard lock(mutex_);
      job->memory_peak_bytes = job->memory.peak();
      if (!record_progress(*job, stage, fraction)) return;
      ++version_;
      changed_cv_.notify_all();
    };
    Scene scene = read_stored_scene(base, limits, &job->cancel, progress);
    {
      // A volume's objects are known from here on.
      std::lock_guard lock(mutex_);
      job->dimension = scene.dimension;
      job->objects = scene.objects.size();
      job->simplices = scene.simplex_count();
      ++version_;
      changed_cv_.notify_all();
    }
    std::shared_ptr<const GvdResult> result =
        compute_job(std::move(scene), JobParams::from_json(job->params_json), options_,
                    &job->cancel, progress, dir("results"), job->id);
    // Persist: the result file (atomic), then its status document, then drop the request.
    const std::vector<uint8_t> bytes = result_to_bytes(*result);
    write_file_atomic(cache_.path_of(job->id), bytes.data(), bytes.size());
    const std::string info = result_info_json(*result);
    std::string doc;
    {
      std::lock_guard lock(mutex_);
      job->memory_peak_bytes = job->memory.peak();
      job->result_info = info;
      job->finished_at = unix_now();
      doc = status_json_locked(*job, JobStatus::kDone);
    }
    try {
      write_file_atomic(dir("results") + "/" + job->id + ".json", doc);
    } catch (const std::exception&) {
      // Rebuilt from the result file at the next start.
    }
    remove_request_files(job->id);
    cache_.put(job->id, result);
    for (const StageStats& st : result->stats.stages) metrics_.stage(st.name, st.seconds);
    std::lock_guard lock(mutex_);
    finish_locked(*job, JobStatus::kDone);
    return;
  } catch (const std::exception&) {
    failure = current_job_failure();
  }
  std::unique_lock lock(mutex_);
  job->memory_peak_bytes = job->memory.peak();
  if (failure.kind == ProblemKind::kCancelled) {
    job->reason = stop_reason(job->reason, job->memory);
    if (job->reason == StopReason::kShutdown) {
      // Stays on disk and runs again at the next start.
      job->status = JobStatus::kQueued;
      ++version_;
      changed_cv_.notify_all();
      return;
    }
    failure = explain_stop(std::move(failure), job->reason, job->memory, options_);
  }
  const JobStatus final =
      failure.kind == ProblemKind::kCancelled ? JobStatus::kCancelled : JobStatus::kFailed;
  job->error = problem_json(failure.kind, failure.detail, instance, "");
  job->finished_at = unix_now();
  const std::string doc = status_json_locked(*job, final);
  lock.unlock();
  // Files first, then the final status: once a job shows as failed or cancelled it may be
  // submitted again, and its new request files must not be removed by this thread.
  if (final == JobStatus::kFailed) {
    try {
      write_file_atomic(dir("failed") + "/" + job->id + ".json", doc);
    } catch (const std::exception&) {
      // The status stays in memory; a failure is deterministic and recomputed otherwise.
    }
  }
  remove_request_files(job->id);
  lock.lock();
  finish_locked(*job, final);
}

void JobManager::watchdog_loop() {
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    changed_cv_.wait_for(lock, std::chrono::milliseconds(50));
    if (stopping_) return;
    const auto now = Clock::now();
    const auto limit = std::chrono::duration<double>(options_.job_seconds);
    std::vector<Job*> running;
    for (auto& [id, job] : jobs_) {
      if (job->status != JobStatus::kRunning || job->cancel) continue;
      if (now - job->run_start > limit) {
        job->reason = StopReason::kTimeout;
        job->cancel = true;
      } else {
        running.push_back(job.get());
      }
    }
    if (!running.empty() && options_.max_memory_mb > 0 &&
        resident_memory_bytes() > options_.max_memory_mb * (1ull << 20)) {
      if (cache_.size() > 0) {
        // Cached results can be loaded again: drop them first and look again next tick.
        cache_.clear();
        log_event("warn", "memory_limit_cache_cleared", "", 0);
      } else if (Job* job = job_to_stop_for_memory(running)) {
        // Still over: stop the job that holds the most itself (not the one that started
        // last, which may hold little: each is charged for its own growth).
        job->reason = StopReason::kMemory;
        job->cancel = true;
      }
    }
  }
}

void JobManager::drain(std::chrono::milliseconds grace) {
  std::unique_lock lock(mutex_);
  draining_ = true;
  work_cv_.wait_for(lock, grace, [&] { return running_ == 0; });
}

void JobManager::stop() {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ && workers_.empty() && !watchdog_.joinable()) return;
    draining_ = true;
    stopping_ = true;
    for (auto& [id, job] : jobs_) {
      if (job->status == JobStatus::kRunning) {
        job->reason = StopReason::kShutdown;
        job->cancel = true;
      }
    }
    work_cv_.notify_all();
    changed_cv_.notify_all();
  }
  for (std::thread& t : workers_) t.join();
  workers_.clear();
  if (watchdog_.joinable()) watchdog_.join();
}

}  // namespace gvd::server
