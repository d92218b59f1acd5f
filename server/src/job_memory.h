#pragma once

// The memory limits of jobs, shared by both queues (job_manager, redis_job_queue): each job
// is charged for the heap it holds itself (gvd/common/memory_account.h, counted by
// counted_new.cpp), not for the process's resident size, which also holds request bodies,
// cached results and other jobs.

#include <cstdint>
#include <string>

#include "gvd/common/memory_account.h"
#include "server_options.h"

namespace gvd::server {

/// The heap one job may hold, bytes: --job-memory-mb, else --max-memory-mb; 0: no limit.
uint64_t job_memory_limit_bytes(const ServerOptions& options);

/// Why a job was stopped: its own memory passed the limit per job.
std::string job_memory_detail(const MemoryAccount& account, const ServerOptions& options);
/// Why a job was stopped: the process passed --max-memory-mb with no cached result left to
/// drop, and of the running jobs this one held the most.
std::string server_memory_detail(const MemoryAccount& account, const ServerOptions& options);

/// Of `jobs` (pointers, raw or shared, to jobs with `cancel`, `memory` and `run_start`), the one to
/// stop when the process is over --max-memory-mb: of those not yet asked to stop, the one
/// that holds the most memory of its own (the newest of equals: it has the least work to
/// lose); null when there is none.
template <class Jobs>
auto* job_to_stop_for_memory(const Jobs& jobs) {
  decltype(&**jobs.begin()) chosen = nullptr;
  for (const auto& job : jobs) {
    if (job->cancel) continue;
    if (chosen == nullptr || job->memory.bytes() > chosen->memory.bytes() ||
        (job->memory.bytes() == chosen->memory.bytes() && job->run_start > chosen->run_start)) {
      chosen = &*job;
    }
  }
  return chosen;
}

}  // namespace gvd::server
