#include "gvd/io/write_outputs.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <numbers>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "gvd/common/error.h"
#include "support/gltf_validate.h"

namespace gvd {

using namespace gvd::scene;
using namespace gvd::surface;
using namespace gvd::graph;
using namespace gvd::io;

namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test::GlbFile;
using test::parse_glb;
using test::read_accessor;
using test::validate_glb_file;

// ---------------------------------------------------------------------------------------------
// Hand-made GVDs.
//
//   3D: object "a" owns the box [0,1]^3, object "b" the box [1,2.5]x[0,1]x[0,1]; they share the
//   plane x = 1, every other face is the domain box. Object "c" has no cell.
//   2D: the same with squares.
// ---------------------------------------------------------------------------------------------

Scene make_scene(int dimension) {
  Scene scene;
  scene.dimension = dimension;
  for (const char* label : {"a", "b", "c"}) {
    SceneObject object;
    object.label = label;
    scene.objects.push_back(object);
  }
  return scene;
}

/// Clearance assigned to a vertex: an arbitrary but known function of the position.
double clearance_at(Vec3 p, ObjectId object) { return object == 0 ? p.y + p.z : 0.5 * (p.y + p.z); }

/// A closed box cell with 4 vertices per face (vertices are duplicated per face, as the GVD
/// duplicates them per object on the other side) and triangle normals pointing inward. The
/// face x = `shared_x` faces `neighbour`, all others the domain box.
GvdCell box_cell(ObjectId object, Vec3 lo, Vec3 hi, double shared_x, ObjectId neighbour) {
  GvdCell cell;
  cell.object = object;
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3;
    const int w = (axis + 2) % 3;
    for (int side = 0; side < 2; ++side) {
      const uint32_t base = static_cast<uint32_t>(cell.positions.size());
      // Corners (u, w) = (0,0) (1,0) (1,1) (0,1) wind around +axis.
      const int corners[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
      const double fixed = side == 0 ? lo[axis] : hi[axis];
      const bool shared = axis == 0 && fixed == shared_x;
      for (const auto& c : corners) {
        Vec3 p;
        p[axis] = fixed;
        p[u] = c[0] == 0 ? lo[u] : hi[u];
        p[w] = c[1] == 0 ? lo[w] : hi[w];
        cell.positions.push_back(p);
        cell.other.push_back(shared ? neighbour : kNoObject);
        cell.clearance.push_back(clearance_at(p, object));
      }
      // Inward normal: +axis on the low side (keep the winding), -axis on the high side.
      const std::array<uint32_t, 6> tris = side == 0 ? std::array<uint32_t, 6>{0, 1, 2, 0, 2, 3}
                                                     : std::array<uint32_t, 6>{0, 2, 1, 0, 3, 2};
      for (uint32_t t : tris) cell.indices.push_back(base + t);
    }
  }
  return cell;
}

Gvd make_gvd_3d() {
  Gvd gvd;
  gvd.dimension = 3;
  gvd.cells.push_back(box_cell(0, {0, 0, 0}, {1, 1, 1}, 1.0, 1));
  gvd.cells.push_back(box_cell(1, {1, 0, 0}, {2.5, 1, 1}, 1.0, 0));
  gvd.cells.emplace_back();  // "c": no cell
  gvd.cells[2].object = 2;
  return gvd;
}

/// A closed square cell, counter-clockwise (the cell on the left of every segment), two
/// vertices per edge; the edge x = `shared_x` faces `neighbour`.
GvdCell square_cell(ObjectId object, Vec3 lo, Vec3 hi, double shared_x, ObjectId neighbour) {
  GvdCell cell;
  cell.object = object;
  const Vec3 ring[4] = {{lo.x, lo.y, 0}, {hi.x, lo.y, 0}, {hi.x, hi.y, 0}, {lo.x, hi.y, 0}};
  for (int e = 0; e < 4; ++e) {
    const Vec3 p = ring[e];
    const Vec3 q = ring[(e + 1) % 4];
    const bool shared = p.x == shared_x && q.x == shared_x;
    for (Vec3 v : {p, q}) {
      cell.indices.push_back(static_cast<uint32_t>(cell.positions.size()));
      cell.positions.push_back(v);
      cell.other.push_back(shared ? neighbour : kNoObject);
      cell.clearance.push_back(clearance_at(v, object));
    }
  }
  return cell;
}

Gvd make_gvd_2d() {
  Gvd gvd;
  gvd.dimension = 2;
  gvd.cells.push_back(square_cell(0, {0, 0, 0}, {1, 1, 0}, 1.0, 1));
  gvd.cells.push_back(square_cell(1, {1, 0, 0}, {2.5, 1, 0}, 1.0, 0));
  gvd.cells.emplace_back();
  gvd.cells[2].object = 2;
  return gvd;
}

double max_clearance(const Gvd& gvd) {
  double m = 0;
  for (const GvdCell& cell : gvd.cells)
    for (double c : cell.clearance) m = std::max(m, c);
  return m;
}

std::string output_path(const std::string& name) {
  const fs::path dir = fs::path(GVD_TEST_OUTPUT_DIR) / "io";
  fs::create_directories(dir);
  return (dir / name).string();
}

/// Writes the GLB to the test output directory and asserts that the Khronos validator finds
/// no error in it.
void expect_valid_glb(const std::vector<uint8_t>& bytes, const std::string& name) {
  const std::string path = output_path(name);
  write_file_atomic(path, bytes.data(), bytes.size());
  const test::GltfReport report = validate_glb_file(path);
  ASSERT_TRUE(report.ran) << report.output;
  EXPECT_EQ(report.errors, 0) << report.output;
  if (report.warnings > 0)
    std::printf("validator warnings on %s: %s\n", path.c_str(), report.output.c_str());
}

/// Checks the node and primitive written for `cell` against the cell itself.
void expect_cell_matches(const GlbFile& glb, const json& node, const GvdCell& cell,
                         const Scene& scene, int dimension, double max_clear) {
  const std::string& label = scene.objects[cell.object].label;
  EXPECT_EQ(node.at("name"), label);
  EXPECT_EQ(node.at("extras"), (json{{"label", label}, {"object", cell.object}}));

  const json& mesh = glb.json.at("meshes").at(node.at("mesh").get<size_t>());
  ASSERT_EQ(mesh.at("primitives").size(), 1u);
  const json& primitive = mesh.at("primitives")[0];
  EXPECT_EQ(primitive.at("mode"), dimension == 2 ? 1 : 4);
  const json& attributes = primitive.at("attributes");
  const size_t n = cell.positions.size();
  const auto null_feature_id = static_cast<double>(scene.objects.size());

  // POSITION: float32 VEC3, min/max = bounds of the stored floats, z = 0 in 2D.
  const json& position_accessor =
      glb.json.at("accessors").at(attributes.at("POSITION").get<size_t>());
  EXPECT_EQ(position_accessor.at("componentType"), 5126);
  EXPECT_EQ(position_accessor.at("type"), "VEC3");
  const std::vector<double> positions = read_accessor(glb, attributes.at("POSITION"));
  ASSERT_EQ(positions.size(), 3 * n);
  std::array<double, 3> lo = {1e300, 1e300, 1e300};
  std::array<double, 3> hi = {-1e300, -1e300, -1e300};
  for (size_t v = 0; v < n; ++v) {
    for (int c = 0; c < 3; ++c) {
      const double expected = dimension == 2 && c == 2 ? 0.0 : cell.positions[v][c];
      EXPECT_EQ(positions[3 * v + c], static_cast<float>(expected)) << "vertex " << v;
      lo[c] = std::min(lo[c], expected);
      hi[c] = std::max(hi[c], expected);
    }
  }
  for (int c = 0; c < 3; ++c) {
    EXPECT_EQ(position_accessor.at("min")[c].get<double>(), lo[c]);
    EXPECT_EQ(position_accessor.at("max")[c].get<double>(), hi[c]);
  }

  // _FEATURE_ID_0 = the cell's `other`, the domain box as the null feature id.
  const std::vector<double> features = read_accessor(glb, attributes.at("_FEATURE_ID_0"));
  ASSERT_EQ(features.size(), n);
  std::set<double> distinct;
  for (size_t v = 0; v < n; ++v) {
    const double expected =
        cell.other[v] == kNoObject ? null_feature_id : static_cast<double>(cell.other[v]);
    EXPECT_EQ(features[v], expected) << "vertex " << v;
    if (cell.other[v] != kNoObject) distinct.insert(expected);
  }
  const json& feature_ids = primitive.at("extensions").at("EXT_mesh_features").at("featureIds");
  ASSERT_EQ(feature_ids.size(), 1u);
  EXPECT_EQ(feature_ids[0].at("attribute"), 0);
  EXPECT_EQ(feature_ids[0].at("nullFeatureId"), scene.objects.size());
  EXPECT_EQ(feature_ids[0].at("featureCount"), std::max<size_t>(1, distinct.size()));

  // _CLEARANCE and the COLOR_0 ramp: grey on the box, red at 0, blue at the largest clearance.
  const std::vector<double> clearance = read_accessor(glb, attributes.at("_CLEARANCE"));
  const std::vector<double> colors = read_accessor(glb, attributes.at("COLOR_0"));
  ASSERT_EQ(clearance.size(), n);
  ASSERT_EQ(colors.size(), 3 * n);
  for (size_t v = 0; v < n; ++v) {
    EXPECT_EQ(clearance[v], static_cast<float>(cell.clearance[v]));
    const std::array<double, 3> rgb = {colors[3 * v], colors[3 * v + 1], colors[3 * v + 2]};
    for (double channel : rgb) {
      EXPECT_GE(channel, 0.0);
      EXPECT_LE(channel, 1.0);
    }
    if (cell.other[v] == kNoObject) {
      EXPECT_EQ(rgb, (std::array<double, 3>{0.5, 0.5, 0.5}));
    } else if (cell.clearance[v] == 0) {
      EXPECT_EQ(rgb, (std::array<double, 3>{1, 0, 0}));
    } else if (cell.clearance[v] == max_clear) {
      EXPECT_EQ(rgb, (std::array<double, 3>{0, 0, 1}));
    } else if (cell.clearance[v] == max_clear / 2) {
      EXPECT_EQ(rgb, (std::array<double, 3>{0.5, 1, 0}));  // between yellow and green
    }
  }

  // Indices: the cell's own, in order (which preserves the winding).
  const json& index_accessor = glb.json.at("accessors").at(primitive.at("indices").get<size_t>());
  EXPECT_EQ(index_accessor.at("componentType"), n <= 65535 ? 5123 : 5125);
  const std::vector<double> indices = read_accessor(glb, primitive.at("indices"));
  ASSERT_EQ(indices.size(), cell.indices.size());
  for (size_t i = 0; i < indices.size(); ++i) EXPECT_EQ(indices[i], cell.indices[i]);

  // Buffer views: 4-byte aligned, with a target.
  for (const char* attribute : {"POSITION", "_FEATURE_ID_0", "_CLEARANCE", "COLOR_0"}) {
    const json& accessor = glb.json.at("accessors").at(attributes.at(attribute).get<size_t>());
    const json& view = glb.json.at("bufferViews").at(accessor.at("bufferView").get<size_t>());
    EXPECT_EQ(view.value("byteOffset", 0) % 4, 0) << attribute;
    EXPECT_EQ(view.at("target"), 34962) << attribute;
  }
  const json& index_view =
      glb.json.at("bufferViews").at(index_accessor.at("bufferView").get<size_t>());
  EXPECT_EQ(index_view.value("byteOffset", 0) % 4, 0);
  EXPECT_EQ(index_view.at("target"), 34963);
}

/// Checks the document-level structure and every node of a written GVD.
void expect_glb_matches(const std::vector<uint8_t>& bytes, const Gvd& gvd, const Scene& scene) {
  const GlbFile glb = parse_glb(bytes);
  EXPECT_EQ(glb.json.at("asset").at("version"), "2.0");
  EXPECT_EQ(glb.json.at("asset").at("generator"), "gvd");
  EXPECT_FALSE(glb.json.contains("extensionsRequired"));
  EXPECT_EQ(glb.json.at("extensionsUsed"), json::array({"EXT_mesh_features"}));
  ASSERT_EQ(glb.json.at("buffers").size(), 1u);
  EXPECT_FALSE(glb.json.at("buffers")[0].contains("uri"));
  EXPECT_LE(glb.json.at("buffers")[0].at("byteLength").get<size_t>(), glb.bin.size());

  std::vector<const GvdCell*> non_empty;
  for (const GvdCell& cell : gvd.cells)
    if (!cell.indices.empty()) non_empty.push_back(&cell);
  const json& nodes = glb.json.at("nodes");
  ASSERT_EQ(nodes.size(), non_empty.size());
  const json& default_scene = glb.json.at("scenes").at(glb.json.at("scene").get<size_t>());
  ASSERT_EQ(default_scene.at("nodes").size(), nodes.size());
  std::set<size_t> in_scene;
  for (const json& n : default_scene.at("nodes")) in_scene.insert(n.get<size_t>());
  EXPECT_EQ(in_scene.size(), nodes.size());

  const double max_clear = max_clearance(gvd);
  for (size_t k = 0; k < nodes.size(); ++k) {
    SCOPED_TRACE("node " + std::to_string(k));
    const size_t object = nodes[k].at("extras").at("object").get<size_t>();
    ASSERT_LT(object, gvd.cells.size());
    expect_cell_matches(glb, nodes[k], gvd.cells[object], scene, gvd.dimension, max_clear);
  }
}

TEST(WriteGlbTest, BoxCells3dRoundTrip) {
  const Gvd gvd = make_gvd_3d();
  const Scene scene = make_scene(3);
  const std::vector<uint8_t> bytes = gvd_to_glb(gvd, scene);
  expect_glb_matches(bytes, gvd, scene);

  // Counts and bounds spelled out once, independently of the cells.
  const GlbFile glb = parse_glb(bytes);
  const json& nodes = glb.json.at("nodes");
  ASSERT_EQ(nodes.size(), 2u);
  EXPECT_EQ(nodes[0].at("name"), "a");
  EXPECT_EQ(nodes[1].at("name"), "b");
  const json& primitive =
      glb.json.at("meshes").at(nodes[1].at("mesh").get<size_t>())["primitives"][0];
  const json& position =
      glb.json.at("accessors").at(primitive["attributes"]["POSITION"].get<size_t>());
  EXPECT_EQ(position.at("count"), 24);
  EXPECT_EQ(position.at("min"), json::array({1.0, 0.0, 0.0}));
  EXPECT_EQ(position.at("max"), json::array({2.5, 1.0, 1.0}));
  EXPECT_EQ(glb.json.at("accessors").at(primitive["indices"].get<size_t>()).at("count"), 36);
}

TEST(WriteGlbTest, TrianglesKeepInwardNormals) {
  const Gvd gvd = make_gvd_3d();
  const GlbFile glb = parse_glb(gvd_to_glb(gvd, make_scene(3)));
  for (const json& node : glb.json.at("nodes")) {
    const json& primitive =
        glb.json.at("meshes").at(node.at("mesh").get<size_t>())["primitives"][0];
    const std::vector<double> p = read_accessor(glb, primitive["attributes"]["POSITION"]);
    const std::vector<double> idx = read_accessor(glb, primitive["indices"]);
    const json& accessor =
        glb.json.at("accessors").at(primitive["attributes"]["POSITION"].get<size_t>());
    Vec3 center;
    for (int c = 0; c < 3; ++c)
      center[c] = 0.5 * (accessor["min"][c].get<double>() + accessor["max"][c].get<double>());
    for (size_t t = 0; t < idx.size(); t += 3) {
      Vec3 v[3];
      for (int k = 0; k < 3; ++k) {
        const auto i = static_cast<size_t>(idx[t + k]);
        v[k] = {p[3 * i], p[3 * i + 1], p[3 * i + 2]};
      }
      const Vec3 normal = cross(v[1] - v[0], v[2] - v[0]);
      EXPECT_GT(dot(normal, center - v[0]), 0) << "triangle " << t / 3 << " of " << node["name"];
    }
  }
}

TEST(WriteGlbTest, BoxCells3dPassValidator) {
  expect_valid_glb(gvd_to_glb(make_gvd_3d(), make_scene(3)), "boxes_3d.glb");
}

TEST(WriteGlbTest, Squares2dAsLines) {
  const Gvd gvd = make_gvd_2d();
  const Scene scene = make_scene(2);
  const std::vector<uint8_t> bytes = gvd_to_glb(gvd, scene);
  expect_glb_matches(bytes, gvd, scene);
  const GlbFile glb = parse_glb(bytes);
  const json& primitive = glb.json.at("meshes")[0]["primitives"][0];
  EXPECT_EQ(primitive.at("mode"), 1);
  const json& position =
      glb.json.at("accessors").at(primitive["attributes"]["POSITION"].get<size_t>());
  EXPECT_EQ(position.at("count"), 8);
  EXPECT_EQ(position.at("min"), json::array({0.0, 0.0, 0.0}));
  EXPECT_EQ(position.at("max"), json::array({1.0, 1.0, 0.0}));
  expect_valid_glb(bytes, "squares_2d.glb");
}

TEST(WriteGlbTest, AllBoxCellHasFeatureCountOne) {
  // A cell that touches only the domain box: no non-null feature id, featureCount stays 1.
  Gvd gvd;
  gvd.dimension = 3;
  gvd.cells.push_back(box_cell(0, {0, 0, 0}, {1, 1, 1}, -1.0, kNoObject));
  Scene scene = make_scene(3);
  scene.objects.resize(1);
  const std::vector<uint8_t> bytes = gvd_to_glb(gvd, scene);
  expect_glb_matches(bytes, gvd, scene);
  expect_valid_glb(bytes, "single_box_3d.glb");
}

TEST(WriteGlbTest, LargeCellUsesUint32Indices) {
  // A 2D ring of 70000 segments: more vertices than uint16 indices can address.
  constexpr uint32_t kSegments = 70000;
  Gvd gvd;
  gvd.dimension = 2;
  GvdCell cell;
  cell.object = 0;
  for (uint32_t s = 0; s < kSegments; ++s) {
    const double angle = 2 * std::numbers::pi * s / kSegments;
    cell.positions.push_back({std::cos(angle), std::sin(angle), 0});
    cell.other.push_back(s % 2 == 0 ? 1 : kNoObject);
    cell.clearance.push_back(0.25);
    cell.indices.push_back(s);
    cell.indices.push_back((s + 1) % kSegments);
  }
  gvd.cells.push_back(cell);
  const Scene scene = make_scene(2);
  const std::vector<uint8_t> bytes = gvd_to_glb(gvd, scene);
  expect_glb_matches(bytes, gvd, scene);
  expect_valid_glb(bytes, "ring_2d.glb");
}

TEST(WriteGlbTest, FileInTwoPartsIsTheGlb) {
  // The CLI writes head and bin one after the other; the server takes gvd_to_glb's bytes.
  // Both must be one valid file: the header's total length counts both parts, and the
  // buffer's byteLength (set after tinygltf wrote the JSON without the data) is the data's.
  for (int dimension : {2, 3}) {
    const Gvd gvd = dimension == 3 ? make_gvd_3d() : make_gvd_2d();
    const Scene scene = make_scene(dimension);
    const gvd::io::GlbFile parts = gvd_glb_file(gvd, scene);
    std::vector<uint8_t> joined = parts.head;
    joined.insert(joined.end(), parts.bin.begin(), parts.bin.end());
    EXPECT_EQ(joined, gvd_to_glb(gvd, scene));
    uint32_t total = 0;
    std::memcpy(&total, joined.data() + 8, 4);
    EXPECT_EQ(total, joined.size());
    EXPECT_EQ(parts.bin.size() % 4, 0u);
    const GlbFile glb = parse_glb(joined);
    EXPECT_EQ((glb.json.at("buffers")[0].at("byteLength").get<size_t>() + 3) / 4 * 4,
              parts.bin.size());
    expect_glb_matches(joined, gvd, scene);
    expect_valid_glb(joined, dimension == 3 ? "two_parts_3d.glb" : "two_parts_2d.glb");
  }
}

TEST(WriteGlbTest, EmptyGvdIsValidGlb) {
  Gvd gvd;
  gvd.dimension = 3;
  gvd.cells.resize(3);
  for (ObjectId i = 0; i < 3; ++i) gvd.cells[i].object = i;
  const std::vector<uint8_t> bytes = gvd_to_glb(gvd, make_scene(3));
  const GlbFile glb = parse_glb(bytes);
  EXPECT_EQ(glb.json.at("asset").at("generator"), "gvd");
  ASSERT_EQ(glb.json.at("scenes").size(), 1u);
  EXPECT_TRUE(glb.json.at("scenes")[0].is_object());
  EXPECT_FALSE(glb.json.at("scenes")[0].contains("nodes"));
  EXPECT_FALSE(glb.json.contains("nodes"));
  expect_valid_glb(bytes, "empty.glb");

  Gvd no_cells;
  expect_valid_glb(gvd_to_glb(no_cells, make_scene(3)), "no_cells.glb");
}

TEST(WriteGlbTest, InconsistentCellIsInternalError) {
  Gvd gvd = make_gvd_3d();
  gvd.cells[0].indices.push_back(1000);  // out of range, and no longer whole triangles
  EXPECT_THROW(gvd_to_glb(gvd, make_scene(3)), InternalError);
}

// ---------------------------------------------------------------------------------------------
// JSON outputs.
// ---------------------------------------------------------------------------------------------

TEST(GvdJsonTest, Float64ValuesRoundTripExactly) {
  Gvd gvd = make_gvd_3d();
  // Coordinates that float32 cannot hold: 1/3 and a gap of 1e-12.
  gvd.cells[0].positions[0] = {1.0 / 3.0, 1e-12, 0.1};
  gvd.cells[0].clearance[0] = 1.0 / 7.0;
  const Scene scene = make_scene(3);
  const json doc = json::parse(gvd_to_json(gvd, scene));
  EXPECT_EQ(doc.at("dimension"), 3);
  EXPECT_EQ(doc.at("null_feature_id"), 3);
  ASSERT_EQ(doc.at("objects").size(), 2u);  // "c" has no cell
  for (const json& object : doc.at("objects")) {
    const size_t i = object.at("object").get<size_t>();
    const GvdCell& cell = gvd.cells.at(i);
    EXPECT_EQ(object.at("label"), scene.objects[i].label);
    ASSERT_EQ(object.at("positions").size(), cell.positions.size());
    for (size_t v = 0; v < cell.positions.size(); ++v) {
      const json& p = object["positions"][v];
      ASSERT_EQ(p.size(), 3u);
      for (int c = 0; c < 3; ++c) EXPECT_EQ(p[c].get<double>(), cell.positions[v][c]);
      const int64_t other = cell.other[v] == kNoObject ? -1 : int64_t{cell.other[v]};
      EXPECT_EQ(object["other"][v].get<int64_t>(), other);
      EXPECT_EQ(object["clearance"][v].get<double>(), cell.clearance[v]);
    }
    ASSERT_EQ(object.at("simplices").size(), cell.indices.size() / 3);
    for (size_t s = 0; s < cell.indices.size() / 3; ++s)
      for (size_t k = 0; k < 3; ++k)
        EXPECT_EQ(object["simplices"][s][k].get<uint32_t>(), cell.indices[3 * s + k]);
  }
  EXPECT_EQ(doc["objects"][0]["positions"][0][0].get<double>(), 1.0 / 3.0);
  EXPECT_EQ(doc["objects"][0]["positions"][0][1].get<double>(), 1e-12);
}

TEST(GvdJsonTest, LargeCellsRoundTripAcrossTheWritersBlocks) {
  // The writer dumps arrays in blocks of elements: a cell of 10,001 vertices and 5,000
  // triangles crosses block boundaries in every array.
  constexpr uint32_t kVertices = 10001;
  Gvd gvd = make_gvd_3d();
  GvdCell& cell = gvd.cells[1];
  cell.positions.clear();
  cell.other.clear();
  cell.clearance.clear();
  cell.indices.clear();
  for (uint32_t v = 0; v < kVertices; ++v) {
    cell.positions.push_back({v / 3.0, 1.0 / (v + 1), -v * 1e-9});
    cell.other.push_back(v % 3 == 0 ? kNoObject : 0);
    cell.clearance.push_back(v * 0.125 + 1.0 / 7.0);
  }
  for (uint32_t t = 0; t < 5000; ++t)
    for (uint32_t k = 0; k < 3; ++k) cell.indices.push_back((t * 7 + k * 13) % kVertices);
  const Scene scene = make_scene(3);
  std::string pieces;
  size_t calls = 0;
  write_gvd_json(gvd, scene, [&](std::string_view s) {
    pieces.append(s);
    ++calls;
  });
  EXPECT_EQ(pieces, gvd_to_json(gvd, scene));
  EXPECT_GT(calls, 10u);  // handed over in pieces, not as one text
  const json doc = json::parse(pieces);
  ASSERT_EQ(doc.at("objects").size(), 2u);
  const json& object = doc["objects"][1];
  EXPECT_EQ(object.at("object"), 1);
  ASSERT_EQ(object.at("positions").size(), kVertices);
  ASSERT_EQ(object.at("other").size(), kVertices);
  ASSERT_EQ(object.at("clearance").size(), kVertices);
  for (uint32_t v = 0; v < kVertices; ++v) {
    for (int c = 0; c < 3; ++c)
      ASSERT_EQ(object["positions"][v][c].get<double>(), cell.positions[v][c]) << v;
    ASSERT_EQ(object["other"][v].get<int64_t>(), cell.other[v] == kNoObject ? -1 : 0) << v;
    ASSERT_EQ(object["clearance"][v].get<double>(), cell.clearance[v]) << v;
  }
  ASSERT_EQ(object.at("simplices").size(), 5000u);
  for (size_t t = 0; t < 5000; ++t)
    for (size_t k = 0; k < 3; ++k)
      ASSERT_EQ(object["simplices"][t][k].get<uint32_t>(), cell.indices[3 * t + k]);
}

TEST(GvdJsonTest, TwoDimensionalHasTwoCoordinatesAndSegments) {
  const Gvd gvd = make_gvd_2d();
  const json doc = json::parse(gvd_to_json(gvd, make_scene(2)));
  EXPECT_EQ(doc.at("dimension"), 2);
  ASSERT_EQ(doc.at("objects").size(), 2u);
  const json& a = doc["objects"][0];
  EXPECT_EQ(a.at("object"), 0);
  EXPECT_EQ(a.at("label"), "a");
  ASSERT_EQ(a.at("positions").size(), 8u);
  for (const json& p : a["positions"]) EXPECT_EQ(p.size(), 2u);
  EXPECT_EQ(a["positions"][1], json::array({1.0, 0.0}));
  ASSERT_EQ(a.at("simplices").size(), 4u);
  for (const json& s : a["simplices"]) EXPECT_EQ(s.size(), 2u);
  // Edge 1 (x = 1) faces "b", the rest the domain box.
  EXPECT_EQ(a.at("other"), json::array({-1, -1, 1, 1, -1, -1, -1, -1}));
}

TEST(GvdJsonTest, EmptyGvdHasNoObjects) {
  Gvd gvd;
  gvd.dimension = 2;
  const json doc = json::parse(gvd_to_json(gvd, make_scene(2)));
  EXPECT_EQ(doc.at("objects"), json::array());
  EXPECT_EQ(doc.at("null_feature_id"), 3);
}

TEST(GraphJsonTest, NodesAndEdgesRoundTrip) {
  DualGraph graph;
  graph.node_count = 3;
  graph.edges.push_back({0, 1, 1.0 / 3.0, 0.1, {1.0, 0.5, 1.0 / 7.0}});
  graph.edges.push_back({1, 2, 2.5, 1e-13, {2.0, 0.25, 0.75}});
  const json doc = json::parse(graph_to_json(graph, make_scene(3)));
  EXPECT_EQ(doc.at("nodes"), json::parse(R"([{"object":0,"label":"a"},{"object":1,"label":"b"},
                                              {"object":2,"label":"c"}])"));
  ASSERT_EQ(doc.at("edges").size(), 2u);
  const json& e = doc["edges"][0];
  EXPECT_EQ(e.at("a"), 0);
  EXPECT_EQ(e.at("b"), 1);
  EXPECT_EQ(e.at("label_a"), "a");
  EXPECT_EQ(e.at("label_b"), "b");
  EXPECT_EQ(e.at("area").get<double>(), 1.0 / 3.0);
  EXPECT_EQ(e.at("min_clearance").get<double>(), 0.1);
  EXPECT_EQ(e.at("tightest_point"), json::array({1.0, 0.5, 1.0 / 7.0}));
  EXPECT_EQ(doc["edges"][1].at("min_clearance").get<double>(), 1e-13);
  EXPECT_EQ(doc["edges"][1].at("label_b"), "c");
}

TEST(GraphJsonTest, TwoDimensionalTightestPointHasTwoCoordinates) {
  DualGraph graph;
  graph.node_count = 3;
  graph.edges.push_back({0, 1, 1.0, 0.5, {1.0, 0.5, 0.0}});
  const json doc = json::parse(graph_to_json(graph, make_scene(2)));
  EXPECT_EQ(doc["edges"][0].at("tightest_point"), json::array({1.0, 0.5}));
}

TEST(GraphJsonTest, NoEdges) {
  const json doc = json::parse(graph_to_json(DualGraph{}, make_scene(3)));
  EXPECT_EQ(doc.at("nodes").size(), 3u);
  EXPECT_EQ(doc.at("edges"), json::array());
}

// ---------------------------------------------------------------------------------------------
// Units: the scene's length unit at the top of every document (the GLB's asset extras), and
// nothing at all when the scene declares none.
// ---------------------------------------------------------------------------------------------

TEST(UnitsTest, EveryWrittenDocumentSaysTheScenesUnits) {
  Scene scene = make_scene(3);
  scene.units = "mm";
  const Gvd gvd = make_gvd_3d();
  DualGraph graph;
  graph.node_count = 3;
  graph.edges.push_back({0, 1, 1.0, 0.5, {1.0, 0.5, 0.5}});

  const std::vector<uint8_t> glb = gvd_to_glb(gvd, scene);
  EXPECT_EQ(parse_glb(glb).json.at("asset").at("extras"), json({{"units", "mm"}}));
  expect_valid_glb(glb, "units.glb");
  EXPECT_EQ(json::parse(gvd_to_json(gvd, scene)).at("units"), "mm");
  EXPECT_EQ(json::parse(graph_to_json(graph, scene)).at("units"), "mm");

  scene.units.clear();  // none declared: none written, not a default
  EXPECT_FALSE(parse_glb(gvd_to_glb(gvd, scene)).json.at("asset").contains("extras"));
  EXPECT_FALSE(json::parse(gvd_to_json(gvd, scene)).contains("units"));
  EXPECT_FALSE(json::parse(graph_to_json(graph, scene)).contains("units"));
}

// ---------------------------------------------------------------------------------------------
// Files.
// ---------------------------------------------------------------------------------------------

fs::path fresh_dir(const std::string& name) {
  const fs::path dir = fs::path(GVD_TEST_OUTPUT_DIR) / "io" / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::vector<std::string> entries(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir)) names.push_back(entry.path().filename());
  std::sort(names.begin(), names.end());
  return names;
}

