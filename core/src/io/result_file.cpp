// The binary result file (layout in result_file.h): writer, checked reader, and the `gvd info`
// summary. The reader treats the bytes as hostile: every count is checked against the bytes
// that remain before anything is allocated, and every index is range-checked after parsing so
// that later commands can trust a loaded result as much as a computed one.
#include "gvd/io/result_file.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <functional>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "gvd/common/error.h"
#include "gvd/grid/grid_advice.h"
#include "gvd/io/write_outputs.h"
#include "gvd/octree/lattice.h"
#include "gvd/scene/load_scene.h"

namespace gvd::io {

using namespace gvd::scene;
using namespace gvd::octree;
using namespace gvd::distance;
using namespace gvd::surface;
using namespace gvd::graph;
using namespace gvd::result;
using namespace gvd::grid;

namespace {

using Json = nlohmann::json;

// The file is little-endian and arrays are copied as raw bytes; a big-endian port would swap
// here. Vec3 arrays are copied as packed (x, y, z) doubles, which requires the layout below.
static_assert(std::endian::native == std::endian::little, "result files are little-endian");
static_assert(std::numeric_limits<double>::is_iec559, "doubles must be IEEE-754 binary64");
static_assert(sizeof(double) == 8 && sizeof(uint64_t) == 8 && sizeof(uint32_t) == 4);
static_assert(std::is_trivially_copyable_v<Vec3> && std::is_standard_layout_v<Vec3>);
static_assert(sizeof(Vec3) == 3 * sizeof(double) && offsetof(Vec3, x) == 0 &&
              offsetof(Vec3, y) == sizeof(double) && offsetof(Vec3, z) == 2 * sizeof(double));
static_assert(std::is_same_v<ObjectId, uint32_t>);

constexpr uint8_t kMagic[8] = {'G', 'V', 'D', 'R', 'E', 'S', 0, 1};
constexpr size_t kHeaderBytes = 8 + 4 + 4;
constexpr size_t kTrailerBytes = 8;
constexpr size_t kSectionHeaderBytes = 4 + 8;

using Tag = std::array<char, 4>;
constexpr Tag kScene{'S', 'C', 'N', 'E'};
constexpr Tag kDomain{'D', 'O', 'M', 'N'};
constexpr Tag kOctree{'O', 'C', 'T', 'R'};
constexpr Tag kDistance{'D', 'I', 'S', 'T'};
constexpr Tag kGvd{'G', 'V', 'D', ' '};
constexpr Tag kGraph{'G', 'R', 'P', 'H'};
constexpr Tag kStats{'S', 'T', 'A', 'T'};
// Optional (files written before it have none): the dual edges' measured gaps.
constexpr Tag kGaps{'G', 'A', 'P', 'S'};

uint64_t fnv1a64(std::span<const uint8_t> bytes) {
  uint64_t h = 0xcbf29ce484222325ull;
  for (const uint8_t b : bytes) {
    h ^= b;
    h *= 0x100000001b3ull;
  }
  return h;
}

/// A tag as text for messages: printable ASCII as is, anything else as \xNN.
std::string tag_name(const Tag& tag) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string s = "\"";
  for (const char c : tag) {
    const auto u = static_cast<unsigned char>(c);
    if (u >= 0x20 && u < 0x7f && c != '"' && c != '\\') {
      s += c;
    } else {
      s += "\\x";
      s += kHex[u >> 4];
      s += kHex[u & 15];
    }
  }
  return s + "\"";
}

[[noreturn]] void bad_file(std::string detail) {
  throw Error(ErrorCode::kInvalidArgument, std::move(detail));
}

// ---------------------------------------------------------------------------------------------
// Writing
// ---------------------------------------------------------------------------------------------

/// Writes the file's bytes to a sink, hashing them as they go. A file is written in two
/// passes over the same calls: the first (no sink) only measures each section, so that the
/// second can put each section's length before its content without holding the file.
class Writer {
 public:
  using Sink = std::function<void(std::string_view)>;
  /// Measuring pass: appends each section's length to `lengths`.
  explicit Writer(std::vector<uint64_t>& lengths) : lengths_(lengths) {}
  /// Writing pass: takes the lengths the measuring pass found.
  Writer(std::vector<uint64_t>& lengths, const Sink& sink) : lengths_(lengths), sink_(&sink) {}

