// GvdIndex against brute force and analytic answers: nearest object, k-rings, roadmap paths,
// exploded views and the clearance report.
#include "gvd/query/gvd_index.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <set>
#include <thread>

#include "gvd/common/error.h"
#include "gvd/io/result_file.h"
#include "gvd/io/write_outputs.h"
#include "gvd/pipeline/pipeline.h"
#include "support/gltf_validate.h"
#include "support/grid_oracle.h"
#include "support/oracles.h"
#include "support/scenes.h"

namespace gvd {

using namespace gvd::scene;
using namespace gvd::result;
using namespace gvd::query;
using namespace gvd::io;
using namespace gvd::pipeline;

namespace {

std::shared_ptr<const GvdResult> run(Scene scene) {
  PipelineOptions o;
  o.threads = 2;
  return std::make_shared<const GvdResult>(compute_gvd(std::move(scene), o));
}

double leaf_diagonal(const GvdResult& r, Vec3 p) {
  const uint32_t leaf = r.octree.locate(r.domain.to_unit(p));
  return std::ldexp(r.domain.side, -r.octree.level[leaf]) * std::sqrt(r.scene.dimension);
}

Vec3 random_point(const GvdResult& r, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const Box box = r.domain.box();
  Vec3 p;
  for (int a = 0; a < r.scene.dimension; ++a) p[a] = box.lo[a] + u(rng) * (box.hi[a] - box.lo[a]);
  return p;
}

// Nearest answers against brute force at `points` (random ones when empty). By default
// exact: the distance is the true one and the object the true nearest (or one tied with it
// to 1e-12). Fast: the reported distance is measured to a point on the reported object, so
// it is never below the true distance, and within the 3/2 factor in leaves that hold an
// object; the object is the true nearest one except where another is within the local cell
// size.
void expect_nearest_matches_brute_force(const GvdIndex& index, int samples, bool fast,
                                        std::vector<Vec3> points = {}) {
  const GvdResult& r = index.result();
  std::mt19937 rng(7);
  if (points.empty())
    for (int i = 0; i < samples; ++i) points.push_back(random_point(r, rng));
  int differ = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    const Vec3 p = points[i];
    const NearestAnswer a = index.nearest(p, fast);
    const test::NearestAnswer truth = test::brute_nearest(r.scene, p);
    ASSERT_LT(a.object, r.scene.objects.size());
    EXPECT_GE(a.distance, truth.distance * (1 - 1e-9) - 1e-12) << "point " << i;
    const double own = test::brute_distance(r.scene, a.object, p);
    EXPECT_LE(own, a.distance * (1 + 1e-9) + 1e-12) << "the closest point lies on the object";
    if (!fast) {
      EXPECT_TRUE(a.exact) << "point " << i;
      EXPECT_NEAR(a.distance, truth.distance, 1e-12 * (1 + truth.distance)) << "point " << i;
      EXPECT_NEAR(own, truth.distance, 1e-12 * (1 + truth.distance))
          << "point " << i << ": " << r.scene.objects[a.object].label << " is not the nearest, "
          << r.scene.objects[truth.object].label << " is";
      continue;
    }
    // Within 3/2 wherever the leaf's corners prove it; the paper's rule alone in empty leaves
    // (only conjectured within 3/2 there, and not at every point: up to ~2.9 measured).
    const uint32_t leaf = r.octree.locate(r.domain.to_unit(p));
    if (r.octree.object[leaf] != scene::kNoObject) {
      EXPECT_LE(a.distance, 1.5 * truth.distance + 1e-12) << "point " << i;
    }
    if (a.object != truth.object) {
      ++differ;
      EXPECT_LE(own - truth.distance, leaf_diagonal(r, p)) << "point " << i;
    }
  }
  EXPECT_LE(differ, static_cast<int>(points.size()) / 50)
      << differ << " of " << points.size() << " answers differ";
}

TEST(GvdIndexNearest, AgreesWithBruteForce3d) {
  std::vector<SceneObject> objects;
  objects.push_back(test::make_sphere("a", {0, 0, 0}, 1.0));
  objects.push_back(test::make_sphere("b", {2.3, 0.2, 0}, 1.0));
  objects.push_back(test::make_box("c", {-1, 1.2, -1}, {3, 1.5, 1}));
  objects.push_back(test::make_sphere("d", {1.1, -1.9, 0.5}, 0.7));
  const GvdIndex index(run(test::make_scene(3, std::move(objects))));
  for (const bool fast : {false, true}) expect_nearest_matches_brute_force(index, 1500, fast);
}

// Four balls at the corners of a square and a plate below (the bundled balls_on_plate's
// layout): above the middle of the square all four are nearly equally near, and the leaves
// there hold candidates of all of them. The default answer is exact there too (the fast one
// picked a ball 2.4e-4 of the distance too far at such a point: more objects in the leaf than
// its close-call test looked at).
TEST(GvdIndexNearest, ExactWhereFourObjectsMeet3d) {
  std::vector<SceneObject> objects;
  const double r = 0.5;
  for (const Vec3& c :
       {Vec3{0, 0, r}, Vec3{0, 1.0005, r}, Vec3{1.002, 0, r}, Vec3{1.002, 1.0005, r}})
    objects.push_back(test::make_sphere("ball", c, r));
  objects.push_back(test::make_box("plate", {-0.6, -0.6, -0.1}, {1.6, 1.6, -0.001}));
  for (size_t i = 0; i < 4; ++i) objects[i].label += "_" + std::to_string(i);
  const GvdIndex index(run(test::make_scene(3, std::move(objects))));
  std::vector<Vec3> line;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> jitter(-1e-3, 1e-3);
  for (int k = 0; k <= 400; ++k)
    line.push_back({0.501 + jitter(rng), 0.50025 + jitter(rng), 0.55 + 0.7 * k / 400.0});
  expect_nearest_matches_brute_force(index, 0, false, line);
}

TEST(GvdIndexNearest, AgreesWithBruteForce2d) {
  std::vector<SceneObject> objects;
  objects.push_back(test::make_gear2d("g1", {0, 0, 0}, 0.8, 1.0, 12, 0.0));
  objects.push_back(test::make_gear2d("g2", {2.02, 0, 0}, 0.8, 1.0, 12, 0.26));
  objects.push_back(test::make_circle("c", {1, 1.6, 0}, 0.4));
  objects.push_back(test::make_rect("r", {-1, -1.6, 0}, {3, -1.3, 0}));
  const GvdIndex index(run(test::make_scene(2, std::move(objects))));
  for (const bool fast : {false, true}) expect_nearest_matches_brute_force(index, 3000, fast);
}

TEST(GvdIndexNearest, PointsOutsideTheDomainAreAnError) {
  const GvdIndex index(run(test::make_scene(
      3, {test::make_sphere("a", {0, 0, 0}, 1), test::make_sphere("b", {3, 0, 0}, 1)})));
  const Box box = index.result().domain.box();
  EXPECT_NO_THROW(index.nearest(box.hi));  // the closed domain includes its faces
  EXPECT_NO_THROW(index.nearest(box.lo));
  try {
    index.nearest({box.hi.x + 1e-9 * (box.hi.x - box.lo.x), 0, 0});
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kOutsideDomain);
    EXPECT_NE(e.detail().find("outside the domain"), std::string::npos) << e.detail();
  }
  EXPECT_THROW(index.nearest({NAN, 0, 0}), Error);
}

