#include "parity/opencl_env.h"

#include <mutex>

namespace gvd::test {

std::shared_ptr<kernels::OpenClBackend> opencl_backend(std::string* why) {
  static std::once_flag once;
  static std::shared_ptr<kernels::OpenClBackend> backend;
  static std::string reason;
  std::call_once(once, [] {
    if (!kernels::opencl_available(&reason)) return;
    backend = kernels::make_opencl_backend();
  });
  if (why) *why = reason;
  return backend;
}

}  // namespace gvd::test
