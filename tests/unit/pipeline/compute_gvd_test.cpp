#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <set>
#include <tuple>

#include "bench/boost_voronoi.h"
#include "gvd/distance/compute_distances.h"
#include "gvd/pipeline/pipeline.h"
#include "gvd/scene/load_scene.h"
#include "support/expect_valid.h"
#include "support/oracles.h"
#include "support/scenes.h"
#include "support/thin_gap_scenes.h"

namespace gvd {

using namespace gvd::scene;
using namespace gvd::distance;
using namespace gvd::surface;
using namespace gvd::graph;
using namespace gvd::result;
using namespace gvd::pipeline;

namespace {

using test::brute_nearest;
using test::expect_valid;
using test::local_cell;
using test::stride_for;

GvdResult run(Scene scene, int max_depth = 0, const std::string& distance = "exact",
              const std::string& refine = "certified", const std::string& resolution = "compact") {
  PipelineOptions o;
  o.max_depth = max_depth;
  o.distance = parse_choice<DistanceMethod>(distance);
  o.refine = parse_choice<RefineRule>(refine);
  o.resolution = parse_choice<GvdResolution>(resolution);
  o.threads = 2;
  return compute_gvd(std::move(scene), o);
}

// Leaves above the depth limit that hold two or more objects without a certificate (the
// certified refinement leaves none: such a leaf is split or certified).
size_t uncertified_leaves_holding_two(const GvdResult& r) {
  size_t bad = 0;
  for (uint32_t i = 0; i < r.octree.leaf_count(); ++i)
    bad += r.octree.object[i] == kManyObjects && !r.octree.is_certified(i) &&
           r.octree.level[i] < r.octree.max_depth;
  return bad;
}

std::set<std::pair<ObjectId, ObjectId>> graph_pairs(const DualGraph& g) {
  std::set<std::pair<ObjectId, ObjectId>> s;
  for (const DualEdge& e : g.edges) s.insert({e.a, e.b});
  return s;
}

TEST(ComputeGvd, TwoSegmentsGiveTheirBisector2D) {
  // Full resolution: the surfaced vertices themselves (the compact output keeps a subset).
  auto r = run(test::make_scene(2, {test::make_segment("a", {0, 0, 0}, {0, 1, 0}),
                                    test::make_segment("b", {1, 0, 0}, {1, 1, 0})}),
               0, "exact", "certified", "full");
  expect_valid(r);
  // Between the segments the interface is the line x = 0.5.
  const GvdCell& a = r.gvd.cells[0];
  size_t on_mid = 0;
  for (size_t v = 0; v < a.positions.size(); ++v) {
    const Vec3 p = a.positions[v];
    if (a.other[v] != 1 || p.y < 0.05 || p.y > 0.95) continue;
    // Exact up to the hair the bisector keeps inside its octree edge (1e-6 of the edge).
    EXPECT_NEAR(p.x, 0.5, 1e-6 * local_cell(r, p) + 1e-12);
    ++on_mid;
  }
  EXPECT_GT(on_mid, 0u);
  EXPECT_EQ(graph_pairs(r.graph), (std::set<std::pair<ObjectId, ObjectId>>{{0, 1}}));
}

TEST(ComputeGvd, TwoPointsGiveTheBisectorPlane3D) {
  // Two mirror-image point-like triangles: their bisector is exactly the plane x = 0.5. The
  // domain is chosen so that the plane does not fall on octree vertices.
  SceneObject a = test::make_point3("a", {0.2, 0.65, 0.65}, 1e-3);
  SceneObject b = a;
  b.label = "b";
  for (Vec3& v : b.vertices) v.x = 1.0 - v.x;
  PipelineOptions o;
  o.threads = 2;
  Box box;
  box.extend(Vec3{0, 0, 0});
  box.extend(Vec3{1.3, 1.3, 1.3});
  o.domain.box = box;
  auto r = compute_gvd(test::make_scene(3, {a, b}), o);
  expect_valid(r);
  size_t n = 0;
  for (const GvdCell& cell : r.gvd.cells) {
    for (size_t v = 0; v < cell.positions.size(); ++v) {
      if (cell.other[v] == kNoObject) continue;
      EXPECT_NEAR(cell.positions[v].x, 0.5, 1e-3);
      ++n;
    }
  }
  EXPECT_GT(n, 0u);
  ASSERT_EQ(r.graph.edges.size(), 1u);
  // The bisector plane clipped to the domain: a 1.3 x 1.3 square.
  EXPECT_NEAR(r.graph.edges[0].area, 1.3 * 1.3, 1e-3);
}

TEST(ComputeGvd, ParallelPlatesGiveTheMidPlane) {
  auto r = run(test::make_scene(3, {test::make_box("low", {0, 0, 0}, {1, 1, 0.1}),
                                    test::make_box("high", {0, 0, 0.12}, {1, 1, 0.2})}));
  expect_valid(r);
  const double mid = 0.11;
  size_t n = 0;
  for (size_t v = 0; v < r.gvd.cells[0].positions.size(); ++v) {
    const Vec3 p = r.gvd.cells[0].positions[v];
    if (r.gvd.cells[0].other[v] != 1) continue;
    if (p.x < 0.05 || p.x > 0.95 || p.y < 0.05 || p.y > 0.95) continue;
    EXPECT_NEAR(p.z, mid, 1e-9);
    ++n;
  }
  EXPECT_GT(n, 0u);
  EXPECT_NEAR(r.graph.edges.at(0).min_clearance, 0.01, 1e-9);
}

// Two bars (82 segments each, long edges split in 40) with parallel long edges `gap` apart,
// turned by `angle` about the origin.
Scene parallel_bars(double gap, double angle = 0, bool swap = false) {
  const double c = std::cos(angle), s = std::sin(angle);
  std::vector<SceneObject> objects;
  for (const auto& [label, y0, y1] : {std::tuple{"bar_a", -0.1, 0.0}, {"bar_b", gap, gap + 0.1}}) {
    SceneObject o;
    o.label = label;
    std::vector<Vec3> ring;
    for (int i = 0; i <= 40; ++i) ring.push_back({i / 40.0, y0, 0});
    for (int i = 40; i >= 0; --i) ring.push_back({i / 40.0, y1, 0});
    for (const Vec3& p : ring) o.vertices.push_back({c * p.x - s * p.y, s * p.x + c * p.y, 0});
    for (uint32_t i = 0; i < ring.size(); ++i)
      o.simplices.push_back({{i, static_cast<uint32_t>((i + 1) % ring.size()), 0}});
    objects.push_back(std::move(o));
  }
  if (swap) std::swap(objects[0], objects[1]);
  return test::make_scene(2, std::move(objects));
}

// The GVD between the bars' long edges is their mid-line, exactly, and it costs cells like
// log(1/gap) (the paper's rule: 1/gap), down to a gap of 1e-7 of the domain; the answer
// does not depend on the scene's orientation or the order of its objects.
TEST(ComputeGvd, ThinGapBetweenBarsIsTheirExactMidLine2D) {
  std::vector<uint64_t> leaves;
  for (const double gap : {1e-3, 1e-5, 1e-7}) {
    for (const double angle : {0.0, 0.3}) {
      for (const bool swap : {false, true}) {
        SCOPED_TRACE("gap " + std::to_string(gap) + " angle " + std::to_string(angle) +
                     (swap ? " swapped" : ""));
        // Full resolution: the surfaced vertices (the compact output keeps a subset).
        const GvdResult r = run(parallel_bars(gap, angle, swap), 0, "exact", "certified", "full");
        expect_valid(r);
        ASSERT_EQ(graph_pairs(r.graph), (std::set<std::pair<ObjectId, ObjectId>>{{0, 1}}));
        EXPECT_NEAR(r.graph.edges[0].min_clearance, gap / 2, 1e-6 * gap);
        // Every vertex between the long edges (away from the bars' ends) is on the mid-line,
        // to a millionth of the clearance (the hair that keeps edge points inside their edge).
        const Vec3 along{std::cos(angle), std::sin(angle), 0}, across{-along.y, along.x, 0};
        size_t on_line = 0;
        for (const GvdCell& cell : r.gvd.cells) {
          for (size_t v = 0; v < cell.positions.size(); ++v) {
            const Vec3 p = cell.positions[v];
            const double t = dot(p, along);
            if (cell.other[v] == kNoObject || t < 0.01 || t > 0.99) continue;
            EXPECT_NEAR(dot(p, across), gap / 2, 1e-6 * gap + 1e-14)
                << "vertex " << v << " at t " << t;
            ++on_line;
          }
        }
        EXPECT_GT(on_line, 0u);
        if (angle == 0 && !swap) leaves.push_back(r.stats.leaves);
      }
    }
  }
  // 1e4 times thinner: the paper's rule needs ~1e4 times the leaves (and fails at 1e-7).
  EXPECT_LE(leaves[2], 4 * leaves[0])
      << leaves[0] << " leaves at 1e-3, " << leaves[2] << " at 1e-7";
}

// A grid of 4 x 4 squares 1e-7 apart (packed parts): where four meet, the GVD's junction is
// equidistant from all four. The Newton step toward it formed |p_k|^2 - |p_0|^2 (~1 each)
// for a difference ~1e-7: its rounding moved the junction by 3e-10, 0.5 % of its distance to
// the squares, and a third square was nearer than the claimed pair at 92 of 1200 vertices.
// Now every vertex (full resolution) claims a pair no third object beats by more than 1e-6 of
// the distance, and is equidistant from that pair. The same where three meet (bricks).
TEST(ComputeGvd, JunctionsOfPackedSquaresAreEquidistant2D) {
  const double gap = 1e-7;
  // Every vertex (full resolution) claims a pair that no third object beats by more than
  // `tie` of the distance, and is equidistant from it.
  auto expect_equidistant = [](const Scene& scene, double tie) {
    const GvdResult r = run(scene, 0, "exact", "certified", "full");
    expect_valid(r);
    size_t checked = 0;
    for (const GvdCell& cell : r.gvd.cells) {
      for (size_t v = 0; v < cell.positions.size(); ++v) {
        if (cell.other[v] == kNoObject) continue;
        const Vec3 p = cell.positions[v];
        const double da = test::brute_distance(scene, cell.object, p);
        const double db = test::brute_distance(scene, cell.other[v], p);
        const test::NearestAnswer nn = test::brute_nearest(scene, p);
        const double third =
            nn.object != cell.object && nn.object != cell.other[v]
                ? nn.distance
                : (nn.second != cell.object && nn.second != cell.other[v] ? nn.second_distance
                                                                          : 1e300);
        const double far = std::max(da, db);
        ASSERT_GE(third, far * (1 - tie)) << "vertex at " << p.x << ", " << p.y;
        // Edge points keep a hair of 1e-6 of their edge (a few gaps long) off its ends.
        ASSERT_NEAR(da, db, 1e-5 * far);
        ++checked;
      }
    }
    EXPECT_GT(checked, 100u);
  };
  const int n = 4;
  std::vector<SceneObject> squares;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double x = double(i) / n, y = double(j) / n;
      squares.push_back(test::make_rect("r" + std::to_string(i) + "_" + std::to_string(j),
                                        {x, y, 0}, {x + 1.0 / n - gap, y + 1.0 / n - gap, 0}));
    }
  expect_equidistant(test::make_scene(2, std::move(squares)), 1e-6);
  // Bricks: rows of four offset by half a brick, so three meet at each T. A junction on the
  // side of the cell that holds its three spokes was held there in one coordinate, where the
  // two conditions left for the other are one too many for an exact solve: the step stopped,
  // 4 % of the gap off (a third brick nearer by 6 % of the distance). Now solved in the least
  // squares sense (within the hair that keeps it off the side).
  std::vector<SceneObject> bricks;
  for (int row = 0; row < 4; ++row) {
    const double shift = row % 2 == 0 ? 0 : 0.125;
    std::vector<double> xs{0};
    for (int k = 0; k <= 4; ++k)
      if (shift + k * 0.25 > 0 && shift + k * 0.25 < 1) xs.push_back(shift + k * 0.25);
    xs.push_back(1);
    for (size_t k = 0; k + 1 < xs.size(); ++k)
      bricks.push_back(test::make_rect("b" + std::to_string(row) + "_" + std::to_string(k),
                                       {xs[k], row * 0.25, 0},
                                       {xs[k + 1] - gap, (row + 1) * 0.25 - gap, 0}));
  }
  expect_equidistant(test::make_scene(2, std::move(bricks)), 1e-5);
}

// Facing plates: the certified refinement gives the exact mid-plane over the whole face with
// a fraction of the paper's leaves (only the rims still refine to the gap).
TEST(ComputeGvd, ThinGapBetweenPlatesIsTheirExactMidPlane3D) {
  const double gap = 1e-2;
  auto scene = [&] {
    return test::make_scene(3, {test::make_box("low", {0, 0, 0}, {1, 1, 0.1}),
                                test::make_box("high", {0.1, 0.1, 0.1 + gap}, {0.9, 0.9, 0.2})});
  };
  const GvdResult paper = run(scene(), 0, "exact", "paper");
  const GvdResult r = run(scene());
  expect_valid(r);
  EXPECT_GT(r.stats.certified_leaves, 0u);
  EXPECT_LT(3 * r.stats.leaves, paper.stats.leaves);
  EXPECT_EQ(graph_pairs(r.graph), graph_pairs(paper.graph));
  size_t on_plane = 0;
  for (size_t v = 0; v < r.gvd.cells[0].positions.size(); ++v) {
    const Vec3 p = r.gvd.cells[0].positions[v];
    if (r.gvd.cells[0].other[v] != 1) continue;
    if (p.x < 0.12 || p.x > 0.88 || p.y < 0.12 || p.y > 0.88) continue;
    EXPECT_NEAR(p.z, 0.1 + gap / 2, 1e-6 * gap);
    ++on_plane;
  }
  EXPECT_GT(on_plane, 0u);
  EXPECT_NEAR(r.graph.edges.at(0).min_clearance, gap / 2, 1e-6 * gap);
}

// Thin-gap answers do not depend on the frame or the order of the objects: two flush plates
// 1e-4 apart, then rotated about a skew axis, translated and listed in the other order, give
// the same pair, the same gap and the mid-plane (to the certificate's tolerance), at a cost
// that does not grow with 1 / g.
TEST(ComputeGvd, ThinGapAnswersAreInvariantUnderRotationTranslationAndRelabelling3D) {
  test::StackedPlatesOptions po;
  po.count = 2;
  po.gap = 1e-4;
  po.cell = 0.25;
  const Scene straight = test::make_stacked_plates(po);
  const double g = po.gap * make_domain(straight).side;
  const Vec3 axis = Vec3{2, -1, 3} / std::sqrt(14.0);
  const Vec3 shift{3.25, -1.5, 0.75};
  auto move = [&](Vec3 p) { return test::rotate(p, axis, 0.7) + shift; };
  Scene moved = straight;
  for (SceneObject& o : moved.objects)
    for (Vec3& v : o.vertices) v = move(v);
  std::swap(moved.objects[0], moved.objects[1]);
  const GvdResult a = run(straight);
  const GvdResult b = run(moved);
  expect_valid(a);
  expect_valid(b);
  ASSERT_EQ(a.graph.edges.size(), 1u);
  ASSERT_EQ(b.graph.edges.size(), 1u);
  EXPECT_NEAR(b.graph.edges[0].gap, a.graph.edges[0].gap, 1e-9 * g);
  EXPECT_NEAR(a.graph.edges[0].min_clearance, g / 2, 1e-6 * g);
  EXPECT_NEAR(b.graph.edges[0].min_clearance, g / 2, 1e-4 * g);
  // The moved mid-plane: through move({0, 0.1 + g / 2, 0}) with normal R e_y.
  const Vec3 normal = move(Vec3{0, 1, 0}) - move(Vec3{0, 0, 0});
  const Vec3 on = move(Vec3{0, 0.1 + g / 2, 0});
  size_t checked = 0;
  for (size_t v = 0; v < b.gvd.cells[0].positions.size(); ++v) {
    if (b.gvd.cells[0].other[v] != 1) continue;
    const Vec3 p = b.gvd.cells[0].positions[v];
    EXPECT_NEAR(dot(p - on, normal), 0,
                1e-4 * g + 1e-6 * (b.gvd.cells[0].clearance[v] + 2 * local_cell(b, p)))
        << "vertex " << v;
    ++checked;
  }
  EXPECT_GT(checked, 0u);
  // In the moved frame too the cost does not grow with 1 / g: 100 times thinner than the
  // same plates at 1e-2, at most twice the leaves.
  po.gap = 1e-2;
  Scene wide = test::make_stacked_plates(po);
  for (SceneObject& o : wide.objects)
    for (Vec3& v : o.vertices) v = move(v);
  const GvdResult w = run(wide);
  EXPECT_LE(b.stats.leaves, 2 * w.stats.leaves) << w.stats.leaves << " leaves at 1e-2";
}

// A cube in a cubic cavity of a unit block, 1.1e-4 from it on all six faces: the
// cube's edges face the cavity's across the gap, rims whose certificates need to know which
// side of each face is material. The input's vertex order must not decide that: with the
// cavity's shell drawn inside out (its normals into the block's material, as an exporter that
// ignores nesting writes it), or every third triangle of both objects reversed, the cost and
// the answers are those of the consistently drawn scene. (With the object's vertex order
// trusted, the turned cavity refused every rim: an L-shaped part in an L-shaped groove took
// 9.3M leaves at 1e-4 against 37k, and the leaf limit at 1e-5.) The same for mirror cells
// beside a box written inside out.
// make_blade_in_slot at `gap`, turned 0.7 rad about the skew axis (2, -1, 3).
Scene turned_blade(double gap) {
  test::BladeInSlotOptions bo;
  bo.gap = gap;
  Scene scene = test::make_blade_in_slot(bo);
  const Vec3 axis = Vec3{2, -1, 3} / std::sqrt(14.0);
  for (SceneObject& o : scene.objects)
    for (Vec3& v : o.vertices) v = test::rotate(v, axis, 0.7);
  return scene;
}

// `scene` against `twin`, the result of the same parts drawn the easy way, side by side: with
// the leaf limit at 1M (the paper's cost fails there at once), within 10 % of the twin's
// leaves, valid, no GVD piece crossing the objects of `scene` as given (not as the pipeline
// snapped them), and one neighbour pair whose gap is `gap` within `tolerance`.
GvdResult expect_costs_what_its_twin_costs(const GvdResult& twin, const Scene& scene, double gap,
                                           double tolerance) {
  PipelineOptions o;
  o.threads = 2;
  o.max_leaves = 1'000'000;
  GvdResult r = compute_gvd(scene, o);
  EXPECT_LE(r.stats.leaves, twin.stats.leaves * 11 / 10);
  expect_valid(r);
  EXPECT_EQ(test::count_gvd_object_crossings(scene, r.gvd, 3000), 0u);
  EXPECT_EQ(r.graph.edges.size(), 1u);
  if (!r.graph.edges.empty()) {
    EXPECT_NEAR(r.graph.edges[0].gap, gap, tolerance);
  }
  return r;
}

// `rounded`, a turned scene rounded as a file stores it, against `doubles`, its twin
// (expect_costs_what_its_twin_costs), the twin's gap within `gap_share` of itself (1e-3;
// snapping moves no gap by more than 2 %), and a faces_snapped warning that names the
// rounding (`kind`).
void expect_costs_what_its_double_twin_costs(const Scene& doubles, const Scene& rounded,
                                             const std::string& kind, double gap_share = 1e-3) {
  const GvdResult twin = run(doubles);
  ASSERT_EQ(twin.graph.edges.size(), 1u);
  const double gap = twin.graph.edges[0].gap;
  const GvdResult r = expect_costs_what_its_twin_costs(twin, rounded, gap, gap_share * gap);
  bool said = false;
  for (const SceneWarning& w : r.scene.warnings)
    said = said || (w.kind == WarningKind::kFacesSnapped && w.detail.find(kind) == 0);
  EXPECT_TRUE(said);
}

// A blade in a slot (clearance 1.1e-3 over its faces and floor) drawn at an angle and stored
// as float32 (an STL, a glTF): its faces are flat, parallel and square only to the rounding,
// which every certificate refused, so it cost what the paper's rule costs (3,971,878 leaves
// against 17,340 in doubles). Its flat faces are now put on exact planes first
// (snap_faces.h): the cost of the double twin, measured side by side.
TEST(ComputeGvd, ThinGapCostDoesNotDependOnFloat32Coordinates3D) {
  const Scene doubles = turned_blade(1e-3);
  Scene floats = doubles;
  test::round_to_float32(floats);
  expect_costs_what_its_double_twin_costs(doubles, floats, "float32");
}

// The slot of boxes (walls standing on the floor) turned 0.7 rad and stored as float32 (an
// STL of the assembly): the walls' undersides, glued to the floor's top, are coplanar with it
// only to the rounding, face the other way, and were put on a plane of their own, 1e-8 off
// the floor's: not buried, every floor corner refused (leaf limit). Glued faces of one
// object now share their plane: the cost of the one-mesh slot turned in doubles; valid.
TEST(ComputeGvd, SlotOfBoxesTurnedInFloat32CostsWhatOneMeshDoes3D) {
  const Vec3 axis = Vec3{2, -1, 3} / std::sqrt(14.0);
  auto turned = [&](Scene scene) {
    for (SceneObject& o : scene.objects)
      for (Vec3& v : o.vertices) v = test::rotate(v, axis, 0.7);
    return scene;
  };
  test::SlotOfPartsOptions one;
  one.boxes = false;
  one.gap = 1e-5;
  test::SlotOfPartsOptions parts = one;
  parts.boxes = true;
  Scene floats = turned(test::make_slot_of_parts(parts));
  test::round_to_float32(floats);
  expect_costs_what_its_double_twin_costs(turned(test::make_slot_of_parts(one)), floats, "float32",
                                          0.02);
}

// The turned blade at 1e-5 written with 10 decimals (an OBJ, an ASCII STL, a JSON scene from
// a script that rounds): its faces are flat and parallel only to 5e-11, and every certificate
// refused them (the leaf limit). The rounding is read from the digits and the faces put on
// exact planes as a float32 input's: the cost of the double twin, measured side by side.
TEST(ComputeGvd, ThinGapCostDoesNotDependOnDecimalCoordinates3D) {
  const Scene doubles = turned_blade(1e-5);
  Scene decimals = doubles;
  test::round_to_decimals(decimals, 10);
  expect_costs_what_its_double_twin_costs(doubles, decimals, "decimal");
}

// A blade in a slot at 1e-5 whose slot is three boxes in one object, as a quick script builds
// it: walls standing on the floor (their undersides glued to its top, their edges there used by
// four triangles), the same with the corners welded (as an STL is read), walls pushed into the
// floor. The slot was not closed to the certificates (glued: 7,174,672 leaves at 1e-4, the leaf
// limit at 1e-5; pushed in: one wall taken for a cavity of the floor, 537,216 leaves at 1e-3).
// Now the cost of the same slot as one closed mesh, measured side by side; valid, the gap right.
TEST(ComputeGvd, SlotOfBoxesCostsWhatOneMeshDoes3D) {
  test::SlotOfPartsOptions one;
  one.boxes = false;
  one.gap = 1e-5;
  const GvdResult twin = run(test::make_slot_of_parts(one));
  for (const auto& [walls_from, weld] : {std::pair{0.2, false}, {0.2, true}, {0.1, false}}) {
    SCOPED_TRACE(std::to_string(walls_from) + (weld ? " welded" : ""));
    test::SlotOfPartsOptions parts = one;
    parts.boxes = true;
    parts.walls_from = walls_from;
    parts.weld = weld;
    expect_costs_what_its_twin_costs(twin, test::make_slot_of_parts(parts), 1e-5, 1e-6 * 1e-5);
  }
}

// Lines where three or four objects meet (3 x 3 packed columns, gap g; a blade in a slot of
// three separate parts, all g apart): without junction cells every cell along such a line
// shrinks to the gap (the columns: 1.43M leaves at 1e-3, the leaf limit at 1e-4). With them
// (PipelineOptions::junctions) the GVD there is the plane GVD of the sections swept along the
// line: the cost at 1e-5 stays within twice the cost at 1e-3, the result is valid, no piece
// crosses an object, and every pair of faces across a gap is a neighbour pair with that gap.
TEST(ComputeGvd, JunctionLinesCostWhatTheirSectionsCost3D) {
  auto columns = [](double g) { return test::make_packed_columns(3, 0.3, g); };
  struct Case {
    const char* name;
    std::function<Scene(double)> make;
    std::vector<std::pair<std::string, std::string>> across;  // pairs facing across a gap g
  };
  const std::vector<Case> cases = {
      {"columns", columns, {{"c00", "c01"}, {"c00", "c10"}, {"c11", "c12"}, {"c11", "c21"}}},
      {"slot of parts",
       test::make_slot_of_separate_parts,
       {{"floor", "blade"},
        {"left", "blade"},
        {"right", "blade"},
        {"floor", "left"},
        {"floor", "right"}}}};
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    PipelineOptions o;
    o.threads = 2;
    o.junctions = true;
    o.max_leaves = 1'000'000;
    const GvdResult wide = compute_gvd(c.make(1e-3), o);
    const double g = 1e-5;
    const Scene scene = c.make(g);
    const GvdResult r = compute_gvd(scene, o);
    EXPECT_LE(r.stats.leaves, 2 * wide.stats.leaves);
    expect_valid(r);
    EXPECT_EQ(test::count_gvd_object_crossings(scene, r.gvd, 3000), 0u);
    for (const auto& [a, b] : c.across) {
      const ObjectId ia = *scene.find(a), ib = *scene.find(b);
      bool found = false;
      for (const DualEdge& e : r.graph.edges) {
        if (std::minmax(e.a, e.b) != std::minmax(ia, ib)) continue;
        found = true;
        EXPECT_NEAR(e.gap, g, 1e-6 * g) << a << " " << b;
      }
      EXPECT_TRUE(found) << a << " " << b;
    }
  }
}

