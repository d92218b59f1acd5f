// Readers of the plain mesh formats: OBJ (groups = objects), PLY (ascii and binary), STL (ascii
// and binary, welded), OFF. They build an unvalidated Scene; parse_scene_bytes validates it.
#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include "gvd/common/error.h"
#include "gvd/scene/load_scene.h"

namespace gvd::scene {

// Entry points used by load_scene.cpp (declared there; one definition each, here).
Scene parse_obj(std::string_view text, const std::string& name, bool single_object,
                const SceneLimits& limits);
Scene parse_ply(std::span<const uint8_t> bytes, const std::string& name, const SceneLimits& limits);
Scene parse_stl(std::span<const uint8_t> bytes, const std::string& name, const SceneLimits& limits);
Scene parse_off(std::string_view text, const std::string& name, const SceneLimits& limits);
bool is_binary_stl(std::span<const uint8_t> bytes);

namespace {

[[noreturn]] void invalid(std::string detail) {
  throw Error(ErrorCode::kInvalidScene, std::move(detail));
}

// An error at byte `offset` (0-based) of a binary file: the detail names the byte,
// ErrorLocation::offset holds it.
[[noreturn]] void invalid_at_byte(uint64_t offset, std::string detail) {
  ErrorLocation where;
  where.offset = static_cast<int64_t>(offset);
  throw Error(ErrorCode::kInvalidScene, std::move(detail), where);
}

// An error on line `line` (1-based) of a text format: the detail says it, ErrorLocation::line
// holds it.
[[noreturn]] void invalid_at(size_t line, std::string detail) {
  ErrorLocation where;
  where.line = static_cast<int64_t>(line);
  throw Error(ErrorCode::kInvalidScene, std::move(detail), where);
}

void check_simplex_limit(uint64_t count, const SceneLimits& limits, const std::string& name) {
  if (count > limits.max_simplices) {
    throw Error(ErrorCode::kLimitExceeded, "\"" + name + "\" has more than the limit of " +
                                               std::to_string(limits.max_simplices) + " triangles");
  }
}

bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v';
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && is_space(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_space(s.back())) s.remove_suffix(1);
  return s;
}

/// Splits on blanks (spaces, tabs, CR).
std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> out;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_space(line[i])) ++i;
    size_t j = i;
    while (j < line.size() && !is_space(line[j])) ++j;
    if (j > i) out.push_back(line.substr(i, j - i));
    i = j;
  }
  return out;
}

/// Calls f(line_number, line) for every line (1-based numbers, '\n' or "\r\n" ends).
template <class F>
void for_each_line(std::string_view text, F&& f) {
  size_t start = 0, number = 1;
  while (start < text.size()) {
    size_t end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    f(number, text.substr(start, end - start));
    start = end + 1;
    ++number;
  }
}

bool parse_double(std::string_view s, double& out) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  if (s.empty()) return false;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && ptr == s.data() + s.size();
}

bool parse_int(std::string_view s, int64_t& out) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  if (s.empty()) return false;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && ptr == s.data() + s.size();
}

/// Appends the fan triangulation (c0, ci, ci+1) of a polygon.
void fan(const std::vector<uint32_t>& polygon, std::vector<Simplex>& out) {
  for (size_t i = 1; i + 1 < polygon.size(); ++i) {
    out.push_back(Simplex{{polygon[0], polygon[i], polygon[i + 1]}});
  }
}

Scene one_object_scene(const std::string& name, std::vector<Vec3> vertices,
                       std::vector<Simplex> simplices) {
  Scene scene;
  scene.dimension = 3;
  scene.objects.push_back(SceneObject{name, std::move(vertices), std::move(simplices)});
  return scene;
}

// ---------------------------------------------------------------------------------- PLY

enum class PlyType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

bool ply_type(std::string_view s, PlyType& t) {
  static const std::pair<std::string_view, PlyType> kNames[] = {
      {"char", PlyType::kInt8},      {"int8", PlyType::kInt8},       {"uchar", PlyType::kUint8},
      {"uint8", PlyType::kUint8},    {"short", PlyType::kInt16},     {"int16", PlyType::kInt16},
      {"ushort", PlyType::kUint16},  {"uint16", PlyType::kUint16},   {"int", PlyType::kInt32},
      {"int32", PlyType::kInt32},    {"uint", PlyType::kUint32},     {"uint32", PlyType::kUint32},
      {"float", PlyType::kFloat32},  {"float32", PlyType::kFloat32}, {"double", PlyType::kFloat64},
      {"float64", PlyType::kFloat64}};
  for (const auto& [n, type] : kNames) {
    if (s == n) {
      t = type;
      return true;
    }
  }
  return false;
}

