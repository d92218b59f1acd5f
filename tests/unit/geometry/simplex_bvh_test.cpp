#include "gvd/geometry/simplex_bvh.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "gvd/geometry/primitives.h"
#include "support/scenes.h"
#include "support/thin_gap_scenes.h"

namespace gvd {

using namespace gvd::scene;

namespace {

// Three finely tessellated spheres apart from each other: each gets a subtree of the shared
// tree of its own, which the in-object queries walk.
struct Fixture {
  Scene scene;
  Domain domain;
  UnitGeometry g;
  SimplexBvh bvh;
  Fixture() {
    scene = test::make_scene(3, {test::make_sphere("a", {0, 0, 0}, 1, 24, 48),
                                 test::make_sphere("b", {2.05, 0, 0}, 1, 24, 48),
                                 test::make_sphere("c", {1, 1.8, 0.3}, 0.8, 24, 48)});
    domain = make_domain(scene);
    g = make_unit_geometry(scene, domain);
    bvh = SimplexBvh(3, g.points, g.simplices, g.object_of);
  }
  double brute(Vec3 p, uint32_t object, bool any) const {
    double best = 1e300;
    for (uint32_t s = 0; s < g.simplices.size(); ++s) {
      if (!any && g.object_of[s] != object) continue;
      best = std::min(best, dist2(p, closest_point_on_simplex(3, g.points, g.simplices[s], p)));
    }
    return best;
  }
};

TEST(SimplexBvh, NearestAndNearestInObjectMatchBruteForce) {
  const Fixture f;
  ASSERT_GT(f.g.simplices.size(), 4096u);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0, 1);
  for (int i = 0; i < 300; ++i) {
    const Vec3 p{u(rng), u(rng), u(rng)};
    const double all = f.brute(p, 0, true);
    const ClosestHit hit = f.bvh.nearest(p);
    ASSERT_TRUE(hit.found());
    EXPECT_NEAR(hit.dist2, all, 1e-11 * all) << "point " << i;
    EXPECT_NEAR(dist2(p, hit.point), hit.dist2, 1e-12 * hit.dist2 + 1e-300);
    for (uint32_t o = 0; o < 3; ++o) {
      const double truth = f.brute(p, o, false);
      const ClosestHit in = f.bvh.nearest_in_object(p, o);
      ASSERT_TRUE(in.found());
      EXPECT_EQ(f.g.object_of[in.simplex], o);
      EXPECT_NEAR(in.dist2, truth, 1e-11 * truth) << "point " << i << " object " << o;
      // A bound below the answer finds nothing; one above finds the same distance.
      EXPECT_FALSE(f.bvh.nearest_in_object(p, o, 0.5 * truth).found());
      EXPECT_NEAR(f.bvh.nearest_in_object(p, o, 2 * truth).dist2, truth, 1e-11 * truth);
    }
  }
}

// closest_to_simplex against sampling: the point it returns lies on the query triangle and is
// as far from the scene as it says, and no sample of the triangle is nearer (while the
// densest sampling comes within its spacing of the answer).
TEST(SimplexBvh, ClosestToSimplexMatchesSampling) {
  const Fixture f;
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(0, 1), small(-0.04, 0.04);
  int checked = 0;
  for (int i = 0; i < 200 && checked < 60; ++i) {
    const Vec3 c{u(rng), u(rng), u(rng)};
    Vec3 q[3];
    for (Vec3& v : q) v = c + Vec3{small(rng), small(rng), small(rng)};
    // Keep triangles in free space (the query must not cross the scene).
    bool clear = true;
    for (const Vec3& v : q) clear &= f.bvh.nearest(v).dist2 > 0.1 * 0.1;
    if (!clear) continue;
    ++checked;
    const ClosestHit hit = f.bvh.closest_to_simplex(q);
    ASSERT_TRUE(hit.found());
    EXPECT_LT(dist2(hit.point, closest_point_on_triangle(hit.point, q[0], q[1], q[2])), 1e-24);
    EXPECT_NEAR(f.bvh.nearest(hit.point).dist2, hit.dist2, 1e-9 * hit.dist2);
    const int n = 24;
    double sampled = 1e300;
    for (int a = 0; a <= n; ++a) {
      for (int b = 0; a + b <= n; ++b) {
        const Vec3 x = q[0] + (q[1] - q[0]) * (double(a) / n) + (q[2] - q[0]) * (double(b) / n);
        sampled = std::min(sampled, std::sqrt(f.bvh.nearest(x).dist2));
      }
    }
    const double exact = std::sqrt(hit.dist2);
    const double spacing = std::max({dist(q[0], q[1]), dist(q[1], q[2]), dist(q[2], q[0])}) / n;
    EXPECT_LE(exact, sampled * (1 + 1e-12)) << "triangle " << i;
    EXPECT_GE(exact, sampled - spacing) << "triangle " << i;
    // A bound below the answer finds nothing.
    EXPECT_FALSE(f.bvh.closest_to_simplex(q, 0.5 * hit.dist2).found());
  }
  EXPECT_GE(checked, 30);
}

// closest_to_simplex skipping the query's own object against brute force over every other
// object's triangles: for triangles of each sphere, the distance to the rest of the scene.
TEST(SimplexBvh, ClosestToSimplexSkippingAnObjectMatchesBruteForce) {
  const Fixture f;
  for (uint32_t s = 0; s < f.g.simplices.size(); s += 97) {
    const uint32_t own = f.g.object_of[s];
    Vec3 q[3];
    for (int j = 0; j < 3; ++j) q[j] = f.g.points[f.g.simplices[s].v[j]];
    double truth = 1e300;
    for (uint32_t t = 0; t < f.g.simplices.size(); ++t) {
      if (f.g.object_of[t] == own) continue;
      Vec3 c[3];
      for (int j = 0; j < 3; ++j) c[j] = f.g.points[f.g.simplices[t].v[j]];
      truth = std::min(truth, triangle_triangle_dist2(q, c));
    }
    const ClosestHit hit = f.bvh.closest_to_simplex(q, 1e300, own);
    ASSERT_TRUE(hit.found()) << "triangle " << s;
    EXPECT_NE(f.g.object_of[hit.simplex], own);
    EXPECT_NEAR(hit.dist2, truth, 1e-12 + 1e-9 * truth) << "triangle " << s;
    // Without the skip, the triangle is its own nearest simplex.
    EXPECT_EQ(f.bvh.closest_to_simplex(q).dist2, 0.0);
  }
}

// object_distance against the brute-force mesh distance of tests/support (its own code):
// three spheres 0.05 and ~0.2 apart, and two of them pushed into each other.
TEST(SimplexBvh, ObjectDistanceMatchesBruteForce) {
  const Fixture f;
  for (uint32_t a = 0; a < 3; ++a) {
    for (uint32_t b = a + 1; b < 3; ++b) {
      const double truth = test::min_distance_3d(f.scene.objects[a], f.scene.objects[b]);
      const SimplexBvh::ObjectPair p = f.bvh.object_distance(a, b);
      ASSERT_TRUE(p.found);
      EXPECT_NEAR(std::sqrt(p.dist2) * f.domain.side, truth, 1e-9 * truth) << a << "/" << b;
      // The witnesses are as far apart as the distance, one on each object.
      EXPECT_NEAR(dist(p.on_a, p.on_b), std::sqrt(p.dist2), 1e-12);
      EXPECT_NEAR(f.bvh.nearest_in_object(p.on_a, a).dist2, 0, 1e-24);
      EXPECT_NEAR(f.bvh.nearest_in_object(p.on_b, b).dist2, 0, 1e-24);
      EXPECT_FALSE(f.bvh.object_distance(a, b, 0.25 * p.dist2).found);
    }
  }
  const Scene overlap = test::make_scene(3, {test::make_sphere("a", {0, 0, 0}, 1, 12, 24),
                                             test::make_sphere("b", {1.5, 0, 0}, 1, 12, 24)});
  const Domain d = make_domain(overlap);
  const UnitGeometry g = make_unit_geometry(overlap, d);
  const SimplexBvh bvh(3, g.points, g.simplices, g.object_of);
  EXPECT_EQ(bvh.object_distance(0, 1).dist2, 0.0);
  // 2D: two rectangles 1e-6 apart diagonally (corner to corner).
  const Scene rects =
      test::make_scene(2, {test::make_rect("a", {0, 0, 0}, {1, 1, 0}),
                           test::make_rect("b", {1 + 1e-6, 1 + 1e-6, 0}, {2, 2, 0})});
  const Domain d2 = make_domain(rects);
  const UnitGeometry g2 = make_unit_geometry(rects, d2);
  const SimplexBvh bvh2(2, g2.points, g2.simplices, g2.object_of);
  EXPECT_NEAR(std::sqrt(bvh2.object_distance(0, 1).dist2) * d2.side, std::sqrt(2.0) * 1e-6,
              2e-14);  // lattice snap: ~1e-14
}

TEST(SimplexBvh, NearestExcludingObjectsMatchesBruteForce) {
  const Fixture f;
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(0, 1);
  for (int i = 0; i < 200; ++i) {
    const Vec3 p{u(rng), u(rng), u(rng)};
    for (const std::vector<uint32_t>& excluded :
         {std::vector<uint32_t>{0}, std::vector<uint32_t>{1, 2}, std::vector<uint32_t>{}}) {
      double truth = 1e300;
      for (uint32_t o = 0; o < 3; ++o)
        if (std::find(excluded.begin(), excluded.end(), o) == excluded.end())
          truth = std::min(truth, f.brute(p, o, false));
      const int n = static_cast<int>(excluded.size());
      const ClosestHit hit = f.bvh.nearest_excluding(p, excluded.data(), n);
      ASSERT_TRUE(hit.found());
      EXPECT_EQ(std::find(excluded.begin(), excluded.end(), f.g.object_of[hit.simplex]),
                excluded.end());
      EXPECT_NEAR(hit.dist2, truth, 1e-11 * truth) << "point " << i;
      // A bound below the answer finds nothing.
      EXPECT_FALSE(f.bvh.nearest_excluding(p, excluded.data(), n, 0.5 * truth).found());
    }
    const uint32_t all[3] = {0, 1, 2};
    EXPECT_FALSE(f.bvh.nearest_excluding(p, all, 3).found());
  }
}

TEST(SimplexBvh, OverlapQueriesCanSkipOneObject) {
  const Fixture f;
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(0, 1);
  for (int i = 0; i < 50; ++i) {
    Box box;
    box.extend(Vec3{u(rng), u(rng), u(rng)});
    box.extend(box.lo + Vec3{0.2, 0.2, 0.2});
    const uint32_t skip = static_cast<uint32_t>(i % 3);
    std::set<uint32_t> got, want;
    size_t skipped_seen = 0, seen_without_skip = 0;
    f.bvh.for_each_overlapping(
        box,
        [&](uint32_t s) {
          got.insert(s);
          skipped_seen += f.g.object_of[s] == skip;
        },
        skip);
    f.bvh.for_each_overlapping(box,
                               [&](uint32_t s) { seen_without_skip += f.g.object_of[s] == skip; });
    // Only subtrees of that object alone are pruned: its simplices in mixed leaves remain.
    EXPECT_LE(skipped_seen, seen_without_skip);
    for (uint32_t s = 0; s < f.g.simplices.size(); ++s) {
      if (f.g.object_of[s] == skip) continue;
      Box b;
      for (int k = 0; k < 3; ++k) b.extend(f.g.points[f.g.simplices[s].v[k]]);
      bool overlap = true;
      for (int a = 0; a < 3; ++a) overlap &= b.lo[a] <= box.hi[a] && b.hi[a] >= box.lo[a];
      if (overlap) want.insert(s);
    }
    // Every overlapping simplex is visited (leaf-mates of the same subtree may be too).
    for (uint32_t s : want) EXPECT_TRUE(got.count(s)) << "box " << i << " simplex " << s;
  }
}

// item::gvd_bvh_nearest, the one nearest-simplex walk (behind nearest, nearest_if,
// nearest_in_object, nearest_excluding and the closest-point kernel), against brute force
// over all simplices, bit for bit: the answer is the lowest-indexed simplex among those whose
// squared distance is within GVD_TIE of the least, with that simplex's own closest point and
// squared distance. Random scenes built to tie: every simplex has a mirror image across the
// plane x = 1/2 (dyadic coordinates, so the mirror is exact and so are the distances from
// queries on the plane), some are repeated, the order is shuffled so a tie's lower index may
// be either side, and half the queries lie on the plane.
struct TieScene {
  int dimension;
  std::vector<Vec3> points;
  std::vector<Simplex> simplices;
  std::vector<uint32_t> object_of;
  uint32_t objects = 5;