  void raw(const void* data, size_t size) {
    pos_ += size;
    if (sink_ == nullptr) return;
    const auto* p = static_cast<const uint8_t*>(data);
    for (size_t i = 0; i < size; ++i) {
      hash_ ^= p[i];
      hash_ *= 0x100000001b3ull;
    }
    (*sink_)(std::string_view(static_cast<const char*>(data), size));
  }
  void u32(uint32_t v) { raw(&v, sizeof v); }
  void u64(uint64_t v) { raw(&v, sizeof v); }
  void f64(double v) { raw(&v, sizeof v); }
  void vec3(Vec3 p) {
    f64(p.x);
    f64(p.y);
    f64(p.z);
  }
  template <class T>
  void array(const std::vector<T>& values) {
    static_assert(std::is_trivially_copyable_v<T> && std::has_unique_object_representations_v<T>,
                  "arrays are written as raw bytes: no padding, no pointers");
    u64(values.size());
    raw(values.data(), values.size() * sizeof(T));
  }
  void array(const std::vector<double>& values) {
    u64(values.size());
    raw(values.data(), values.size() * sizeof(double));
  }
  void array(const std::vector<Vec3>& values) {  // packed xyz doubles (layout asserted above)
    u64(values.size());
    raw(values.data(), values.size() * sizeof(Vec3));
  }
  void string(std::string_view text) {
    u64(text.size());
    raw(text.data(), text.size());
  }

  void begin_section(const Tag& tag) {
    GVD_CHECK(section_start_ == kNoSection, "sections do not nest");
    raw(tag.data(), tag.size());
    if (sink_ == nullptr) {
      u64(0);
    } else {
      GVD_CHECK(next_section_ < lengths_.size(), "a section the measuring pass did not see");
      u64(lengths_[next_section_++]);
    }
    section_start_ = pos_;
  }
  void end_section() {
    GVD_CHECK(section_start_ != kNoSection, "end_section without begin_section");
    if (sink_ == nullptr) {
      lengths_.push_back(pos_ - section_start_);
    } else {
      GVD_CHECK(lengths_[next_section_ - 1] == pos_ - section_start_,
                "a section changed between the passes");
    }
    section_start_ = kNoSection;
  }

  /// The checksum of everything written (writing pass), after it; returns the file's size.
  size_t finish() {
    GVD_CHECK(section_start_ == kNoSection, "unterminated section");
    u64(hash_);
    return pos_;
  }

 private:
  static constexpr size_t kNoSection = ~size_t{0};
  std::vector<uint64_t>& lengths_;
  const Sink* sink_ = nullptr;
  size_t pos_ = 0;
  size_t next_section_ = 0;
  uint64_t hash_ = 0xcbf29ce484222325ull;  // FNV-1a 64 (fnv1a64)
  size_t section_start_ = kNoSection;
};

Json stats_to_value(const ResultStats& s) {
  Json stages = Json::array();
  for (const StageStats& st : s.stages) {
    stages.push_back(
        {{"name", st.name}, {"seconds", st.seconds}, {"bytes", st.bytes}, {"items", st.items}});
  }
  Json value = {{"stages", std::move(stages)},
                {"backend", s.backend},
                {"threads", s.threads},
                {"max_depth", s.max_depth},
                {"depth", s.depth},
                {"leaves", s.leaves},
                {"vertices", s.vertices},
                {"octree_bytes", s.octree_bytes},
                {"bytes_per_leaf", s.bytes_per_leaf},
                {"distance_bytes", s.distance_bytes},
                {"gvd_simplices", s.gvd_simplices},
                {"graph_edges", s.graph_edges},
                {"refine_rounds", s.refine_rounds},
                {"ambiguous_cells_left", s.ambiguous_at_limit},
                {"thin_regions_left", s.unseen_left},
                {"touching_leaves", s.touching_leaves},
                {"certified_leaves", s.certified_leaves},
                {"total_seconds", s.total_seconds},
                {"peak_rss_bytes", s.peak_rss_bytes},
                {"start_rss_bytes", s.start_rss_bytes}};
  if (!s.job.empty()) value["job"] = s.job;  // files of the CLI keep their bytes
  return value;
}

size_t expected_size(const GvdResult& r) {
  size_t n = 4096 + r.scene.simplex_count() * 40 + r.scene.vertex_count() * 60;
  n += r.octree.leaf_count() * 13;
  n += r.field.size() * 17 + r.field.closest.size() * 24;
  for (const GvdCell& c : r.gvd.cells) n += c.positions.size() * 36 + c.indices.size() * 4 + 64;
  n += r.graph.edges.size() * 48;
  return n;
}

// ---------------------------------------------------------------------------------------------
// Reading
// ---------------------------------------------------------------------------------------------

/// A bounds-checked cursor over one section's payload. Messages name the section and the byte
/// offset in the file.
class Reader {
 public:
  Reader(std::span<const uint8_t> bytes, size_t file_offset, std::string section)
      : bytes_(bytes), base_(file_offset), section_(std::move(section)) {}

  size_t remaining() const { return bytes_.size() - pos_; }

  [[noreturn]] void fail(const std::string& what) const {
    bad_file("section " + section_ + " at byte " + std::to_string(base_ + pos_) + ": " + what);
  }

