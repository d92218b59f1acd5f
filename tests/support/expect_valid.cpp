#include "support/expect_valid.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "support/oracles.h"

namespace gvd::test {

using namespace gvd::scene;
using namespace gvd::surface;
using namespace gvd::result;

double local_cell(const GvdResult& r, Vec3 p) {
  const uint32_t leaf = r.octree.locate(r.domain.to_unit(p));
  return std::ldexp(r.domain.side, -r.octree.level[leaf]);
}

void expect_valid(const GvdResult& r, const std::function<bool(ObjectId, ObjectId)>& oriented) {
  const int dim = r.scene.dimension;
  for (const GvdCell& cell : r.gvd.cells) {
    EXPECT_EQ(count_open_edges(cell, dim), 0u) << "cell " << cell.object << " is not closed";
  }
  EXPECT_EQ(count_gvd_object_crossings(r.scene, r.gvd, 3000), 0u);
  // Equidistance at interface vertices, and the two nearest objects are the claimed ones.
  size_t checked = 0, wrong_pair = 0;
  for (const GvdCell& cell : r.gvd.cells) {
    for (size_t v = 0; v < cell.positions.size(); v += stride_for(cell.positions.size())) {
      if (cell.other[v] == kNoObject) continue;
      const Vec3 p = cell.positions[v];
      const double h = local_cell(r, p);
      const double da = brute_distance(r.scene, cell.object, p);
      const double db = brute_distance(r.scene, cell.other[v], p);
      EXPECT_NEAR(da, db, 2.0 * h) << "vertex " << v << " of cell " << cell.object;
      const auto nn = brute_nearest(r.scene, p);
      const std::set<ObjectId> claimed{cell.object, cell.other[v]};
      if (!claimed.count(nn.object)) {
        // Allowed only where a third object is within the local resolution.
        if (nn.distance < std::min(da, db) - 2.0 * h) ++wrong_pair;
      }
      ++checked;
    }
  }
  EXPECT_EQ(wrong_pair, 0u) << "of " << checked;
  // Orientation by area (measure_orientation): a step of a quarter of the local leaf (at most
  // half the local clearance) along each sampled simplex's normal.
  const Orientation o = measure_orientation(
      r.scene, r.gvd, [&](Vec3 c) { return 0.25 * local_cell(r, c); }, 3000, oriented);
  EXPECT_LE(o.flipped, 0.005 * o.tested)
      << "area facing the wrong way: " << o.flipped << " of " << o.tested;
  // Distance field at octree vertices: never below the true distance, within the 3/2 factor.
  for (uint32_t v = 0; v < r.field.size(); v += stride_for(r.field.size())) {
    const Vec3 p = r.domain.from_unit(r.field.vertices.position(v));
    const double truth = brute_nearest(r.scene, p).distance;
    const double got = r.field.distance(v) * r.domain.side;
    ASSERT_GE(got, truth - 1e-9 * r.domain.side);
    ASSERT_LE(got, 1.5 * truth + 1e-9 * r.domain.side) << "vertex " << v;
    if (r.field.exact[v]) {
      ASSERT_NEAR(got, truth, 1e-9 * r.domain.side);
    }
  }
}

}  // namespace gvd::test
