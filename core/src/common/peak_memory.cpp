#include "gvd/common/peak_memory.h"

#include <malloc.h>

#include <atomic>
#include <fstream>
#include <string>

namespace gvd {

namespace {

// A "Name:  <n> kB" line of /proc/self/status, in bytes (0 if absent).
uint64_t status_kb(const std::string& name) {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind(name, 0) == 0) {
      try {
        return static_cast<uint64_t>(std::stoull(line.substr(name.size()))) * 1024;
      } catch (...) {
        return 0;
      }
    }
  }
  return 0;
}

std::atomic<bool> adaptive_heap{false};
std::atomic<int> block_threshold{0};  // the M_MMAP_THRESHOLD in force (0: glibc's own)

// Whether blocks were kept since the heap was last trimmed: a computation that started small
// and grew frees them later, and they are given back at each checkpoint after.
std::atomic<bool> kept_blocks{false};

void set_block_threshold(int bytes) {
  int was = block_threshold.load(std::memory_order_relaxed);
  if (was != bytes && block_threshold.compare_exchange_strong(was, bytes)) {
    // Setting the threshold also stops glibc from moving it (and the trim threshold with it).
    mallopt(M_MMAP_THRESHOLD, bytes);
    mallopt(M_TRIM_THRESHOLD, bytes == kKeptBlockBytes ? 4 * kKeptBlockBytes  // the heap's top
                                                       : 128 << 10);          // glibc's default
  }
  if (bytes == kKeptBlockBytes) {
    kept_blocks = true;
  } else if (kept_blocks.load(std::memory_order_relaxed)) {
    malloc_trim(0);
  }
}

}  // namespace

uint64_t peak_rss_bytes() { return status_kb("VmHWM:"); }

uint64_t rss_bytes() { return status_kb("VmRSS:"); }

uint64_t file_rss_bytes() { return status_kb("RssFile:"); }

void use_returning_heap(bool small_computations_keep_blocks) {
  adaptive_heap = small_computations_keep_blocks;
  set_block_threshold(kReturnedBlockBytes);
}

void heap_checkpoint(size_t leaves) {
  if (!adaptive_heap.load(std::memory_order_relaxed)) return;
  set_block_threshold(leaves < kSmallComputationLeaves ? kKeptBlockBytes : kReturnedBlockBytes);
}

void heap_computation_starts() {
  if (!adaptive_heap.load(std::memory_order_relaxed)) return;
  set_block_threshold(kReturnedBlockBytes);  // trims what the last one kept
  kept_blocks = false;
}

}  // namespace gvd