  void raw(void* out, size_t size, const char* what) {
    if (size > remaining()) {
      fail(std::string(what) + " needs " + std::to_string(size) + " bytes but only " +
           std::to_string(remaining()) + " remain in the section");
    }
    if (size > 0) std::memcpy(out, bytes_.data() + pos_, size);
    pos_ += size;
  }
  uint32_t u32(const char* what) {
    uint32_t v = 0;
    raw(&v, sizeof v, what);
    return v;
  }
  uint64_t u64(const char* what) {
    uint64_t v = 0;
    raw(&v, sizeof v, what);
    return v;
  }
  double f64(const char* what) {
    double v = 0;
    raw(&v, sizeof v, what);
    return v;
  }
  Vec3 vec3(const char* what) {
    Vec3 p;
    raw(&p, sizeof p, what);
    return p;
  }
  /// A u64 count and that many elements; the count is checked against the remaining bytes
  /// before anything is allocated.
  template <class T>
  std::vector<T> array(const char* what) {
    static_assert(std::is_trivially_copyable_v<T>);
    const uint64_t count = u64(what);
    if (count > remaining() / sizeof(T)) {
      fail(std::string(what) + " has " + std::to_string(count) + " elements of " +
           std::to_string(sizeof(T)) + " bytes, but only " + std::to_string(remaining()) +
           " bytes remain in the section");
    }
    std::vector<T> values(static_cast<size_t>(count));
    raw(values.data(), values.size() * sizeof(T), what);
    return values;
  }
  std::string string(const char* what) {
    const uint64_t size = u64(what);
    if (size > remaining()) {
      fail(std::string(what) + " has " + std::to_string(size) + " bytes, but only " +
           std::to_string(remaining()) + " remain in the section");
    }
    std::string text(reinterpret_cast<const char*>(bytes_.data() + pos_),
                     static_cast<size_t>(size));
    pos_ += static_cast<size_t>(size);
    return text;
  }
  /// A count of records that each take at least `min_record_bytes` (checked like an array).
  uint64_t count(const char* what, size_t min_record_bytes) {
    const uint64_t n = u64(what);
    if (n > remaining() / min_record_bytes) {
      fail(std::string(what) + " = " + std::to_string(n) + " does not fit the " +
           std::to_string(remaining()) + " bytes that remain in the section");
    }
    return n;
  }
  void expect_end() const {
    if (remaining() != 0) fail(std::to_string(remaining()) + " unexpected bytes at the end");
  }