TEST(GvdIndexNearest, SameAnswersFromSavedResultAndFromManyThreads) {
  std::shared_ptr<const GvdResult> result = run(test::make_scene(
      3, {test::make_sphere("a", {0, 0, 0}, 1), test::make_sphere("b", {2.2, 0, 0}, 1),
          test::make_box("c", {-1, -2, -1}, {3, -1.5, 1})}));
  const GvdIndex index(result);
  const GvdIndex loaded(
      std::make_shared<const GvdResult>(load_result_bytes(result_to_bytes(*result))));
  std::mt19937 rng(3);
  std::vector<Vec3> points;
  for (int i = 0; i < 2000; ++i) points.push_back(random_point(*result, rng));
  std::vector<NearestAnswer> expected;
  for (const Vec3& p : points) expected.push_back(index.nearest(p));
  for (size_t i = 0; i < points.size(); ++i) {
    const NearestAnswer a = loaded.nearest(points[i]);
    EXPECT_EQ(a.object, expected[i].object);
    EXPECT_DOUBLE_EQ(a.distance, expected[i].distance);
  }
  // A fresh index, so that the four threads' first queries race to build its tables.
  const GvdIndex fresh(result);
  std::vector<int> mismatches(4, 0);
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&, t] {
      for (size_t i = static_cast<size_t>(t); i < points.size(); i += 2) {
        const NearestAnswer a = fresh.nearest(points[i]);
        if (a.object != expected[i].object || a.distance != expected[i].distance) ++mismatches[t];
      }
    });
  }
  for (std::thread& th : threads) th.join();
  for (int m : mismatches) EXPECT_EQ(m, 0);
}

