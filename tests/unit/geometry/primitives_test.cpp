// The cell-simplex overlap tests of the octree against clipping oracles: a triangle (segment)
// meets a box iff clipping it to the box leaves something.

#include "gvd/geometry/primitives.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "support/scenes.h"

namespace gvd {
namespace {

// Sutherland-Hodgman: the part of a convex polygon inside the box.
std::vector<Vec3> clip(std::vector<Vec3> poly, const Box& box) {
  for (int axis = 0; axis < 3; ++axis) {
    for (int side = 0; side < 2; ++side) {
      const double bound = side == 0 ? box.lo[axis] : box.hi[axis];
      auto inside = [&](const Vec3& p) { return side == 0 ? p[axis] >= bound : p[axis] <= bound; };
      std::vector<Vec3> out;
      for (size_t i = 0; i < poly.size(); ++i) {
        const Vec3 a = poly[i], b = poly[(i + 1) % poly.size()];
        if (inside(a)) out.push_back(a);
        if (inside(a) != inside(b)) {
          const double t = (bound - a[axis]) / (b[axis] - a[axis]);
          Vec3 q = a + (b - a) * t;
          q[axis] = bound;
          out.push_back(q);
        }
      }
      poly = std::move(out);
      if (poly.empty()) return poly;
    }
  }
  return poly;
}

Box grown(const Box& b, double d) {
  Box out = b;
  for (int i = 0; i < 3; ++i) {
    out.lo[i] -= d;
    out.hi[i] += d;
  }
  return out;
}

// The test's answer where the oracle is sure (the simplex still meets the box shrunk by a
// hair, or misses it grown by one); cases within the hair of touching are left out.
struct Verdicts {
  int overlaps = 0, misses = 0;
  void add(bool test, bool surely_in, bool surely_out, int i) {
    if (surely_in) {
      EXPECT_TRUE(test) << "missed overlap at case " << i;
      ++overlaps;
    }
    if (surely_out) {
      EXPECT_FALSE(test) << "false overlap at case " << i;
      ++misses;
    }
  }
  void expect_both_sides_covered() const {
    EXPECT_GT(overlaps, 20000);
    EXPECT_GT(misses, 20000);
  }
};

TEST(Primitives, TriangleBoxOverlapMatchesClipping) {
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> u(0, 1);
  Verdicts verdicts;
  for (int i = 0; i < 200000; ++i) {
    // Boxes of several sizes against triangles from much smaller to much larger than them
    // (large facets over small cells is the octree's common case).
    const double size = std::ldexp(1.0, -static_cast<int>(u(rng) * 8));
    const Vec3 lo{u(rng), u(rng), u(rng)};
    const Box box{lo, lo + Vec3{size, size, size}};
    const double scale = size * std::ldexp(1.0, static_cast<int>(u(rng) * 10) - 3);
    const Vec3 c = box.center() + Vec3{u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5} * (2 * size);
    auto r = [&] { return Vec3{u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5} * scale; };
    const Vec3 a = c + r(), b = c + r(), d = c + r();
    const double margin = 1e-9 * size;
    verdicts.add(triangle_overlaps_box(a, b, d, box, 0.0),
                 !clip({a, b, d}, grown(box, -margin)).empty(),
                 clip({a, b, d}, grown(box, margin)).empty(), i);
  }
  verdicts.expect_both_sides_covered();
}

TEST(Primitives, SegmentBoxOverlapMatchesClipping) {
  std::mt19937_64 rng(23);
  std::uniform_real_distribution<double> u(0, 1);
  Verdicts verdicts;
  for (int i = 0; i < 200000; ++i) {
    const double size = std::ldexp(1.0, -static_cast<int>(u(rng) * 8));
    const Vec3 lo{u(rng), u(rng), 0};
    const Box box{lo, lo + Vec3{size, size, 0}};
    const double scale = size * std::ldexp(1.0, static_cast<int>(u(rng) * 10) - 3);
    const Vec3 c = box.center() + Vec3{u(rng) - 0.5, u(rng) - 0.5, 0} * (2 * size);
    const Vec3 a = c + Vec3{u(rng) - 0.5, u(rng) - 0.5, 0} * scale;
    const Vec3 b = c + Vec3{u(rng) - 0.5, u(rng) - 0.5, 0} * scale;
    const double margin = 1e-9 * size;
    // A segment is a degenerate polygon: clip the pair (a, b).
    Box in = grown(box, -margin), out = grown(box, margin);
    in.lo.z = out.lo.z = -1;
    in.hi.z = out.hi.z = 1;
    verdicts.add(segment_overlaps_box_2d(a, b, box, 0.0), !clip({a, b}, in).empty(),
                 clip({a, b}, out).empty(), i);
  }
  verdicts.expect_both_sides_covered();
}

// Coplanar triangles a gap apart inside their plane (the flush side faces of stacked parts),
// rotated off the axes so that the plane is only coplanar up to rounding: no false crossing.
TEST(Primitives, CoplanarTrianglesApartInTheirPlaneAreNotCrossing) {
  const Vec3 axis = Vec3{2, -1, 3} / std::sqrt(14.0);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> angle(0.1, 3.0);
  for (int k = 0; k < 200; ++k) {
    const double t = angle(rng);
    auto turn = [&](Vec3 p) { return test::rotate(p, axis, t); };
    const double gap = 1e-4;
    const Vec3 a[3] = {turn({0, 0, 0}), turn({1, 0, 0}), turn({0, 0.1, 0})};
    const Vec3 b[3] = {turn({0, 0.1 + gap, 0}), turn({1, 0.1 + gap, 0}), turn({0, 0.2 + gap, 0})};
    const double d = std::sqrt(triangle_triangle_dist2(a, b));
    ASSERT_NEAR(d, gap, 1e-12) << "rotation " << k;
    ASSERT_NEAR(std::sqrt(segment_triangle_dist2(b[0], b[1], a[0], a[1], a[2])), gap, 1e-12);
  }
}

}  // namespace
}  // namespace gvd