TEST(AtomicWriteTest, WritesCompleteFileAndLeavesNoTemporary) {
  const fs::path dir = fresh_dir("atomic");
  const std::string path = (dir / "out.bin").string();
  std::vector<uint8_t> big(3 << 20);
  for (size_t i = 0; i < big.size(); ++i) big[i] = static_cast<uint8_t>(i * 2654435761u >> 24);
  write_file_atomic(path, big.data(), big.size());
  EXPECT_EQ(read_file_bytes(path), big);
  EXPECT_EQ(entries(dir), std::vector<std::string>{"out.bin"});

  // Replacing with shorter content leaves exactly the new content.
  write_file_atomic(path, std::string("short"));
  const std::vector<uint8_t> expected = {'s', 'h', 'o', 'r', 't'};
  EXPECT_EQ(read_file_bytes(path), expected);
  EXPECT_EQ(entries(dir), std::vector<std::string>{"out.bin"});

  write_file_atomic(path, std::string());
  EXPECT_TRUE(read_file_bytes(path).empty());
  EXPECT_EQ(entries(dir), std::vector<std::string>{"out.bin"});
}

TEST(AtomicWriteTest, PiecesMakeOneFileAndAFailedProducerLeavesTheOldOne) {
  const fs::path dir = fresh_dir("atomic_pieces");
  const std::string path = (dir / "out.bin").string();
  // Small pieces (gathered) and pieces over the 1 MiB buffer (written as they are).
  std::string expected;
  write_file_atomic(path, [&](const std::function<void(std::string_view)>& put) {
    for (size_t i = 0; i < 300; ++i) {
      const size_t size = i % 50 == 7 ? (size_t{1} << 20) + i : i % 13;
      const std::string piece(size, static_cast<char>('a' + i % 26));
      expected += piece;
      put(piece);
    }
  });
  const std::vector<uint8_t> bytes = read_file_bytes(path);
  EXPECT_EQ(std::string(bytes.begin(), bytes.end()), expected);
  EXPECT_EQ(entries(dir), std::vector<std::string>{"out.bin"});

  // A producer that throws half way: the error comes through, the old file stays whole and
  // no temporary is left.
  EXPECT_THROW(write_file_atomic(path,
                                 [&](const std::function<void(std::string_view)>& put) {
                                   put(std::string(3 << 20, 'x'));
                                   throw Error(ErrorCode::kInternal, "the producer failed");
                                 }),
               Error);
  EXPECT_EQ(read_file_bytes(path), bytes);
  EXPECT_EQ(entries(dir), std::vector<std::string>{"out.bin"});
}

