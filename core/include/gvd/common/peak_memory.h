#pragma once

// The process's memory as the system reports it (peak, current and file-backed resident size,
// process-wide; on Linux from /proc/self/status, 0 where it cannot be read), and the heap policy
// of the processes that run computations: freed blocks of kReturnedBlockBytes and more go back to
// the system (a small computation may keep some), so that the resident size follows what the
// stages hold. use_returning_heap is called once, before any thread starts.

#include <cstddef>
#include <cstdint>

namespace gvd {

/// The process's peak resident set size so far (Linux: VmHWM of /proc/self/status), in bytes;
/// 0 where it cannot be read. Process-wide: in a long-running server it includes every job
/// run before.
uint64_t peak_rss_bytes();
/// The process's resident set size now (Linux: VmRSS), in bytes; 0 where it cannot be read.
uint64_t rss_bytes();
/// The part of the resident set that maps files (Linux: RssFile): mostly the code and data of
/// shared libraries, shared with every other process that maps them and dropped by the kernel
/// under pressure. With OpenCL through PoCL it is ~65 MB (its LLVM), against ~14 MB of memory
/// the runtime allocates. 0 where it cannot be read.
uint64_t file_rss_bytes();

/// The heap policy of a process that runs computations (the command line, the server, the
/// benchmarks; not the Python module, which lives in someone else's process): blocks of
/// kReturnedBlockBytes and more are mapped on their own and unmapped when freed, so that the
/// resident memory follows what the stages hold rather than the most they ever held. glibc's
/// default raises that threshold each time such a block is freed (up to 32 MiB), after which
/// a stage's freed arrays stay resident under the next stage's; keeping every freed block
/// (a threshold of 1 GiB, what gvd did before) put the spheres' peak 100 MB higher for 3-8 %
/// of the CPU time (page faults of arrays mapped again). Call once, before any thread starts.
///
/// `small_computations_keep_blocks` (the command line and the benchmarks, which run one
/// computation at a time): heap_checkpoint then lets a small computation keep its freed
/// blocks below kKeptBlockBytes in the heap. Each refinement round frees and allocates arrays
/// of the same sizes; returning them made every round fault their pages in again, and a page
/// fault costs ~10 us on a virtual machine with slow page-table updates (this one), a quarter
/// of the paper's maze's time. What that keeps is a few MB; a large computation keeps the
/// policy above (deciding by the process's resident size instead, keeping blocks until it
/// passed 32-64 MB, put the spheres' peak 4-15 MB higher).
///
/// With `small_computations_keep_blocks`, a computation's heap also asks the kernel for
/// transparent huge pages (madvise; where the system offers them on request) until the
/// computation turns out not to be small (heap_computation_grows, heap_checkpoint): one fault
/// then maps 2 MiB instead of 4 KiB. That took the maze from ~5,700 page faults to ~3,200 and
/// 16 % off its time (docs/BENCHMARKS.md); on a large computation it would hold 2 MiB pages its
/// small blocks only partly use (the spheres' peak 14-17 MB higher), so a large one gives them up.
void use_returning_heap(bool small_computations_keep_blocks = false);
/// Called by the pipeline when it knows the size of the computation it runs (the octree's
/// leaves, after each build and refinement round and before surfacing): switches the policy
/// of use_returning_heap to it. A computation that grew past small gives back at each later
/// checkpoint the kept blocks it has freed since. Nothing unless use_returning_heap(true) was
/// called.
void heap_checkpoint(size_t leaves);
/// Called by the pipeline as a computation starts (its size unknown while its first octree is
/// built): the returning policy, and what the last computation kept given back (with huge
/// pages, only once this one turns out not to be small: giving back the free pages inside the
/// heap splits its huge pages, and the next small computation faulted 4 KiB pages again).
void heap_computation_starts();
/// Called while a computation's first octree is built (the cells made so far): the huge pages
/// of use_returning_heap for the heap it has grown, or none from here on once it is past
/// small (and what earlier computations kept given back then). Nothing unless
/// use_returning_heap(true) was called.
void heap_computation_grows(size_t cells);
/// While one lives on a thread, the three calls above do nothing on that thread: a computation
/// run inside another (the plane GVD on a junction cell's face) must not switch the heap
/// policy of the one around it.
class NestedComputation {
 public:
  NestedComputation();
  ~NestedComputation();
  NestedComputation(const NestedComputation&) = delete;
  NestedComputation& operator=(const NestedComputation&) = delete;
};
inline constexpr int kReturnedBlockBytes = 256 << 10;
inline constexpr int kKeptBlockBytes = 2 << 20;
/// Below this many leaves a computation is small (~25 MB at 200 B per leaf).
inline constexpr size_t kSmallComputationLeaves = size_t{1} << 17;

}  // namespace gvd