size_t ply_size(PlyType t) {
  switch (t) {
    case PlyType::kInt8:
    case PlyType::kUint8:
      return 1;
    case PlyType::kInt16:
    case PlyType::kUint16:
      return 2;
    case PlyType::kInt32:
    case PlyType::kUint32:
    case PlyType::kFloat32:
      return 4;
    case PlyType::kFloat64:
      return 8;
  }
  return 1;
}

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::kFloat32;
  bool is_list = false;
  PlyType count_type = PlyType::kUint8;
};

struct PlyElement {
  std::string name;
  uint64_t count = 0;
  std::vector<PlyProperty> properties;
};

enum class PlyFormat { kAscii, kLittle, kBig };

/// Reads the values of the body one by one, in either encoding.
class PlyReader {
 public:
  /// Where the next value starts in the file.
  size_t offset() const { return base_ + pos_; }
  /// `base`: where the body starts in the file (error offsets are the file's).
  PlyReader(std::span<const uint8_t> body, PlyFormat format, const std::string& name, size_t base)
      : body_(body), format_(format), name_(name), base_(base) {}

  double read(PlyType t, const std::string& where) {
    if (format_ == PlyFormat::kAscii) {
      while (pos_ < body_.size() && is_space(static_cast<char>(body_[pos_]))) ++pos_;
      const size_t start = pos_;
      while (pos_ < body_.size() && !is_space(static_cast<char>(body_[pos_]))) ++pos_;
      if (pos_ == start) {
        invalid_at_byte(base_ + pos_, "PLY \"" + name_ + "\" is truncated at " + where +
                                          ": the file ends at byte " +
                                          std::to_string(base_ + pos_));
      }
      const std::string_view token(reinterpret_cast<const char*>(body_.data()) + start,
                                   pos_ - start);
      double v = 0;
      if (!parse_double(token, v)) {
        invalid("PLY \"" + name_ + "\": " + where + ": \"" + std::string(token) +
                "\" is not a number");
      }
      return v;
    }
    const size_t n = ply_size(t);
    if (body_.size() - pos_ < n) {
      invalid_at_byte(base_ + pos_, "PLY \"" + name_ + "\" is truncated at " + where + " (byte " +
                                        std::to_string(base_ + pos_) + "): " + std::to_string(n) +
                                        " bytes needed, " + std::to_string(body_.size() - pos_) +
                                        " left");
    }
    uint8_t raw[8];
    std::memcpy(raw, body_.data() + pos_, n);
    pos_ += n;
    const bool swap = (format_ == PlyFormat::kBig) == (std::endian::native == std::endian::little);
    if (swap) std::reverse(raw, raw + n);
    switch (t) {
      case PlyType::kInt8:
        return static_cast<int8_t>(raw[0]);
      case PlyType::kUint8:
        return raw[0];
      case PlyType::kInt16:
        return load<int16_t>(raw);
      case PlyType::kUint16:
        return load<uint16_t>(raw);
      case PlyType::kInt32:
        return load<int32_t>(raw);
      case PlyType::kUint32:
        return load<uint32_t>(raw);
      case PlyType::kFloat32:
        return load<float>(raw);
      case PlyType::kFloat64:
        return load<double>(raw);
    }
    return 0;
  }

  size_t remaining() const { return body_.size() - pos_; }

 private:
  template <class T>
  static double load(const uint8_t* raw) {
    T v;
    std::memcpy(&v, raw, sizeof(T));
    return static_cast<double>(v);
  }

  std::span<const uint8_t> body_;
  size_t pos_ = 0;
  PlyFormat format_;
  const std::string& name_;
  size_t base_;
};

// ---------------------------------------------------------------------------------- STL

uint32_t read_le32(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) | static_cast<uint32_t>(p[1]) << 8 |
         static_cast<uint32_t>(p[2]) << 16 | static_cast<uint32_t>(p[3]) << 24;
}