TEST(AtomicWriteTest, MissingDirectoryIsIoErrorNamingPath) {
  const fs::path dir = fresh_dir("atomic_missing");
  const std::string path = (dir / "no" / "such" / "out.json").string();
  try {
    write_file_atomic(path, std::string("{}"));
    FAIL() << "expected gvd::Error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kIo);
    EXPECT_NE(e.detail().find(path), std::string::npos) << e.detail();
    EXPECT_NE(e.detail().find("No such file or directory"), std::string::npos) << e.detail();
  }
  EXPECT_TRUE(entries(dir).empty());
}

TEST(AtomicWriteTest, TargetIsDirectoryIsIoErrorAndCleansUp) {
  const fs::path dir = fresh_dir("atomic_onto_dir");
  fs::create_directories(dir / "taken");
  const std::string path = (dir / "taken").string();
  try {
    write_file_atomic(path, std::string("x"));
    FAIL() << "expected gvd::Error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kIo);
    EXPECT_NE(e.detail().find(path), std::string::npos) << e.detail();
  }
  EXPECT_EQ(entries(dir), std::vector<std::string>{"taken"});  // the temporary is gone
}

TEST(ReadFileIoTest, MissingFileNamesPath) {
  const std::string path = (fresh_dir("read") / "absent.glb").string();
  try {
    read_file_bytes(path);
    FAIL() << "expected gvd::Error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kIo);
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

TEST(ReadFileIoTest, DirectoryIsIoError) {
  const std::string path = fresh_dir("read_dir").string();
  try {
    read_file_bytes(path);
    FAIL() << "expected gvd::Error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kIo);
    EXPECT_NE(e.detail().find(path), std::string::npos) << e.detail();
  }
}

}  // namespace
}  // namespace gvd
