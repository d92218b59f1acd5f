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

namespace gvd {

// Entry point used by load_scene.cpp (declared there too).
Scene parse_gltf(std::span<const uint8_t> bytes, bool binary, const std::string& name,
                 const SceneLimits& limits);

namespace {

[[noreturn]] void invalid(std::string detail) {
  throw Error(ErrorCode::kInvalidScene, std::move(detail));
}

uint32_t read_u32(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) | static_cast<uint32_t>(p[1]) << 8 |
         static_cast<uint32_t>(p[2]) << 16 | static_cast<uint32_t>(p[3]) << 24;
}

/// Checks the GLB container (header and chunk table) before tinygltf sees it, so that a
/// truncated or lying file gets a precise message. Returns the JSON chunk.
std::string_view check_glb_container(std::span<const uint8_t> bytes, const std::string& pre) {
  if (bytes.size() < 12) {
    invalid(pre + "truncated GLB: " + std::to_string(bytes.size()) +
            " bytes, the header alone needs 12");
  }
  if (std::memcmp(bytes.data(), "glTF", 4) != 0) invalid(pre + "missing the GLB magic \"glTF\"");
  const uint32_t version = read_u32(bytes.data() + 4);
  if (version != 2)
    invalid(pre + "GLB version " + std::to_string(version) + " (only 2 is supported)");
  const uint32_t length = read_u32(bytes.data() + 8);
  if (length > bytes.size()) {
    invalid(pre + "truncated GLB: the header announces " + std::to_string(length) +
            " bytes but only " + std::to_string(bytes.size()) + " are present");
  }
  if (length < 20) invalid(pre + "GLB too short to hold a JSON chunk");
  const uint64_t json_length = read_u32(bytes.data() + 12);
  if (read_u32(bytes.data() + 16) != 0x4E4F534Au) invalid(pre + "the first GLB chunk is not JSON");
  if (20 + json_length > length) {
    invalid(pre + "truncated GLB: the JSON chunk announces " + std::to_string(json_length) +
            " bytes but only " + std::to_string(length - 20) + " follow");
  }
  uint64_t pos = 20 + json_length;
  while (pos < length) {
    if (length - pos < 8)
      invalid(pre + "truncated GLB: incomplete chunk header at byte " + std::to_string(pos));
    const uint64_t chunk = read_u32(bytes.data() + pos);
    if (pos + 8 + chunk > length) {
      invalid(pre + "truncated GLB: the chunk at byte " + std::to_string(pos) + " announces " +
              std::to_string(chunk) + " bytes but only " + std::to_string(length - pos - 8) +
              " follow");
    }
    pos += 8 + chunk;
  }
  return {reinterpret_cast<const char*>(bytes.data()) + 20, static_cast<size_t>(json_length)};
}

/// We never read files on behalf of a document (the service gets untrusted input): every
/// buffer must be embedded (GLB BIN chunk or data: URI).
void check_no_external_buffers(std::string_view json_text, const std::string& pre) {
  nlohmann::json doc;
  try {
    doc = parse_json_input(json_text, "the glTF JSON", ErrorCode::kInvalidScene);
  } catch (const Error& e) {  // the offset is within the glTF JSON, not the file: detail only
    invalid(pre + e.what());
  }
  if (!doc.is_object()) invalid(pre + "the glTF JSON is not an object");
  const auto buffers = doc.find("buffers");
  if (buffers == doc.end() || !buffers->is_array()) return;
  for (size_t i = 0; i < buffers->size(); ++i) {
    const nlohmann::json& b = (*buffers)[i];
    if (!b.is_object()) continue;
    const auto uri = b.find("uri");
    if (uri != b.end() && uri->is_string() &&
        !uri->get_ref<const std::string&>().starts_with("data:")) {
      invalid(pre + "buffer " + std::to_string(i) + " refers to the external file \"" +
              uri->get<std::string>() +
              "\": external buffers are not supported (embed them, or send a GLB)");
    }
  }
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

Mat4 local_transform(const tinygltf::Node& node, const std::string& pre) {
  if (!node.matrix.empty()) {
    if (node.matrix.size() != 16)
      invalid(pre + "node \"" + node.name + "\": matrix needs 16 numbers");
    Mat4 m;
    std::copy(node.matrix.begin(), node.matrix.end(), m.begin());
    return m;
  }
  Mat4 t = identity(), r = identity(), s = identity();
  if (!node.translation.empty()) {
    if (node.translation.size() != 3) invalid(pre + "node \"" + node.name + "\": bad translation");
    t[12] = node.translation[0];
    t[13] = node.translation[1];
    t[14] = node.translation[2];
  }
  if (!node.rotation.empty()) {
    if (node.rotation.size() != 4) invalid(pre + "node \"" + node.name + "\": bad rotation");
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
    if (node.scale.size() != 3) invalid(pre + "node \"" + node.name + "\": bad scale");
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
  AccessorView(const tinygltf::Model& model, int index, const std::string& where) {
    if (index < 0 || static_cast<size_t>(index) >= model.accessors.size()) {
      invalid(where + ": accessor " + std::to_string(index) + " does not exist");
    }
    const tinygltf::Accessor& a = model.accessors[static_cast<size_t>(index)];
    const std::string at = where + ": accessor " + std::to_string(index);
    if (a.sparse.isSparse) invalid(at + " is sparse (not supported)");
    if (a.bufferView < 0 || static_cast<size_t>(a.bufferView) >= model.bufferViews.size()) {
      invalid(at + " has no valid bufferView");
    }
    const tinygltf::BufferView& view = model.bufferViews[static_cast<size_t>(a.bufferView)];
    if (view.buffer < 0 || static_cast<size_t>(view.buffer) >= model.buffers.size()) {
      invalid(at + ": bufferView " + std::to_string(a.bufferView) + " has no valid buffer");
    }
    const std::vector<unsigned char>& data = model.buffers[static_cast<size_t>(view.buffer)].data;
    component_type_ = a.componentType;
    const int size = tinygltf::GetComponentSizeInBytes(static_cast<uint32_t>(a.componentType));
    const int components = tinygltf::GetNumComponentsInType(static_cast<uint32_t>(a.type));
    if (size <= 0 || components <= 0) invalid(at + " has an unknown component type or type");
    component_size_ = static_cast<size_t>(size);
    components_ = components;
    normalized_ = a.normalized;
    count = a.count;
    const size_t element = component_size_ * static_cast<size_t>(components);
    stride_ = view.byteStride != 0 ? view.byteStride : element;
    if (stride_ < element) invalid(at + ": byteStride smaller than an element");
    if (view.byteOffset > data.size() || view.byteLength > data.size() - view.byteOffset) {
      invalid(at + ": bufferView " + std::to_string(a.bufferView) + " exceeds its buffer");
    }
    if (count > 0) {
      if (count > view.byteLength || stride_ > view.byteLength || a.byteOffset > view.byteLength) {
        invalid(at + ": " + std::to_string(count) + " elements exceed bufferView " +
                std::to_string(a.bufferView) + " (" + std::to_string(view.byteLength) + " bytes)");
      }
      const uint64_t need = a.byteOffset + static_cast<uint64_t>(stride_) * (count - 1) + element;
      if (need > view.byteLength) {
        invalid(at + ": " + std::to_string(count) + " elements exceed bufferView " +
                std::to_string(a.bufferView) + " (" + std::to_string(view.byteLength) + " bytes)");
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

/// Appends the triangles of one primitive (positions transformed) to `object`.
void add_primitive(const tinygltf::Model& model, const tinygltf::Primitive& prim, const Mat4& world,
                   const std::string& where, SceneObject& object, const SceneLimits& limits,
                   uint64_t& total) {
  const auto pos_it = prim.attributes.find("POSITION");
  if (pos_it == prim.attributes.end()) invalid(where + " has no POSITION attribute");
  const AccessorView positions(model, pos_it->second, where + " POSITION");
  if (positions.components() != 3) invalid(where + ": POSITION is not a VEC3");
  const auto offset = static_cast<uint32_t>(object.vertices.size());
  const size_t simplices_before = object.simplices.size();
  if (positions.count > 0xFFFFFFF0ull - offset) invalid(where + ": too many vertices");
  for (size_t i = 0; i < positions.count; ++i) {
    object.vertices.push_back(
        apply(world, {positions.get(i, 0), positions.get(i, 1), positions.get(i, 2)}));
  }
  std::vector<uint32_t> index;
  if (prim.indices >= 0) {
    const AccessorView indices(model, prim.indices, where + " indices");
    if (indices.components() != 1) invalid(where + ": indices are not SCALAR");
    if (indices.component_type() == TINYGLTF_COMPONENT_TYPE_FLOAT ||
        indices.component_type() == TINYGLTF_COMPONENT_TYPE_DOUBLE) {
      invalid(where + ": indices must have an integer component type");
    }
    index.reserve(indices.count);
    for (size_t i = 0; i < indices.count; ++i) {
      const double v = indices.get(i, 0);
      if (v < 0 || v >= static_cast<double>(positions.count)) {
        invalid(where + ": index " + std::to_string(i) + " = " + std::to_string(v) +
                " is out of range (" + std::to_string(positions.count) + " vertices)");
      }
      index.push_back(static_cast<uint32_t>(v));
    }
  } else {
    index.resize(positions.count);
    for (size_t i = 0; i < positions.count; ++i) index[i] = static_cast<uint32_t>(i);
  }
  const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
  auto add = [&](uint32_t a, uint32_t b, uint32_t c) {
    object.simplices.push_back(Simplex{{a + offset, b + offset, c + offset}});
  };
  if (mode == TINYGLTF_MODE_TRIANGLES) {
    if (index.size() % 3 != 0) invalid(where + ": TRIANGLES with a count not divisible by 3");
    for (size_t i = 0; i + 2 < index.size(); i += 3) add(index[i], index[i + 1], index[i + 2]);
  } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
    for (size_t i = 0; i + 2 < index.size(); ++i) {
      if (i % 2 == 0) {
        add(index[i], index[i + 1], index[i + 2]);
      } else {
        add(index[i + 1], index[i], index[i + 2]);
      }
    }
  } else if (mode == TINYGLTF_MODE_TRIANGLE_FAN) {
    for (size_t i = 1; i + 1 < index.size(); ++i) add(index[0], index[i], index[i + 1]);
  } else {
    invalid(where + ": primitive mode " + std::to_string(mode) +
            " is not a surface (points/lines are not supported)");
  }
  total += object.simplices.size() - simplices_before;
  if (total > limits.max_simplices) {
    throw Error(ErrorCode::kLimitExceeded, "more than the limit of " +
                                               std::to_string(limits.max_simplices) +
                                               " triangles (reached at " + where + ")");
  }
}

}  // namespace

Scene parse_gltf(std::span<const uint8_t> bytes, bool binary, const std::string& name,
                 const SceneLimits& limits) {
  const std::string pre = (binary ? "GLB \"" : "glTF \"") + name + "\": ";
  if (bytes.size() > 0xFFFFFFFFull) invalid(pre + "file larger than 4 GiB");
  std::string_view json_text;
  if (binary) {
    json_text = check_glb_container(bytes, pre);
  } else {
    json_text = {reinterpret_cast<const char*>(bytes.data()), bytes.size()};
  }
  check_no_external_buffers(json_text, pre);

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
    invalid(pre + (err.empty() ? std::string("tinygltf could not load it") : err));
  }

  // Roots: the default scene's nodes (or scene 0), else every node that is nobody's child.
  std::vector<int> roots;
  if (!model.scenes.empty()) {
    const size_t s =
        model.defaultScene >= 0 && static_cast<size_t>(model.defaultScene) < model.scenes.size()
            ? static_cast<size_t>(model.defaultScene)
            : 0;
    roots = model.scenes[s].nodes;
  } else {
    std::vector<char> is_child(model.nodes.size(), 0);
    for (const tinygltf::Node& n : model.nodes) {
      for (int c : n.children) {
        if (c >= 0 && static_cast<size_t>(c) < model.nodes.size())
          is_child[static_cast<size_t>(c)] = 1;
      }
    }
    for (size_t i = 0; i < model.nodes.size(); ++i) {
      if (!is_child[i]) roots.push_back(static_cast<int>(i));
    }
  }

  Scene scene;
  scene.dimension = 3;
  std::vector<char> visited(model.nodes.size(), 0);
  std::vector<std::pair<int, Mat4>> stack;
  for (auto it = roots.rbegin(); it != roots.rend(); ++it) stack.emplace_back(*it, identity());
  uint64_t total = 0;
  while (!stack.empty()) {
    auto [index, parent] = stack.back();
    stack.pop_back();
    if (index < 0 || static_cast<size_t>(index) >= model.nodes.size()) {
      invalid(pre + "node " + std::to_string(index) + " does not exist");
    }
    if (visited[static_cast<size_t>(index)]) {
      invalid(pre + "node " + std::to_string(index) +
              " is reached twice (a cycle or several parents in the node hierarchy)");
    }
    visited[static_cast<size_t>(index)] = 1;
    const tinygltf::Node& node = model.nodes[static_cast<size_t>(index)];
    const Mat4 world = multiply(parent, local_transform(node, pre));
    if (node.mesh >= 0) {
      if (static_cast<size_t>(node.mesh) >= model.meshes.size()) {
        invalid(pre + "node " + std::to_string(index) + " refers to missing mesh " +
                std::to_string(node.mesh));
      }
      SceneObject object;
      object.label = node.name.empty() ? "node_" + std::to_string(index) : node.name;
      const tinygltf::Mesh& mesh = model.meshes[static_cast<size_t>(node.mesh)];
      for (size_t p = 0; p < mesh.primitives.size(); ++p) {
        add_primitive(model, mesh.primitives[p], world,
                      pre + "node " + std::to_string(index) + " (\"" + object.label + "\") mesh " +
                          std::to_string(node.mesh) + " primitive " + std::to_string(p),
                      object, limits, total);
      }
      scene.objects.push_back(std::move(object));
    }
    for (auto it = node.children.rbegin(); it != node.children.rend(); ++it) {
      stack.emplace_back(*it, world);
    }
  }
  if (scene.objects.empty()) invalid(pre + "no node with a mesh in the scene");
  return scene;
}

}  // namespace gvd