 private:
  std::span<const uint8_t> bytes_;
  size_t pos_ = 0;
  size_t base_;
  std::string section_;
};

struct Section {
  std::span<const uint8_t> payload;
  size_t offset = 0;  ///< of the payload in the file
};

/// Splits the section area into known sections (unknown tags are skipped; a known tag twice is
/// an error).
std::map<Tag, Section> split_sections(std::span<const uint8_t> bytes) {
  const std::array<Tag, 8> known{kScene, kDomain, kOctree, kDistance, kGvd, kGraph, kStats, kGaps};
  std::map<Tag, Section> sections;
  const size_t end = bytes.size() - kTrailerBytes;
  size_t pos = kHeaderBytes;
  while (pos < end) {
    if (end - pos < kSectionHeaderBytes) {
      bad_file("truncated section header at byte " + std::to_string(pos) + ": " +
               std::to_string(end - pos) + " bytes before the checksum, a header needs " +
               std::to_string(kSectionHeaderBytes));
    }
    Tag tag;
    std::memcpy(tag.data(), bytes.data() + pos, tag.size());
    uint64_t length = 0;
    std::memcpy(&length, bytes.data() + pos + 4, sizeof length);
    const size_t payload = pos + kSectionHeaderBytes;
    if (length > end - payload) {
      bad_file("section " + tag_name(tag) + " at byte " + std::to_string(pos) + " claims " +
               std::to_string(length) + " bytes but runs past the end: only " +
               std::to_string(end - payload) + " bytes remain before the checksum");
    }
    if (std::find(known.begin(), known.end(), tag) != known.end()) {
      const auto [it, inserted] =
          sections.emplace(tag, Section{bytes.subspan(payload, length), payload});
      if (!inserted) {
        bad_file("duplicate section " + tag_name(tag) + " at byte " + std::to_string(pos) +
                 " (first at byte " + std::to_string(it->second.offset - kSectionHeaderBytes) +
                 ")");
      }
    }
    pos = payload + static_cast<size_t>(length);
  }
  for (const Tag& tag : known) {
    if (!sections.count(tag) && tag != kGaps) bad_file("missing section " + tag_name(tag));
  }
  return sections;
}

Reader reader_for(const std::map<Tag, Section>& sections, const Tag& tag) {
  const Section& s = sections.at(tag);
  return Reader(s.payload, s.offset, tag_name(tag));
}

int read_dimension(Reader& in) {
  const uint32_t dim = in.u32("dimension");
  if (dim != 2 && dim != 3) in.fail("dimension must be 2 or 3, got " + std::to_string(dim));
  return static_cast<int>(dim);
}

Scene read_scene(Reader in) {
  const std::string text = in.string("scene JSON");
  const std::string warnings_text = in.string("warnings JSON");
  in.expect_end();
  // The scene was validated when it was computed; the limits of the build that computed it
  // may have been larger than today's defaults, so none apply here.
  SceneLimits limits;
  limits.max_objects = std::numeric_limits<uint64_t>::max();
  limits.max_simplices = std::numeric_limits<uint64_t>::max();
  limits.max_abs_coordinate = std::numeric_limits<double>::max();
  Scene scene;
  try {
    scene = parse_scene_json(text, limits);
  } catch (const Error& e) {
    in.fail("the stored scene does not parse: " + std::string(e.what()));
  }
  // Validation recomputes topology warnings; the stored list (which also holds the
  // pipeline's warnings) is the one of record.
  scene.warnings.clear();
  try {
    scene.warnings = warnings_from_json(warnings_text);
  } catch (const Error& e) {
    in.fail("the stored warnings: " + e.detail());
  }
  return scene;
}

Domain read_domain(Reader in) {
  Domain d;
  d.dimension = read_dimension(in);
  d.origin = in.vec3("origin");
  d.side = in.f64("side");
  // The octree's frame, when it is not the user's axes (files without it: the user's).
  if (in.remaining() > 0) {
    for (Vec3& a : d.axis) a = in.vec3("axis");
  }
  in.expect_end();
  if (!std::isfinite(d.origin.x) || !std::isfinite(d.origin.y) || !std::isfinite(d.origin.z) ||
      !std::isfinite(d.side) || !(d.side > 0)) {
    in.fail("the domain must have a finite origin and a positive finite side");
  }
  // A rotation, to rounding.
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      const double want = i == j ? 1 : 0;
      if (!(std::abs(dot(d.axis[i], d.axis[j]) - want) <= 1e-12))
        in.fail("the domain's axes are not orthonormal");
    }
  }
  if (!(dot(cross(d.axis[0], d.axis[1]), d.axis[2]) > 0))
    in.fail("the domain's axes are a reflection");
  if (d.dimension == 2 && !d.aligned()) in.fail("a 2D domain must have the user's axes");
  return d;
}

Octree read_octree(Reader in) {
  Octree o;
  o.dimension = read_dimension(in);
  const uint32_t max_depth = in.u32("max_depth");
  const uint32_t depth = in.u32("depth");
  if (max_depth > static_cast<uint32_t>(lattice_bits(o.dimension)) || depth > max_depth) {
    in.fail("depth " + std::to_string(depth) + " / max_depth " + std::to_string(max_depth) +
            " out of range (the lattice has " + std::to_string(lattice_bits(o.dimension)) +
            " levels)");
  }
  o.max_depth = static_cast<int>(max_depth);
  o.depth = static_cast<int>(depth);
  const uint64_t leaves = in.count("leaf count", sizeof(uint64_t) + 1 + sizeof(ObjectId));
  o.code = in.array<uint64_t>("code[]");
  o.level = in.array<uint8_t>("level[]");
  o.object = in.array<ObjectId>("object[]");
  in.expect_end();
  if (o.code.size() != leaves || o.level.size() != leaves || o.object.size() != leaves) {
    in.fail("leaf count " + std::to_string(leaves) + " but " + std::to_string(o.code.size()) +
            " codes, " + std::to_string(o.level.size()) + " levels, " +
            std::to_string(o.object.size()) + " objects");
  }
  return o;
}

DistanceField read_distance(Reader in) {
  DistanceField f;
  f.vertices.dimension = read_dimension(in);
  f.vertices.key = in.array<uint64_t>("key[]");
  f.label = in.array<ObjectId>("label[]");
  f.point = in.array<uint32_t>("point[]");
  f.closest = in.array<Vec3>("closest[]");
  f.exact = in.array<uint8_t>("exact[]");
  f.exact_count = in.u64("exact_count");
  f.exact_reused = in.u64("exact_reused");
  f.exact_near_gvd = in.u64("exact_near_gvd");
  in.expect_end();
  const size_t n = f.vertices.key.size();
  if (f.label.size() != n || f.point.size() != n || f.exact.size() != n) {
    in.fail(std::to_string(n) + " vertex keys but " + std::to_string(f.label.size()) + " labels, " +
            std::to_string(f.point.size()) + " points, " + std::to_string(f.exact.size()) +
            " exact flags");
  }
  return f;
}

