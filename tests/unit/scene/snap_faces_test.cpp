// snap_rounded_faces: a float32 input's flat faces put back on exact planes, by no more than
// the rounding, never across a gap.
#include "gvd/scene/snap_faces.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "support/scenes.h"
#include "support/thin_gap_scenes.h"

namespace gvd {

using namespace gvd::scene;

namespace {

const Vec3 kAxis = Vec3{2, -1, 3} / std::sqrt(14.0);
constexpr double kAngle = 0.7;

void turn(Scene& scene) {
  for (SceneObject& o : scene.objects)
    for (Vec3& v : o.vertices) v = test::rotate(v, kAxis, kAngle);
}

double largest_coordinate(const Scene& scene) {
  double m = 0;
  for (const SceneObject& o : scene.objects)
    for (const Vec3& v : o.vertices) m = std::max({m, std::abs(v.x), std::abs(v.y), std::abs(v.z)});
  return m;
}

Vec3 unit_normal(const SceneObject& o, const Simplex& t) {
  const Vec3 n =
      cross(o.vertices[t.v[1]] - o.vertices[t.v[0]], o.vertices[t.v[2]] - o.vertices[t.v[0]]);
  return n / norm(n);
}

/// Over all pairs of triangles of the scene whose design normals (`design`, the unturned
/// normal of each triangle in scene order) are parallel: the largest sine between their
/// normals now; whose design normals are square: the largest cosine; and over triangles of
/// one face (parallel design normals, one design offset): the largest spread of n . p over
/// their vertices, n the first triangle's normal.
struct Squareness {
  double parallel = 0, square = 0, flat = 0;
};
Squareness measure(const Scene& scene, const std::vector<Vec3>& design,
                   const std::vector<double>& offset) {
  std::vector<Vec3> n;
  std::vector<std::array<Vec3, 3>> corners;
  for (const SceneObject& o : scene.objects)
    for (const Simplex& t : o.simplices) {
      n.push_back(unit_normal(o, t));
      corners.push_back({o.vertices[t.v[0]], o.vertices[t.v[1]], o.vertices[t.v[2]]});
    }
  Squareness s;
  for (size_t i = 0; i < n.size(); ++i)
    for (size_t j = 0; j < n.size(); ++j) {
      if (norm(cross(design[i], design[j])) < 1e-9) {
        s.parallel = std::max(s.parallel, norm(cross(n[i], n[j])));
        if (dot(design[i], design[j]) > 0 && std::abs(offset[i] - offset[j]) < 1e-9)
          for (const Vec3& p : corners[j])
            s.flat = std::max(s.flat, std::abs(dot(n[i], p - corners[i][0])));
      } else if (std::abs(dot(design[i], design[j])) < 1e-9) {
        s.square = std::max(s.square, std::abs(dot(n[i], n[j])));
      }
    }
  return s;
}

/// Design normals and offsets (n . p) of every triangle, in scene order.
void design_of(const Scene& scene, std::vector<Vec3>& normals, std::vector<double>& offsets) {
  for (const SceneObject& o : scene.objects)
    for (const Simplex& t : o.simplices) {
      normals.push_back(unit_normal(o, t));
      offsets.push_back(dot(normals.back(), o.vertices[t.v[0]]));
    }
}

/// Two boxes drawn along x, y, z (3e-4 apart along x), turned 0.7 rad.
Scene turned_assembly() {
  Scene scene = test::make_scene(3, {test::make_box("a", {0.1, 0.2, 0.1}, {0.4, 0.9, 0.7}),
                                     test::make_box("b", {0.4003, 0.25, 0.15}, {0.8, 0.6, 0.5})});
  turn(scene);
  return scene;
}

/// turned_assembly after `round`, snapped: its 12 faces and 16 vertices
/// flat, parallel and square to double rounding after (broken by the rounding before), no
/// vertex moved by more than 16 roundings, the gap kept within 4.
void expect_snapped(void (*round)(Scene&), int threads, double expected_rounding) {
  Scene scene = turned_assembly();
  std::vector<Vec3> design;  // turned in doubles: the design
  std::vector<double> offset;
  design_of(scene, design, offset);
  round(scene);
  const Scene before = scene;
  const Squareness was = measure(scene, design, offset);
  // The rounding broke them, by 100 times the bounds below at least: the test means something.
  EXPECT_GT(was.parallel, 1e-12);
  EXPECT_GT(was.flat, 1e-13);

  const FaceSnap snap = snap_rounded_faces(scene, threads);
  if (expected_rounding > 0) {
    EXPECT_EQ(snap.rounding, expected_rounding);
  }
  EXPECT_EQ(snap.faces, 12u);
  EXPECT_EQ(snap.vertices, 16u);
  EXPECT_EQ(snap.refused, 0u);
  const Squareness now = measure(scene, design, offset);
  EXPECT_LT(now.parallel, 1e-14);
  EXPECT_LT(now.square, 1e-14);
  EXPECT_LT(now.flat, 1e-15);
  double moved = 0;
  for (size_t o = 0; o < scene.objects.size(); ++o)
    for (size_t v = 0; v < scene.objects[o].vertices.size(); ++v)
      moved = std::max(moved, dist(scene.objects[o].vertices[v], before.objects[o].vertices[v]));
  EXPECT_LE(moved, 16 * snap.rounding);
  EXPECT_EQ(moved, snap.max_move);
  EXPECT_NEAR(test::min_distance_3d(scene.objects[0], scene.objects[1]),
              test::min_distance_3d(before.objects[0], before.objects[1]), 4 * snap.rounding);
}

}  // namespace

// The assembly rounded to float32 (as an STL of a tilted assembly): its faces are flat,
// parallel and square only to ~1e-7; the rounding is 2^-24 of the largest coordinate.
TEST(SnapFaces, PutsATurnedFloat32AssemblyOnExactSquarePlanes) {
  Scene turned = turned_assembly();
  test::round_to_float32(turned);
  expect_snapped([](Scene& s) { test::round_to_float32(s); }, 2,
                 std::ldexp(largest_coordinate(turned), -24));
}

// The same assembly written with 8 and with 11 decimals (an OBJ, a JSON scene written by a
// script that rounds): flat, parallel and square only to 5e-9 or 5e-12, which the
// certificates refused as they refused float32's rounding. Put on exact planes as a float32
// one is, the rounding taken from the digits: half a unit in the last place, or in the last
// significant digit of the largest coordinate. (At 11 decimals the faces are flat to 5e-12
// against entries of their scatter ~0.1: in x, y, z the fit's rounding noise refused every
// parallel face.)
TEST(SnapFaces, PutsATurnedAssemblyWrittenWithFewDecimalsOnExactSquarePlanes) {
  expect_snapped([](Scene& s) { test::round_to_decimals(s, 8); }, 2, 0);
  expect_snapped([](Scene& s) { test::round_to_decimals(s, 11); }, 2, 0);
  for (const int places : {8, 11}) {
    Scene scene = turned_assembly();
    test::round_to_decimals(scene, places);
    const FaceSnap snap = snap_rounded_faces(scene);
    EXPECT_FALSE(snap.float32);
    EXPECT_GE(snap.rounding, 0.5 * std::pow(10.0, -places));
    EXPECT_LE(snap.rounding, 5 * std::pow(10.0, -places));
  }
}

// A scene written by hand in short decimals (0.2, 0.4003) is exact, not rounded: most of its
// coordinates use fewer digits than the longest. Nor is one of integers (past float32's 2^24,
// which the float32 rule would take). Both left alone.
TEST(SnapFaces, TakesShortDecimalsAndIntegersForExact) {
  Scene by_hand = test::make_scene(3, {test::make_box("a", {0.1, 0.2, 0.1}, {0.4, 0.9, 0.7}),
                                       test::make_box("b", {0.4003, 0.25, 0.15}, {0.8, 0.6, 0.5})});
  EXPECT_EQ(snap_rounded_faces(by_hand).rounding, 0.0);
  const double big = 16777217;  // 2^24 + 1: no float32
  Scene integers = test::make_scene(3, {test::make_box("a", {big, 2, 1}, {big + 3, 9, 7}),
                                        test::make_box("b", {big + 4, 3, 2}, {big + 7, 6, 5})});
  EXPECT_EQ(snap_rounded_faces(integers).rounding, 0.0);
}

// Doubles, curved meshes and a scene drawn along the axes in float32 are left as they are.
// (A UV sphere's quads are flat: those are faces, and are snapped.)
TEST(SnapFaces, LeavesDoublesCurvedMeshesAndExactFacesAlone) {
  Scene doubles = test::make_scene(3, {test::make_box("a", {0.1, 0.2, 0.1}, {0.4, 0.9, 0.7}),
                                       test::make_box("b", {0.41, 0.25, 0.15}, {0.8, 0.6, 0.5})});
  turn(doubles);
  Scene copy = doubles;
  FaceSnap snap = snap_rounded_faces(copy);
  EXPECT_EQ(snap.rounding, 0.0);  // neither float32 nor few decimals: nothing done
  for (size_t o = 0; o < copy.objects.size(); ++o)
    EXPECT_EQ(copy.objects[o].vertices, doubles.objects[o].vertices);

  // Spheres with bumps (a UV sphere's quads are flat faces): no two triangles coplanar, no
  // triangle with sharp edges.
  auto bumpy = [](const char* label, Vec3 centre, double radius) {
    SceneObject o = test::make_sphere(label, centre, radius, 24);
    for (size_t v = 0; v < o.vertices.size(); ++v)
      o.vertices[v] = centre + (o.vertices[v] - centre) * (1 + 0.02 * std::sin(7.0 * v));
    return o;
  };
  Scene balls =
      test::make_scene(3, {bumpy("a", {0.3, 0.3, 0.3}, 0.2), bumpy("b", {0.7, 0.3, 0.3}, 0.19)});
  turn(balls);
  test::round_to_float32(balls);
  copy = balls;
  snap = snap_rounded_faces(copy);
  EXPECT_GT(snap.rounding, 0.0);
  EXPECT_EQ(snap.faces, 0u);
  EXPECT_EQ(snap.vertices, 0u);
  for (size_t o = 0; o < copy.objects.size(); ++o)
    EXPECT_EQ(copy.objects[o].vertices, balls.objects[o].vertices);

  Scene along = test::make_scene(3, {test::make_box("a", {0.1, 0.2, 0.1}, {0.4, 0.9, 0.7}),
                                     test::make_box("b", {0.41, 0.25, 0.15}, {0.8, 0.6, 0.5})});
  test::round_to_float32(along);
  copy = along;
  snap = snap_rounded_faces(copy);
  EXPECT_EQ(snap.faces, 12u);
  EXPECT_EQ(snap.vertices, 0u);  // already exact
  for (size_t o = 0; o < copy.objects.size(); ++o)
    EXPECT_EQ(copy.objects[o].vertices, along.objects[o].vertices);
}

// What the design says is kept: a face tilted by 1e-5 rad against its neighbour across a gap
// stays tilted (1e-5 over the face is far more than the rounding), and a gap of a few
// roundings is not closed (moves near another object stay within 1 % of the distance).
TEST(SnapFaces, KeepsADesignedTiltAndEveryGap) {
  Scene scene = test::make_scene(3, {test::make_box("a", {0.1, 0.1, 0.1}, {0.9, 0.9, 0.4}),
                                     test::make_box("b", {0.1, 0.1, 0.41}, {0.9, 0.9, 0.6})});
  // b's bottom face tilted by 1e-5 about x.
  for (Vec3& v : scene.objects[1].vertices)
    if (v.z < 0.5) v.z += 1e-5 * (v.y - 0.1);
  turn(scene);
  test::round_to_float32(scene);
  auto bottom_tilt = [](const Scene& s) {
    // The largest angle between a's top triangles and b's bottom triangles (normals opposed).
    double tilt = 0;
    for (const Simplex& t : s.objects[0].simplices)
      for (const Simplex& u : s.objects[1].simplices) {
        const Vec3 n = unit_normal(s.objects[0], t), m = unit_normal(s.objects[1], u);
        if (dot(n, m) < -0.99) tilt = std::max(tilt, norm(cross(n, m)));
      }
    return tilt;
  };
  const double before = bottom_tilt(scene);
  ASSERT_NEAR(before, 1e-5, 2e-6);
  snap_rounded_faces(scene);
  EXPECT_NEAR(bottom_tilt(scene), before, 1e-6);

  // Boxes 3 roundings apart (1.8e-7 at coordinates near 0.9... rounding ~6e-8): the facing
  // vertices may move by at most 1 % of that, so the gap changes by less than 2 %.
  Scene tight = test::make_scene(3, {test::make_box("a", {0.1, 0.1, 0.1}, {0.9, 0.9, 0.4}),
                                     test::make_box("b", {0.2, 0.2, 0.4}, {0.8, 0.8, 0.6})});
  turn(tight);
  test::round_to_float32(tight);
  const double rounding = std::ldexp(largest_coordinate(tight), -24);
  for (Vec3& v : tight.objects[1].vertices)
    v = v + test::rotate({0, 0, 3 * rounding}, kAxis, kAngle);
  test::round_to_float32(tight);
  const double gap = test::min_distance_3d(tight.objects[0], tight.objects[1]);
  ASSERT_GT(gap, rounding);
  const FaceSnap snap = snap_rounded_faces(tight);
  EXPECT_GT(snap.refused, 0u);
  EXPECT_NEAR(test::min_distance_3d(tight.objects[0], tight.objects[1]), gap, 0.02 * gap);
}

}  // namespace gvd
