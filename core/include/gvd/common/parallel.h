#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace gvd {

/// Number of worker threads to use: `requested` if > 0, else the hardware concurrency.
inline int resolve_threads(int requested) {
  if (requested > 0) return requested;
  const unsigned hc = std::thread::hardware_concurrency();
  return hc == 0 ? 1 : static_cast<int>(hc);
}

/// Runs body(begin, end, thread_index) over [0, n) split into contiguous chunks handed out
/// dynamically to `threads` threads (the calling thread is one of them). The first exception
/// thrown by a body is rethrown after all threads stopped.
template <class Body>
void parallel_for(size_t n, int threads, Body&& body, size_t grain = 1024) {
  threads = std::max(1, threads);
  if (n == 0) return;
  if (threads == 1 || n <= grain) {
    body(size_t{0}, n, 0);
    return;
  }
  std::atomic<size_t> next{0};
  std::exception_ptr error;
  std::mutex error_mutex;
  auto worker = [&](int t) {
    try {
      for (;;) {
        const size_t b = next.fetch_add(grain);
        if (b >= n) break;
        body(b, std::min(n, b + grain), t);
      }
    } catch (...) {
      std::lock_guard<std::mutex> lock(error_mutex);
      if (!error) error = std::current_exception();
      next.store(n);
    }
  };
  const int count = static_cast<int>(std::min<size_t>(threads, (n + grain - 1) / grain));
  std::vector<std::thread> pool;
  pool.reserve(count - 1);
  for (int t = 1; t < count; ++t) pool.emplace_back(worker, t);
  worker(0);
  for (auto& th : pool) th.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace gvd
