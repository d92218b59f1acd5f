// The flat-pair certificate (refine/pair_certificate.h) against brute force: every cell it
// certifies must have at most its two objects nearest at sampled points, with the distances
// equal to the distances to its planes and the nearer object on the side its planes say.

#include "gvd/refine/pair_certificate.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "gvd/octree/lattice.h"
#include "support/oracles.h"
#include "support/scenes.h"
#include "support/thin_gap_scenes.h"
#include "support/unit_world.h"

namespace gvd {

using namespace gvd::scene;
using namespace gvd::octree;
using namespace gvd::refine;

namespace {

using World = test::UnitWorld;

// A square sheet [0,1]^2 at height z, split into n x n cells of two triangles each (welded).
SceneObject make_sheet(const std::string& label, double z, int n) {
  SceneObject o;
  o.label = label;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) o.vertices.push_back({double(i) / n, double(j) / n, z});
  auto at = [&](int i, int j) { return static_cast<uint32_t>(j * (n + 1) + i); };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      o.simplices.push_back({{at(i, j), at(i + 1, j), at(i + 1, j + 1)}});
      o.simplices.push_back({{at(i, j), at(i + 1, j + 1), at(i, j + 1)}});
    }
  return o;
}

// The unit-domain box of a cube with corner lo_user and side size_user (user units).
Box user_cube(const World& s, Vec3 lo_user, double size_user) {
  Box b;
  b.lo = s.domain.to_unit(lo_user);
  b.hi = b.lo + Vec3{size_user, size_user, size_user} / s.domain.side;
  return b;
}

// The brute-force audit: `samples` points of a certified cell (corners, centre and random
// points) keep to the certificate.
void audit_cell(const World& s, const PairCertifier::Certificate& c, const Box& unit_box,
                int samples, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0, 1);
  const int dim = s.scene.dimension;
  for (int k = 0; k < samples; ++k) {
    Vec3 x;
    for (int i = 0; i < dim; ++i) {
      const double t = k < (1 << dim) ? ((k >> i) & 1) : u(rng);
      x[i] = unit_box.lo[i] + t * (unit_box.hi[i] - unit_box.lo[i]);
    }
    const Vec3 p = s.domain.from_unit(x);
    const test::NearestAnswer nn = test::brute_nearest(s.scene, p);
    const double da = test::brute_distance(s.scene, c.a, p) / s.domain.side;
    const double db = test::brute_distance(s.scene, c.b, p) / s.domain.side;
    const double sa = dot(c.normal[0], x) - c.offset[0];
    const double sb = dot(c.normal[1], x) - c.offset[1];
    if (c.mirror) {
      // The bisector is the mirror plane: a's side nearer to a, b's side nearer to b, equal
      // distances on it (to the rounding the certificate allows).
      const double band = 1e-9;
      if (sa < -band) {
        ASSERT_LT(da, db) << "a point on " << c.a << "'s side is nearer to " << c.b;
      }
      if (sa > band) {
        ASSERT_LT(db, da) << "a point on " << c.b << "'s side is nearer to " << c.a;
      }
      if (std::abs(sa) <= 1e-15) {
        ASSERT_NEAR(da, db, 1e-12);
      }
    } else {
      ASSERT_NEAR(da, std::abs(sa), 1e-12) << "distance to " << c.a << " is not its plane's";
      ASSERT_NEAR(db, std::abs(sb), 1e-12) << "distance to " << c.b << " is not its plane's";
    }
    // No third object is nearer than both (ties allowed at rounding level).
    ASSERT_LE(nn.distance / s.domain.side, std::min(da, db) + 1e-12);
    if (nn.object != c.a && nn.object != c.b) {
      ASSERT_NEAR(nn.distance / s.domain.side, std::min(da, db), 1e-12);
    }
  }
}

// Certifies cells on a regular grid of one level and audits the certified ones; returns how
// many were certified (and how many of them as mirror pairs in `mirrors`).
int audit_level(const World& s, int level, int samples, int* mirrors = nullptr) {
  const PairCertifier certifier(s.geometry, s.bvh);
  const int dim = s.scene.dimension;
  const uint32_t n = 1u << level;
  std::mt19937_64 rng(level);
  int certified = 0;
  for (uint32_t k = 0; k < (dim == 2 ? n : n) && k < (dim == 2 ? 1u : n); ++k)
    for (uint32_t j = 0; j < n; ++j)
      for (uint32_t i = 0; i < n; ++i) {
        lattice::Coord c;
        const uint64_t size = lattice::cell_size(dim, level);
        c.c[0] = static_cast<uint32_t>(i * size);
        c.c[1] = static_cast<uint32_t>(j * size);
        c.c[2] = static_cast<uint32_t>(k * size);
        const Box box = lattice::cell_box(dim, c, level);
        const PairCertifier::Certificate cert = certifier.certify(box);
        if (cert.verdict != CellVerdict::kPair) continue;
        ++certified;
        if (mirrors != nullptr) *mirrors += cert.mirror;
        audit_cell(s, cert, box, samples, rng);
        if (::testing::Test::HasFatalFailure()) return certified;
      }
  return certified;
}

// The audit of an extruded pair cell (brute-force distances): both distances are invariant
// along its direction e (an axis or slanted), and d_a - d_b changes sign at most once, from -
// to +, along every line in the direction `rise` and along every axis but e (in rise's sense)
// through sampled points: the bisector is one monotone curve of the cross-section swept along
// e, and every octree edge meets it at most once.
// Lines along a cone's straddled axis that audit_extruded saw meet the bisector twice.
int g_twice_seen = 0;

