#include "job_stop.h"

#include <exception>
#include <new>

#include "gvd/common/error.h"
#include "job_memory.h"

namespace gvd::server {

JobFailure current_job_failure() {
  try {
    throw;
  } catch (const Error& e) {
    return {problem_kind(e.code()), e.detail()};
  } catch (const std::bad_alloc&) {
    return {ProblemKind::kLimitExceeded, "out of memory"};
  } catch (const std::exception& e) {
    return {ProblemKind::kInternal, e.what()};
  }
}

StopReason stop_reason(StopReason reason, const MemoryAccount& memory) {
  return reason == StopReason::kNone && memory.over() ? StopReason::kJobMemory : reason;
}

JobFailure explain_stop(JobFailure failure, StopReason reason, const MemoryAccount& memory,
                        const ServerOptions& options) {
  if (failure.kind != ProblemKind::kCancelled) return failure;
  switch (reason) {
    case StopReason::kTimeout:
      return {ProblemKind::kLimitExceeded, "the job ran longer than this server's limit of " +
                                               seconds_text(options.job_seconds) +
                                               " s (--job-seconds)"};
    case StopReason::kMemory:
      return {ProblemKind::kLimitExceeded, server_memory_detail(memory, options)};
    case StopReason::kJobMemory:
      return {ProblemKind::kLimitExceeded, job_memory_detail(memory, options)};
    case StopReason::kShutdown:
      return failure;
    case StopReason::kUser:
    case StopReason::kNone:
      break;
  }
  return {ProblemKind::kCancelled, "cancelled by DELETE while running"};
}

}  // namespace gvd::server
