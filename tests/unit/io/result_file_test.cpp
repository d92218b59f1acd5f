#include "gvd/io/result_file.h"

#include <gtest/gtest.h>

#include <cstring>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "gvd/common/error.h"
#include "gvd/io/write_outputs.h"
#include "gvd/octree/lattice.h"
#include "gvd/pipeline/pipeline.h"
#include "gvd/query/contact_report.h"
#include "gvd/query/gvd_index.h"
#include "support/gltf_validate.h"
#include "support/scenes.h"

namespace gvd {

using namespace gvd::scene;
using namespace gvd::octree;
using namespace gvd::distance;
using namespace gvd::surface;
using namespace gvd::graph;
using namespace gvd::result;
using namespace gvd::query;
using namespace gvd::io;
using namespace gvd::pipeline;

namespace {

using nlohmann::json;

// ---------------------------------------------------------------------------------------------
// Fixtures: two small real results, computed once.
//
//   2D: two circles and an open segment (the segment gives an "open" topology warning).
//   3D: two intersecting boxes (an "objects_touch" warning from the pipeline) and a sphere.
// ---------------------------------------------------------------------------------------------

GvdResult compute(Scene scene, int max_depth) {
  PipelineOptions o;
  o.max_depth = max_depth;
  o.threads = 2;
  return compute_gvd(std::move(scene), o);
}

const GvdResult& result_2d() {
  static const GvdResult r =
      compute(test::make_scene(2, {test::make_circle("left", {0, 0, 0}, 0.5, 24),
                                   test::make_circle("right", {1.6, 0.1, 0}, 0.4, 24),
                                   test::make_segment("bar", {0.2, 1.0, 0}, {1.4, 1.2, 0})}),
              9);
  return r;
}

const GvdResult& result_3d() {
  static const GvdResult r =
      compute(test::make_scene(3, {test::make_box("a", {0, 0, 0}, {1, 1, 1}),
                                   test::make_box("b", {0.5, 0.5, 0.5}, {1.5, 1.5, 1.5}),
                                   test::make_sphere("ball", {0.4, 2.4, 0.5}, 0.4, 6, 12)}),
              6);
  return r;
}

std::string output_path(const std::string& name) {
  return std::string(GVD_TEST_OUTPUT_DIR) + "/" + name;
}

template <class T>
bool bit_equal(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

bool bit_equal(Vec3 a, Vec3 b) { return std::memcmp(&a, &b, sizeof a) == 0; }

void expect_same_result(const GvdResult& a, const GvdResult& b) {
  // Scene: objects exactly, warnings as stored.
  ASSERT_EQ(a.scene.dimension, b.scene.dimension);
  ASSERT_EQ(a.scene.objects.size(), b.scene.objects.size());
  for (size_t i = 0; i < a.scene.objects.size(); ++i) {
    const SceneObject& x = a.scene.objects[i];
    const SceneObject& y = b.scene.objects[i];
    EXPECT_EQ(x.label, y.label);
    EXPECT_TRUE(bit_equal(x.vertices, y.vertices)) << "object " << i;
    EXPECT_TRUE(bit_equal(x.simplices, y.simplices)) << "object " << i;
  }
  ASSERT_EQ(a.scene.warnings.size(), b.scene.warnings.size());
  for (size_t i = 0; i < a.scene.warnings.size(); ++i) {
    EXPECT_EQ(a.scene.warnings[i].kind, b.scene.warnings[i].kind);
    EXPECT_EQ(a.scene.warnings[i].object, b.scene.warnings[i].object);
    EXPECT_EQ(a.scene.warnings[i].count, b.scene.warnings[i].count);
    EXPECT_EQ(a.scene.warnings[i].detail, b.scene.warnings[i].detail);
  }
  // Domain and the rebuilt geometry.
  EXPECT_EQ(a.domain.dimension, b.domain.dimension);
  EXPECT_TRUE(bit_equal(a.domain.origin, b.domain.origin));
  for (int i = 0; i < 3; ++i) EXPECT_EQ(a.domain.axis[i], b.domain.axis[i]) << "axis " << i;
  EXPECT_EQ(a.domain.side, b.domain.side);
  EXPECT_EQ(a.geometry.dimension, b.geometry.dimension);
  EXPECT_EQ(a.geometry.object_count, b.geometry.object_count);
  EXPECT_TRUE(bit_equal(a.geometry.points, b.geometry.points));
  EXPECT_TRUE(bit_equal(a.geometry.simplices, b.geometry.simplices));
  EXPECT_EQ(a.geometry.object_of, b.geometry.object_of);
  // Octree.
  EXPECT_EQ(a.octree.dimension, b.octree.dimension);
  EXPECT_EQ(a.octree.max_depth, b.octree.max_depth);
  EXPECT_EQ(a.octree.depth, b.octree.depth);
  EXPECT_EQ(a.octree.code, b.octree.code);
  EXPECT_EQ(a.octree.level, b.octree.level);
  EXPECT_EQ(a.octree.object, b.octree.object);
  // Distance field.
  EXPECT_EQ(a.field.vertices.dimension, b.field.vertices.dimension);
  EXPECT_EQ(a.field.vertices.key, b.field.vertices.key);
  // The loaded field is indexed again; a computed one dropped its hash after refinement
  // (compute_gvd) and finds keys by binary search: both give every key its position.
  EXPECT_TRUE(b.field.vertices.indexed());
  for (size_t v = 0; v < a.field.vertices.size(); v += 1 + a.field.vertices.size() / 300) {
    const uint64_t k = a.field.vertices.key[v];
    EXPECT_EQ(a.field.vertices.find(k), v);
    EXPECT_EQ(b.field.vertices.find(k), v);
    EXPECT_EQ(a.field.vertices.find(k + 1), b.field.vertices.find(k + 1));
  }
  EXPECT_EQ(a.field.label, b.field.label);
  EXPECT_EQ(a.field.point, b.field.point);
  EXPECT_TRUE(bit_equal(a.field.closest, b.field.closest));
  EXPECT_EQ(a.field.exact, b.field.exact);
  EXPECT_EQ(a.field.exact_count, b.field.exact_count);
  EXPECT_EQ(a.field.exact_reused, b.field.exact_reused);
  EXPECT_EQ(a.field.exact_near_gvd, b.field.exact_near_gvd);
  // GVD.
  EXPECT_EQ(a.gvd.dimension, b.gvd.dimension);
  ASSERT_EQ(a.gvd.cells.size(), b.gvd.cells.size());
  for (size_t i = 0; i < a.gvd.cells.size(); ++i) {
    const GvdCell& x = a.gvd.cells[i];
    const GvdCell& y = b.gvd.cells[i];
    EXPECT_EQ(x.object, y.object);
    EXPECT_TRUE(bit_equal(x.positions, y.positions)) << "cell " << i;
    EXPECT_EQ(x.other, y.other) << "cell " << i;
    EXPECT_TRUE(bit_equal(x.clearance, y.clearance)) << "cell " << i;
    EXPECT_EQ(x.indices, y.indices) << "cell " << i;
  }
  // Graph.
  EXPECT_EQ(a.graph.node_count, b.graph.node_count);
  ASSERT_EQ(a.graph.edges.size(), b.graph.edges.size());
  for (size_t i = 0; i < a.graph.edges.size(); ++i) {
    const DualEdge& x = a.graph.edges[i];
    const DualEdge& y = b.graph.edges[i];
    EXPECT_EQ(x.a, y.a);
    EXPECT_EQ(x.b, y.b);
    EXPECT_EQ(x.area, y.area);
    EXPECT_EQ(x.min_clearance, y.min_clearance);
    EXPECT_TRUE(bit_equal(x.tightest_point, y.tightest_point));
    EXPECT_EQ(x.gap, y.gap);
    EXPECT_EQ(x.touching, y.touching);
  }
  // Stats (doubles through JSON must round-trip exactly).
  const ResultStats& s = a.stats;
  const ResultStats& t = b.stats;
  ASSERT_EQ(s.stages.size(), t.stages.size());
  for (size_t i = 0; i < s.stages.size(); ++i) {
    EXPECT_EQ(s.stages[i].name, t.stages[i].name);
    EXPECT_EQ(s.stages[i].seconds, t.stages[i].seconds);
    EXPECT_EQ(s.stages[i].bytes, t.stages[i].bytes);
    EXPECT_EQ(s.stages[i].items, t.stages[i].items);
  }
  EXPECT_EQ(s.backend, t.backend);
  EXPECT_EQ(s.threads, t.threads);
  EXPECT_EQ(s.max_depth, t.max_depth);
  EXPECT_EQ(s.depth, t.depth);
  EXPECT_EQ(s.leaves, t.leaves);
  EXPECT_EQ(s.vertices, t.vertices);
  EXPECT_EQ(s.octree_bytes, t.octree_bytes);
  EXPECT_EQ(s.bytes_per_leaf, t.bytes_per_leaf);
  EXPECT_EQ(s.distance_bytes, t.distance_bytes);
  EXPECT_EQ(s.gvd_simplices, t.gvd_simplices);
  EXPECT_EQ(s.graph_edges, t.graph_edges);
  EXPECT_EQ(s.refine_rounds, t.refine_rounds);
  EXPECT_EQ(s.ambiguous_at_limit, t.ambiguous_at_limit);
  EXPECT_EQ(s.touching_leaves, t.touching_leaves);
  EXPECT_EQ(s.total_seconds, t.total_seconds);
  EXPECT_EQ(s.peak_rss_bytes, t.peak_rss_bytes);
  EXPECT_EQ(s.start_rss_bytes, t.start_rss_bytes);
  // The process held something before the computation, and its peak is no lower.
  EXPECT_GT(s.start_rss_bytes, 0u);
  EXPECT_GE(s.peak_rss_bytes, s.start_rss_bytes);
}

// Lookups that depend on what load_result rebuilds.
void expect_queries_work(const GvdResult& original, const GvdResult& loaded) {
  const DistanceField& f = loaded.field;
  for (size_t v = 0; v < f.size(); v += 1 + f.size() / 500) {
    EXPECT_EQ(f.vertices.find(f.vertices.key[v]), v);
  }
  EXPECT_EQ(f.vertices.find(FlatMap64::kEmptyKey - 1), FlatMap64::kMissing);
  // Every leaf locates itself from its centre, and arbitrary points agree with the original.
  const Octree& o = loaded.octree;
  for (uint32_t leaf = 0; leaf < o.leaf_count(); leaf += 1 + o.leaf_count() / 500) {
    EXPECT_EQ(o.locate(o.box(leaf).center()), leaf);
  }
  for (int i = 0; i <= 20; ++i) {
    const Vec3 u{i / 20.0, (20 - i) / 20.0, original.scene.dimension == 3 ? (i % 7) / 6.0 : 0.0};
    EXPECT_EQ(o.locate(u), original.octree.locate(u));
  }
}

// The file layout, for tampering: header, then tag + u64 length + payload, then the checksum.
struct SectionAt {
  std::string tag;
  size_t header = 0;   ///< offset of the tag
  size_t payload = 0;  ///< offset of the payload
  uint64_t length = 0;
};

std::vector<SectionAt> sections_of(const std::vector<uint8_t>& bytes) {
  std::vector<SectionAt> out;
  size_t pos = 16;
  while (pos + 8 < bytes.size()) {
    SectionAt s;
    s.tag.assign(reinterpret_cast<const char*>(bytes.data() + pos), 4);
    std::memcpy(&s.length, bytes.data() + pos + 4, 8);
    s.header = pos;
    s.payload = pos + 12;
    out.push_back(s);
    pos = s.payload + s.length;
  }
  return out;
}

SectionAt section(const std::vector<uint8_t>& bytes, const std::string& tag) {
  for (const SectionAt& s : sections_of(bytes))
    if (s.tag == tag) return s;
  ADD_FAILURE() << "no section " << tag;
  return {};
}

uint64_t fnv1a64(const uint8_t* data, size_t size) {
  uint64_t h = 0xcbf29ce484222325ull;
  for (size_t i = 0; i < size; ++i) {
    h ^= data[i];
    h *= 0x100000001b3ull;
  }
  return h;
}

/// Rewrites the trailer so that a tampered file passes the checksum and reaches the parser.
void reseal(std::vector<uint8_t>& bytes) {
  const uint64_t h = fnv1a64(bytes.data(), bytes.size() - 8);
  std::memcpy(bytes.data() + bytes.size() - 8, &h, 8);
}

void put_u64(std::vector<uint8_t>& bytes, size_t at, uint64_t v) {
  std::memcpy(bytes.data() + at, &v, 8);
}

/// Loads and expects gvd::Error{kInvalidArgument} whose detail contains `needle`.
void expect_rejected(const std::vector<uint8_t>& bytes, const std::string& needle) {
  try {
    load_result_bytes(bytes);
    ADD_FAILURE() << "loaded, expected an error containing \"" << needle << "\"";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument) << e.what();
    EXPECT_NE(e.detail().find(needle), std::string::npos) << e.detail();
  }
}

// ---------------------------------------------------------------------------------------------

TEST(ResultFile, RoundTrip2D) {
  const GvdResult& r = result_2d();
  ASSERT_GT(r.graph.edges.size(), 0u);
  bool open_warning = false;
  for (const SceneWarning& w : r.scene.warnings) open_warning |= w.object == "bar";
  EXPECT_TRUE(open_warning) << "the fixture should carry a warning";

  const std::string path = output_path("round_trip_2d.gvdres");
  save_result(r, path);
  const GvdResult loaded = load_result(path);
  expect_same_result(r, loaded);
  expect_queries_work(r, loaded);
}

TEST(ResultFile, RoundTrip3D) {
  const GvdResult& r = result_3d();
  ASSERT_GT(r.graph.edges.size(), 0u);
  bool touch = false;
  for (const SceneWarning& w : r.scene.warnings) touch |= w.kind == WarningKind::kObjectsTouch;
  EXPECT_TRUE(touch) << "the fixture should carry the pipeline's warning";

  const std::string path = output_path("round_trip_3d.gvdres");
  save_result(r, path);
  const GvdResult loaded = load_result(path);
  expect_same_result(r, loaded);
  expect_queries_work(r, loaded);
  // Saving the loaded result gives the same bytes: nothing is lost or reordered.
  EXPECT_EQ(result_to_bytes(loaded), read_file_bytes(path));
}

// The scene's units travel with the result (docs/FORMATS.md, "Units"): the saved file keeps
// them, and every document and answer made from the reloaded result says them at its top
// level; a result without units says none.
TEST(ResultFile, UnitsTravelWithTheSavedResult) {
  GvdResult with = result_2d();
  with.scene.units = "\u00b5m";
  const std::string path = output_path("units_2d.gvdres");
  save_result(with, path);
  const auto loaded = std::make_shared<const GvdResult>(load_result(path));
  EXPECT_EQ(loaded->scene.units, "\u00b5m");
  expect_same_result(with, *loaded);

  const GvdResult without_loaded = load_result_bytes(result_to_bytes(result_2d()));
  EXPECT_TRUE(without_loaded.scene.units.empty());
  const auto without = std::make_shared<const GvdResult>(without_loaded);

  for (const auto& r : {loaded, without}) {
    const bool has = !r->scene.units.empty();
    SCOPED_TRACE(has ? "with units" : "without units");
    const GvdIndex index(r);
    const ObjectId left = index.object("left");
    PathQuery q;
    q.from = {-0.55, -0.5, 0};
    q.to = {2.05, -0.4, 0};
    const std::vector<std::string> documents = {
        result_info_json(*r),
        graph_to_json(r->graph, r->scene),
        gvd_to_json(r->gvd, r->scene),
        tight_to_json(index, 1.0, index.tight(1.0)),
        nearest_to_json(index, index.nearest({0.8, 0.0, 0})),
        neighbors_to_json(index, left, 1, index.neighbors(left, 1)),
        path_to_json(index, q, index.path(q)),
        exploded_to_json(index, index.explode(left)),
        contacts_to_json(index, 0.5, find_contacts(index, 0.5)),
        "{\"asset\":" +
            test::parse_glb(gvd_to_glb(r->gvd, r->scene))
                .json.at("asset")
                .value("extras", json::object())
                .dump() +
            "}",
    };
    for (const std::string& text : documents) {
      const json doc = json::parse(text);
      const json& top = doc.contains("asset") ? doc.at("asset") : doc;
      if (has) {
        EXPECT_EQ(top.value("units", ""), "\u00b5m") << text.substr(0, 200);
      } else {
        EXPECT_FALSE(top.contains("units")) << text.substr(0, 200);
      }
    }
  }
}

// A tilted scene gets the octree's own frame (scene.h, DomainFrame): the axes are saved,
// loaded bit for bit, and the loaded result answers in user coordinates; a DOMN section whose
// axes are not a rotation is rejected.
TEST(ResultFile, RoundTripOfATiltedSceneKeepsTheOctreesAxes) {
  const Vec3 axis = Vec3{1, 2, 2} / 3.0;
  Scene scene = test::make_scene(3, {test::make_box("a", {0, 0, 0}, {1, 1, 0.5}),
                                     test::make_box("b", {0, 0, 0.6}, {1, 1, 1})});
  for (SceneObject& o : scene.objects)
    for (Vec3& v : o.vertices) v = test::rotate(v, axis, 0.5);
  const GvdResult r = compute(scene, 5);
  ASSERT_FALSE(r.domain.aligned());
  const std::string path = output_path("round_trip_tilted.gvdres");
  save_result(r, path);
  const GvdResult loaded = load_result(path);
  expect_same_result(r, loaded);
  expect_queries_work(r, loaded);
  const Vec3 p = test::rotate(Vec3{0.5, 0.5, 0.55}, axis, 0.5);
  EXPECT_EQ(loaded.domain.to_unit(p), r.domain.to_unit(p));
  EXPECT_EQ(result_to_bytes(loaded), read_file_bytes(path));
  const nlohmann::json info = nlohmann::json::parse(result_info_json(loaded));
  ASSERT_EQ(info["domain"]["axes"].size(), 3u);
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k)
      EXPECT_EQ(info["domain"]["axes"][i][k].get<double>(), r.domain.axis[i][k]);
  EXPECT_FALSE(nlohmann::json::parse(result_info_json(result_3d()))["domain"].contains("axes"));