void audit_extruded(const World& s, const PairCertifier::Certificate& c, const Box& box,
                    std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0, 1);
  auto point = [&] {
    Vec3 x;
    for (int i = 0; i < 3; ++i) x[i] = box.lo[i] + u(rng) * (box.hi[i] - box.lo[i]);
    return x;
  };
  auto dist_to = [&](ObjectId o, Vec3 x) {
    return test::brute_distance(s.scene, o, s.domain.from_unit(x)) / s.domain.side;
  };
  auto sign_of = [&](Vec3 x) {
    const double f = dist_to(c.a, x) - dist_to(c.b, x);
    return std::abs(f) <= 1e-13 ? 0 : (f < 0 ? -1 : 1);
  };
  const double side = box.hi.x - box.lo.x;
  for (int k = 0; k < 3; ++k) {
    const Vec3 x = point();
    // Another point of the cell on the line through x along e.
    double t_lo = -1e300, t_hi = 1e300;
    for (int a = 0; a < 3; ++a) {
      if (c.along[a] == 0) continue;
      double t0 = (box.lo[a] - x[a]) / c.along[a], t1 = (box.hi[a] - x[a]) / c.along[a];
      if (t0 > t1) std::swap(t0, t1);
      t_lo = std::max(t_lo, t0);
      t_hi = std::min(t_hi, t1);
    }
    const Vec3 y = x + c.along * (t_lo + u(rng) * (t_hi - t_lo));
    ASSERT_NEAR(dist_to(c.a, x), dist_to(c.a, y), 1e-12) << "d_a varies along e";
    ASSERT_NEAR(dist_to(c.b, x), dist_to(c.b, y), 1e-12) << "d_b varies along e";
    // Lines through x: along rise, and along each axis but e (slanted: all three); where the
    // certificate straddles an axis (c.mixed; a wedge: both but c.monotone), lines along that
    // axis only where octree edges can run (the cell's sides and middle).
    Vec3 dirs[4], from[4];
    int nd = 0;
    from[nd] = x;
    dirs[nd++] = c.rise;
    for (int a = 0; a < 3; ++a) {
      if (a == c.axis) continue;
      Vec3 d;
      d[a] = c.rise[a] > 0 ? 1 : -1;
      if (std::abs(c.rise[a]) < 1e-9) continue;  // slanted: e's plane, none of e's sense
      if (a == c.mixed) continue;                // checked below
      if (c.monotone >= 0 && a != c.monotone) continue;
      from[nd] = x;
      dirs[nd++] = d;
    }
    for (int l = 0; l < nd; ++l) {
      int last = 0, changes = 0;
      for (int i = -16; i <= 16; ++i) {
        const Vec3 p = from[l] + dirs[l] * (side * i / 16.0);
        bool in = true;
        for (int a = 0; a < 3; ++a) in &= p[a] >= box.lo[a] && p[a] <= box.hi[a];
        if (!in) continue;
        const int sg = sign_of(p);
        if (sg == 0) continue;
        ASSERT_FALSE(last == 1 && sg == -1) << "d_a - d_b falls along the rise, line " << l;
        changes += last != 0 && sg != last;
        last = sg;
      }
      ASSERT_LE(changes, 1);
    }
  }
  if (c.mixed < 0) return;
  // Along the straddled axis: the lines of the cell and its children (quarters), finely. Beside
  // a roof's apex one may meet the bisector twice; the certificate must say so (`twice`: the
  // surfacer then looks for both crossings on those edges), and never more.
  // Skew cones (no axis): at quarters across both other axes, one of them drawn at random.
  // Wedges: along both straddled axes.
  for (int line = 0; line < (c.monotone >= 0 ? 2 : 1); ++line) {
    const int m = line == 0 ? c.mixed : 3 - c.monotone - c.mixed;
    const int mono = c.axis >= 0 ? 3 - c.axis - m : (m + 1) % 3;
    const int other = c.axis >= 0 ? -1 : (m + 2) % 3;
    std::uniform_int_distribution<int> quarter(0, 4);
    for (int k = 0; k <= 4; ++k) {
      Vec3 p = point();
      p[mono] = box.lo[mono] + 0.25 * k * side;
      if (other >= 0) p[other] = box.lo[other] + 0.25 * quarter(rng) * side;
      int last = 0, changes = 0;
      for (int i = 0; i <= 128; ++i) {
        p[m] = box.lo[m] + side * i / 128.0;
        const int sg = sign_of(p);
        if (sg == 0) continue;
        changes += last != 0 && sg != last;
        last = sg;
      }
      ASSERT_LE(changes, 2) << "a line along a straddled axis meets the bisector more than twice";
      if (changes == 2) {
        ASSERT_TRUE(c.twice) << "a line along a straddled axis meets the bisector twice, unsaid";
        ++g_twice_seen;
      }
    }
  }
}

// The box of the level-`level` lattice cell holding unit point `unit`.
using test::lattice_cell_at;

// A blade in a slot at 1e-3 (coarse triangles) with an extruding certifier and its rims'
// coordinates (user units).
struct BladeCase {
  test::BladeInSlotOptions options = [] {
    test::BladeInSlotOptions o;
    o.gap = 1e-3;
    o.cell = 0.1;
    return o;
  }();
  World world{test::make_blade_in_slot(options)};
  PairCertifier certifier{world.geometry, world.bvh, nullptr, true};
  double g = options.gap * world.domain.side;
  double x0 = 0.5 - 0.5 * options.width, x1 = 0.5 + 0.5 * options.width;
  double floor_y = 0.5 - options.depth;
  /// Beside the blade's four end edges, in the gap by its faces, at three heights in the slot.
  std::vector<Vec3> end_edges() const {
    std::vector<Vec3> out;
    for (double y : {floor_y + 0.1, floor_y + 0.2, 0.45})
      for (double z : {0.1, 0.9})
        for (const Vec3& p : {Vec3{x0 - 0.5 * g, y, z}, Vec3{x1 + 0.5 * g, y, z}}) out.push_back(p);
    return out;
  }
};

TEST(PairCertifier, ExtrudedCellsHoldUnderBruteForce3D) {
  // A blade in a slot, clearance g = 1e-3 of the domain on both faces and the floor: every
  // rim of it is straight (the blade's edges, the slot's floor corners and mouth).
  const BladeCase blade;
  const World& s = blade.world;
  const PairCertifier& certifier = blade.certifier;
  const double g = blade.g, x0 = blade.x0, x1 = blade.x1, floor_y = blade.floor_y;
  // Points near the rims (user units): bottom edges, floor corners, mouth, blade ends.
  const Vec3 rims[] = {{x0, floor_y + g, 0}, {x1, floor_y + g, 0},    {x0 - g, 0.5, 0},
                       {x1 + g, 0.5, 0},     {0.5, floor_y + g, 0.1}, {x0, 0.4, 0.9}};
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  int extruded[3] = {0, 0, 0}, tried = 0;
  for (int level = 7; level <= 11; ++level) {
    const double cell = std::ldexp(1.0, -level);
    for (const Vec3& rim : rims) {
      for (int k = 0; k < 3; ++k) {
        Vec3 p = rim;
        if (rim.z == 0) p.z = 0.3 + 0.4 * (u(rng) + 1) / 2;
        Vec3 unit = s.domain.to_unit(p);
        for (int a = 0; a < 3; ++a) unit[a] += u(rng) * cell;
        const Box box = lattice_cell_at(unit, level);
        const PairCertifier::Certificate cert = certifier.certify(box);
        ++tried;
        if (cert.axis < 0) continue;
        ASSERT_EQ(cert.verdict, extruded_verdict(cert.axis));
        ++extruded[cert.axis];
        audit_extruded(s, cert, box, rng);
        if (HasFatalFailure()) return;
      }
    }
  }
  // The long rims run along z, the blade's bottom ends along x and its end edges along y.
  EXPECT_GT(extruded[2], tried / 4);
  EXPECT_GT(extruded[0] + extruded[1], 0);
}

