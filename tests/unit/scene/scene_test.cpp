// validate_scene, make_domain, make_unit_geometry.
#include "gvd/scene/scene.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "gvd/common/error.h"
#include "gvd/geometry/simplex_bvh.h"
#include "support/scenes.h"
#include "support/thin_gap_scenes.h"

namespace gvd {

using namespace gvd::scene;

namespace {

/// Runs f and checks that it throws gvd::Error with `code` and a detail containing `part`.
template <class F>
void expect_error(F&& f, ErrorCode code, const std::string& part) {
  try {
    f();
    ADD_FAILURE() << "no error; expected one containing \"" << part << "\"";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), code) << e.what();
    EXPECT_NE(e.detail().find(part), std::string::npos) << e.detail();
  }
}

SceneObject tetrahedron(const std::string& label, Vec3 at = {}) {
  SceneObject o;
  o.label = label;
  o.vertices = {at, at + Vec3{1, 0, 0}, at + Vec3{0, 1, 0}, at + Vec3{0, 0, 1}};
  o.simplices = {{{0, 2, 1}}, {{0, 1, 3}}, {{1, 2, 3}}, {{0, 3, 2}}};
  return o;
}

SceneObject square_2d(const std::string& label, Vec3 at = {}) {
  SceneObject o;
  o.label = label;
  o.vertices = {at, at + Vec3{1, 0, 0}, at + Vec3{1, 1, 0}, at + Vec3{0, 1, 0}};
  o.simplices = {{{0, 1, 0}}, {{1, 2, 0}}, {{2, 3, 0}}, {{3, 0, 0}}};
  return o;
}

Scene scene3(std::vector<SceneObject> objects) {
  Scene s;
  s.dimension = 3;
  s.objects = std::move(objects);
  return s;
}

const SceneWarning* find_warning(const Scene& s, const std::string& kind) {
  for (const SceneWarning& w : s.warnings) {
    if (warning_kind_name(w.kind) == kind) return &w;
  }
  return nullptr;
}

TEST(SceneValidate, ClosedTetrahedronHasNoWarnings) {
  Scene s = scene3({tetrahedron("a"), tetrahedron("b", {3, 0, 0})});
  validate_scene(s);
  EXPECT_TRUE(s.warnings.empty());
  EXPECT_EQ(s.simplex_count(), 8u);
  EXPECT_EQ(s.vertex_count(), 8u);
  EXPECT_EQ(s.find("b"), ObjectId{1});
  EXPECT_FALSE(s.find("c").has_value());
}

TEST(SceneValidate, RejectsEmptyScene) {
  Scene s;
  expect_error([&] { validate_scene(s); }, ErrorCode::kInvalidScene, "no objects");
}

TEST(SceneValidate, RejectsBadDimension) {
  Scene s = scene3({tetrahedron("a")});
  s.dimension = 4;
  expect_error([&] { validate_scene(s); }, ErrorCode::kInvalidScene, "dimension");
}

TEST(SceneValidate, RejectsDuplicateLabelNamingBothIndices) {
  Scene s = scene3({tetrahedron("a"), tetrahedron("b"), tetrahedron("a")});
  expect_error([&] { validate_scene(s); }, ErrorCode::kInvalidScene, "objects 0 and 2");
}

TEST(SceneValidate, RejectsEmptyLabel) {
  Scene s = scene3({tetrahedron("a"), tetrahedron("")});
  expect_error([&] { validate_scene(s); }, ErrorCode::kInvalidScene, "object 1");
}

TEST(SceneValidate, RejectsIndexOutOfRange) {
  Scene s = scene3({tetrahedron("a"), tetrahedron("b")});
  s.objects[1].simplices[2].v[1] = 4;
  expect_error([&] { validate_scene(s); }, ErrorCode::kInvalidScene, "\"b\"): triangle 2");
}

TEST(SceneValidate, RejectsNonFiniteCoordinate) {
  Scene s = scene3({tetrahedron("a")});
  s.objects[0].vertices[3].y = std::nan("");
  expect_error([&] { validate_scene(s); }, ErrorCode::kInvalidScene, "vertex 3");
}

TEST(SceneValidate, RejectsTooLargeCoordinate) {
  Scene s = scene3({tetrahedron("a")});
  s.objects[0].vertices[2].z = -2e15;
  expect_error([&] { validate_scene(s); }, ErrorCode::kInvalidScene, "\"a\"): vertex 2");
}

TEST(SceneValidate, RejectsObjectWithoutSimplices) {
  Scene s = scene3({tetrahedron("a"), tetrahedron("hollow")});
  s.objects[1].simplices.clear();
  expect_error([&] { validate_scene(s); }, ErrorCode::kInvalidScene, "\"hollow\"");
}

