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
