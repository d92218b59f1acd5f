// parse_scene_bytes / load_scene on the fixtures of tests/data/formats and the malformed corpus
// of tests/data/malformed (expected.json lists the code and a detail fragment per file).
#include "gvd/scene/load_scene.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "gvd/common/error.h"

namespace gvd {

using namespace gvd::scene;

namespace {

const std::string kData = GVD_TEST_DATA_DIR;

std::vector<uint8_t> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  EXPECT_TRUE(in) << path;
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::vector<uint8_t> bytes_of(const std::string& text) { return {text.begin(), text.end()}; }

Scene parse_file(const std::string& relative, SceneFormat format = SceneFormat::kAuto) {
  const std::string path = kData + "/" + relative;
  return parse_scene_bytes(read_bytes(path), format, std::filesystem::path(path).stem().string());
}

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

const SceneWarning* find_warning(const Scene& s, const std::string& kind) {
  for (const SceneWarning& w : s.warnings) {
    if (warning_kind_name(w.kind) == kind) return &w;
  }
  return nullptr;
}

void expect_closed_cube(const SceneObject& o) {
  EXPECT_EQ(o.vertices.size(), 8u);
  EXPECT_EQ(o.simplices.size(), 12u);
}

// ---------------------------------------------------------------------------------- OBJ

TEST(ObjLoad, GroupsBecomeObjects) {
  const Scene s = parse_file("formats/groups.obj");
  EXPECT_EQ(s.dimension, 3);
  ASSERT_EQ(s.objects.size(), 2u);
  EXPECT_EQ(s.objects[0].label, "tet");  // `o tet_object` renamed by the `g tet` right after
  EXPECT_EQ(s.objects[0].vertices.size(), 4u);
  EXPECT_EQ(s.objects[0].simplices.size(), 4u);
  EXPECT_EQ(s.objects[1].label, "cube");
  expect_closed_cube(s.objects[1]);
  EXPECT_EQ(s.objects[1].vertices[0], (Vec3{3, 0, 0}));  // re-indexed: only used vertices
  EXPECT_TRUE(s.warnings.empty()) << s.warnings.front().detail;
}

TEST(ObjLoad, FacesBeforeAnyGroupAreNamedAfterTheFile) {
  const Scene s = parse_file("formats/loose_faces.obj");
  ASSERT_EQ(s.objects.size(), 2u);
  EXPECT_EQ(s.objects[0].label, "loose_faces");
  EXPECT_EQ(s.objects[0].simplices.size(), 4u);
  EXPECT_EQ(s.objects[1].label, "other");
  EXPECT_EQ(s.objects[1].vertices.size(), 3u);
  ASSERT_NE(find_warning(s, "open_mesh"), nullptr);
  EXPECT_EQ(find_warning(s, "open_mesh")->object, "other");
}

TEST(ObjLoad, ReopenedGroupAppends) {
  const Scene s = parse_scene_bytes(
      bytes_of("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\ng a\nf 1 3 2\ng b\nf 1 2 4\ng a\nf 2 3 4\n"),
      SceneFormat::kObj, "x");
  ASSERT_EQ(s.objects.size(), 2u);
  EXPECT_EQ(s.objects[0].simplices.size(), 2u);
}

TEST(ObjLoad, NoFacesIsAnError) {
  expect_error(
      [] { parse_scene_bytes(bytes_of("v 0 0 0\nv 1 0 0\nl 1 2\n"), SceneFormat::kObj, "lines"); },
      ErrorCode::kInvalidScene, "no faces");
}

TEST(ObjLoad, BadIndexNamesTheLine) {
  expect_error(
      [] {
        parse_scene_bytes(bytes_of("v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 3\nf 1 2 4\n"),
                          SceneFormat::kObj, "bad");
      },
      ErrorCode::kInvalidScene, "line 6");
  expect_error(
      [] { parse_scene_bytes(bytes_of("v 0 0 0\nf -1 -2 -3\n"), SceneFormat::kObj, "bad"); },
      ErrorCode::kInvalidScene, "line 2");
}

// The line is a field of the error too (problem documents and Python copy it), for each text
// format, and not set where there is no line.
TEST(MeshLoad, TextFormatErrorsCarryTheirLine) {
  const auto line_of = [](const std::string& text, SceneFormat format) -> int64_t {
    try {
      parse_scene_bytes(bytes_of(text), format, "bad");
    } catch (const Error& e) {
      return e.where().line;
    }
    return -2;  // no error
  };
  EXPECT_EQ(line_of("v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 3\nf 1 2 4\n", SceneFormat::kObj), 6);
  EXPECT_EQ(line_of("v 0 0 0\nv 1 x 0\n", SceneFormat::kObj), 2);
  EXPECT_EQ(line_of("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nbogus\n",
                    SceneFormat::kPly),
            5);
  EXPECT_EQ(line_of("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 q\n3 0 1 2\n", SceneFormat::kOff), 5);
  EXPECT_EQ(line_of("solid s\nfacet normal 0 0 1\nouter loop\nouter loop\n", SceneFormat::kStl), 4);
  EXPECT_EQ(line_of("v 0 0 0\n", SceneFormat::kObj), -1);  // "no faces": no line to name
}

// ---------------------------------------------------------------------------------- PLY

TEST(PlyLoad, AsciiWithExtraPropertiesAndElements) {
  const Scene s = parse_file("formats/tetra_ascii.ply");
  ASSERT_EQ(s.objects.size(), 1u);
  EXPECT_EQ(s.objects[0].label, "tetra_ascii");
  EXPECT_EQ(s.objects[0].vertices.size(), 4u);
  EXPECT_EQ(s.objects[0].simplices.size(), 4u);
  EXPECT_TRUE(s.warnings.empty());
}

TEST(PlyLoad, BinaryLittleEndian) {
  const Scene s = parse_file("formats/cube_binary_le.ply");
  ASSERT_EQ(s.objects.size(), 1u);
  expect_closed_cube(s.objects[0]);
  EXPECT_EQ(s.objects[0].vertices[6], (Vec3{1, 1, 1}));
  EXPECT_TRUE(s.warnings.empty());
}

TEST(PlyLoad, BinaryBigEndian) {
  const Scene s = parse_file("formats/cube_binary_be.ply");
  ASSERT_EQ(s.objects.size(), 1u);
  EXPECT_EQ(s.objects[0].label, "cube_binary_be");
  expect_closed_cube(s.objects[0]);
  EXPECT_EQ(s.objects[0].vertices[6], (Vec3{1, 1, 1}));
  EXPECT_EQ(s.objects[0].vertices[3], (Vec3{0, 1, 0}));
  EXPECT_TRUE(s.warnings.empty());
}

TEST(PlyLoad, TruncatedBinaryIsAnError) {
  std::vector<uint8_t> bytes = read_bytes(kData + "/formats/cube_binary_be.ply");
  bytes.resize(bytes.size() - 5);
  expect_error([&] { parse_scene_bytes(bytes, SceneFormat::kAuto, "cut"); },
               ErrorCode::kInvalidScene, "truncated");
}

// Cut at every seventh length past the header, a binary PLY's error says a byte of the body
// (ErrorLocation::offset and the detail): where the value it could not read starts (at most
// 8 bytes before the end) or where the rows that cannot fit start.
TEST(PlyLoad, TruncatedBinaryNamesTheByte) {
  const std::vector<uint8_t> whole = read_bytes(kData + "/formats/cube_binary_be.ply");
  const std::string text(whole.begin(), whole.end());
  const size_t body = text.find("end_header\n") + 11;
  for (size_t cut = body + 1; cut < whole.size(); cut += 7) {
    const std::vector<uint8_t> bytes(whole.begin(), whole.begin() + static_cast<long>(cut));
    try {
      parse_scene_bytes(bytes, SceneFormat::kAuto, "cut");
      ADD_FAILURE() << "cut at " << cut << " was accepted";
    } catch (const Error& e) {
      EXPECT_LE(e.where().offset, static_cast<int64_t>(cut)) << cut;
      EXPECT_GE(e.where().offset, static_cast<int64_t>(body)) << cut;
      if (std::string(e.what()).find("is truncated at") != std::string::npos) {
        EXPECT_GE(e.where().offset + 8, static_cast<int64_t>(cut)) << cut;
      }
      EXPECT_NE(std::string(e.what()).find("byte " + std::to_string(e.where().offset)),
                std::string::npos)
          << e.what();
    }
  }
}

// ---------------------------------------------------------------------------------- STL

// A binary STL whose 80-byte header starts with "solid" (as many exporters write it), cut
// short: the error says binary and truncated, how many facets the header declares and the
// byte where the file ends (was "no facets", read as ASCII); with bytes added after the last
// facet, it says how many.
TEST(StlLoad, TruncatedOrPaddedBinaryIsSaidSo) {
  std::vector<uint8_t> bytes(84 + 50 * 3, 0);
  const std::string header = "solid exported by a CAD tool";
  std::copy(header.begin(), header.end(), bytes.begin());
  bytes[80] = 3;
  for (size_t f = 0; f < 3; ++f) {
    for (size_t c = 0; c < 3; ++c) {
      const float v[3] = {static_cast<float>(f + (c == 1)), static_cast<float>(c == 2), 0.5f};
      std::memcpy(bytes.data() + 84 + 50 * f + 12 + 12 * c, v, sizeof v);
    }
  }
  EXPECT_EQ(parse_scene_bytes(bytes, SceneFormat::kAuto, "ok").objects[0].simplices.size(), 3u);
  std::vector<uint8_t> cut(bytes.begin(), bytes.end() - 20);
  try {
    parse_scene_bytes(cut, SceneFormat::kAuto, "cut");
    ADD_FAILURE() << "a truncated binary STL was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.where().offset, static_cast<int64_t>(cut.size()));
    const std::string what = e.what();
    EXPECT_NE(what.find("binary STL truncated"), std::string::npos) << what;
    EXPECT_NE(what.find("3 facets"), std::string::npos) << what;
  }
  // An ASCII STL with bytes above 0x7f (a UTF-8 name) is still read as ASCII.
  const std::string ascii =
      "solid W\xc3\xbcrfel\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 0\n"
      "   vertex 0 1 0\n  endloop\n endfacet\nendsolid W\xc3\xbcrfel\n" +
      std::string(60, ' ');
  EXPECT_EQ(parse_scene_bytes(std::vector<uint8_t>(ascii.begin(), ascii.end()), SceneFormat::kAuto,
                              "utf8")
                .objects[0]
                .simplices.size(),
            1u);
  std::vector<uint8_t> padded = bytes;
  padded.resize(bytes.size() + 5, 0);
  expect_error([&] { parse_scene_bytes(padded, SceneFormat::kAuto, "padded"); },
               ErrorCode::kInvalidScene, "5 bytes after the 3 facets");
}

TEST(StlLoad, AsciiIsWelded) {
  const Scene s = parse_file("formats/tetra_ascii.stl");
  ASSERT_EQ(s.objects.size(), 1u);
  EXPECT_EQ(s.objects[0].label, "tetra_ascii");
  EXPECT_EQ(s.objects[0].vertices.size(), 4u);  // 12 corners welded (-0 == 0)
  EXPECT_EQ(s.objects[0].simplices.size(), 4u);
  EXPECT_TRUE(s.warnings.empty());
}

TEST(StlLoad, BinaryWhoseHeaderStartsWithSolid) {
  const std::vector<uint8_t> bytes = read_bytes(kData + "/formats/cube_binary_solid_header.stl");
  ASSERT_EQ(std::string(bytes.begin(), bytes.begin() + 5), "solid");
  const Scene s = parse_scene_bytes(bytes, SceneFormat::kAuto, "cube");
  ASSERT_EQ(s.objects.size(), 1u);
  expect_closed_cube(s.objects[0]);
  EXPECT_TRUE(s.warnings.empty());
  const Scene t = parse_scene_bytes(bytes, SceneFormat::kStl, "cube");
  expect_closed_cube(t.objects[0]);
}

// ---------------------------------------------------------------------------------- OFF

TEST(OffLoad, QuadsAreFanTriangulated) {
  const Scene s = parse_file("formats/cube.off");
  ASSERT_EQ(s.objects.size(), 1u);
  EXPECT_EQ(s.objects[0].label, "cube");
  expect_closed_cube(s.objects[0]);
  EXPECT_TRUE(s.warnings.empty());
}

// ---------------------------------------------------------------------------------- glTF

void expect_two_nodes(const Scene& s) {
  ASSERT_EQ(s.objects.size(), 2u);
  EXPECT_EQ(s.objects[0].label, "tet_child");
  EXPECT_EQ(s.objects[1].label, "node_2");
  for (const SceneObject& o : s.objects) {
    EXPECT_EQ(o.simplices.size(), 4u) << o.label;
  }
  EXPECT_EQ(s.objects[0].vertices.size(), 4u);
  EXPECT_EQ(s.objects[1].vertices.size(), 12u);  // not indexed
  // parent translation (10,0,0) then child scale 2: (1,0,0) -> (12,0,0)
  EXPECT_EQ(s.objects[0].vertices[1], (Vec3{12, 0, 0}));
  EXPECT_EQ(s.objects[0].vertices[3], (Vec3{10, 0, 2}));
  // matrix with translation (0,0,5)
  for (const Vec3& p : s.objects[1].vertices) {
    EXPECT_GE(p.z, 5.0);
    EXPECT_LE(p.z, 6.0);
  }
  ASSERT_NE(find_warning(s, "open_mesh"), nullptr);  // node_2 is a soup of 12 corners
  EXPECT_EQ(find_warning(s, "open_mesh")->object, "node_2");
}

TEST(GltfLoad, BinaryGlb) { expect_two_nodes(parse_file("formats/two_nodes.glb")); }

TEST(GltfLoad, AsciiGltfWithDataUri) { expect_two_nodes(parse_file("formats/two_nodes.gltf")); }

TEST(GltfLoad, ExplicitFormats) {
  expect_two_nodes(parse_file("formats/two_nodes.glb", SceneFormat::kGlb));
  expect_two_nodes(parse_file("formats/two_nodes.gltf", SceneFormat::kGltf));
}

TEST(GltfLoad, TruncatedGlbIsAnErrorAtEveryLength) {
  const std::vector<uint8_t> bytes = read_bytes(kData + "/formats/two_nodes.glb");
  expect_error([&] { parse_scene_bytes(std::span(bytes).first(100), SceneFormat::kAuto, "cut"); },
               ErrorCode::kInvalidScene, "truncated GLB");
  for (size_t n = 0; n < bytes.size(); n += 7) {
    try {
      parse_scene_bytes(std::span(bytes).first(n), SceneFormat::kGlb, "cut");
      ADD_FAILURE() << "accepted " << n << " bytes";
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::kInvalidScene) << n << ": " << e.what();
    }
  }
}

TEST(GltfLoad, CorruptedJsonChunkIsAnError) {
  std::vector<uint8_t> bytes = read_bytes(kData + "/formats/two_nodes.glb");
  bytes[25] = '#';
  expect_error([&] { parse_scene_bytes(bytes, SceneFormat::kAuto, "bad"); },
               ErrorCode::kInvalidScene, "GLB \"bad\"");
}

// glTF/GLB errors say where: a JSON pointer into the glTF
// document, the scene object (a node with a mesh) and its triangle, or the GLB's byte offset.
// two_nodes: scene nodes [0, 2]; node 0 "parent" (no mesh) has child 1 "tet_child" (mesh 0,
// object 0: POSITION accessor 0, 4 vertices; indices accessor 1, 12 uint16 at BIN byte 48);
// node 2 is unnamed (mesh 1, object 1 "node_2": POSITION accessor 2, 12 vertices).

nlohmann::json two_nodes_gltf() {
  std::ifstream in(kData + "/formats/two_nodes.gltf");
  return nlohmann::json::parse(in);
}

struct GlbParts {
  nlohmann::json json;
  std::vector<uint8_t> bin;
};

uint32_t u32_at(const std::vector<uint8_t>& b, size_t at) {
  return static_cast<uint32_t>(b[at]) | static_cast<uint32_t>(b[at + 1]) << 8 |
         static_cast<uint32_t>(b[at + 2]) << 16 | static_cast<uint32_t>(b[at + 3]) << 24;
}

void put_u32(std::vector<uint8_t>& b, uint32_t v) {
  for (int k = 0; k < 4; ++k) b.push_back(static_cast<uint8_t>(v >> (8 * k)));
}

// two_nodes.glb taken apart (JSON chunk, BIN chunk), to change and put back together.
GlbParts two_nodes_glb() {
  const std::vector<uint8_t> b = read_bytes(kData + "/formats/two_nodes.glb");
  const uint32_t json_length = u32_at(b, 12);
  GlbParts parts;
  parts.json = nlohmann::json::parse(b.begin() + 20, b.begin() + 20 + json_length);
  const size_t bin = 20 + json_length;
  parts.bin.assign(b.begin() + static_cast<std::ptrdiff_t>(bin + 8),
                   b.begin() + static_cast<std::ptrdiff_t>(bin + 8 + u32_at(b, bin)));
  return parts;
}

std::vector<uint8_t> glb_of(const GlbParts& parts) {
  std::string json = parts.json.dump();
  while (json.size() % 4 != 0) json += ' ';
  std::vector<uint8_t> bin = parts.bin;
  while (bin.size() % 4 != 0) bin.push_back(0);
  std::vector<uint8_t> out = {'g', 'l', 'T', 'F'};
  put_u32(out, 2);
  put_u32(out, static_cast<uint32_t>(12 + 8 + json.size() + 8 + bin.size()));
  put_u32(out, static_cast<uint32_t>(json.size()));
  put_u32(out, 0x4E4F534Au);
  out.insert(out.end(), json.begin(), json.end());
  put_u32(out, static_cast<uint32_t>(bin.size()));
  put_u32(out, 0x004E4942u);
  out.insert(out.end(), bin.begin(), bin.end());
  return out;
}

// The location of the error parsing `bytes` throws (code `code`); an empty one when none.
ErrorLocation gltf_error_where(const std::vector<uint8_t>& bytes,
                               ErrorCode code = ErrorCode::kInvalidScene,
                               const SceneLimits& limits = {}) {
  try {
    parse_scene_bytes(bytes, SceneFormat::kAuto, "bad", limits);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), code) << e.what();
    return e.where();
  }
  return {};
}

