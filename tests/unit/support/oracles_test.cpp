// The judges' oracles judged: the segment-triangle test on clear cases, on segments that lie
// in the triangle's plane, and on the heptagonal shaft's compacted GVD triangle that it once
// counted as crossing the shaft (an edge of the shaft in the triangle's plane, 1.4e-5 off it).

#include "support/oracles.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "gvd/geometry/primitives.h"
#include "gvd/pipeline/pipeline.h"
#include "support/scenes.h"

namespace {

using gvd::Vec3;
using gvd::test::segment_hits_triangle;

const Vec3 kT0{0, 0, 0}, kT1{1, 0, 0}, kT2{0, 1, 0};

TEST(Oracles, SegmentAcrossTheTriangleHitsIt) {
  EXPECT_TRUE(segment_hits_triangle({0.2, 0.2, -1}, {0.2, 0.2, 1}, kT0, kT1, kT2));
  EXPECT_TRUE(segment_hits_triangle({0.2, 0.2, 1}, {0.3, 0.1, -2}, kT0, kT1, kT2));
}

TEST(Oracles, SegmentShortOfOrBesideTheTriangleMissesIt) {
  EXPECT_FALSE(segment_hits_triangle({0.2, 0.2, 0.1}, {0.2, 0.2, 1}, kT0, kT1, kT2));
  EXPECT_FALSE(segment_hits_triangle({0.6, 0.6, -1}, {0.6, 0.6, 1}, kT0, kT1, kT2));
  EXPECT_FALSE(segment_hits_triangle({-0.1, 0.5, -1}, {-0.1, 0.5, 1}, kT0, kT1, kT2));
}

TEST(Oracles, SegmentTouchingTheTriangleHitsIt) {
  EXPECT_TRUE(segment_hits_triangle({0.2, 0.2, 0}, {0.2, 0.2, 1}, kT0, kT1, kT2));   // an end on it
  EXPECT_TRUE(segment_hits_triangle({0.5, 0.5, -1}, {0.5, 0.5, 1}, kT0, kT1, kT2));  // a side
}

TEST(Oracles, SegmentInThePlaneIsADecisionInThePlane) {
  EXPECT_TRUE(segment_hits_triangle({-1, 0.3, 0}, {2, 0.3, 0}, kT0, kT1, kT2));     // across
  EXPECT_TRUE(segment_hits_triangle({0.1, 0.1, 0}, {0.2, 0.1, 0}, kT0, kT1, kT2));  // inside
  EXPECT_FALSE(segment_hits_triangle({0.6, 0.6, 0}, {2, 0.6, 0}, kT0, kT1, kT2));   // beside
  EXPECT_FALSE(segment_hits_triangle({-1, -0.1, 0}, {2, -0.1, 0}, kT0, kT1, kT2));  // parallel
}

// Triangles and segments drawn in a plane, then turned into a tilted one (the turn's rounding
// puts them ~1e-16 off a common plane, either side): the answer must be the plane's, from the
// unturned coordinates, wherever the two are clearly apart or clearly across.
TEST(Oracles, SegmentsInATiltedPlaneAgreeWithThePlanarAnswer) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> coord(-1, 1);
  const Vec3 axis = Vec3{0.3, -0.7, 0.5} / gvd::norm(Vec3{0.3, -0.7, 0.5});
  const double angle = 0.83;
  auto turn = [&](Vec3 p) {  // Rodrigues
    return p * std::cos(angle) + gvd::cross(axis, p) * std::sin(angle) +
           axis * (gvd::dot(axis, p) * (1 - std::cos(angle)));
  };
  auto side = [](Vec3 p, Vec3 q, Vec3 r) {
    return (q.x - p.x) * (r.y - p.y) - (q.y - p.y) * (r.x - p.x);
  };
  int checked = 0, hits = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    Vec3 t[3], s[2];
    for (Vec3& p : t) p = {coord(rng), coord(rng), 0};
    for (Vec3& p : s) p = {coord(rng), coord(rng), 0};
    const double area = side(t[0], t[1], t[2]);
    if (std::fabs(area) < 0.05) continue;
    // The planar answer, with a margin: skip what lies within 1e-6 of deciding otherwise.
    double nearest = 1e300;
    for (const Vec3& p : s) {
      for (int k = 0; k < 3; ++k) {
        nearest =
            std::min(nearest, gvd::dist(p, gvd::closest_point_on_segment(p, t[k], t[(k + 1) % 3])));
      }
    }
    for (int k = 0; k < 3; ++k) {
      nearest = std::min(nearest, gvd::dist(t[k], gvd::closest_point_on_segment(t[k], s[0], s[1])));
    }
    if (nearest < 1e-6) continue;
    bool inside = false;
    for (const Vec3& p : s) {
      const double a = side(t[0], t[1], p), b = side(t[1], t[2], p), c = side(t[2], t[0], p);
      inside = inside || (area > 0 ? (a > 0 && b > 0 && c > 0) : (a < 0 && b < 0 && c < 0));
    }
    bool crosses = inside;
    for (int k = 0; k < 3; ++k) {
      crosses = crosses || gvd::test::segments_intersect_2d(s[0], s[1], t[k], t[(k + 1) % 3]);
    }
    const bool got =
        segment_hits_triangle(turn(s[0]), turn(s[1]), turn(t[0]), turn(t[1]), turn(t[2]));
    ASSERT_EQ(got, crosses) << "trial " << trial;
    ++checked;
    hits += crosses;
  }
  EXPECT_GT(checked, 10000);
  EXPECT_GT(hits, 1000);
  EXPECT_LT(hits, checked - 1000);
}