TEST(PairCertifier, SlantedCellsHoldUnderBruteForce3D) {
  // Rims square to an axis but along neither other one: the blade in its slot tilted about x
  // (its long rims then run in the yz plane), and the hexagonal bore's edges at 60 and 120
  // degrees in the planes of its ends.
  const BladeCase blade;
  const double g = blade.g, x0 = blade.x0, x1 = blade.x1, floor_y = blade.floor_y;
  Scene tilted = blade.world.scene;
  const Vec3 about_x{1, 0, 0};
  for (SceneObject& obj : tilted.objects)
    for (Vec3& v : obj.vertices) v = test::rotate(v, about_x, 0.3);
  const World t(std::move(tilted));
  const PairCertifier tilted_certifier(t.geometry, t.bvh, nullptr, true);
  test::ShaftInBoreOptions so;
  so.gap = 1e-3;
  so.cell = 0.1;
  const World shaft(test::make_shaft_in_bore(so));
  const PairCertifier shaft_certifier(shaft.geometry, shaft.bvh, nullptr, true);
  const double gs = so.gap * shaft.domain.side, pi = std::acos(-1.0);
  // Points on the rims (user units) with the world they are in.
  struct Rim {
    const World* world;
    const PairCertifier* certifier;
    Vec3 at;
    int slanted;  ///< the axis square to the rim
  };
  std::vector<Rim> rims;
  for (double z : {0.35, 0.5, 0.65}) {
    for (const Vec3& p : {Vec3{x0, floor_y + g, z}, Vec3{x1, floor_y + g, z}, Vec3{x0 - g, 0.5, z}})
      rims.push_back({&t, &tilted_certifier, test::rotate(p, about_x, 0.3), 0});
  }
  // Mid-edges of the bore's ends on the faces whose normals are at 30, 150 and 330 degrees
  // (the edges run at 120, 60 and 60 degrees), in the gap.
  for (double deg : {30.0, 150.0, 330.0}) {
    const double a = deg * pi / 180, apothem = so.radius * std::cos(pi / 6) - gs / 2;
    for (double z : {0.0, 0.6})
      rims.push_back(
          {&shaft, &shaft_certifier, Vec3{apothem * std::cos(a), apothem * std::sin(a), z}, 2});
  }
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  int slanted = 0, tried = 0, in_shaft = 0;
  for (int level = 7; level <= 11; ++level) {
    const double cell = std::ldexp(1.0, -level);
    for (const Rim& rim : rims) {
      for (int k = 0; k < 3; ++k) {
        Vec3 unit = rim.world->domain.to_unit(rim.at);
        for (int a = 0; a < 3; ++a) unit[a] += 0.5 * u(rng) * cell;
        const Box box = lattice_cell_at(unit, level);
        const PairCertifier::Certificate cert = rim.certifier->certify(box);
        ++tried;
        if (cert.slanted < 0) continue;
        ASSERT_EQ(cert.slanted, rim.slanted);
        ASSERT_LT(cert.axis, 0);
        ASSERT_EQ(
            certified_mark(cert.verdict),
            29 + 2 * cert.slanted +
                (cert.along[(cert.slanted + 1) % 3] * cert.along[(cert.slanted + 2) % 3] < 0));
        ASSERT_NEAR(cert.along[cert.slanted], 0, 1e-12);
        ++slanted;
        in_shaft += rim.world == &shaft;
        audit_extruded(*rim.world, cert, box, rng);
        if (HasFatalFailure()) return;
      }
    }
  }
  EXPECT_GT(slanted, tried / 4) << "of " << tried;
  EXPECT_GT(in_shaft, 0);
  EXPECT_GT(slanted - in_shaft, 0);
}

TEST(PairCertifier, SkewCellsHoldUnderBruteForce3D) {
  // A UV sphere sealed in a cavity scaled from it: its meridian rims run along no axis nor
  // square to one. Where the two faces' normals keep one sign on every axis (the meridians at
  // 30, 45 and 60 degrees, off the equator), cells at the rim are skew extruded cells: d_a and
  // d_b invariant along e, and at most one sign change of d_a - d_b along the rise and along
  // every axis (so every octree edge meets the bisector at most once). Where they straddle
  // one axis, skew cones: at most two along that axis, and `twice` where there are two.
  test::BallInSocketOptions o;
  o.gap = 1e-3;
  const World w(test::make_ball_in_socket(o));
  // The socket has two shells (box and cavity), each oriented: extruded cells need that.
  const PairCertifier certifier(w.geometry, w.bvh, nullptr, true, true);
  const double g = o.gap * 1.1, pi = std::acos(-1.0);
  // Midpoints of meridian edges (between rings i and i + 1 at longitude phi), pushed out into
  // the gap by half of it.
  std::vector<Vec3> rims;
  // Meridians at 0 and 90 degrees lie in a coordinate plane, square to y and x, and their
  // faces' normals straddle that axis (slanted rims across their own axis): skew cones, whose
  // lines along it may meet the bisector twice (audit_extruded counts them finely).
  for (double deg : {30.0, 45.0, 60.0, 210.0, 0.0, 90.0}) {
    const double phi = deg * pi / 180;
    for (int i : {2, 3, 7, 8}) {
      const double t0 = pi * i / o.rings, t1 = pi * (i + 1) / o.rings;
      auto at = [&](double th) {
        return Vec3{std::sin(th) * std::cos(phi), std::sin(th) * std::sin(phi), std::cos(th)} *
               o.radius;
      };
      const Vec3 mid = (at(t0) + at(t1)) * 0.5;
      rims.push_back(mid * (1 + 0.5 * g / norm(mid)));
    }
  }
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> u(-1, 1);
  int skew = 0, cones = 0, tried = 0;
  for (int level = 8; level <= 11; ++level) {
    const double cell = std::ldexp(1.0, -level);
    for (const Vec3& rim : rims) {
      for (int k = 0; k < 3; ++k) {
        Vec3 unit = w.domain.to_unit(rim);
        for (int a = 0; a < 3; ++a) unit[a] += 0.5 * u(rng) * cell;
        const Box box = lattice_cell_at(unit, level);
        const PairCertifier::Certificate cert = certifier.certify(box);
        ++tried;
        if (!cert.skew) continue;
        const uint8_t mark = certified_mark(cert.verdict);
        ASSERT_EQ(inherited_mark(mark), 0) << "children must be asked again";
        ASSERT_LT(cert.axis, 0);
        ASSERT_LT(cert.slanted, 0);
        ASSERT_NEAR(norm(cert.along), 1, 1e-12);
        if (cert.mixed < 0) {
          ASSERT_EQ(cert.verdict, CellVerdict::kSkew);
          ASSERT_EQ(mark, kSkewMark);
          for (int a = 0; a < 3; ++a) ASSERT_GE(std::abs(cert.along[a]), 0.01);
          ++skew;
        } else {
          ASSERT_TRUE(is_cone(cert.verdict));
          ASSERT_EQ(mark, kSkewMark + 1 + 2 * cert.mixed + (cert.twice ? 1 : 0));
          ASSERT_FALSE(cert.inherited);
          ++cones;
        }
        audit_extruded(w, cert, box, rng);
        if (HasFatalFailure()) return;
      }
    }
  }
  EXPECT_GT(skew, tried / 6) << "of " << tried;
  EXPECT_GT(cones, 0) << "of " << tried;
  // The same socket with its cavity's shell written inside out (its normals point into the
  // material, as an outer skin's would): the material side is found by the shells' nesting,
  // not by the vertex order, so every rim cell gets the certificate it had, and it holds
  // under the brute-force audit on the turned scene.
  Scene inverted = w.scene;
  SceneObject& socket = inverted.objects[0];
  for (size_t t = 12; t < socket.simplices.size(); ++t)
    std::swap(socket.simplices[t].v[1], socket.simplices[t].v[2]);
  const World wi(std::move(inverted));
  const PairCertifier inverted_certifier(wi.geometry, wi.bvh, nullptr, true, true);
  int same = 0;
  for (int level = 8; level <= 11; ++level) {
    for (const Vec3& rim : rims) {
      const Box box = lattice_cell_at(wi.domain.to_unit(rim), level);
      const PairCertifier::Certificate drawn = certifier.certify(box);
      const PairCertifier::Certificate cert = inverted_certifier.certify(box);
      ASSERT_EQ(cert.verdict, drawn.verdict) << "level " << level;
      ASSERT_EQ(cert.skew, drawn.skew);
      if (!cert.skew) continue;
      ++same;
      audit_extruded(wi, cert, box, rng);
      if (HasFatalFailure()) return;
    }
  }
  EXPECT_GT(same, 0);
}