ErrorLocation gltf_error_where(const nlohmann::json& gltf) {
  return gltf_error_where(bytes_of(gltf.dump()));
}

TEST(GltfErrorLocation, GlbContainerFaultsGiveTheirByteOffset) {
  const std::vector<uint8_t> good = read_bytes(kData + "/formats/two_nodes.glb");
  std::vector<uint8_t> magic = good;
  magic[1] = 'X';  // "gXTF": read as glTF JSON (the magic decides), malformed at byte 0
  try {
    parse_scene_bytes(magic, SceneFormat::kGlb, "bad");
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.where().offset, 0) << e.what();
  }
  EXPECT_EQ(gltf_error_where(read_bytes(kData + "/malformed/glb_bad_version.glb")).offset, 4);
  // The JSON chunk's header (at byte 12) announces more bytes than the file holds.
  EXPECT_EQ(gltf_error_where(read_bytes(kData + "/malformed/glb_chunk_overflow.glb")).offset, 12);
  // Cut files: the offset is where the file ends.
  const std::vector<uint8_t> truncated = read_bytes(kData + "/malformed/glb_truncated.glb");
  EXPECT_EQ(gltf_error_where(truncated).offset, static_cast<int64_t>(truncated.size()));
  for (const size_t cut : {size_t{5}, size_t{11}}) {
    try {
      parse_scene_bytes(std::span(good).first(cut), SceneFormat::kGlb, "cut");
      ADD_FAILURE() << "no error at " << cut;
    } catch (const Error& e) {
      EXPECT_EQ(e.where().offset, static_cast<int64_t>(cut)) << e.what();
    }
  }
  // The BIN chunk's header lies about its length: the offset is that chunk's.
  std::vector<uint8_t> bin_overflow = good;
  const size_t bin_at = 20 + u32_at(good, 12);
  bin_overflow[bin_at] = 0xFF;
  bin_overflow[bin_at + 1] = 0xFF;
  const ErrorLocation bin = gltf_error_where(bin_overflow);
  EXPECT_EQ(bin.offset, static_cast<int64_t>(bin_at));
  EXPECT_TRUE(bin.pointer.empty());
  EXPECT_LT(bin.object, 0);
  // Malformed JSON in the JSON chunk: the offset is the file's (the chunk starts at byte 20).
  std::vector<uint8_t> bad_json = good;
  bad_json[21] = '#';  // {#asset": ...
  EXPECT_EQ(gltf_error_where(bad_json).offset, 21);
}