TEST(SceneValidate, RejectsMoreObjectsThanTheLimit) {
  Scene s = scene3({tetrahedron("a"), tetrahedron("b", {2, 0, 0})});
  SceneLimits limits;
  limits.max_objects = 1;
  expect_error([&] { validate_scene(s, limits); }, ErrorCode::kLimitExceeded, "2 objects");
}

TEST(SceneValidate, RejectsMoreSimplicesThanTheLimit) {
  Scene s = scene3({tetrahedron("a")});
  SceneLimits limits;
  limits.max_simplices = 3;
  expect_error([&] { validate_scene(s, limits); }, ErrorCode::kLimitExceeded, "4 simplices");
}

TEST(SceneValidate, RemovesAndCountsDegenerateTriangles) {
  Scene s = scene3({tetrahedron("a")});
  SceneObject& o = s.objects[0];
  o.vertices.push_back({0.5, 0, 0});      // on the edge 0-1
  o.vertices.push_back({0.5, 1e-17, 0});  // 1e-17 off it: zero area
  o.simplices.push_back({{0, 0, 1}});     // repeated index
  o.simplices.push_back({{0, 1, 4}});     // collinear
  o.simplices.push_back({{0, 1, 5}});     // needle below tolerance
  validate_scene(s);
  ASSERT_EQ(o.simplices.size(), 4u);
  const SceneWarning* w = find_warning(s, "degenerate_simplices");
  ASSERT_NE(w, nullptr);
  EXPECT_EQ(w->count, 3u);
  EXPECT_EQ(w->object, "a");
  EXPECT_EQ(find_warning(s, "open_mesh"), nullptr);
}

TEST(SceneValidate, KeepsThinButValidTriangle) {
  Scene s = scene3({tetrahedron("a")});
  s.objects[0].vertices.push_back({0.5, 1e-9, 0});
  s.objects[0].simplices.push_back({{0, 1, 4}});
  validate_scene(s);
  EXPECT_EQ(s.objects[0].simplices.size(), 5u);
  EXPECT_EQ(find_warning(s, "degenerate_simplices"), nullptr);
}

TEST(SceneValidate, AllDegenerateIsAnError) {
  Scene s = scene3({tetrahedron("a"), tetrahedron("flat")});
  s.objects[1].simplices = {{{0, 1, 1}}, {{2, 2, 2}}};
  expect_error([&] { validate_scene(s); }, ErrorCode::kInvalidScene, "\"flat\"");
}

TEST(SceneValidate, WarnsAboutOpenMesh) {
  Scene s = scene3({tetrahedron("a")});
  s.objects[0].simplices.pop_back();  // three open edges
  validate_scene(s);
  const SceneWarning* w = find_warning(s, "open_mesh");
  ASSERT_NE(w, nullptr);
  EXPECT_EQ(w->count, 3u);
  EXPECT_EQ(w->object, "a");
}

TEST(SceneValidate, WarnsAboutNonManifoldEdge) {
  Scene s = scene3({tetrahedron("a")});
  s.objects[0].vertices.push_back({0.3, 0.3, -1});
  s.objects[0].simplices.push_back({{0, 1, 4}});  // a fin on edge 0-1
  validate_scene(s);
  const SceneWarning* w = find_warning(s, "non_manifold");
  ASSERT_NE(w, nullptr);
  EXPECT_EQ(w->count, 1u);
  const SceneWarning* open = find_warning(s, "open_mesh");
  ASSERT_NE(open, nullptr);
  EXPECT_EQ(open->count, 2u);  // the fin's two free edges
}

TEST(SceneValidate, WarnsAboutMultipleComponents) {
  SceneObject two = tetrahedron("pair");
  const SceneObject other = tetrahedron("x", {5, 0, 0});
  for (const Vec3& p : other.vertices) two.vertices.push_back(p);
  for (Simplex t : other.simplices) {
    for (uint32_t& v : t.v) v += 4;
    two.simplices.push_back(t);
  }
  Scene s = scene3({two});
  validate_scene(s);
  const SceneWarning* w = find_warning(s, "multiple_components");
  ASSERT_NE(w, nullptr);
  EXPECT_EQ(w->count, 2u);
  EXPECT_EQ(w->object, "pair");
}

TEST(SceneValidate, IsIdempotent) {
  Scene s = scene3({tetrahedron("a")});
  s.objects[0].simplices.pop_back();
  s.objects[0].simplices.push_back({{1, 1, 2}});
  validate_scene(s);
  const size_t warnings = s.warnings.size();
  validate_scene(s);
  EXPECT_EQ(s.warnings.size(), warnings);
}

