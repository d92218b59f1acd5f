#pragma once

// The one OpenCL backend of the parity test process, created once before any test uses it
// (PoCL must be initialised once: several threads making the first OpenCL calls at once crash
// it). Tests that need it skip with the reason when there is no platform.

#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "gvd/kernels/opencl_backend.h"

namespace gvd::test {

/// The backend, or null with `why` set (no platform / device).
std::shared_ptr<kernels::OpenClBackend> opencl_backend(std::string* why);

}  // namespace gvd::test

/// Skips the current test when no OpenCL device exists, saying why.
#define GVD_REQUIRE_OPENCL(backend)                                                \
  std::string gvd_why_;                                                            \
  const auto backend = ::gvd::test::opencl_backend(&gvd_why_);                     \
  if (!backend) {                                                                  \
    GTEST_SKIP() << "no OpenCL device, parity not checked: " << gvd_why_           \
                 << " (install pocl-opencl-icd; POCL_CACHE_DIR must be writable)"; \
  }
