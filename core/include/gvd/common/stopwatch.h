#pragma once

// Stopwatch: the wall-clock time in seconds, on std::chrono::steady_clock, since construction or
// the last lap(), which returns the elapsed time and starts again.

#include <chrono>

namespace gvd {

/// Wall-clock time since construction (or the last restart), in seconds.
class Stopwatch {
 public:
  Stopwatch() : start_(std::chrono::steady_clock::now()) {}
  double seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }
  /// Returns the elapsed seconds and starts again.
  double lap() {
    const double s = seconds();
    start_ = std::chrono::steady_clock::now();
    return s;
  }

 private:
  std::chrono::steady_clock::time_point start_;
};

}  // namespace gvd
