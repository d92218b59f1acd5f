#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <tuple>
#include <vector>

namespace gvd::server {

/// A Prometheus histogram with fixed upper bounds (seconds).
class Histogram {
 public:
  explicit Histogram(std::vector<double> bounds)
      : bounds_(std::move(bounds)), counts_(bounds_.size() + 1) {}
  void observe(double value);
  /// Appends the `_bucket`, `_sum` and `_count` lines; `labels` is `k="v",...` or empty.
  void render(std::string& out, const std::string& name, const std::string& labels) const;

 private:
  std::vector<double> bounds_;
  std::vector<uint64_t> counts_;  ///< non-cumulative; the last is +Inf
  double sum_ = 0;
  uint64_t count_ = 0;
};

/// The server's metrics, rendered in the Prometheus text format (version 0.0.4). Thread-safe.
class Metrics {
 public:
  Metrics();
  void request(const std::string& route, const std::string& method, int status, double seconds);
  void job_finished(const std::string& status, double seconds);
  void stage(const std::string& stage, double seconds);
  void count(const std::string& name);  ///< a plain counter: cache hits, rejections...

  /// Gauges are read when rendering (queue depth, running jobs, memory...).
  using GaugeFn = std::function<double()>;
  void gauge(const std::string& name, const std::string& help, GaugeFn fn);

  std::string render() const;

 private:
  mutable std::mutex mutex_;
  std::map<std::tuple<std::string, std::string, int>, uint64_t> requests_;
  std::map<std::string, Histogram> request_seconds_;
  std::map<std::string, uint64_t> jobs_finished_;
  Histogram job_seconds_;
  std::map<std::string, Histogram> stage_seconds_;
  std::map<std::string, uint64_t> counters_;
  std::vector<std::tuple<std::string, std::string, GaugeFn>> gauges_;
};

/// Resident set size of this process, bytes (0 when unknown).
uint64_t resident_memory_bytes();

}  // namespace gvd::server
