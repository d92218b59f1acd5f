#include "metrics.h"

#include <unistd.h>

#include <cstdio>
#include <fstream>

namespace gvd::server {
namespace {

const std::vector<double> kRequestBounds = {0.0005, 0.001, 0.002, 0.005, 0.01, 0.025,
                                            0.05,   0.1,   0.25,  0.5,   1,    5};
const std::vector<double> kJobBounds = {0.01, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10, 30, 60, 300};

std::string number(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::string escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '\\' || c == '"') out += '\\';
    if (c == '\n') {
      out += "\\n";
      continue;
    }
    out += c;
  }
  return out;
}

// Counters the server knows in advance, so they appear (at 0) before the first event.
const char* const kCounters[][2] = {
    {"gvd_jobs_submitted_total", "Jobs accepted for computation (new, not cache hits)."},
    {"gvd_job_cache_hits_total", "Submissions answered by an existing job (same content)."},
    {"gvd_jobs_rejected_total", "Submissions refused because the queue was full."},
    {"gvd_result_cache_hits_total", "Result lookups served from the in-memory LRU."},
    {"gvd_result_cache_misses_total", "Result lookups that loaded the result from disk."},
    {"gvd_jobs_recovered_total", "Unfinished jobs re-queued at start-up."},
    {"gvd_queue_reclaimed_total",
     "Redis queue: jobs this replica took over from a stopped worker (XAUTOCLAIM)."},
    {"gvd_queue_redis_reconnects_total", "Redis queue: connections to Redis lost."},
    {"gvd_jobs_rate_limited_total", "Submissions refused by the per-client token bucket."},
    {"gvd_http_requests_overloaded_total",
     "Requests answered 503 at once because every HTTP thread was busy and "
     "--max-queued-requests waited (header_gate.h)."},
};

}  // namespace

void Histogram::observe(double value) {
  size_t i = 0;
  while (i < bounds_.size() && value > bounds_[i]) ++i;
  ++counts_[i];
  sum_ += value;
  ++count_;
}

void Histogram::render(std::string& out, const std::string& name, const std::string& labels) const {
  uint64_t cumulative = 0;
  const std::string sep = labels.empty() ? "" : ",";
  for (size_t i = 0; i <= bounds_.size(); ++i) {
    cumulative += counts_[i];
    out += name + "_bucket{" + labels + sep + "le=\"" +
           (i < bounds_.size() ? number(bounds_[i]) : std::string("+Inf")) + "\"} " +
           std::to_string(cumulative) + "\n";
  }
  const std::string braces = labels.empty() ? "" : "{" + labels + "}";
  out += name + "_sum" + braces + " " + number(sum_) + "\n";
  out += name + "_count" + braces + " " + std::to_string(count_) + "\n";
}

Metrics::Metrics() : job_seconds_(kJobBounds) {
  for (const auto& c : kCounters) counters_[c[0]] = 0;
}

void Metrics::request(const std::string& route, const std::string& method, int status,
                      double seconds) {
  std::lock_guard lock(mutex_);
  ++requests_[{route, method, status}];
  request_seconds_.try_emplace(route, kRequestBounds).first->second.observe(seconds);
}

void Metrics::job_finished(const std::string& status, double seconds) {
  std::lock_guard lock(mutex_);
  ++jobs_finished_[status];
  if (status == "done") job_seconds_.observe(seconds);
}

void Metrics::stage(const std::string& stage, double seconds) {
  std::lock_guard lock(mutex_);
  stage_seconds_.try_emplace(stage, kJobBounds).first->second.observe(seconds);
}

void Metrics::count(const std::string& name) {
  std::lock_guard lock(mutex_);
  ++counters_[name];
}

void Metrics::gauge(const std::string& name, const std::string& help, GaugeFn fn) {
  std::lock_guard lock(mutex_);
  gauges_.emplace_back(name, help, std::move(fn));
}

std::string Metrics::render() const {
  // Gauges read other components' state under their own locks: evaluate them before taking
  // ours, so no lock is ever held while waiting for another (no ordering to get wrong).
  std::vector<std::tuple<std::string, std::string, GaugeFn>> gauges;
  {
    std::lock_guard lock(mutex_);
    gauges = gauges_;
  }
  std::string gauge_text;
  for (const auto& [name, help, fn] : gauges) {
    gauge_text += "# HELP " + name + " " + help + "\n# TYPE " + name + " gauge\n";
    gauge_text += name + " " + number(fn()) + "\n";
  }
  std::lock_guard lock(mutex_);
  std::string out;
  out += "# HELP gvd_http_requests_total HTTP requests by route template, method and status.\n";
  out += "# TYPE gvd_http_requests_total counter\n";
  for (const auto& [key, n] : requests_) {
    const auto& [route, method, status] = key;
    out += "gvd_http_requests_total{route=\"" + escape(route) + "\",method=\"" + method +
           "\",status=\"" + std::to_string(status) + "\"} " + std::to_string(n) + "\n";
  }
  out += "# HELP gvd_http_request_duration_seconds Time to answer a request, by route.\n";
  out += "# TYPE gvd_http_request_duration_seconds histogram\n";
  for (const auto& [route, h] : request_seconds_) {
    h.render(out, "gvd_http_request_duration_seconds", "route=\"" + escape(route) + "\"");
  }
  out += "# HELP gvd_jobs_finished_total Jobs that ended, by final status.\n";
  out += "# TYPE gvd_jobs_finished_total counter\n";
  for (const char* s : {"done", "failed", "cancelled"}) {
    const auto it = jobs_finished_.find(s);
    out += std::string("gvd_jobs_finished_total{status=\"") + s + "\"} " +
           std::to_string(it == jobs_finished_.end() ? 0 : it->second) + "\n";
  }
  out += "# HELP gvd_job_duration_seconds Compute time of finished jobs.\n";
  out += "# TYPE gvd_job_duration_seconds histogram\n";
  job_seconds_.render(out, "gvd_job_duration_seconds", "");
  out += "# HELP gvd_job_stage_duration_seconds Compute time of finished jobs by stage.\n";
  out += "# TYPE gvd_job_stage_duration_seconds histogram\n";
  for (const auto& [stage, h] : stage_seconds_) {
    h.render(out, "gvd_job_stage_duration_seconds", "stage=\"" + escape(stage) + "\"");
  }
  for (const auto& [name, n] : counters_) {
    const char* help = "";
    for (const auto& c : kCounters) {
      if (name == c[0]) help = c[1];
    }
    out += "# HELP " + name + " " + help + "\n# TYPE " + name + " counter\n";
    out += name + " " + std::to_string(n) + "\n";
  }
  out += gauge_text;
  return out;
}

uint64_t resident_memory_bytes() {
  std::ifstream statm("/proc/self/statm");
  uint64_t size = 0, resident = 0;
  if (!(statm >> size >> resident)) return 0;
  return resident * static_cast<uint64_t>(sysconf(_SC_PAGESIZE));
}

}  // namespace gvd::server
