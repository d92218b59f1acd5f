// Parity of the closest-point initialisation kernel (kernels/cl/closest_points.cl) with its
// CPU twin (closest_points_cpu), the scalar loop and SimplexBvh::nearest, on random and
// adversarial input: ties, degenerate simplices, queries on the simplices, the deepest
// lattice level, bounds that exclude everything, empty geometry, odd batch sizes.
// Tolerance: none. The kernel shares its per-item source with the twin and is built without
// FP contraction, so every hit must agree bit for bit (simplex, point and squared distance).

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>

#include "gvd/common/error.h"
#include "gvd/distance/closest_points.h"
#include "parity/opencl_env.h"

namespace gvd {

using namespace gvd::scene;
using namespace gvd::distance;

namespace {

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

bool same_hit(const ClosestHit& a, const ClosestHit& b) {
  if (a.simplex != b.simplex) return false;
  if (!a.found()) return true;
  return same_bits(a.point.x, b.point.x) && same_bits(a.point.y, b.point.y) &&
         same_bits(a.point.z, b.point.z) && same_bits(a.dist2, b.dist2);
}

std::string describe(const ClosestHit& h) {
  char s[160];
  std::snprintf(s, sizeof s, "simplex %u point (%.17g, %.17g, %.17g) d2 %.17g", h.simplex,
                h.point.x, h.point.y, h.point.z, h.dist2);
  return s;
}

struct Batch {
  std::vector<Vec3> queries;
  std::vector<double> bound2;
  void add(Vec3 q, double b = 1e300) {
    queries.push_back(q);
    bound2.push_back(b);
  }
};

// Runs the four implementations and expects identical answers; returns the kernel's hits.
std::vector<ClosestHit> expect_parity(kernels::OpenClBackend& backend, const UnitGeometry& g,
                                      const Batch& batch) {
  const SimplexBvh bvh(g.dimension, g.points, g.simplices);
  const ClosestPointData data = make_closest_point_data(bvh);
  const size_t n = batch.queries.size();
  std::vector<ClosestHit> twin(n), scalar(n), kernel(n), coherent(n);
  closest_points_cpu(data, batch.queries, batch.bound2, twin, 2);
  closest_points_cpu_coherent(data, batch.queries, batch.bound2, coherent, 2);
  size_t bad_coherent = 0;
  for (size_t i = 0; i < n; ++i) bad_coherent += !same_hit(twin[i], coherent[i]);
  EXPECT_EQ(bad_coherent, 0u) << "closest_points_cpu_coherent differs from the twin";
  closest_points_scalar(data, batch.queries, batch.bound2, scalar);
  backend.closest_points(g, bvh)->solve(batch.queries, batch.bound2, kernel);
  size_t bad_kernel = 0, bad_twin = 0, bad_scalar = 0;
  for (size_t i = 0; i < n; ++i) {
    const ClosestHit ref = bvh.nearest(batch.queries[i], batch.bound2[i]);
    if (!same_hit(ref, twin[i]) && bad_twin++ == 0)
      ADD_FAILURE() << "twin differs from SimplexBvh::nearest at query " << i << ": "
                    << describe(twin[i]) << " vs " << describe(ref);
    if (!same_hit(ref, scalar[i])) ++bad_scalar;
    if (!same_hit(twin[i], kernel[i]) && bad_kernel++ == 0)
      ADD_FAILURE() << "kernel differs from the CPU twin at query " << i << ": "
                    << describe(kernel[i]) << " vs " << describe(twin[i]);
  }
  EXPECT_EQ(bad_kernel, 0u) << "of " << n << " queries";
  EXPECT_EQ(bad_twin, 0u) << "of " << n << " queries";
  EXPECT_EQ(bad_scalar, 0u) << "of " << n << " queries";
  return kernel;
}

// `objects` x `per_object` small random simplices in [0.1, 0.9]^D (2D: segments, z = 0).
UnitGeometry random_geometry(int dim, int objects, int per_object, double size, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> pos(0.1, 0.9), off(-size, size);
  UnitGeometry g;
  g.dimension = dim;
  g.object_count = static_cast<uint32_t>(objects);
  for (int o = 0; o < objects; ++o) {
    const Vec3 c{pos(rng), pos(rng), dim == 3 ? pos(rng) : 0.0};
    for (int k = 0; k < per_object; ++k) {
      const Vec3 base = c + Vec3{off(rng), off(rng), dim == 3 ? off(rng) : 0.0};
      Simplex s;
      for (int v = 0; v < dim; ++v) {
        s.v[v] = static_cast<uint32_t>(g.points.size());
        g.points.push_back(base + Vec3{off(rng), off(rng), dim == 3 ? off(rng) : 0.0} * 0.3);
      }
      g.simplices.push_back(s);
      g.object_of.push_back(static_cast<ObjectId>(o));
    }
  }
  return g;
}

Batch random_queries(int dim, size_t n, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Batch b;
  for (size_t i = 0; i < n; ++i) b.add({u(rng), u(rng), dim == 3 ? u(rng) : 0.0});
  return b;
}

class ClosestPointParity : public ::testing::TestWithParam<int> {};

TEST_P(ClosestPointParity, RandomSimplicesAndQueries) {
  GVD_REQUIRE_OPENCL(backend);
  const int dim = GetParam();
  for (uint64_t seed : {1u, 2u, 3u}) {
    const UnitGeometry g = random_geometry(dim, 12, 60, 0.05, seed);
    Batch b = random_queries(dim, 20000 + seed, seed * 77);
    expect_parity(*backend, g, b);
  }
}

TEST_P(ClosestPointParity, TightBoundsExcludeOrJustAdmitTheClosestSimplex) {
  GVD_REQUIRE_OPENCL(backend);
  const int dim = GetParam();
  const UnitGeometry g = random_geometry(dim, 5, 40, 0.08, 9);
  const SimplexBvh bvh(g.dimension, g.points, g.simplices);
  const Batch free_batch = random_queries(dim, 3000, 5);
  Batch b;
  for (const Vec3& q : free_batch.queries) {
    const double d2 = bvh.nearest(q).dist2;
    b.add(q, d2);               // exactly the distance: admitted (ties to the bound)
    b.add(q, d2 * (1 - 1e-9));  // just below: nothing found
    b.add(q, std::nextafter(d2, 0.0));
    b.add(q, 0.0);
  }
  const std::vector<ClosestHit> hits = expect_parity(*backend, g, b);
  size_t misses = 0;
  for (const ClosestHit& h : hits) misses += !h.found();
  EXPECT_GT(misses, b.queries.size() / 2) << "bounds below the distance must find nothing";
}

// Two objects mirrored about the plane z = 1/2 (2D: the line y = 1/2): queries on it are at
// exactly the same distance from both, and the lower simplex index must win on both sides.
TEST_P(ClosestPointParity, ExactTiesGoToTheLowerSimplex) {
  GVD_REQUIRE_OPENCL(backend);
  const int dim = GetParam();
  UnitGeometry g;
  g.dimension = dim;
  g.object_count = 2;
  const int axis = dim == 3 ? 2 : 1;
  for (int o = 0; o < 2; ++o) {
    const double h = o == 0 ? 0.25 : 0.75;
    for (int k = 0; k < 8; ++k) {  // a fan of simplices sharing a vertex: ties inside objects too
      const double x0 = 0.125 + 0.0625 * k, x1 = x0 + 0.0625;
      Simplex s;
      Vec3 a{x0, 0.25, 0.25}, b{x1, 0.25, 0.25}, c{x0, 0.75, 0.25};
      a[axis] = b[axis] = c[axis] = h;
      if (dim == 2) a.z = b.z = c.z = 0;
      const uint32_t base = static_cast<uint32_t>(g.points.size());
      g.points.push_back(a);
      g.points.push_back(b);
      if (dim == 3) g.points.push_back(c);
      s.v[0] = base;
      s.v[1] = base + 1;
      s.v[2] = dim == 3 ? base + 2 : 0;
      g.simplices.push_back(s);
      g.object_of.push_back(static_cast<ObjectId>(o));
    }
  }
  Batch b;
  for (int i = 0; i <= 64; ++i)
    for (int j = 0; j <= (dim == 3 ? 64 : 0); ++j) {
      Vec3 q{i / 64.0, j / 64.0, 0.0};
      q[axis] = 0.5;
      if (dim == 3)
        q.y = j / 64.0;
      else
        q.z = 0;
      b.add(q);
    }
  const std::vector<ClosestHit> hits = expect_parity(*backend, g, b);
  for (const ClosestHit& h : hits) EXPECT_EQ(g.object_of[h.simplex], 0u) << "tie not to object 0";
}

// Degenerate simplices (collinear and single-point triangles, zero-length segments) and
// queries exactly on vertices, edges and inside simplices (distance 0).
TEST_P(ClosestPointParity, DegenerateSimplicesAndQueriesOnThem) {
  GVD_REQUIRE_OPENCL(backend);
  const int dim = GetParam();
  UnitGeometry g = random_geometry(dim, 3, 30, 0.1, 21);
  auto add = [&](Vec3 a, Vec3 b, Vec3 c) {
    Simplex s;
    for (int v = 0; v < dim; ++v) {
      s.v[v] = static_cast<uint32_t>(g.points.size());
      g.points.push_back(v == 0 ? a : v == 1 ? b : c);
    }
    g.simplices.push_back(s);
    g.object_of.push_back(1);
  };
  const double z = dim == 3 ? 0.5 : 0.0;
  add({0.3, 0.3, z}, {0.5, 0.5, z}, {0.4, 0.4, z});  // collinear
  add({0.6, 0.2, z}, {0.6, 0.2, z}, {0.6, 0.2, z});  // a point
  add({0.2, 0.7, z}, {0.2, 0.7, z}, {0.3, 0.7, z});  // two equal vertices
  Batch b = random_queries(dim, 4000, 8);
  for (const Simplex& s : g.simplices) {
    const Vec3 a = g.points[s.v[0]], c = g.points[s.v[1]];
    b.add(a);
    b.add((a + c) * 0.5);
    if (dim == 3) b.add((a + c + g.points[s.v[2]]) / 3.0);
  }
  expect_parity(*backend, g, b);
}

// Queries on the finest lattice (2^-21 in 3D, 2^-26 in 2D) right next to simplices whose
// vertices are lattice points too: distances of a few finest cells.
TEST_P(ClosestPointParity, DeepestLevelLatticeQueries) {
  GVD_REQUIRE_OPENCL(backend);
  const int dim = GetParam();
  const double h = std::ldexp(1.0, dim == 3 ? -21 : -26);
  UnitGeometry g;
  g.dimension = dim;
  g.object_count = 2;
  for (int o = 0; o < 2; ++o) {
    const double off = (o == 0 ? -3 : 4) * h;
    Simplex s;
    for (int v = 0; v < dim; ++v) s.v[v] = static_cast<uint32_t>(g.points.size() + v);
    if (dim == 3) {
      g.points.push_back({0.5 - 40 * h, 0.5 - 40 * h, 0.5 + off});
      g.points.push_back({0.5 + 40 * h, 0.5 - 40 * h, 0.5 + off});
      g.points.push_back({0.5, 0.5 + 40 * h, 0.5 + off});
    } else {
      g.points.push_back({0.5 - 40 * h, 0.5 + off, 0});
      g.points.push_back({0.5 + 40 * h, 0.5 + off, 0});
    }
    g.simplices.push_back(s);
    g.object_of.push_back(static_cast<ObjectId>(o));
  }
  Batch b;
  for (int i = -48; i <= 48; i += 3)
    for (int j = -8; j <= 8; ++j)
      for (int k = (dim == 3 ? -8 : 0); k <= (dim == 3 ? 8 : 0); k += 2)
        b.add({0.5 + i * h, 0.5 + j * h, dim == 3 ? 0.5 + k * h : 0.0});
  expect_parity(*backend, g, b);
}

// Batch sizes around the work-group size, and a scene without simplices.
TEST_P(ClosestPointParity, OddBatchSizesAndEmptyGeometry) {
  GVD_REQUIRE_OPENCL(backend);
  const int dim = GetParam();
  const UnitGeometry g = random_geometry(dim, 2, 10, 0.1, 4);
  for (size_t n : {1u, 2u, 63u, 64u, 65u, 127u, 1000u})
    expect_parity(*backend, g, random_queries(dim, n, n));
  UnitGeometry empty;
  empty.dimension = dim;
  const std::vector<ClosestHit> hits = expect_parity(*backend, empty, random_queries(dim, 10, 1));
  for (const ClosestHit& h : hits) EXPECT_FALSE(h.found());
  expect_parity(*backend, g, Batch{});
}

INSTANTIATE_TEST_SUITE_P(Dim, ClosestPointParity, ::testing::Values(2, 3),
                         [](const auto& p) { return std::to_string(p.param) + "D"; });

// Without a platform the backend cannot be created and says why; the twin still works.
TEST(OpenClAvailability, ExplicitRequestWithoutPlatformIsAnErrorAndAutoFallsBack) {
  std::string why;
  if (kernels::opencl_available(&why)) {
    const kernels::BackendChoice c = kernels::choose_backend("auto");
    EXPECT_EQ(c.backend, "opencl");
    EXPECT_NE(c.compute, nullptr);
    EXPECT_TRUE(c.note.empty());
    GTEST_SKIP() << "an OpenCL device exists; the no-platform paths run with OCL_ICD_VENDORS "
                    "pointing to an empty folder (ctest parity_without_platform)";
  }
  EXPECT_FALSE(why.empty());
  try {
    kernels::choose_backend("opencl");
    ADD_FAILURE() << "--backend opencl without a platform must fail";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
    EXPECT_NE(std::string(e.what()).find("OpenCL"), std::string::npos) << e.what();
  }
  const kernels::BackendChoice c = kernels::choose_backend("auto");
  EXPECT_EQ(c.backend, "cpu");
  EXPECT_EQ(c.compute, nullptr);
  EXPECT_NE(c.log.find("no OpenCL"), std::string::npos) << c.log;
}

TEST(OpenClAvailability, UnknownBackendIsRejected) {
  EXPECT_THROW(kernels::choose_backend("cuda"), Error);
  EXPECT_EQ(kernels::choose_backend("cpu").compute, nullptr);
}

}  // namespace
}  // namespace gvd