  TieScene(int dim, uint64_t seed, int base) : dimension(dim) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    const int arity = dim == 2 ? 2 : 3;
    // Snapped to multiples of 2^-20: 1 - x is then exact.
    auto snap = [](double x) { return std::ldexp(std::round(std::ldexp(x, 20)), -20); };
    std::vector<std::vector<Vec3>> shapes;
    for (int i = 0; i < base; ++i) {
      const Vec3 c{0.05 + 0.35 * u(rng), u(rng), dim == 2 ? 0.0 : u(rng)};
      std::vector<Vec3> corners;
      for (int k = 0; k < arity; ++k) {
        // A few degenerate simplices (all corners on one point).
        const double r = i % 97 == 0 ? 0.0 : 0.05;
        corners.push_back({snap(c.x + r * (u(rng) - 0.5)), snap(c.y + r * (u(rng) - 0.5)),
                           dim == 2 ? 0.0 : snap(c.z + r * (u(rng) - 0.5))});
      }
      shapes.push_back(corners);
      for (Vec3& v : corners) v.x = 1 - v.x;
      shapes.push_back(corners);
      if (i % 7 == 0) shapes.push_back(corners);  // an exact repeat: ties at the same point
    }
    std::shuffle(shapes.begin(), shapes.end(), rng);
    for (size_t i = 0; i < shapes.size(); ++i) {
      Simplex s;
      for (int k = 0; k < 3; ++k) {
        s.v[k] = static_cast<uint32_t>(points.size()) + static_cast<uint32_t>(k < arity ? k : 0);
      }
      for (const Vec3& v : shapes[i]) points.push_back(v);
      simplices.push_back(s);
      // Numbered object by object, as scenes are.
      object_of.push_back(static_cast<uint32_t>(i * objects / shapes.size()));
    }
  }