// The blade in its slot turned 0.7 rad, then moved 1000 away (coordinates ~1e3 in doubles:
// their rounding, 1.1e-13, tilts a small triangle's normal by up to ~4e-12): the rims' faces
// were taken as square to their axis only within 1e-12, so every rim refined to the gap
// (leaf limit); a tilt of 1e-10 moves the bisector by at most 1e-10 of the cell across it.
// Now the cost of the blade at the origin, measured side by side; valid, the gap right.
TEST(ComputeGvd, ThinGapCostDoesNotDependOnWhereTheSceneIs3D) {
  const Scene here = turned_blade(1e-4);
  const GvdResult twin = run(here);
  // 1e5 away the rounding is 1.5e-11: the perpendicular test grows with it (8.4M leaves at
  // 1e-10 for the blade at 1e-5).
  for (const double t : {1e3, 1e5}) {
    SCOPED_TRACE(t);
    Scene there = here;
    for (SceneObject& o : there.objects)
      for (Vec3& v : o.vertices) v = v + Vec3{1, -0.5, 0.25} * t;
    expect_costs_what_its_twin_costs(twin, there, 1.1e-4, 1e-6 * 1.1e-4);
  }
}

// Six plates, every other one inset by 0.1 (its rims over its neighbours' faces), turned
// 0.7 rad about (2, -1, 3): the middle gap's mid-plane lies on the lattice plane y = 1/2, to
// the lattice's rounding (4.7e-14 off it). On the faces across an inset rim, the curve from
// the rim's parabola to the face's edge found no root where the mid-plane runs along that
// edge, so its chord cut the rim's corner: 5 GVD triangles through a plate (2 at 1e-5).
TEST(ComputeGvd, TurnedInsetPlatesKeepTheGvdOffTheirRims3D) {
  test::StackedPlatesOptions po;
  po.gap = 1e-4;
  po.inset = 0.1;
  Scene scene = test::make_stacked_plates(po);
  const Vec3 axis = Vec3{2, -1, 3} / std::sqrt(14.0);
  for (SceneObject& o : scene.objects)
    for (Vec3& v : o.vertices) v = test::rotate(v, axis, 0.7);
  const GvdResult r = run(scene);
  expect_valid(r);
  EXPECT_EQ(test::count_gvd_object_crossings(r.scene, r.gvd, 3000), 0u);
  const auto pairs = graph_pairs(r.graph);
  for (ObjectId i = 0; i + 1 < 6; ++i) EXPECT_EQ(pairs.count({i, i + 1}), 1u) << i;
}