// Every edge used by exactly two triangles is run in opposite directions by them (the
// oracle for a consistently oriented mesh).
size_t edges_run_the_same_way(const SceneObject& o) {
  std::map<std::pair<uint32_t, uint32_t>, int> directed;
  for (const Simplex& t : o.simplices)
    for (int e = 0; e < 3; ++e) ++directed[{t.v[e], t.v[(e + 1) % 3]}];
  size_t same = 0;
  for (const auto& [edge, count] : directed) same += count > 1;
  return same;
}

// A box with three of its twelve triangles reversed (CAD exports flip faces) and a separate
// open pair of triangles that disagree: validate_scene reverses the three (the smaller area
// of the box) and one of the pair, says how many, and then every shared edge runs both ways;
// the box's normals point out (positive signed volume), as most of its area had them.
TEST(SceneValidate, ReversesTrianglesThatDisagreeWithTheirNeighbours) {
  SceneObject box = test::make_box("box", {0, 0, 0}, {1, 2, 3});
  ASSERT_EQ(edges_run_the_same_way(box), 0u);
  for (size_t t : {0, 5, 7}) std::swap(box.simplices[t].v[1], box.simplices[t].v[2]);
  ASSERT_GT(edges_run_the_same_way(box), 0u);
  SceneObject pair;
  pair.label = "pair";
  pair.vertices = {{5, 0, 0}, {6, 0, 0}, {5, 1, 0}, {6, 1, 0.5}};
  pair.simplices = {{{0, 1, 2}}, {{1, 2, 3}}};  // both run 1 -> 2
  Scene s = scene3({box, pair});
  validate_scene(s);
  for (const SceneObject& o : s.objects) EXPECT_EQ(edges_run_the_same_way(o), 0u) << o.label;
  double volume = 0;
  for (const Simplex& t : s.objects[0].simplices) {
    const std::vector<Vec3>& v = s.objects[0].vertices;
    volume += dot(v[t.v[0]], cross(v[t.v[1]], v[t.v[2]])) / 6;
  }
  EXPECT_NEAR(volume, 6.0, 1e-12);
  size_t found = 0;
  for (const SceneWarning& w : s.warnings) {
    if (w.kind != WarningKind::kReorientedTriangles) continue;
    ++found;
    EXPECT_EQ(w.count, w.object == "box" ? 3u : 1u) << w.object;
  }
  EXPECT_EQ(found, 2u);
  const size_t warnings = s.warnings.size();
  validate_scene(s);  // nothing left to reverse
  EXPECT_EQ(s.warnings.size(), warnings);
}

TEST(SceneValidate, TwoDimensionalDegreeWarningsAndZ) {
  Scene s;
  s.dimension = 2;
  s.objects = {square_2d("sq")};
  s.objects[0].vertices[1].z = 7;  // 2D: z is forced to 0
  SceneObject path;
  path.label = "path";
  path.vertices = {{0, 3, 0}, {1, 3, 0}, {2, 3, 0}, {1, 4, 0}};
  path.simplices = {{{0, 1, 0}}, {{1, 2, 0}}, {{1, 3, 0}}, {{2, 2, 0}}};
  s.objects.push_back(path);
  validate_scene(s);
  EXPECT_EQ(s.objects[0].vertices[1].z, 0.0);
  EXPECT_EQ(s.objects[1].simplices.size(), 3u);
  const SceneWarning* open = find_warning(s, "open_mesh");
  ASSERT_NE(open, nullptr);
  EXPECT_EQ(open->object, "path");
  EXPECT_EQ(open->count, 3u);
  const SceneWarning* nm = find_warning(s, "non_manifold");
  ASSERT_NE(nm, nullptr);
  EXPECT_EQ(nm->count, 1u);
  const SceneWarning* deg = find_warning(s, "degenerate_simplices");
  ASSERT_NE(deg, nullptr);
  EXPECT_EQ(deg->count, 1u);
}

// ------------------------------------------------------------------------------- Domain

TEST(Domain, DefaultIsPaddedCubeAroundTheBoundingBox) {
  Scene s = scene3({tetrahedron("a")});
  s.objects[0].vertices = {{-1, 2, 0}, {3, 2, 0}, {-1, 4, 0}, {-1, 2, 1}};  // extents 4, 2, 1
  const Domain d = make_domain(s);
  EXPECT_DOUBLE_EQ(d.side, 4 * 1.1);
  const Vec3 centre = d.origin + Vec3{d.side, d.side, d.side} * 0.5;
  EXPECT_DOUBLE_EQ(centre.x, 1.0);
  EXPECT_DOUBLE_EQ(centre.y, 3.0);
  EXPECT_DOUBLE_EQ(centre.z, 0.5);
  EXPECT_DOUBLE_EQ(d.origin.x, -1 - 0.05 * 4);
  const Box b = d.box();
  EXPECT_DOUBLE_EQ(b.hi.x - b.lo.x, d.side);
  EXPECT_DOUBLE_EQ(b.hi.z - b.lo.z, d.side);
}