Gvd read_gvd(Reader in) {
  Gvd g;
  g.dimension = read_dimension(in);
  // A cell takes at least its object id and five array counts.
  const uint64_t cells = in.count("cell count", sizeof(ObjectId) + 4 * sizeof(uint64_t));
  g.cells.resize(static_cast<size_t>(cells));
  for (GvdCell& c : g.cells) {
    c.object = in.u32("cell object");
    c.positions = in.array<Vec3>("positions[]");
    c.other = in.array<ObjectId>("other[]");
    c.clearance = in.array<double>("clearance[]");
    c.indices = in.array<uint32_t>("indices[]");
  }
  in.expect_end();
  return g;
}

DualGraph read_graph(Reader in) {
  DualGraph g;
  g.node_count = in.u32("node_count");
  const uint64_t edges = in.count("edge count", 2 * sizeof(ObjectId) + 5 * sizeof(double));
  const auto a = in.array<ObjectId>("a[]");
  const auto b = in.array<ObjectId>("b[]");
  const auto area = in.array<double>("area[]");
  const auto min_clearance = in.array<double>("min_clearance[]");
  const auto tightest = in.array<Vec3>("tightest_point[]");
  in.expect_end();
  if (a.size() != edges || b.size() != edges || area.size() != edges ||
      min_clearance.size() != edges || tightest.size() != edges) {
    in.fail("edge count " + std::to_string(edges) + " disagrees with the edge arrays");
  }
  g.edges.resize(static_cast<size_t>(edges));
  for (size_t i = 0; i < g.edges.size(); ++i) {
    g.edges[i] = {a[i], b[i], area[i], min_clearance[i], tightest[i]};
  }
  return g;
}

void read_gaps(Reader in, DualGraph& g) {
  const auto gap = in.array<double>("gap[]");
  const auto touching = in.array<uint8_t>("touching[]");
  in.expect_end();
  if (gap.size() != g.edges.size() || touching.size() != g.edges.size()) {
    in.fail("the gap arrays have " + std::to_string(gap.size()) + " / " +
            std::to_string(touching.size()) + " entries for " + std::to_string(g.edges.size()) +
            " graph edges");
  }
  for (size_t i = 0; i < g.edges.size(); ++i) {
    if (!(gap[i] >= 0 || gap[i] == -1) || touching[i] > 1) {
      in.fail("graph edge " + std::to_string(i) + " has an invalid gap or touching flag");
    }
    g.edges[i].gap = gap[i];
    g.edges[i].touching = touching[i] != 0;
  }
}

ResultStats read_stats(Reader in) {
  const std::string text = in.string("statistics JSON");
  in.expect_end();
  try {
    return stats_from_json(text);
  } catch (const Error& e) {
    in.fail(e.detail());
  }
}