// gvd_audit on the heptagonal shaft at 1e-5 (tests/bench/audit): a compacted GVD triangle on
// the 45-degree bisector of the shaft's side and the housing's end, and the shaft's edge
// where that bisector plane meets the side (z = 0.6): coplanar, but 1.4e-5 apart.
TEST(Oracles, AShaftEdgeInTheBisectorsPlaneDoesNotCrossIt) {
  const Vec3 g[3] = {{0.17893474236188467, 0.068749999999999867, 0.61086136573804606},
                     {0.16174724236188465, 0.079441623791737803, 0.6000148850289706},
                     {0.18758764052241239, 0.025781249999999867, 0.60001391568260498}};
  const Vec3 a{0.18116343022471024, 0.03908918776283634, 0.60000000000000009};
  const Vec3 b{0.16233906952832641, 0.07817837552567268, 0.60000000000000009};
  EXPECT_FALSE(segment_hits_triangle(a, b, g[0], g[1], g[2]));
  EXPECT_FALSE(segment_hits_triangle(b, a, g[0], g[1], g[2]));
  // The same edge moved in the plane to pass through the triangle's centroid crosses it.
  const Vec3 up = (g[0] + g[1] + g[2]) / 3.0 - (a + b) * 0.5;
  EXPECT_TRUE(segment_hits_triangle(a + up, b + up, g[0], g[1], g[2]));
}

}  // namespace

// measure_orientation on a real result: the GVD between two boxes across a thin gap faces the
// right way (its probes stay in the gap however large the step asked for), and the same GVD
// with every triangle turned around is counted as facing the wrong way throughout.
TEST(Oracles, OrientationIsMeasuredInsideTheGapAndCatchesATurnedGvd) {
  const gvd::scene::Scene scene =
      gvd::test::make_scene(3, {gvd::test::make_box("a", {0, 0, 0}, {1, 1, 1}),
                                gvd::test::make_box("b", {1 + 1e-4, 0.2, 0.1}, {2, 0.9, 1.3})});
  gvd::pipeline::PipelineOptions o;
  o.threads = 2;
  gvd::result::GvdResult r = gvd::pipeline::compute_gvd(scene, o);
  const auto step = [](Vec3) { return 0.3; };  // far wider than the gap
  const gvd::test::Orientation right =
      gvd::test::measure_orientation(r.scene, r.gvd, step, 1000000);
  ASSERT_GT(right.tested, 0);
  EXPECT_LE(right.flipped, 1e-3 * right.tested);
  for (gvd::surface::GvdCell& cell : r.gvd.cells) {
    for (size_t t = 0; t + 2 < cell.indices.size(); t += 3) {
      std::swap(cell.indices[t + 1], cell.indices[t + 2]);
    }
  }
  const gvd::test::Orientation turned =
      gvd::test::measure_orientation(r.scene, r.gvd, step, 1000000);
  EXPECT_NEAR(turned.tested, right.tested, 1e-9 * right.tested);
  EXPECT_GE(turned.flipped, 0.999 * turned.tested);
}

// brute_mesh_distance on boxes: apart along x by 0.3 (the faces' distance), apart diagonally
// (the corners' distance), and crossing (0).
TEST(Oracles, MeshDistanceOfBoxes) {
  using gvd::test::make_box;
  const gvd::scene::SceneObject a = make_box("a", {0, 0, 0}, {1, 1, 1});
  EXPECT_NEAR(gvd::test::brute_mesh_distance(a, make_box("b", {1.3, 0.2, 0.2}, {2, 0.8, 0.8})), 0.3,
              1e-12);
  EXPECT_NEAR(gvd::test::brute_mesh_distance(a, make_box("c", {1.3, 1.4, 1.0}, {2, 2, 2})), 0.5,
              1e-12);
  EXPECT_EQ(gvd::test::brute_mesh_distance(a, make_box("d", {0.5, 0.5, -1}, {0.7, 0.7, 2})), 0);
}
