// The plane GVD on the faces of junction cells (pipeline/junction_face.h), under brute force.
#include "gvd/pipeline/junction_face.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <set>
#include <string>
#include <tuple>

#include "gvd/octree/contacts.h"
#include "gvd/refine/pair_certificate.h"
#include "support/oracles.h"
#include "support/scenes.h"
#include "support/unit_world.h"

namespace gvd {

using namespace gvd::scene;
using namespace gvd::octree;
using namespace gvd::refine;
using namespace gvd::pipeline;

using World = test::UnitWorld;
using test::lattice_cell_at;

// On both end faces of junction cells of packed columns and of a blade in a slot of separate
// parts (gap 1e-3): every point of the face's GVD is equidistant from the objects of its
// segments and no other object is nearer; ends of the network lie on the face's border;
// points where three or more segments meet touch three or more objects; and the two end
// faces carry the same GVD (the distances are invariant along the axis).
TEST(JunctionFace, PlaneGvdOfJunctionCellsHoldsUnderBruteForce3D) {
  const double g = 1e-3;
  struct Case {
    const char* name;
    Scene scene;
    std::vector<Vec3> lines;
  };
  std::vector<Case> cases;
  cases.push_back({"columns",
                   test::make_packed_columns(3, 0.3, g),
                   {{0.3, 0.3, 0}, {0.6, 0.3, 0}, {0.3, 0.6, 0}}});
  cases.push_back(
      {"slot of parts", test::make_slot_of_separate_parts(g), {{0.45, 0.2, 0}, {0.55, 0.2, 0}}});
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1, 1), t(0, 1);
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const World s(c.scene);
    const ContactPairs contacts = find_contact_pairs(s.geometry, s.bvh, contact_tolerance(21));
    const PairCertifier certifier(s.geometry, s.bvh, &contacts, true);
    int faces = 0, crossed = 0, junctions = 0;
    for (int level = 5; level <= 11; ++level) {
      for (const Vec3 line : c.lines) {
        Vec3 p = line + Vec3{0.5 * g * u(rng), 0.5 * g * u(rng), 0};
        p.z = 0.4 + 0.2 * t(rng);
        const Box box = lattice_cell_at(s.domain.to_unit(p), level);
        const PairCertifier::Junction j = certifier.certify_junction(box);
        if (!j.certified) continue;
        ASSERT_EQ(j.axis, 2);
        const double side_user = (box.hi.x - box.lo.x) * s.domain.side;
        surface::FaceGvd face[2];
        for (int end = 0; end < 2; ++end) {
          Box f = box;
          f.lo.z = f.hi.z = end == 0 ? box.lo.z : box.hi.z;
          ASSERT_TRUE(junction_face_gvd(s.geometry, s.bvh, f, 2, face[end]));
          ++faces;
          const surface::FaceGvd& jf = face[end];
          // (Three objects can be nearest by the certificate's bound and yet no GVD cross it.)
          if (jf.segments.empty()) continue;
          ++crossed;
          std::vector<std::set<ObjectId>> touches(jf.points.size());
          std::vector<int> degree(jf.points.size(), 0);
          for (size_t i = 0; i < jf.segments.size(); ++i) {
            for (uint32_t v : {jf.segments[i].first, jf.segments[i].second}) {
              ++degree[v];
              touches[v].insert(jf.pairs[i].first);
              touches[v].insert(jf.pairs[i].second);
            }
          }
          for (size_t v = 0; v < jf.points.size(); ++v) {
            const Vec3 q = s.domain.from_unit(jf.points[v]);
            double least = 1e300, most = 0;
            for (ObjectId o : touches[v]) {
              const double d = test::brute_distance(s.scene, o, q);
              least = std::min(least, d);
              most = std::max(most, d);
            }
            EXPECT_LE(most - least, 1e-9 * side_user) << "point " << v << " level " << level;
            for (ObjectId o = 0; o < s.scene.objects.size(); ++o) {
              if (touches[v].count(o)) continue;
              EXPECT_GE(test::brute_distance(s.scene, o, q), least - 1e-9 * side_user)
                  << "object " << o << " nearer at point " << v << " level " << level;
            }
            if (degree[v] == 1) {
              const Vec3 x = jf.points[v];
              const double hair = 1e-12;
              const bool border =
                  std::abs(x.x - box.lo.x) <= hair || std::abs(x.x - box.hi.x) <= hair ||
                  std::abs(x.y - box.lo.y) <= hair || std::abs(x.y - box.hi.y) <= hair;
              EXPECT_TRUE(border) << "a loose end inside the face, level " << level;
            }
            if (degree[v] >= 3) {
              EXPECT_GE(touches[v].size(), 3u) << "level " << level;
              ++junctions;
            }
          }
        }
        // Invariance along the axis: the same points on both end faces.
        ASSERT_EQ(face[0].points.size(), face[1].points.size()) << "level " << level;
        std::vector<std::pair<double, double>> a, b;
        for (Vec3 x : face[0].points) a.emplace_back(x.x, x.y);
        for (Vec3 x : face[1].points) b.emplace_back(x.x, x.y);
        std::sort(a.begin(), a.end());
        std::sort(b.begin(), b.end());
        for (size_t i = 0; i < a.size(); ++i) {
          EXPECT_NEAR(a[i].first, b[i].first, 1e-12);
          EXPECT_NEAR(a[i].second, b[i].second, 1e-12);
        }
      }
    }
    EXPECT_GT(faces, 4);
    EXPECT_GT(crossed, 4);
    EXPECT_GT(junctions, 0);
  }
}