  std::vector<uint8_t> bytes = read_file_bytes(path);
  const SectionAt domain = section(bytes, "DOMN");
  // dimension u32, origin 3 x f64, side f64, then the first axis' x.
  const size_t first_axis = domain.payload + 4 + 24 + 8;
  double x = 0;
  std::memcpy(&x, bytes.data() + first_axis, 8);
  x *= 1.01;
  std::memcpy(bytes.data() + first_axis, &x, 8);
  reseal(bytes);
  expect_rejected(bytes, "not orthonormal");
}

TEST(ResultFile, HeaderLayout) {
  const std::vector<uint8_t> bytes = result_to_bytes(result_2d());
  ASSERT_GE(bytes.size(), 24u);
  EXPECT_EQ(std::memcmp(bytes.data(), "GVDRES\0\1", 8), 0);
  const ResultFileHeader h = read_result_header(bytes);
  EXPECT_EQ(h.format_version, kResultFormatVersion);
  EXPECT_EQ(h.algorithm_version, kAlgorithmVersion);
  std::vector<std::string> tags;
  for (const SectionAt& s : sections_of(bytes)) tags.push_back(s.tag);
  EXPECT_EQ(tags, (std::vector<std::string>{"SCNE", "DOMN", "OCTR", "DIST", "GVD ", "GRPH", "GAPS",
                                            "STAT"}));
  const SectionAt last = sections_of(bytes).back();
  EXPECT_EQ(last.payload + last.length + 8, bytes.size());
  EXPECT_EQ(fnv1a64(bytes.data(), bytes.size() - 8), [&] {
    uint64_t h64 = 0;
    std::memcpy(&h64, bytes.data() + bytes.size() - 8, 8);
    return h64;
  }());
}

// Files written before the gaps were measured have no GAPS section: they load, with every
// gap "not measured" (< 0) and no pair touching.
TEST(ResultFile, FilesWithoutGapsLoadWithGapsNotMeasured) {
  const GvdResult& r = result_3d();
  std::vector<uint8_t> bytes = result_to_bytes(r);
  const SectionAt gaps = section(bytes, "GAPS");
  bytes.erase(bytes.begin() + static_cast<std::ptrdiff_t>(gaps.header),
              bytes.begin() + static_cast<std::ptrdiff_t>(gaps.payload + gaps.length));
  reseal(bytes);
  const GvdResult loaded = load_result_bytes(bytes);
  ASSERT_EQ(loaded.graph.edges.size(), r.graph.edges.size());
  for (const DualEdge& e : loaded.graph.edges) {
    EXPECT_LT(e.gap, 0);
    EXPECT_FALSE(e.touching);
  }
  for (const DualEdge& e : r.graph.edges) EXPECT_GE(e.gap, 0);
}

TEST(ResultFile, RejectsEmptyAndForeignFiles) {
  expect_rejected({}, "not a gvd result");
  const std::string text = "{\"dimension\": 3, \"objects\": []}";
  expect_rejected(std::vector<uint8_t>(text.begin(), text.end()), "not a gvd result");
  std::vector<uint8_t> bytes = result_to_bytes(result_2d());
  bytes[3] = 'X';
  expect_rejected(bytes, "magic");
}

TEST(ResultFile, RejectsAFutureFormatVersion) {
  std::vector<uint8_t> bytes = result_to_bytes(result_2d());
  const uint32_t future = kResultFormatVersion + 1;
  std::memcpy(bytes.data() + 8, &future, 4);
  reseal(bytes);
  expect_rejected(bytes, "unsupported result format version " + std::to_string(future));
  expect_rejected(bytes, "this build reads version " + std::to_string(kResultFormatVersion));
}

TEST(ResultFile, EveryTruncationThrows) {
  const std::vector<uint8_t> bytes = result_to_bytes(result_2d());
  std::vector<size_t> lengths = {0, 1, 7, 8, 12, 15, 16, 17, 23, 24, 28, 36};
  for (size_t n = 37; n < bytes.size(); n += 1 + bytes.size() / 150) lengths.push_back(n);
  for (size_t k = 1; k <= 16; ++k) lengths.push_back(bytes.size() - k);
  for (const size_t n : lengths) {
    const std::vector<uint8_t> cut(bytes.begin(), bytes.begin() + static_cast<long>(n));
    EXPECT_THROW(load_result_bytes(cut), Error) << "truncated at " << n;
  }
  // The checksum catches plain truncation; a truncated file with a valid checksum reaches the
  // section parser, which must refuse it too (never read past the end or crash).
  for (const size_t n : lengths) {
    if (n < 16 || n == bytes.size() - 8) continue;  // size - 8 is the file without its trailer
    std::vector<uint8_t> cut(bytes.begin(), bytes.begin() + static_cast<long>(n));
    cut.resize(n + 8);
    reseal(cut);
    try {
      load_result_bytes(cut);
      ADD_FAILURE() << "resealed truncation at " << n << " loaded";
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument) << "at " << n << ": " << e.what();
    }
  }
}