TEST(GltfErrorLocation, MalformedJsonTextGivesItsOffset) {
  std::vector<uint8_t> bytes = read_bytes(kData + "/formats/two_nodes.gltf");
  const std::string text(bytes.begin(), bytes.end());
  const size_t at = text.find("\"nodes\"");
  ASSERT_NE(at, std::string::npos);
  bytes[at] = '#';
  EXPECT_EQ(gltf_error_where(bytes).offset, static_cast<int64_t>(at));
}

TEST(GltfErrorLocation, IndexOutOfRangeNamesTheObjectAndTriangle) {
  GlbParts parts = two_nodes_glb();
  // Index entry 7 of accessor 1 (uint16 at BIN byte 48 + 2 * 7) -> 9: tet_child has 4 vertices.
  parts.bin[48 + 14] = 9;
  parts.bin[48 + 15] = 0;
  const ErrorLocation where = gltf_error_where(glb_of(parts));
  EXPECT_EQ(where.pointer, "/accessors/1");
  EXPECT_EQ(where.object, 0);
  EXPECT_EQ(where.label, "tet_child");
  EXPECT_EQ(where.element, "triangle");
  EXPECT_EQ(where.index, 2);  // entries 6, 7, 8
  EXPECT_LT(where.offset, 0);

  // As a strip, entry 7 is first read by triangle 5 (entries 5, 6, 7).
  parts.json["meshes"][0]["primitives"][0]["mode"] = 5;
  const ErrorLocation strip = gltf_error_where(glb_of(parts));
  EXPECT_EQ(strip.element, "triangle");
  EXPECT_EQ(strip.index, 5);
}