TEST(Domain, PaddingOption) {
  Scene s = scene3({tetrahedron("a")});
  DomainOptions options;
  options.padding = 0.0;
  const Domain d = make_domain(s, options);
  EXPECT_DOUBLE_EQ(d.side, 1.0);
  EXPECT_EQ(d.origin, (Vec3{0, 0, 0}));
  options.padding = 0.25;
  EXPECT_DOUBLE_EQ(make_domain(s, options).side, 1.5);
}

TEST(Domain, NegativePaddingIsAnError) {
  Scene s = scene3({tetrahedron("a")});
  DomainOptions options;
  options.padding = -0.1;
  expect_error([&] { make_domain(s, options); }, ErrorCode::kInvalidArgument, "padding");
}

TEST(Domain, CoincidentVerticesGetUnitSide) {
  Scene s = scene3({tetrahedron("a")});
  for (Vec3& p : s.objects[0].vertices) p = {2, 2, 2};
  DomainOptions options;
  options.padding = 0;
  const Domain d = make_domain(s, options);
  EXPECT_DOUBLE_EQ(d.side, 1.0);
  EXPECT_EQ(d.origin, (Vec3{1.5, 1.5, 1.5}));
}

TEST(Domain, TwoDimensionalKeepsZZero) {
  Scene s;
  s.dimension = 2;
  s.objects = {square_2d("sq", {1, 1, 0})};
  const Domain d = make_domain(s);
  EXPECT_EQ(d.origin.z, 0.0);
  EXPECT_EQ(d.box().lo.z, 0.0);
  EXPECT_EQ(d.box().hi.z, 0.0);
  EXPECT_DOUBLE_EQ(d.side, 1.1);
  EXPECT_EQ(d.to_unit({2, 2, 0}).z, 0.0);
}

TEST(Domain, ToUnitAndBackRoundTrip) {
  Scene s = scene3({tetrahedron("a", {-3, 5, 7})});
  const Domain d = make_domain(s);
  const Vec3 p{-2.5, 5.25, 7.75};
  const Vec3 u = d.to_unit(p);
  for (int i = 0; i < 3; ++i) {
    EXPECT_GT(u[i], 0.0);
    EXPECT_LT(u[i], 1.0);
  }
  const Vec3 q = d.from_unit(u);
  EXPECT_NEAR(q.x, p.x, 1e-12);
  EXPECT_NEAR(q.y, p.y, 1e-12);
  EXPECT_NEAR(q.z, p.z, 1e-12);
}

TEST(Domain, UserBoxIsMadeACubeWithoutPadding) {
  Scene s = scene3({tetrahedron("a")});
  DomainOptions options;
  options.box = Box{{-1, -1, -1}, {3, 2, 1}};  // extents 4, 3, 2, centre (1, 0.5, 0)
  const Domain d = make_domain(s, options);
  EXPECT_DOUBLE_EQ(d.side, 4.0);
  EXPECT_EQ(d.origin, (Vec3{-1, -1.5, -2}));
}

TEST(Domain, UserBoxMustContainAllVertices) {
  Scene s = scene3({tetrahedron("a"), tetrahedron("far", {5, 0, 0})});
  DomainOptions options;
  options.box = Box{{-1, -1, -1}, {5.5, 2, 2}};
  expect_error([&] { make_domain(s, options); }, ErrorCode::kInvalidArgument,
               "object 1 (\"far\") vertex 1");
}

TEST(Domain, EmptyUserBoxIsAnError) {
  Scene s = scene3({tetrahedron("a")});
  DomainOptions options;
  options.box = Box{};
  expect_error([&] { make_domain(s, options); }, ErrorCode::kInvalidArgument, "box");
}

