#pragma once

// The thin OpenCL host layer under the backends: RAII handles, checked calls (every failure
// names the call and the error), platform/device choice and the program binary cache. Private
// to gvd_kernels; nothing outside kernels/ includes <CL/cl.h>.

#include <CL/cl.h>

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace gvd::kernels::cl {

/// The symbolic name of an OpenCL error code ("CL_OUT_OF_RESOURCES"), or "CL error <n>".
std::string error_name(cl_int code);

/// Throws gvd::Error{kInternal} "OpenCL: <call> failed: <name> (<code>)<detail>" unless
/// `code` is CL_SUCCESS.
void check(cl_int code, const char* call, const std::string& detail = {});

/// Owns one cl_* handle; releases it with the matching clRelease* call.
template <class Handle, cl_int (*Release)(Handle)>
class Owned {
 public:
  Owned() = default;
  explicit Owned(Handle h) : h_(h) {}
  Owned(const Owned&) = delete;
  Owned& operator=(const Owned&) = delete;
  Owned(Owned&& o) noexcept : h_(std::exchange(o.h_, nullptr)) {}
  Owned& operator=(Owned&& o) noexcept {
    if (this != &o) {
      reset();
      h_ = std::exchange(o.h_, nullptr);
    }
    return *this;
  }
  ~Owned() { reset(); }
  void reset() {
    if (h_ != nullptr) Release(h_);
    h_ = nullptr;
  }
  Handle get() const { return h_; }
  explicit operator bool() const { return h_ != nullptr; }

 private:
  Handle h_ = nullptr;
};

using Context = Owned<cl_context, clReleaseContext>;
using Queue = Owned<cl_command_queue, clReleaseCommandQueue>;
using Program = Owned<cl_program, clReleaseProgram>;
using Kernel = Owned<cl_kernel, clReleaseKernel>;
using Buffer = Owned<cl_mem, clReleaseMemObject>;

/// One OpenCL device found by `list_devices`.
struct DeviceInfo {
  cl_platform_id platform = nullptr;
  cl_device_id device = nullptr;
  std::string platform_name;
  std::string device_name;
  std::string device_version;
  std::string driver_version;
  cl_device_type type = 0;
  bool fp64 = false;
  /// "<platform> / <device>" for logs.
  std::string label() const { return platform_name + " / " + device_name; }
};

/// Every device of every platform. Empty with `why` set when there is no platform (the ICD
/// loader finds none: CL_PLATFORM_NOT_FOUND_KHR, e.g. OCL_ICD_VENDORS is an empty folder) or
/// no platform has a device.
std::vector<DeviceInfo> list_devices(std::string* why);

/// Picks a device. `selector` (GVD_OPENCL_DEVICE): empty = the first GPU with fp64, else the
/// first device with fp64; "P:D" = platform P, device D (indices as `list_devices` orders
/// them); anything else = the first device whose "<platform> / <device>" contains it (case
/// insensitive). Throws gvd::Error{kInvalidArgument} naming the devices when none matches.
DeviceInfo choose_device(const std::vector<DeviceInfo>& devices, const std::string& selector);

/// A context and in-order queue on one device.
struct Runtime {
  DeviceInfo device;
  Context context;
  Queue queue;
};
Runtime make_runtime(const DeviceInfo& device);

/// Where compiled program binaries are kept: `requested`, else $GVD_KERNEL_CACHE_DIR, else
/// $XDG_CACHE_HOME/gvd/kernels, else $HOME/.cache/gvd/kernels ("" = no cache).
std::string resolve_cache_dir(const std::string& requested);

/// Outcome of `build_program` (for logs and the benchmarks).
struct BuildInfo {
  bool from_cache = false;
  double seconds = 0;
  std::string cache_file;  ///< "" when no cache is used
};

/// Builds `source` with `options` for the runtime's device. With a cache directory, the binary
/// is looked up under a key hashing source, options and platform/device/driver names and
/// versions; a miss compiles from source and stores the binary (atomically; an unwritable
/// directory only disables the cache). Build failures throw gvd::Error{kInternal} carrying
/// the compiler's build log.
Program build_program(const Runtime& rt, const std::string& source, const std::string& options,
                      const std::string& cache_dir, BuildInfo* info = nullptr);

/// A kernel of a built program (checked).
Kernel make_kernel(const Program& program, const char* name);

/// A device buffer of `bytes` (> 0), optionally initialised from `host`.
Buffer make_buffer(const Runtime& rt, cl_mem_flags flags, size_t bytes, const void* host);

/// Sets argument `index` of `kernel` to a value (checked, with the kernel and index named).
template <class T>
void set_arg(const Kernel& kernel, cl_uint index, const T& value) {
  check(clSetKernelArg(kernel.get(), index, sizeof(T), &value), "clSetKernelArg",
        " (argument " + std::to_string(index) + ")");
}

/// 64-bit FNV-1a of a byte string (the cache key; not cryptographic, collisions only cost a
/// stale binary, and the key also includes the source length).
uint64_t fnv1a64(const std::string& bytes);

}  // namespace gvd::kernels::cl