TEST(GltfErrorLocation, NodeFaultsPointIntoTheNode) {
  nlohmann::json gltf = two_nodes_gltf();
  gltf["nodes"][2]["matrix"].erase(15);
  ErrorLocation where = gltf_error_where(gltf);
  EXPECT_EQ(where.pointer, "/nodes/2/matrix");
  EXPECT_EQ(where.object, 1);  // node 2 becomes the second object
  EXPECT_EQ(where.label, "node_2");

  // A node without a mesh is no object: the pointer alone.
  gltf = two_nodes_gltf();
  gltf["nodes"][0]["translation"] = nlohmann::json::array({1, 2});
  where = gltf_error_where(gltf);
  EXPECT_EQ(where.pointer, "/nodes/0/translation");
  EXPECT_LT(where.object, 0);
  EXPECT_TRUE(where.label.empty());

  gltf = two_nodes_gltf();
  gltf["nodes"][1]["mesh"] = 9;
  EXPECT_EQ(gltf_error_where(gltf).pointer, "/nodes/1/mesh");

  // Missing and repeated nodes: the member that names them.
  gltf = two_nodes_gltf();
  gltf["scenes"][0]["nodes"][1] = 7;
  EXPECT_EQ(gltf_error_where(gltf).pointer, "/scenes/0/nodes/1");
  gltf = two_nodes_gltf();
  gltf["nodes"][1]["children"] = nlohmann::json::array({2});
  EXPECT_EQ(gltf_error_where(gltf).pointer, "/scenes/0/nodes/1");  // node 2 reached again
  gltf = two_nodes_gltf();
  gltf["nodes"][0]["children"] = nlohmann::json::array({1, 1});
  EXPECT_EQ(gltf_error_where(gltf).pointer, "/nodes/0/children/1");
}