// Signed answers against the winding-number oracle (grid_oracle.h: solid angles in 3D,
// turning angles in 2D): a closed object says whether the point is inside it, with the
// distance negative there; an open one has no inside (-1). `extra` points lie exactly on the
// rows of the objects' vertices, where the ray of the parity test runs along edges and
// through vertices.
void expect_signs_match_winding_numbers(const GvdIndex& index, int samples,
                                        const std::vector<Vec3>& extra) {
  const GvdResult& r = index.result();
  std::mt19937 rng(11);
  std::vector<Vec3> points = extra;
  for (int i = 0; i < samples; ++i) points.push_back(random_point(r, rng));
  int inside = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    const Vec3 p = points[i];
    for (const bool fast : {false, true}) {
      const NearestAnswer a = index.nearest(p, fast);
      const SceneObject& object = r.scene.objects[a.object];
      if (!is_closed_object(object, r.scene.dimension)) {
        EXPECT_FALSE(index.is_closed(a.object));
        EXPECT_EQ(a.inside, -1) << "point " << i;
        EXPECT_EQ(a.signed_distance(), a.distance);
        continue;
      }
      EXPECT_TRUE(index.is_closed(a.object));
      ASSERT_NE(a.inside, -1) << "point " << i;
      // On the surface (within rounding) both answers are right.
      if (a.distance < 1e-9 * r.domain.side) continue;
      const bool truth = test::oracle_inside(object, r.scene.dimension, p);
      EXPECT_EQ(a.inside == 1, truth) << "point " << i << " (" << p.x << ", " << p.y << ", " << p.z
                                      << ") object " << object.label;
      EXPECT_EQ(a.signed_distance(), truth ? -a.distance : a.distance);
      inside += truth && !fast;
    }
  }
  EXPECT_GT(inside, samples / 50) << "the samples should reach inside the objects";
}

/// Points on the rows (3D: same y and z; 2D: same y) of every vertex of the scene, at
/// x positions inside and outside the objects.
std::vector<Vec3> vertex_rows(const GvdResult& r) {
  std::vector<Vec3> out;
  const Box box = r.domain.box();
  for (const SceneObject& o : r.scene.objects) {
    for (const Vec3& v : o.vertices) {
      for (const double t : {0.1, 0.37, 0.5, 0.81}) {
        Vec3 p = v;
        p.x = box.lo.x + t * (box.hi.x - box.lo.x);
        out.push_back(p);
      }
    }
  }
  return out;
}