TEST(ResultFile, FlippedByteFailsTheChecksum) {
  std::vector<uint8_t> bytes = result_to_bytes(result_3d());
  bytes[bytes.size() / 2] ^= 0x10;
  expect_rejected(bytes, "file is truncated or corrupted");
}

TEST(ResultFile, AbsurdCountsThrowWithoutAllocating) {
  const std::vector<uint8_t> good = result_to_bytes(result_3d());
  const SectionAt octree = section(good, "OCTR");
  const SectionAt dist = section(good, "DIST");
  const SectionAt gvd = section(good, "GVD ");
  const SectionAt graph = section(good, "GRPH");
  const uint64_t absurd = uint64_t{1} << 61;  // * 8 bytes overflows 64 bits

  {  // OCTR: dimension, max_depth, depth (3 x u32), leaf count, code count
    std::vector<uint8_t> b = good;
    put_u64(b, octree.payload + 20, absurd);
    reseal(b);
    expect_rejected(b, "code[] has " + std::to_string(absurd) + " elements");
  }
  {
    std::vector<uint8_t> b = good;
    put_u64(b, octree.payload + 12, ~uint64_t{0});
    reseal(b);
    expect_rejected(b, "leaf count");
  }
  {  // DIST: dimension, key count
    std::vector<uint8_t> b = good;
    put_u64(b, dist.payload + 4, absurd);
    reseal(b);
    expect_rejected(b, "key[]");
  }
  {  // GVD: dimension, cell count
    std::vector<uint8_t> b = good;
    put_u64(b, gvd.payload + 4, absurd);
    reseal(b);
    expect_rejected(b, "cell count");
  }
  {  // GVD: first cell's object, then its positions count
    std::vector<uint8_t> b = good;
    put_u64(b, gvd.payload + 16, ~uint64_t{0} / 3);
    reseal(b);
    expect_rejected(b, "positions[]");
  }
  {  // GRPH: node_count, edge count
    std::vector<uint8_t> b = good;
    put_u64(b, graph.payload + 4, absurd);
    reseal(b);
    expect_rejected(b, "edge count");
  }
  {  // A section whose length runs past the end.
    std::vector<uint8_t> b = good;
    put_u64(b, dist.header + 4, absurd);
    reseal(b);
    expect_rejected(b, "runs past the end");
  }
}