// The scene with every vertex moved by `turn`, in the user's frame (World).
template <class Turn>
World turned_world(const Scene& scene, Turn turn) {
  Scene turned = scene;
  for (SceneObject& obj : turned.objects)
    for (Vec3& v : obj.vertices) v = turn(v);
  return World(std::move(turned));
}

// Certifies cells of levels 8 ... 11 around each of `rims` (user units), `per_rim` per level at
// random offsets. Every wedge among them (a certificate with a monotone axis) is skew, passes
// `check`, carries its wedge mark, has its children asked again and holds under
// audit_extruded. Counts the cells tried and the wedges; g_twice_seen counts the lines that
// met the bisector twice.
template <class Check>
void audit_wedges_near(const World& t, const PairCertifier& certifier,
                       const std::vector<Vec3>& rims, uint64_t seed, int per_rim, Check check,
                       int& wedges, int& tried) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  wedges = tried = 0;
  g_twice_seen = 0;
  for (int level = 8; level <= 11; ++level) {
    const double cell = std::ldexp(1.0, -level);
    for (const Vec3& rim : rims) {
      for (int k = 0; k < per_rim; ++k) {
        Vec3 unit = t.domain.to_unit(rim);
        for (int a = 0; a < 3; ++a) unit[a] += 0.5 * u(rng) * cell;
        const Box box = lattice_cell_at(unit, level);
        const PairCertifier::Certificate cert = certifier.certify(box);
        ++tried;
        if (cert.monotone < 0) continue;
        ASSERT_TRUE(cert.skew);
        ASSERT_NEAR(norm(cert.along), 1, 1e-12);
        check(cert);
        if (::testing::Test::HasFatalFailure()) return;
        ASSERT_TRUE(is_cone(cert.verdict));
        const uint8_t mark = certified_mark(cert.verdict);
        ASSERT_EQ(mark, kSkewWedgeMark + 2 * cert.monotone + (cert.twice ? 1 : 0));
        ASSERT_EQ(inherited_mark(mark), 0) << "children must be asked again";
        ++wedges;
        audit_extruded(t, cert, box, rng);
        if (::testing::Test::HasFatalFailure()) return;
      }
    }
  }
}

TEST(PairCertifier, WedgeCellsHoldUnderBruteForce3D) {
  // The blade in its slot turned 30 degrees about y, then 20 about x: the blade's edges at its
  // ends (along y before the turn) are square to x, and the normals of their two faces (the
  // blade's side, its end) straddle w, the direction square to the edge in the yz plane, so
  // they straddle both y and z and keep one sign along x alone. Cells there are wedges: d_a
  // and d_b invariant along e, one sign change along the rise and along x, at most two along
  // y and z at the cell's quarters, and `twice` where there are two.
  const BladeCase blade;
  const double pi = std::acos(-1.0);
  auto turn = [&](Vec3 v) {
    return test::rotate(test::rotate(v, Vec3{0, 1, 0}, pi / 6), Vec3{1, 0, 0}, pi / 9);
  };
  const World t = turned_world(blade.world.scene, turn);
  const PairCertifier certifier(t.geometry, t.bvh, nullptr, true, true);
  std::vector<Vec3> rims;
  for (const Vec3& p : blade.end_edges()) rims.push_back(turn(p));
  int wedges = 0, tried = 0;
  audit_wedges_near(
      t, certifier, rims, 23, 3,
      [](const PairCertifier::Certificate& cert) {
        ASSERT_EQ(cert.monotone, 0) << "the edges are square to x";
        ASSERT_NEAR(cert.along.x, 0, 1e-12);
        ASSERT_EQ(cert.mixed, 1);
      },
      wedges, tried);
  if (HasFatalFailure()) return;
  EXPECT_GT(wedges, tried / 4) << "of " << tried;
  EXPECT_GT(g_twice_seen, 0) << "no line met the bisector twice: the audit saw no wedge's roof";
  // Without cones, no wedge either.
  const PairCertifier no_cones(t.geometry, t.bvh, nullptr, true, false);
  for (const Vec3& rim : rims)
    EXPECT_LT(no_cones.certify(lattice_cell_at(t.domain.to_unit(rim), 9)).monotone, 0);
}

TEST(PairCertifier, SkewWedgeCellsHoldUnderBruteForce3D) {
  // The blade in its slot turned 0.7 rad about the skew axis (2, -1, 3): its rims are square
  // to no axis, and the normals of their two faces straddle two axes and keep one sign along
  // the third. Cells there are wedges across both straddled axes, e square to no axis: d_a
  // and d_b invariant along e, one sign change along the rise and along the monotone axis, at
  // most two along the straddled ones at the cell's quarters, `twice` where there are two.
  const BladeCase blade;
  const double g = blade.g, x0 = blade.x0, x1 = blade.x1, floor_y = blade.floor_y;
  const Vec3 axis = Vec3{2, -1, 3} / std::sqrt(14.0);
  auto turn = [&](Vec3 v) { return test::rotate(v, axis, 0.7); };
  const World t = turned_world(blade.world.scene, turn);
  const PairCertifier certifier(t.geometry, t.bvh, nullptr, true, true);
  // Beside the blade's bottom edges and the slot's mouth, and its end edges.
  std::vector<Vec3> rims;
  for (double z : {0.3, 0.5, 0.7}) {
    rims.push_back(turn({x0 - 0.5 * g, floor_y + 0.5 * g, z}));
    rims.push_back(turn({x1 + 0.5 * g, floor_y + 0.5 * g, z}));
    rims.push_back(turn({x0 - 0.5 * g, 0.5, z}));
  }
  for (const Vec3& p : blade.end_edges()) rims.push_back(turn(p));
  int wedges = 0, tried = 0;
  audit_wedges_near(
      t, certifier, rims, 29, 2,
      [](const PairCertifier::Certificate& cert) {
        for (int a = 0; a < 3; ++a)
          ASSERT_GT(std::abs(cert.along[a]), 0.009) << "square to no axis";
        ASSERT_NE(cert.mixed, cert.monotone);
      },
      wedges, tried);
  if (HasFatalFailure()) return;
  EXPECT_GT(wedges, tried / 4) << "of " << tried;
  EXPECT_GT(g_twice_seen, 0) << "no line met the bisector twice: the audit saw no wedge's roof";
}