// Six stacked plates 1e-5 apart, flush on their sides, turned 0.7 rad and moved 1000 away:
// their doubles carry ~1e-13 of rounding there, and the flush sides' mirror images matched
// only to the lattice's 4 * 2^-48, so the mirror cells refined every side to the gap (leaf
// limit). The certificates' flatness and mirror tolerances now grow with the input's own
// rounding (UnitGeometry::rounding): the paper's cost would not fit in 1M leaves.
TEST(ComputeGvd, FlushPlatesFarFromTheOriginStayCheap3D) {
  test::StackedPlatesOptions po;
  po.gap = 1e-5;
  Scene scene = test::make_stacked_plates(po);
  const Vec3 axis = Vec3{2, -1, 3} / std::sqrt(14.0);
  for (SceneObject& o : scene.objects)
    for (Vec3& v : o.vertices) v = test::rotate(v, axis, 0.7) + Vec3{1000, -500, 250};
  PipelineOptions o;
  o.threads = 2;
  o.max_leaves = 1'000'000;
  const GvdResult r = compute_gvd(scene, o);
  expect_valid(r);
  EXPECT_EQ(test::count_gvd_object_crossings(r.scene, r.gvd, 3000), 0u);
  const auto pairs = graph_pairs(r.graph);
  for (ObjectId i = 0; i + 1 < 6; ++i) EXPECT_EQ(pairs.count({i, i + 1}), 1u) << i;
}

// The same blade at 1.1e-4, 100 from the origin in float32: the rounding there (6e-6) is 5 %
// of the gap, so the faces facing it stay where the file has them (moving them would change
// the gap by more than 2 %) and the gap refines to the rounding. The leaf limit's error then
// says why.
TEST(ComputeGvd, LeafLimitSaysWhenFloat32RoundingIsAShareOfTheGap3D) {
  Scene scene = turned_blade(1e-4);
  for (SceneObject& o : scene.objects)
    for (Vec3& v : o.vertices) v = v + Vec3{100, -50, 25};
  test::round_to_float32(scene);
  PipelineOptions o;
  o.threads = 2;
  o.max_leaves = 200'000;
  try {
    compute_gvd(scene, o);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kLimitExceeded);
    EXPECT_NE(e.detail().find("float32 input were not put on exact planes"), std::string::npos)
        << e.detail();
  }
}

TEST(ComputeGvd, ThinGapCostDoesNotDependOnTheInputsVertexOrder3D) {
  test::CubeInCavityOptions co;
  const double g = co.gap * 1.1;  // the block spans 1
  auto scene = [&](bool turn_cavity, int reverse_every) {
    co.cavity_inside_out = turn_cavity;
    Scene s = test::make_cube_in_cavity(co);
    for (SceneObject& o : s.objects)
      for (size_t t = 0; reverse_every > 0 && t < o.simplices.size(); t += reverse_every)
        std::swap(o.simplices[t].v[1], o.simplices[t].v[2]);
    return s;
  };
  const GvdResult drawn = run(scene(false, 0));
  expect_valid(drawn);
  ASSERT_EQ(drawn.graph.edges.size(), 1u);
  const double gap = drawn.graph.edges[0].gap;
  EXPECT_NEAR(gap, g, 1e-9 * g);
  EXPECT_GT(drawn.stats.certified_leaves, 0u);
  for (const auto& [turn, every] : {std::pair{true, 0}, {false, 3}, {true, 3}}) {
    SCOPED_TRACE(std::string(turn ? "cavity turned" : "") +
                 (every ? ", every third reversed" : ""));
    const GvdResult r = run(scene(turn, every));
    expect_valid(r);
    EXPECT_EQ(r.stats.leaves, drawn.stats.leaves);
    EXPECT_EQ(r.stats.certified_leaves, drawn.stats.certified_leaves);
    EXPECT_EQ(graph_pairs(r.graph), graph_pairs(drawn.graph));
    ASSERT_EQ(r.graph.edges.size(), 1u);
    EXPECT_NEAR(r.graph.edges[0].gap, gap, 1e-9 * gap);
    EXPECT_FALSE(r.graph.edges[0].touching);
  }
  // Two boxes side by side, 1e-4 apart, flush on top, bottom and ends: their rims are mirror
  // images in the mid-plane. With one box written inside out (all its normals in) the mirror
  // test compared its triangles against turned normals and failed: 4,543,428 leaves against
  // 568.
  auto boxes = [](bool inside_out) {
    SceneObject a = test::make_box("a", {0, 0, 0}, {0.4, 1, 0.6});
    if (inside_out)
      for (Simplex& t : a.simplices) std::swap(t.v[1], t.v[2]);
    return test::make_scene(3, {std::move(a), test::make_box("b", {0.4001, 0, 0}, {0.8, 1, 0.6})});
  };
  const GvdResult flush = run(boxes(false));
  const GvdResult turned = run(boxes(true));
  expect_valid(turned);
  EXPECT_EQ(turned.stats.leaves, flush.stats.leaves);
  EXPECT_EQ(turned.stats.certified_leaves, flush.stats.certified_leaves);
  ASSERT_EQ(turned.graph.edges.size(), 1u);
  EXPECT_NEAR(turned.graph.edges[0].gap, 1e-4, 1e-12);
}

// A plate over a slab, 1e-4 apart, whose bottom face is a 4 x 4 grid of quads meeting the
// side faces' long edges at T-junctions (as CAD exporters that mesh each face alone write
// them): no edge of the bottom's rim has one triangle across, but the plate is closed as a
// solid, and it costs what the conforming plate costs. (With T-junctions taken as open edges
// the plate got no extruded cells: 5,412,072 leaves at 1e-4 against 16,920.)
TEST(ComputeGvd, ThinGapCostDoesNotDependOnTJunctions3D) {
  const double g = 1e-4;
  auto scene = [&](int k) {
    const Vec3 lo{0.1, 0.1, 0.1 + g}, hi{0.9, 0.9, 0.2};
    return test::make_scene(3, {test::make_box("low", {0, 0, 0}, {1, 1, 0.1}),
                                k > 1 ? test::make_box_with_split_bottom("high", lo, hi, k)
                                      : test::make_box("high", lo, hi)});
  };
  const GvdResult plain = run(scene(1));
  const GvdResult split = run(scene(4));
  expect_valid(split);
  EXPECT_EQ(split.stats.leaves, plain.stats.leaves);
  EXPECT_EQ(split.stats.certified_leaves, plain.stats.certified_leaves);
  ASSERT_EQ(split.graph.edges.size(), 1u);
  EXPECT_NEAR(split.graph.edges[0].gap, g, 1e-9 * g);
  EXPECT_NEAR(split.graph.edges[0].min_clearance, g / 2, 1e-6 * g);
}

