// find_contacts against brute force (every simplex pair of every object pair) and analytic
// answers: which pairs are below the bound, their exact gaps and closest points, the sites of
// their interface, interference depth.
#include "gvd/query/contact_report.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <set>

#include "gvd/common/error.h"
#include "gvd/geometry/primitives.h"
#include "gvd/pipeline/pipeline.h"
#include "support/oracles.h"
#include "support/scenes.h"

namespace gvd {

using namespace gvd::scene;
using namespace gvd::result;
using namespace gvd::query;
using namespace gvd::pipeline;

namespace {

std::shared_ptr<const GvdResult> run(Scene scene) {
  PipelineOptions o;
  o.threads = 2;
  return std::make_shared<const GvdResult>(compute_gvd(std::move(scene), o));
}

/// The least distance between two objects over every pair of their simplices.
double brute_gap(const SceneObject& a, const SceneObject& b, int dim) {
  double best2 = 1e300;
  for (const Simplex& s : a.simplices) {
    const Vec3 o = a.vertices[s.v[0]];  // relative coordinates keep small gaps exact
    for (const Simplex& t : b.simplices) {
      double d2;
      if (dim == 2) {
        d2 = segment_segment_dist2_2d(a.vertices[s.v[0]] - o, a.vertices[s.v[1]] - o,
                                      b.vertices[t.v[0]] - o, b.vertices[t.v[1]] - o);
      } else {
        const Vec3 p[3] = {a.vertices[s.v[0]] - o, a.vertices[s.v[1]] - o, a.vertices[s.v[2]] - o};
        const Vec3 q[3] = {b.vertices[t.v[0]] - o, b.vertices[t.v[1]] - o, b.vertices[t.v[2]] - o};
        d2 = triangle_triangle_dist2(p, q);
      }
      best2 = std::min(best2, d2);
    }
  }
  return std::sqrt(best2);
}

/// The brute-force gap of every pair of objects, a < b.
std::map<std::pair<ObjectId, ObjectId>, double> brute_gaps(const Scene& scene) {
  std::map<std::pair<ObjectId, ObjectId>, double> out;
  for (ObjectId a = 0; a < scene.objects.size(); ++a)
    for (ObjectId b = a + 1; b < scene.objects.size(); ++b)
      out[{a, b}] = brute_gap(scene.objects[a], scene.objects[b], scene.dimension);
  return out;
}

/// Every reported pair and only those: brute-force gaps below the bound (or 0), the same
/// gaps, closest points on their objects and as far apart as the gap.
void expect_pairs_match_brute_force(const GvdIndex& index, double max_gap,
                                    const std::vector<Contact>& contacts,
                                    const std::map<std::pair<ObjectId, ObjectId>, double>& gaps) {
  const Scene& scene = index.result().scene;
  std::set<std::pair<ObjectId, ObjectId>> want, got;
  for (const auto& [pair, g] : gaps)
    if (g < max_gap || g == 0) want.insert(pair);
  for (const Contact& c : contacts) {
    ASSERT_LT(c.a, c.b);
    got.insert({c.a, c.b});
    const double truth = gaps.at({c.a, c.b});
    EXPECT_NEAR(c.gap, truth, 1e-12 + 1e-9 * truth) << c.a << "-" << c.b;
    EXPECT_EQ(c.interference, truth == 0);
    // Pairs that meet report points of two crossing simplices; the others a closest pair.
    if (!c.interference) {
      EXPECT_NEAR(dist(c.on_a, c.on_b), c.gap, 1e-9 * (1 + c.gap));
    }
    EXPECT_LT(test::brute_distance(scene, c.a, c.on_a), 1e-9);
    EXPECT_LT(test::brute_distance(scene, c.b, c.on_b), 1e-9);
    for (const ContactSite& s : c.sites) {
      EXPECT_GT(s.area, 0);
      EXPECT_GE(s.min_gap, c.gap * (1 - 1e-9) - 1e-12);
      EXPECT_LT(s.min_gap, max_gap);
      EXPECT_NEAR(dist(s.on_a, s.on_b), s.min_gap, 1e-9);
    }
  }
  EXPECT_EQ(got, want);
  for (size_t i = 1; i < contacts.size(); ++i) EXPECT_LE(contacts[i - 1].gap, contacts[i].gap);
}

TEST(Contacts, PairsBelowTheBoundMatchBruteForce3d) {
  std::vector<SceneObject> objects;
  objects.push_back(test::make_box("a", {0, 0, 0}, {1, 1, 1}));
  objects.push_back(test::make_box("b", {1.02, 0, 0}, {2, 1, 1}));     // 0.02 from a
  objects.push_back(test::make_box("c", {0, 1.005, 0}, {1, 2, 0.5}));  // 0.005 above a
  objects.push_back(test::make_sphere("d", {1.5, 1.6, 0.5}, 0.45));    // near b and c
  objects.push_back(test::make_sphere("e", {3, 3, 3}, 0.3));           // far from all
  const auto result = run(test::make_scene(3, std::move(objects)));
  const GvdIndex index(result);
  const auto gaps = brute_gaps(result->scene);
  for (const double bound : {0.0, 0.01, 0.03, 0.2, 10.0}) {
    SCOPED_TRACE(bound);
    expect_pairs_match_brute_force(index, bound, find_contacts(index, bound), gaps);
  }
}

TEST(Contacts, PairsBelowTheBoundMatchBruteForce2d) {
  std::vector<SceneObject> objects;
  objects.push_back(test::make_gear2d("g1", {0, 0, 0}, 0.8, 1.0, 12, 0.0));
  objects.push_back(test::make_gear2d("g2", {2.02, 0, 0}, 0.8, 1.0, 12, 0.26));
  objects.push_back(test::make_rect("r", {-1, -1.1, 0}, {3, -1.05, 0}));
  objects.push_back(test::make_circle("c", {1, 1.6, 0}, 0.4));
  const auto result = run(test::make_scene(2, std::move(objects)));
  const GvdIndex index(result);
  const auto gaps = brute_gaps(result->scene);
  for (const double bound : {0.0, 0.04, 0.1, 0.5, 10.0}) {
    SCOPED_TRACE(bound);
    expect_pairs_match_brute_force(index, bound, find_contacts(index, bound), gaps);
  }
}

// Two unit boxes facing each other over a 1 x 1 face at gap g: the interface is the mid-plane
// (mirror symmetry), where the clearance is g/2 over the face and sqrt((g/2)^2 + d^2) at a
// distance d from it; below a bound G it is the face grown by r = sqrt((G/2)^2 - (g/2)^2)
// with round corners: area 1 + 4r + pi r^2, centroid the face's centre.
TEST(Contacts, FacingBoxesHaveOneSiteOfTheGrownFace) {
  const double g = 0.01, bound = 0.06;
  const auto result = run(test::make_scene(3, {test::make_box("a", {0, 0, 0}, {1, 1, 1}),
                                               test::make_box("b", {1 + g, 0, 0}, {2, 1, 1})}));
  const GvdIndex index(result);
  const std::vector<Contact> contacts = find_contacts(index, bound);
  ASSERT_EQ(contacts.size(), 1u);
  const Contact& c = contacts[0];
  EXPECT_NEAR(c.gap, g, 1e-12);
  EXPECT_FALSE(c.interference);
  EXPECT_GT(c.interface_area, 1.0);
  ASSERT_EQ(c.sites.size(), 1u);
  const double r = std::sqrt(bound * bound - g * g) / 2;
  const double area = 1 + 4 * r + std::numbers::pi * r * r;
  EXPECT_NEAR(c.sites[0].area, area, 0.01 * area);
  EXPECT_NEAR(c.sites[0].centroid.x, 1 + g / 2, 1e-9);
  EXPECT_NEAR(c.sites[0].centroid.y, 0.5, 1e-3);
  EXPECT_NEAR(c.sites[0].centroid.z, 0.5, 1e-3);
  EXPECT_NEAR(c.sites[0].min_gap, g, 1e-12);
}

// One object of two cubes over a long box, both at gap g: two sites, one over each cube,
// each at least the cube's face (clearance g/2 there) and about at most the face grown by r
// on every side (where the long box goes on, the interface bends up to the cube's edge: its
// curved GVD pieces, kept within a tolerance of the bisector, get 5 % of slack).
TEST(Contacts, SeparateCloseRegionsAreSeparateSites) {
  const double g = 0.01, bound = 0.06;
  SceneObject pair = test::make_box("pair", {0, 1 + g, 0}, {1, 2, 1});
  const SceneObject second = test::make_box("second", {2, 1 + g, 0}, {3, 2, 1});
  const uint32_t offset = static_cast<uint32_t>(pair.vertices.size());
  for (const Vec3& v : second.vertices) pair.vertices.push_back(v);
  for (Simplex t : second.simplices) {
    for (uint32_t& v : t.v) v += offset;
    pair.simplices.push_back(t);
  }
  const auto result =
      run(test::make_scene(3, {test::make_box("long", {0, 0, 0}, {3, 1, 1}), std::move(pair)}));
  const GvdIndex index(result);
  const std::vector<Contact> contacts = find_contacts(index, bound);
  ASSERT_EQ(contacts.size(), 1u);
  ASSERT_EQ(contacts[0].sites.size(), 2u);
  const double r = std::sqrt(bound * bound - g * g) / 2;
  std::vector<double> xs;
  for (const ContactSite& site : contacts[0].sites) {
    xs.push_back(site.centroid.x);
    EXPECT_GE(site.area, 1 - 1e-9);
    EXPECT_LE(site.area, 1.05 * (1 + 4 * r + std::numbers::pi * r * r));
    EXPECT_NEAR(site.min_gap, g, 1e-12);
  }
  std::sort(xs.begin(), xs.end());
  EXPECT_NEAR(xs[0], 0.5, 0.02);
  EXPECT_NEAR(xs[1], 2.5, 0.02);
}

// One box pushed into another by 0.1: interference, gap 0, and the depth of its deepest
// vertices (those at x = 0.9 inside a, 0.1 from a's face x = 1).
TEST(Contacts, InterferenceReportsGapZeroAndTheDeepestVertex) {
  const auto result =
      run(test::make_scene(3, {test::make_box("a", {0, 0, 0}, {1, 1, 1}),
                               test::make_box("b", {0.9, 0.25, 0.25}, {1.9, 0.75, 0.75}),
                               test::make_box("c", {0, 0, 1.5}, {1, 1, 2})}));
  const GvdIndex index(result);
  const std::vector<Contact> contacts = find_contacts(index, 0.0);
  ASSERT_EQ(contacts.size(), 1u);
  EXPECT_EQ(contacts[0].a, 0u);
  EXPECT_EQ(contacts[0].b, 1u);
  EXPECT_EQ(contacts[0].gap, 0);
  EXPECT_TRUE(contacts[0].interference);
  EXPECT_NEAR(contacts[0].depth_lower_bound, 0.1, 1e-9);
  // Both are convex: the penetration depth, exactly (b moved 0.1 along +x leaves a).
  EXPECT_NEAR(contacts[0].penetration_depth, 0.1, 1e-12);
  expect_pairs_match_brute_force(index, 0.6, find_contacts(index, 0.6), brute_gaps(result->scene));
}

// A sphere sunk into a box's corner, and a box pushed into a dented one (a corner pushed in:
// not convex): the convex pair has its penetration depth, never below its deepest vertex and
// never above the true sphere's; the other none.
TEST(Contacts, PenetrationDepthOfConvexPairsOnly) {
  SceneObject dented = test::make_box("dented", {3, 0, 0}, {4, 1, 1});
  dented.vertices[7] = {3.7, 0.7, 0.7};
  const auto result = run(test::make_scene(
      3, {test::make_box("a", {0, 0, 0}, {1, 1, 1}), test::make_sphere("s", {1.1, 1.1, 1.1}, 0.3),
          std::move(dented), test::make_box("b", {3.65, 0.6, 0.6}, {3.9, 0.9, 0.9})}));
  const GvdIndex index(result);
  const std::vector<Contact> contacts = find_contacts(index, 0.0);
  ASSERT_EQ(contacts.size(), 2u);
  for (const Contact& c : contacts) {
    ASSERT_TRUE(c.interference);
    if (c.a == 0) {
      // The true sphere (radius 0.3, centre 0.1 outside each of the corner's three faces)
      // leaves the box along the diagonal after 0.3 - 0.1 sqrt(3); the faceted one, inside
      // it, after a little less.
      EXPECT_EQ(c.b, 1u);
      EXPECT_GT(c.penetration_depth, 0.1);
      EXPECT_LE(c.penetration_depth, 0.3 - 0.1 * std::sqrt(3.0) + 1e-12);
      EXPECT_GE(c.penetration_depth, c.depth_lower_bound - 1e-12);
    } else {
      EXPECT_EQ(c.a, 2u);
      EXPECT_LT(c.penetration_depth, 0) << "the dented box is not convex";
    }
  }
  const auto doc = nlohmann::json::parse(contacts_to_json(index, 0.0, contacts));
  for (const auto& c : doc["contacts"])
    EXPECT_EQ(c["penetration_depth"].is_null(), c["a"] == 2) << c.dump();
}

// A wall between two boxes: they are closer than the bound but their cells do not meet.
TEST(Contacts, PairsWhoseCellsDoNotMeetHaveNoInterface) {
  const auto result = run(test::make_scene(3, {test::make_box("a", {0, 0, 0}, {1, 1, 1}),
                                               test::make_box("wall", {1.04, -1, -1}, {1.06, 2, 2}),
                                               test::make_box("b", {1.1, 0, 0}, {2.1, 1, 1})}));
  const GvdIndex index(result);
  const std::vector<Contact> contacts = find_contacts(index, 0.2);
  expect_pairs_match_brute_force(index, 0.2, contacts, brute_gaps(result->scene));
  bool seen = false;
  for (const Contact& c : contacts) {
    if (c.a != 0 || c.b != 2) continue;
    seen = true;
    EXPECT_NEAR(c.gap, 0.1, 1e-12);
    EXPECT_EQ(c.interface_area, 0);
    EXPECT_TRUE(c.sites.empty());
  }
  EXPECT_TRUE(seen);
}

TEST(Contacts, JsonAndBadBounds) {
  const auto result = run(test::make_scene(2, {test::make_rect("a", {0, 0, 0}, {1, 1, 0}),
                                               test::make_rect("b", {1.1, 0, 0}, {2, 1, 0})}));
  const GvdIndex index(result);
  const auto doc = nlohmann::json::parse(contacts_to_json(index, 0.5, find_contacts(index, 0.5)));
  ASSERT_EQ(doc["contacts"].size(), 1u);
  EXPECT_EQ(doc["contacts"][0]["label_a"], "a");
  EXPECT_EQ(doc["contacts"][0]["label_b"], "b");
  EXPECT_NEAR(doc["contacts"][0]["gap"].get<double>(), 0.1, 1e-12);
  EXPECT_TRUE(doc["contacts"][0]["depth_lower_bound"].is_null());
  EXPECT_TRUE(doc["contacts"][0]["penetration_depth"].is_null());
  EXPECT_EQ(doc["contacts"][0]["on_a"].size(), 2u);
  EXPECT_THROW(find_contacts(index, -1), Error);
  // More candidate pairs than allowed: a limit error before any distance is measured.
  try {
    find_contacts(index, 10.0, 0);
    FAIL() << "expected the candidate limit";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kLimitExceeded);
    EXPECT_NE(e.detail().find("lower the bound"), std::string::npos) << e.detail();
  }
  EXPECT_THROW(find_contacts(index, NAN), Error);
}

}  // namespace
}  // namespace gvd