/// Cross-section consistency: every index a later stage dereferences is in range.
void check_consistency(const GvdResult& r) {
  const int dim = r.scene.dimension;
  const auto fail = [](const std::string& what) { bad_file("inconsistent result: " + what); };
  if (r.domain.dimension != dim || r.octree.dimension != dim || r.field.vertices.dimension != dim ||
      r.gvd.dimension != dim) {
    fail("dimensions disagree (scene " + std::to_string(dim) + ", domain " +
         std::to_string(r.domain.dimension) + ", octree " + std::to_string(r.octree.dimension) +
         ", distance " + std::to_string(r.field.vertices.dimension) + ", gvd " +
         std::to_string(r.gvd.dimension) + ")");
  }
  const uint64_t objects = r.scene.objects.size();
  const auto is_object_or_none = [&](ObjectId id) { return id == kNoObject || id < objects; };

  const Octree& o = r.octree;
  if (o.leaf_count() == 0) fail("the octree has no leaves");
  if (o.code[0] != 0) fail("the first octree leaf is not at the origin");
  for (size_t i = 0; i < o.leaf_count(); ++i) {
    if (i > 0 && o.code[i] <= o.code[i - 1]) {
      fail("octree leaf codes are not strictly increasing at leaf " + std::to_string(i));
    }
    if (o.level[i] > o.max_depth) {
      fail("octree leaf " + std::to_string(i) + " has level " + std::to_string(o.level[i]) +
           " beyond max_depth " + std::to_string(o.max_depth));
    }
    if (!is_object_or_none(o.object[i]) && o.object[i] != kManyObjects) {
      fail("octree leaf " + std::to_string(i) + " has object " + std::to_string(o.object[i]) +
           " of " + std::to_string(objects));
    }
  }

  const DistanceField& f = r.field;
  for (size_t v = 0; v < f.size(); ++v) {
    const uint64_t key = f.vertices.key[v];
    if (key == FlatMap64::kEmptyKey || (v > 0 && key <= f.vertices.key[v - 1])) {
      fail("vertex keys are not strictly increasing at vertex " + std::to_string(v));
    }
    if (!is_object_or_none(f.label[v])) {
      fail("vertex " + std::to_string(v) + " has label " + std::to_string(f.label[v]) + " of " +
           std::to_string(objects) + " objects");
    }
    if (f.point[v] != kNoVertex && f.point[v] >= f.closest.size()) {
      fail("vertex " + std::to_string(v) + " has closest point " + std::to_string(f.point[v]) +
           " of " + std::to_string(f.closest.size()));
    }
  }

  if (r.gvd.cells.size() > objects) {
    fail(std::to_string(r.gvd.cells.size()) + " GVD cells for " + std::to_string(objects) +
         " objects");
  }
  const size_t arity = dim == 2 ? 2 : 3;
  for (size_t ci = 0; ci < r.gvd.cells.size(); ++ci) {
    const GvdCell& c = r.gvd.cells[ci];
    const std::string where = "GVD cell " + std::to_string(ci);
    if (!is_object_or_none(c.object)) fail(where + " has object " + std::to_string(c.object));
    if (c.other.size() != c.positions.size() || c.clearance.size() != c.positions.size()) {
      fail(where + " has " + std::to_string(c.positions.size()) + " positions but " +
           std::to_string(c.other.size()) + " other ids and " + std::to_string(c.clearance.size()) +
           " clearances");
    }
    if (c.indices.size() % arity != 0) {
      fail(where + " has " + std::to_string(c.indices.size()) + " indices, not a multiple of " +
           std::to_string(arity));
    }
    for (size_t k = 0; k < c.indices.size(); ++k) {
      if (c.indices[k] >= c.positions.size()) {
        fail(where + " index " + std::to_string(k) + " = " + std::to_string(c.indices[k]) +
             " is out of range");
      }
    }
    for (size_t k = 0; k < c.other.size(); ++k) {
      if (!is_object_or_none(c.other[k])) {
        fail(where + " vertex " + std::to_string(k) + " has other object " +
             std::to_string(c.other[k]));
      }
    }
  }

  if (r.graph.node_count > objects) {
    fail("the graph has " + std::to_string(r.graph.node_count) + " nodes for " +
         std::to_string(objects) + " objects");
  }
  for (size_t e = 0; e < r.graph.edges.size(); ++e) {
    const DualEdge& edge = r.graph.edges[e];
    if (edge.a >= r.graph.node_count || edge.b >= r.graph.node_count) {
      fail("graph edge " + std::to_string(e) + " (" + std::to_string(edge.a) + ", " +
           std::to_string(edge.b) + ") is out of range");
    }
  }
}

}  // namespace

// ---------------------------------------------------------------------------------------------

namespace {

void write_result(const GvdResult& r, Writer& out) {
  out.raw(kMagic, sizeof kMagic);
  out.u32(kResultFormatVersion);
  out.u32(kAlgorithmVersion);

  out.begin_section(kScene);
  out.string(scene_to_json(r.scene));
  out.string(warnings_to_json(r.scene.warnings));
  out.end_section();

  out.begin_section(kDomain);
  out.u32(static_cast<uint32_t>(r.domain.dimension));
  out.vec3(r.domain.origin);
  out.f64(r.domain.side);
  if (!r.domain.aligned()) {
    for (const Vec3& a : r.domain.axis) out.vec3(a);
  }
  out.end_section();

  out.begin_section(kOctree);
  out.u32(static_cast<uint32_t>(r.octree.dimension));
  out.u32(static_cast<uint32_t>(r.octree.max_depth));
  out.u32(static_cast<uint32_t>(r.octree.depth));
  out.u64(r.octree.leaf_count());
  out.array(r.octree.code);
  out.array(r.octree.level);
  out.array(r.octree.object);
  out.end_section();

  out.begin_section(kDistance);
  out.u32(static_cast<uint32_t>(r.field.vertices.dimension));
  out.array(r.field.vertices.key);
  out.array(r.field.label);
  out.array(r.field.point);
  out.array(r.field.closest);
  out.array(r.field.exact);
  out.u64(r.field.exact_count);
  out.u64(r.field.exact_reused);
  out.u64(r.field.exact_near_gvd);
  out.end_section();

  out.begin_section(kGvd);
  out.u32(static_cast<uint32_t>(r.gvd.dimension));
  out.u64(r.gvd.cells.size());
  for (const GvdCell& c : r.gvd.cells) {
    out.u32(c.object);
    out.array(c.positions);
    out.array(c.other);
    out.array(c.clearance);
    out.array(c.indices);
  }
  out.end_section();

  out.begin_section(kGraph);
  out.u32(r.graph.node_count);
  const size_t edges = r.graph.edges.size();
  out.u64(edges);
  std::vector<ObjectId> a(edges), b(edges);
  std::vector<double> area(edges), min_clearance(edges);
  std::vector<Vec3> tightest(edges);
  for (size_t i = 0; i < edges; ++i) {
    const DualEdge& e = r.graph.edges[i];
    a[i] = e.a;
    b[i] = e.b;
    area[i] = e.area;
    min_clearance[i] = e.min_clearance;
    tightest[i] = e.tightest_point;
  }
  out.array(a);
  out.array(b);
  out.array(area);
  out.array(min_clearance);
  out.array(tightest);
  out.end_section();

  out.begin_section(kGaps);
  std::vector<double> gap(edges);
  std::vector<uint8_t> touching(edges);
  for (size_t i = 0; i < edges; ++i) {
    gap[i] = r.graph.edges[i].gap;
    touching[i] = r.graph.edges[i].touching ? 1 : 0;
  }
  out.array(gap);
  out.array(touching);
  out.end_section();

  out.begin_section(kStats);
  out.string(stats_to_json(r.stats));
  out.end_section();
}

/// The file's bytes handed to `sink` in order (the two passes of Writer); returns its size.
size_t write_result(const GvdResult& r, const Writer::Sink& sink) {
  std::vector<uint64_t> lengths;
  Writer measure(lengths);
  write_result(r, measure);
  Writer out(lengths, sink);
  write_result(r, out);
  return out.finish();
}

}  // namespace

