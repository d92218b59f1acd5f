#include "gvd/common/peak_memory.h"

#include <malloc.h>
#include <sys/mman.h>
#include <unistd.h>

#include <atomic>
#include <cstdlib>
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

// `trim`: whether the returning threshold also gives back what was kept (malloc_trim).
void set_block_threshold(int bytes, bool trim = true) {
  int was = block_threshold.load(std::memory_order_relaxed);
  if (was != bytes && block_threshold.compare_exchange_strong(was, bytes)) {
    // Setting the threshold also stops glibc from moving it (and the trim threshold with it).
    mallopt(M_MMAP_THRESHOLD, bytes);
    mallopt(M_TRIM_THRESHOLD, bytes == kKeptBlockBytes ? 4 * kKeptBlockBytes  // the heap's top
                                                       : 128 << 10);          // glibc's default
  }
  if (bytes == kKeptBlockBytes) {
    kept_blocks = true;
  } else if (trim && kept_blocks.load(std::memory_order_relaxed)) {
    malloc_trim(0);
  }
}

// Huge pages for the heap of a small computation (see use_returning_heap). The heap's break
// when use_returning_heap(true) was called: the heap above it is the computations'.
uintptr_t heap_base = 0;
std::atomic<bool> huge_heap{false};

// Asks the kernel for (or no longer for) transparent huge pages on the heap between heap_base
// and the break. The heap grows by brk, and a part added after this call is not advised until
// the next one: while huge pages are wanted, the heap's top is first grown to kHeapHeadroom of
// free room (a block allocated there and freed; glibc then keeps that much as its top pad when
// it trims), so that the next stage's arrays fall inside the advised part. Pages already
// faulted keep their size.
constexpr int kHeapHeadroom = 8 << 20;

void advise_heap(bool huge) {
  mallopt(M_TOP_PAD, huge ? kHeapHeadroom : 128 << 10);  // 128 KiB: glibc's default
  if (huge) {
    const int threshold = block_threshold.load(std::memory_order_relaxed);
    mallopt(M_MMAP_THRESHOLD, 2 * kHeapHeadroom);  // the block from the heap, not mapped
    void* volatile block = malloc(kHeapHeadroom);  // volatile: the pair is not elided
    free(block);
    if (threshold > 0) mallopt(M_MMAP_THRESHOLD, threshold);
  }
  // Whole pages (the kernel maps a huge page where an aligned 2 MiB of the range is whole).
  const uintptr_t page = static_cast<uintptr_t>(sysconf(_SC_PAGESIZE));
  const uintptr_t begin = (heap_base + page - 1) & ~(page - 1);
  const uintptr_t end = reinterpret_cast<uintptr_t>(sbrk(0)) & ~(page - 1);
  if (end > begin) {
    // Fails harmlessly where the kernel has no transparent huge pages.
    (void)madvise(reinterpret_cast<void*>(begin), end - begin,
                  huge ? MADV_HUGEPAGE : MADV_NOHUGEPAGE);
  }
}

// Huge pages while the computation is small, none once it is not (not again in the same one:
// what it holds stays in its 4 KiB pages).
void huge_pages_while_small(size_t size) {
  if (heap_base == 0 || !huge_heap.load(std::memory_order_relaxed)) return;
  if (size >= kSmallComputationLeaves) {
    huge_heap = false;
    set_block_threshold(kReturnedBlockBytes);  // and what earlier ones kept given back
  }
  advise_heap(huge_heap);
}

}  // namespace

uint64_t peak_rss_bytes() { return status_kb("VmHWM:"); }

uint64_t rss_bytes() { return status_kb("VmRSS:"); }

uint64_t file_rss_bytes() { return status_kb("RssFile:"); }

void use_returning_heap(bool small_computations_keep_blocks) {
  adaptive_heap = small_computations_keep_blocks;
  if (small_computations_keep_blocks && heap_base == 0) {
    heap_base = reinterpret_cast<uintptr_t>(sbrk(0));
  } else if (!small_computations_keep_blocks && heap_base != 0) {
    huge_heap = false;
    advise_heap(false);  // and glibc's own top pad again
    heap_base = 0;
  }
  set_block_threshold(kReturnedBlockBytes);
}

namespace {
thread_local int nested_computations = 0;
}  // namespace

NestedComputation::NestedComputation() { ++nested_computations; }
NestedComputation::~NestedComputation() { --nested_computations; }

void heap_checkpoint(size_t leaves) {
  if (!adaptive_heap.load(std::memory_order_relaxed) || nested_computations > 0) return;
  set_block_threshold(leaves < kSmallComputationLeaves ? kKeptBlockBytes : kReturnedBlockBytes);
  huge_pages_while_small(leaves);
}

void heap_computation_grows(size_t cells) {
  if (adaptive_heap.load(std::memory_order_relaxed) && nested_computations == 0)
    huge_pages_while_small(cells);
}

void heap_computation_starts() {
  if (!adaptive_heap.load(std::memory_order_relaxed) || nested_computations > 0) return;
  if (heap_base == 0) {
    set_block_threshold(kReturnedBlockBytes);  // trims what the last one kept
    kept_blocks = false;
    return;
  }
  // With huge pages, what the last computation kept stays until this one turns out not to be
  // small (huge_pages_while_small gives it back then): trimming gives back the free pages
  // inside the heap too, which splits its huge pages, and the next small computation then
  // faulted 4 KiB pages again (the maze's octree stage in gvd_bench's later repetitions,
  // 33-37 ms against 22 ms in the first).
  set_block_threshold(kReturnedBlockBytes, /*trim=*/false);
  huge_heap = true;
  advise_heap(true);
}

}  // namespace gvd