  // The brute-force answer among the simplices `candidate` accepts; `ambiguous` when some
  // squared distance lies just beyond the tie band, where the walk's pairwise rule and this
  // global one could differ (then the query is skipped).
  template <class Candidate>
  ClosestHit brute(Vec3 p, Candidate&& candidate, double max_dist2, bool& ambiguous) const {
    std::vector<double> d2(simplices.size(), 1e300);
    std::vector<Vec3> q(simplices.size());
    double least = 1e300;
    for (uint32_t s = 0; s < simplices.size(); ++s) {
      if (!candidate(s)) continue;
      q[s] = closest_point_on_simplex(dimension, points, simplices[s], p);
      d2[s] = dist2(p, q[s]);
      least = std::min(least, d2[s]);
    }
    ambiguous = false;
    ClosestHit best;
    best.dist2 = max_dist2;
    if (least > max_dist2) return best;
    for (uint32_t s = 0; s < simplices.size(); ++s) {
      if (d2[s] <= least * (1 + GVD_TIE)) {
        if (!best.found()) best = {q[s], d2[s], s};
      } else if (d2[s] <= least * (1 + 8 * GVD_TIE)) {
        ambiguous = true;
      }
    }
    return best;
  }
};

void expect_same_hit(const ClosestHit& got, const ClosestHit& want, const std::string& where) {
  EXPECT_EQ(got.simplex, want.simplex) << where;
  EXPECT_EQ(got.dist2, want.dist2) << where;
  EXPECT_TRUE(got.point.x == want.point.x && got.point.y == want.point.y &&
              got.point.z == want.point.z)
      << where;
}