TEST(GvdIndexNearest, InsideAndSignedDistanceMatchWindingNumbers3d) {
  std::vector<SceneObject> objects;
  objects.push_back(test::make_sphere("ball", {0, 0, 0}, 1.0));
  objects.push_back(test::make_box("box", {1.3, -0.5, -0.5}, {2.3, 0.5, 0.5}));
  // A box turned about a skew axis (the domain frame stays the world's: several directions).
  SceneObject turned = test::make_box("turned", {-0.4, -0.4, -0.4}, {0.4, 0.4, 0.4});
  for (Vec3& v : turned.vertices)
    v = test::rotate(v, Vec3{1, 2, 3} * (1 / std::sqrt(14.0)), 0.7) + Vec3{0, 2, 0};
  objects.push_back(std::move(turned));
  // An open sheet: two triangles, no inside.
  SceneObject sheet;
  sheet.label = "sheet";
  sheet.vertices = {{-1, -1.5, -1}, {1, -1.5, -1}, {1, -1.5, 1}, {-1, -1.5, 1}};
  sheet.simplices = {Simplex{{0, 1, 2}}, Simplex{{0, 2, 3}}};
  objects.push_back(std::move(sheet));
  const auto result = run(test::make_scene(3, std::move(objects)));
  const GvdIndex index(result);
  expect_signs_match_winding_numbers(index, 1500, vertex_rows(*result));
}

TEST(GvdIndexNearest, InsideAndSignedDistanceMatchWindingNumbers2d) {
  std::vector<SceneObject> objects;
  objects.push_back(test::make_gear2d("gear", {0, 0, 0}, 0.8, 1.0, 12, 0.0));
  objects.push_back(test::make_rect("rect", {1.3, -0.5, 0}, {2.3, 0.5, 0}));
  objects.push_back(test::make_circle("circle", {0, 1.8, 0}, 0.5, 7));
  objects.push_back(test::make_segment("wire", {-1, -1.4, 0}, {1.5, -1.2, 0}));
  const auto result = run(test::make_scene(2, std::move(objects)));
  const GvdIndex index(result);
  expect_signs_match_winding_numbers(index, 3000, vertex_rows(*result));
}

TEST(GvdIndexNeighbors, TwoObjectsAreEachOthersOneRing) {
  const GvdIndex spheres(run(test::make_scene(
      3, {test::make_sphere("a", {0, 0, 0}, 1), test::make_sphere("b", {3, 0, 0}, 1)})));
  const std::vector<RingNeighbor> s = spheres.neighbors(spheres.object("a"), 1);
  ASSERT_EQ(s.size(), 1u);
  EXPECT_EQ(s[0].object, spheres.object("b"));
  EXPECT_EQ(s[0].ring, 1);
  EXPECT_EQ(s[0].via, spheres.object("a"));
  EXPECT_EQ(spheres.max_ring(spheres.object("a")), 1);
  EXPECT_THROW(spheres.object("zz"), Error);
  EXPECT_THROW(spheres.neighbors(0, 0), Error);

  // Two equal cubes: the interface is the bisector plane x = 1.55 clipped to the domain square.
  const GvdIndex cubes(run(test::make_scene(3, {test::make_box("a", {0, 0, 0}, {1, 1, 1}),
                                                test::make_box("b", {2.1, 0, 0}, {3.1, 1, 1})})));
  const std::vector<RingNeighbor> c = cubes.neighbors(0, 3);
  ASSERT_EQ(c.size(), 1u);
  const double side = cubes.result().domain.side;
  EXPECT_NEAR(c[0].area, side * side, 1e-5 * side * side);
  EXPECT_NEAR(c[0].min_clearance, 0.55, 1e-6);
  EXPECT_NEAR(c[0].tightest_point.x, 1.55, 1e-6);
}