// Checks the GVD of a shaft in its bore (make_shaft_in_bore, face gap g) inside the bore and
// away from the corners (where the shaft's edge is nearer than its faces): the mid surface,
// the prism whose apothem is the bore's less g / 2, exactly. Returns the vertices checked.
size_t expect_shaft_mid_surface(const GvdResult& r, const test::ShaftInBoreOptions& so, double g) {
  const double pi = std::acos(-1.0);
  const double mid = so.radius * std::cos(pi / so.sides) - g / 2;
  size_t checked = 0;
  for (size_t v = 0; v < r.gvd.cells[0].positions.size(); ++v) {
    if (r.gvd.cells[0].other[v] != 1) continue;
    const Vec3 p = r.gvd.cells[0].positions[v];
    if (p.z < 0.05 || p.z > 0.55) continue;  // away from the bore's ends
    // Face normals at pi / n + 2 pi k / n (the polygon has a vertex on +x): the largest
    // projection is the apothem coordinate, the second says how near a corner p is.
    double first = -1e300, second = -1e300;
    for (int k = 0; k < so.sides; ++k) {
      const double a = pi / so.sides + 2 * pi * k / so.sides;
      const double h = std::cos(a) * p.x + std::sin(a) * p.y;
      if (h > first) {
        second = first;
        first = h;
      } else {
        second = std::max(second, h);
      }
    }
    if (second > mid - 3 * g) continue;  // near a corner
    EXPECT_NEAR(first, mid, 1e-6 * (r.gvd.cells[0].clearance[v] + 2 * local_cell(r, p)) + 1e-14)
        << "vertex " << v << " at " << p.x << ", " << p.y << ", " << p.z;
    ++checked;
  }
  return checked;
}

/// The face gap of make_shaft_in_bore in scene units: its `gap` is a fraction of the side of
/// the domain along x, y, z (the default frame may be turned and have another side).
double shaft_gap(const Scene& scene, const test::ShaftInBoreOptions& so) {
  DomainOptions world;
  world.frame = DomainFrame::kWorld;
  return so.gap * make_domain(scene, world).side;
}

// A hexagonal shaft in a hexagonal bore, g between every pair of facing faces: the GVD is the
// mid surface inside the bore (expect_shaft_mid_surface).
TEST(ComputeGvd, ShaftInBoreGivesTheMidSurface3D) {
  // The bore's edges at 60 and 120 degrees in its end planes are slanted cells; the corners on
  // the x axis (normals straddling it) are cones on either side of the lattice plane y = 1/2.
  for (double gap : {1e-2, 1e-3}) {
    test::ShaftInBoreOptions so;
    so.gap = gap;
    so.cell = 0.1;
    const Scene scene = test::make_shaft_in_bore(so);
    const double g = shaft_gap(scene, so);
    // Full resolution: every surfaced vertex is checked (compaction removes those inside flat
    // parts, which the extruded cells along the bore leave few of).
    const GvdResult r = run(scene, 0, "exact", "certified", "full");
    expect_valid(r);
    EXPECT_GT(r.stats.certified_leaves, 0u);
    ASSERT_EQ(r.graph.edges.size(), 1u);
    EXPECT_NEAR(r.graph.edges[0].gap, g, 1e-9 * g);
    EXPECT_GT(expect_shaft_mid_surface(r, so, g), 100u);
  }
}

// A round (16-sided) shaft in its bore: with the octree along x, y, z, four of its corners
// have face normals that straddle an axis and refine to the gap (length / g leaves); the
// default frame is turned by half a side about z, so that every corner lies between two
// octree planes its faces are square to or slanted against within a quadrant. Valid, the
// exact gap, the mid surface exactly, and 100 times thinner for at most 3 times the leaves.
TEST(ComputeGvd, RoundShaftTurnsTheOctreeAndCostsTheSameAtAnyGap3D) {
  uint64_t leaves[2] = {0, 0};
  const double gaps[2] = {1e-3, 1e-5};
  for (int k = 0; k < 2; ++k) {
    test::ShaftInBoreOptions so;
    so.sides = 16;
    so.gap = gaps[k];
    so.cell = 0.1;
    const Scene scene = test::make_shaft_in_bore(so);
    const double g = shaft_gap(scene, so);
    const GvdResult r = run(scene, 0, "exact", "certified", "full");
    ASSERT_FALSE(r.domain.aligned());
    expect_valid(r);
    leaves[k] = r.stats.leaves;
    ASSERT_EQ(r.graph.edges.size(), 1u);
    EXPECT_FALSE(r.graph.edges[0].touching);
    EXPECT_NEAR(r.graph.edges[0].gap, g, 1e-9 * g);
    EXPECT_GT(expect_shaft_mid_surface(r, so, g), 100u) << "gap " << gaps[k];
  }
  EXPECT_LE(leaves[1], 3 * leaves[0])
      << leaves[0] << " leaves at 1e-3, " << leaves[1] << " at 1e-5";
}

// A faceted ball sealed in a socket whose cavity is the ball scaled: every face parallel to
// its cavity face, the rims between them along every direction. The meridians' rims run along
// no axis nor square to one (skew extruded cells), those at 0 and 90 degrees and next to the
// equator have normals that straddle an axis (skew cones), and the socket has two shells (box
// and cavity, each oriented). Leaves from 1e-2 to 3e-3 at 8 x 16 (this test): 4.0x before
// any of them (g^-1.15), 2.4x with skew cells alone, 1.57x now; at most g^-0.6 is asked.
// Correct at both gaps (expect_valid), the gap exact.
TEST(ComputeGvd, BallInSocketCostsLessThanOneOverTheGap3D) {
  uint64_t leaves[2] = {0, 0};
  uint64_t skew = 0, cones = 0;
  const double gaps[2] = {1e-2, 3e-3};
  for (int k = 0; k < 2; ++k) {
    test::BallInSocketOptions o;
    o.rings = 8;
    o.segments = 16;
    o.gap = gaps[k];
    const Scene scene = test::make_ball_in_socket(o);
    const double g = test::min_distance_3d(scene.objects[0], scene.objects[1]);
    const GvdResult r = run(scene, 0, "exact", "certified", "full");
    expect_valid(r);
    leaves[k] = r.stats.leaves;
    for (uint32_t i = 0; i < r.octree.leaf_count(); ++i) {
      skew += r.octree.is_skew(i);
      cones += r.octree.is_skew(i) && r.octree.cone_axis(i) >= 0;
    }
    ASSERT_EQ(r.graph.edges.size(), 1u);
    EXPECT_FALSE(r.graph.edges[0].touching);
    EXPECT_NEAR(r.graph.edges[0].gap, g, 1e-9 * g);
  }
  EXPECT_GT(skew, cones);
  EXPECT_GT(cones, 0u);
  EXPECT_LE(static_cast<double>(leaves[1]),
            std::pow(gaps[0] / gaps[1], 0.6) * static_cast<double>(leaves[0]))
      << leaves[0] << " leaves at 1e-2, " << leaves[1] << " at 3e-3";
}

// A leaf that holds two objects without a certificate exists only at the depth limit or the
// contact depth: anywhere else the GVD piece surfaced in it can cross an object. A pentagonal
// shaft in its bore, and a hexagonal one whose corners' apexes lie off the lattice planes (a
// block far off makes the domain lopsided; --frame world keeps make_domain from shifting the
// cube onto them), at 1e-3: no such leaf. Cones near an apex inside a cell certify the cell
// and its children only; before the refinement split such leaves, 32 and 426 of them were
// left.
TEST(ComputeGvd, LeavesHoldingTwoObjectsAreCertifiedOrAtTheLimit3D) {
  for (int variant = 0; variant < 2; ++variant) {
    test::ShaftInBoreOptions so;
    so.gap = 1e-3;
    if (variant == 0) so.sides = 5;
    Scene scene = test::make_shaft_in_bore(so);
    if (variant == 1)
      scene.objects.push_back(test::make_box("far", {0.3, 0.55, 0.3}, {0.35, 0.6291, 0.35}));
    PipelineOptions o;
    o.threads = 2;
    o.domain.frame = DomainFrame::kWorld;
    const GvdResult r = compute_gvd(std::move(scene), o);
    const size_t bad = uncertified_leaves_holding_two(r);
    EXPECT_EQ(bad, 0u) << (variant == 0 ? "pentagonal shaft" : "lopsided hexagonal shaft");
    for (const GvdCell& cell : r.gvd.cells) EXPECT_EQ(test::count_open_edges(cell, 3), 0u);
    EXPECT_EQ(test::count_gvd_object_crossings(r.scene, r.gvd, 1000), 0u);
  }
}

// Shafts whose corners have face normals on both sides of an octree axis (a pentagon; a
// hexagon with a vertex on x; a triangle, whose corners' normals span 120 degrees), in a domain
// made lopsided by a far block so that no corner lies on a lattice plane by chance:
// make_domain puts the apex of the bisector's roof over those corners on a lattice plane, the
// cells on either side are certified (cones), and 100 times thinner costs at most 3 times the
// leaves (what grows is the corners at the bore's ends; 10 for the triangle, below). Valid
// (closed, oriented, brute-force oracles), no piece crosses an object, no uncertified leaf holds
// both, the exact gap, the mid surface.
TEST(ComputeGvd, ShaftsWhoseCornersStraddleAnAxisCostTheSameAtAnyGap3D) {
  for (int sides : {3, 5, 6}) {
    uint64_t leaves[2] = {0, 0};
    const double gaps[2] = {1e-3, 1e-5};
    for (int k = 0; k < 2; ++k) {
      test::ShaftInBoreOptions so;
      so.sides = sides;
      so.gap = gaps[k];
      so.cell = 0.1;
      Scene scene = test::make_shaft_in_bore(so);
      const double g = shaft_gap(scene, so);
      scene.objects.push_back(test::make_box("far", {0.3, 0.55, 0.3}, {0.35, 0.6291, 0.35}));
      const GvdResult r = run(scene, 0, "exact", "certified", "full");
      const std::string what = std::to_string(sides) + " sides at " + std::to_string(gaps[k]);
      SCOPED_TRACE(what);
      expect_valid(r);
      EXPECT_EQ(test::count_gvd_object_crossings(r.scene, r.gvd, 1000), 0u) << what;
      const size_t bad = uncertified_leaves_holding_two(r);
      EXPECT_EQ(bad, 0u) << what;
      EXPECT_EQ(r.stats.refine_rounds, 1) << what;
      leaves[k] = r.stats.leaves;
      const DualEdge* pair = nullptr;
      for (const DualEdge& e : r.graph.edges)
        if (e.a == 0 && e.b == 1) pair = &e;
      ASSERT_NE(pair, nullptr) << what;
      EXPECT_FALSE(pair->touching);
      EXPECT_NEAR(pair->gap, g, 1e-9 * g) << what;
      EXPECT_GT(expect_shaft_mid_surface(r, so, g), 100u) << what;
    }
    // The triangle's corners meet the bore's ends in cells that refine below the gap until
    // about 1e-4 (in this lopsided domain with 0.05 cells: 74k leaves at 1e-4, 75k at 1e-5):
    // the bound is g^-0.5 over the sweep, half the exponent the issue allows in 3D.
    EXPECT_LE(leaves[1], (sides == 3 ? 10 : 3) * leaves[0])
        << sides << " sides: " << leaves[0] << " leaves at 1e-3, " << leaves[1] << " at 1e-5";
  }
}

