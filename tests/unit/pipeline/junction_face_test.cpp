// The plane GVD on the faces of junction cells (pipeline/junction_face.h), under brute force.
#include "gvd/pipeline/junction_face.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <set>
#include <string>

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

}  // namespace gvd