TEST(GvdIndexNeighbors, RowOfBoxesGrowsOneObjectPerRing) {
  std::vector<SceneObject> boxes;
  for (int i = 0; i < 5; ++i) {
    boxes.push_back(
        test::make_box("box" + std::to_string(i), {2.0 * i, 0, 0}, {2.0 * i + 1, 1, 1}));
  }
  const GvdIndex index(run(test::make_scene(3, std::move(boxes))));
  for (int k = 1; k <= 4; ++k) {
    const std::vector<RingNeighbor> n = index.neighbors(0, k);
    ASSERT_EQ(n.size(), static_cast<size_t>(k)) << "ring " << k;
    for (int i = 0; i < k; ++i) {
      EXPECT_EQ(n[i].object, static_cast<ObjectId>(i + 1));
      EXPECT_EQ(n[i].ring, i + 1);
      EXPECT_EQ(n[i].via, static_cast<ObjectId>(i));
      EXPECT_NEAR(n[i].min_clearance, 0.5, 1e-6);  // half the gap between boxes
    }
  }
  EXPECT_EQ(index.neighbors(0, 99).size(), 4u);
  EXPECT_EQ(index.max_ring(0), 4);
  EXPECT_EQ(index.max_ring(2), 2);
}

// Oracle for a returned path: it starts and ends where asked, no piece touches an object
// (brute force over every simplex), and the reported clearance is not larger than the
// distance to the objects sampled along the polyline.
void expect_valid_path(const GvdResult& r, const PathQuery& q, const PathAnswer& path) {
  ASSERT_TRUE(path.found) << path.reason;
  ASSERT_GE(path.points.size(), 2u);
  EXPECT_EQ(path.points.front(), q.from);
  EXPECT_EQ(path.points.back(), q.to);
  const int dim = r.scene.dimension;
  double length = 0, sampled = 1e300;
  for (size_t i = 0; i + 1 < path.points.size(); ++i) {
    const Vec3 a = path.points[i], b = path.points[i + 1];
    length += dist(a, b);
    for (const SceneObject& o : r.scene.objects) {
      for (const Simplex& s : o.simplices) {
        const bool hit =
            dim == 3 ? test::segment_hits_triangle(a, b, o.vertices[s.v[0]], o.vertices[s.v[1]],
                                                   o.vertices[s.v[2]])
                     : test::segments_intersect_2d(a, b, o.vertices[s.v[0]], o.vertices[s.v[1]]);
        ASSERT_FALSE(hit) << "path piece " << i << " crosses object " << o.label;
      }
    }
    for (int k = 0; k <= 8; ++k) {
      sampled = std::min(sampled, test::brute_nearest(r.scene, a + (b - a) * (k / 8.0)).distance);
    }
  }
  EXPECT_NEAR(path.length, length, 1e-9 * length);
  EXPECT_GT(path.min_clearance, 0);
  EXPECT_LE(path.min_clearance, sampled * (1 + 1e-9));
  EXPECT_GE(path.min_clearance, q.min_clearance);
}

TEST(GvdIndexPath, CorridorBetweenPlatesRunsAlongTheMidPlane) {
  const auto result = run(test::make_scene(3, {test::make_box("bottom", {0, 0, 0}, {4, 4, 0.1}),
                                               test::make_box("top", {0, 0, 1.1}, {4, 4, 1.2})}));
  const GvdIndex index(result);
  PathQuery q;
  q.from = {0.5, 2.0, 0.3};
  q.to = {3.5, 1.0, 0.9};
  q.cost = PathCost::kClearance;
  const PathAnswer path = index.path(q);
  expect_valid_path(*result, q, path);
  ASSERT_GE(path.points.size(), 3u);
  for (size_t i = 1; i + 1 < path.points.size(); ++i) {
    EXPECT_NEAR(path.points[i].z, 0.6, 1e-6) << "point " << i << " is off the mid plane";
  }
  EXPECT_NEAR(path.min_clearance, 0.2, 1e-9);  // the start, 0.2 above the bottom plate

  // The shortest path may cut straight across when nothing is in the way.
  q.cost = PathCost::kShortest;
  const PathAnswer straight = index.path(q);
  expect_valid_path(*result, q, straight);
  EXPECT_NEAR(straight.length, dist(q.from, q.to), 1e-12);

  // A clearance larger than the corridor's half height excludes every passage.
  q.min_clearance = 0.6;
  const PathAnswer none = index.path(q);
  EXPECT_FALSE(none.found);
  EXPECT_TRUE(none.points.empty());
  EXPECT_FALSE(none.reason.empty());
}