TEST(PairCertifier, ExtrudedConeCellsHoldUnderBruteForce3D) {
  // A hexagonal shaft in its bore: at the corners on the x axis the normals of the two faces
  // (+-30 degrees) straddle the x axis, so only the cell's own lines along y are checked and
  // sub-cells are asked again (inherited = false).
  test::ShaftInBoreOptions o;
  o.gap = 1e-3;
  o.cell = 0.1;
  const double g = o.gap * make_domain(test::make_shaft_in_bore(o)).side;
  // The apex of the bisector at the corner on +x, between the shaft's corner and the bore's:
  // lines along y just inside it meet the bisector twice.
  const double apex = o.radius - 0.5 * g / std::cos(std::acos(-1.0) / 6);
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  int cone = 0, quadrant = 0;
  g_twice_seen = 0;
  // A small block far off makes the domain lopsided, so that the apex falls inside cells
  // rather than on the lattice planes through the domain's middle; four sizes of it place the
  // apex differently in the cells.
  for (double far_y : {0.6113, 0.6291, 0.6457, 0.6702}) {
    Scene scene = test::make_shaft_in_bore(o);
    scene.objects.push_back(test::make_box("far", {0.3, 0.55, 0.3}, {0.35, far_y, 0.35}));
    const World s(std::move(scene));
    const PairCertifier certifier(s.geometry, s.bvh, nullptr, true, true);
    for (int level = 8; level <= 12; ++level) {
      const double cell = std::ldexp(1.0, -level);
      const Vec3 at = s.domain.to_unit({apex, 0, 0.3});
      for (int i = -1; i <= 0; ++i)
        for (int j = -1; j <= 1; ++j) {
          const Box box = lattice_cell_at(at + Vec3{i * cell, j * cell, 0}, level);
          const PairCertifier::Certificate cert = certifier.certify(box);
          if (cert.axis < 0) continue;
          ASSERT_EQ(cert.axis, 2);
          ASSERT_EQ(cert.verdict,
                    cert.inherited ? extruded_verdict(2) : cone_verdict(2, cert.mixed, cert.twice));
          cone += !cert.inherited;
          audit_extruded(s, cert, box, rng);
          if (HasFatalFailure()) return;
        }
    }
    if (far_y != 0.6113) continue;
    // Cells along the rims at three corners: 0 degrees (a cone), 60 (a quadrant), 180 (a cone).
    for (int level = 7; level <= 11; ++level) {
      const double cell = std::ldexp(1.0, -level);
      for (double corner : {0.0, 60.0, 180.0}) {
        const double a = corner * std::acos(-1.0) / 180;
        const Vec3 rim{(o.radius - g) * std::cos(a), (o.radius - g) * std::sin(a), 0};
        for (int k = 0; k < 4; ++k) {
          Vec3 p = rim;
          p.z = 0.3 + 0.1 * u(rng);
          Vec3 unit = s.domain.to_unit(p);
          for (int i = 0; i < 3; ++i) unit[i] += 0.5 * u(rng) * cell;
          const Box box = lattice_cell_at(unit, level);
          const PairCertifier::Certificate cert = certifier.certify(box);
          if (cert.axis < 0) continue;
          ASSERT_EQ(cert.axis, 2);
          ASSERT_EQ(cert.verdict,
                    cert.inherited ? extruded_verdict(2) : cone_verdict(2, cert.mixed, cert.twice));
          (cert.inherited ? quadrant : cone) += 1;
          if (!cert.inherited) {
            ASSERT_EQ(cert.mixed, 1);
          }
          audit_extruded(s, cert, box, rng);
          if (HasFatalFailure()) return;
        }
      }
    }
  }
  EXPECT_GT(cone, 0);
  EXPECT_GT(quadrant, 0);
  EXPECT_GT(g_twice_seen, 0) << "no cell beside the apex was tried";
}

TEST(PairCertifier, ExtrudedCellsNeedClosedStraightQuadrantRims) {
  // Rims of a blade in a slot that are not straight along an axis: the ends (the blade's
  // corners, where rims along two axes meet) and a copy tilted about x.
  const BladeCase blade;
  const World& s = blade.world;
  const PairCertifier& certifier = blade.certifier;
  const test::BladeInSlotOptions& o = blade.options;
  const double g = blade.g, x0 = blade.x0, floor_y = blade.floor_y;
  const Box corner = user_cube(s, Vec3{x0, floor_y + g, 0.1} - Vec3{g, g, g}, 2 * g);
  EXPECT_LT(certifier.certify(corner).axis, 0) << "the blade's corner";
  // Straight rims along z, but the cell reaches both walls of the slot: the blade's outward
  // normals -x and +x lie in no quadrant.
  const Box across = user_cube(s, {x0 - 0.01, floor_y - 0.01, 0.5}, o.width + 0.02);
  EXPECT_LT(certifier.certify(across).axis, 0) << "both bottom edges";
  // Tilted about a skew axis (the octree kept on x, y, z): rims along no axis nor square to
  // one are not certified.
  Scene tilted = s.scene;
  const Vec3 skew = Vec3{2, -1, 3} / std::sqrt(14.0);
  for (SceneObject& obj : tilted.objects)
    for (Vec3& v : obj.vertices) v = test::rotate(v, skew, 0.2);
  const World t(std::move(tilted));
  const PairCertifier tilted_certifier(t.geometry, t.bvh, nullptr, true);
  for (int k = 0; k < 8; ++k) {
    const Vec3 rim = test::rotate({x0, floor_y + g, 0.3 + 0.05 * k}, skew, 0.2);
    const Box box = user_cube(t, rim - Vec3{2 * g, 2 * g, 2 * g}, 4 * g);
    const PairCertifier::Certificate cert = tilted_certifier.certify(box);
    EXPECT_LT(cert.axis, 0) << "a rim off the axes";
    EXPECT_LT(cert.slanted, 0) << "a rim off the axes";
  }
  // An open sheet over a box: the sheet is not closed.
  const World open(test::make_scene(
      3, {make_sheet("sheet", 0.2, 4), test::make_box("box", {0.2, 0.2, 0}, {0.8, 0.8, 0.199})}));
  const PairCertifier open_certifier(open.geometry, open.bvh, nullptr, true);
  const Box edge = user_cube(open, {0.19, 0.5, 0.19}, 0.02);
  EXPECT_LT(open_certifier.certify(edge).axis, 0) << "an open sheet";
  // A box over a slab, 1e-3 apart: its rim along y is extruded, also when the box is one of
  // two shells of one object (neither inside the other: both are outer skins), and also when
  // the second shell is written inside out (the material side comes from the nesting, not the
  // vertex order) — but not when the second shell encloses no volume (two copies of one
  // triangle, back to back: a closed shell with no material side).
  enum class Second { kNone, kOutward, kInverted, kFlat };
  auto box_over_slab = [](Second second) {
    SceneObject box = test::make_box("box", {0.2, 0.1001, 0.2}, {0.6, 0.3, 0.6});
    if (second == Second::kFlat) {
      const auto base = static_cast<uint32_t>(box.vertices.size());
      box.vertices.insert(box.vertices.end(), {{0.7, 0.5, 0.7}, {0.9, 0.5, 0.7}, {0.7, 0.7, 0.9}});
      box.simplices.push_back({{base, base + 1, base + 2}});
      box.simplices.push_back({{base, base + 2, base + 1}});
    } else if (second != Second::kNone) {
      const SceneObject other = test::make_box("x", {0.7, 0.5, 0.7}, {0.9, 0.7, 0.9});
      const uint32_t base = static_cast<uint32_t>(box.vertices.size());
      box.vertices.insert(box.vertices.end(), other.vertices.begin(), other.vertices.end());
      for (Simplex tri : other.simplices) {
        for (uint32_t& v : tri.v) v += base;
        if (second == Second::kInverted) std::swap(tri.v[1], tri.v[2]);
        box.simplices.push_back(tri);
      }
    }
    Scene scene;
    scene.dimension = 3;
    scene.objects = {test::make_box("slab", {0, 0, 0}, {1, 0.1, 1}), box};
    return scene;  // not validated: validation would keep each shell's orientation anyway
  };
  for (const Second second : {Second::kNone, Second::kOutward, Second::kInverted, Second::kFlat}) {
    const World w(box_over_slab(second));
    const PairCertifier c(w.geometry, w.bvh, nullptr, true);
    const Box rim = user_cube(w, {0.195, 0.0995, 0.4}, 0.01);
    EXPECT_EQ(c.certify(rim).axis >= 0, second != Second::kFlat)
        << static_cast<int>(second)
        << ": none, two outward shells, the second inverted, the second flat";
  }
}

