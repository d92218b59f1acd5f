#pragma once

#include <string>
#include <string_view>

#include "gvd/common/error.h"

namespace gvd::server {

/// Every kind of error the server answers with: the core's ErrorCodes plus the transport's
/// own (body too large, queue full, ...). One row each in the table of problem.cpp.
enum class ProblemKind {
  // Core error codes (gvd::ErrorCode), same order.
  kInvalidScene,
  kInvalidArgument,
  kUnsupportedFormat,
  kOutsideDomain,
  kLimitExceeded,
  kNotFound,
  kIo,
  kCancelled,
  kInternal,
  // Transport.
  kRouteNotFound,
  kMethodNotAllowed,
  kLengthRequired,
  kBodyTooLarge,
  kHeadersTooLarge,
  kUnsupportedMediaType,
  kUnsupportedEncoding,
  kQueueFull,
  kDraining,
  kTooManyStreams,
  kJobNotFinished,
  kJobFailed,
  kNoPath,
  kRateLimited,       ///< one client over its submission rate (--rate-limit)
  kQueueUnavailable,  ///< the shared job queue (Redis) cannot be reached
  kUriTooLong,        ///< a request line over cpp-httplib's 8 KiB
  kRequestTimeout,    ///< headers or a body that did not arrive in time (--header-timeout,
                      ///< --body-seconds)
  kOverloaded,        ///< every HTTP thread busy and --max-queued-requests waiting
  kAdaptiveOnly,      ///< an output or query of a grid job (mode=grid) that needs the octree
};

/// One row of the table: HTTP status, stable problem type URI, title, whether retrying the
/// same request later can succeed (then the answer carries Retry-After).
struct ProblemInfo {
  int status = 500;
  std::string_view type;   ///< relative URI "/problems/<name>", stable across versions
  std::string_view title;  ///< short, human, the same for every instance
  bool retryable = false;
};

const ProblemInfo& problem_info(ProblemKind kind);
ProblemKind problem_kind(ErrorCode code);

/// Every row, for the documentation and the tests.
inline constexpr int kProblemKindCount = static_cast<int>(ProblemKind::kAdaptiveOnly) + 1;

/// An RFC 9457 problem document (application/problem+json):
/// {"type","title","status","detail","instance","request_id"} plus, from the core error's
/// location (gvd::ErrorLocation, never the detail's text), "object": {"index","label"},
/// "element": {"kind","index"} and "pointer" (a JSON pointer into the scene or glTF) where it
/// gives them, and any extra members given as a JSON object text in `extra_json`.
/// Seconds as a person writes them in a message: "5", "0.25", "1e+07" (not "5.000000").
std::string seconds_text(double seconds);

std::string problem_json(ProblemKind kind, std::string_view detail, std::string_view instance,
                         std::string_view request_id, std::string_view extra_json = {},
                         const ErrorLocation& where = {});

/// A thrown problem (transport errors raised inside handlers).
class ProblemError : public std::runtime_error {
 public:
  ProblemError(ProblemKind kind, std::string detail, std::string extra_json = {})
      : std::runtime_error(detail),
        kind_(kind),
        detail_(std::move(detail)),
        extra_json_(std::move(extra_json)) {}
  ProblemKind kind() const { return kind_; }
  const std::string& detail() const { return detail_; }
  const std::string& extra_json() const { return extra_json_; }

 private:
  ProblemKind kind_;
  std::string detail_;
  std::string extra_json_;
};

}  // namespace gvd::server