// A prism drawn as CAD exports it, two triangles per side face and fans on its caps: a regular
// `sides`-gon of circumradius r (a vertex at angle `phase`) from z0 to z1, closed and
// outward; or, with `bore` > 0, a sleeve: the same polygon of circumradius `outer` with a
// coaxial bore of circumradius `bore`, outward normals everywhere (into the bore on its walls).
SceneObject cad_prism(const std::string& label, int sides, double r, double z0, double z1,
                      double phase, double bore = 0) {
  SceneObject o;
  o.label = label;
  const double pi = std::acos(-1.0);
  auto at = [&](double radius, int i, double z) {
    const double a = phase + 2 * pi * i / sides;
    return Vec3{radius * std::cos(a), radius * std::sin(a), z};
  };
  auto add = [&](uint32_t a, uint32_t b, uint32_t c) { o.simplices.push_back({{a, b, c}}); };
  const auto n = static_cast<uint32_t>(sides);
  if (bore <= 0) {
    for (const double z : {z0, z1})
      for (int i = 0; i < sides; ++i) o.vertices.push_back(at(r, i, z));
    o.vertices.push_back({0, 0, z0});
    o.vertices.push_back({0, 0, z1});
    for (uint32_t i = 0; i < n; ++i) {
      const uint32_t j = (i + 1) % n;
      add(i, j, n + j);
      add(i, n + j, n + i);
      add(2 * n, j, i);
      add(2 * n + 1, n + i, n + j);
    }
    return o;
  }
  // Rings: (z0, bore), (z0, outer), (z1, bore), (z1, outer).
  for (const double z : {z0, z1})
    for (const double radius : {bore, r})
      for (int i = 0; i < sides; ++i) o.vertices.push_back(at(radius, i, z));
  auto v = [&](uint32_t ring, uint32_t i) { return ring * n + i % n; };
  for (uint32_t i = 0; i < n; ++i) {
    const uint32_t j = i + 1;
    add(v(1, i), v(1, j), v(3, j));  // outer wall
    add(v(1, i), v(3, j), v(3, i));
    add(v(0, i), v(2, j), v(0, j));  // bore wall, facing the axis
    add(v(0, i), v(2, i), v(2, j));
    add(v(0, i), v(0, j), v(1, j));  // end at z0, facing -z
    add(v(0, i), v(1, j), v(1, i));
    add(v(2, i), v(3, j), v(2, j));  // end at z1, facing +z
    add(v(2, i), v(3, i), v(3, j));
  }
  return o;
}

// A pentagonal shaft in a pentagonal sleeve, both drawn as CAD exports them (long triangles
// spanning the whole length, no vertex between the ends), at an angle about z, g between
// facing faces. Near the bore's ends the cells were small enough for a cone's line along the
// straddled axis to pass next to the roof's apex, nearly along the bisector: the crossing
// count there ran out of its evaluation budget, the cells failed round after round and the
// whole scene fell back to no cones (3.9M leaves and 27 s at 1e-4; now 37k leaves). Valid,
// no crossings, no fallback, the exact gap, and 10 and 100 times thinner for at most 3 times
// the leaves.
TEST(ComputeGvd, CadMeshedShaftInASleeveCostsTheSameAtAnyGap3D) {
  const double pi = std::acos(-1.0);
  uint64_t leaves[3] = {0, 0, 0};
  const double gaps[3] = {1e-3, 1e-4, 1e-5};
  for (int k = 0; k < 3; ++k) {
    const int sides = 5;
    const double r = 0.2, phase = 0.3, g = gaps[k];
    const double bore = (r * std::cos(pi / sides) + g) / std::cos(pi / sides);
    Scene scene;
    scene.dimension = 3;
    scene.objects.push_back(cad_prism("shaft", sides, r, -0.1, 0.7, phase));
    scene.objects.push_back(
        cad_prism("sleeve", sides, 0.45 / std::cos(pi / sides), 0, 0.6, phase, bore));
    const std::string what = "gap " + std::to_string(g);
    const GvdResult r5 = run(scene);
    expect_valid(r5);
    EXPECT_EQ(test::count_gvd_object_crossings(r5.scene, r5.gvd, 1000), 0u) << what;
    for (const SceneWarning& w : r5.scene.warnings)
      EXPECT_NE(w.kind, WarningKind::kConesDropped) << what;
    size_t bad = 0;
    for (uint32_t i = 0; i < r5.octree.leaf_count(); ++i)
      bad += r5.octree.object[i] == kManyObjects && !r5.octree.is_certified(i) &&
             r5.octree.level[i] < r5.octree.max_depth;
    EXPECT_EQ(bad, 0u) << what;
    ASSERT_EQ(r5.graph.edges.size(), 1u) << what;
    EXPECT_FALSE(r5.graph.edges[0].touching);
    EXPECT_NEAR(r5.graph.edges[0].gap, g, 1e-9 * g) << what;
    leaves[k] = r5.stats.leaves;
    if (k != 1) continue;
    // The sleeve's ends reversed (inward), as some exporters write them: validate_scene turns
    // them back (reoriented_triangles) and the cost is the same.
    SceneObject& sleeve = scene.objects[1];
    for (size_t t = 0; t < sleeve.simplices.size(); ++t)
      if (t % 8 >= 4) std::swap(sleeve.simplices[t].v[1], sleeve.simplices[t].v[2]);
    validate_scene(scene);
    const GvdResult flipped = run(scene);
    EXPECT_EQ(flipped.stats.leaves, leaves[k]);
    size_t reoriented = 0;
    for (const SceneWarning& w : flipped.scene.warnings)
      if (w.kind == WarningKind::kReorientedTriangles) reoriented += w.count;
    EXPECT_EQ(reoriented, 4u * sides);
  }
  for (int k = 1; k < 3; ++k)
    EXPECT_LE(leaves[k], 3 * leaves[0])
        << leaves[0] << " leaves at 1e-3, " << leaves[k] << " at " << gaps[k];
}

// `one` with a copy of its objects moved by `move`, labelled with "_2": objects 0, 1 and their
// copies 2, 3.
template <class Move>
Scene with_moved_copy(const Scene& one, Move move) {
  Scene scene = one;
  for (SceneObject obj : one.objects) {
    for (Vec3& v : obj.vertices) v = move(v);
    obj.label += "_2";
    scene.objects.push_back(std::move(obj));
  }
  return scene;
}

// A result of with_moved_copy's scene of two pairs (0-1 and 2-3, each at gap g): valid, cells
// oriented on each pair's interface, no uncertified leaf holding two objects, both pairs in
// the dual graph at their exact gap and not touching.
void expect_two_pairs_at_gap(const GvdResult& r, double g) {
  expect_valid(r, [](ObjectId a, ObjectId b) { return std::min(a, b) / 2 == std::max(a, b) / 2; });
  EXPECT_EQ(uncertified_leaves_holding_two(r), 0u);
  int pairs = 0;
  for (const DualEdge& e : r.graph.edges) {
    if (!((e.a == 0 && e.b == 1) || (e.a == 2 && e.b == 3))) continue;
    ++pairs;
    EXPECT_FALSE(e.touching);
    EXPECT_NEAR(e.gap, g, 1e-9 * g) << e.a << "-" << e.b;
  }
  EXPECT_EQ(pairs, 2);
}

// One shaft in its bore (`sides`, `gap`), and two: it at half the gap (the joined scene's
// domain is about twice as large) beside a copy moved by `move`. The two are valid, both pairs
// at their exact gaps, no uncertified leaf holding two objects, and cost at most three times
// the one.
template <class Move>
void expect_two_shafts_cost_what_two_single_ones_do(int sides, double gap, Move move) {
  test::ShaftInBoreOptions so;
  so.sides = sides;
  so.gap = gap;
  const GvdResult one = run(test::make_shaft_in_bore(so));
  so.gap = 0.5 * gap;
  const Scene single = test::make_shaft_in_bore(so);
  const GvdResult two = run(with_moved_copy(single, move));
  expect_two_pairs_at_gap(two, so.gap * make_domain(single).side);
  EXPECT_LE(two.stats.leaves, 3 * one.stats.leaves)
      << one.stats.leaves << " leaves for one shaft, " << two.stats.leaves << " for two";
}

// Two triangular shafts in their bores side by side cost about what two single ones do. Their
// walls at 60 and 120 degrees are slanted faces whose normals come from triangles on the 2^-48
// lattice, tilted by up to ~2e-12 by the rounding; with the slanted certificate's tolerance
// at 1e-12 the bores' mouths refined to the gap (306,636 leaves against 28,204 for one shaft
// at 1e-4).
TEST(ComputeGvd, TwoTriangularShaftsCostWhatTwoSingleOnesCost3D) {
  expect_two_shafts_cost_what_two_single_ones_do(3, 1e-4, [](Vec3 v) {
    return v + Vec3{1.5, 0, 0};
  });
}

// Two hexagonal shafts in their bores, the second turned 0.7 rad about the skew axis (2, -1, 3):
// the octree's frame fits one, and the other's rims are skew wedges whose e is the shaft's
// axis. The two faces of a rim give two normals, and e is their cross product, but each face's
// normal comes from its own triangles on the 2^-48 lattice: e missed being square to them by
// ~1e-12, over the skew test's 1e-12 (not the 1e-10 slanted cells allow), and every rim cell
// was refused down to the gap (here 177,815 leaves against 30,584 for one shaft at 1e-3; on
// gvd_audit's two_hex_skew 1,047,509 at 1e-4 and 9,305,794 at 1e-5).
TEST(ComputeGvd, TwoHexagonalShaftsTurnedAboutASkewAxisCostWhatTwoSingleOnesCost3D) {
  const Vec3 axis = Vec3{2, -1, 3} / std::sqrt(14.0);
  expect_two_shafts_cost_what_two_single_ones_do(6, 1e-3, [&](Vec3 v) {
    return test::rotate(v - Vec3{0.5, 0.5, 0.5}, axis, 0.7) + Vec3{2.0, 0.5, 0.5};
  });
}

// Two pentagonal shafts in their bores side by side, the second 1.3 along x and 0.1234 along
// y. With the default frame, make_domain puts both shafts' apexes on x on lattice planes (the
// cube's side) and the first one's on y; the second one's apex on y lies inside cells. With
// --frame world nothing is aligned. Cells holding an apex are cones too: lines along the
// straddled axis beside the apex meet the bisector twice, the certificate says so, and the
// surfacer finds both crossings on those edges. Before, such cells were refused and refined to
// the gap (default frame), or 2:1 balance split their grandchildren round after round until the
// pipeline built the octree again without cones (world frame: warning cones_dropped, twice the
// leaves). Both frames now keep the cones and cost about the same: no leaf holding both objects
// uncertified, no piece crossing an object, closed cells.
TEST(ComputeGvd, ShaftsWhoseApexesAreNotAllOnPlanesKeepTheOtherCones3D) {
  test::ShaftInBoreOptions so;
  so.sides = 5;
  so.gap = 1e-3;
  so.cell = 0.1;
  const Scene one = test::make_shaft_in_bore(so);
  Scene scene = one;
  for (SceneObject o : one.objects) {
    for (Vec3& v : o.vertices) v = v + Vec3{1.3, 0.1234, 0};
    o.label += "_2";
    scene.objects.push_back(std::move(o));
  }
  uint64_t leaves[2] = {0, 0};
  for (const DomainFrame frame : {DomainFrame::kAuto, DomainFrame::kWorld}) {
    PipelineOptions o;
    o.threads = 2;
    o.domain.frame = frame;
    const GvdResult r = compute_gvd(scene, o);
    const bool world = frame == DomainFrame::kWorld;
    const char* what = world ? "world" : "auto";
    const size_t bad = uncertified_leaves_holding_two(r);
    EXPECT_EQ(bad, 0u) << what;
    for (const GvdCell& cell : r.gvd.cells) EXPECT_EQ(test::count_open_edges(cell, 3), 0u);
    EXPECT_EQ(test::count_gvd_object_crossings(r.scene, r.gvd, 1000), 0u) << what;
    EXPECT_LT(r.stats.refine_rounds, 12) << what;
    const bool dropped =
        std::any_of(r.scene.warnings.begin(), r.scene.warnings.end(),
                    [](const SceneWarning& w) { return w.kind == WarningKind::kConesDropped; });
    EXPECT_FALSE(dropped) << what;
    leaves[world ? 1 : 0] = r.stats.leaves;
  }
  EXPECT_LT(4 * leaves[1], 5 * leaves[0])
      << leaves[0] << " leaves, with --frame world " << leaves[1];
}

