#pragma once

#include <cstdint>

namespace gvd {

/// The process's peak resident set size so far (Linux: VmHWM of /proc/self/status), in bytes;
/// 0 where it cannot be read. Process-wide: in a long-running server it includes every job
/// run before.
uint64_t peak_rss_bytes();
/// The process's resident set size now (Linux: VmRSS), in bytes; 0 where it cannot be read.
uint64_t rss_bytes();

}  // namespace gvd