TEST(GltfErrorLocation, AccessorAndBufferFaultsPointAtTheirMember) {
  nlohmann::json gltf = two_nodes_gltf();
  gltf["meshes"][1]["primitives"][0]["attributes"]["POSITION"] = 5;
  ErrorLocation where = gltf_error_where(gltf);
  EXPECT_EQ(where.pointer, "/meshes/1/primitives/0/attributes/POSITION");
  EXPECT_EQ(where.object, 1);
  EXPECT_EQ(where.label, "node_2");

  // 400 positions in a bufferView of 48 bytes (the malformed corpus).
  where = gltf_error_where(read_bytes(kData + "/malformed/gltf_accessor_overflow.gltf"));
  EXPECT_EQ(where.pointer, "/accessors/0");
  EXPECT_EQ(where.object, 0);
  EXPECT_EQ(where.label, "tet_child");

  gltf = two_nodes_gltf();
  gltf["bufferViews"][2]["byteLength"] = 400;
  EXPECT_EQ(gltf_error_where(gltf).pointer, "/bufferViews/2");

  gltf = two_nodes_gltf();
  gltf["bufferViews"][2]["byteStride"] = 4;
  EXPECT_EQ(gltf_error_where(gltf).pointer, "/bufferViews/2/byteStride");

  gltf = two_nodes_gltf();
  gltf["accessors"][2]["type"] = "VEC2";
  EXPECT_EQ(gltf_error_where(gltf).pointer, "/accessors/2/type");

  gltf = two_nodes_gltf();
  gltf["meshes"][0]["primitives"][0]["attributes"].erase("POSITION");
  where = gltf_error_where(gltf);
  EXPECT_EQ(where.pointer, "/meshes/0/primitives/0/attributes");
  EXPECT_EQ(where.label, "tet_child");

  EXPECT_EQ(gltf_error_where(read_bytes(kData + "/malformed/gltf_external_buffer.gltf")).pointer,
            "/buffers/0/uri");
  where = gltf_error_where(read_bytes(kData + "/malformed/gltf_lines_primitive.gltf"));
  EXPECT_EQ(where.pointer, "/meshes/1/primitives/0/mode");
  EXPECT_EQ(where.object, 1);
}