// Whether p (the blade's own frame) lies in the gap between the blade and the slot's left wall,
// away from the floor, the mouth and the blade's ends: there the GVD is the mid-plane.
bool in_left_wall_gap(const test::BladeInSlotOptions& o, double g, Vec3 p) {
  const double x0 = 0.5 - 0.5 * o.width, floor_y = 0.5 - o.depth;
  return p.x >= x0 - g && p.x <= x0 && p.y >= floor_y + 0.02 && p.y <= 0.48 && p.z >= 0.12 &&
         p.z <= 0.88;
}

// A blade fully in a slot, clearance g to both walls and the floor over the whole faces: every
// rim is straight along an axis (the blade's edges, the slot's floor corners and mouth), so
// extruded pair cells sweep the bisector along the rims and the cost does not follow 1 / g.
// Valid (closed, oriented, no crossings, equidistant vertices), the exact gap, the mid-planes
// of the wall gaps exactly, and 100 times thinner for at most twice the leaves.
TEST(ComputeGvd, BladeFullyInSlotCostsTheSameAtAnyGap3D) {
  uint64_t leaves[2] = {0, 0};
  const double gaps[2] = {1e-3, 1e-5};
  for (int k = 0; k < 2; ++k) {
    test::BladeInSlotOptions o;
    o.gap = gaps[k];
    const Scene scene = test::make_blade_in_slot(o);
    const double g = o.gap * make_domain(scene).side;
    const GvdResult r = run(scene);
    expect_valid(r);
    leaves[k] = r.stats.leaves;
    ASSERT_EQ(r.graph.edges.size(), 1u);
    EXPECT_FALSE(r.graph.edges[0].touching);
    EXPECT_NEAR(r.graph.edges[0].gap, g, 1e-9 * g);
    EXPECT_NEAR(r.graph.edges[0].min_clearance, g / 2, 1e-2 * g);
    const double x0 = 0.5 - 0.5 * o.width;
    size_t on_plane = 0;
    std::vector<double> relative;
    const GvdCell& cell = r.gvd.cells[0];
    for (size_t v = 0; v < cell.positions.size(); ++v) {
      if (cell.other[v] != 1) continue;
      const Vec3 p = cell.positions[v];
      const double da = test::brute_distance(r.scene, 0, p);
      const double db = test::brute_distance(r.scene, 1, p);
      if (relative.size() < 4000) relative.push_back(std::abs(da - db) / std::max(da, db));
      if (!in_left_wall_gap(o, g, p)) continue;
      EXPECT_NEAR(p.x, x0 - g / 2, 1e-6 * g) << "vertex " << v;
      ++on_plane;
    }
    EXPECT_GT(on_plane, 0u);
    ASSERT_FALSE(relative.empty());
    std::nth_element(relative.begin(), relative.begin() + relative.size() / 2, relative.end());
    EXPECT_LT(relative[relative.size() / 2], 1e-6) << "median relative gap at GVD vertices";
  }
  EXPECT_LE(leaves[1], 2 * leaves[0])
      << leaves[0] << " leaves at 1e-3, " << leaves[1] << " at 1e-5";
}

// Two blades in their slots, the second turned 30 degrees about y against the first: one
// octree frame cannot serve both. The turned blade's rims along y have their normals on both
// sides of x or z (cones), and the apexes of the bisector's roofs over its four rims lie at
// coordinates that no lattice plane holds. Cells holding them are cones whose edges along the
// straddled axis may cross the bisector twice (found exactly by the surfacer); before, they were
// refused and the rims refined to the gap (3.2M leaves at 1e-4, the leaf limit at 1e-5). Valid,
// both pairs' gaps exact, and 100 times thinner for at most twice the leaves. Orientation is
// counted on each blade's interface with its own block: between the two blocks, junctions of
// block, block_2 and blade_2 in cells of 0.05 to 0.37 at a clearance near 1 leave fans folded
// over 0.25 % (1e-3) to 0.54 % (1e-5) of the sampled area, the paper's surfacing in coarse
// cells far from any thin gap (docs/BENCHMARKS.md).

// Two blades in slots at gaps[0] and gaps[1], the second moved by `turn` (its user
// coordinates after the blade's own centre is moved to the origin): valid, both pairs' gaps
// exact, no uncertified leaf holding two objects; the leaf counts at the two gaps.
template <class Turn>
std::array<uint64_t, 2> blades_turned_against_each_other(Turn turn, const double (&gaps)[2]) {
  std::array<uint64_t, 2> leaves{0, 0};
  for (int k = 0; k < 2; ++k) {
    test::BladeInSlotOptions o;
    o.gap = gaps[k];
    const Scene one = test::make_blade_in_slot(o);
    const double g = o.gap * make_domain(one).side;
    const GvdResult r = run(with_moved_copy(one, [&](Vec3 v) {
      return turn(v - Vec3{0.5, 0, 0.5}) + Vec3{2, 0, 0.5};
    }));
    SCOPED_TRACE("gap " + std::to_string(gaps[k]));
    expect_two_pairs_at_gap(r, g);
    leaves[k] = r.stats.leaves;
  }
  return leaves;
}

TEST(ComputeGvd, BladesTurnedAgainstEachOtherCostTheSameAtAnyGap3D) {
  const double gaps[2] = {1e-3, 1e-5};
  const std::array<uint64_t, 2> leaves = blades_turned_against_each_other(
      [](Vec3 v) {
        return test::rotate(v, {0, 1, 0}, std::acos(-1.0) / 6);
      },
      gaps);
  EXPECT_LE(leaves[1], 2 * leaves[0])
      << leaves[0] << " leaves at 1e-3, " << leaves[1] << " at 1e-5";
}

// The same with the second blade turned about two axes (30 degrees about y, then 20 about
// x): its edges at its ends are square to x, and their faces' normals straddle both y and z
// (the octree frame fits the first blade). Such cells are wedges (pair_certificate.h), whose
// edges along y and z may cross the bisector twice and whose faces square to x carry the
// bisector's straight pieces along e; before, they were split to the gap along those edges
// (2.27M leaves at 1e-4 against 65k for the blades turned about y alone, the leaf limit at
// 1e-5).
TEST(ComputeGvd, BladesTurnedAboutTwoAxesCostTheSameAtAnyGap3D) {
  const double pi = std::acos(-1.0);
  const double gaps[2] = {1e-3, 1e-4};
  const std::array<uint64_t, 2> leaves = blades_turned_against_each_other(
      [&](Vec3 v) {
        return test::rotate(test::rotate(v, {0, 1, 0}, pi / 6), {1, 0, 0}, pi / 9);
      },
      gaps);
  EXPECT_LE(leaves[1], 2 * leaves[0])
      << leaves[0] << " leaves at 1e-3, " << leaves[1] << " at 1e-4";
}

// The same with the second blade turned 0.7 rad about the skew axis (2, -1, 3): no frame that
// fits the first blade has an axis square to the second one's rims, whose faces' normals
// straddle two axes and keep one sign along the third. Such cells are wedges too, e square to
// no axis; on their faces square to the third axis the bisector is C sheared along e, a curve
// that turns by up to nearly a half turn, whose pieces the surfacer sorts across the middle of
// that turn. Before, they were split to the gap (11.5M leaves and 217 s at 1e-4).
TEST(ComputeGvd, BladesTurnedAboutASkewAxisCostTheSameAtAnyGap3D) {
  const double gaps[2] = {1e-3, 1e-4};
  const std::array<uint64_t, 2> leaves = blades_turned_against_each_other(
      [](Vec3 v) {
        return test::rotate(v, Vec3{2, -1, 3} / std::sqrt(14.0), 0.7);
      },
      gaps);
  EXPECT_LE(leaves[1], 2 * leaves[0])
      << leaves[0] << " leaves at 1e-3, " << leaves[1] << " at 1e-4";
}

// The blade in its slot tilted about the skew axis (2, -1, 3), in the user's frame (--frame
// world): its rims are square to no axis, and their faces' normals straddle two axes: skew
// wedges. Where e runs nearly along a face, the bisector there turns by nearly a half turn (a
// hairpin), and a line across one of its arcs meets the other leg too: the tracer keeps to
// the triangle of the arc's chord and end tangents (at 1e-5 two GVD triangles cut the blade's
// rim without that). Before, such cells were split to the gap (522,824 leaves at 1e-3, 5.64M
// at 1e-4). Valid, no GVD triangle crossing an object (every one checked), the exact gap, and
// 100 times thinner for at most twice the leaves.
TEST(ComputeGvd, TiltedBladeInTheUsersFrameCostsTheSameAtAnyGap3D) {
  uint64_t leaves[2] = {0, 0};
  const double gaps[2] = {1e-3, 1e-5};
  for (int k = 0; k < 2; ++k) {
    test::BladeInSlotOptions bo;
    bo.gap = gaps[k];
    Scene scene = test::make_blade_in_slot(bo);
    const double g = bo.gap * make_domain(scene).side;
    for (SceneObject& ob : scene.objects)
      for (Vec3& v : ob.vertices) v = test::rotate(v, Vec3{2, -1, 3} / std::sqrt(14.0), 0.7);
    PipelineOptions o;
    o.threads = 2;
    o.domain.frame = DomainFrame::kWorld;
    const GvdResult r = compute_gvd(scene, o);
    SCOPED_TRACE("gap " + std::to_string(gaps[k]));
    ASSERT_TRUE(r.domain.aligned());
    expect_valid(r);
    EXPECT_EQ(test::count_gvd_object_crossings(r.scene, r.gvd, 0), 0u);
    EXPECT_EQ(uncertified_leaves_holding_two(r), 0u);
    ASSERT_EQ(r.graph.edges.size(), 1u);
    EXPECT_FALSE(r.graph.edges[0].touching);
    EXPECT_NEAR(r.graph.edges[0].gap, g, 1e-9 * g);
    leaves[k] = r.stats.leaves;
  }
  EXPECT_LE(leaves[1], 2 * leaves[0])
      << leaves[0] << " leaves at 1e-3, " << leaves[1] << " at 1e-5";
}