std::vector<uint8_t> result_to_bytes(const GvdResult& r) {
  std::vector<uint8_t> bytes;
  bytes.reserve(expected_size(r));
  write_result(
      r, [&](std::string_view piece) { bytes.insert(bytes.end(), piece.begin(), piece.end()); });
  return bytes;
}

void save_result(const GvdResult& result, const std::string& path) {
  // Streamed into the file: a large result is not held a second time as bytes.
  write_file_atomic(path, [&](const Writer::Sink& put) { write_result(result, put); });
}

ResultFileHeader read_result_header(std::span<const uint8_t> bytes) {
  if (bytes.size() < sizeof kMagic || std::memcmp(bytes.data(), kMagic, sizeof kMagic) != 0) {
    bad_file(bytes.empty() ? "not a gvd result: the file is empty"
                           : "not a gvd result: the file does not start with the magic "
                             "\"GVDRES\\0\\1\"");
  }
  if (bytes.size() < kHeaderBytes) {
    bad_file("truncated gvd result: " + std::to_string(bytes.size()) +
             " bytes, the header alone needs " + std::to_string(kHeaderBytes));
  }
  ResultFileHeader h;
  std::memcpy(&h.format_version, bytes.data() + 8, 4);
  std::memcpy(&h.algorithm_version, bytes.data() + 12, 4);
  if (h.format_version != kResultFormatVersion) {
    bad_file(
        "unsupported result format version " + std::to_string(h.format_version) +
        ": this build reads version " + std::to_string(kResultFormatVersion) +
        (h.format_version > kResultFormatVersion ? " (the file was written by a newer gvd)" : ""));
  }
  return h;
}

GvdResult load_result_bytes(std::span<const uint8_t> bytes) {
  read_result_header(bytes);
  if (bytes.size() < kHeaderBytes + kTrailerBytes) {
    bad_file("truncated gvd result: " + std::to_string(bytes.size()) +
             " bytes, shorter than a header and checksum");
  }
  const size_t body = bytes.size() - kTrailerBytes;
  uint64_t stored = 0;
  std::memcpy(&stored, bytes.data() + body, sizeof stored);
  if (fnv1a64(bytes.first(body)) != stored) {
    bad_file("checksum mismatch over " + std::to_string(body) +
             " bytes: the file is truncated or corrupted");
  }

  const std::map<Tag, Section> sections = split_sections(bytes);
  GvdResult r;
  r.scene = read_scene(reader_for(sections, kScene));
  r.domain = read_domain(reader_for(sections, kDomain));
  r.octree = read_octree(reader_for(sections, kOctree));
  r.field = read_distance(reader_for(sections, kDistance));
  r.gvd = read_gvd(reader_for(sections, kGvd));
  r.graph = read_graph(reader_for(sections, kGraph));
  if (sections.count(kGaps) != 0) read_gaps(reader_for(sections, kGaps), r.graph);
  r.stats = read_stats(reader_for(sections, kStats));
  check_consistency(r);

  try {
    r.geometry = make_unit_geometry(r.scene, r.domain);
  } catch (const Error& e) {
    bad_file("the stored scene does not fit the stored domain: " + e.detail());
  }
  r.field.vertices.rebuild_index();
  return r;
}

