#include "job_memory.h"

#include <algorithm>
#include <cstdio>

namespace gvd::server {
namespace {

std::string megabytes(int64_t bytes) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1f", static_cast<double>(bytes) / (1 << 20));
  return text;
}

}  // namespace

uint64_t job_memory_limit_bytes(const ServerOptions& options) {
  const uint64_t mb = options.job_memory_mb > 0 ? options.job_memory_mb : options.max_memory_mb;
  return std::min<uint64_t>(mb, uint64_t{1} << 40) << 20;
}

std::string job_memory_detail(const MemoryAccount& account, const ServerOptions& options) {
  return "the job's own memory reached " + megabytes(account.peak()) + " MB, over the limit of " +
         std::to_string(job_memory_limit_bytes(options) >> 20) + " MB per job (" +
         (options.job_memory_mb > 0 ? "--job-memory-mb" : "--max-memory-mb") + ")";
}

std::string server_memory_detail(const MemoryAccount& account, const ServerOptions& options) {
  return "the server's memory limit of " + std::to_string(options.max_memory_mb) +
         " MB (--max-memory-mb) was reached while this job ran, with no cached result left to "
         "free; of the running jobs it held the most (" +
         megabytes(account.bytes()) + " MB of its own)";
}

}  // namespace gvd::server