TEST(GvdIndexPath, CorridorIn2dRunsAlongTheMidLine) {
  const auto result =
      run(test::make_scene(2, {test::make_rect("lower", {0, 0, 0}, {4, 0.1, 0}),
                               test::make_rect("upper", {0, 1.1, 0}, {4, 1.2, 0})}));
  const GvdIndex index(result);
  PathQuery q;
  q.from = {0.5, 0.25, 0};
  q.to = {3.5, 0.95, 0};
  q.cost = PathCost::kClearance;
  const PathAnswer path = index.path(q);
  expect_valid_path(*result, q, path);
  ASSERT_GE(path.points.size(), 3u);
  for (size_t i = 1; i + 1 < path.points.size(); ++i) {
    EXPECT_NEAR(path.points[i].y, 0.6, 1e-6) << "point " << i;
  }
}

TEST(GvdIndexPath, NoPathOutOfAClosedShell) {
  // A hollow box (outer and inner surface: one closed shell) around a small box.
  SceneObject shell = test::make_box("shell", {0, 0, 0}, {4, 4, 4});
  const SceneObject inner = test::make_box("inner_wall", {0.5, 0.5, 0.5}, {3.5, 3.5, 3.5});
  const auto base = static_cast<uint32_t>(shell.vertices.size());
  shell.vertices.insert(shell.vertices.end(), inner.vertices.begin(), inner.vertices.end());
  for (Simplex s : inner.simplices) {
    for (uint32_t& v : s.v) v += base;
    std::swap(s.v[1], s.v[2]);  // normals into the hollow
    shell.simplices.push_back(s);
  }
  const auto result = run(test::make_scene(
      3, {std::move(shell), test::make_box("core", {1.5, 1.5, 1.5}, {2.5, 2.5, 2.5})}));
  const GvdIndex index(result);
  PathQuery q;
  q.from = {1.0, 2.0, 2.0};  // between the core and the shell
  q.to = {4.1, 2.0, 2.0};    // outside the shell
  const PathAnswer out = index.path(q);
  EXPECT_FALSE(out.found);
  EXPECT_TRUE(out.points.empty());
  EXPECT_FALSE(out.reason.empty());

  q.to = {3.0, 3.0, 1.0};  // elsewhere inside: around the core
  q.cost = PathCost::kClearance;
  expect_valid_path(*result, q, index.path(q));

  q.to = {2.0, 2.0, 2.0};  // inside the core box
  const PathAnswer into = index.path(q);
  EXPECT_FALSE(into.found) << "a closed object's inside is not reachable";
}

TEST(GvdIndexPath, AroundObstaclesIn2d) {
  std::vector<SceneObject> objects;
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 3; ++j) {
      objects.push_back(test::make_circle("c" + std::to_string(i) + std::to_string(j),
                                          {1.0 * i, 1.0 * j + 0.5 * (i % 2), 0}, 0.3));
    }
  }
  const auto result = run(test::make_scene(2, std::move(objects)));
  const GvdIndex index(result);
  for (PathCost cost : {PathCost::kShortest, PathCost::kClearance}) {
    PathQuery q;
    q.from = {-0.45, 0.0, 0};
    q.to = {3.45, 2.0, 0};
    q.cost = cost;
    expect_valid_path(*result, q, index.path(q));
    q.min_clearance = 0.1;
    expect_valid_path(*result, q, index.path(q));
  }
  PathQuery inside;
  inside.from = {0, 0, 0};  // the centre of circle c00: enclosed
  inside.to = {3.45, 2.0, 0};
  EXPECT_FALSE(index.path(inside).found);
}