// A box tilted about a skew axis: the octree's frame is the box's own (each axis parallel to
// one of the rotated x, y, z), right-handed and orthonormal; every face of the box lies on a
// plane of constant unit coordinate, the cube is the box's largest extent padded, and
// to_unit / from_unit / contains work in it.
TEST(Domain, TiltedBoxGetsItsOwnFrame) {
  const Vec3 axis = Vec3{2, -1, 3} / std::sqrt(14.0);
  const double angle = 0.7;
  Scene s = scene3({test::make_box("box", {-1, 0, 0}, {3, 2, 1})});  // extents 4, 2, 1
  for (Vec3& v : s.objects[0].vertices) v = test::rotate(v, axis, angle);
  const Domain d = make_domain(s);
  ASSERT_FALSE(d.aligned());
  for (int i = 0; i < 3; ++i) {
    const Vec3 want =
        test::rotate(Vec3{i == 0 ? 1.0 : 0, i == 1 ? 1.0 : 0, i == 2 ? 1.0 : 0}, axis, angle);
    int parallel = 0;
    for (int j = 0; j < 3; ++j) parallel += norm(cross(d.axis[j], want)) < 1e-12;
    EXPECT_EQ(parallel, 1) << "rotated axis " << i;
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(dot(d.axis[i], d.axis[j]), i == j ? 1 : 0, 1e-15);
  }
  EXPECT_GT(dot(cross(d.axis[0], d.axis[1]), d.axis[2]), 0.999);
  EXPECT_NEAR(d.side, 4 * 1.1, 1e-12);
  const UnitGeometry g = make_unit_geometry(s, d);
  for (const Simplex& t : g.simplices) {
    const Vec3 a = g.points[t.v[0]], b = g.points[t.v[1]], c = g.points[t.v[2]];
    int flat = 0;
    for (int i = 0; i < 3; ++i) flat += a[i] == b[i] && b[i] == c[i];
    EXPECT_EQ(flat, 1) << "a face of the box is not on a plane of the octree";
  }
  for (const Vec3& v : s.objects[0].vertices) {
    EXPECT_TRUE(d.contains(v, 1e-12));
    const Vec3 back = d.from_unit(d.to_unit(v));
    EXPECT_NEAR(dist(back, v), 0, 1e-14);
  }
  // Inside the cube's bounding box but outside the (tilted) cube: near a corner of the box.
  const Box bounds = d.box();
  EXPECT_TRUE(d.contains(bounds.center()));
  EXPECT_FALSE(d.contains(bounds.lo * 0.999 + bounds.center() * 0.001));
}

// Sign changes of d_shaft - d_housing (brute force over the triangles given) at n + 1
// evenly spaced points of the segment [a, b] (scene units).
int bisector_crossings(const Scene& scene, const std::vector<uint32_t> near[2], Vec3 a, Vec3 b,
                       int n, size_t first = 0) {
  int changes = 0, last = 0;
  for (int i = 0; i <= n; ++i) {
    const Vec3 x = a + (b - a) * (static_cast<double>(i) / n);
    double d[2];
    for (int k = 0; k < 2; ++k) {
      const SceneObject& o = scene.objects[first + k];
      d[k] = 1e300;
      for (uint32_t t : near[k])
        d[k] = std::min(d[k], dist(x, closest_point_on_simplex(3, o.vertices, o.simplices[t], x)));
    }
    const int sign = d[1] < d[0] ? -1 : d[1] > d[0] ? 1 : 0;
    if (sign != 0 && last != 0 && sign != last) ++changes;
    if (sign != 0) last = sign;
  }
  return changes;
}

// Brute force beside a shaft's corner (objects first, first + 1: shaft, housing): the most
// crossings of the bisector by a line along x within 6 g on either side of the plane x = plane,
// over lines at corner.y + h g / 100 (|h| <= 150), on the plane and 0.1 g off it.
std::pair<int, int> crossings_beside_plane(const Scene& scene, Vec3 corner, double plane, double g,
                                           size_t first, int step) {
  std::vector<uint32_t> near[2];
  for (int k = 0; k < 2; ++k) {
    const SceneObject& o = scene.objects[first + k];
    for (uint32_t t = 0; t < o.simplices.size(); ++t)
      if (dist(corner, closest_point_on_simplex(3, o.vertices, o.simplices[t], corner)) < 0.1)
        near[k].push_back(t);
  }
  int worst = 0, worst_off = 0;
  for (int h = -150; h <= 150; h += step) {
    const Vec3 at{plane, corner.y + h * 0.01 * g, corner.z};
    const Vec3 reach{6 * g, 0, 0};
    worst = std::max({worst, bisector_crossings(scene, near, at - reach, at, 600, first),
                      bisector_crossings(scene, near, at, at + reach, 600, first)});
    const Vec3 off = at + Vec3{0.1 * g, 0, 0};
    worst_off = std::max({worst_off, bisector_crossings(scene, near, off - reach, off, 600, first),
                          bisector_crossings(scene, near, off, off + reach, 600, first)});
  }
  return {worst, worst_off};
}

