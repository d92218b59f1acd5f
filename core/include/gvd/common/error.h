#pragma once

#include <stdexcept>
#include <string>
#include <string_view>

namespace gvd {

/// Stable error codes of the core. The server maps each to an HTTP status and a problem
/// type in one table; the CLI maps them to exit codes.
enum class ErrorCode {
  kInvalidScene,       ///< the input geometry is malformed (says which object and index)
  kInvalidArgument,    ///< an option or query is malformed or out of range
  kUnsupportedFormat,  ///< the input format is not recognised
  kOutsideDomain,      ///< a query point lies outside the computed domain
  kLimitExceeded,      ///< a configured limit (objects, simplices, leaves, time) was hit
  kNotFound,           ///< an unknown label, file or result
  kIo,                 ///< reading or writing a file failed
  kCancelled,          ///< the caller cancelled the computation
  kInternal,           ///< a bug: an internal consistency check failed
};

/// Short machine name of a code ("invalid_scene", ...), stable across versions.
std::string_view error_code_name(ErrorCode code);

/// The caller's fault or a limit. `what()` is "<code name>: <detail>".
class Error : public std::runtime_error {
 public:
  Error(ErrorCode code, std::string detail);
  ErrorCode code() const { return code_; }
  const std::string& detail() const { return detail_; }

 private:
  ErrorCode code_;
  std::string detail_;
};

/// Our bug: a violated internal invariant.
class InternalError : public Error {
 public:
  explicit InternalError(std::string detail) : Error(ErrorCode::kInternal, std::move(detail)) {}
};

[[noreturn]] void fail_check(const char* condition, const char* message, const char* file,
                             int line);

}  // namespace gvd

/// Always-on invariant check; throws gvd::InternalError naming the condition and place.
#define GVD_CHECK(cond, msg)                                          \
  do {                                                                \
    if (!(cond)) ::gvd::fail_check(#cond, (msg), __FILE__, __LINE__); \
  } while (false)

#ifdef NDEBUG
#define GVD_ASSERT(cond, msg) \
  do {                        \
  } while (false)
#else
#define GVD_ASSERT(cond, msg) GVD_CHECK(cond, msg)
#endif
