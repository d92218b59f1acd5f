// Collision-free exploded views (GvdIndex::explode) against an oracle of their own: every
// pair of moved objects measured by brute force (test::min_distance_2d / _3d, every triangle
// or segment pair near each other) at sampled times of the motion, on the bundled scenes, an
// anchor that surrounds its objects, and a scene whose paper displacements collide.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "gvd/pipeline/pipeline.h"
#include "gvd/query/gvd_index.h"
#include "gvd/scene/load_scene.h"
#include "support/scenes.h"
#include "support/thin_gap_scenes.h"

namespace gvd {
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
/// and must be apart afterwards. Also checks each displacement against its factor.
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

std::vector<Vec3> displacements(const ExplodedView& view) {
  std::vector<Vec3> out;
  for (const ExplodedObject& o : view.objects) out.push_back(o.displacement);
  return out;
}

/// The paper's displacements, before any were held back.
std::vector<Vec3> paper_displacements(const ExplodedView& view) {
  std::vector<Vec3> out;
  for (const ExplodedObject& o : view.objects)
    out.push_back(o.ring > 0 ? o.direction * (view.scale * o.ring) : Vec3{});
  return out;
}

void expect_factors(const ExplodedView& view) {
  for (const ExplodedObject& o : view.objects) {
    const bool allowed = o.factor == 1 || o.factor == 0.5 || o.factor == 0.25 ||
                         o.factor == 0.125 || o.factor == 0.0625 || o.factor == 0;
    EXPECT_TRUE(allowed) << "object " << o.object << " factor " << o.factor;
    const Vec3 want = o.ring > 0 ? o.direction * (o.factor * view.scale * o.ring) : Vec3{};
    EXPECT_NEAR(dist(o.displacement, want), 0, 1e-12 * (1 + view.scale));
  }
}

// The README's example: the balls on their plate, anchored on the plate. The paper's
// directions lean inwards (the balls' cells are cut by their neighbours' on the inner side),
// so at full explode ball pairs overlap; held back, no pair comes closer than it must at any
// of 40 sampled times. Likewise the two gears in their frame.
TEST(Explode, BundledScenesNeverCollide) {
  for (const char* name : {"balls_on_plate", "gears2d"}) {
    SCOPED_TRACE(name);
    const std::string path[] = {std::string(GVD_TEST_DATA_DIR) + "/scenes/" + name + ".json"};
    const GvdIndex index = index_of(load_scene(path));
    const ObjectId anchor = index.object(std::string(name) == "gears2d" ? "frame" : "plate");
    const ExplodedView view = index.explode(anchor);
    expect_factors(view);
    EXPECT_GE(worst_keep_ratio(index, view, displacements(view), 40), 1 - 1e-9);
    if (std::string(name) == "balls_on_plate") {
      // The oracle sees the paper's collision, and the held-back view still moves.
      EXPECT_LT(worst_keep_ratio(index, view, paper_displacements(view), 40), 0.5);
      double moved_most = 0;
      for (const ExplodedObject& o : view.objects) moved_most = std::max(moved_most, o.factor);
      EXPECT_EQ(moved_most, 1.0);
    }
  }
}

// An anchor that surrounds its objects: four spheres in an open-topped box (five slabs, one
// object). Nothing collides with the box or with another sphere at any sampled time, and the
// spheres do move (up, out of the box).
TEST(Explode, ObjectsInsideASurroundingAnchorNeverCollide) {
  SceneObject box = test::make_box("box", {-2, -2, -0.2}, {2, 2, 0});
  for (const auto& [lo, hi] :
       std::vector<std::pair<Vec3, Vec3>>{{{-2.2, -2, -0.2}, {-2, 2, 1.5}},
                                          {{2, -2, -0.2}, {2.2, 2, 1.5}},
                                          {{-2.2, -2.2, -0.2}, {2.2, -2, 1.5}},
                                          {{-2.2, 2, -0.2}, {2.2, 2.2, 1.5}}}) {
    const SceneObject wall = test::make_box("wall", lo, hi);
    const auto base = static_cast<uint32_t>(box.vertices.size());
    box.vertices.insert(box.vertices.end(), wall.vertices.begin(), wall.vertices.end());
    for (Simplex s : wall.simplices) {
      for (uint32_t& v : s.v) v += base;
      box.simplices.push_back(s);
    }
  }
  std::vector<SceneObject> objects{box};
  for (int i = 0; i < 4; ++i) {
    const Vec3 c{i % 2 == 0 ? -0.9 : 0.9, i < 2 ? -0.9 : 0.9, 0.85};
    objects.push_back(test::make_sphere("ball_" + std::to_string(i), c, 0.8, 8, 16));
  }
  const GvdIndex index = index_of(test::make_scene(3, objects));
  const ExplodedView view = index.explode(index.object("box"));
  expect_factors(view);
  EXPECT_GE(worst_keep_ratio(index, view, displacements(view), 40), 1 - 1e-9);
  int moving = 0;
  for (const ExplodedObject& o : view.objects) moving += norm(o.displacement) > 0;
  EXPECT_GT(moving, 0);
}

}  // namespace
}  // namespace gvd
