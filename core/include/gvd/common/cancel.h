#pragma once

// The cancel flag of a long computation: another thread sets it, the computation reads it at
// bounded intervals and stops with gvd::Error{kCancelled}.

#include <atomic>
#include <string>

#include "gvd/common/error.h"

namespace gvd {

/// Whether `cancel` (may be null: never) is set. A relaxed load: cheap enough for every row of
/// cells or every few thousand simplices.
inline bool is_cancelled(const std::atomic<bool>* cancel) {
  return cancel != nullptr && cancel->load(std::memory_order_relaxed);
}

/// Throws gvd::Error{kCancelled, "<what> cancelled"} when `cancel` is set.
inline void throw_if_cancelled(const std::atomic<bool>* cancel, const char* what) {
  if (is_cancelled(cancel)) throw Error(ErrorCode::kCancelled, std::string(what) + " cancelled");
}

}  // namespace gvd
