// closest_points_cpu_coherent (the pipeline's CPU solver) against closest_points_cpu, bit for
// bit: on spatially ordered and random batches, with exact ties and with tight bounds.

#include "gvd/distance/closest_points.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <random>

#include "gvd/octree/lattice.h"
#include "support/scenes.h"

namespace gvd {

using namespace gvd::scene;
using namespace gvd::octree;
using namespace gvd::distance;

namespace {

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

void expect_same(const UnitGeometry& g, const std::vector<Vec3>& queries,
                 const std::vector<double>& bound2) {
  const SimplexBvh bvh(g.dimension, g.points, g.simplices);
  const ClosestPointData data = make_closest_point_data(bvh);
  const size_t n = queries.size();
  std::vector<ClosestHit> plain(n), coherent(n);
  closest_points_cpu(data, queries, bound2, plain, 2);
  closest_points_cpu_coherent(data, queries, bound2, coherent, 2);
  size_t found = 0;
  for (size_t i = 0; i < n; ++i) {
    ASSERT_EQ(plain[i].simplex, coherent[i].simplex) << "query " << i;
    if (!plain[i].found()) continue;
    ++found;
    ASSERT_TRUE(same_bits(plain[i].dist2, coherent[i].dist2)) << "query " << i;
    ASSERT_TRUE(same_bits(plain[i].point.x, coherent[i].point.x) &&
                same_bits(plain[i].point.y, coherent[i].point.y) &&
                same_bits(plain[i].point.z, coherent[i].point.z))
        << "query " << i;
  }
  EXPECT_GT(found, 0u);
}

// Z order of unit-cube points (as compute_distances orders its queries).
void z_order(int dim, std::vector<Vec3>& q) {
  auto code = [&](Vec3 p) {
    lattice::Coord c;
    for (int a = 0; a < 3; ++a)
      c.c[a] = static_cast<uint32_t>(std::clamp(p[a], 0.0, 1.0) * ((1u << 20) - 1));
    return lattice::morton(dim, c);
  };
  std::sort(q.begin(), q.end(), [&](Vec3 a, Vec3 b) { return code(a) < code(b); });
}

TEST(ClosestPointsCoherent, SameAnswersAsTheTwinInZOrderAndAtRandom) {
  for (int dim : {2, 3}) {
    const Scene scene =
        dim == 2 ? test::make_scene(2, {test::make_circle("a", {0, 0, 0}, 1, 64),
                                        test::make_circle("b", {2.01, 0, 0}, 1, 64),
                                        test::make_circle("c", {1, 1.8, 0}, 0.7, 64)})
                 : test::make_scene(3, {test::make_sphere("a", {0, 0, 0}, 1, 16, 32),
                                        test::make_sphere("b", {2.01, 0, 0}, 1, 16, 32),
                                        test::make_sphere("c", {1, 1.8, 0.3}, 0.7, 16, 32)});
    const Domain domain = make_domain(scene);
    const UnitGeometry g = make_unit_geometry(scene, domain);
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> u(0, 1);
    std::vector<Vec3> q(20000);
    for (Vec3& p : q) p = {u(rng), u(rng), dim == 3 ? u(rng) : 0.0};
    std::vector<double> free(q.size(), 1e300);
    expect_same(g, q, free);  // random order
    z_order(dim, q);
    expect_same(g, q, free);
    // Tight bounds: exactly the distance, just below it, nothing.
    const SimplexBvh bvh(g.dimension, g.points, g.simplices);
    std::vector<Vec3> tq;
    std::vector<double> tb;
    for (size_t i = 0; i < q.size(); i += 7) {
      const double d2 = bvh.nearest(q[i]).dist2;
      for (double b : {d2, d2 * (1 - 1e-9), std::nextafter(d2, 0.0), 0.0, 4 * d2}) {
        tq.push_back(q[i]);
        tb.push_back(b);
      }
    }
    expect_same(g, tq, tb);
  }
}

TEST(ClosestPointsCoherent, ExactTiesGoToTheLowerSimplexAsInTheTwin) {
  // Two fans of triangles mirrored about z = 1/2; queries on the plane, in order, are at
  // exactly the same distance from both objects (and from neighbouring triangles of a fan).
  UnitGeometry g;
  g.dimension = 3;
  g.object_count = 2;
  for (int o = 0; o < 2; ++o) {
    const double h = o == 0 ? 0.25 : 0.75;
    for (int k = 0; k < 8; ++k) {
      const double x0 = 0.125 + 0.0625 * k, x1 = x0 + 0.0625;
      const uint32_t base = static_cast<uint32_t>(g.points.size());
      g.points.push_back({x0, 0.25, h});
      g.points.push_back({x1, 0.25, h});
      g.points.push_back({x0, 0.75, h});
      g.simplices.push_back(Simplex{{base, base + 1, base + 2}});
      g.object_of.push_back(static_cast<ObjectId>(o));
    }
  }
  std::vector<Vec3> q;
  for (int i = 0; i <= 64; ++i)
    for (int j = 0; j <= 64; ++j) q.push_back({i / 64.0, j / 64.0, 0.5});
  expect_same(g, q, std::vector<double>(q.size(), 1e300));
}

}  // namespace
}  // namespace gvd