// The section cache: a face one above another along a junction line (the same section) gets
// the GVD the face computed alone gets, moved along the axis; a face whose section differs (the
// fourth column of the line ends below it) is computed from its own.
TEST(JunctionFace, FacesWithTheSameSectionShareOneComputation3D) {
  const double g = 1e-3;
  Scene scene = test::make_packed_columns(2, 0.3, g);
  // The column at [0.3, 0.6) x [0.3, 0.6) ends at z = 0.5.
  const ObjectId shortened = static_cast<ObjectId>(scene.objects.size() - 1);
  for (Vec3& v : scene.objects[shortened].vertices) {
    ASSERT_GE(v.x, 0.3 - 1e-12);
    ASSERT_GE(v.y, 0.3 - 1e-12);
    v.z = std::min(v.z, 0.5);
  }
  const World s(scene);
  auto sorted = [](const surface::FaceGvd& f) {
    std::vector<std::tuple<double, double, double, double, double, double, ObjectId, ObjectId>> out;
    for (size_t i = 0; i < f.segments.size(); ++i) {
      Vec3 a = f.points[f.segments[i].first], b = f.points[f.segments[i].second];
      if (std::tie(b.x, b.y, b.z) < std::tie(a.x, a.y, a.z)) std::swap(a, b);
      out.emplace_back(a.x, a.y, a.z, b.x, b.y, b.z, f.pairs[i].first, f.pairs[i].second);
    }
    std::sort(out.begin(), out.end());
    return out;
  };
  const int level = 7;
  const double cell = std::ldexp(1.0, -level);
  const Vec3 at = s.domain.to_unit(Vec3{0.3 - 0.5 * g, 0.3 - 0.5 * g, 0.2});
  Box face = lattice_cell_at(at, level);
  face.hi.z = face.lo.z;
  JunctionSectionCache sections;
  surface::FaceGvd first, alone, shared;
  ASSERT_TRUE(junction_face_gvd(s.geometry, s.bvh, face, 2, first, nullptr, &sections));
  ASSERT_FALSE(first.segments.empty());
  // Two cells higher, the same section.
  Box higher = face;
  higher.lo.z = higher.hi.z = face.lo.z + 2 * cell;
  ASSERT_TRUE(junction_face_gvd(s.geometry, s.bvh, higher, 2, alone));
  ASSERT_TRUE(junction_face_gvd(s.geometry, s.bvh, higher, 2, shared, nullptr, &sections));
  EXPECT_EQ(sections.size(), 1u) << "one section, computed once";
  EXPECT_EQ(sorted(shared), sorted(alone));
  for (const Vec3& p : shared.points) EXPECT_EQ(p.z, higher.lo.z);
  // Above the shortened column: three columns, its own section, its own GVD.
  Box beside = face;
  beside.lo.z = beside.hi.z = std::floor(s.domain.to_unit(Vec3{0, 0, 0.75}).z / cell) * cell;
  surface::FaceGvd beside_alone, beside_shared;
  const bool a = junction_face_gvd(s.geometry, s.bvh, beside, 2, beside_alone);
  const bool b = junction_face_gvd(s.geometry, s.bvh, beside, 2, beside_shared, nullptr, &sections);
  EXPECT_EQ(a, b);
  EXPECT_EQ(sections.size(), 2u) << "another section";
  EXPECT_EQ(sorted(beside_shared), sorted(beside_alone));
  ASSERT_FALSE(beside_alone.segments.empty());
  std::set<ObjectId> objects;
  for (const auto& [l, r] : beside_alone.pairs) objects.insert({l, r});
  EXPECT_EQ(objects.count(shortened), 0u) << "the shortened column ends below";
  std::set<ObjectId> below;
  for (const auto& [l, r] : first.pairs) below.insert({l, r});
  EXPECT_EQ(below.count(shortened), 1u);
}

}  // namespace gvd
