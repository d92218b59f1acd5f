// OpenCL implementation of the data-parallel octree build steps (build_octree_data_parallel.h):
// every step is one kernel of kernels/cl/octree_build.cl; the two-pass steps launch it twice
// (count, then fill) around an exclusive prefix sum on the host.

#include <numeric>

#include "backend_impl.h"
#include "gvd/common/error.h"
#include "gvd/octree/build_octree_data_parallel.h"

namespace gvd::kernels {

using namespace gvd::scene;
using namespace gvd::octree;

namespace {

class OpenClOctreeBuildSteps final : public OctreeBuildSteps {
 public:
  OpenClOctreeBuildSteps(std::shared_ptr<OpenClBackend::Impl> impl, const UnitGeometry& g)
      : impl_(std::move(impl)), dim_(g.dimension) {
    const ItemGeometry items = item_geometry(g);
    point_count_ = items.points.size();
    simplex_count_ = g.simplices.size();
    points_ = upload(items.points);
    simplices_ = upload(items.simplices);
  }

  std::vector<uint64_t> vertex_keys(int max_level) override {
    std::vector<uint64_t> keys(point_count_);
    if (keys.empty()) return keys;
    std::lock_guard<std::mutex> lock(impl_->mutex);
    const cl::Buffer out = output(keys.size() * sizeof(uint64_t));
    const cl::Kernel& k = kernel("gvd_vertex_keys");
    cl::set_arg(k, 0, cl_int{dim_});
    cl::set_arg(k, 1, points_.get());
    cl::set_arg(k, 2, static_cast<cl_uint>(point_count_));
    cl::set_arg(k, 3, cl_int{dim_ * (lattice_bits(dim_) - max_level)});
    cl::set_arg(k, 4, out.get());
    launch(k, keys.size(), "gvd_vertex_keys");
    read(out, keys);
    return keys;
  }

  void radix_tree(std::span<const uint64_t> keys, int bits, std::vector<item::GvdRadixNode>& nodes,
                  std::vector<int32_t>& parent) override {
    const size_t n = keys.size();
    nodes.assign(n > 1 ? n - 1 : 0, {});
    parent.assign(nodes.size(), -1);
    if (nodes.empty()) return;
    std::lock_guard<std::mutex> lock(impl_->mutex);
    const cl::Buffer kb = input(keys.data(), n * sizeof(uint64_t));
    const cl::Buffer nb = output(nodes.size() * sizeof(item::GvdRadixNode));
    const cl::Buffer pb = output(parent.size() * sizeof(int32_t));
    const cl::Kernel& k = kernel("gvd_radix_nodes");
    cl::set_arg(k, 0, kb.get());
    cl::set_arg(k, 1, static_cast<cl_int>(n));
    cl::set_arg(k, 2, cl_int{bits});
    cl::set_arg(k, 3, nb.get());
    launch(k, nodes.size(), "gvd_radix_nodes");
    const cl::Kernel& p = kernel("gvd_radix_parents");
    cl::set_arg(p, 0, nb.get());
    cl::set_arg(p, 1, static_cast<cl_int>(nodes.size()));
    cl::set_arg(p, 2, pb.get());
    launch(p, nodes.size(), "gvd_radix_parents");
    read(nb, nodes);
    read(pb, parent);
  }

