// glTF 2.0 / GLB input through tinygltf (the only file that includes it: its header is
// heavy): one object per
// node with a mesh, world transforms applied, TRIANGLES (strips and fans converted).
#include <tiny_gltf.h>

#include <array>
#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "gvd/common/error.h"
#include "gvd/common/json_input.h"
#include "gvd/scene/load_scene.h"

namespace gvd::scene {

// Entry point used by load_scene.cpp (declared there too).
Scene parse_gltf(std::span<const uint8_t> bytes, bool binary, const std::string& name,
                 const SceneLimits& limits);

namespace {

[[noreturn]] void invalid(std::string detail, ErrorLocation where) {
  throw Error(ErrorCode::kInvalidScene, std::move(detail), std::move(where));
}

/// A fault of the GLB container at byte `offset` of the file.
ErrorLocation at_byte(uint64_t offset) {
  ErrorLocation where;
  where.offset = static_cast<int64_t>(offset);
  return where;
}

/// The scene object a fault lies in: the node with a mesh being read (object = its index in
/// the scene, label = its label), or none (object -1) outside such a node.
struct ObjectSite {
  int64_t object = -1;
  std::string label;
};

/// A fault at `pointer` (RFC 6901) into the glTF document, within `site`'s object, at its
/// `element` number `index` when one is known.
ErrorLocation at(const ObjectSite& site, std::string pointer, std::string element = "",
                 int64_t index = -1) {
  ErrorLocation where;
  where.object = site.object;
  where.label = site.label;
  where.pointer = std::move(pointer);
  where.element = std::move(element);
  where.index = index;
  return where;
}

std::string accessor_pointer(int index) { return "/accessors/" + std::to_string(index); }
std::string view_pointer(int index) { return "/bufferViews/" + std::to_string(index); }

uint32_t read_u32(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) | static_cast<uint32_t>(p[1]) << 8 |
         static_cast<uint32_t>(p[2]) << 16 | static_cast<uint32_t>(p[3]) << 24;
}

/// Checks the GLB container (header and chunk table) before tinygltf sees it, so that a
/// truncated or lying file gets a precise message. Returns the JSON chunk.
std::string_view check_glb_container(std::span<const uint8_t> bytes, const std::string& pre) {
  // Offsets: where the file ends for a cut file, else the header field or chunk at fault.
  if (bytes.size() < 12) {
    invalid(pre + "truncated GLB: " + std::to_string(bytes.size()) +
                " bytes, the header alone needs 12",
            at_byte(bytes.size()));
  }
  if (std::memcmp(bytes.data(), "glTF", 4) != 0)
    invalid(pre + "missing the GLB magic \"glTF\" at byte 0", at_byte(0));
  const uint32_t version = read_u32(bytes.data() + 4);
  if (version != 2) {
    invalid(pre + "GLB version " + std::to_string(version) + " at byte 4 (only 2 is supported)",
            at_byte(4));
  }
  const uint32_t length = read_u32(bytes.data() + 8);
  if (length > bytes.size()) {
    invalid(pre + "truncated GLB: the header announces " + std::to_string(length) +
                " bytes but only " + std::to_string(bytes.size()) + " are present",
            at_byte(bytes.size()));
  }
  if (length < 20) {
    invalid(pre + "GLB too short to hold a JSON chunk (its header at byte 12 needs 8 bytes)",
            at_byte(12));
  }
  const uint64_t json_length = read_u32(bytes.data() + 12);
  if (read_u32(bytes.data() + 16) != 0x4E4F534Au)
    invalid(pre + "the first GLB chunk (at byte 12) is not JSON", at_byte(12));
  if (20 + json_length > length) {
    invalid(pre + "truncated GLB: the JSON chunk at byte 12 announces " +
                std::to_string(json_length) + " bytes but only " + std::to_string(length - 20) +
                " follow",
            at_byte(12));
  }
  uint64_t pos = 20 + json_length;
  while (pos < length) {
    if (length - pos < 8) {
      invalid(pre + "truncated GLB: incomplete chunk header at byte " + std::to_string(pos),
              at_byte(pos));
    }
    const uint64_t chunk = read_u32(bytes.data() + pos);
    if (pos + 8 + chunk > length) {
      invalid(pre + "truncated GLB: the chunk at byte " + std::to_string(pos) + " announces " +
                  std::to_string(chunk) + " bytes but only " + std::to_string(length - pos - 8) +
                  " follow",
              at_byte(pos));
    }
    pos += 8 + chunk;
  }
  return {reinterpret_cast<const char*>(bytes.data()) + 20, static_cast<size_t>(json_length)};
}

/// The members tinygltf requires, checked here first so that a missing or mistyped one has a
/// pointer (tinygltf says which only in words).
void check_required_members(const nlohmann::json& doc, const std::string& pre) {
  const auto asset = doc.find("asset");
  if (asset == doc.end() || !asset->is_object())
    invalid(pre + "the glTF has no \"asset\" object", at({}, "/asset"));
  const auto version = asset->find("version");
  if (version == asset->end() || !version->is_string())
    invalid(pre + "\"asset\" has no \"version\" string", at({}, "/asset/version"));
  struct Required {
    const char* array;
    const char* name;  // an element's name in messages
    const char* member;
    bool is_string;  // else an integer
  };
  static constexpr Required kRequired[] = {
      {"buffers", "buffer", "byteLength", false},
      {"bufferViews", "bufferView", "buffer", false},
      {"bufferViews", "bufferView", "byteLength", false},
      {"accessors", "accessor", "componentType", false},
      {"accessors", "accessor", "count", false},
      {"accessors", "accessor", "type", true},
  };
  for (const Required& r : kRequired) {
    const auto list = doc.find(r.array);
    if (list == doc.end() || !list->is_array()) continue;
    for (size_t i = 0; i < list->size(); ++i) {
      const nlohmann::json& e = (*list)[i];
      const std::string pointer = std::string("/") + r.array + "/" + std::to_string(i);
      if (!e.is_object())
        invalid(pre + r.name + " " + std::to_string(i) + " is not an object", at({}, pointer));
      const auto m = e.find(r.member);
      if (m == e.end() || (r.is_string ? !m->is_string() : !m->is_number_integer())) {
        invalid(pre + r.name + " " + std::to_string(i) + " has no " +
                    (r.is_string ? "string" : "integer") + " \"" + r.member + "\"",
                at({}, pointer + "/" + r.member));
      }
    }
  }
  const auto meshes = doc.find("meshes");
  if (meshes == doc.end() || !meshes->is_array()) return;
  for (size_t m = 0; m < meshes->size(); ++m) {
    const nlohmann::json& mesh = (*meshes)[m];
    const auto prims = mesh.is_object() ? mesh.find("primitives") : mesh.end();
    if (!mesh.is_object() || prims == mesh.end() || !prims->is_array()) continue;
    for (size_t p = 0; p < prims->size(); ++p) {
      const nlohmann::json& prim = (*prims)[p];
      const std::string pointer =
          "/meshes/" + std::to_string(m) + "/primitives/" + std::to_string(p);
      const auto attributes = prim.is_object() ? prim.find("attributes") : prim.end();
      if (!prim.is_object() || attributes == prim.end() || !attributes->is_object()) {
        invalid(pre + "mesh " + std::to_string(m) + " primitive " + std::to_string(p) +
                    " has no \"attributes\" object",
                at({}, prim.is_object() ? pointer + "/attributes" : pointer));
      }
    }
  }
}

/// We never read files on behalf of a document (the service gets untrusted input): every
/// buffer must be embedded (GLB BIN chunk or data: URI). `json_base`: where the JSON text
/// starts in the file (20 in a GLB), so that offsets are the file's.
/// Then the members tinygltf requires (check_required_members).
void check_document(std::string_view json_text, uint64_t json_base, const std::string& pre) {
  nlohmann::json doc;
  try {
    doc = parse_json_input(json_text, "the glTF JSON", ErrorCode::kInvalidScene);
  } catch (const Error& e) {  // its offset is within the JSON text: make it the file's
    if (e.where().offset < 0) invalid(pre + e.what(), {});
    const uint64_t offset = json_base + static_cast<uint64_t>(e.where().offset);
    invalid(pre + e.what() +
                (json_base > 0 ? " (byte " + std::to_string(offset) + " of the file)" : ""),
            at_byte(offset));
  }
  if (!doc.is_object()) {
    const size_t first = json_text.find_first_not_of(" \t\r\n");
    const uint64_t offset = json_base + (first == std::string_view::npos ? 0 : first);
    invalid(pre + "the glTF JSON is not an object (byte " + std::to_string(offset) + ")",
            at_byte(offset));
  }
  const auto buffers = doc.find("buffers");
  for (size_t i = 0; buffers != doc.end() && buffers->is_array() && i < buffers->size(); ++i) {
    const nlohmann::json& b = (*buffers)[i];
    if (!b.is_object()) continue;
    const auto uri = b.find("uri");
    if (uri != b.end() && uri->is_string() &&
        !uri->get_ref<const std::string&>().starts_with("data:")) {
      invalid(pre + "buffer " + std::to_string(i) + " refers to the external file \"" +
                  uri->get<std::string>() +
                  "\": external buffers are not supported (embed them, or send a GLB)",
              at({}, "/buffers/" + std::to_string(i) + "/uri"));
    }
  }
  check_required_members(doc, pre);
}

bool no_file_exists(const std::string&, void*) { return false; }
std::string same_path(const std::string& path, void*) { return path; }
bool no_read(std::vector<unsigned char>*, std::string* err, const std::string& path, void*) {
  if (err) *err += "external file \"" + path + "\" not loaded (not supported)\n";
  return false;
}
bool no_write(std::string* err, const std::string&, const std::vector<unsigned char>&, void*) {
  if (err) *err += "writing files is not supported\n";
  return false;
}
/// Images are irrelevant to the geometry: skip decoding them.
bool skip_image(tinygltf::Image*, const int, std::string*, std::string*, int, int,
                const unsigned char*, int, void*) {
  return true;
}

using Mat4 = std::array<double, 16>;  // column-major, as glTF

Mat4 identity() { return {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}; }

Mat4 multiply(const Mat4& a, const Mat4& b) {
  Mat4 r{};
  for (int c = 0; c < 4; ++c) {
    for (int row = 0; row < 4; ++row) {
      double s = 0;
      for (int k = 0; k < 4; ++k) s += a[k * 4 + row] * b[c * 4 + k];
      r[c * 4 + row] = s;
    }
  }
  return r;
}

/// `index`: the node's index in the document; `site`: the object it becomes, if any.
Mat4 local_transform(const tinygltf::Node& node, int index, const ObjectSite& site,
                     const std::string& pre) {
  const std::string pointer = "/nodes/" + std::to_string(index);
  if (!node.matrix.empty()) {
    if (node.matrix.size() != 16) {
      invalid(pre + "node " + std::to_string(index) + " (\"" + node.name +
                  "\"): matrix needs 16 numbers",
              at(site, pointer + "/matrix"));
    }
    Mat4 m;
    std::copy(node.matrix.begin(), node.matrix.end(), m.begin());
    return m;
  }
  Mat4 t = identity(), r = identity(), s = identity();
  if (!node.translation.empty()) {
    if (node.translation.size() != 3) {
      invalid(pre + "node " + std::to_string(index) + " (\"" + node.name +
                  "\"): bad translation (needs 3 numbers)",
              at(site, pointer + "/translation"));
    }
    t[12] = node.translation[0];
    t[13] = node.translation[1];
    t[14] = node.translation[2];
  }
  if (!node.rotation.empty()) {
    if (node.rotation.size() != 4) {
      invalid(pre + "node " + std::to_string(index) + " (\"" + node.name +
                  "\"): bad rotation (needs 4 numbers)",
              at(site, pointer + "/rotation"));
    }
    double x = node.rotation[0], y = node.rotation[1], z = node.rotation[2], w = node.rotation[3];
    const double n = std::sqrt(x * x + y * y + z * z + w * w);
    if (n > 0) {
      x /= n, y /= n, z /= n, w /= n;
    }
    r = {1 - 2 * (y * y + z * z),
         2 * (x * y + z * w),
         2 * (x * z - y * w),
         0,
         2 * (x * y - z * w),
         1 - 2 * (x * x + z * z),
         2 * (y * z + x * w),
         0,
         2 * (x * z + y * w),
         2 * (y * z - x * w),
         1 - 2 * (x * x + y * y),
         0,
         0,
         0,
         0,
         1};
  }
  if (!node.scale.empty()) {
    if (node.scale.size() != 3) {
      invalid(pre + "node " + std::to_string(index) + " (\"" + node.name +
                  "\"): bad scale (needs 3 numbers)",
              at(site, pointer + "/scale"));
    }
    s[0] = node.scale[0];
    s[5] = node.scale[1];
    s[10] = node.scale[2];
  }
  return multiply(t, multiply(r, s));
}

Vec3 apply(const Mat4& m, Vec3 p) {
  return {m[0] * p.x + m[4] * p.y + m[8] * p.z + m[12],
          m[1] * p.x + m[5] * p.y + m[9] * p.z + m[13],
          m[2] * p.x + m[6] * p.y + m[10] * p.z + m[14]};
}

/// Bounds-checked access to the elements of an accessor, any component type.
class AccessorView {
 public:
  /// `reference`: the pointer of the member that names the accessor (a primitive's
  /// "indices" or attribute); faults of the accessor and its bufferView point at those.
  AccessorView(const tinygltf::Model& model, int index, const std::string& where,
               const std::string& reference, const ObjectSite& site) {
    if (index < 0 || static_cast<size_t>(index) >= model.accessors.size()) {
      invalid(where + ": accessor " + std::to_string(index) + " does not exist",
              at(site, reference));
    }
    const tinygltf::Accessor& a = model.accessors[static_cast<size_t>(index)];
    const std::string text = where + ": accessor " + std::to_string(index);
    const std::string pointer = accessor_pointer(index);
    if (a.sparse.isSparse)
      invalid(text + " is sparse (not supported)", at(site, pointer + "/sparse"));
    if (a.bufferView < 0 || static_cast<size_t>(a.bufferView) >= model.bufferViews.size()) {
      invalid(text + " has no valid bufferView", at(site, pointer + "/bufferView"));
    }
    const tinygltf::BufferView& view = model.bufferViews[static_cast<size_t>(a.bufferView)];
    const std::string vpointer = view_pointer(a.bufferView);
    if (view.buffer < 0 || static_cast<size_t>(view.buffer) >= model.buffers.size()) {
      invalid(text + ": bufferView " + std::to_string(a.bufferView) + " has no valid buffer",
              at(site, vpointer + "/buffer"));
    }
    const std::vector<unsigned char>& data = model.buffers[static_cast<size_t>(view.buffer)].data;
    component_type_ = a.componentType;
    const int size = tinygltf::GetComponentSizeInBytes(static_cast<uint32_t>(a.componentType));
    const int components = tinygltf::GetNumComponentsInType(static_cast<uint32_t>(a.type));
    if (size <= 0)
      invalid(text + " has an unknown componentType", at(site, pointer + "/componentType"));
    if (components <= 0) invalid(text + " has an unknown type", at(site, pointer + "/type"));
    component_size_ = static_cast<size_t>(size);
    components_ = components;
    normalized_ = a.normalized;
    count = a.count;
    const size_t element = component_size_ * static_cast<size_t>(components);
    stride_ = view.byteStride != 0 ? view.byteStride : element;
    if (stride_ < element) {
      invalid(text + ": byteStride of bufferView " + std::to_string(a.bufferView) +
                  " smaller than an element",
              at(site, vpointer + "/byteStride"));
    }
    if (view.byteOffset > data.size() || view.byteLength > data.size() - view.byteOffset) {
      invalid(text + ": bufferView " + std::to_string(a.bufferView) + " exceeds its buffer",
              at(site, vpointer));
    }
    if (count > 0) {
      const bool fits =
          count <= view.byteLength && stride_ <= view.byteLength &&
          a.byteOffset <= view.byteLength &&
          a.byteOffset + static_cast<uint64_t>(stride_) * (count - 1) + element <= view.byteLength;
      if (!fits) {
        invalid(text + ": " + std::to_string(count) + " elements exceed bufferView " +
                    std::to_string(a.bufferView) + " (" + std::to_string(view.byteLength) +
                    " bytes)",
                at(site, pointer));
      }
    }
    base_ = data.data() + view.byteOffset + a.byteOffset;
  }