// A box over a slab, 1e-3 apart, whose bottom face is a 3 x 3 grid of quads: its grid points
// on the face's sides are T-junctions (the side faces' edges run past them), so no edge of
// the bottom's rim has one triangle across, yet the box is closed. Its rim cells get the
// certificate the conforming box's get, and it holds under the brute-force audit. With the
// grid's own points (not the box's corners) lowered by 1e-9, those on the rim lie off the
// side faces' edges: a crack along the rim, and no extruded certificate.
TEST(PairCertifier, TJunctionsCloseAShell) {
  auto box_over_slab = [](int k, double drop) {
    SceneObject box =
        test::make_box_with_split_bottom("box", {0.2, 0.2, 0.1001}, {0.6, 0.6, 0.3}, k);
    for (size_t v = 8; v < box.vertices.size(); ++v) box.vertices[v].z -= drop;  // not corners
    Scene scene;
    scene.dimension = 3;
    scene.objects = {test::make_box("slab", {0, 0, 0}, {1, 1, 0.1}), box};
    return scene;
  };
  const World plain(box_over_slab(1, 0));
  const World split(box_over_slab(3, 0));
  const World cracked(box_over_slab(3, 1e-9));
  const PairCertifier c_plain(plain.geometry, plain.bvh, nullptr, true);
  const PairCertifier c_split(split.geometry, split.bvh, nullptr, true);
  const PairCertifier c_cracked(cracked.geometry, cracked.bvh, nullptr, true);
  std::mt19937_64 rng(7);
  int certified = 0;
  // Cells along the rim x = 0.2 (along y) and y = 0.2 (along x), where the bottom's grid
  // points at 1/3 and 2/3 of the side lie.
  for (const Vec3 at : {Vec3{0.195, 0.3, 0.0995}, Vec3{0.195, 0.33, 0.0995},
                        Vec3{0.195, 0.4666, 0.0995}, Vec3{0.3333, 0.195, 0.0995}}) {
    SCOPED_TRACE(std::to_string(at.x) + ", " + std::to_string(at.y));
    const PairCertifier::Certificate want = c_plain.certify(user_cube(plain, at, 0.01));
    const Box box = user_cube(split, at, 0.01);
    const PairCertifier::Certificate cert = c_split.certify(box);
    ASSERT_GE(want.axis, 0);
    EXPECT_EQ(cert.verdict, want.verdict);
    EXPECT_EQ(cert.axis, want.axis);
    if (cert.axis < 0) continue;
    ++certified;
    audit_extruded(split, cert, box, rng);
    if (HasFatalFailure()) return;
    EXPECT_LT(c_cracked.certify(user_cube(cracked, at, 0.01)).axis, 0) << "a crack";
  }
  EXPECT_EQ(certified, 4);
}

TEST(PairCertifier, PartsGluedIntoOneObjectCloseIt) {
  // The walls' edges on the floor's top are used by four triangles, and the walls' undersides
  // lie inside the slot: it was not closed to the certificates, so no rim of it was
  // extruded (434,512 leaves at 1e-3, the leaf limit at 1e-5). Now its parts are paired around
  // those edges, by index or by angle, the glued faces left out: beside the floor's corners and
  // the slot's mouth, wherever the same slot written as one closed mesh is certified, so is
  // this one, held under brute force.
  const double g = 1e-3;
  test::SlotOfPartsOptions one;
  one.boxes = false;
  one.gap = g;
  const World twin(test::make_slot_of_parts(one));
  const PairCertifier c_twin(twin.geometry, twin.bvh, nullptr, true);
  struct Variant {
    const char* name;
    double walls_from;
    bool weld;
  };
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  for (const Variant& v : {Variant{"standing", 0.2, false}, Variant{"welded", 0.2, true},
                           Variant{"pushed in", 0.1, false}}) {
    SCOPED_TRACE(v.name);
    test::SlotOfPartsOptions parts;
    parts.walls_from = v.walls_from;
    parts.weld = v.weld;
    parts.gap = g;
    const World s(test::make_slot_of_parts(parts));
    const PairCertifier certifier(s.geometry, s.bvh, nullptr, true);
    int certified = 0, tried = 0;
    for (int level = 7; level <= 11; ++level) {
      const double cell = std::ldexp(1.0, -level);
      for (const Vec3 rim : {Vec3{0.45, 0.2, 0}, Vec3{0.55, 0.2, 0}, Vec3{0.45, 0.5, 0},
                             Vec3{0.55, 0.5, 0}, Vec3{0.5, 0.2, 0}, Vec3{0.45, 0.35, 0}}) {
        for (int k = 0; k < 3; ++k) {
          Vec3 p = rim + Vec3{0.5 * g * u(rng), 0.5 * g * u(rng), 0};
          p.z = 0.3 + 0.2 * (u(rng) + 1);
          Vec3 unit = s.domain.to_unit(p);
          for (int a = 0; a < 3; ++a) unit[a] += u(rng) * cell;
          const Box box = lattice_cell_at(unit, level);
          const PairCertifier::Certificate want = c_twin.certify(box);
          if (want.verdict == CellVerdict::kSplit) continue;
          ++tried;
          const PairCertifier::Certificate cert = certifier.certify(box);
          ASSERT_NE(cert.verdict, CellVerdict::kSplit)
              << "level " << level << " near " << rim.x << ", " << rim.y;
          if (cert.verdict == CellVerdict::kOneObject) {
            // Inside a wall the glued faces are nearer than the U's surface: one object. No
            // point of the cell may be nearer to the other.
            std::uniform_real_distribution<double> t(0, 1);
            for (int i = 0; i < 64; ++i) {
              Vec3 x;
              for (int a = 0; a < 3; ++a) x[a] = box.lo[a] + t(rng) * (box.hi[a] - box.lo[a]);
              const Vec3 q = s.domain.from_unit(x);
              ASSERT_LE(test::brute_distance(s.scene, cert.a, q),
                        test::brute_distance(s.scene, 1 - cert.a, q) + 1e-15);
            }
            continue;
          }
          EXPECT_EQ(cert.verdict, want.verdict)
              << "level " << level << " near " << rim.x << ", " << rim.y;
          if (cert.axis < 0) continue;
          ++certified;
          audit_extruded(s, cert, box, rng);
          if (HasFatalFailure()) return;
        }
      }
    }
    EXPECT_GT(tried, 20);
    EXPECT_GT(certified, tried / 4);
  }
}

TEST(PairCertifier, ParallelPlatesAreCertifiedAcrossTheGap) {
  const World s(test::make_scene(3, {test::make_box("low", {0, 0, 0}, {1, 1, 0.1}),
                                     test::make_box("high", {0, 0, 0.1001}, {1, 1, 0.2})}));
  const PairCertifier certifier(s.geometry, s.bvh);
  // A cell in the middle of the plates holding both faces and the gap (0.1 .. 0.1001).
  auto cell_at = [&](Vec3 lo_user, double size_user) { return user_cube(s, lo_user, size_user); };
  const PairCertifier::Certificate mid = certifier.certify(cell_at({0.45, 0.45, 0.09}, 0.03));
  ASSERT_EQ(mid.verdict, CellVerdict::kPair);
  EXPECT_EQ(mid.a, 0u);
  EXPECT_EQ(mid.b, 1u);
  EXPECT_NEAR(std::abs(mid.normal[0].z), 1.0, 1e-15);
  EXPECT_NEAR(std::abs(mid.normal[1].z), 1.0, 1e-15);
  EXPECT_FALSE(mid.mirror);
  // Next to the plates' rim the nearest points can be on their side faces: not flat, but the
  // rims are flush, so near the gap each plate is the other's mirror image across z = 0.10005.
  const PairCertifier::Certificate rim = certifier.certify(cell_at({0.985, 0.45, 0.09}, 0.03));
  ASSERT_EQ(rim.verdict, CellVerdict::kPair);
  EXPECT_TRUE(rim.mirror);
  EXPECT_NEAR(rim.normal[0].z, 1.0, 1e-15);  // from "low" towards "high"
  EXPECT_NEAR(s.domain.from_unit(rim.normal[0] * rim.offset[0]).z, 0.10005, 1e-12);
  // Deep inside the low plate, far from the high one relative to the cell: one object.
  EXPECT_EQ(certifier.certify(cell_at({0.45, 0.45, 0.02}, 0.01)).verdict, CellVerdict::kOneObject);
}