// Members tinygltf requires are checked before it runs: their pointers, not its words alone.
TEST(GltfErrorLocation, MissingRequiredMembersPointAtThem) {
  nlohmann::json gltf = two_nodes_gltf();
  gltf["asset"].erase("version");
  EXPECT_EQ(gltf_error_where(gltf).pointer, "/asset/version");
  gltf = two_nodes_gltf();
  gltf["accessors"][2].erase("count");
  EXPECT_EQ(gltf_error_where(gltf).pointer, "/accessors/2/count");
  gltf = two_nodes_gltf();
  gltf["accessors"][1]["type"] = 3;
  EXPECT_EQ(gltf_error_where(gltf).pointer, "/accessors/1/type");
  gltf = two_nodes_gltf();
  gltf["bufferViews"][1].erase("buffer");
  EXPECT_EQ(gltf_error_where(gltf).pointer, "/bufferViews/1/buffer");
  gltf = two_nodes_gltf();
  gltf["buffers"][0].erase("byteLength");
  EXPECT_EQ(gltf_error_where(gltf).pointer, "/buffers/0/byteLength");
  gltf = two_nodes_gltf();
  gltf["meshes"][1]["primitives"][0].erase("attributes");
  EXPECT_EQ(gltf_error_where(gltf).pointer, "/meshes/1/primitives/0/attributes");
  // The same JSON in a GLB: the same pointers.
  GlbParts parts = two_nodes_glb();
  parts.json["accessors"][0].erase("componentType");
  EXPECT_EQ(gltf_error_where(glb_of(parts)).pointer, "/accessors/0/componentType");
}

TEST(GltfErrorLocation, TriangleLimitNamesThePrimitiveThatCrossedIt) {
  SceneLimits limits;
  limits.max_simplices = 5;  // tet_child has 4, node_2 4 more
  const ErrorLocation where = gltf_error_where(read_bytes(kData + "/formats/two_nodes.glb"),
                                               ErrorCode::kLimitExceeded, limits);
  EXPECT_EQ(where.pointer, "/meshes/1/primitives/0");
  EXPECT_EQ(where.object, 1);
  EXPECT_EQ(where.label, "node_2");
}

// A glTF in a scene of parts is one object: its faults name that part, and keep their pointer.
TEST(GltfErrorLocation, InAPartTheObjectIsThePart) {
  GlbParts parts = two_nodes_glb();
  parts.bin[48 + 14] = 9;
  const std::vector<uint8_t> bad = glb_of(parts);
  const std::vector<uint8_t> off = read_bytes(kData + "/formats/cube.off");
  const std::vector<ScenePart> p = {{"cube", off, SceneFormat::kAuto, "part \"cube\""},
                                    {"nodes", bad, SceneFormat::kAuto, "part \"nodes\""}};
  try {
    parse_scene_parts(p);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.where().object, 1) << e.what();
    EXPECT_EQ(e.where().label, "nodes");
    EXPECT_EQ(e.where().pointer, "/accessors/1");
    // tet_child comes first in the merged object: its triangle numbers stay the same.
    EXPECT_EQ(e.where().element, "triangle");
    EXPECT_EQ(e.where().index, 2);
  }
}

// ------------------------------------------------------------------------ sniffing, files

TEST(LoadSceneSniff, JsonAndUnknown) {
  const std::string json =
      R"(  {"dimension": 2, "objects": [{"label": "w", "vertices": [[0,0],[1,0]], "segments": [[0,1]]}]})";
  EXPECT_EQ(parse_scene_bytes(bytes_of(json), SceneFormat::kAuto, "x").dimension, 2);
  expect_error([] { parse_scene_bytes(bytes_of("hello world\n"), SceneFormat::kAuto, "greeting"); },
               ErrorCode::kUnsupportedFormat, "greeting");
  expect_error([] { parse_scene_bytes(bytes_of(""), SceneFormat::kAuto, "nothing"); },
               ErrorCode::kUnsupportedFormat, "nothing");
}

