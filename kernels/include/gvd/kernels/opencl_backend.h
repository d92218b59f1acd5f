#pragma once

// The OpenCL compute backend and the choice between it and the CPU twins. The only
// public header of gvd_kernels; OpenCL types stay inside the library.

#include <memory>
#include <string>

#include "gvd/compute/compute_backend.h"

namespace gvd::kernels {

/// Options of the OpenCL backend.
struct OpenClOptions {
  /// Which device: "" = $GVD_OPENCL_DEVICE, and when that is unset too the first GPU with
  /// fp64, else the first device with fp64. "P:D" = platform P, device D (0-based, in
  /// clGetPlatformIDs/clGetDeviceIDs order); any other text = the first device whose
  /// "<platform> / <device>" contains it (case insensitive), e.g. "pthread" or "NVIDIA".
  std::string device;
  /// Program binary cache: "" = $GVD_KERNEL_CACHE_DIR, else $XDG_CACHE_HOME/gvd/kernels,
  /// else $HOME/.cache/gvd/kernels. Keyed by source, build options and device; a directory
  /// that cannot be written only disables the cache.
  std::string cache_dir;
  /// Run every kernel once on a tiny input at creation, so that lazy compilation in the
  /// driver (PoCL compiles per work-group size at the first launch) happens at start-up.
  bool warm_up = true;
  /// Appended to the kernel build options (benchmarks use a -D nonce to force a cold build).
  std::string extra_build_options;
};

/// How the kernel programs were built (for logs and the benchmarks).
struct KernelBuildReport {
  double seconds = 0;       ///< program build (binary from the cache, or compile)
  bool from_cache = false;  ///< the program binary came from the cache
  double warm_up_seconds = 0;
  std::string cache_file;  ///< "" when no cache directory was usable
};

/// The OpenCL implementation of ComputeBackend. Thread-safe: launches are serialised on one
/// in-order queue. Create it once, at start-up, before any concurrent use (PoCL crashes when
/// several threads make the first OpenCL calls at once).
class OpenClBackend : public compute::ComputeBackend {
 public:
  ~OpenClBackend() override;
  std::string name() const override;
  std::unique_ptr<distance::ClosestPointSolver> closest_points(const scene::UnitGeometry& geometry,
                                                               const SimplexBvh& bvh) override;
  std::unique_ptr<octree::OctreeBuildSteps> octree_build_steps(
      const scene::UnitGeometry& geometry) override;
  std::unique_ptr<grid::GridEvaluator> grid_evaluator(const grid::GridGeometry& geometry,
                                                      const grid::GridSpec& spec,
                                                      grid::GridMetric metric) override;
  const KernelBuildReport& build_report() const;
  struct Impl;

 private:
  friend std::shared_ptr<OpenClBackend> make_opencl_backend(const OpenClOptions& options);
  OpenClBackend() = default;
  std::shared_ptr<Impl> impl_;
};

/// Creates the OpenCL backend: picks the device, builds (or loads) the programs, warms up.
/// No platform or device: gvd::Error{kInvalidArgument} saying so (never a silent fallback).
/// Device failures and kernel build errors: gvd::Error{kInternal} naming the OpenCL call, the
/// error and the compiler's build log.
std::shared_ptr<OpenClBackend> make_opencl_backend(const OpenClOptions& options = {});

/// True when an OpenCL device with fp64 exists; else false and `why` says what is missing.
bool opencl_available(std::string* why = nullptr);

/// The outcome of choosing a backend from `--backend`.
struct BackendChoice {
  std::string backend;  ///< "opencl" or "cpu" (PipelineOptions::backend)
  std::shared_ptr<compute::ComputeBackend> compute;  ///< null for the CPU twins
  std::string note;  ///< why the CPU runs although OpenCL was allowed ("" otherwise)
  std::string log;   ///< one line for the log: what runs and why
};

/// `requested`: "cpu" = the CPU twins; "opencl" = the OpenCL backend, or gvd::Error
/// {kInvalidArgument} when there is no platform/device (explicit requests never fall back);
/// "auto" = OpenCL when a device exists, else the CPU twins with `note` and `log` saying why.
/// Anything else is gvd::Error{kInvalidArgument}.
BackendChoice choose_backend(const std::string& requested, const OpenClOptions& options = {});

}  // namespace gvd::kernels