TEST(PairCertifier, MirrorRimsNeedExactMirrorImages) {
  // Flush plates, but the high one 0.002 shorter on +x: near that rim they are no mirror
  // images, near the -x rim they are.
  const World s(test::make_scene(3, {test::make_box("low", {0, 0, 0}, {1, 1, 0.1}),
                                     test::make_box("high", {0, 0, 0.1001}, {0.998, 1, 0.2})}));
  const PairCertifier certifier(s.geometry, s.bvh);
  auto cell_at = [&](Vec3 lo_user, double size_user) { return user_cube(s, lo_user, size_user); };
  EXPECT_EQ(certifier.certify(cell_at({0.985, 0.45, 0.09}, 0.03)).verdict, CellVerdict::kSplit);
  const PairCertifier::Certificate rim = certifier.certify(cell_at({-0.015, 0.45, 0.09}, 0.03));
  ASSERT_EQ(rim.verdict, CellVerdict::kPair);
  EXPECT_TRUE(rim.mirror);
  // Too wide a gap for mirror cells (0.03 of a 1.1 domain > kMirrorGap): the paper's rule
  // resolves it.
  const World wide(test::make_scene(3, {test::make_box("low", {0, 0, 0}, {1, 1, 0.1}),
                                        test::make_box("high", {0, 0, 0.13}, {1, 1, 0.23})}));
  const PairCertifier wide_certifier(wide.geometry, wide.bvh);
  EXPECT_EQ(wide_certifier.certify(user_cube(wide, {0.985, 0.45, 0.09}, 0.03)).verdict,
            CellVerdict::kSplit);
}

TEST(PairCertifier, MirrorCellsHoldUnderBruteForce3D) {
  // Three flush stacked plates (every rim a mirror rim) and a tilted copy of two of them
  // (rotated by 0.3 rad about a skew axis: mirror images only up to rounding).
  for (const bool tilted : {false, true}) {
    SCOPED_TRACE(tilted ? "tilted" : "axis-aligned");
    std::vector<SceneObject> objects;
    for (int i = 0; i < (tilted ? 2 : 3); ++i) {
      const double z0 = i * 0.1004;
      objects.push_back(
          test::make_box("plate_" + std::to_string(i), {0, 0, z0}, {0.6, 0.5, z0 + 0.1}));
    }
    if (tilted) {
      const Vec3 axis = Vec3{1, 2, 3} / std::sqrt(14.0);
      for (SceneObject& o : objects)
        for (Vec3& p : o.vertices) p = test::rotate(p, axis, 0.3);
    }
    const World s(test::make_scene(3, std::move(objects)));
    int certified = 0, mirrors = 0;
    for (int level = 3; level <= 5; ++level) certified += audit_level(s, level, 24, &mirrors);
    EXPECT_GT(mirrors, 100) << certified << " certified";
  }
}

TEST(PairCertifier, CertifiedCellsHoldUnderBruteForce3D) {
  const World s(test::make_scene(3, {make_sheet("floor", 0.0, 6), make_sheet("ceiling", 0.013, 5),
                                     test::make_box("post", {0.8, 0.8, 0.3}, {0.9, 0.9, 0.5})}));
  int certified = 0;
  for (int level = 3; level <= 5; ++level) certified += audit_level(s, level, 24);
  EXPECT_GT(certified, 1000);
}

TEST(PairCertifier, CertifiedCellsHoldUnderBruteForce2D) {
  // Two bars, a tilted segment chain and a square: parallel and non-parallel flat pairs.
  SceneObject chain;
  chain.label = "chain";
  for (int i = 0; i <= 8; ++i) chain.vertices.push_back({0.1 + 0.1 * i, 0.5 + 0.03 * i, 0});
  for (uint32_t i = 0; i < 8; ++i) chain.simplices.push_back({{i, i + 1, 0}});
  const World s(
      test::make_scene(2, {test::make_rect("a", {0, 0, 0}, {1, 0.2, 0}),
                           test::make_rect("b", {0, 0.2004, 0}, {1, 0.4, 0}), std::move(chain),
                           test::make_rect("c", {0.2, 0.8, 0}, {0.4, 0.9, 0})}));
  int certified = 0;
  for (int level = 3; level <= 8; ++level) certified += audit_level(s, level, 32);
  EXPECT_GT(certified, 1000);
}

TEST(PairCertifier, OpenRimsFoldsAndNonManifoldSidesAreNotCertified) {
  // Two small sheets facing each other: cells reaching their open rims are not certified;
  // cells well inside are.
  {
    const World s(test::make_scene(3, {make_sheet("a", 0.0, 4), make_sheet("b", 0.01, 4)}));
    const PairCertifier certifier(s.geometry, s.bvh);
    Box inner;
    inner.lo = s.domain.to_unit({0.45, 0.45, -0.01});
    inner.hi = s.domain.to_unit({0.5, 0.5, 0.04});
    EXPECT_EQ(certifier.certify(inner).verdict, CellVerdict::kPair);
    Box rim;
    rim.lo = s.domain.to_unit({0.97, 0.45, -0.01});
    rim.hi = s.domain.to_unit({1.02, 0.5, 0.04});
    EXPECT_EQ(certifier.certify(rim).verdict, CellVerdict::kSplit);
  }
  // A sheet folded back onto itself (two coplanar triangles on the same side of their shared
  // edge) is not a plane patch even though all its vertices are coplanar.
  {
    SceneObject folded;
    folded.label = "folded";
    folded.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.5, 0.8, 0}};
    folded.simplices = {{{0, 1, 2}}, {{0, 1, 3}}};
    const World s(test::make_scene(3, {std::move(folded), make_sheet("b", 0.01, 2)}));
    const PairCertifier certifier(s.geometry, s.bvh);
    Box cell;
    cell.lo = s.domain.to_unit({0.2, -0.05, -0.01});
    cell.hi = s.domain.to_unit({0.3, 0.05, 0.04});
    EXPECT_EQ(certifier.certify(cell).verdict, CellVerdict::kSplit);
  }
}