  void facet_cells(int max_level, std::vector<uint32_t>& begin, std::vector<uint64_t>& code,
                   std::vector<int32_t>& level) override {
    begin.assign(simplex_count_ + 1, 0);
    code.clear();
    level.clear();
    if (simplex_count_ == 0) return;
    std::lock_guard<std::mutex> lock(impl_->mutex);
    const cl::Kernel& k = kernel("gvd_facet_cell_lists");
    const cl_mem none = nullptr;
    const cl::Buffer counts = output(simplex_count_ * sizeof(uint32_t));
    cl::set_arg(k, 0, cl_int{dim_});
    cl::set_arg(k, 1, points_.get());
    cl::set_arg(k, 2, simplices_.get());
    cl::set_arg(k, 3, static_cast<cl_uint>(simplex_count_));
    cl::set_arg(k, 4, cl_double{item::gvd_slack(0)});
    cl::set_arg(k, 5, cl_int{max_level});
    cl::set_arg(k, 6, cl_int{0});
    cl::set_arg(k, 7, counts.get());
    cl::set_arg(k, 8, none);
    cl::set_arg(k, 9, none);
    cl::set_arg(k, 10, none);
    launch(k, simplex_count_, "gvd_facet_cell_lists");
    std::vector<uint32_t> c(simplex_count_);
    read(counts, c);
    for (size_t s = 0; s < simplex_count_; ++s) begin[s + 1] = begin[s] + c[s];
    code.resize(begin.back());
    level.resize(begin.back());
    const cl::Buffer bb = input(begin.data(), begin.size() * sizeof(uint32_t));
    const cl::Buffer cb = output(code.size() * sizeof(uint64_t));
    const cl::Buffer lb = output(level.size() * sizeof(int32_t));
    cl::set_arg(k, 6, cl_int{1});
    cl::set_arg(k, 7, none);
    cl::set_arg(k, 8, bb.get());
    cl::set_arg(k, 9, cb.get());
    cl::set_arg(k, 10, lb.get());
    launch(k, simplex_count_, "gvd_facet_cell_lists");
    read(cb, code);
    read(lb, level);
  }

  CsrU32 cell_facets(const SccArray& scc, std::span<const uint64_t> cell_code,
                     std::span<const uint8_t> cell_level) override {
    const size_t n = cell_code.size();
    if (n == 0 || scc.code.empty()) return empty_rows(n);
    std::lock_guard<std::mutex> lock(impl_->mutex);
    const cl::Buffer sc = input(scc.code.data(), scc.code.size() * sizeof(uint64_t));
    const cl::Buffer ss = input(scc.simplex.data(), scc.simplex.size() * sizeof(uint32_t));
    const cl::Buffer slo = input(scc.lo.data(), scc.lo.size() * sizeof(item::GvdPoint));
    const cl::Buffer shi = input(scc.hi.data(), scc.hi.size() * sizeof(item::GvdPoint));
    const cl::Buffer sl = input(scc.level_begin.data(), scc.level_begin.size() * sizeof(uint32_t));
    const cl::Buffer cc = input(cell_code.data(), n * sizeof(uint64_t));
    const cl::Buffer cl_ = input(cell_level.data(), n * sizeof(uint8_t));
    const cl::Kernel& k = kernel("gvd_cell_facets");
    cl::set_arg(k, 0, cl_int{dim_});
    cl::set_arg(k, 1, points_.get());
    cl::set_arg(k, 2, simplices_.get());
    cl::set_arg(k, 3, sc.get());
    cl::set_arg(k, 4, ss.get());
    cl::set_arg(k, 5, slo.get());
    cl::set_arg(k, 6, shi.get());
    cl::set_arg(k, 7, sl.get());
    cl::set_arg(k, 8, cc.get());
    cl::set_arg(k, 9, cl_.get());
    cl::set_arg(k, 10, static_cast<cl_uint>(n));
    return two_pass(k, n, 11, "gvd_cell_facets");
  }

  CsrU32 child_facets(const CsrU32& lists, std::span<const uint32_t> parent,
                      std::span<const uint64_t> child_code,
                      std::span<const uint8_t> child_level) override {
    const size_t n = child_code.size();
    if (n == 0 || lists.items.empty()) return empty_rows(n);
    std::lock_guard<std::mutex> lock(impl_->mutex);
    const cl::Buffer lb = input(lists.begin.data(), lists.begin.size() * sizeof(uint32_t));
    const cl::Buffer li = input(lists.items.data(), lists.items.size() * sizeof(uint32_t));
    const cl::Buffer pb = input(parent.data(), n * sizeof(uint32_t));
    const cl::Buffer cc = input(child_code.data(), n * sizeof(uint64_t));
    const cl::Buffer cl_ = input(child_level.data(), n * sizeof(uint8_t));
    const cl::Kernel& k = kernel("gvd_child_facets");
    cl::set_arg(k, 0, cl_int{dim_});
    cl::set_arg(k, 1, points_.get());
    cl::set_arg(k, 2, simplices_.get());
    cl::set_arg(k, 3, lb.get());
    cl::set_arg(k, 4, li.get());
    cl::set_arg(k, 5, pb.get());
    cl::set_arg(k, 6, cc.get());
    cl::set_arg(k, 7, cl_.get());
    cl::set_arg(k, 8, static_cast<cl_uint>(n));
    return two_pass(k, n, 9, "gvd_child_facets");
  }

