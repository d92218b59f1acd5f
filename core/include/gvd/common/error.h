#pragma once

// The core's errors: stable error codes with their machine names, gvd::Error (a code, a detail
// text and where in the input it lies; `what()` is "<code name>: <detail>") and InternalError
// for a violated invariant. GVD_CHECK is always on and throws InternalError naming the condition
// and place; GVD_ASSERT does the same but is compiled out under NDEBUG.

#include <cstdint>
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

/// Where in the input an error lies, for callers that point at it (problem documents, the
/// Python exceptions' attributes) without reading the detail text. Unset fields keep their
/// defaults; the detail says the same in words.
struct ErrorLocation {
  int64_t object = -1;  ///< the object's index in the scene (input order); -1: none
  std::string label;    ///< the object's label ("" when none or not known yet)
  /// The kind of element: "vertex", "triangle", "segment", "point" (a query point in a
  /// batch); "" when none.
  std::string element;
  int64_t index = -1;  ///< that element's index (within the object, or the batch); -1: none
  /// A JSON pointer (RFC 6901) into the scene document or the glTF document; "" when none.
  std::string pointer;
  int64_t line = -1;  ///< the line (1-based) of a text input (OBJ, PLY header, STL, OFF); -1: none
  /// A byte offset (0-based) into the JSON text that was parsed (a scene file, a request body,
  /// a glTF; a GLB's JSON chunk counted from the file's start) where it is malformed or nested
  /// too deep, into a binary mesh file (PLY, STL) where it is truncated, or into a GLB's
  /// container where it is cut or at the header field or chunk header at fault; -1: none
  int64_t offset = -1;
  bool empty() const {
    return object < 0 && label.empty() && element.empty() && pointer.empty() && line < 0 &&
           offset < 0;
  }
};

/// The caller's fault or a limit. `what()` is "<code name>: <detail>".
class Error : public std::runtime_error {
 public:
  Error(ErrorCode code, std::string detail, ErrorLocation where = {});
  ErrorCode code() const { return code_; }
  const std::string& detail() const { return detail_; }
  /// Where in the input (structured; the detail says it in words).
  const ErrorLocation& where() const { return where_; }

 private:
  ErrorCode code_;
  std::string detail_;
  ErrorLocation where_;
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
