#pragma once

// The heap bytes one computation holds, so that a process running several (gvd-server's
// workers) can charge each for its own growth rather than for the process's resident size,
// which also holds request bodies, cached results and other jobs.

#include <atomic>
#include <cstdint>

namespace gvd {

/// Bytes charged by the allocator to one computation: what it allocated minus what it freed,
/// on every thread that runs for it. The allocator is gvd-server's (its operator new and
/// delete charge the calling thread's account); in a process without it, accounts stay at 0.
/// parallel_for's workers and the BVH build's thread run under their caller's account.
class MemoryAccount {
 public:
  /// When the bytes pass `limit` (0: never), `over()` becomes true and `*flag` (if not null,
  /// e.g. the computation's cancel flag) is set.
  void set_limit(int64_t limit, std::atomic<bool>* flag) {
    flag_.store(flag, std::memory_order_relaxed);
    limit_.store(limit, std::memory_order_release);
  }
  /// The bytes held now and the most held so far. Each thread charges its account in steps
  /// of up to kMemoryChargeStep, so both may be short by that much per thread.
  int64_t bytes() const { return bytes_.load(std::memory_order_relaxed); }
  int64_t peak() const { return peak_.load(std::memory_order_relaxed); }
  bool over() const { return over_.load(std::memory_order_acquire); }
  /// Called by charge_memory (and by the tests).
  void add(int64_t delta);

 private:
  std::atomic<int64_t> bytes_{0};
  std::atomic<int64_t> peak_{0};
  std::atomic<int64_t> limit_{0};
  std::atomic<std::atomic<bool>*> flag_{nullptr};
  std::atomic<bool> over_{false};
};

/// The account the calling thread's allocations are charged to (null: none).
MemoryAccount* current_memory_account();

/// Charges the calling thread's allocations to `account` (may be null: none) until destroyed,
/// then to the account before.
class ScopedMemoryAccount {
 public:
  explicit ScopedMemoryAccount(MemoryAccount* account);
  ~ScopedMemoryAccount();
  ScopedMemoryAccount(const ScopedMemoryAccount&) = delete;
  ScopedMemoryAccount& operator=(const ScopedMemoryAccount&) = delete;

 private:
  MemoryAccount* previous_;
};

/// For the allocator: whether the calling thread has an account (the block's size need not
/// be asked for otherwise), and `delta` bytes (+ allocated, - freed) charged to it. Gathered
/// per thread and passed on every kMemoryChargeStep bytes and when the thread's account
/// changes, so that threads do not contend for the account on every allocation.
bool charging_memory();
void charge_memory(int64_t delta);
inline constexpr int64_t kMemoryChargeStep = int64_t{1} << 20;

}  // namespace gvd