TEST(ResultFile, MissingDuplicateAndUnknownSections) {
  const std::vector<uint8_t> good = result_to_bytes(result_2d());
  {  // An unknown tag is skipped, so renaming a section makes it missing.
    std::vector<uint8_t> b = good;
    std::memcpy(b.data() + section(b, "GRPH").header, "XGRP", 4);
    reseal(b);
    expect_rejected(b, "missing section \"GRPH\"");
  }
  {  // A duplicate known section.
    std::vector<uint8_t> b = good;
    std::memcpy(b.data() + section(b, "GRPH").header, "DOMN", 4);
    reseal(b);
    expect_rejected(b, "duplicate section \"DOMN\"");
  }
  {  // An extra unknown section (a newer writer) loads.
    const SectionAt stat = section(good, "STAT");
    std::vector<uint8_t> b(good.begin(), good.begin() + static_cast<long>(stat.header));
    const char extra[] = "NEW!\x05\0\0\0\0\0\0\0hello";
    b.insert(b.end(), extra, extra + 17);
    b.insert(b.end(), good.begin() + static_cast<long>(stat.header), good.end());
    reseal(b);
    const GvdResult loaded = load_result_bytes(b);
    expect_same_result(result_2d(), loaded);
  }
}

TEST(ResultFile, InconsistentDataIsRejected) {
  const std::vector<uint8_t> good = result_to_bytes(result_3d());
  const SectionAt octree = section(good, "OCTR");
  const SectionAt dist = section(good, "DIST");
  {  // An octree leaf beyond max_depth (first level byte follows dims, leaf count, codes).
    std::vector<uint8_t> b = good;
    const size_t leaves = result_3d().octree.leaf_count();
    b[octree.payload + 12 + 8 + 8 + leaves * 8 + 8] = 60;
    reseal(b);
    expect_rejected(b, "beyond max_depth");
  }
  {  // Unsorted vertex keys would break the index.
    std::vector<uint8_t> b = good;
    put_u64(b, dist.payload + 4 + 8, ~uint64_t{0});
    reseal(b);
    expect_rejected(b, "vertex keys are not strictly increasing");
  }
}