GvdResult load_result(const std::string& path) {
  const std::vector<uint8_t> bytes = read_file_bytes(path);
  try {
    return load_result_bytes(bytes);
  } catch (const InternalError&) {
    throw;
  } catch (const Error& e) {
    throw Error(e.code(), path + ": " + e.detail(), e.where());
  }
}

// ---------------------------------------------------------------------------------------------

std::string stats_to_json(const ResultStats& stats) {
  return stats_to_value(stats).dump(-1, ' ', false, Json::error_handler_t::replace);
}

ResultStats stats_from_json(std::string_view text) {
  ResultStats s;
  try {
    const Json j = Json::parse(text.begin(), text.end());
    if (!j.is_object()) bad_file("the statistics must be a JSON object");
    s.backend = j.value("backend", s.backend);
    s.threads = j.value("threads", s.threads);
    s.max_depth = j.value("max_depth", s.max_depth);
    s.depth = j.value("depth", s.depth);
    s.leaves = j.value("leaves", s.leaves);
    s.vertices = j.value("vertices", s.vertices);
    s.octree_bytes = j.value("octree_bytes", s.octree_bytes);
    s.bytes_per_leaf = j.value("bytes_per_leaf", s.bytes_per_leaf);
    s.distance_bytes = j.value("distance_bytes", s.distance_bytes);
    s.gvd_simplices = j.value("gvd_simplices", s.gvd_simplices);
    s.graph_edges = j.value("graph_edges", s.graph_edges);
    s.refine_rounds = j.value("refine_rounds", s.refine_rounds);
    s.ambiguous_at_limit = j.value("ambiguous_cells_left", s.ambiguous_at_limit);
    s.unseen_left = j.value("thin_regions_left", s.unseen_left);
    s.touching_leaves = j.value("touching_leaves", s.touching_leaves);
    s.certified_leaves = j.value("certified_leaves", s.certified_leaves);
    s.total_seconds = j.value("total_seconds", s.total_seconds);
    s.peak_rss_bytes = j.value("peak_rss_bytes", s.peak_rss_bytes);
    s.start_rss_bytes = j.value("start_rss_bytes", s.start_rss_bytes);
    s.job = j.value("job", s.job);
    if (const auto it = j.find("stages"); it != j.end()) {
      for (const Json& st : it->get_ref<const Json::array_t&>()) {
        s.stages.push_back({st.at("name").get<std::string>(), st.at("seconds").get<double>(),
                            st.at("bytes").get<uint64_t>(), st.at("items").get<uint64_t>()});
      }
    }
  } catch (const Json::exception& e) {
    bad_file(std::string("malformed statistics JSON: ") + e.what());
  }
  return s;
}

std::string result_info_json(const GvdResult& r) {
  // The stats as stored, plus what describes the scene and domain, and the warnings.
  Json doc = stats_to_value(r.stats);
  const int dim = r.scene.dimension;
  const Vec3 o = r.domain.origin;
  doc["dimension"] = dim;
  doc["objects"] = r.scene.objects.size();
  doc["simplices"] = r.scene.simplex_count();
  if (!r.scene.units.empty()) doc["units"] = r.scene.units;  // lengths below are in them
  doc["domain"] = {{"origin", dim == 2 ? Json::array({o.x, o.y}) : Json::array({o.x, o.y, o.z})},
                   {"side", r.domain.side}};
  if (!r.domain.aligned()) {
    Json axes = Json::array();
    for (const Vec3& a : r.domain.axis) axes.push_back(Json::array({a.x, a.y, a.z}));
    doc["domain"]["axes"] = std::move(axes);
  }
  doc["warnings"] = Json::parse(warnings_to_json(r.scene.warnings));
  // When a uniform grid would do (grid_advice.h): null when no gap was measured.
  const GridAdvice advice = grid_advice(r.scene, r.graph);
  if (advice.measured) {
    Json grid = {{"closest_gap", advice.gap},
                 {"touching_pairs", advice.touching_pairs},
                 {"longest_side", advice.longest_side},
                 {"cell_limit", advice.cell_limit}};
    if (advice.gap > 0) {
      grid["pair"] = {r.scene.objects[advice.a].label, r.scene.objects[advice.b].label};
      grid["resolution"] = advice.resolution;
      grid["cells"] = advice.cells;
      grid["fits_cell_limit"] = advice.fits;
    } else {
      grid["pair"] = nullptr;
      grid["resolution"] = nullptr;
      grid["cells"] = nullptr;
      grid["fits_cell_limit"] = false;
    }
    doc["grid"] = std::move(grid);
  } else {
    doc["grid"] = nullptr;
  }
  return doc.dump(-1, ' ', false, Json::error_handler_t::replace);
}

}  // namespace gvd::io
