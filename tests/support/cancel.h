#pragma once

// A check shared by the cancel tests: work run with its cancel flag already set must stop with
// gvd::Error{kCancelled}, not run to the end or fail otherwise.

#include <gtest/gtest.h>

#include <functional>

#include "gvd/common/error.h"

namespace gvd::test {

inline void expect_cancelled(const std::function<void()>& work, const char* what) {
  try {
    work();
    ADD_FAILURE() << what << " ran to the end with the flag set";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kCancelled) << what << ": " << e.what();
  }
}

}  // namespace gvd::test
