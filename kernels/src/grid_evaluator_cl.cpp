// The uniform grid's per-range evaluation on OpenCL: kernels/cl/grid_distance.cl, one work
// item per row of cells, the grid's best keys and sites kept on the device between batches.

#include <algorithm>
#include <chrono>
#include <limits>
#include <mutex>
#include <vector>

#include "backend_impl.h"
#include "cl_runtime.h"
#include "gvd/common/cancel.h"
#include "gvd/common/error.h"
#include "gvd/grid/grid_evaluator.h"

namespace gvd::kernels {

using namespace gvd::grid;

namespace {

class OpenClGridEvaluator final : public GridEvaluator {
 public:
  OpenClGridEvaluator(std::shared_ptr<OpenClBackend::Impl> impl, const GridGeometry& geometry,
                      const GridSpec& spec, GridMetric metric)
      : impl_(std::move(impl)), spec_(make_item_spec(spec, metric)), cells_(spec.cell_count()) {
    GVD_CHECK(!geometry.object_of.empty(), "grid evaluator: no sites");
    const cl::Runtime& rt = impl_->rt;
    points_ = cl::make_buffer(rt, CL_MEM_READ_ONLY, geometry.points.size() * sizeof(Vec3),
                              geometry.points.data());
    simplices_ = cl::make_buffer(rt, CL_MEM_READ_ONLY, geometry.simplices.size() * sizeof(uint32_t),
                                 geometry.simplices.data());
    spec_buffer_ = cl::make_buffer(rt, CL_MEM_READ_ONLY, sizeof spec_, &spec_);
    nodes_ = cl::make_buffer(rt, CL_MEM_READ_ONLY, geometry.nodes.size() * sizeof(item::GvdBvhNode),
                             geometry.nodes.data());
    order_ = cl::make_buffer(rt, CL_MEM_READ_ONLY, geometry.order.size() * sizeof(uint32_t),
                             geometry.order.data());
    roots_ = cl::make_buffer(rt, CL_MEM_READ_ONLY, geometry.roots.size() * sizeof(uint32_t),
                             geometry.roots.data());
    const std::vector<double> key(cells_, std::numeric_limits<double>::infinity());
    const std::vector<uint32_t> site(cells_, GVD_NO_SIMPLEX);
    best_key_ = cl::make_buffer(rt, CL_MEM_READ_WRITE, cells_ * sizeof(double), key.data());
    best_site_ = cl::make_buffer(rt, CL_MEM_READ_WRITE, cells_ * sizeof(uint32_t), site.data());
  }

  void evaluate(std::span<const item::GvdGridJob> jobs, std::span<const uint32_t> sites,
                uint32_t items, std::span<int32_t> visible) override {
    GVD_CHECK(visible.size() == sites.size(), "grid evaluator: one flag per site entry");
    if (jobs.empty() || items == 0 || sites.empty()) return;
    const cl::Runtime& rt = impl_->rt;
    std::lock_guard<std::mutex> lock(impl_->mutex);
    // Only lists longer than the private key array (GVD_GRID_LOCAL) touch dist.
    uint64_t pairs = 1;
    for (const item::GvdGridJob& j : jobs) {
      if (j.site_count > GVD_GRID_LOCAL) {
        pairs = std::max<uint64_t>(
            pairs, j.dist_first + uint64_t{j.site_count} * j.size[0] * j.size[1] * j.size[2]);
      }
    }
    grow(dist_, dist_bytes_, pairs * sizeof(double), CL_MEM_READ_WRITE);
    grow(jobs_, jobs_bytes_, jobs.size_bytes(), CL_MEM_READ_ONLY);
    grow(sites_, sites_bytes_, sites.size_bytes(), CL_MEM_READ_ONLY);
    grow(visible_, visible_bytes_, visible.size_bytes(), CL_MEM_READ_WRITE);
    cl_command_queue q = rt.queue.get();
    cl::check(clEnqueueWriteBuffer(q, jobs_.get(), CL_FALSE, 0, jobs.size_bytes(), jobs.data(), 0,
                                   nullptr, nullptr),
              "clEnqueueWriteBuffer", " (grid jobs)");
    cl::check(clEnqueueWriteBuffer(q, sites_.get(), CL_FALSE, 0, sites.size_bytes(), sites.data(),
                                   0, nullptr, nullptr),
              "clEnqueueWriteBuffer", " (grid sites)");
    cl::check(clEnqueueWriteBuffer(q, visible_.get(), CL_FALSE, 0, visible.size_bytes(),
                                   visible.data(), 0, nullptr, nullptr),
              "clEnqueueWriteBuffer", " (grid visibility flags)");
    const cl::Kernel& k = impl_->grid_kernel;
    const cl_uint job_count = static_cast<cl_uint>(jobs.size());
    const cl_uint item_count = items;
    cl_uint a = 0;
    cl::set_arg(k, a++, spec_buffer_.get());
    cl::set_arg(k, a++, nodes_.get());
    cl::set_arg(k, a++, order_.get());
    cl::set_arg(k, a++, roots_.get());
    cl::set_arg(k, a++, points_.get());
    cl::set_arg(k, a++, simplices_.get());
    cl::set_arg(k, a++, jobs_.get());
    cl::set_arg(k, a++, job_count);
    cl::set_arg(k, a++, sites_.get());
    cl::set_arg(k, a++, item_count);
    cl::set_arg(k, a++, best_key_.get());
    cl::set_arg(k, a++, best_site_.get());
    cl::set_arg(k, a++, dist_.get());
    cl::set_arg(k, a++, visible_.get());
    const size_t local = std::min<size_t>(impl_->local_size, 16);
    if (cancel_ == nullptr) {
      const size_t global = round_up(items, local);
      cl::check(
          clEnqueueNDRangeKernel(q, k.get(), 1, nullptr, &global, &local, 0, nullptr, nullptr),
          "clEnqueueNDRangeKernel", " (gvd_grid_distance)");
    } else {
      launch_in_slices(q, k, items, local);
    }
    cl::check(clEnqueueReadBuffer(q, visible_.get(), CL_TRUE, 0, visible.size_bytes(),
                                  visible.data(), 0, nullptr, nullptr),
              "clEnqueueReadBuffer", " (grid visibility flags)");
  }

