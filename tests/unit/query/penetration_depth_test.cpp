// ConvexShape against analytic penetration depths and a brute-force oracle: the least overlap
// of the two objects' projections over many directions, refined by a local search (the depth
// must be at most every sampled overlap and reached by some direction).
#include "gvd/query/penetration_depth.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "support/scenes.h"

namespace gvd {

using namespace gvd::scene;
using namespace gvd::query;

namespace {

/// The object turned by a rotation (rows r0, r1, r2) and moved by t.
SceneObject moved(SceneObject o, const Vec3 r[3], Vec3 t) {
  for (Vec3& v : o.vertices) v = Vec3{dot(r[0], v), dot(r[1], v), dot(r[2], v)} + t;
  return o;
}

/// A random rotation (3D; 2D: about z), from a normalised random quaternion.
void random_rotation(std::mt19937& rng, int dim, Vec3 r[3]) {
  std::normal_distribution<double> g;
  double w = g(rng), x = 0, y = 0, z = g(rng);
  if (dim == 3) {
    x = g(rng);
    y = g(rng);
  }
  const double n = std::sqrt(w * w + x * x + y * y + z * z);
  w /= n, x /= n, y /= n, z /= n;
  r[0] = {1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)};
  r[1] = {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)};
  r[2] = {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)};
}

/// The overlap of the two objects' projections on direction d (unit): how far b must move
/// along d to leave a along d.
double overlap(const SceneObject& a, const SceneObject& b, Vec3 d) {
  double hi = -1e300, lo = 1e300;
  for (const Vec3& v : a.vertices) hi = std::max(hi, dot(v, d));
  for (const Vec3& v : b.vertices) lo = std::min(lo, dot(v, d));
  return hi - lo;
}