TEST(LoadScene, OneSceneFile) {
  const std::vector<std::string> paths = {kData + "/formats/two_objects_2d.json"};
  const Scene s = load_scene(paths);
  EXPECT_EQ(s.dimension, 2);
  ASSERT_EQ(s.objects.size(), 2u);
  EXPECT_EQ(s.objects[1].label, "wall");
}

TEST(LoadScene, OneMeshFileIsAOneObjectScene) {
  const std::vector<std::string> paths = {kData + "/formats/cube.off"};
  const Scene s = load_scene(paths);
  ASSERT_EQ(s.objects.size(), 1u);
  EXPECT_EQ(s.objects[0].label, "cube");
  EXPECT_TRUE(s.units.empty());  // meshes have no units unless the caller gives them
}

TEST(LoadScene, SeveralFilesAreOneObjectEachLabelledByStem) {
  const std::vector<std::string> paths = {
      kData + "/formats/cube_binary_le.ply", kData + "/formats/tetra_ascii.stl",
      kData + "/formats/groups.obj", kData + "/formats/two_nodes.glb"};
  const Scene s = load_scene(paths);
  ASSERT_EQ(s.objects.size(), 4u);
  EXPECT_TRUE(s.units.empty());
  EXPECT_EQ(s.objects[0].label, "cube_binary_le");
  EXPECT_EQ(s.objects[1].label, "tetra_ascii");
  EXPECT_EQ(s.objects[2].label, "groups");
  EXPECT_EQ(s.objects[2].simplices.size(), 16u);  // both OBJ groups merged
  EXPECT_EQ(s.objects[2].vertices.size(), 12u);
  EXPECT_EQ(s.objects[3].label, "two_nodes");
  EXPECT_EQ(s.objects[3].simplices.size(), 8u);
  const SceneWarning* w = find_warning(s, "multiple_components");
  ASSERT_NE(w, nullptr);
  EXPECT_EQ(w->object, "groups");
}

TEST(LoadScene, DuplicateStemsNameBothPaths) {
  const std::vector<std::string> paths = {kData + "/formats/cube.off",
                                          kData + "/formats/tetra_ascii.ply",
                                          kData + "/formats/tetra_ascii.stl"};
  expect_error([&] { load_scene(paths); }, ErrorCode::kInvalidScene,
               "tetra_ascii.ply\" and \"" + kData + "/formats/tetra_ascii.stl");
}

TEST(LoadScene, UnreadableFileIsAnIoError) {
  const std::vector<std::string> paths = {kData + "/formats/cube.off", "/nonexistent/x.stl"};
  expect_error([&] { load_scene(paths); }, ErrorCode::kIo, "/nonexistent/x.stl");
  const std::vector<std::string> dir = {kData + "/formats"};
  expect_error([&] { load_scene(dir); }, ErrorCode::kIo, "formats");
}

TEST(LoadScene, MixingDimensionsIsAnError) {
  const std::vector<std::string> paths = {kData + "/formats/cube.off",
                                          kData + "/formats/two_objects_2d.json"};
  expect_error([&] { load_scene(paths); }, ErrorCode::kInvalidScene, "2D");
}

// The one merge of several meshes (the CLI's files, the server's multipart parts).
TEST(ParseSceneParts, OneObjectPerPartNamedByItsSource) {
  const std::vector<uint8_t> obj = read_bytes(kData + "/formats/groups.obj");
  const std::vector<uint8_t> off = read_bytes(kData + "/formats/cube.off");
  const std::vector<ScenePart> parts = {{"left", obj, SceneFormat::kAuto, "part \"left\""},
                                        {"right", off, SceneFormat::kAuto, "part \"right\""}};
  const Scene s = parse_scene_parts(parts);
  ASSERT_EQ(s.objects.size(), 2u);
  EXPECT_EQ(s.objects[0].label, "left");
  EXPECT_EQ(s.objects[0].simplices.size(), 16u);  // both OBJ groups, one object
  expect_closed_cube(s.objects[1]);
  EXPECT_EQ(s.objects[1].label, "right");
  // The same bytes as files give the same objects.
  const std::vector<std::string> paths = {kData + "/formats/groups.obj",
                                          kData + "/formats/cube.off"};
  const Scene files = load_scene(paths);
  for (size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(files.objects[i].vertices, s.objects[i].vertices);
    EXPECT_EQ(files.objects[i].simplices.size(), s.objects[i].simplices.size());
  }
}