 private:
  static CsrU32 empty_rows(size_t n) {
    CsrU32 r;
    r.begin.assign(n + 1, 0);
    return r;
  }

  const cl::Kernel& kernel(const char* name) const { return impl_->octree_kernels.at(name); }

  cl::Buffer input(const void* data, size_t bytes) const {
    return cl::make_buffer(impl_->rt, CL_MEM_READ_ONLY, bytes == 0 ? 1 : bytes,
                           bytes == 0 ? nullptr : data);
  }
  template <class T>
  cl::Buffer upload(const std::vector<T>& v) const {
    return input(v.data(), v.size() * sizeof(T));
  }
  cl::Buffer output(size_t bytes) const {
    return cl::make_buffer(impl_->rt, CL_MEM_READ_WRITE, bytes == 0 ? 1 : bytes, nullptr);
  }
  template <class T>
  void read(const cl::Buffer& b, std::vector<T>& v) const {
    if (v.empty()) return;
    cl::check(clEnqueueReadBuffer(impl_->rt.queue.get(), b.get(), CL_TRUE, 0, v.size() * sizeof(T),
                                  v.data(), 0, nullptr, nullptr),
              "clEnqueueReadBuffer");
  }
  void launch(const cl::Kernel& k, size_t n, const char* name) const {
    const size_t local = impl_->local_size;
    const size_t global = round_up(n, local);
    cl::check(clEnqueueNDRangeKernel(impl_->rt.queue.get(), k.get(), 1, nullptr, &global, &local, 0,
                                     nullptr, nullptr),
              "clEnqueueNDRangeKernel", std::string(" (") + name + ")");
  }

  // Arguments from `first`: fill flag, counts, out_begin, out. Count pass, exclusive prefix
  // sum on the host, fill pass.
  CsrU32 two_pass(const cl::Kernel& k, size_t n, cl_uint first, const char* name) const {
    CsrU32 r;
    r.begin.assign(n + 1, 0);
    const cl::Buffer counts = output(n * sizeof(uint32_t));
    const cl_mem none = nullptr;
    cl::set_arg(k, first, cl_int{0});
    cl::set_arg(k, first + 1, counts.get());
    cl::set_arg(k, first + 2, none);
    cl::set_arg(k, first + 3, none);
    launch(k, n, name);
    std::vector<uint32_t> c(n);
    read(counts, c);
    for (size_t i = 0; i < n; ++i) r.begin[i + 1] = r.begin[i] + c[i];
    r.items.resize(r.begin[n]);
    if (r.items.empty()) return r;
    const cl::Buffer begin = input(r.begin.data(), r.begin.size() * sizeof(uint32_t));
    const cl::Buffer out = output(r.items.size() * sizeof(uint32_t));
    cl::set_arg(k, first, cl_int{1});
    cl::set_arg(k, first + 1, none);
    cl::set_arg(k, first + 2, begin.get());
    cl::set_arg(k, first + 3, out.get());
    launch(k, n, name);
    read(out, r.items);
    return r;
  }

  std::shared_ptr<OpenClBackend::Impl> impl_;
  int dim_;
  size_t point_count_ = 0, simplex_count_ = 0;
  cl::Buffer points_, simplices_;
};

}  // namespace

std::unique_ptr<OctreeBuildSteps> make_opencl_octree_steps(
    std::shared_ptr<OpenClBackend::Impl> impl, const UnitGeometry& geometry) {
  return std::make_unique<OpenClOctreeBuildSteps>(std::move(impl), geometry);
}

}  // namespace gvd::kernels
