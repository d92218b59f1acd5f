#include "gvd/kernels/opencl_backend.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <mutex>

#include "backend_impl.h"
#include "cl_runtime.h"
#include "gvd/common/error.h"
#include "gvd/common/stopwatch.h"
#include "gvd/distance/closest_points.h"
#include "gvd/grid/compute_grid.h"
#include "gvd/grid/grid_evaluator.h"
#include "gvd/kernels/embedded_sources.h"
#include "gvd/octree/build_octree.h"
#include "gvd/octree/build_octree_data_parallel.h"

namespace gvd::kernels {

using namespace gvd::scene;
using namespace gvd::octree;
using namespace gvd::distance;
using namespace gvd::compute;
using namespace gvd::grid;

namespace {

// OpenCL C 1.2 (PoCL 3.1 offers no more); never relaxed math: the kernels must round
// exactly like their CPU twins.
constexpr const char* kBuildOptions = "-cl-std=CL1.2";

}  // namespace

namespace {

class OpenClClosestPointSolver final : public ClosestPointSolver {
 public:
  // Uploads the BVH's own arrays as they are: SimplexBvh stores them in the layout the kernel
  // reads (closest_point_item.h).
  OpenClClosestPointSolver(std::shared_ptr<OpenClBackend::Impl> impl, const SimplexBvh& bvh)
      : impl_(std::move(impl)) {
    dimension_ = bvh.dimension();
    node_count_ = static_cast<cl_uint>(bvh.nodes().size());
    if (node_count_ == 0) return;  // no simplices: every query misses, nothing to upload
    const cl::Runtime& rt = impl_->rt;
    nodes_ = cl::make_buffer(rt, CL_MEM_READ_ONLY, bvh.nodes().size_bytes(), bvh.nodes().data());
    order_ = cl::make_buffer(rt, CL_MEM_READ_ONLY, bvh.order().size_bytes(), bvh.order().data());
    points_ = cl::make_buffer(rt, CL_MEM_READ_ONLY, bvh.points().size_bytes(), bvh.points().data());
    corner_ = cl::make_buffer(rt, CL_MEM_READ_ONLY, bvh.corner().size_bytes(), bvh.corner().data());
  }

  void solve(std::span<const Vec3> queries, std::span<const double> bound2,
             std::span<ClosestHit> hits) override {
    GVD_CHECK(queries.size() == bound2.size() && queries.size() == hits.size(),
              "closest_points: queries, bounds and hits must have the same length");
    const size_t n = queries.size();
    if (n == 0) return;
    if (node_count_ == 0) {
      for (ClosestHit& h : hits) h = ClosestHit{};
      return;
    }
    GVD_CHECK(n < 0xFFFFFFFFu, "closest_points: too many queries for one launch");
    static_assert(sizeof(Vec3) == sizeof(item::GvdPoint));
    const cl::Runtime& rt = impl_->rt;
    std::lock_guard<std::mutex> lock(impl_->mutex);
    const cl::Buffer q = cl::make_buffer(rt, CL_MEM_READ_ONLY, n * sizeof(Vec3), queries.data());
    const cl::Buffer b = cl::make_buffer(rt, CL_MEM_READ_ONLY, n * sizeof(double), bound2.data());
    const cl::Buffer h = cl::make_buffer(rt, CL_MEM_WRITE_ONLY, n * sizeof(item::GvdHit), nullptr);
    const cl::Kernel& k = impl_->closest_kernel;
    const cl_int dim = dimension_;
    const cl_uint count = static_cast<cl_uint>(n);
    cl::set_arg(k, 0, dim);
    cl::set_arg(k, 1, node_count_);
    cl::set_arg(k, 2, nodes_.get());
    cl::set_arg(k, 3, order_.get());
    cl::set_arg(k, 4, points_.get());
    cl::set_arg(k, 5, corner_.get());
    cl::set_arg(k, 6, q.get());
    cl::set_arg(k, 7, b.get());
    cl::set_arg(k, 8, count);
    cl::set_arg(k, 9, h.get());
    const size_t local = impl_->local_size;
    const size_t global = round_up(n, local);
    cl::check(clEnqueueNDRangeKernel(rt.queue.get(), k.get(), 1, nullptr, &global, &local, 0,
                                     nullptr, nullptr),
              "clEnqueueNDRangeKernel", " (gvd_closest_points)");
    std::vector<item::GvdHit> out(n);
    cl::check(clEnqueueReadBuffer(rt.queue.get(), h.get(), CL_TRUE, 0, n * sizeof(item::GvdHit),
                                  out.data(), 0, nullptr, nullptr),
              "clEnqueueReadBuffer", " (closest-point hits)");
    for (size_t i = 0; i < n; ++i) hits[i] = to_closest_hit(out[i]);
  }