  int components() const { return components_; }
  int component_type() const { return component_type_; }

  double get(size_t i, int c) const {
    const unsigned char* p = base_ + i * stride_ + static_cast<size_t>(c) * component_size_;
    switch (component_type_) {
      case TINYGLTF_COMPONENT_TYPE_BYTE: {
        const double v = load<int8_t>(p);
        return normalized_ ? std::max(v / 127.0, -1.0) : v;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
        return normalized_ ? load<uint8_t>(p) / 255.0 : load<uint8_t>(p);
      case TINYGLTF_COMPONENT_TYPE_SHORT: {
        const double v = load<int16_t>(p);
        return normalized_ ? std::max(v / 32767.0, -1.0) : v;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
        return normalized_ ? load<uint16_t>(p) / 65535.0 : load<uint16_t>(p);
      case TINYGLTF_COMPONENT_TYPE_INT:
        return load<int32_t>(p);
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
        return load<uint32_t>(p);
      case TINYGLTF_COMPONENT_TYPE_FLOAT:
        return load<float>(p);
      case TINYGLTF_COMPONENT_TYPE_DOUBLE:
        return load<double>(p);
      default:
        return 0;
    }
  }

  size_t count = 0;

 private:
  template <class T>
  static double load(const unsigned char* p) {
    T v;
    std::memcpy(&v, p, sizeof(T));
    return static_cast<double>(v);
  }

  const unsigned char* base_ = nullptr;
  size_t stride_ = 0;
  size_t component_size_ = 0;
  int components_ = 0;
  int component_type_ = 0;
  bool normalized_ = false;
};

/// The first triangle (0-based, within the primitive) that reads entry `i` of a primitive's
/// `n` indices in `mode`; -1 when none does (fewer than 3 indices).
int64_t first_triangle_of(size_t i, size_t n, int mode) {
  if (n < 3) return -1;
  if (mode == TINYGLTF_MODE_TRIANGLES) return static_cast<int64_t>(i / 3);
  // Strip and fan: triangle t reads entries t + 1 and t + 2 (and t, or 0 in a fan).
  return static_cast<int64_t>(i < 2 ? 0 : i - 2);
}

/// Appends the triangles of one primitive (positions transformed) to `object`, the scene
/// object `site`; `pointer`: the primitive's ("/meshes/m/primitives/p").
void add_primitive(const tinygltf::Model& model, const tinygltf::Primitive& prim, const Mat4& world,
                   const std::string& where, const std::string& pointer, const ObjectSite& site,
                   SceneObject& object, const SceneLimits& limits, uint64_t& total) {
  const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
  if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
      mode != TINYGLTF_MODE_TRIANGLE_FAN) {
    invalid(where + ": primitive mode " + std::to_string(mode) +
                " is not a surface (points/lines are not supported)",
            at(site, pointer + "/mode"));
  }
  const auto pos_it = prim.attributes.find("POSITION");
  if (pos_it == prim.attributes.end())
    invalid(where + " has no POSITION attribute", at(site, pointer + "/attributes"));
  const AccessorView positions(model, pos_it->second, where + " POSITION",
                               pointer + "/attributes/POSITION", site);
  if (positions.components() != 3) {
    invalid(where + ": POSITION is not a VEC3",
            at(site, accessor_pointer(pos_it->second) + "/type"));
  }
  const auto offset = static_cast<uint32_t>(object.vertices.size());
  const size_t simplices_before = object.simplices.size();
  if (positions.count > 0xFFFFFFF0ull - offset)
    invalid(where + ": too many vertices", at(site, accessor_pointer(pos_it->second)));
  for (size_t i = 0; i < positions.count; ++i) {
    object.vertices.push_back(
        apply(world, {positions.get(i, 0), positions.get(i, 1), positions.get(i, 2)}));
  }
  std::vector<uint32_t> index;
  // The accessor that lists the corners in order: the indices, or the positions themselves.
  const int corners = prim.indices >= 0 ? prim.indices : pos_it->second;
  if (prim.indices >= 0) {
    const AccessorView indices(model, prim.indices, where + " indices", pointer + "/indices", site);
    if (indices.components() != 1) {
      invalid(where + ": indices are not SCALAR",
              at(site, accessor_pointer(prim.indices) + "/type"));
    }
    if (indices.component_type() == TINYGLTF_COMPONENT_TYPE_FLOAT ||
        indices.component_type() == TINYGLTF_COMPONENT_TYPE_DOUBLE) {
      invalid(where + ": indices must have an integer component type",
              at(site, accessor_pointer(prim.indices) + "/componentType"));
    }
    index.reserve(indices.count);
    for (size_t i = 0; i < indices.count; ++i) {
      const double v = indices.get(i, 0);
      if (v < 0 || v >= static_cast<double>(positions.count)) {
        // The element is the object's triangle that reads it (-1 when no triangle does).
        const int64_t triangle = first_triangle_of(i, indices.count, mode);
        const int64_t in_object =
            triangle < 0 ? -1 : static_cast<int64_t>(simplices_before) + triangle;
        invalid(
            where + ": index " + std::to_string(i) + " = " + std::to_string(v) +
                " is out of range (" + std::to_string(positions.count) + " vertices)" +
                (in_object < 0 ? ""
                               : ", in triangle " + std::to_string(in_object) + " of the object"),
            at(site, accessor_pointer(prim.indices), in_object < 0 ? "" : "triangle", in_object));
      }
      index.push_back(static_cast<uint32_t>(v));
    }
  } else {
    index.resize(positions.count);
    for (size_t i = 0; i < positions.count; ++i) index[i] = static_cast<uint32_t>(i);
  }
  auto add = [&](uint32_t a, uint32_t b, uint32_t c) {
    object.simplices.push_back(Simplex{{a + offset, b + offset, c + offset}});
  };
  if (mode == TINYGLTF_MODE_TRIANGLES) {
    if (index.size() % 3 != 0) {
      invalid(where + ": TRIANGLES with a count not divisible by 3",
              at(site, accessor_pointer(corners) + "/count"));
    }
    for (size_t i = 0; i + 2 < index.size(); i += 3) add(index[i], index[i + 1], index[i + 2]);
  } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
    for (size_t i = 0; i + 2 < index.size(); ++i) {
      if (i % 2 == 0) {
        add(index[i], index[i + 1], index[i + 2]);
      } else {
        add(index[i + 1], index[i], index[i + 2]);
      }
    }
  } else {  // TRIANGLE_FAN
    for (size_t i = 1; i + 1 < index.size(); ++i) add(index[0], index[i], index[i + 1]);
  }
  total += object.simplices.size() - simplices_before;
  if (total > limits.max_simplices) {
    throw Error(ErrorCode::kLimitExceeded,
                "more than the limit of " + std::to_string(limits.max_simplices) +
                    " triangles (reached at " + where + ")",
                at(site, pointer));
  }
}

}  // namespace

