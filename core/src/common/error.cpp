#include "gvd/common/error.h"

#include <string>

namespace gvd {

std::string_view error_code_name(ErrorCode code) {
  switch (code) {
    case ErrorCode::kInvalidScene:
      return "invalid_scene";
    case ErrorCode::kInvalidArgument:
      return "invalid_argument";
    case ErrorCode::kUnsupportedFormat:
      return "unsupported_format";
    case ErrorCode::kOutsideDomain:
      return "outside_domain";
    case ErrorCode::kLimitExceeded:
      return "limit_exceeded";
    case ErrorCode::kNotFound:
      return "not_found";
    case ErrorCode::kIo:
      return "io_error";
    case ErrorCode::kCancelled:
      return "cancelled";
    case ErrorCode::kInternal:
      return "internal";
  }
  return "internal";
}

Error::Error(ErrorCode code, std::string detail, ErrorLocation where)
    : std::runtime_error(std::string(error_code_name(code)) + ": " + detail),
      code_(code),
      detail_(std::move(detail)),
      where_(std::move(where)) {}

void fail_check(const char* condition, const char* message, const char* file, int line) {
  throw InternalError(std::string(message) + " (" + condition + " failed at " + file + ":" +
                      std::to_string(line) + ")");
}

}  // namespace gvd