// A pentagonal shaft in its bore (a vertex on +x; a far block makes the domain lopsided): at
// the corners at 72 and 288 degrees the faces' normals lie on both sides of the y axis, so
// the bisector there is a roof that a line along x meets twice. make_domain shifts the cube
// so that the roof's apex lies on a lattice plane x = k / 32: then, brute force, every line
// along x near the corner meets the bisector at most once on each side of that plane (the
// octree's cells lie on one side or the other). The apex is not at a vertex's coordinate
// (the corner's bisecting ray is not along an axis): a plane 0.1 g off fails, as does one
// through the shaft's or the bore's corner.
// A shaft of `sides` in its bore at a gap of 1e-3 of the plain domain's side (g, scene
// units), with a far block that makes the domain lopsided.
struct LopsidedShaft {
  test::ShaftInBoreOptions so;
  Scene scene;
  double g = 0;
};
LopsidedShaft lopsided_shaft(int sides) {
  LopsidedShaft out;
  out.so.sides = sides;
  out.so.gap = 1e-3;
  out.so.cell = 0.1;
  out.scene = test::make_shaft_in_bore(out.so);
  out.g = out.so.gap * make_domain(out.scene, DomainOptions{{}, 0.05, DomainFrame::kWorld}).side;
  out.scene.objects.push_back(test::make_box("far", {0.3, 0.55, 0.3}, {0.35, 0.6291, 0.35}));
  return out;
}

// The corners of shaft `s` at `angles` (radians; z = 0.3) in domain d: the plane x = k / 32
// nearest each (the shift put one within a few gaps of it) has at most one crossing on each
// side (crossings_beside_plane), and a plane 0.1 g off, beyond it or (`either_side`) before it
// too, has two.
void expect_corners_beside_a_plane(const LopsidedShaft& s, const Domain& d,
                                   std::initializer_list<double> angles, bool either_side) {
  for (const double angle : angles) {
    const Vec3 corner{s.so.radius * std::cos(angle), s.so.radius * std::sin(angle), 0.3};
    const double unit = d.to_unit(corner).x;
    const double plane = d.origin.x + std::round(unit * 32) / 32 * d.side;
    ASSERT_LT(std::abs(plane - corner.x), 3 * s.g) << "no lattice plane near the corner";
    auto [worst, worst_off] = crossings_beside_plane(s.scene, corner, plane, s.g, 0, 1);
    if (either_side) {
      worst_off = std::max(
          worst_off, crossings_beside_plane(s.scene, corner, plane - 0.1 * s.g, s.g, 0, 1).first);
    }
    EXPECT_LE(worst, 1) << "corner at " << angle;
    EXPECT_EQ(worst_off, 2) << "corner at " << angle;
  }
}

TEST(Domain, StraddledRimsPutTheRoofsApexOnALatticePlane) {
  const double pi = std::acos(-1.0);
  const LopsidedShaft s = lopsided_shaft(5);
  const Domain d = make_domain(s.scene);
  ASSERT_TRUE(d.aligned());
  expect_corners_beside_a_plane(s, d, {0.4 * pi, 1.6 * pi}, false);
}

// A triangular shaft in its bore (a vertex on +x): at its corners at 120 and 240 degrees the
// faces' normals (180 and +-60 degrees) lie on both sides of the y axis and span 120 degrees.
// The roof's apex lies a third of the gap beside the shaft's corner, between it and the
// bore's, and the lines along y through the bore's corner run along the bore's face and meet
// no bisector: both the shaft's rims and the bore's find the same apex, and make_domain puts it
// on a lattice plane x = k / 32. Brute force as above: at most one crossing on each side of
// the plane, two for a plane 0.1 g off (to one side or the other: the roof is lopsided).
TEST(Domain, TheRoofsApexBesideATriangularShaftsCornerIsOnALatticePlane) {
  const double pi = std::acos(-1.0);
  const LopsidedShaft s = lopsided_shaft(3);
  SceneFrame frame;
  const Domain d = make_domain(s.scene, {}, &frame);
  ASSERT_TRUE(d.aligned());
  // The shaft's and the bore's rims at the corners: two groups on x, one apex.
  std::vector<double> apexes;
  for (const StraddledRims& r : frame.straddled[0])
    if (std::abs(r.apex - s.so.radius * std::cos(2 * pi / 3)) < 2 * s.g) apexes.push_back(r.apex);
  ASSERT_EQ(apexes.size(), 2u);
  EXPECT_NEAR(apexes[0], apexes[1], 1e-6 * s.g);
  expect_corners_beside_a_plane(s, d, {2 * pi / 3, 4 * pi / 3}, true);
}