Scene parse_gltf(std::span<const uint8_t> bytes, bool binary, const std::string& name,
                 const SceneLimits& limits) {
  const std::string pre = (binary ? "GLB \"" : "glTF \"") + name + "\": ";
  if (bytes.size() > 0xFFFFFFFFull) invalid(pre + "file larger than 4 GiB", at_byte(0xFFFFFFFFull));
  std::string_view json_text;
  if (binary) {
    json_text = check_glb_container(bytes, pre);
  } else {
    json_text = {reinterpret_cast<const char*>(bytes.data()), bytes.size()};
  }
  check_document(json_text, binary ? 20 : 0, pre);

  tinygltf::TinyGLTF loader;
  loader.SetFsCallbacks(
      tinygltf::FsCallbacks{&no_file_exists, &same_path, &no_read, &no_write, nullptr});
  loader.SetImageLoader(&skip_image, nullptr);
  tinygltf::Model model;
  std::string err, warn;
  const auto size = static_cast<unsigned int>(bytes.size());
  const bool ok =
      binary ? loader.LoadBinaryFromMemory(&model, &err, &warn, bytes.data(), size, "")
             : loader.LoadASCIIFromString(&model, &err, &warn,
                                          reinterpret_cast<const char*>(bytes.data()), size, "");
  if (!ok) {
    while (!err.empty() && (err.back() == '\n' || err.back() == ' ')) err.pop_back();
    // tinygltf says where only in words: no location (our own checks above and below give one).
    invalid(pre + (err.empty() ? std::string("tinygltf could not load it") : err), {});
  }

  // A node to visit: its index, its parent's world transform, and the pointer of the member
  // that names it ("/scenes/0/nodes/1", "/nodes/2/children/0"; "/nodes/i" for a root found
  // by elimination).
  struct Visit {
    int node;
    Mat4 parent;
    std::string reference;
  };
  // Roots: the default scene's nodes (or scene 0), else every node that is nobody's child.
  std::vector<Visit> roots;
  if (!model.scenes.empty()) {
    const size_t s =
        model.defaultScene >= 0 && static_cast<size_t>(model.defaultScene) < model.scenes.size()
            ? static_cast<size_t>(model.defaultScene)
            : 0;
    const std::vector<int>& nodes = model.scenes[s].nodes;
    for (size_t k = 0; k < nodes.size(); ++k) {
      roots.push_back(
          {nodes[k], identity(), "/scenes/" + std::to_string(s) + "/nodes/" + std::to_string(k)});
    }
  } else {
    std::vector<char> is_child(model.nodes.size(), 0);
    for (const tinygltf::Node& n : model.nodes) {
      for (int c : n.children) {
        if (c >= 0 && static_cast<size_t>(c) < model.nodes.size())
          is_child[static_cast<size_t>(c)] = 1;
      }
    }
    for (size_t i = 0; i < model.nodes.size(); ++i) {
      if (!is_child[i])
        roots.push_back({static_cast<int>(i), identity(), "/nodes/" + std::to_string(i)});
    }
  }

  Scene scene;
  scene.dimension = 3;
  std::vector<char> visited(model.nodes.size(), 0);
  std::vector<Visit> stack(roots.rbegin(), roots.rend());
  uint64_t total = 0;
  while (!stack.empty()) {
    const Visit visit = std::move(stack.back());
    stack.pop_back();
    const int index = visit.node;
    if (index < 0 || static_cast<size_t>(index) >= model.nodes.size()) {
      invalid(pre + "node " + std::to_string(index) + " does not exist", at({}, visit.reference));
    }
    if (visited[static_cast<size_t>(index)]) {
      invalid(pre + "node " + std::to_string(index) +
                  " is reached twice (a cycle or several parents in the node hierarchy)",
              at({}, visit.reference));
    }
    visited[static_cast<size_t>(index)] = 1;
    const tinygltf::Node& node = model.nodes[static_cast<size_t>(index)];
    const std::string node_pointer = "/nodes/" + std::to_string(index);
    // A node with a mesh becomes the next scene object: its faults name that object.
    ObjectSite site;
    if (node.mesh >= 0) {
      site.object = static_cast<int64_t>(scene.objects.size());
      site.label = node.name.empty() ? "node_" + std::to_string(index) : node.name;
    }
    const Mat4 world = multiply(visit.parent, local_transform(node, index, site, pre));
    if (node.mesh >= 0) {
      if (static_cast<size_t>(node.mesh) >= model.meshes.size()) {
        invalid(pre + "node " + std::to_string(index) + " refers to missing mesh " +
                    std::to_string(node.mesh),
                at(site, node_pointer + "/mesh"));
      }
      SceneObject object;
      object.label = site.label;
      const tinygltf::Mesh& mesh = model.meshes[static_cast<size_t>(node.mesh)];
      for (size_t p = 0; p < mesh.primitives.size(); ++p) {
        add_primitive(model, mesh.primitives[p], world,
                      pre + "node " + std::to_string(index) + " (\"" + object.label + "\") mesh " +
                          std::to_string(node.mesh) + " primitive " + std::to_string(p),
                      "/meshes/" + std::to_string(node.mesh) + "/primitives/" + std::to_string(p),
                      site, object, limits, total);
      }
      scene.objects.push_back(std::move(object));
    }
    for (size_t k = node.children.size(); k-- > 0;) {
      stack.push_back({node.children[k], world, node_pointer + "/children/" + std::to_string(k)});
    }
  }
  if (scene.objects.empty())
    invalid(pre + "no node with a mesh in the scene", at({}, model.nodes.empty() ? "" : "/nodes"));
  return scene;
}

}  // namespace gvd::scene