Vec3 direction(int dim, double theta, double phi) {
  if (dim == 2) return {std::cos(phi), std::sin(phi), 0};
  return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

/// Checks a penetration against the directions: moving b along its direction by its depth is
/// what the overlap there asks, and no sampled direction asks less.
void expect_least_overlap(const SceneObject& a, const SceneObject& b, int dim,
                          const ConvexShape::Penetration& p) {
  EXPECT_NEAR(norm(p.direction), 1, 1e-12);
  EXPECT_NEAR(overlap(a, b, p.direction), p.depth, 1e-12) << "the depth is not reached there";
  const int n = dim == 2 ? 20000 : 60000;
  for (int i = 0; i < n; ++i) {
    // Fibonacci points on the sphere (2D: the circle).
    const double phi =
        dim == 2 ? 2 * std::numbers::pi * i / n
                 : std::fmod(i * std::numbers::pi * (3 - std::sqrt(5.0)), 2 * std::numbers::pi);
    const double theta = dim == 2 ? 0 : std::acos(1 - 2 * (i + 0.5) / n);
    ASSERT_GE(overlap(a, b, direction(dim, theta, phi)), p.depth - 1e-12)
        << "a direction with less overlap: theta " << theta << " phi " << phi;
  }
}

ConvexShape::Penetration penetration_of(const SceneObject& a, const SceneObject& b, int dim) {
  const auto sa = ConvexShape::of(a, dim), sb = ConvexShape::of(b, dim);
  EXPECT_TRUE(sa && sb) << a.label << " or " << b.label << " not convex";
  if (!sa || !sb) return {-1, {}};
  const auto p = ConvexShape::penetration(*sa, *sb);
  EXPECT_TRUE(p.has_value());
  return p.value_or(ConvexShape::Penetration{-1, {}});
}

double depth_of(const SceneObject& a, const SceneObject& b, int dim) {
  return penetration_of(a, b, dim).depth;
}

/// A bar along x (diamond cross-section: turned 45 degrees about x), half-diagonal h, with
/// its top edge at height `top`.
SceneObject diamond_bar(const std::string& label, int along, double h, double top) {
  SceneObject box = test::make_box(label, {-5, -h / std::sqrt(2.0), -h / std::sqrt(2.0)},
                                   {5, h / std::sqrt(2.0), h / std::sqrt(2.0)});
  const double c = std::cos(std::numbers::pi / 4), s = std::sin(std::numbers::pi / 4);
  const Vec3 about_x[3] = {{1, 0, 0}, {0, c, -s}, {0, s, c}};
  const Vec3 x_to_y[3] = {{0, -1, 0}, {1, 0, 0}, {0, 0, 1}};
  SceneObject o = moved(box, about_x, {0, 0, top - h});
  if (along == 1) o = moved(o, x_to_y, {0, 0, 0});
  return o;
}

TEST(PenetrationDepth, BoxesPushedIntoEachOther) {
  const SceneObject a = test::make_box("a", {0, 0, 0}, {1, 1, 1});
  // Pushed 0.1 into the face x = 1.
  EXPECT_NEAR(depth_of(a, test::make_box("b", {0.9, 0.25, 0.25}, {1.9, 0.75, 0.75}), 3), 0.1,
              1e-12);
  // Wholly inside: out through the nearest face, z = 0 (b reaches 0.6 above it).
  EXPECT_NEAR(depth_of(a, test::make_box("b", {0.3, 0.3, 0.2}, {0.7, 0.7, 0.6}), 3), 0.6, 1e-12);
  // Touching face to face: 0.
  EXPECT_NEAR(depth_of(a, test::make_box("b", {1, 0, 0}, {2, 1, 1}), 3), 0, 1e-12);
  // 2D: a square pushed 0.05 into another.
  EXPECT_NEAR(depth_of(test::make_rect("a", {0, 0, 0}, {1, 1, 0}),
                       test::make_rect("b", {0.2, 0.95, 0}, {0.6, 2, 0}), 2),
              0.05, 1e-12);
}

// Two bars crossed at right angles, each turned so that an edge faces the other: they overlap
// by 0.03 between their edges, which only an edge-edge axis of the Minkowski difference gives
// (every face normal of either bar meets the other's length).
TEST(PenetrationDepth, CrossedEdgesUseTheEdgePairAxis) {
  const SceneObject a = diamond_bar("a", 0, 0.5, 0.0);
  // a's top edge at z = 0, b's bottom edge (its top 1.0 above) at z = -0.03.
  const SceneObject b = diamond_bar("b", 1, 0.5, 0.97);
  const ConvexShape::Penetration p = penetration_of(a, b, 3);
  EXPECT_NEAR(p.depth, 0.03, 1e-12);
  EXPECT_NEAR(std::abs(p.direction.z), 1, 1e-12);
  expect_least_overlap(a, b, 3, p);
}

TEST(PenetrationDepth, RandomConvexPairsMatchTheLeastOverlap) {
  std::mt19937 rng(7);
  // Offsets below the sum of the shapes' inner radii: every pair overlaps.
  std::uniform_real_distribution<double> u(-0.25, 0.25);
  for (int trial = 0; trial < 12; ++trial) {
    SCOPED_TRACE("trial " + std::to_string(trial));
    const int dim = trial % 3 == 2 ? 2 : 3;
    Vec3 ra[3], rb[3];
    random_rotation(rng, dim, ra);
    random_rotation(rng, dim, rb);
    SceneObject a, b;
    if (dim == 2) {
      a = moved(test::make_rect("a", {-0.6, -0.3, 0}, {0.6, 0.3, 0}), ra, {0, 0, 0});
      b = moved(test::make_circle("b", {0, 0, 0}, 0.5, 7), rb, {u(rng), u(rng), 0});
    } else if (trial % 3 == 0) {
      a = moved(test::make_box("a", {-0.6, -0.3, -0.4}, {0.6, 0.3, 0.4}), ra, {0, 0, 0});
      b = moved(test::make_box("b", {-0.2, -0.5, -0.3}, {0.2, 0.5, 0.3}), rb,
                {u(rng), u(rng), u(rng)});
    } else {
      a = moved(test::make_sphere("a", {0, 0, 0}, 0.5, 5, 7), ra, {0, 0, 0});
      b = moved(test::make_box("b", {-0.2, -0.5, -0.3}, {0.2, 0.5, 0.3}), rb,
                {u(rng), u(rng), u(rng)});
    }
    const ConvexShape::Penetration p = penetration_of(a, b, dim);
    EXPECT_GT(p.depth, 0);
    expect_least_overlap(a, b, dim, p);
  }
}

TEST(PenetrationDepth, ObjectsThatAreNotConvexHaveNoShape) {
  ConvexShape::Verdict verdict;
  // A box with a corner pushed in.
  SceneObject dented = test::make_box("dented", {0, 0, 0}, {1, 1, 1});
  dented.vertices[7] = {0.7, 0.7, 0.7};
  EXPECT_FALSE(ConvexShape::of(dented, 3, kPenetrationBudget, &verdict));
  EXPECT_EQ(verdict, ConvexShape::Verdict::kNotConvex);
  // Two boxes as one object.
  SceneObject two = test::make_box("two", {0, 0, 0}, {1, 1, 1});
  const SceneObject other = test::make_box("other", {2, 0, 0}, {3, 1, 1});
  for (Simplex s : other.simplices) {
    for (uint32_t& v : s.v) v += 8;
    two.simplices.push_back(s);
  }
  two.vertices.insert(two.vertices.end(), other.vertices.begin(), other.vertices.end());
  EXPECT_FALSE(ConvexShape::of(two, 3));
  // An open box.
  SceneObject open = test::make_box("open", {0, 0, 0}, {1, 1, 1});
  open.simplices.pop_back();
  EXPECT_FALSE(ConvexShape::of(open, 3));
  // A pentagram: every turn the same way, but twice around.
  SceneObject star;
  for (int k = 0; k < 5; ++k) {
    const double t = 2 * std::numbers::pi * 2 * k / 5;
    star.vertices.push_back({std::cos(t), std::sin(t), 0});
    star.simplices.push_back({{static_cast<uint32_t>(k), static_cast<uint32_t>((k + 1) % 5), 0}});
  }
  EXPECT_FALSE(ConvexShape::of(star, 2));
  // The same five points in order are convex; so are a box, a sphere and a box turned inside
  // out (its triangles reversed).
  for (int k = 0; k < 5; ++k) {
    const double t = 2 * std::numbers::pi * k / 5;
    star.vertices[k] = {std::cos(t), std::sin(t), 0};
  }
  EXPECT_TRUE(ConvexShape::of(star, 2));
  EXPECT_TRUE(ConvexShape::of(test::make_sphere("s", {0, 0, 0}, 1), 3));
  SceneObject inside_out = test::make_box("i", {0, 0, 0}, {1, 1, 1});
  for (Simplex& s : inside_out.simplices) std::swap(s.v[1], s.v[2]);
  EXPECT_TRUE(ConvexShape::of(inside_out, 3, kPenetrationBudget, &verdict));
  EXPECT_EQ(verdict, ConvexShape::Verdict::kConvex);
  // Over the budget: not measured, and said so.
  EXPECT_FALSE(ConvexShape::of(test::make_sphere("s", {0, 0, 0}, 1), 3, 100, &verdict));
  EXPECT_EQ(verdict, ConvexShape::Verdict::kOverBudget);
  const auto a = ConvexShape::of(test::make_box("a", {0, 0, 0}, {1, 1, 1}), 3);
  ASSERT_TRUE(a);
  EXPECT_FALSE(ConvexShape::penetration(*a, *a, 10));
}

}  // namespace
}  // namespace gvd
