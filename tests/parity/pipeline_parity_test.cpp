// End to end: compute_gvd with the OpenCL backend against the CPU twins on small 2D and 3D
// scenes (separated, nearly touching, intersecting, point-like objects). Octree leaves,
// vertex labels and the dual graph must be identical; closest points and GVD positions agree
// to 1e-12 of the domain (in practice bit for bit: one per-item source, no FP contraction).

#include <gtest/gtest.h>

#include <cmath>

#include "gvd/pipeline/pipeline.h"
#include "parity/opencl_env.h"
#include "support/scenes.h"

namespace gvd {

using namespace gvd::scene;
using namespace gvd::octree;
using namespace gvd::compute;
using namespace gvd::surface;
using namespace gvd::result;
using namespace gvd::pipeline;

namespace {

constexpr double kTolerance = 1e-12;  // unit domain

GvdResult run(const Scene& scene, std::shared_ptr<ComputeBackend> compute,
              const char* octree_build = "levels") {
  PipelineOptions o;
  o.octree_build = parse_choice<OctreeBuild>(octree_build);
  o.threads = 2;
  o.backend = compute ? BackendRequest::kOpenCl : BackendRequest::kCpu;
  o.compute = std::move(compute);
  return compute_gvd(scene, o);
}

void expect_same_result(const Scene& scene, kernels::OpenClBackend& backend_ref,
                        std::shared_ptr<kernels::OpenClBackend> backend,
                        const char* octree_build = "levels") {
  (void)backend_ref;
  const GvdResult cpu = run(scene, nullptr);
  const GvdResult ocl = run(scene, backend, octree_build);
  EXPECT_EQ(cpu.stats.backend, "cpu");
  EXPECT_EQ(ocl.stats.backend.rfind("opencl", 0), 0u) << ocl.stats.backend;
  // Octree.
  ASSERT_EQ(cpu.octree.code, ocl.octree.code);
  ASSERT_EQ(cpu.octree.level, ocl.octree.level);
  EXPECT_EQ(cpu.octree.object, ocl.octree.object);
  // Distance field: labels identical, closest points within the tolerance.
  ASSERT_EQ(cpu.field.vertices.key, ocl.field.vertices.key);
  EXPECT_EQ(cpu.field.label, ocl.field.label);
  EXPECT_EQ(cpu.field.exact, ocl.field.exact);
  size_t far = 0;
  for (uint32_t v = 0; v < cpu.field.size(); ++v) {
    const bool a = cpu.field.point[v] != kNoVertex, b = ocl.field.point[v] != kNoVertex;
    ASSERT_EQ(a, b) << "vertex " << v;
    if (!a) continue;
    far += dist(cpu.field.closest[cpu.field.point[v]], ocl.field.closest[ocl.field.point[v]]) >
           kTolerance;
  }
  EXPECT_EQ(far, 0u) << "closest points farther apart than " << kTolerance;
  // GVD and dual graph.
  ASSERT_EQ(cpu.gvd.cells.size(), ocl.gvd.cells.size());
  for (size_t c = 0; c < cpu.gvd.cells.size(); ++c) {
    const GvdCell& x = cpu.gvd.cells[c];
    const GvdCell& y = ocl.gvd.cells[c];
    EXPECT_EQ(x.object, y.object);
    EXPECT_EQ(x.indices, y.indices);
    EXPECT_EQ(x.other, y.other);
    ASSERT_EQ(x.positions.size(), y.positions.size());
    for (size_t i = 0; i < x.positions.size(); ++i)
      EXPECT_LE(dist(x.positions[i], y.positions[i]), kTolerance * cpu.domain.side);
  }
  ASSERT_EQ(cpu.graph.edges.size(), ocl.graph.edges.size());
  for (size_t e = 0; e < cpu.graph.edges.size(); ++e) {
    EXPECT_EQ(cpu.graph.edges[e].a, ocl.graph.edges[e].a);
    EXPECT_EQ(cpu.graph.edges[e].b, ocl.graph.edges[e].b);
    EXPECT_NEAR(cpu.graph.edges[e].area, ocl.graph.edges[e].area,
                1e-9 * (1 + cpu.graph.edges[e].area));
  }
}

TEST(PipelineParity, TwoDimensionalScenes) {
  GVD_REQUIRE_OPENCL(backend);
  using namespace test;
  // Separated and nearly touching.
  expect_same_result(make_scene(2, {make_circle("a", {0, 0, 0}, 1, 40),
                                    make_rect("b", {1.01, -0.5, 0}, {2, 0.5, 0}),
                                    make_segment("c", {-1, 1.2, 0}, {2, 1.2, 0})}),
                     *backend, backend);
  // Gears (many close teeth) and intersecting objects (refined to the contact depth).
  expect_same_result(make_scene(2, {make_gear2d("g1", {0, 0, 0}, 0.8, 1.0, 12, 0.0),
                                    make_gear2d("g2", {2.02, 0, 0}, 0.8, 1.0, 12, 0.26),
                                    make_rect("crossing", {-0.2, -0.2, 0}, {0.5, 1.5, 0})}),
                     *backend, backend);
}

TEST(PipelineParity, ThreeDimensionalScenes) {
  GVD_REQUIRE_OPENCL(backend);
  using namespace test;
  expect_same_result(make_scene(3, {make_sphere("s1", {0, 0, 0}, 1.0, 8, 16),
                                    make_sphere("s2", {2.05, 0, 0}, 1.0, 8, 16),
                                    make_box("plate", {-1.5, -1.5, -1.6}, {3.5, 1.5, -1.1})}),
                     *backend, backend);
  // Point-like objects and touching boxes (a shared face).
  expect_same_result(
      make_scene(3, {make_point3("p", {0.5, 0.5, 0.5}), make_box("b1", {0, 0, 0}, {1, 1, 0.3}),
                     make_box("b2", {0, 0, 0.3}, {1, 0.4, 0.45})}),
      *backend, backend);
}

// The whole pipeline with the first octree from the data-parallel build on the OpenCL kernels
// against the CPU twins with the level-synchronous build.
TEST(PipelineParity, DataParallelOctreeBuild) {
  GVD_REQUIRE_OPENCL(backend);
  using namespace test;
  expect_same_result(make_scene(2, {make_gear2d("g1", {0, 0, 0}, 0.8, 1.0, 12, 0.0),
                                    make_gear2d("g2", {2.02, 0, 0}, 0.8, 1.0, 12, 0.26)}),
                     *backend, backend, "data-parallel");
  expect_same_result(make_scene(3, {make_sphere("s1", {0, 0, 0}, 1.0, 8, 16),
                                    make_box("b", {1.03, -1, -1}, {2, 1, 1})}),
                     *backend, backend, "data-parallel");
}

}  // namespace
}  // namespace gvd