// Packed columns (3 x 3 boxes along z, gap g) and a blade in a slot of three separate parts
// (floor, two walls, all g apart): lines along z where three or four objects meet. Cells on
// those lines are junction cells; at sampled points of each, every active object's distance
// is invariant along e (brute force) and no other object is nearer than the nearest active one.
// Cells that reach the columns' ends, or the same columns turned by 0.2 rad, are not.
TEST(PairCertifier, JunctionCellsHoldUnderBruteForce3D) {
  const double g = 1e-3;
  const Scene columns = test::make_packed_columns(3, 0.3, g);
  const Scene slot = test::make_slot_of_separate_parts(g);
  struct Case {
    const char* name;
    Scene scene;
    std::vector<Vec3> lines;  // points (x, y) of the junction lines along z
  };
  std::vector<Case> cases;
  cases.push_back(
      {"columns", columns, {{0.3, 0.3, 0}, {0.6, 0.3, 0}, {0.3, 0.6, 0}, {0.6, 0.6, 0}}});
  cases.push_back({"slot of parts", slot, {{0.45, 0.2, 0}, {0.55, 0.2, 0}}});
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> u(-1, 1), t(0, 1);
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const World s(c.scene);
    const ContactPairs contacts = find_contact_pairs(s.geometry, s.bvh, contact_tolerance(21));
    const PairCertifier certifier(s.geometry, s.bvh, &contacts, true);
    int certified = 0;
    for (int level = 5; level <= 12; ++level) {
      const double cell = std::ldexp(1.0, -level);
      int at_level = 0;
      for (const Vec3 line : c.lines) {
        for (int k = 0; k < 4; ++k) {
          Vec3 p = line + Vec3{0.5 * g * u(rng), 0.5 * g * u(rng), 0};
          p.z = 0.35 + 0.3 * t(rng);
          Vec3 unit = s.domain.to_unit(p);
          for (int a = 0; a < 2; ++a) unit[a] += u(rng) * cell;
          const Box box = lattice_cell_at(unit, level);
          const PairCertifier::Junction j = certifier.certify_junction(box);
          if (!j.certified) continue;
          ++at_level;
          ASSERT_EQ(j.axis, 2);
          ASSERT_GE(j.n_objects, 3);
          for (int i = 0; i < 24; ++i) {
            Vec3 x, y;
            for (int a = 0; a < 3; ++a) x[a] = box.lo[a] + t(rng) * (box.hi[a] - box.lo[a]);
            y = x;
            y.z = box.lo.z + t(rng) * (box.hi.z - box.lo.z);
            const Vec3 qx = s.domain.from_unit(x), qy = s.domain.from_unit(y);
            double nearest_active = 1e300;
            for (int k2 = 0; k2 < j.n_objects; ++k2) {
              const double dx = test::brute_distance(s.scene, j.objects[k2], qx);
              const double dy = test::brute_distance(s.scene, j.objects[k2], qy);
              ASSERT_NEAR(dx, dy, 1e-12) << "object " << j.objects[k2] << " level " << level;
              nearest_active = std::min(nearest_active, dx);
            }
            for (ObjectId o = 0; o < s.scene.objects.size(); ++o) {
              if (std::find(j.objects, j.objects + j.n_objects, o) != j.objects + j.n_objects)
                continue;
              ASSERT_GT(test::brute_distance(s.scene, o, qx), nearest_active)
                  << "object " << o << " level " << level;
            }
          }
        }
      }
      EXPECT_GT(at_level, 0) << "level " << level;
      certified += at_level;
    }
    EXPECT_GT(certified, 0);
    // At the columns' ends (and the blade's, which runs past the slot) the strips end: a cell
    // reaching z = 1 is no junction cell.
    for (int level = 5; level <= 10; ++level) {
      const Box box = lattice_cell_at(s.domain.to_unit(c.lines[0] + Vec3{0, 0, 1}), level);
      EXPECT_FALSE(certifier.certify_junction(box).certified) << "an end, level " << level;
    }
  }
  // The columns turned by 0.2 rad about x: their faces are square to no axis.
  Scene turned = columns;
  for (SceneObject& o : turned.objects)
    for (Vec3& v : o.vertices) v = test::rotate(v, Vec3{1, 0, 0}, 0.2);
  const World s(turned);
  const PairCertifier certifier(s.geometry, s.bvh, nullptr, true);
  for (int level = 5; level <= 10; ++level) {
    const Vec3 p = test::rotate(Vec3{0.3, 0.3, 0.5}, Vec3{1, 0, 0}, 0.2);
    EXPECT_FALSE(certifier.certify_junction(lattice_cell_at(s.domain.to_unit(p), level)).certified)
        << "turned, level " << level;
  }
}

// A child of a junction cell beside the line may see two of its objects only, a rim of one
// in reach of the other (no pair certificate): a blade's bottom edge over a floor g below,
// the blade's side in reach. classify_child makes it a junction cell of two along the
// parent's axis (z: the floor's top and the blade's bottom are square to x as well, but the
// blade's bottom ends across x); classify alone, or under another parent, splits it. Brute
// force: both distances invariant along z in every such cell.
TEST(PairCertifier, TwoObjectJunctionCellsUnderJunctionCellsHoldUnderBruteForce3D) {
  const double g = 1e-3;
  Scene scene;
  scene.dimension = 3;
  scene.objects.push_back(test::make_box("floor", {0, 0, 0}, {1, 0.2, 1}));
  scene.objects.push_back(test::make_box("blade", {0.45, 0.2 + g, -0.1}, {0.55, 0.6, 1.1}));
  const World s(scene);
  PairCertifier certifier(s.geometry, s.bvh, nullptr, true);
  certifier.enable_junctions();
  const uint8_t junction_z = certified_mark(CellVerdict::kJunctionZ);
  std::mt19937_64 rng(23);
  std::uniform_real_distribution<double> u(-1, 1), t(0, 1);
  int two = 0;
  for (int level = 5; level <= 12; ++level) {
    const double cell = std::ldexp(1.0, -level);
    for (int k = 0; k < 16; ++k) {
      const Vec3 p{0.45 + 2 * g * u(rng), 0.2 + 0.5 * g + g * u(rng), 0.3 + 0.4 * t(rng)};
      Vec3 unit = s.domain.to_unit(p);
      for (int a = 0; a < 2; ++a) unit[a] += 0.5 * u(rng) * cell;
      const Box box = lattice_cell_at(unit, level);
      const CellVerdict v = certifier.classify_child(box, {}, junction_z);
      if (v == certifier.classify(box)) continue;
      ASSERT_EQ(certifier.classify(box), CellVerdict::kSplit);
      ASSERT_EQ(v, CellVerdict::kJunctionZ) << "level " << level;
      EXPECT_EQ(certifier.classify_child(box, {}, certified_mark(CellVerdict::kPair)),
                CellVerdict::kSplit);
      ++two;
      for (int i = 0; i < 24; ++i) {
        Vec3 x;
        for (int a = 0; a < 3; ++a) x[a] = box.lo[a] + t(rng) * (box.hi[a] - box.lo[a]);
        Vec3 y = x;
        y.z = box.lo.z + t(rng) * (box.hi.z - box.lo.z);
        for (ObjectId o = 0; o < 2; ++o) {
          ASSERT_NEAR(test::brute_distance(scene, o, s.domain.from_unit(x)),
                      test::brute_distance(scene, o, s.domain.from_unit(y)), 1e-12)
              << "object " << o << " level " << level;
        }
      }
    }
  }
  EXPECT_GT(two, 0);
  // Not where the floor ends (z = 1).
  for (int level = 5; level <= 10; ++level) {
    const Box box = lattice_cell_at(s.domain.to_unit(Vec3{0.45, 0.2 + 0.5 * g, 1}), level);
    EXPECT_NE(certifier.classify_child(box, {}, junction_z), CellVerdict::kJunctionZ)
        << "an end, level " << level;
  }
}

}  // namespace
}  // namespace gvd