// The blade in its slot tilted about a skew axis: the octree turns to the scene's faces
// (DomainFrame::kAuto), so its rims are extruded cells again and it costs what the untilted
// one costs (with the user's axes its rims refine to the gap: ~59x the leaves at 1e-3,
// ~430x at 1e-4). The answers come back in the user's frame: the left wall's gap has its
// mid-plane at x0 - g / 2 in the blade's own coordinates.
TEST(ComputeGvd, TiltedBladeInSlotCostsWhatItCostsUntilted3D) {
  test::BladeInSlotOptions o;
  o.gap = 1e-4;
  const Scene straight = test::make_blade_in_slot(o);
  const double g = o.gap * make_domain(straight).side;
  const Vec3 axis = Vec3{2, -1, 3} / std::sqrt(14.0);
  const double angle = 0.7;
  Scene tilted = straight;
  for (SceneObject& ob : tilted.objects)
    for (Vec3& v : ob.vertices) v = test::rotate(v, axis, angle);
  const GvdResult a = run(straight);
  const GvdResult b = run(tilted);
  ASSERT_FALSE(b.domain.aligned());
  expect_valid(b);
  EXPECT_LE(b.stats.leaves, a.stats.leaves + a.stats.leaves / 10) << a.stats.leaves << " untilted";
  ASSERT_EQ(b.graph.edges.size(), 1u);
  EXPECT_FALSE(b.graph.edges[0].touching);
  EXPECT_NEAR(b.graph.edges[0].gap, g, 1e-9 * g);
  EXPECT_NEAR(b.graph.edges[0].min_clearance, g / 2, 1e-2 * g);
  const double x0 = 0.5 - 0.5 * o.width;
  size_t on_plane = 0;
  const GvdCell& cell = b.gvd.cells[0];
  for (size_t v = 0; v < cell.positions.size(); ++v) {
    if (cell.other[v] != 1) continue;
    const Vec3 p = test::rotate(cell.positions[v], axis, -angle);  // the blade's own frame
    if (!in_left_wall_gap(o, g, p)) continue;
    EXPECT_NEAR(p.x, x0 - g / 2, 1e-6 * g) << "vertex " << v;
    ++on_plane;
  }
  EXPECT_GT(on_plane, 0u);
}

// Six stacked plates, every other one inset (so each rim is a plate's edge over the next
// plate's face, not a mirror image), full-face gaps g: extruded cells along the rims. The
// middle gap's mid-plane lies on a lattice plane, so traced curves there reach a face's edge
// and follow it (a chord across the rim would cut the plate). Valid at 1e-3 and 1e-5, and
// 100 times thinner for at most twice the leaves.
TEST(ComputeGvd, StackedPlatesOfDifferentSizesCostTheSameAtAnyGap3D) {
  uint64_t leaves[2] = {0, 0};
  const double gaps[2] = {1e-3, 1e-5};
  for (int k = 0; k < 2; ++k) {
    std::vector<SceneObject> plates;
    double y = 0;
    for (int i = 0; i < 6; ++i) {
      const double inset = i % 2 == 1 ? 0.1 : 0.0;
      plates.push_back(test::make_box("p" + std::to_string(i), {inset, y, inset},
                                      {1 - inset, y + 0.1, 1 - 0.5 * inset}));
      y += 0.1 + gaps[k];
    }
    const GvdResult r = run(test::make_scene(3, std::move(plates)));
    expect_valid(r);
    leaves[k] = r.stats.leaves;
    for (const DualEdge& e : r.graph.edges) {
      if (e.b != e.a + 1) continue;  // consecutive plates
      EXPECT_NEAR(e.gap, gaps[k], 1e-9 * gaps[k]);
      EXPECT_NEAR(e.min_clearance, gaps[k] / 2, 1e-9 * gaps[k]);
    }
  }
  EXPECT_LE(leaves[1], 2 * leaves[0])
      << leaves[0] << " leaves at 1e-3, " << leaves[1] << " at 1e-5";
}

// Flush stacked plates at a full-face gap of 1e-5 of the domain: at their rims each plate is
// the next one's mirror image, so the GVD is the mid-plane of every gap up to and beyond the
// rims (mirror cells), in a number of leaves that does not depend on the gap.
TEST(ComputeGvd, FlushStackedPlatesGiveExactMidPlanesAtAnyGap3D) {
  std::vector<uint64_t> leaves;
  for (const double gap : {1e-3, 1e-5}) {
    SCOPED_TRACE("gap " + std::to_string(gap));
    test::StackedPlatesOptions po;
    po.count = 3;
    po.gap = gap;
    po.cell = 0.1;
    const Scene scene = test::make_stacked_plates(po);
    const double g = gap * make_domain(scene).side;
    const GvdResult r = run(scene);
    expect_valid(r);
    leaves.push_back(r.stats.leaves);
    ASSERT_EQ(graph_pairs(r.graph), (std::set<std::pair<ObjectId, ObjectId>>{{0, 1}, {1, 2}}));
    size_t checked = 0;
    for (const GvdCell& cell : r.gvd.cells) {
      for (size_t v = 0; v < cell.positions.size(); ++v) {
        const ObjectId other = cell.other[v];
        if (other == kNoObject) continue;
        // Plate i spans y in [i (0.1 + g), i (0.1 + g) + 0.1]: the mid-plane of gap i, i + 1.
        const ObjectId low = std::min(cell.object, other);
        const double mid = low * (0.1 + g) + 0.1 + g / 2;
        // To the hair that keeps edge points inside their edge: a millionth of the edge or,
        // on edges longer than the distance, of the local clearance (>= g / 2).
        const Vec3 p = cell.positions[v];
        EXPECT_NEAR(p.y, mid, 1e-6 * (cell.clearance[v] + 2 * local_cell(r, p)) + 1e-14)
            << "vertex " << v;
        ++checked;
      }
    }
    EXPECT_GT(checked, 0u);
    for (const DualEdge& e : r.graph.edges) {
      EXPECT_NEAR(e.min_clearance, g / 2, 1e-6 * (g / 2 + 2 * local_cell(r, e.tightest_point)));
    }
  }
  EXPECT_LE(leaves[1], 2 * leaves[0])
      << leaves[0] << " leaves at 1e-3, " << leaves[1] << " at 1e-5";
}

// Two curved objects almost touching at a point, 3e-5 apart on an 11-unit domain (the
// lattice resolves ~6e-6 there): default options report their true gap and half of it as
// the clearance, not "touching". Pushed into each other they are touching, with clearance 0.
TEST(ComputeGvd, NearContactReportsTheTrueGapAndTouchingOnlyWhenUnresolvable) {
  for (const double gap : {3e-5, -1e-3}) {
    SCOPED_TRACE("gap " + std::to_string(gap));
    SceneObject a = test::make_sphere("a", {0, 0, 0}, 2.5, 48, 96);
    SceneObject b = test::make_sphere("b", {2.5 + 3.0, 0, 0}, 3.0, 48, 96);
    // Both meshes have a vertex on the x axis (their poles are on z): a's at x = 2.5, b's at
    // x = 2.5; shift b to the gap asked for.
    for (Vec3& v : b.vertices) v.x += gap;
    const double truth = gap > 0 ? test::min_distance_3d(a, b) : 0.0;
    const GvdResult r = run(test::make_scene(3, {a, b}));
    EXPECT_GT(r.domain.side, 11.0);
    ASSERT_EQ(r.graph.edges.size(), 1u);
    const DualEdge& e = r.graph.edges[0];
    bool warned = false;
    for (const SceneWarning& w : r.scene.warnings) warned |= w.kind == WarningKind::kObjectsTouch;
    if (gap > 0) {
      EXPECT_NEAR(e.gap, truth, 1e-9 * truth);
      EXPECT_FALSE(e.touching);
      EXPECT_FALSE(warned);
      EXPECT_NEAR(e.min_clearance, truth / 2, 0.02 * truth / 2);
    } else {
      EXPECT_EQ(e.gap, 0.0);
      EXPECT_TRUE(e.touching);
      EXPECT_TRUE(warned);
      EXPECT_EQ(e.min_clearance, 0.0);
    }
  }
}

// 470 convex polygons cut in 235 pairs, flat-to-flat gaps log-spaced from 1e-3 down to 1e-6 or
// 1e-7 of the domain: the dual graph is the exact segment Voronoi diagram's (Boost.Polygon),
// also where a thin wedge of a third object separates two regions at the domain's edge.
// Turned by 0.37 rad and moved (the octree's frame is then the scene's, not the pairs' edges),
// the same holds.
TEST(ComputeGvd, PolygonPairsDualGraphIsTheExactSegmentVoronoiOnes2D) {
  for (const auto& [gap, angle] : {std::pair{1e-6, 0.0}, {1e-7, 0.0}, {1e-7, 0.37}}) {
    SCOPED_TRACE("gap " + std::to_string(gap) + " angle " + std::to_string(angle));
    test::PolygonPairsOptions po;
    po.min_gap = gap;
    Scene scene = test::make_polygon_pairs_2d(po);
    const double c = std::cos(angle), s = std::sin(angle);
    if (angle != 0)
      for (SceneObject& o : scene.objects)
        for (Vec3& v : o.vertices) v = {c * v.x - s * v.y + 0.3, s * v.x + c * v.y - 1.7, 0};
    const GvdResult r = run(std::move(scene));
    const bench::BoostAdjacency truth = bench::boost_voronoi_adjacency(r.scene, r.domain.box());
    std::set<std::pair<ObjectId, ObjectId>> exact;
    for (const bench::BoostAdjacentPair& p : truth.pairs) exact.insert({p.a, p.b});
    const std::set<std::pair<ObjectId, ObjectId>> ours = graph_pairs(r.graph);
    for (const auto& [a, b] : ours)
      EXPECT_TRUE(exact.count({a, b}))
          << "only ours: " << r.scene.objects[a].label << "/" << r.scene.objects[b].label;
    for (const auto& [a, b] : exact)
      EXPECT_TRUE(ours.count({a, b})) << "only the exact diagram: " << r.scene.objects[a].label
                                      << "/" << r.scene.objects[b].label;
  }
}

TEST(ComputeGvd, SphereInShellGivesTheMidRadiusSphere) {
  SceneObject inner = test::make_sphere("inner", {0, 0, 0}, 0.5, 16, 32);
  SceneObject shell = test::make_sphere("shell", {0, 0, 0}, 1.0, 16, 32);
  auto r = run(test::make_scene(3, {inner, shell}), 7);
  expect_valid(r);
  size_t n = 0;
  for (size_t v = 0; v < r.gvd.cells[0].positions.size(); ++v) {
    if (r.gvd.cells[0].other[v] != 1) continue;
    const Vec3 p = r.gvd.cells[0].positions[v];
    // Between two tessellated spheres the bisector is at the mid radius up to the
    // tessellation error (~1 - cos(pi/16) of the radius) and the cell size.
    EXPECT_NEAR(norm(p), 0.75, 0.03 + local_cell(r, p));
    ++n;
  }
  EXPECT_GT(n, 0u);
  // Each sphere lies in its own cell only: the inner one inside the cell bounded at mid radius.
  for (ObjectId o = 0; o < 2; ++o) {
    const SceneObject& obj = r.scene.objects[o];
    for (size_t t = 0; t < obj.simplices.size(); t += 13) {
      const Simplex& x = obj.simplices[t];
      const Vec3 c = (obj.vertices[x.v[0]] + obj.vertices[x.v[1]] + obj.vertices[x.v[2]]) / 3.0;
      EXPECT_TRUE(test::inside_cell(r.gvd.cells[o], c)) << "object " << o;
      EXPECT_FALSE(test::inside_cell(r.gvd.cells[1 - o], c)) << "object " << o;
    }
  }
  // The inner object's cell is closed and lies entirely inside the shell.
  EXPECT_EQ(graph_pairs(r.graph), (std::set<std::pair<ObjectId, ObjectId>>{{0, 1}}));
}