// Every single-byte corruption that passes the checksum either loads or throws a gvd::Error
// (never an internal error, a crash or an out-of-bounds read under ASan).
TEST(ResultFile, ResealedCorruptionNeverCrashes) {
  const std::vector<uint8_t> good = result_to_bytes(result_2d());
  const size_t step = 1 + good.size() / 400;
  for (size_t at = 0; at + 8 < good.size(); at += step) {
    for (const uint8_t mask : {uint8_t{0x01}, uint8_t{0x80}, uint8_t{0xff}}) {
      std::vector<uint8_t> b = good;
      b[at] ^= mask;
      reseal(b);
      try {
        load_result_bytes(b);
      } catch (const Error& e) {
        EXPECT_NE(e.code(), ErrorCode::kInternal) << "byte " << at << ": " << e.what();
      }
    }
  }
}

TEST(ResultFile, UnreadableAndUnwritablePaths) {
  try {
    load_result(output_path("no/such/dir/result.gvdres"));
    ADD_FAILURE() << "loaded a missing file";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kIo);
  }
  try {
    load_result(std::string(GVD_TEST_OUTPUT_DIR));  // a directory
    ADD_FAILURE() << "loaded a directory";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kIo);
  }
  try {
    save_result(result_2d(), output_path("no/such/dir/result.gvdres"));
    ADD_FAILURE() << "saved into a missing directory";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kIo);
  }
  // A bad file names its path.
  const std::string path = output_path("not_a_result.gvdres");
  write_file_atomic(path, std::string("hello"));
  try {
    load_result(path);
    ADD_FAILURE() << "loaded a text file";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
    EXPECT_NE(e.detail().find(path), std::string::npos) << e.detail();
  }
}