// Two pentagonal shafts side by side, the second 1.3 along x and 0.1234 along y: the roofs'
// apexes over their corners at 72 and 288 degrees lie at two x coordinates (and the ones at 0
// degrees at two y coordinates). make_domain puts the first apex on x on a plane of level 5
// and makes the cube's side (at most 10 % larger) a multiple of their distance over a power of
// two, so that the second lies on a plane of level 12 or coarser too. Brute force: on that
// plane, every line along x near the second shaft's corners meets the bisector at most once
// on each side of it, and 0.1 g off it twice on one side.
TEST(Domain, TheCubesSidePutsASecondApexOnALatticePlane) {
  const double pi = std::acos(-1.0);
  test::ShaftInBoreOptions so;
  so.sides = 5;
  so.gap = 1e-3;
  so.cell = 0.1;
  const Scene one = test::make_shaft_in_bore(so);
  const double g = so.gap * make_domain(one, DomainOptions{{}, 0.05, DomainFrame::kWorld}).side;
  const Vec3 shift{1.3, 0.1234, 0};
  Scene scene = one;
  for (SceneObject o : one.objects) {
    for (Vec3& v : o.vertices) v = v + shift;
    o.label += "_2";
    scene.objects.push_back(std::move(o));
  }
  SceneFrame frame;
  const Domain d = make_domain(scene, {}, &frame);
  ASSERT_TRUE(d.aligned());
  const Domain plain = make_domain(scene, DomainOptions{{}, 0.05, DomainFrame::kWorld});
  EXPECT_GE(d.side, plain.side);
  EXPECT_LE(d.side, 1.1 * plain.side);
  for (const double angle : {0.4 * pi, 1.6 * pi}) {
    const Vec3 corner = shift + Vec3{so.radius * std::cos(angle), so.radius * std::sin(angle), 0.3};
    // The second shaft's apex on x (within a gap of its corner), on a plane of level <= 12.
    const StraddledRims* rims = nullptr;
    for (const StraddledRims& r : frame.straddled[0])
      if (std::abs(r.apex - corner.x) < g) rims = &r;
    ASSERT_NE(rims, nullptr) << "no straddled rims found at the second shaft's corner";
    const double unit = d.to_unit(Vec3{rims->apex, corner.y, corner.z}).x * 4096;
    EXPECT_NEAR(unit, std::round(unit), 1e-6);
    const double plane = d.origin.x + std::round(unit) / 4096 * d.side;
    const auto [worst, worst_off] = crossings_beside_plane(scene, corner, plane, g, 2, 2);
    EXPECT_LE(worst, 1) << "corner at " << angle;
    EXPECT_EQ(worst_off, 2) << "corner at " << angle;
  }
}

// A round shaft in its bore at a thin gap: the housing's outside is drawn along x, y, z and
// holds most of the area, but only the faces across the gap cost cells, so they decide. The
// octree turns about z by half a side (pi / sides, the shaft has a vertex on +x), which puts
// four of the shaft's faces on octree planes; at a wide gap (0.05 of the side, beyond the
// facing reach) the user's axes stay.
TEST(Domain, FacesAcrossAThinGapDecideTheFrame) {
  const double pi = std::acos(-1.0);
  for (int sides : {8, 16}) {
    test::ShaftInBoreOptions so;
    so.sides = sides;
    so.gap = 1e-4;
    so.cell = 0.1;
    const Scene scene = test::make_shaft_in_bore(so);
    const Domain d = make_domain(scene);
    ASSERT_FALSE(d.aligned()) << sides << " sides";
    EXPECT_NEAR(std::abs(d.axis[2].z), 1, 1e-12);
    EXPECT_NEAR(std::abs(std::atan2(d.axis[0].y, d.axis[0].x)), pi / sides, 1e-9);
    // The shaft's faces whose normal is along a frame axis are flat in unit coordinates.
    const UnitGeometry g = make_unit_geometry(scene, d);
    const auto shaft = scene.find("shaft");
    ASSERT_TRUE(shaft.has_value());
    size_t flat = 0;
    for (uint32_t t = 0; t < g.simplices.size(); ++t) {
      if (g.object_of[t] != *shaft) continue;
      const Vec3 a = g.points[g.simplices[t].v[0]], b = g.points[g.simplices[t].v[1]],
                 c = g.points[g.simplices[t].v[2]];
      for (int i = 0; i < 2; ++i) flat += a[i] == b[i] && b[i] == c[i];
    }
    EXPECT_GT(flat, 0u) << sides << " sides";
    so.gap = 0.05;
    EXPECT_TRUE(make_domain(test::make_shaft_in_bore(so)).aligned()) << sides << " sides";
  }
}

