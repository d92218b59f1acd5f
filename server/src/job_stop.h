#pragma once

// Why a running job stopped and what its problem document says, shared by both queues
// (job_manager, redis_job_queue), so that a job stopped for the same reason reads the same
// whichever queue ran it.

#include <string>

#include "gvd/common/memory_account.h"
#include "problem.h"
#include "server_options.h"

namespace gvd::server {

/// Why a running job's cancel flag was set: by nobody yet, DELETE, --job-seconds, the process
/// over --max-memory-mb, the job over its own memory limit, or the server shutting down.
enum class StopReason { kNone, kUser, kTimeout, kMemory, kJobMemory, kShutdown };

/// A job that did not finish: the problem kind and the detail its document gives.
struct JobFailure {
  ProblemKind kind = ProblemKind::kInternal;
  std::string detail;
};

/// The failure of the exception being handled; call it from a catch block. gvd::Error by its
/// code, std::bad_alloc as a limit ("out of memory"), any other std::exception as internal.
JobFailure current_job_failure();

/// Why a stopped computation stopped: `reason`, or kJobMemory when nothing else asked it to
/// and its own account is over the limit (the account cancels the job itself).
StopReason stop_reason(StopReason reason, const MemoryAccount& memory);

/// `failure` with a cancelled computation (kind kCancelled) explained by `reason`: a limit
/// (kTimeout, kMemory, kJobMemory) with the limit's text, or "cancelled by DELETE while
/// running". Any other failure is returned as it is. kShutdown is not explained: the caller
/// queues the job again instead of failing it.
JobFailure explain_stop(JobFailure failure, StopReason reason, const MemoryAccount& memory,
                        const ServerOptions& options);

}  // namespace gvd::server