/// Merges exactly identical positions (STL stores every triangle corner separately).
class Welder {
 public:
  uint32_t add(Vec3 p) {
    for (int i = 0; i < 3; ++i) p[i] += 0.0;  // -0 and +0 are the same position
    auto [it, inserted] = index_.emplace(p, static_cast<uint32_t>(vertices.size()));
    if (inserted) vertices.push_back(p);
    return it->second;
  }
  std::vector<Vec3> vertices;

 private:
  std::unordered_map<Vec3, uint32_t, PositionHash> index_;
};

}  // namespace

// ---------------------------------------------------------------------------------- OBJ

Scene parse_obj(std::string_view text, const std::string& name, bool single_object,
                const SceneLimits& limits) {
  struct Group {
    std::string label;
    std::vector<uint32_t> corners;  // global vertex indices, 3 per triangle
  };
  std::vector<Vec3> vertices;
  std::vector<Group> groups;
  std::unordered_map<std::string, size_t> group_of;
  size_t current = 0;
  auto open_group = [&](const std::string& label) {
    auto [it, inserted] = group_of.emplace(label, groups.size());
    if (inserted) groups.push_back(Group{label, {}});
    current = it->second;
  };
  open_group(name);

  struct Pending {
    size_t line;
    int64_t index;
  };
  std::vector<Pending> forward_refs;  // positive indices beyond the vertices read so far
  uint64_t triangles = 0;
  std::vector<uint32_t> polygon;

  for_each_line(text, [&](size_t line_no, std::string_view line) {
    line = trim(line);
    if (line.empty() || line.front() == '#') return;
    const std::vector<std::string_view> t = split(line);
    const std::string at = "OBJ \"" + name + "\" line " + std::to_string(line_no);
    if (t[0] == "v") {
      if (t.size() < 4) invalid_at(line_no, at + ": a vertex needs 3 coordinates");
      Vec3 p;
      for (int c = 0; c < 3; ++c) {
        if (!parse_double(t[c + 1], p[c])) {
          invalid_at(line_no,
                     at + ": coordinate \"" + std::string(t[c + 1]) + "\" is not a number");
        }
      }
      vertices.push_back(p);
    } else if (t[0] == "f") {
      if (t.size() < 4) invalid_at(line_no, at + ": a face needs at least 3 vertices");
      polygon.clear();
      for (size_t k = 1; k < t.size(); ++k) {
        const std::string_view ref = t[k].substr(0, t[k].find('/'));
        int64_t i = 0;
        if (!parse_int(ref, i)) {
          invalid_at(line_no, at + ": bad vertex reference \"" + std::string(t[k]) + "\"");
        }
        if (i == 0) invalid_at(line_no, at + ": vertex index 0 (OBJ indices start at 1)");
        int64_t index = i > 0 ? i - 1 : static_cast<int64_t>(vertices.size()) + i;
        if (index < 0) {
          invalid_at(line_no, at + ": relative vertex index " + std::to_string(i) +
                                  " is out of range (" + std::to_string(vertices.size()) +
                                  " vertices so far)");
        }
        if (index > 0xFFFFFFFEll)
          invalid_at(line_no, at + ": vertex index " + std::to_string(i) + " is out of range");
        if (index >= static_cast<int64_t>(vertices.size())) forward_refs.push_back({line_no, i});
        polygon.push_back(static_cast<uint32_t>(index));
      }
      triangles += polygon.size() - 2;
      check_simplex_limit(triangles, limits, name);
      Group& g = groups[current];
      for (size_t k = 1; k + 1 < polygon.size(); ++k) {
        g.corners.insert(g.corners.end(), {polygon[0], polygon[k], polygon[k + 1]});
      }
    } else if ((t[0] == "o" || t[0] == "g") && !single_object) {
      const std::string label(trim(line.substr(1)));
      open_group(label.empty() ? name : label);
    }
    // vt, vn, vp, l, p, s, usemtl, mtllib, ...: not geometry of a solid; ignored.
  });

  for (const Pending& p : forward_refs) {
    if (p.index > static_cast<int64_t>(vertices.size())) {
      invalid_at(p.line, "OBJ \"" + name + "\" line " + std::to_string(p.line) + ": vertex index " +
                             std::to_string(p.index) + " is out of range (the file has " +
                             std::to_string(vertices.size()) + " vertices)");
    }
  }
  if (triangles == 0) invalid("OBJ \"" + name + "\" has no faces");

  Scene scene;
  scene.dimension = 3;
  std::vector<uint32_t> local(vertices.size(), 0);
  std::vector<uint32_t> stamp(vertices.size(), 0xFFFFFFFFu);
  for (size_t gi = 0; gi < groups.size(); ++gi) {
    Group& g = groups[gi];
    if (g.corners.empty()) continue;  // empty groups (e.g. `o` directly followed by `g`)
    SceneObject object;
    object.label = g.label;
    object.simplices.reserve(g.corners.size() / 3);
    for (size_t k = 0; k < g.corners.size(); k += 3) {
      Simplex s;
      for (int c = 0; c < 3; ++c) {
        const uint32_t v = g.corners[k + static_cast<size_t>(c)];
        if (stamp[v] != gi) {
          stamp[v] = static_cast<uint32_t>(gi);
          local[v] = static_cast<uint32_t>(object.vertices.size());
          object.vertices.push_back(vertices[v]);
        }
        s.v[c] = local[v];
      }
      object.simplices.push_back(s);
    }
    scene.objects.push_back(std::move(object));
  }
  return scene;
}