TEST(SimplexBvh, NearestWalkMatchesBruteForceWithItsTieRule) {
  for (const int dim : {2, 3}) {
    const TieScene scene(dim, 40 + static_cast<uint64_t>(dim), 600);
    const SimplexBvh bvh(dim, scene.points, scene.simplices, scene.object_of);
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(0, 1);
    int ambiguous_queries = 0, ties = 0;
    const int queries = 300;
    for (int i = 0; i < queries; ++i) {
      // Half the queries on the mirror plane, where every mirrored pair ties exactly.
      const Vec3 p{i % 2 == 0 ? 0.5 : u(rng), u(rng), dim == 2 ? 0.0 : u(rng)};
      const std::string where = std::to_string(dim) + "D query " + std::to_string(i);
      bool ambiguous = false, any_ambiguous = false;
      auto check = [&](const ClosestHit& got, const ClosestHit& want, const char* what) {
        any_ambiguous |= ambiguous;
        if (!ambiguous) expect_same_hit(got, want, where + " " + what);
      };

      const ClosestHit all = scene.brute(
          p, [](uint32_t) { return true; }, 1e300, ambiguous);
      ASSERT_TRUE(all.found()) << where;
      check(bvh.nearest(p), all, "nearest");
      // A bound at the answer keeps it; one below finds nothing.
      check(bvh.nearest(p, all.dist2), all, "nearest, bound at the answer");
      EXPECT_FALSE(bvh.nearest(p, 0.5 * all.dist2).found()) << where;
      // Whether the tie rule chose: another simplex is as near.
      for (uint32_t s = 0; s < scene.simplices.size() && !ambiguous; ++s) {
        const Vec3 q = closest_point_on_simplex(dim, scene.points, scene.simplices[s], p);
        if (s != all.simplex && dist2(p, q) <= all.dist2 * (1 + GVD_TIE)) {
          ++ties;
          break;
        }
      }

      // A filter: every third simplex (by a hash of its index) is no candidate.
      auto accept = [](uint32_t s) { return (s * 2654435761u >> 16) % 3 != 0; };
      check(bvh.nearest_if(p, accept), scene.brute(p, accept, 1e300, ambiguous), "nearest_if");

      for (uint32_t o = 0; o < scene.objects; ++o) {
        auto in_object = [&](uint32_t s) { return scene.object_of[s] == o; };
        check(bvh.nearest_in_object(p, o), scene.brute(p, in_object, 1e300, ambiguous),
              "nearest_in_object");
      }

      for (const std::vector<uint32_t>& excluded :
           {std::vector<uint32_t>{}, std::vector<uint32_t>{1}, std::vector<uint32_t>{0, 3, 4}}) {
        auto kept = [&](uint32_t s) {
          return std::find(excluded.begin(), excluded.end(), scene.object_of[s]) == excluded.end();
        };
        check(bvh.nearest_excluding(p, excluded.data(), static_cast<int>(excluded.size())),
              scene.brute(p, kept, 1e300, ambiguous), "nearest_excluding");
      }
      ambiguous_queries += any_ambiguous;
    }
    // The scene does tie (else the test would not test the rule), and skips are rare.
    EXPECT_GT(ties, queries / 4) << dim << "D";
    EXPECT_LT(ambiguous_queries, queries / 20) << dim << "D";
  }
}