TEST(GvdIndexExplode, DirectionsFollowTheInterfaceNormals) {
  const GvdIndex index(run(test::make_scene(
      3, {test::make_sphere("a", {0, 0, 0}, 1), test::make_sphere("b", {3, 0, 0}, 1),
          test::make_sphere("c", {6, 0, 0}, 1)})));
  const ExplodedView view = index.explode(index.object("a"));
  ASSERT_EQ(view.objects.size(), 3u);
  EXPECT_EQ(view.objects[0].ring, 0);
  EXPECT_EQ(norm(view.objects[0].displacement), 0.0);
  EXPECT_EQ(view.objects[1].ring, 1);
  EXPECT_EQ(view.objects[2].ring, 2);
  // The interface of two tessellated spheres is nearly the bisector plane: D_1 is nearly its
  // unit normal (+x), and D_2 inherits it.
  for (int o : {1, 2}) {
    EXPECT_NEAR(view.objects[o].direction.x, 1.0, 0.01);
    EXPECT_NEAR(view.objects[o].direction.y, 0.0, 0.01);
    EXPECT_NEAR(view.objects[o].direction.z, 0.0, 0.01);
  }
  EXPECT_GT(view.scale, 0);
  EXPECT_NEAR(view.objects[2].displacement.x, 2 * view.scale * view.objects[2].direction.x, 1e-12);

  const ExplodedView middle = index.explode(index.object("b"), {.scale = 0.5});
  EXPECT_NEAR(middle.objects[0].direction.x, -1.0, 0.01);
  EXPECT_NEAR(middle.objects[2].direction.x, 1.0, 0.01);
  EXPECT_NEAR(middle.objects[2].displacement.x, 0.5 * middle.objects[2].direction.x, 1e-12);

  // Cubes: the interfaces are planes, so D_1 and D_2 are +x (bisector points are placed a
  // hair, 1e-6 of an edge, inside octree edges).
  const GvdIndex cubes(run(test::make_scene(
      3, {test::make_box("a", {0, 0, 0}, {1, 1, 1}), test::make_box("b", {2.1, 0, 0}, {3.1, 1, 1}),
          test::make_box("c", {4.3, 0, 0}, {5.3, 1, 1})})));
  const ExplodedView row = cubes.explode(0);
  for (int o : {1, 2}) {
    EXPECT_NEAR(row.objects[o].direction.x, 1.0, 1e-5);
    EXPECT_NEAR(norm(row.objects[o].direction), 1.0, 1e-5);
  }
}

TEST(GvdIndexExplode, TwoDimensionalNormalsPointAway) {
  const GvdIndex index(run(test::make_scene(
      2, {test::make_circle("hub", {0, 0, 0}, 1), test::make_circle("up", {0, 3, 0}, 1),
          test::make_circle("right", {3, 0, 0}, 1)})));
  const ExplodedView view = index.explode(index.object("hub"));
  const Vec3 up = view.objects[index.object("up")].direction;
  const Vec3 right = view.objects[index.object("right")].direction;
  EXPECT_GT(up.y, 0.9);
  EXPECT_GT(right.x, 0.9);
  EXPECT_LE(norm(up), 1.0 + 1e-12);
}

