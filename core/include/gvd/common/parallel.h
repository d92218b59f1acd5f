#pragma once

// The parallel loop every stage uses: resolve_threads (0 or less: the hardware concurrency) and
// parallel_for, which hands out [0, n) in chunks of `grain` to `threads` threads, the caller among
// them, on workers kept for the life of the process (a nested or concurrent loop starts its own).
// The first exception a body throws is rethrown once all threads have stopped, and what the
// workers allocate is charged to the caller's MemoryAccount.

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include "gvd/common/memory_account.h"

namespace gvd {

/// Number of worker threads to use: `requested` if > 0, else the hardware concurrency.
inline int resolve_threads(int requested) {
  if (requested > 0) return requested;
  const unsigned hc = std::thread::hardware_concurrency();
  return hc == 0 ? 1 : static_cast<int>(hc);
}

namespace detail {

/// Worker threads kept for parallel_for: started when first needed and kept for the life of
/// the process (the pool is never destroyed, so a loop still running on another thread at
/// exit cannot meet a destroyed pool; the idle workers end with the process). Starting and
/// joining a thread per loop cost ~50-150 us on this machine, and a pipeline run has hundreds
/// of loops. One loop uses the pool at a time; a nested or concurrent one (another job of the
/// server, a loop inside a loop) finds it busy and starts its own threads.
class WorkerPool {
 public:
  static WorkerPool& instance() {
    static WorkerPool* const pool = new WorkerPool;
    return *pool;
  }
  /// Starts task(t) for t = 1..workers on pool threads; false (nothing started) when busy.
  bool start(int workers, const std::function<void(int)>& task) {
    std::unique_lock<std::mutex> lock(mutex_);
    if (busy_) return false;
    busy_ = true;
    while (threads_ < workers) {
      const int index = ++threads_;
      std::thread([this, index] { loop(index); }).detach();
    }
    task_ = &task;
    workers_ = workers;
    running_.store(workers);
    generation_.fetch_add(1);
    lock.unlock();
    wake_.notify_all();
    return true;
  }
  /// Waits for the tasks start() handed out, then frees the pool.
  void wait() {
    spin_while([&] { return running_.load(std::memory_order_acquire) != 0; });
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [&] { return running_.load() == 0; });
    task_ = nullptr;
    busy_ = false;
  }

 private:
  WorkerPool() = default;
  // Spins while `busy()` holds, up to kSpin: a loop's workers and its caller usually meet
  // again within microseconds (a compute runs hundreds of short loops), and waking a sleeping
  // thread through the condition variable cost ~40 us a loop here (TBB's spinning workers
  // start one in ~2 us; tests/library_checks/tbb_parallel.cpp).
  template <class Busy>
  static void spin_while(Busy&& busy) {
    constexpr auto kSpin = std::chrono::microseconds(50);
    const auto until = std::chrono::steady_clock::now() + kSpin;
    for (int i = 1; busy(); ++i) {
      if (i % 64 == 0 && std::chrono::steady_clock::now() >= until) return;
      std::this_thread::yield();
    }
  }
  void loop(int index) {
    uint64_t seen = 0;
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
      if (generation_.load() == seen) {
        lock.unlock();
        spin_while([&] { return generation_.load(std::memory_order_acquire) == seen; });
        lock.lock();
      }
      wake_.wait(lock, [&] { return generation_.load() != seen && index <= workers_; });
      seen = generation_.load();
      const std::function<void(int)>* task = task_;
      lock.unlock();
      (*task)(index);  // never throws: parallel_for's tasks catch everything
      lock.lock();
      if (--running_ == 0) done_.notify_all();
    }
  }
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  const std::function<void(int)>* task_ = nullptr;
  // Written under mutex_; read without it only by the spins (the lock is taken after them).
  std::atomic<uint64_t> generation_{0};
  std::atomic<int> running_{0};
  int threads_ = 0, workers_ = 0;
  bool busy_ = false;
};

}  // namespace detail

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
  MemoryAccount* const account = current_memory_account();
  auto worker = [&](int t) {
    const ScopedMemoryAccount charge(account);  // what the workers allocate is the caller's
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
  const std::function<void(int)> task = worker;
  detail::WorkerPool& kept = detail::WorkerPool::instance();
  if (kept.start(count - 1, task)) {
    worker(0);
    kept.wait();
  } else {
    std::vector<std::thread> pool;
    pool.reserve(count - 1);
    for (int t = 1; t < count; ++t) pool.emplace_back(worker, t);
    worker(0);
    for (auto& th : pool) th.join();
  }
  if (error) std::rethrow_exception(error);
}

}  // namespace gvd