  /// The launch as slices of work items (global offsets; each item is one row of cells and
  /// writes only its own cells and flags, so slices are independent), the cancel flag read
  /// between them. A slice's size follows the last one's time towards ~0.1 s, so that a set
  /// flag is seen within about that, while slices stay large enough to fill the device.
  void launch_in_slices(cl_command_queue q, const cl::Kernel& k, uint32_t items, size_t local) {
    using Clock = std::chrono::steady_clock;
    size_t slice = round_up(std::min<size_t>(items, 64), local);
    for (size_t first = 0; first < items;) {
      throw_if_cancelled(cancel_, "the grid's evaluation");
      const size_t global = round_up(std::min<size_t>(slice, items - first), local);
      const Clock::time_point start = Clock::now();
      cl::check(clEnqueueNDRangeKernel(q, k.get(), 1, &first, &global, &local, 0, nullptr, nullptr),
                "clEnqueueNDRangeKernel", " (gvd_grid_distance)");
      cl::check(clFinish(q), "clFinish", " (gvd_grid_distance)");
      first += global;
      const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
      if (seconds < 0.05) slice *= 2;
      if (seconds > 0.2 && slice > local) slice = round_up(slice / 2, local);
    }
  }

  void read_best(std::span<double> key, std::span<uint32_t> site) override {
    GVD_CHECK(key.size() == cells_ && site.size() == cells_,
              "grid evaluator: read_best wants one entry per cell");
    std::lock_guard<std::mutex> lock(impl_->mutex);
    cl_command_queue q = impl_->rt.queue.get();
    cl::check(clEnqueueReadBuffer(q, best_key_.get(), CL_TRUE, 0, key.size_bytes(), key.data(), 0,
                                  nullptr, nullptr),
              "clEnqueueReadBuffer", " (grid best keys)");
    cl::check(clEnqueueReadBuffer(q, best_site_.get(), CL_TRUE, 0, site.size_bytes(), site.data(),
                                  0, nullptr, nullptr),
              "clEnqueueReadBuffer", " (grid best sites)");
  }

 private:
  /// A device buffer of at least `bytes` (grown by doubling; its contents are not kept).
  void grow(cl::Buffer& buffer, size_t& have, size_t bytes, cl_mem_flags flags) {
    if (have >= bytes && buffer) return;
    have = std::max(bytes, 2 * have);
    buffer = cl::make_buffer(impl_->rt, flags, have, nullptr);
  }

  std::shared_ptr<OpenClBackend::Impl> impl_;
  item::GvdGridSpec spec_;
  size_t cells_;
  cl::Buffer points_, simplices_, spec_buffer_, nodes_, order_, roots_, best_key_, best_site_;
  cl::Buffer dist_, jobs_, sites_, visible_;
  size_t dist_bytes_ = 0, jobs_bytes_ = 0, sites_bytes_ = 0, visible_bytes_ = 0;
};

}  // namespace

std::unique_ptr<GridEvaluator> make_opencl_grid_evaluator(std::shared_ptr<OpenClBackend::Impl> impl,
                                                          const GridGeometry& geometry,
                                                          const GridSpec& spec, GridMetric metric) {
  return std::make_unique<OpenClGridEvaluator>(std::move(impl), geometry, spec, metric);
}

}  // namespace gvd::kernels