TEST(GvdIndexExplode, AnimatedGlbMovesEveryObjectAlongItsVector) {
  const GvdIndex index(run(test::make_scene(
      3, {test::make_sphere("a", {0, 0, 0}, 1), test::make_box("b", {1.5, -1, -1}, {2.5, 1, 1}),
          test::make_sphere("c", {0, 2.6, 0}, 1)})));
  const ExplodedView view = index.explode(index.object("a"), {.scale = 0.7});
  std::vector<Vec3> displacement;
  for (const ExplodedObject& o : view.objects) displacement.push_back(o.displacement);
  const std::vector<uint8_t> bytes = exploded_to_glb(index.result().scene, displacement, 3.0);
  const std::string path = std::string(GVD_TEST_OUTPUT_DIR) + "/exploded_three.glb";
  write_file_atomic(path, bytes.data(), bytes.size());
  const test::GltfReport report = test::validate_glb_file(path);
  ASSERT_TRUE(report.ran) << report.output;
  EXPECT_EQ(report.errors, 0) << report.output;

  // An independent read: one node per object, one channel per node whose last keyframe is
  // the displacement (float32) reached at t = 3 s.
  const test::GlbFile glb = test::parse_glb(bytes);
  ASSERT_EQ(glb.json["nodes"].size(), 3u);
  const auto& animation = glb.json["animations"][0];
  ASSERT_EQ(animation["channels"].size(), 3u);
  for (const auto& channel : animation["channels"]) {
    EXPECT_EQ(channel["target"]["path"], "translation");
    const int node = channel["target"]["node"];
    const auto& sampler = animation["samplers"][channel["sampler"].get<int>()];
    const std::vector<double> t = test::read_accessor(glb, sampler["input"]);
    const std::vector<double> x = test::read_accessor(glb, sampler["output"]);
    ASSERT_EQ(t.size(), 2u);
    EXPECT_EQ(t[1], 3.0);
    ASSERT_EQ(x.size(), 6u);
    const std::string label = glb.json["nodes"][node]["name"];
    const Vec3 d = view.objects[index.object(label)].displacement;
    EXPECT_NEAR(x[3], d.x, 1e-6 * (1 + std::abs(d.x)));
    EXPECT_NEAR(x[4], d.y, 1e-6 * (1 + std::abs(d.y)));
    EXPECT_NEAR(x[5], d.z, 1e-6 * (1 + std::abs(d.z)));
  }
  EXPECT_GT(view.objects[index.object("b")].direction.x, 0.9);
  EXPECT_GT(view.objects[index.object("c")].direction.y, 0.9);
}

TEST(GvdIndexJson, PointsAreParsedWithErrorsThatSayWhere) {
  EXPECT_EQ(parse_points_json("[[1,2,3],[4,5,6]]", 3).size(), 2u);
  EXPECT_EQ(parse_points_json(R"({"points":[[1,2]]})", 2)[0].y, 2.0);
  for (const char* bad : {"[[1,2]]", "[[1,2,\"x\"]]", "{\"p\":[]}", "[1,2,3]", "nope"}) {
    try {
      parse_points_json(bad, 3);
      ADD_FAILURE() << bad << " was accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument) << bad;
    }
  }
  try {
    parse_points_json("[[0,0,0],[1,2]]", 3);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(e.detail().find("point 1"), std::string::npos) << e.detail();
  }
}

TEST(GvdIndexTight, ReportsOnlyPairsBelowTheBound) {
  const auto result = run(test::make_scene(
      3, {test::make_sphere("a", {0, 0, 0}, 1), test::make_sphere("b", {2.1, 0, 0}, 1),
          test::make_sphere("c", {5.1, 0, 0}, 1)}));
  const GvdIndex index(result);
  const std::vector<TightSpot> spots = index.tight(0.5);
  ASSERT_EQ(spots.size(), 1u);
  EXPECT_EQ(spots[0].a, 0u);
  EXPECT_EQ(spots[0].b, 1u);
  // The tightest point is (nearly) equidistant from both and as far from them as reported.
  const double da = test::brute_distance(result->scene, 0, spots[0].point);
  const double db = test::brute_distance(result->scene, 1, spots[0].point);
  EXPECT_NEAR(da, spots[0].min_clearance, 1e-6);
  EXPECT_NEAR(db, spots[0].min_clearance, 1e-3);
  EXPECT_LT(spots[0].min_clearance, 0.06);
  EXPECT_EQ(index.tight(10).size(), 2u);
  EXPECT_TRUE(index.tight(0).empty());
  EXPECT_THROW(index.tight(-1), Error);
}

}  // namespace
}  // namespace gvd