TEST(ComputeGvd, ClosePackedSpheres3D) {
  std::vector<SceneObject> objects;
  int k = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 2; ++j)
      objects.push_back(test::make_sphere(std::to_string(k++),
                                          {i * (1.0 + 1e-3 * (i + 1)), j * 1.0005, 0}, 0.5, 8, 16));
  auto r = run(test::make_scene(3, objects));
  expect_valid(r);
  // Every object lies inside its own cell and in no other (sampled on its triangles).
  for (ObjectId o = 0; o < r.scene.objects.size(); ++o) {
    const SceneObject& obj = r.scene.objects[o];
    for (size_t t = 0; t < obj.simplices.size(); t += 9) {
      const Simplex& x = obj.simplices[t];
      const Vec3 c = (obj.vertices[x.v[0]] + obj.vertices[x.v[1]] + obj.vertices[x.v[2]]) / 3.0;
      for (ObjectId q = 0; q < r.gvd.cells.size(); ++q) {
        EXPECT_EQ(test::inside_cell(r.gvd.cells[q], c), q == o)
            << "object " << o << " triangle " << t << " vs cell " << q;
      }
    }
  }
  // Side by side neighbours must be adjacent in the dual graph.
  const auto pairs = graph_pairs(r.graph);
  EXPECT_TRUE(pairs.count({0, 1}));
  EXPECT_TRUE(pairs.count({0, 2}));
  EXPECT_TRUE(pairs.count({2, 4}));
}

TEST(ComputeGvd, GearsIn2DWithTinyGaps) {
  auto r = run(test::make_scene(
      2, {test::make_gear2d("g1", {0, 0, 0}, 0.8, 1.0, 12, 0.0),
          test::make_gear2d("g2", {2.0 + 1e-5, 0, 0}, 0.8, 1.0, 12, 3.14159265358979 / 12),
          test::make_rect("frame", {-1.2, -1.2, 0}, {3.2, 1.2, 0})}));
  expect_valid(r);
  EXPECT_EQ(graph_pairs(r.graph),
            (std::set<std::pair<ObjectId, ObjectId>>{{0, 1}, {0, 2}, {1, 2}}));
}

TEST(ComputeGvd, ThePapersWavefrontDistanceGivesAValidGvdToo) {
  const Scene gears = test::make_scene(
      2, {test::make_gear2d("g1", {0, 0, 0}, 0.8, 1.0, 12, 0.0),
          test::make_gear2d("g2", {2.0 + 1e-4, 0, 0}, 0.8, 1.0, 12, 3.14159265358979 / 12)});
  const Scene spheres =
      test::make_scene(3, {test::make_sphere("a", {0, 0, 0}, 0.5, 8, 16),
                           test::make_sphere("b", {1.002, 0, 0}, 0.5, 8, 16),
                           test::make_box("c", {-0.5, 0.6, -0.5}, {1.5, 1, 0.5})});
  for (const Scene* scene : {&gears, &spheres}) {
    SCOPED_TRACE(scene->dimension);
    expect_valid(run(*scene, 0, "exact"));
    const GvdResult w = run(*scene, 0, "wavefront");
    expect_valid(w);  // includes the 3/2 factor at every sampled vertex
    size_t exact = 0;
    for (uint8_t e : w.field.exact) exact += e;
    EXPECT_LT(exact, w.field.size());  // the wavefront did reach vertices
    const GvdResult x = run(*scene, 0, "exact");
    EXPECT_EQ(graph_pairs(w.graph), graph_pairs(x.graph));
  }
}

TEST(ComputeGvd, MirrorImagesWhoseBisectorIsAnOctreePlaneStayOriented) {
  // The default domain is centred on the scene, so the bisector of the two mirrored spheres
  // is the octree's mid plane: every vertex on it is equidistant up to rounding. Near ties
  // must label them alike (GVD_TIE), or the surface folds inside that plane (2.5 % of the
  // 0/1 interface area faced the wrong way before).
  auto r = run(test::make_scene(3, {test::make_sphere("a", {0, 0, 0}, 0.5, 8, 16),
                                    test::make_sphere("b", {1.002, 0, 0}, 0.5, 8, 16),
                                    test::make_box("c", {-0.5, 0.6, -0.5}, {1.5, 1, 0.5})}));
  ASSERT_NEAR(r.domain.to_unit({0.501, 0, 0}).x, 0.5, 1e-12);
  expect_valid(r);
  EXPECT_EQ(graph_pairs(r.graph),
            (std::set<std::pair<ObjectId, ObjectId>>{{0, 1}, {0, 2}, {1, 2}}));
}

// Results do not depend on the unit: three objects drawn at 1, 1e-100 and 1e-300 (whose
// squared lengths underflow) give the same neighbour pairs, gaps and clearances scaled, and
// no triangle is taken for degenerate.
TEST(ComputeGvd, TinyScenesGiveTheScaledAnswers) {
  auto scene_at = [](double k) {
    Scene s = test::make_scene(3, {test::make_sphere("a", {0, 0, 0}, 1, 8, 16),
                                   test::make_box("b", {1.2, -1, -1}, {2.2, 1, 1}),
                                   test::make_sphere("c", {0, 2.5, 0}, 1, 8, 16)});
    for (SceneObject& o : s.objects)
      for (Vec3& v : o.vertices) v = v * k;
    return s;
  };
  const GvdResult unit = run(scene_at(1));
  for (double k : {1e-100, 1e-300}) {
    const GvdResult tiny = run(scene_at(k));
    EXPECT_TRUE(tiny.scene.warnings.empty()) << k << ": " << tiny.scene.warnings[0].detail;
    ASSERT_EQ(graph_pairs(tiny.graph), graph_pairs(unit.graph)) << k;
    for (size_t e = 0; e < unit.graph.edges.size(); ++e) {
      EXPECT_NEAR(tiny.graph.edges[e].gap / k, unit.graph.edges[e].gap,
                  1e-9 * unit.graph.edges[e].gap)
          << k;
      EXPECT_NEAR(tiny.graph.edges[e].min_clearance / k, unit.graph.edges[e].min_clearance,
                  1e-6 * unit.graph.edges[e].min_clearance)
          << k;
    }
  }
}

TEST(ComputeGvd, IntersectingBoxesStayClosed) {
  auto r = run(test::make_scene(3, {test::make_box("a", {0, 0, 0}, {1, 1, 1}),
                                    test::make_box("b", {0.5, 0.5, 0.5}, {1.5, 1.5, 1.5})}),
               6);
  for (const GvdCell& cell : r.gvd.cells) EXPECT_EQ(test::count_open_edges(cell, 3), 0u);
  bool warned = false;
  for (const auto& w : r.scene.warnings) warned |= w.kind == WarningKind::kObjectsTouch;
  EXPECT_TRUE(warned);
}

TEST(ComputeGvd, TouchingObjectsAtTheDefaultDepthStayCheapAndClosed) {
  // Intersecting boxes, and boxes stacked face to face: refining to the depth limit (21)
  // along the contact would need billions of cells; the contact depth bounds it.
  for (int variant = 0; variant < 2; ++variant) {
    std::vector<SceneObject> objects{test::make_box("a", {0, 0, 0}, {1, 1, 1})};
    if (variant == 0) {
      objects.push_back(test::make_box("b", {0.5, 0.5, 0.5}, {1.5, 1.5, 1.5}));
    } else {
      objects.push_back(test::make_box("b", {0, 0, 1}, {1, 1, 2}));
    }
    objects.push_back(test::make_box("c", {1.7, 0, 0}, {2.5, 1, 1}));
    auto r = run(test::make_scene(3, objects));
    EXPECT_LT(r.octree.leaf_count(), 300000u);
    for (const GvdCell& cell : r.gvd.cells) EXPECT_EQ(test::count_open_edges(cell, 3), 0u);
    std::string touching;
    for (const auto& w : r.scene.warnings)
      if (w.kind == WarningKind::kObjectsTouch) touching = w.detail;
    EXPECT_NE(touching.find("a/b"), std::string::npos) << touching;
    EXPECT_EQ(touching.find("/c"), std::string::npos) << touching;
    // c is separate: its cell boundary crosses no object.
    Gvd only_c;
    only_c.dimension = 3;
    only_c.cells.push_back(r.gvd.cells[2]);
    EXPECT_EQ(test::count_gvd_object_crossings(r.scene, only_c), 0u);
  }
}

TEST(ComputeGvd, NonManifoldAndOpenObjects3D) {
  // "bowtie": two boxes sharing only an edge, as one object (non-manifold, two components of
  // faces meeting at the edge); "sheet": a single open quad; "ball" a sphere between them.
  SceneObject bowtie = test::make_box("bowtie", {0, 0, 0}, {1, 1, 1});
  const SceneObject second = test::make_box("x", {1, 1, 0}, {2, 2, 1});
  const uint32_t offset = static_cast<uint32_t>(bowtie.vertices.size());
  for (const Vec3& v : second.vertices) bowtie.vertices.push_back(v);
  for (Simplex t : second.simplices) {
    for (uint32_t& i : t.v) i += offset;
    bowtie.simplices.push_back(t);
  }
  SceneObject sheet;
  sheet.label = "sheet";
  sheet.vertices = {{-0.5, -0.5, 1.3}, {2.5, -0.5, 1.3}, {2.5, 2.5, 1.3}, {-0.5, 2.5, 1.3}};
  sheet.simplices = {{{0, 1, 2}}, {{0, 2, 3}}};
  auto r =
      run(test::make_scene(3, {bowtie, sheet, test::make_sphere("ball", {1.8, 0.2, 0.5}, 0.25)}));
  expect_valid(r);
  std::set<std::string> kinds;
  for (const auto& w : r.scene.warnings) kinds.insert(warning_kind_name(w.kind));
  EXPECT_TRUE(kinds.count("open_mesh"));
  EXPECT_EQ(graph_pairs(r.graph),
            (std::set<std::pair<ObjectId, ObjectId>>{{0, 1}, {0, 2}, {1, 2}}));
}

TEST(ComputeGvd, SingleObjectCellIsTheDomainBox) {
  auto r = run(test::make_scene(3, {test::make_sphere("only", {0, 0, 0}, 1)}));
  expect_valid(r);
  EXPECT_TRUE(r.graph.edges.empty());
  // Closed by the box: 6 faces of the padded cube, area 6 * (2 * 1.1)^2.
  double area = 0;
  const GvdCell& c = r.gvd.cells[0];
  for (size_t s = 0; s < c.indices.size(); s += 3) {
    area += 0.5 * norm(cross(c.positions[c.indices[s + 1]] - c.positions[c.indices[s]],
                             c.positions[c.indices[s + 2]] - c.positions[c.indices[s]]));
  }
  EXPECT_NEAR(area, 6 * 2.2 * 2.2, 1e-9);
}

// Progress moves within the long stages, not only at their ends: the balls on the plate
// (about 150k octree vertices, 10k+ surfaced leaves) report fractions strictly between 0 and 1
// in the octree, distance and surface stages, never decreasing within a stage.
TEST(ComputeGvd, ProgressMovesWithinStages) {
  const std::string path = std::string(GVD_TEST_DATA_DIR) + "/scenes/balls_on_plate.json";
  PipelineOptions o;
  o.threads = 2;
  std::vector<std::pair<std::string, double>> calls;
  o.progress = [&](const std::string& stage, double f) { calls.emplace_back(stage, f); };
  compute_gvd(load_scene(std::span<const std::string>(&path, 1)), o);
  for (const char* stage : {"octree", "distance", "surface"}) {
    double last = -1;
    int inside = 0;
    for (const auto& [s, f] : calls) {
      if (s != stage) continue;
      EXPECT_GE(f, last) << stage;
      last = f;
      inside += f > 0 && f < 1;
    }
    EXPECT_GT(inside, 0) << stage << " reports only its start and end";
  }
  ASSERT_FALSE(calls.empty());
  EXPECT_EQ(calls.back(), (std::pair<std::string, double>{"done", 1.0}));
}

}  // namespace
}  // namespace gvd