// The in-object queries on both kinds of object tree: three concentric spheres (no subtree of
// the shared tree holds one alone, so each gets a tree of its own; more than 4096 triangles
// between them, so those are built on two threads) beside two spheres apart from everything
// (subtrees of the shared tree). Each query against brute force over the object's triangles.
TEST(SimplexBvh, InObjectQueriesMatchBruteForceOnSharedAndOwnTrees) {
  const Scene scene = test::make_scene(3, {test::make_sphere("inner", {0, 0, 0}, 1, 24, 48),
                                           test::make_sphere("middle", {0, 0, 0}, 1.2, 24, 48),
                                           test::make_sphere("outer", {0, 0, 0}, 1.4, 24, 48),
                                           test::make_sphere("far", {4, 0, 0}, 1, 12, 24),
                                           test::make_sphere("farther", {4, 3, 0}, 1, 12, 24)});
  const Domain domain = make_domain(scene);
  const UnitGeometry g = make_unit_geometry(scene, domain);
  const SimplexBvh bvh(3, g.points, g.simplices, g.object_of);
  ASSERT_EQ(bvh.objects_with_own_tree(), 3u);
  uint32_t nested = 0;
  for (uint32_t o : g.object_of) nested += o < 3;
  ASSERT_GT(nested, 4096u);
  const uint32_t objects = 5;
  auto corners = [&](uint32_t s, Vec3* c) {
    for (int j = 0; j < 3; ++j) c[j] = g.points[g.simplices[s].v[j]];
  };

  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0, 1);
  for (int i = 0; i < 60; ++i) {
    const Vec3 p{u(rng), u(rng), u(rng)};
    for (uint32_t o = 0; o < objects; ++o) {
      double truth = 1e300;
      for (uint32_t s = 0; s < g.simplices.size(); ++s)
        if (g.object_of[s] == o)
          truth =
              std::min(truth, dist2(p, closest_point_on_simplex(3, g.points, g.simplices[s], p)));
      const ClosestHit hit = bvh.nearest_in_object(p, o);
      ASSERT_TRUE(hit.found());
      EXPECT_EQ(g.object_of[hit.simplex], o);
      EXPECT_NEAR(hit.dist2, truth, 1e-11 * truth) << "point " << i << " object " << o;
    }
  }
  // closest_to_simplex_in_object, from a sample of every object's triangles to every object.
  for (uint32_t s = 0; s < g.simplices.size(); s += 331) {
    Vec3 q[3];
    corners(s, q);
    for (uint32_t o = 0; o < objects; ++o) {
      double truth = 1e300;
      for (uint32_t t = 0; t < g.simplices.size(); ++t) {
        if (g.object_of[t] != o) continue;
        Vec3 c[3];
        corners(t, c);
        truth = std::min(truth, triangle_triangle_dist2(q, c));
      }
      const ClosestHit hit = bvh.closest_to_simplex_in_object(q, o);
      ASSERT_TRUE(hit.found());
      EXPECT_EQ(g.object_of[hit.simplex], o);
      EXPECT_NEAR(hit.dist2, truth, 1e-12 + 1e-9 * truth) << "triangle " << s << " object " << o;
    }
  }
  // for_each_overlapping_in_object: every triangle of the object whose box overlaps, and no
  // other object's.
  for (int i = 0; i < 40; ++i) {
    Box box;
    box.extend(Vec3{u(rng), u(rng), u(rng)});
    box.extend(box.lo + Vec3{0.15, 0.15, 0.15});
    for (uint32_t o = 0; o < objects; ++o) {
      std::set<uint32_t> got;
      bvh.for_each_overlapping_in_object(o, box, [&](uint32_t s) { got.insert(s); });
      for (uint32_t s : got) EXPECT_EQ(g.object_of[s], o) << "box " << i;
      for (uint32_t s = 0; s < g.simplices.size(); ++s) {
        if (g.object_of[s] != o) continue;
        Vec3 c[3];
        corners(s, c);
        Box b;
        for (const Vec3& v : c) b.extend(v);
        bool overlap = true;
        for (int a = 0; a < 3; ++a) overlap &= b.lo[a] <= box.hi[a] && b.hi[a] >= box.lo[a];
        if (overlap) {
          EXPECT_TRUE(got.count(s)) << "box " << i << " simplex " << s;
        }
      }
    }
  }
  // object_distance between trees of both kinds: analytic for the concentric spheres (the
  // radii's difference, less the tessellation's sag), brute force for the far ones.
  const double inner_middle = bvh.object_distance(0, 1).dist2;
  EXPECT_NEAR(std::sqrt(inner_middle) * domain.side, 0.2, 0.2 * 0.05);
  for (const auto& [a, b] : {std::pair<uint32_t, uint32_t>{2, 3}, {3, 4}, {1, 4}}) {
    const double truth = test::min_distance_3d(scene.objects[a], scene.objects[b]);
    const SimplexBvh::ObjectPair pair = bvh.object_distance(a, b);
    ASSERT_TRUE(pair.found);
    EXPECT_NEAR(std::sqrt(pair.dist2) * domain.side, truth, 1e-9 * truth) << a << "/" << b;
    EXPECT_NEAR(bvh.nearest_in_object(pair.on_a, a).dist2, 0, 1e-24);
    EXPECT_NEAR(bvh.nearest_in_object(pair.on_b, b).dist2, 0, 1e-24);
  }
}

}  // namespace
}  // namespace gvd
