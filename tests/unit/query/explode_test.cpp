// Collision-free exploded views (GvdIndex::explode) against an oracle of their own: every
// pair of moved objects measured by brute force (test::min_distance_2d / _3d, every triangle
// or segment pair near each other) at sampled times of the motion, on the bundled scenes, an
// anchor that surrounds its objects, and a scene whose paper displacements collide.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "gvd/pipeline/pipeline.h"
#include "gvd/query/explode_motion.h"
#include "gvd/query/gvd_index.h"
#include "gvd/scene/load_scene.h"
#include "support/scenes.h"
#include "support/thin_gap_scenes.h"

namespace gvd {

using namespace gvd::scene;
using namespace gvd::result;
using namespace gvd::query;
using namespace gvd::pipeline;

namespace {

GvdIndex index_of(Scene scene) {
  return GvdIndex(std::make_shared<const GvdResult>(compute_gvd(std::move(scene))));
}

SceneObject moved(const SceneObject& o, Vec3 by) {
  SceneObject m = o;
  for (Vec3& v : m.vertices) v = v + by;
  return m;
}

double distance(int dimension, const SceneObject& a, const SceneObject& b) {
  return dimension == 2 ? test::min_distance_2d(a, b) : test::min_distance_3d(a, b);
}

/// The least, over sampled times t = k / samples and pairs, of (distance at t) / (what the
/// pair must keep: half of min(gap at 0, scale)); pairs that touch at 0 are skipped at t = 0
/// and must be apart afterwards.
double worst_keep_ratio(const GvdIndex& index, const ExplodedView& view,
                        const std::vector<Vec3>& displacement, int samples) {
  const Scene& scene = index.result().scene;
  const size_t n = scene.objects.size();
  double worst = 1e300;
  for (size_t a = 0; a < n; ++a) {
    for (size_t b = a + 1; b < n; ++b) {
      const double gap = distance(scene.dimension, scene.objects[a], scene.objects[b]);
      const double keep = 0.5 * std::min(gap, view.scale);
      for (int k = 1; k <= samples; ++k) {
        const double t = double(k) / samples;
        const double d = distance(scene.dimension, moved(scene.objects[a], displacement[a] * t),
                                  moved(scene.objects[b], displacement[b] * t));
        worst = std::min(worst, keep > 0 ? d / keep : (d > 0 ? 1e300 : 0.0));
      }
    }
  }
  return worst;
}

/// The least, over sampled times and pairs of objects that are not neighbours in the dual
/// graph, of (distance at t) - (distance at 0): never below 0 when no such pair approaches
/// (explode allows them 1 % of the scale: kExplodeSlack).
double worst_non_neighbour_approach(const GvdIndex& index, const ExplodedView& view, int samples) {
  const Scene& scene = index.result().scene;
  const size_t n = scene.objects.size();
  double worst = 1e300;
  for (size_t a = 0; a < n; ++a) {
    std::vector<bool> neighbour(n, false);
    for (const RingNeighbor& r : index.neighbors(static_cast<ObjectId>(a), 1))
      neighbour[r.object] = true;
    for (size_t b = a + 1; b < n; ++b) {
      if (neighbour[b]) continue;
      const double gap = distance(scene.dimension, scene.objects[a], scene.objects[b]);
      for (int k = 1; k <= samples; ++k) {
        const double t = double(k) / samples;
        const double d =
            distance(scene.dimension, moved(scene.objects[a], view.objects[a].displacement * t),
                     moved(scene.objects[b], view.objects[b].displacement * t));
        worst = std::min(worst, d - gap);
      }
    }
  }
  return worst;
}

std::vector<Vec3> displacements(const ExplodedView& view) {
  std::vector<Vec3> out;
  for (const ExplodedObject& o : view.objects) out.push_back(o.displacement);
  return out;
}

void expect_factors(const ExplodedView& view) {
  for (const ExplodedObject& o : view.objects) {
    EXPECT_TRUE(o.factor >= 0 && o.factor <= 1) << "object " << o.object << " factor " << o.factor;
    EXPECT_LE(norm(o.direction), 1 + 1e-9) << "object " << o.object;
    const Vec3 want = o.ring > 0 ? o.direction * (o.factor * view.scale * o.ring) : Vec3{};
    EXPECT_NEAR(dist(o.displacement, want), 0, 1e-12 * (1 + view.scale));
  }
}

// ExplodeMotion on two unit cubes 1 apart along x (neighbours; margin 0.25, so each must keep
// 0.125 from the other): the largest share of a displacement is certified by conservative
// advancement on exact distances and, for a pair moving apart, by the gap along the closest
// pair's direction, which changes linearly. Approaching, the share stops short of the bound
// (0.875 of the gap may go); moving apart or sliding past, all of it is kept; against a
// committed motion, what that motion took is taken into account.
TEST(ExplodeMotion, SharesKeepTheBoundAgainstApproachingAndCommittedMotions) {
  const GvdIndex index = index_of(test::make_scene(
      3, {test::make_box("a", {0, 0, 0}, {1, 1, 1}), test::make_box("b", {2, 0, 0}, {3, 1, 1})}));
  const GvdResult& r = index.result();
  auto motion = [&] { return ExplodeMotion(r.geometry, index.bvh(), r.domain, r.graph, 0.25); };
  const double room = 1 - 0.125;  // what a may close of the gap
  {
    ExplodeMotion m = motion();
    const double share = m.largest_share(0, {3, 0, 0});  // straight at b
    EXPECT_LE(3 * share, room * (1 + 1e-9));
    EXPECT_GE(3 * share, 0.75 * room);                // the bisection gets near it
    EXPECT_EQ(m.largest_share(0, {-3, 0, 0}), 1.0);   // away from b
    EXPECT_EQ(m.largest_share(0, {0, 3, 0}), 1.0);    // past b at the same distance
    EXPECT_EQ(m.largest_share(1, {3, 0.5, 0}), 1.0);  // b away from a
  }
  {
    ExplodeMotion m = motion();
    m.commit(1, {-0.5, 0, 0});  // b comes half the way
    const double share = m.largest_share(0, {1, 0, 0});
    EXPECT_LE(0.5 + share, room * (1 + 1e-9));
    EXPECT_GE(0.5 + share, 0.5 + 0.75 * (room - 0.5));
    EXPECT_EQ(m.largest_share(0, {-1, 0, 0}), 1.0);  // a gets out of its way
  }
}

// The README's example: the balls on their plate, anchored on the plate, and the two gears
// in their frame. The paper's directions lean inwards (the balls' cells are cut by their
// neighbours' on the inner side; the gears' point at each other), so at full explode ball pairs
// overlapped and the gears were held still. No pair comes closer than it must at any of 40
// sampled times, non-neighbours not at all, and the balls lift off their plate visibly.
TEST(Explode, BundledScenesNeverCollide) {
  for (const char* name : {"balls_on_plate", "gears2d"}) {
    SCOPED_TRACE(name);
    const std::string path[] = {std::string(GVD_TEST_DATA_DIR) + "/scenes/" + name + ".json"};
    const GvdIndex index = index_of(load_scene(path));
    const ObjectId anchor = index.object(std::string(name) == "gears2d" ? "frame" : "plate");
    const ExplodedView view = index.explode(anchor);
    expect_factors(view);
    EXPECT_GE(worst_keep_ratio(index, view, displacements(view), 40), 1 - 1e-9);
    EXPECT_GE(worst_non_neighbour_approach(index, view, 40), -0.01 * view.scale);
    EXPECT_GE(worst_non_neighbour_approach(index, view, 40), -0.01 * view.scale);
    if (std::string(name) == "balls_on_plate") {
      for (const ExplodedObject& o : view.objects) {
        if (o.object == anchor) continue;
        EXPECT_GE(o.displacement.z, 0.25 * view.scale) << "object " << o.object;
      }
    }
  }
}

/// One object made of several closed parts (the slabs of a box, a shell's two surfaces).
SceneObject joined(const std::string& label, const std::vector<SceneObject>& parts) {
  SceneObject out;
  out.label = label;
  for (const SceneObject& part : parts) {
    const auto base = static_cast<uint32_t>(out.vertices.size());
    out.vertices.insert(out.vertices.end(), part.vertices.begin(), part.vertices.end());
    for (Simplex s : part.simplices) {
      for (uint32_t& v : s.v) v += base;
      out.simplices.push_back(s);
    }
  }
  return out;
}

/// An open-topped box: a floor [-2, 2]^2 x [-0.2, 0] and four walls up to z = 1.5.
SceneObject open_box(const std::string& label) {
  std::vector<SceneObject> parts{test::make_box("floor", {-2, -2, -0.2}, {2, 2, 0})};
  for (const auto& [lo, hi] :
       std::vector<std::pair<Vec3, Vec3>>{{{-2.2, -2, -0.2}, {-2, 2, 1.5}},
                                          {{2, -2, -0.2}, {2.2, 2, 1.5}},
                                          {{-2.2, -2.2, -0.2}, {2.2, -2, 1.5}},
                                          {{-2.2, 2, -0.2}, {2.2, 2.2, 1.5}}}) {
    parts.push_back(test::make_box("wall", lo, hi));
  }
  return joined(label, parts);
}

/// A closed hollow cube: outer [-h - 0.3, h + 0.3]^3, cavity [-h, h]^3 (inward triangles).
SceneObject closed_shell(const std::string& label, double h) {
  SceneObject inner = test::make_box("cavity", {-h, -h, -h}, {h, h, h});
  for (Simplex& s : inner.simplices) std::swap(s.v[1], s.v[2]);
  const double o = h + 0.3;
  return joined(label, {test::make_box("outer", {-o, -o, -o}, {o, o, o}), inner});
}

/// Four spheres of radius 0.8 on a 2 x 2 grid (0.2 apart) centred on x = y = 0, at height z.
std::vector<SceneObject> four_balls(double z) {
  std::vector<SceneObject> balls;
  for (int i = 0; i < 4; ++i) {
    const Vec3 c{i % 2 == 0 ? -0.9 : 0.9, i < 2 ? -0.9 : 0.9, z};
    balls.push_back(test::make_sphere("ball_" + std::to_string(i), c, 0.8, 8, 16));
  }
  return balls;
}

/// The non-anchor objects move visibly and apart: each by at least `least` (user units), and
/// every pair of them ends farther apart than it began.
void expect_moved_apart(const GvdIndex& index, const ExplodedView& view, double least) {
  const Scene& scene = index.result().scene;
  for (const ExplodedObject& o : view.objects) {
    if (o.object == view.anchor) continue;
    EXPECT_GE(norm(o.displacement), least) << scene.objects[o.object].label;
  }
  for (size_t a = 0; a < scene.objects.size(); ++a) {
    for (size_t b = a + 1; b < scene.objects.size(); ++b) {
      if (a == view.anchor || b == view.anchor) continue;
      const double before = distance(scene.dimension, scene.objects[a], scene.objects[b]);
      const double after =
          distance(scene.dimension, moved(scene.objects[a], view.objects[a].displacement),
                   moved(scene.objects[b], view.objects[b].displacement));
      EXPECT_GT(after, before) << scene.objects[a].label << " - " << scene.objects[b].label;
    }
  }
}

// An anchor that surrounds its objects: four spheres in an open-topped box (five slabs, one
// object). Nothing collides with the box or with another sphere at any sampled time, and every
// sphere comes up, out through the opening, by a visible share of the scale.
TEST(Explode, ObjectsInsideASurroundingAnchorNeverCollide) {
  std::vector<SceneObject> objects{open_box("box")};
  for (SceneObject& ball : four_balls(0.85)) objects.push_back(std::move(ball));
  const GvdIndex index = index_of(test::make_scene(3, objects));
  const ExplodedView view = index.explode(index.object("box"));
  expect_factors(view);
  EXPECT_GE(worst_keep_ratio(index, view, displacements(view), 40), 1 - 1e-9);
  EXPECT_GE(worst_non_neighbour_approach(index, view, 40), -0.01 * view.scale);
  for (const ExplodedObject& o : view.objects) {
    if (o.object == view.anchor) continue;
    EXPECT_GE(o.displacement.z, 0.25 * view.scale) << "ball " << o.object << " not lifted";
  }
}

// Regression: the gears in their closed frame (gears2d) were held still, the paper's
// directions pointing at each other. They have room only inside the frame: each must use at
// least a quarter of its gap to the frame (the rule lets it take half), and the two must end
// farther apart; nothing collides on the way.
TEST(Explode, GearsInTheirFrameMoveApart) {
  const std::string path[] = {std::string(GVD_TEST_DATA_DIR) + "/scenes/gears2d.json"};
  const GvdIndex index = index_of(load_scene(path));
  const ExplodedView view = index.explode(index.object("frame"));
  expect_factors(view);
  EXPECT_GE(worst_keep_ratio(index, view, displacements(view), 40), 1 - 1e-9);
  EXPECT_GE(worst_non_neighbour_approach(index, view, 40), -0.01 * view.scale);
  const Scene& scene = index.result().scene;
  const SceneObject& frame = scene.objects[index.object("frame")];
  double least = 1e300;
  for (const char* gear : {"gear_a", "gear_b"})
    least = std::min(least, test::min_distance_2d(scene.objects[index.object(gear)], frame));
  ASSERT_GT(least, 0);
  expect_moved_apart(index, view, 0.25 * least);
}

// Objects inside a closed shell cannot leave it; with room in the cavity they spread apart
// (the paper's directions point inwards, at each other) by a visible share of the scale.
TEST(Explode, ObjectsInsideAClosedShellMoveApart) {
  std::vector<SceneObject> objects{closed_shell("shell", 3)};
  for (SceneObject& ball : four_balls(0)) objects.push_back(std::move(ball));
  const GvdIndex index = index_of(test::make_scene(3, objects));
  const ExplodedView view = index.explode(index.object("shell"));
  expect_factors(view);
  EXPECT_GE(worst_keep_ratio(index, view, displacements(view), 40), 1 - 1e-9);
  EXPECT_GE(worst_non_neighbour_approach(index, view, 40), -0.01 * view.scale);
  expect_moved_apart(index, view, 0.25 * view.scale);
}

// Nested: the open box with its balls inside a closed shell, anchored on the shell. The box
// stands on nothing but the shell's cavity; whatever moves, nothing collides, and the balls
// still come apart.
TEST(Explode, NestedSurroundingAnchorsNeverCollide) {
  std::vector<SceneObject> objects{closed_shell("shell", 3.5), open_box("box")};
  for (SceneObject& ball : four_balls(0.85)) objects.push_back(std::move(ball));
  const GvdIndex index = index_of(test::make_scene(3, objects));
  const ExplodedView view = index.explode(index.object("shell"));
  expect_factors(view);
  EXPECT_GE(worst_keep_ratio(index, view, displacements(view), 40), 1 - 1e-9);
  EXPECT_GE(worst_non_neighbour_approach(index, view, 40), -0.01 * view.scale);
  const Scene& scene = index.result().scene;
  for (uint32_t a = 2; a < scene.objects.size(); ++a) {
    EXPECT_GT(norm(view.objects[a].displacement), 0.1 * view.scale) << scene.objects[a].label;
  }
}

}  // namespace
}  // namespace gvd
