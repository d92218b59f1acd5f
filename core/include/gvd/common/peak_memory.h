#pragma once

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
void use_returning_heap();
inline constexpr int kReturnedBlockBytes = 256 << 10;

}  // namespace gvd