 private:
  std::shared_ptr<OpenClBackend::Impl> impl_;
  int dimension_ = 3;
  cl_uint node_count_ = 0;
  cl::Buffer nodes_, order_, points_, corner_;
};

// One triangle and a few queries: enough to make the driver finish compiling the kernel.
void warm_up(OpenClBackend& backend) {
  UnitGeometry g;
  g.dimension = 3;
  g.points = {{0.1, 0.1, 0.1}, {0.9, 0.1, 0.1}, {0.1, 0.9, 0.2}};
  g.simplices = {Simplex{{0, 1, 2}}};
  g.object_of = {0};
  g.object_count = 1;
  const SimplexBvh bvh(g.dimension, g.points, g.simplices);
  const auto solver = backend.closest_points(g, bvh);
  std::vector<Vec3> q(64, Vec3{0.5, 0.5, 0.5});
  std::vector<double> bound(q.size(), 1e300);
  std::vector<ClosestHit> hits(q.size());
  solver->solve(q, bound, hits);
  GVD_CHECK(hits[0].found(), "OpenCL warm-up: the closest-point kernel found nothing");
  // The octree kernels: a two-object scene needs every step (radix tree, conflicts).
  g.points.push_back({0.1, 0.1, 0.25});
  g.points.push_back({0.9, 0.1, 0.25});
  g.points.push_back({0.1, 0.9, 0.3});
  g.simplices.push_back(Simplex{{3, 4, 5}});
  g.object_of.push_back(1);
  g.object_count = 2;
  OctreeOptions o;
  o.max_depth = 6;
  o.threads = 1;
  const auto steps = backend.octree_build_steps(g);
  const Octree t = build_octree_data_parallel(g, o, steps.get());
  GVD_CHECK(t.leaf_count() > 1, "OpenCL warm-up: the octree kernels split nothing");
  // The grid kernel: a 2D grid of two segments.
  Scene scene;
  scene.dimension = 2;
  scene.objects.resize(2);
  scene.objects[0] = {
      "a",
      {{0.1, 0.1, 0}, {0.4, 0.2, 0}},
      {Simplex{{0, 1, 0}}},
  };
  scene.objects[1] = {
      "b",
      {{0.6, 0.8, 0}, {0.9, 0.7, 0}},
      {Simplex{{0, 1, 0}}},
  };
  GridOptions go;
  go.resolution = 16;
  go.compute = std::shared_ptr<ComputeBackend>(&backend, [](ComputeBackend*) {});
  const DistanceGrid grid = compute_grid(scene, go);
  GVD_CHECK(grid.label.front() == 0 && grid.label.back() == 1,
            "OpenCL warm-up: the grid kernel labelled the cells wrongly");
}

}  // namespace

OpenClBackend::~OpenClBackend() = default;

std::string OpenClBackend::name() const { return "opencl (" + impl_->rt.device.label() + ")"; }

const KernelBuildReport& OpenClBackend::build_report() const { return impl_->report; }

std::unique_ptr<OctreeBuildSteps> OpenClBackend::octree_build_steps(const UnitGeometry& geometry) {
  return make_opencl_octree_steps(impl_, geometry);
}

std::unique_ptr<GridEvaluator> OpenClBackend::grid_evaluator(const GridGeometry& geometry,
                                                             const GridSpec& spec,
                                                             GridMetric metric) {
  return make_opencl_grid_evaluator(impl_, geometry, spec, metric);
}

std::unique_ptr<ClosestPointSolver> OpenClBackend::closest_points(const UnitGeometry&,
                                                                  const SimplexBvh& bvh) {
  return std::make_unique<OpenClClosestPointSolver>(impl_, bvh);
}

std::shared_ptr<OpenClBackend> make_opencl_backend(const OpenClOptions& options) {
  std::string why;
  const std::vector<cl::DeviceInfo> devices = cl::list_devices(&why);
  if (devices.empty()) throw Error(ErrorCode::kInvalidArgument, "OpenCL unavailable: " + why);
  std::string selector = options.device;
  if (selector.empty()) {
    if (const char* e = std::getenv("GVD_OPENCL_DEVICE"); e != nullptr) selector = e;
  }
  auto impl = std::make_shared<OpenClBackend::Impl>();
  impl->rt = cl::make_runtime(cl::choose_device(devices, selector));
  cl::BuildInfo info;
  impl->closest_program =
      cl::build_program(impl->rt, embedded::k_closest_points,
                        options.extra_build_options.empty()
                            ? std::string(kBuildOptions)
                            : std::string(kBuildOptions) + " " + options.extra_build_options,
                        cl::resolve_cache_dir(options.cache_dir), &info);
  cl::BuildInfo octree_info;
  impl->octree_program =
      cl::build_program(impl->rt, embedded::k_octree_build,
                        options.extra_build_options.empty()
                            ? std::string(kBuildOptions)
                            : std::string(kBuildOptions) + " " + options.extra_build_options,
                        cl::resolve_cache_dir(options.cache_dir), &octree_info);
  cl::BuildInfo grid_info;
  impl->grid_program =
      cl::build_program(impl->rt, embedded::k_grid,
                        options.extra_build_options.empty()
                            ? std::string(kBuildOptions)
                            : std::string(kBuildOptions) + " " + options.extra_build_options,
                        cl::resolve_cache_dir(options.cache_dir), &grid_info);
  impl->report.seconds = info.seconds + octree_info.seconds + grid_info.seconds;
  impl->report.from_cache = info.from_cache && octree_info.from_cache && grid_info.from_cache;
  impl->report.cache_file = info.cache_file;
  impl->closest_kernel = cl::make_kernel(impl->closest_program, "gvd_closest_points");
  impl->grid_kernel = cl::make_kernel(impl->grid_program, "gvd_grid_distance");
  for (const char* name : {"gvd_vertex_keys", "gvd_radix_nodes", "gvd_radix_parents",
                           "gvd_facet_cell_lists", "gvd_cell_facets", "gvd_child_facets"})
    impl->octree_kernels.emplace(name, cl::make_kernel(impl->octree_program, name));
  size_t max_wg = 0;
  cl::check(clGetKernelWorkGroupInfo(impl->closest_kernel.get(), impl->rt.device.device,
                                     CL_KERNEL_WORK_GROUP_SIZE, sizeof max_wg, &max_wg, nullptr),
            "clGetKernelWorkGroupInfo");
  impl->local_size = std::min<size_t>(64, std::max<size_t>(1, max_wg));
  std::shared_ptr<OpenClBackend> backend(new OpenClBackend());
  backend->impl_ = std::move(impl);
  if (options.warm_up) {
    const Stopwatch sw;
    warm_up(*backend);
    backend->impl_->report.warm_up_seconds = sw.seconds();
  }
  return backend;
}

bool opencl_available(std::string* why) {
  std::string reason;
  const std::vector<cl::DeviceInfo> devices = cl::list_devices(&reason);
  bool fp64 = false;
  for (const cl::DeviceInfo& d : devices) fp64 |= d.fp64;
  if (!devices.empty() && !fp64) reason = "no OpenCL device supports double precision";
  if (why) *why = reason;
  return fp64;
}

BackendChoice choose_backend(const std::string& requested, const OpenClOptions& options) {
  BackendChoice c;
  if (requested == "cpu") {
    c.backend = "cpu";
    c.log = "backend cpu (CPU twins, as requested)";
    return c;
  }
  if (requested != "opencl" && requested != "auto") {
    throw Error(ErrorCode::kInvalidArgument,
                "unknown backend '" + requested + "' (expected opencl, cpu or auto)");
  }
  std::string why;
  if (requested == "auto" && !opencl_available(&why)) {
    c.backend = "cpu";
    c.note = why + "; ran the CPU twins";
    c.log = "backend cpu: " + c.note;
    return c;
  }
  try {
    std::shared_ptr<OpenClBackend> backend = make_opencl_backend(options);
    const KernelBuildReport& r = backend->build_report();
    c.backend = "opencl";
    char detail[160];
    std::snprintf(detail, sizeof detail, "kernels %s in %.0f ms, warm-up %.0f ms",
                  r.from_cache ? "loaded from cache" : "compiled", 1e3 * r.seconds,
                  1e3 * r.warm_up_seconds);
    c.log = "backend " + backend->name() + ", " + detail;
    c.compute = std::move(backend);
  } catch (const Error& e) {
    if (requested == "opencl") {
      if (e.code() != ErrorCode::kInvalidArgument) throw;
      throw Error(ErrorCode::kInvalidArgument,
                  "backend opencl requested, but " + e.detail() +
                      " (an explicit --backend opencl never falls back; use auto or cpu)");
    }
    c.backend = "cpu";
    c.note = std::string("OpenCL failed: ") + e.what() + "; ran the CPU twins";
    c.log = "backend cpu: " + c.note;
  }
  return c;
}

}  // namespace gvd::kernels
