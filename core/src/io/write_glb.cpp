// The GVD as binary glTF (docs/FORMATS.md, "GVD GLB"). All tinygltf use of the core lives here so
// that its heavy header is compiled once (it costs seconds per translation unit).
#include <tiny_gltf.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "gvd/common/error.h"
#include "gvd/io/write_outputs.h"

namespace gvd::io {

using namespace gvd::scene;
using namespace gvd::surface;

namespace {

/// The scene's length unit as asset.extras.units (glTF's own unit is the metre; ours is a
/// label, as everywhere: positions are the scene's coordinates, not converted). None: no extras.
void set_units(tinygltf::Asset& asset, const std::string& units) {
  if (units.empty()) return;
  tinygltf::Value::Object extras;
  extras["units"] = tinygltf::Value(units);
  asset.extras = tinygltf::Value(std::move(extras));
}

constexpr const char* kMeshFeaturesExtension = "EXT_mesh_features";

/// Colour of the domain-box side of a cell: it has no clearance to speak of.
constexpr std::array<float, 3> kBoxColor = {0.5f, 0.5f, 0.5f};

/// The clearance ramp: red at 0 -> yellow -> green -> blue at `max_clearance` (piecewise
/// linear with the three segments of equal length), so that tight places stand out in red.
std::array<float, 3> clearance_color(double clearance, double max_clearance) {
  double t = max_clearance > 0 ? clearance / max_clearance : 0.0;
  t = std::clamp(t, 0.0, 1.0) * 3.0;
  std::array<double, 3> rgb;
  if (t <= 1.0) {
    rgb = {1.0, t, 0.0};  // red -> yellow
  } else if (t <= 2.0) {
    rgb = {2.0 - t, 1.0, 0.0};  // yellow -> green
  } else {
    rgb = {0.0, 3.0 - t, t - 2.0};  // green -> blue
  }
  return {static_cast<float>(rgb[0]), static_cast<float>(rgb[1]), static_cast<float>(rgb[2])};
}

/// Appends `bytes` to the single buffer at a 4-byte aligned offset (every component type we
/// write is at most 4 bytes wide, so this satisfies glTF's accessor alignment) and adds a
/// bufferView with the given target. Returns the bufferView index.
int add_buffer_view(tinygltf::Model& model, const void* data, size_t bytes, int target) {
  std::vector<unsigned char>& buffer = model.buffers[0].data;
  buffer.resize((buffer.size() + 3) / 4 * 4, 0);
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = buffer.size();
  view.byteLength = bytes;
  view.target = target;
  const auto* begin = static_cast<const unsigned char*>(data);
  buffer.insert(buffer.end(), begin, begin + bytes);
  model.bufferViews.push_back(std::move(view));
  return static_cast<int>(model.bufferViews.size() - 1);
}

/// A float32 accessor of `components` components per element over a new bufferView.
/// `target` 0 leaves the bufferView untargeted (animation data).
int add_float_accessor(tinygltf::Model& model, const std::vector<float>& values, int components,
                       bool with_bounds, int target = TINYGLTF_TARGET_ARRAY_BUFFER) {
  const size_t count = values.size() / static_cast<size_t>(components);
  tinygltf::Accessor accessor;
  accessor.bufferView =
      add_buffer_view(model, values.data(), values.size() * sizeof(float), target);
  accessor.byteOffset = 0;
  accessor.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
  accessor.count = count;
  accessor.type = components == 1 ? TINYGLTF_TYPE_SCALAR : TINYGLTF_TYPE_VEC3;
  if (with_bounds) {
    // The bounds of the float32 values actually stored (not of the doubles they came from):
    // the validator compares them exactly.
    accessor.minValues.assign(static_cast<size_t>(components), std::numeric_limits<double>::max());
    accessor.maxValues.assign(static_cast<size_t>(components),
                              std::numeric_limits<double>::lowest());
    for (size_t i = 0; i < values.size(); ++i) {
      const size_t c = i % static_cast<size_t>(components);
      accessor.minValues[c] = std::min(accessor.minValues[c], static_cast<double>(values[i]));
      accessor.maxValues[c] = std::max(accessor.maxValues[c], static_cast<double>(values[i]));
    }
  }
  model.accessors.push_back(std::move(accessor));
  return static_cast<int>(model.accessors.size() - 1);
}

/// The index accessor: uint16 when every index fits below the uint16 restart value 65535
/// (which glTF forbids as an index), uint32 otherwise.
int add_index_accessor(tinygltf::Model& model, const std::vector<uint32_t>& indices,
                       size_t vertex_count) {
  tinygltf::Accessor accessor;
  if (vertex_count <= 0xFFFFu) {
    std::vector<uint16_t> narrow(indices.begin(), indices.end());
    accessor.bufferView = add_buffer_view(model, narrow.data(), narrow.size() * sizeof(uint16_t),
                                          TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
    accessor.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
  } else {
    accessor.bufferView = add_buffer_view(model, indices.data(), indices.size() * sizeof(uint32_t),
                                          TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
    accessor.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
  }
  accessor.byteOffset = 0;
  accessor.count = indices.size();
  accessor.type = TINYGLTF_TYPE_SCALAR;
  model.accessors.push_back(std::move(accessor));
  return static_cast<int>(model.accessors.size() - 1);
}

/// Checks the invariants of a cell that the writer relies on (our bug if violated: the GVD is
/// produced by the pipeline, not by the user).
void check_cell(const GvdCell& cell, ObjectId index, size_t object_count, int dimension) {
  const size_t n = cell.positions.size();
  GVD_CHECK(cell.object == index, "gvd cell i must belong to object i");
  GVD_CHECK(cell.other.size() == n && cell.clearance.size() == n,
            "gvd cell attributes must have one value per vertex");
  GVD_CHECK(cell.indices.size() % static_cast<size_t>(dimension) == 0,
            "gvd cell indices must form whole simplices");
  for (uint32_t v : cell.indices) GVD_CHECK(v < n, "gvd cell index out of range");
  for (size_t v = 0; v < n; ++v) {
    const Vec3 p = cell.positions[v];
    GVD_CHECK(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z),
              "gvd cell position must be finite");
    GVD_CHECK(std::isfinite(cell.clearance[v]), "gvd cell clearance must be finite");
    GVD_CHECK(cell.other[v] == kNoObject || cell.other[v] < object_count,
              "gvd cell 'other' must be an object of the scene or the domain box");
  }
}

/// Adds the mesh of one non-empty cell and the node that shows it; returns the node index.
int add_cell(tinygltf::Model& model, const GvdCell& cell, ObjectId index, const Scene& scene,
             int dimension, double max_clearance) {
  const size_t n = cell.positions.size();
  const auto null_feature_id = static_cast<uint32_t>(scene.objects.size());

  std::vector<float> positions;
  std::vector<float> feature_ids;
  std::vector<float> clearance;
  std::vector<float> colors;
  positions.reserve(3 * n);
  feature_ids.reserve(n);
  clearance.reserve(n);
  colors.reserve(3 * n);
  std::set<uint32_t> distinct_features;
  for (size_t v = 0; v < n; ++v) {
    const Vec3 p = cell.positions[v];
    positions.push_back(static_cast<float>(p.x));
    positions.push_back(static_cast<float>(p.y));
    positions.push_back(dimension == 2 ? 0.0f : static_cast<float>(p.z));
    const bool is_box = cell.other[v] == kNoObject;
    const uint32_t feature = is_box ? null_feature_id : cell.other[v];
    if (!is_box) distinct_features.insert(feature);
    feature_ids.push_back(static_cast<float>(feature));
    clearance.push_back(static_cast<float>(cell.clearance[v]));
    const std::array<float, 3> rgb =
        is_box ? kBoxColor : clearance_color(cell.clearance[v], max_clearance);
    colors.insert(colors.end(), rgb.begin(), rgb.end());
  }

  tinygltf::Primitive primitive;
  primitive.mode = dimension == 2 ? TINYGLTF_MODE_LINE : TINYGLTF_MODE_TRIANGLES;
  primitive.attributes["POSITION"] = add_float_accessor(model, positions, 3, true);
  primitive.attributes["_FEATURE_ID_0"] = add_float_accessor(model, feature_ids, 1, false);
  primitive.attributes["_CLEARANCE"] = add_float_accessor(model, clearance, 1, false);
  primitive.attributes["COLOR_0"] = add_float_accessor(model, colors, 3, false);
  primitive.indices = add_index_accessor(model, cell.indices, n);

  // EXT_mesh_features: the feature id is the vertex attribute _FEATURE_ID_0; featureCount
  // counts the distinct objects across this cell's boundary (the schema wants at least 1).
  tinygltf::Value::Object feature_id;
  feature_id["featureCount"] =
      tinygltf::Value(std::max(1, static_cast<int>(distinct_features.size())));
  feature_id["attribute"] = tinygltf::Value(0);
  feature_id["nullFeatureId"] = tinygltf::Value(static_cast<int>(null_feature_id));
  tinygltf::Value::Object mesh_features;
  mesh_features["featureIds"] =
      tinygltf::Value(tinygltf::Value::Array{tinygltf::Value(std::move(feature_id))});
  primitive.extensions[kMeshFeaturesExtension] = tinygltf::Value(std::move(mesh_features));

  const std::string& label = scene.objects[index].label;
  tinygltf::Mesh mesh;
  mesh.name = label;
  mesh.primitives.push_back(std::move(primitive));
  model.meshes.push_back(std::move(mesh));

  tinygltf::Node node;
  node.name = label;
  node.mesh = static_cast<int>(model.meshes.size() - 1);
  tinygltf::Value::Object extras;
  extras["label"] = tinygltf::Value(label);
  extras["object"] = tinygltf::Value(static_cast<int>(index));
  node.extras = tinygltf::Value(std::move(extras));
  model.nodes.push_back(std::move(node));
  return static_cast<int>(model.nodes.size() - 1);
}

/// The model as a GLB file in two parts. The binary buffer is moved out of the model before
/// tinygltf serialises it (tinygltf copies it into its own buffer and then into the stream:
/// a large GVD was held about five times at once), and only the JSON comes from tinygltf.
GlbFile model_to_glb(tinygltf::Model& model) {
  GlbFile file;
  std::vector<unsigned char> bin;
  if (!model.buffers.empty()) bin = std::move(model.buffers[0].data);
  std::ostringstream out(std::ios::out | std::ios::binary);
  tinygltf::TinyGLTF writer;
  const bool ok = writer.WriteGltfSceneToStream(&model, out, /*prettyPrint=*/false,
                                                /*writeBinary=*/true);
  GVD_CHECK(ok && out.good(), "tinygltf failed to serialise the model");
  // tinygltf's file without binary data: the 12-byte header, then the JSON chunk (8-byte chunk
  // header, then the text, padded with spaces). Its buffer's byteLength is that of the empty
  // buffer: set to the real one.
  const std::string glb = out.str();
  GVD_CHECK(glb.size() >= 20, "tinygltf wrote no JSON chunk");
  uint32_t json_chunk = 0;
  std::memcpy(&json_chunk, glb.data() + 12, sizeof json_chunk);
  GVD_CHECK(glb.size() >= 20 + size_t{json_chunk}, "tinygltf's JSON chunk is truncated");
  std::string json = glb.substr(20, json_chunk);
  while (!json.empty() && json.back() == ' ') json.pop_back();
  if (!bin.empty()) {
    nlohmann::json document = nlohmann::json::parse(json);
    document["buffers"][0]["byteLength"] = bin.size();
    json = document.dump();
  }
  // The container (glTF 2.0 binary, little-endian): what tinygltf writes with the buffer in.
  auto put32 = [&](uint32_t v) {
    unsigned char b[4];
    std::memcpy(b, &v, 4);
    file.head.insert(file.head.end(), b, b + 4);
  };
  const size_t json_padded = (json.size() + 3) / 4 * 4;
  const size_t bin_padded = (bin.size() + 3) / 4 * 4;
  const size_t total = 12 + 8 + json_padded + (bin.empty() ? 0 : 8 + bin_padded);
  GVD_CHECK(total <= 0xFFFFFFFFu, "the GLB exceeds 4 GiB, the format's limit");
  file.head.reserve(12 + 8 + json_padded + 8);
  file.head.insert(file.head.end(), {'g', 'l', 'T', 'F'});
  put32(2);
  put32(static_cast<uint32_t>(total));
  put32(static_cast<uint32_t>(json_padded));
  put32(0x4E4F534Au);  // "JSON"
  file.head.insert(file.head.end(), json.begin(), json.end());
  file.head.resize(12 + 8 + json_padded, ' ');
  if (!bin.empty()) {
    put32(static_cast<uint32_t>(bin_padded));
    put32(0x004E4942u);  // "BIN"
    bin.resize(bin_padded, 0);
    file.bin = std::move(bin);
  }
  return file;
}

/// The flat index list of an object's simplices (3 per triangle, 2 per segment).
std::vector<uint32_t> simplex_indices(const SceneObject& object, int dimension) {
  std::vector<uint32_t> out;
  out.reserve(static_cast<size_t>(dimension) * object.simplices.size());
  for (const Simplex& s : object.simplices) out.insert(out.end(), s.v, s.v + dimension);
  return out;
}

}  // namespace

GlbFile gvd_glb_file(const Gvd& gvd, const Scene& scene) {
  GVD_CHECK(gvd.dimension == 2 || gvd.dimension == 3, "gvd dimension must be 2 or 3");
  GVD_CHECK(gvd.cells.size() <= scene.objects.size(), "gvd has more cells than scene objects");
  // Object indices and the null feature id are written as JSON integers and float32 values:
  // both are exact far beyond SceneLimits::max_objects.
  GVD_CHECK(scene.objects.size() < (size_t{1} << 24), "too many objects for float feature ids");

  double max_clearance = 0;
  for (size_t i = 0; i < gvd.cells.size(); ++i) {
    const GvdCell& cell = gvd.cells[i];
    if (cell.indices.empty()) continue;
    check_cell(cell, static_cast<ObjectId>(i), scene.objects.size(), gvd.dimension);
    for (double c : cell.clearance) max_clearance = std::max(max_clearance, c);
  }

  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = "gvd";
  set_units(model.asset, scene.units);
  model.buffers.emplace_back();
  tinygltf::Scene gltf_scene;
  // A name keeps the scene a JSON object even without nodes (tinygltf writes an empty scene
  // as null, which is invalid glTF).
  gltf_scene.name = "gvd";
  // The buffer at its final size from the start (growing it would hold it twice at times):
  // per vertex 3 + 1 + 1 + 3 floats, per index 2 or 4 bytes, each bufferView 4-byte aligned.
  size_t buffer_bytes = 0;
  for (const GvdCell& cell : gvd.cells) {
    if (cell.indices.empty()) continue;
    const size_t index_bytes = cell.indices.size() * (cell.positions.size() <= 0xFFFFu ? 2 : 4);
    buffer_bytes += 8 * sizeof(float) * cell.positions.size() + (index_bytes + 3) / 4 * 4;
  }
  model.buffers[0].data.reserve(buffer_bytes);
  for (size_t i = 0; i < gvd.cells.size(); ++i) {
    if (gvd.cells[i].indices.empty()) continue;
    gltf_scene.nodes.push_back(add_cell(model, gvd.cells[i], static_cast<ObjectId>(i), scene,
                                        gvd.dimension, max_clearance));
  }
  model.scenes.push_back(std::move(gltf_scene));
  model.defaultScene = 0;

  if (model.buffers[0].data.empty()) {
    // No cell has simplices: glTF forbids a zero-length buffer, and no primitive uses the
    // extension.
    model.buffers.clear();
  } else {
    model.buffers[0].data.resize((model.buffers[0].data.size() + 3) / 4 * 4, 0);
    model.extensionsUsed.push_back(kMeshFeaturesExtension);
  }

  return model_to_glb(model);
}

std::vector<uint8_t> exploded_to_glb(const Scene& scene, std::span<const Vec3> displacement,
                                     double seconds) {
  GVD_CHECK(displacement.size() == scene.objects.size(), "one displacement per object");
  GVD_CHECK(seconds > 0 && std::isfinite(seconds), "animation length must be positive");
  const int dimension = scene.dimension;
  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = "gvd";
  set_units(model.asset, scene.units);
  model.buffers.emplace_back();
  tinygltf::Scene gltf_scene;
  gltf_scene.name = "exploded";
  tinygltf::Animation animation;
  animation.name = "explode";
  const int times = add_float_accessor(model, {0.0f, static_cast<float>(seconds)}, 1, true, 0);
  const size_t n = scene.objects.size();
  for (size_t i = 0; i < n; ++i) {
    const SceneObject& object = scene.objects[i];
    tinygltf::Node node;
    node.name = object.label;
    tinygltf::Value::Object extras;
    extras["label"] = tinygltf::Value(object.label);
    extras["object"] = tinygltf::Value(static_cast<int>(i));
    const Vec3 d = displacement[i];
    extras["displacement"] = tinygltf::Value(tinygltf::Value::Array{
        tinygltf::Value(d.x), tinygltf::Value(d.y), tinygltf::Value(dimension == 2 ? 0.0 : d.z)});
    node.extras = tinygltf::Value(std::move(extras));
    const std::vector<uint32_t> indices = simplex_indices(object, dimension);
    if (!indices.empty()) {
      std::vector<float> positions;
      positions.reserve(3 * object.vertices.size());
      for (const Vec3& p : object.vertices) {
        positions.push_back(static_cast<float>(p.x));
        positions.push_back(static_cast<float>(p.y));
        positions.push_back(dimension == 2 ? 0.0f : static_cast<float>(p.z));
      }
      // A distinct colour per object (golden-angle hues).
      tinygltf::Material material;
      material.name = object.label;
      const double hue = std::fmod(static_cast<double>(i) * 0.618033988749895, 1.0);
      const std::array<float, 3> rgb = clearance_color(hue, 1.0);
      material.pbrMetallicRoughness.baseColorFactor = {rgb[0], rgb[1], rgb[2], 1.0};
      material.pbrMetallicRoughness.metallicFactor = 0.0;
      material.doubleSided = true;
      model.materials.push_back(std::move(material));
      tinygltf::Primitive primitive;
      primitive.mode = dimension == 2 ? TINYGLTF_MODE_LINE : TINYGLTF_MODE_TRIANGLES;
      primitive.attributes["POSITION"] = add_float_accessor(model, positions, 3, true);
      primitive.indices = add_index_accessor(model, indices, object.vertices.size());
      primitive.material = static_cast<int>(model.materials.size() - 1);
      tinygltf::Mesh mesh;
      mesh.name = object.label;
      mesh.primitives.push_back(std::move(primitive));
      model.meshes.push_back(std::move(mesh));
      node.mesh = static_cast<int>(model.meshes.size() - 1);
    }
    model.nodes.push_back(std::move(node));
    const int node_index = static_cast<int>(model.nodes.size() - 1);
    gltf_scene.nodes.push_back(node_index);
    // Translation from 0 to the displacement over `seconds`, linear.
    tinygltf::AnimationSampler sampler;
    sampler.input = times;
    sampler.output =
        add_float_accessor(model,
                           {0.0f, 0.0f, 0.0f, static_cast<float>(d.x), static_cast<float>(d.y),
                            dimension == 2 ? 0.0f : static_cast<float>(d.z)},
                           3, false, 0);
    sampler.interpolation = "LINEAR";
    animation.samplers.push_back(std::move(sampler));
    tinygltf::AnimationChannel channel;
    channel.sampler = static_cast<int>(animation.samplers.size() - 1);
    channel.target_node = node_index;
    channel.target_path = "translation";
    animation.channels.push_back(std::move(channel));
  }
  model.animations.push_back(std::move(animation));
  model.scenes.push_back(std::move(gltf_scene));
  model.defaultScene = 0;
  model.buffers[0].data.resize((model.buffers[0].data.size() + 3) / 4 * 4, 0);
  return model_to_glb(model).bytes();
}

std::vector<uint8_t> gvd_to_glb(const Gvd& gvd, const Scene& scene) {
  return gvd_glb_file(gvd, scene).bytes();
}

void write_glb_file(const std::string& path, const Gvd& gvd, const Scene& scene) {
  const GlbFile glb = gvd_glb_file(gvd, scene);
  write_file_atomic(path, [&](const std::function<void(std::string_view)>& put) {
    for (const std::vector<uint8_t>* part : {&glb.head, &glb.bin})
      put(std::string_view(reinterpret_cast<const char*>(part->data()), part->size()));
  });
}

std::vector<uint8_t> GlbFile::bytes() && {
  std::vector<uint8_t> out = std::move(head);
  out.insert(out.end(), bin.begin(), bin.end());
  std::vector<uint8_t>().swap(bin);
  return out;
}

}  // namespace gvd::io