TEST(ParseSceneParts, ErrorsNameTheParts) {
  const std::vector<uint8_t> off = read_bytes(kData + "/formats/cube.off");
  const std::vector<uint8_t> flat = read_bytes(kData + "/formats/two_objects_2d.json");
  const std::vector<uint8_t> junk = bytes_of("not a mesh");
  expect_error(
      [&] {
        const std::vector<ScenePart> p = {{"a", off, SceneFormat::kAuto, "part \"a\""},
                                          {"a", off, SceneFormat::kAuto, "part \"b\""}};
        parse_scene_parts(p);
      },
      ErrorCode::kInvalidScene, "part \"a\" and part \"b\" have the same label \"a\"");
  expect_error(
      [&] {
        const std::vector<ScenePart> p = {{"a", off, SceneFormat::kAuto, "part \"a\""},
                                          {"b", flat, SceneFormat::kAuto, "part \"b\""}};
        parse_scene_parts(p);
      },
      ErrorCode::kInvalidScene, "part \"b\" is 2D but part \"a\" is 3D");
  expect_error(
      [&] {
        const std::vector<ScenePart> p = {{"", off, SceneFormat::kAuto, "a multipart part"}};
        parse_scene_parts(p);
      },
      ErrorCode::kInvalidScene, "a multipart part has no label");
  expect_error([&] { parse_scene_parts({}); }, ErrorCode::kInvalidScene, "no meshes");
  // The object limit is checked before any part is parsed: junk parts over the limit are a
  // limit error, not a format error.
  SceneLimits limits;
  limits.max_objects = 2;
  expect_error(
      [&] {
        const std::vector<ScenePart> p = {{"a", junk, SceneFormat::kAuto, "part \"a\""},
                                          {"b", junk, SceneFormat::kAuto, "part \"b\""},
                                          {"c", junk, SceneFormat::kAuto, "part \"c\""}};
        parse_scene_parts(p, limits);
      },
      ErrorCode::kLimitExceeded, "3 meshes, more than the limit of 2 objects");
}

// Reliability D4: a mesh of many vertices and few simplices (no format bounded the vertices)
// is refused at 3 vertices per simplex of the simplex limit, unless a vertex limit is set.
TEST(LoadScene, VerticesAreLimitedInEveryFormat) {
  std::string off = "OFF\n7 2 0\n";
  for (int i = 0; i < 7; ++i) off += std::to_string(i) + " 0 " + std::to_string(i % 2) + "\n";
  off += "3 0 1 2\n3 1 2 3\n";
  SceneLimits limits;
  limits.max_simplices = 2;
  expect_error([&] { parse_scene_bytes(bytes_of(off), SceneFormat::kOff, "m", limits); },
               ErrorCode::kLimitExceeded,
               "the scene has 7 vertices, more than the limit of 6 (3 per simplex of the limit of "
               "2 simplices)");
  limits.max_vertices = 7;
  EXPECT_EQ(parse_scene_bytes(bytes_of(off), SceneFormat::kOff, "m", limits).vertex_count(), 7u);
}

TEST(ParseSceneParts, DegenerateSimplicesAreReportedUnderThePartNamingItsSource) {
  // A tetrahedron plus one zero-area triangle (a repeated vertex).
  const std::vector<uint8_t> off = bytes_of(
      "OFF\n4 5 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n3 0 0 1\n");
  const std::vector<uint8_t> cube = read_bytes(kData + "/formats/cube.off");
  const std::vector<ScenePart> parts = {{"tet", off, SceneFormat::kAuto, "part \"tet\""},
                                        {"cube", cube, SceneFormat::kAuto, "part \"cube\""}};
  const Scene s = parse_scene_parts(parts);
  const SceneWarning* w = find_warning(s, "degenerate_simplices");
  ASSERT_NE(w, nullptr);
  EXPECT_EQ(w->object, "tet");
  EXPECT_EQ(w->count, 1u);
  EXPECT_EQ(s.objects[0].simplices.size(), 4u);
}

TEST(LoadSceneRobustness, EveryPrefixOfEveryFixtureParsesOrFailsCleanly) {
  for (const auto& entry : std::filesystem::directory_iterator(kData + "/formats")) {
    if (entry.path().extension() == ".py") continue;
    const std::vector<uint8_t> bytes = read_bytes(entry.path().string());
    SCOPED_TRACE(entry.path().filename().string());
    for (size_t n = 0; n <= bytes.size(); n += 1 + n / 64) {
      try {
        parse_scene_bytes(std::span(bytes).first(n), SceneFormat::kAuto, "prefix");
      } catch (const Error& e) {
        EXPECT_TRUE(e.code() == ErrorCode::kInvalidScene ||
                    e.code() == ErrorCode::kUnsupportedFormat)
            << n << ": " << e.what();
      }
    }
  }
}

// ------------------------------------------------------------------------ malformed corpus

TEST(SceneMalformedCorpus, EveryFileIsRejectedAsListed) {
  const std::string dir = kData + "/malformed";
  std::ifstream manifest_in(dir + "/expected.json");
  ASSERT_TRUE(manifest_in);
  const nlohmann::json manifest = nlohmann::json::parse(manifest_in);
  const nlohmann::json& files = manifest.at("files");
  size_t checked = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    const std::string file = entry.path().filename().string();
    if (file == "expected.json") continue;
    SCOPED_TRACE(file);
    ASSERT_TRUE(files.contains(file)) << "not listed in expected.json";
    const std::string code = files[file].at("code");
    const std::string contains = files[file].at("contains");
    try {
      parse_scene_bytes(read_bytes(entry.path().string()), SceneFormat::kAuto,
                        entry.path().stem().string());
      ADD_FAILURE() << "accepted";
    } catch (const Error& e) {
      EXPECT_EQ(error_code_name(e.code()), code) << e.what();
      EXPECT_NE(e.detail().find(contains), std::string::npos) << e.detail();
    }
    ++checked;
  }
  EXPECT_EQ(checked, files.size());
}

}  // namespace
}  // namespace gvd