TEST(ResultFile, InfoJsonMatchesTheStats) {
  for (const GvdResult* r : {&result_2d(), &result_3d()}) {
    const json j = json::parse(result_info_json(*r));
    const ResultStats& s = r->stats;
    const int dim = r->scene.dimension;
    EXPECT_EQ(j.at("dimension").get<int>(), dim);
    EXPECT_EQ(j.at("objects").get<size_t>(), r->scene.objects.size());
    EXPECT_EQ(j.at("simplices").get<uint64_t>(), r->scene.simplex_count());
    ASSERT_EQ(j.at("domain").at("origin").size(), static_cast<size_t>(dim));
    for (int a = 0; a < dim; ++a)
      EXPECT_EQ(j.at("domain").at("origin")[a].get<double>(), r->domain.origin[a]);
    EXPECT_EQ(j.at("domain").at("side").get<double>(), r->domain.side);
    EXPECT_EQ(j.at("backend").get<std::string>(), s.backend);
    EXPECT_EQ(j.at("threads").get<int>(), s.threads);
    EXPECT_EQ(j.at("max_depth").get<int>(), s.max_depth);
    EXPECT_EQ(j.at("depth").get<int>(), s.depth);
    EXPECT_EQ(j.at("leaves").get<uint64_t>(), s.leaves);
    EXPECT_EQ(j.at("leaves").get<uint64_t>(), r->octree.leaf_count());
    EXPECT_EQ(j.at("vertices").get<uint64_t>(), s.vertices);
    EXPECT_EQ(j.at("octree_bytes").get<uint64_t>(), s.octree_bytes);
    EXPECT_EQ(j.at("bytes_per_leaf").get<double>(), s.bytes_per_leaf);
    EXPECT_EQ(j.at("distance_bytes").get<uint64_t>(), s.distance_bytes);
    EXPECT_EQ(j.at("gvd_simplices").get<uint64_t>(), s.gvd_simplices);
    EXPECT_EQ(j.at("graph_edges").get<uint64_t>(), s.graph_edges);
    EXPECT_EQ(j.at("graph_edges").get<uint64_t>(), r->graph.edges.size());
    EXPECT_EQ(j.at("refine_rounds").get<int>(), s.refine_rounds);
    EXPECT_EQ(j.at("ambiguous_cells_left").get<uint64_t>(), s.ambiguous_at_limit);
    EXPECT_EQ(j.at("touching_leaves").get<uint64_t>(), s.touching_leaves);
    EXPECT_EQ(j.at("total_seconds").get<double>(), s.total_seconds);
    ASSERT_EQ(j.at("stages").size(), s.stages.size());
    for (size_t i = 0; i < s.stages.size(); ++i) {
      EXPECT_EQ(j["stages"][i].at("name").get<std::string>(), s.stages[i].name);
      EXPECT_EQ(j["stages"][i].at("seconds").get<double>(), s.stages[i].seconds);
      EXPECT_EQ(j["stages"][i].at("bytes").get<uint64_t>(), s.stages[i].bytes);
      EXPECT_EQ(j["stages"][i].at("items").get<uint64_t>(), s.stages[i].items);
    }
    ASSERT_EQ(j.at("warnings").size(), r->scene.warnings.size());
    for (size_t i = 0; i < r->scene.warnings.size(); ++i) {
      EXPECT_EQ(j["warnings"][i].at("kind").get<std::string>(),
                warning_kind_name(r->scene.warnings[i].kind));
      EXPECT_EQ(j["warnings"][i].at("object").get<std::string>(), r->scene.warnings[i].object);
      EXPECT_EQ(j["warnings"][i].at("count").get<uint64_t>(), r->scene.warnings[i].count);
      EXPECT_EQ(j["warnings"][i].at("detail").get<std::string>(), r->scene.warnings[i].detail);
    }
  }
}

TEST(ResultFile, StatsJsonRoundTripAndErrors) {
  const ResultStats& s = result_3d().stats;
  EXPECT_EQ(stats_to_json(stats_from_json(stats_to_json(s))), stats_to_json(s));
  EXPECT_THROW(stats_from_json("[1, 2]"), Error);
  EXPECT_THROW(stats_from_json("{\"leaves\": \"many\"}"), Error);
  EXPECT_THROW(stats_from_json("{\"stages\": [{\"name\": 1}]}"), Error);
  EXPECT_THROW(stats_from_json("not json"), Error);
  EXPECT_EQ(stats_from_json("{}").leaves, 0u);
}

}  // namespace
}  // namespace gvd