// ---------------------------------------------------------------------------------- PLY

Scene parse_ply(std::span<const uint8_t> bytes, const std::string& name,
                const SceneLimits& limits) {
  const std::string_view all(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  const std::string pre = "PLY \"" + name + "\": ";
  if (!all.starts_with("ply")) invalid(pre + "missing the \"ply\" magic");
  size_t pos = 0;
  size_t header_line = 0;
  PlyFormat format = PlyFormat::kAscii;
  bool has_format = false;
  std::vector<PlyElement> elements;
  bool ended = false;
  while (pos < all.size() && !ended) {
    size_t end = all.find('\n', pos);
    if (end == std::string_view::npos) invalid(pre + "the header has no end_header line");
    const std::string_view line = trim(all.substr(pos, end - pos));
    pos = end + 1;
    ++header_line;
    const std::string at = pre + "header line " + std::to_string(header_line);
    const std::vector<std::string_view> t = split(line);
    if (t.empty()) continue;
    if (header_line == 1) {
      if (t[0] != "ply") invalid_at(header_line, at + ": expected \"ply\"");
      continue;
    }
    if (t[0] == "comment" || t[0] == "obj_info") continue;
    if (t[0] == "end_header") {
      ended = true;
    } else if (t[0] == "format") {
      if (t.size() < 2) invalid_at(header_line, at + ": format needs a type");
      if (t[1] == "ascii") {
        format = PlyFormat::kAscii;
      } else if (t[1] == "binary_little_endian") {
        format = PlyFormat::kLittle;
      } else if (t[1] == "binary_big_endian") {
        format = PlyFormat::kBig;
      } else {
        invalid_at(header_line, at + ": unknown format \"" + std::string(t[1]) + "\"");
      }
      has_format = true;
    } else if (t[0] == "element") {
      int64_t count = 0;
      if (t.size() != 3 || !parse_int(t[2], count) || count < 0) {
        invalid_at(header_line, at + ": expected \"element NAME COUNT\"");
      }
      elements.push_back(PlyElement{std::string(t[1]), static_cast<uint64_t>(count), {}});
    } else if (t[0] == "property") {
      if (elements.empty()) invalid_at(header_line, at + ": property before any element");
      PlyProperty p;
      if (t.size() == 5 && t[1] == "list") {
        p.is_list = true;
        if (!ply_type(t[2], p.count_type) || !ply_type(t[3], p.type)) {
          invalid_at(header_line, at + ": unknown list property type");
        }
        if (p.count_type == PlyType::kFloat32 || p.count_type == PlyType::kFloat64) {
          invalid_at(header_line, at + ": a list count must have an integer type");
        }
        p.name = std::string(t[4]);
      } else if (t.size() == 3) {
        if (!ply_type(t[1], p.type)) {
          invalid_at(header_line, at + ": unknown property type \"" + std::string(t[1]) + "\"");
        }
        p.name = std::string(t[2]);
      } else {
        invalid_at(header_line, at + ": malformed property line");
      }
      elements.back().properties.push_back(std::move(p));
    } else {
      invalid_at(header_line, at + ": unknown header keyword \"" + std::string(t[0]) + "\"");
    }
  }
  if (!ended) invalid(pre + "the header has no end_header line");
  if (!has_format) invalid(pre + "the header has no format line");

  PlyReader reader(bytes.subspan(pos), format, name, pos);
  std::vector<Vec3> vertices;
  std::vector<Simplex> simplices;
  bool has_vertices = false, has_faces = false;
  std::vector<uint32_t> polygon;
  for (const PlyElement& e : elements) {
    // Every row holds at least one byte (binary) or two characters (ascii) per property.
    const uint64_t min_row = std::max<uint64_t>(1, e.properties.size());
    if (e.count > reader.remaining() / min_row + 1) {
      invalid_at_byte(reader.offset(), pre + "element \"" + e.name + "\" declares " +
                                           std::to_string(e.count) + " rows from byte " +
                                           std::to_string(reader.offset()) +
                                           " on, but the file ends at byte " +
                                           std::to_string(bytes.size()) + " (truncated?)");
    }
    const bool is_vertex = e.name == "vertex";
    const bool is_face = e.name == "face";
    int xyz[3] = {-1, -1, -1};
    int list = -1;
    for (size_t k = 0; k < e.properties.size(); ++k) {
      const PlyProperty& p = e.properties[k];
      if (is_vertex && !p.is_list) {
        if (p.name == "x") xyz[0] = static_cast<int>(k);
        if (p.name == "y") xyz[1] = static_cast<int>(k);
        if (p.name == "z") xyz[2] = static_cast<int>(k);
      }
      if (is_face && p.is_list && (p.name == "vertex_indices" || p.name == "vertex_index")) {
        list = static_cast<int>(k);
      }
    }
    if (is_vertex) {
      if (xyz[0] < 0 || xyz[1] < 0 || xyz[2] < 0) {
        invalid(pre + "element vertex lacks one of the properties x, y, z");
      }
      has_vertices = true;
      vertices.reserve(e.count);
    }
    if (is_face) {
      if (list < 0) invalid(pre + "element face has no list property vertex_indices");
      has_faces = true;
      check_simplex_limit(e.count, limits, name);
      simplices.reserve(e.count);
    }
    for (uint64_t row = 0; row < e.count; ++row) {
      const std::string where = "element " + e.name + " " + std::to_string(row);
      Vec3 p;
      for (size_t k = 0; k < e.properties.size(); ++k) {
        const PlyProperty& prop = e.properties[k];
        if (!prop.is_list) {
          const double v = reader.read(prop.type, where);
          for (int c = 0; c < 3; ++c) {
            if (is_vertex && xyz[c] == static_cast<int>(k)) p[c] = v;
          }
          continue;
        }
        const double n = reader.read(prop.count_type, where);
        if (n < 0) invalid(pre + where + ": negative list length");
        // A list length read as a float type can be anything: a count is a whole number that
        // fits 32 bits (a larger one could not be in the file anyway).
        if (!(n <= 4294967295.0) || n != std::floor(n))
          invalid(pre + where + ": list length " + std::to_string(n) + " is not a count");
        const auto count = static_cast<uint64_t>(n);
        const bool wanted = is_face && static_cast<int>(k) == list;
        if (wanted) {
          if (count < 3) {
            invalid(pre + "face " + std::to_string(row) + " has " + std::to_string(count) +
                    " vertices (at least 3 needed)");
          }
          polygon.clear();
        }
        for (uint64_t i = 0; i < count; ++i) {
          const double v = reader.read(prop.type, where);
          if (!wanted) continue;
          if (v < 0 || v != static_cast<double>(static_cast<int64_t>(v)) || v > 4294967294.0) {
            invalid(pre + "face " + std::to_string(row) + ": bad vertex index " +
                    std::to_string(v));
          }
          polygon.push_back(static_cast<uint32_t>(v));
        }
        if (wanted) {
          fan(polygon, simplices);
          check_simplex_limit(simplices.size(), limits, name);
        }
      }
      if (is_vertex) vertices.push_back(p);
    }
  }
  if (!has_vertices) invalid(pre + "no vertex element");
  if (!has_faces || simplices.empty()) invalid(pre + "no faces");
  return one_object_scene(name, std::move(vertices), std::move(simplices));
}

// ---------------------------------------------------------------------------------- STL

bool is_binary_stl(std::span<const uint8_t> bytes) {
  if (bytes.size() < 84) return false;
  const uint32_t n = read_le32(bytes.data() + 80);
  return 84 + 50 * static_cast<uint64_t>(n) == bytes.size();
}

Scene parse_stl(std::span<const uint8_t> bytes, const std::string& name,
                const SceneLimits& limits) {
  const std::string pre = "STL \"" + name + "\": ";
  Welder welder;
  std::vector<Simplex> simplices;
  if (is_binary_stl(bytes)) {
    const uint64_t n = (bytes.size() - 84) / 50;
    check_simplex_limit(n, limits, name);
    simplices.reserve(n);
    for (uint64_t i = 0; i < n; ++i) {
      const uint8_t* rec = bytes.data() + 84 + 50 * i;
      Simplex s;
      for (int c = 0; c < 3; ++c) {
        Vec3 p;
        for (int k = 0; k < 3; ++k) {
          const uint32_t bits =
              read_le32(rec + 12 + 12 * static_cast<size_t>(c) + 4 * static_cast<size_t>(k));
          p[k] = std::bit_cast<float>(bits);
        }
        s.v[c] = welder.add(p);
      }
      simplices.push_back(s);
    }
    return one_object_scene(name, std::move(welder.vertices), std::move(simplices));
  }

  // Not 84 + 50 * count bytes, but binary after its 80-byte header (a NUL byte, which no ASCII
  // STL holds; many exporters start the header with "solid" too): a truncated or padded binary
  // STL, said so with the byte where its facets stop matching.
  if (bytes.size() >= 84 &&
      std::any_of(bytes.begin() + 84, bytes.end(), [](uint8_t b) { return b == 0; })) {
    const uint64_t n = read_le32(bytes.data() + 80);
    const uint64_t expected = 84 + 50 * n;
    if (expected > bytes.size()) {
      const uint64_t whole = (bytes.size() - 84) / 50;
      invalid_at_byte(bytes.size(), pre + "binary STL truncated: its header declares " +
                                        std::to_string(n) + " facets (" + std::to_string(expected) +
                                        " bytes) but the file ends at byte " +
                                        std::to_string(bytes.size()) + ", in facet " +
                                        std::to_string(whole));
    }
    invalid_at_byte(expected, pre + "binary STL with " + std::to_string(bytes.size() - expected) +
                                  " bytes after the " + std::to_string(n) +
                                  " facets its header declares (from byte " +
                                  std::to_string(expected) + ")");
  }
  const std::string_view text(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  if (!trim(text).starts_with("solid")) {
    invalid(pre + "neither ASCII (\"solid ...\") nor binary (size must be 84 + 50 * count)");
  }
  std::vector<uint32_t> loop;
  bool in_loop = false;
  size_t facet = 0;
  for_each_line(text, [&](size_t line_no, std::string_view line) {
    const std::vector<std::string_view> t = split(line);
    if (t.empty()) return;
    const std::string at = pre + "line " + std::to_string(line_no);
    if (t[0] == "outer") {
      if (in_loop) invalid_at(line_no, at + ": nested loop");
      in_loop = true;
      loop.clear();
    } else if (t[0] == "vertex") {
      if (!in_loop) invalid_at(line_no, at + ": vertex outside of a loop");
      Vec3 p;
      if (t.size() != 4) invalid_at(line_no, at + ": a vertex needs 3 coordinates");
      for (int c = 0; c < 3; ++c) {
        if (!parse_double(t[static_cast<size_t>(c) + 1], p[c])) {
          invalid_at(line_no, at + ": coordinate \"" + std::string(t[static_cast<size_t>(c) + 1]) +
                                  "\" is not a number");
        }
      }
      loop.push_back(welder.add(p));
    } else if (t[0] == "endloop") {
      if (!in_loop) invalid_at(line_no, at + ": endloop without a loop");
      if (loop.size() != 3) {
        invalid_at(line_no, at + ": facet " + std::to_string(facet) + " has " +
                                std::to_string(loop.size()) + " vertices (3 expected)");
      }
      simplices.push_back(Simplex{{loop[0], loop[1], loop[2]}});
      check_simplex_limit(simplices.size(), limits, name);
      in_loop = false;
      ++facet;
    }
  });
  if (in_loop) invalid(pre + "truncated: the last facet's loop is not closed");
  if (simplices.empty()) invalid(pre + "no facets");
  return one_object_scene(name, std::move(welder.vertices), std::move(simplices));
}

// ---------------------------------------------------------------------------------- OFF

Scene parse_off(std::string_view text, const std::string& name, const SceneLimits& limits) {
  const std::string pre = "OFF \"" + name + "\": ";
  // Logical lines: comments stripped, blank lines skipped.
  std::vector<std::pair<size_t, std::vector<std::string_view>>> lines;
  for_each_line(text, [&](size_t line_no, std::string_view line) {
    line = line.substr(0, line.find('#'));
    std::vector<std::string_view> t = split(line);
    if (!t.empty()) lines.emplace_back(line_no, std::move(t));
  });
  size_t li = 0;
  if (lines.empty()) invalid(pre + "empty file");
  std::vector<std::string_view> head = lines[li++].second;
  const std::string_view magic = head[0];
  if (!magic.ends_with("OFF")) invalid(pre + "missing the \"OFF\" header");
  if (magic.find('4') != std::string_view::npos || magic.starts_with("n")) {
    invalid(pre + "only 3D OFF is supported (got \"" + std::string(magic) + "\")");
  }
  if (head.size() > 1 && head[1] == "BINARY") invalid(pre + "binary OFF is not supported");
  std::vector<std::string_view> counts(head.begin() + 1, head.end());
  if (counts.empty()) {
    if (li >= lines.size()) invalid(pre + "missing the vertex/face counts");
    counts = lines[li++].second;
  }
  int64_t nv = 0, nf = 0;
  if (counts.size() < 2 || !parse_int(counts[0], nv) || !parse_int(counts[1], nf) || nv < 0 ||
      nf < 0) {
    invalid(pre + "bad counts line (expected \"vertices faces edges\")");
  }
  if (static_cast<uint64_t>(nv) + static_cast<uint64_t>(nf) > lines.size() - li) {
    invalid(pre + "declares " + std::to_string(nv) + " vertices and " + std::to_string(nf) +
            " faces but has only " + std::to_string(lines.size() - li) + " lines (truncated?)");
  }
  std::vector<Vec3> vertices;
  vertices.reserve(static_cast<size_t>(nv));
  for (int64_t i = 0; i < nv; ++i) {
    const auto& [line_no, t] = lines[li++];
    const std::string at =
        pre + "line " + std::to_string(line_no) + " (vertex " + std::to_string(i) + ")";
    if (t.size() < 3) invalid_at(line_no, at + ": a vertex needs 3 coordinates");
    Vec3 p;
    for (int c = 0; c < 3; ++c) {
      if (!parse_double(t[static_cast<size_t>(c)], p[c])) {
        invalid_at(line_no,
                   at + ": \"" + std::string(t[static_cast<size_t>(c)]) + "\" is not a number");
      }
    }
    vertices.push_back(p);
  }
  std::vector<Simplex> simplices;
  std::vector<uint32_t> polygon;
  for (int64_t f = 0; f < nf; ++f) {
    const auto& [line_no, t] = lines[li++];
    const std::string at =
        pre + "line " + std::to_string(line_no) + " (face " + std::to_string(f) + ")";
    int64_t n = 0;
    if (!parse_int(t[0], n) || n < 3)
      invalid_at(line_no, at + ": a face needs at least 3 vertices");
    if (t.size() < static_cast<size_t>(n) + 1)
      invalid_at(line_no, at + ": fewer indices than announced");
    polygon.clear();
    for (int64_t k = 0; k < n; ++k) {
      int64_t index = 0;
      if (!parse_int(t[static_cast<size_t>(k) + 1], index) || index < 0 || index >= nv) {
        invalid_at(line_no, at + ": bad vertex index \"" +
                                std::string(t[static_cast<size_t>(k) + 1]) + "\" (" +
                                std::to_string(nv) + " vertices)");
      }
      polygon.push_back(static_cast<uint32_t>(index));
    }
    fan(polygon, simplices);
    check_simplex_limit(simplices.size(), limits, name);
  }
  if (simplices.empty()) invalid(pre + "no faces");
  return one_object_scene(name, std::move(vertices), std::move(simplices));
}

}  // namespace gvd::scene