// The user's axes stay where no other frame holds more of the faces' area (a tetrahedron's
// three square faces against its one slanted face), where nothing is flat (a tilted sphere),
// in 2D, with a user box and with frame = world.
TEST(Domain, OtherScenesKeepTheUsersAxes) {
  EXPECT_TRUE(make_domain(scene3({tetrahedron("t")})).aligned());
  Scene sphere = scene3({test::make_sphere("ball", {0.3, 0.1, 0.2}, 1.0, 12, 24)});
  for (Vec3& v : sphere.objects[0].vertices)
    v = test::rotate(v, Vec3{1, 1, 0} / std::sqrt(2.0), 0.3);
  EXPECT_TRUE(make_domain(sphere).aligned());
  Scene flat;
  flat.dimension = 2;
  flat.objects = {square_2d("sq")};
  for (Vec3& v : flat.objects[0].vertices) v = test::rotate(v, Vec3{0, 0, 1}, 0.4);
  EXPECT_TRUE(make_domain(flat).aligned());
  Scene box = scene3({test::make_box("box", {0, 0, 0}, {1, 2, 3})});
  for (Vec3& v : box.objects[0].vertices) v = test::rotate(v, Vec3{0, 0.6, 0.8}, 0.9);
  ASSERT_FALSE(make_domain(box).aligned());
  DomainOptions world;
  world.frame = DomainFrame::kWorld;
  EXPECT_TRUE(make_domain(box, world).aligned());
  DomainOptions user;
  user.box = Box{{-5, -5, -5}, {5, 5, 5}};
  EXPECT_TRUE(make_domain(box, user).aligned());
  EXPECT_EQ(parse_domain_frame("world"), DomainFrame::kWorld);
  EXPECT_EQ(std::string(domain_frame_name(DomainFrame::kAuto)), "auto");
  expect_error([] { parse_domain_frame("tilted"); }, ErrorCode::kInvalidArgument, "auto or world");
}

// ------------------------------------------------------------------------- UnitGeometry

TEST(SceneUnitGeometry, FlattensObjectsAndSnapsToTheLattice) {
  Scene s = scene3({tetrahedron("a", {0.1, 0.2, 0.3}), tetrahedron("b", {1.7, -0.3, 0.9})});
  validate_scene(s);
  const Domain d = make_domain(s);
  const UnitGeometry g = make_unit_geometry(s, d);
  EXPECT_EQ(g.dimension, 3);
  EXPECT_EQ(g.object_count, 2u);
  ASSERT_EQ(g.points.size(), 8u);
  ASSERT_EQ(g.simplices.size(), 8u);
  ASSERT_EQ(g.object_of.size(), 8u);
  EXPECT_EQ(g.object_of[3], 0u);
  EXPECT_EQ(g.object_of[4], 1u);
  EXPECT_EQ(g.simplices[4].v[0], 4u);  // offset by the first object's 4 vertices
  EXPECT_EQ(g.simplices[4].v[1], 6u);
  for (const Vec3& p : g.points) {
    for (int i = 0; i < 3; ++i) {
      EXPECT_GE(p[i], 0.0);
      EXPECT_LE(p[i], 1.0);
      const double scaled = std::ldexp(p[i], 48);
      EXPECT_EQ(scaled, std::floor(scaled)) << p[i];
    }
  }
  const Vec3 back = d.from_unit(g.points[5]);
  EXPECT_NEAR(back.x, 2.7, 1e-12);
}

TEST(SceneUnitGeometry, BoundaryVerticesAreClampedIntoTheUnitCube) {
  Scene s = scene3({tetrahedron("a", {0.1, 0.2, 0.3})});
  DomainOptions options;
  options.padding = 0;
  const UnitGeometry g = make_unit_geometry(s, make_domain(s, options));
  double lo = 1, hi = 0;
  for (const Vec3& p : g.points) {
    for (int i = 0; i < 3; ++i) {
      lo = std::min(lo, p[i]);
      hi = std::max(hi, p[i]);
    }
  }
  EXPECT_EQ(lo, 0.0);
  EXPECT_EQ(hi, 1.0);
}

TEST(SceneUnitGeometry, TwoDimensionalKeepsZZero) {
  Scene s;
  s.dimension = 2;
  s.objects = {square_2d("sq"), square_2d("sq2", {3, 0.5, 0})};
  validate_scene(s);
  const UnitGeometry g = make_unit_geometry(s, make_domain(s));
  for (const Vec3& p : g.points) EXPECT_EQ(p.z, 0.0);
  EXPECT_EQ(g.simplices[4].v[0], 4u);
  EXPECT_EQ(g.simplices[4].v[2], 0u);
}

TEST(SceneUnitGeometry, VertexOutsideTheDomainIsAnError) {
  Scene s = scene3({tetrahedron("a"), tetrahedron("b", {4, 0, 0})});
  Domain d;
  d.dimension = 3;
  d.origin = {0, 0, 0};
  d.side = 2;
  expect_error([&] { make_unit_geometry(s, d); }, ErrorCode::kInvalidArgument,
               "object 1 (\"b\") vertex 0");
}

}  // namespace
}  // namespace gvd
