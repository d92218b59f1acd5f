#include "gvd/octree/contacts.h"

#include <gtest/gtest.h>

#include "gvd/geometry/primitives.h"
#include "support/scenes.h"

namespace gvd {

using namespace gvd::scene;
using namespace gvd::octree;

namespace {

TEST(Contacts, SegmentDistancesAreAnalytic) {
  // Skew lines: x axis and a parallel to y at height 2 -> 2.
  EXPECT_DOUBLE_EQ(segment_segment_dist2({-1, 0, 0}, {1, 0, 0}, {0, -1, 2}, {0, 1, 2}), 4.0);
  // Crossing in 2D -> 0.
  EXPECT_DOUBLE_EQ(segment_segment_dist2({-1, 0, 0}, {1, 0, 0}, {0, -1, 0}, {0, 1, 0}), 0.0);
  // Parallel, offset, overlapping -> 0.25.
  EXPECT_DOUBLE_EQ(segment_segment_dist2({0, 0, 0}, {2, 0, 0}, {1, 0.5, 0}, {3, 0.5, 0}), 0.25);
  // Endpoint to endpoint.
  EXPECT_DOUBLE_EQ(segment_segment_dist2({0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}), 1.0);
  // Degenerate segment (a point).
  EXPECT_DOUBLE_EQ(segment_segment_dist2({0, 3, 0}, {0, 3, 0}, {-1, 0, 0}, {1, 0, 0}), 9.0);
}

TEST(Contacts, TriangleDistancesAreAnalytic) {
  const Vec3 a[3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  const Vec3 above[3] = {{0, 0, 0.5}, {1, 0, 0.5}, {0, 1, 0.5}};
  EXPECT_DOUBLE_EQ(triangle_triangle_dist2(a, above), 0.25);
  const Vec3 piercing[3] = {{0.2, 0.2, -1}, {0.2, 0.2, 1}, {0.3, 0.25, 1}};
  EXPECT_DOUBLE_EQ(triangle_triangle_dist2(a, piercing), 0.0);
  const Vec3 edge_near[3] = {{2, 0, 0}, {3, 0, 0}, {2, 1, 0}};
  EXPECT_DOUBLE_EQ(triangle_triangle_dist2(a, edge_near), 1.0);
}

TEST(Contacts, FindsTouchingAndIntersectingPairsOnly) {
  const Scene scene = test::make_scene(
      3,
      {test::make_box("a", {0, 0, 0}, {1, 1, 1}), test::make_box("b", {0.5, 0.5, 0.5}, {2, 2, 2}),
       test::make_box("c", {0, 0, 1}, {1, 1, 2}), test::make_box("d", {3, 3, 3}, {4, 4, 4}),
       test::make_box("e", {3, 3, 4.001}, {4, 4, 5})});
  const Domain d = make_domain(scene);
  const UnitGeometry g = make_unit_geometry(scene, d);
  const SimplexBvh bvh(3, g.points, g.simplices);
  const ContactPairs pairs = find_contact_pairs(g, bvh, 1e-6);
  // a/b intersect, a/c share a face, b/c intersect; d/e are 1e-3 apart (not touching).
  const std::vector<std::pair<ObjectId, ObjectId>> expected{{0, 1}, {0, 2}, {1, 2}};
  EXPECT_EQ(pairs.pairs(), expected);
  EXPECT_TRUE(pairs.touching(1, 0));
  EXPECT_FALSE(pairs.touching(3, 4));
  // With a tolerance above the gap, d/e touch too.
  EXPECT_TRUE(find_contact_pairs(g, bvh, 1e-3 / d.side * 1.01).touching(3, 4));
}

}  // namespace
}  // namespace gvd
