#pragma once

// The state of one OpenCL backend, shared by its solvers and build steps (private to
// gvd_kernels).

#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "cl_runtime.h"
#include "gvd/kernels/opencl_backend.h"

namespace gvd::kernels {

struct OpenClBackend::Impl {
  cl::Runtime rt;
  cl::Program closest_program;
  cl::Kernel closest_kernel;
  cl::Program octree_program;
  std::map<std::string, cl::Kernel> octree_kernels;
  cl::Program grid_program;
  cl::Kernel grid_kernel;
  size_t local_size = 64;  // work-group size of the launches (<= the kernels' maximum)
  KernelBuildReport report;
  std::mutex mutex;  // one launch sequence at a time on the shared queue and kernel objects
};

inline size_t round_up(size_t n, size_t m) { return (n + m - 1) / m * m; }

/// The OpenCL implementation of the data-parallel octree build steps.
std::unique_ptr<octree::OctreeBuildSteps> make_opencl_octree_steps(
    std::shared_ptr<OpenClBackend::Impl> impl, const scene::UnitGeometry& geometry);

/// The OpenCL implementation of the uniform grid's per-range evaluation.
std::unique_ptr<grid::GridEvaluator> make_opencl_grid_evaluator(
    std::shared_ptr<OpenClBackend::Impl> impl, const grid::GridGeometry& geometry,
    const grid::GridSpec& spec, grid::GridMetric metric);

}  // namespace gvd::kernels
