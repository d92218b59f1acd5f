// Format detection, dispatch to the readers, and loading from files.
#include "gvd/scene/load_scene.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <system_error>
#include <unordered_map>
#include <utility>
#include <vector>

#include "gvd/common/error.h"

namespace gvd::scene {

// The readers, one definition each in scene_json.cpp, mesh_formats.cpp and gltf_scene.cpp.
// They return unvalidated scenes (except scene_from_json_value, which validates).
Scene scene_from_json_value(const nlohmann::json& doc, const SceneLimits& limits,
                            const std::atomic<bool>* cancel = nullptr);
/// The JSON text parsed once its nesting, objects, vertices, simplices and values are counted
/// within `limits` (a pass that builds nothing, so an oversized scene is refused early).
nlohmann::json parse_scene_json_value(std::string_view text, const SceneLimits& limits,
                                      const std::atomic<bool>* cancel);
Scene parse_obj(std::string_view text, const std::string& name, bool single_object,
                const SceneLimits& limits);
Scene parse_ply(std::span<const uint8_t> bytes, const std::string& name, const SceneLimits& limits);
Scene parse_stl(std::span<const uint8_t> bytes, const std::string& name, const SceneLimits& limits);
Scene parse_off(std::string_view text, const std::string& name, const SceneLimits& limits);
Scene parse_gltf(std::span<const uint8_t> bytes, bool binary, const std::string& name,
                 const SceneLimits& limits);
bool is_binary_stl(std::span<const uint8_t> bytes);

namespace {

std::string_view as_text(std::span<const uint8_t> bytes) {
  return {reinterpret_cast<const char*>(bytes.data()), bytes.size()};
}

/// The text without a UTF-8 byte order mark and leading blanks.
std::string_view skip_leading(std::string_view s) {
  if (s.starts_with("\xEF\xBB\xBF")) s.remove_prefix(3);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  return s;
}

bool has_obj_lines(std::string_view text) {
  size_t start = 0;
  while (start < text.size()) {
    size_t end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = skip_leading(text.substr(start, end - start));
    if (line.size() >= 2 && (line[0] == 'v' || line[0] == 'f') &&
        (line[1] == ' ' || line[1] == '\t')) {
      return true;
    }
    start = end + 1;
  }
  return false;
}

/// One object holding all the objects of `scene` (vertex indices offset), labelled `label`.
SceneObject merge_objects(Scene& scene, const std::string& label) {
  SceneObject merged;
  merged.label = label;
  for (SceneObject& o : scene.objects) {
    const auto offset = static_cast<uint32_t>(merged.vertices.size());
    merged.vertices.insert(merged.vertices.end(), o.vertices.begin(), o.vertices.end());
    for (Simplex s : o.simplices) {
      s.v[0] += offset;
      s.v[1] += offset;
      if (scene.dimension == 3) s.v[2] += offset;
      merged.simplices.push_back(s);
    }
  }
  return merged;
}

/// Where an error of part `part` (labelled `label`) lies in the scene of parts: the part is the
/// object. The element keeps its index when it lay in the part's first object, which starts
/// the merged one (merge_objects); elsewhere the index was its sub-object's, and the pointer,
/// line or offset still says where.
ErrorLocation in_part(ErrorLocation where, size_t part, const std::string& label) {
  if (where.object > 0) {
    where.element.clear();
    where.index = -1;
  }
  where.object = static_cast<int64_t>(part);
  where.label = label;
  return where;
}

/// Parses and validates; `single_object` makes OBJ groups one object labelled `name`.
Scene parse_bytes(std::span<const uint8_t> bytes, SceneFormat format, const std::string& name,
                  const SceneLimits& limits, bool single_object) {
  const std::string_view text = as_text(bytes);
  if (format == SceneFormat::kAuto) {
    const std::string_view lead = skip_leading(text);
    if (bytes.size() >= 4 && text.starts_with("glTF")) {
      format = SceneFormat::kGlb;
    } else if (lead.starts_with("{") || lead.starts_with("[") || lead.starts_with("null") ||
               lead.starts_with("true") || lead.starts_with("false")) {
      // JSON that is no object is no scene either: said as such (not "unrecognised format").
      const nlohmann::json doc = parse_scene_json_value(text, limits, nullptr);
      if (doc.is_object() && doc.contains("asset")) {
        format = SceneFormat::kGltf;
      } else {
        return scene_from_json_value(doc, limits);
      }
    } else if (text.starts_with("ply")) {
      format = SceneFormat::kPly;
    } else if (lead.starts_with("OFF") || lead.starts_with("COFF") || lead.starts_with("NOFF") ||
               lead.starts_with("CNOFF") || lead.starts_with("STOFF")) {
      format = SceneFormat::kOff;
    } else if (is_binary_stl(bytes) || lead.starts_with("solid")) {
      format = SceneFormat::kStl;
    } else if (has_obj_lines(text)) {
      format = SceneFormat::kObj;
    } else {
      throw Error(ErrorCode::kUnsupportedFormat,
                  "\"" + name +
                      "\": unrecognised format (expected scene JSON, OBJ, glTF/GLB, PLY, STL or "
                      "OFF)");
    }
  }
  Scene scene;
  switch (format) {
    case SceneFormat::kJson:
      return scene_from_json_value(parse_scene_json_value(text, limits, nullptr), limits);
    case SceneFormat::kObj:
      scene = parse_obj(text, name, single_object, limits);
      break;
    case SceneFormat::kGltf:
    case SceneFormat::kGlb:
      // A .gltf given as kGltf may still be binary and vice versa: trust the magic.
      scene = parse_gltf(bytes, text.starts_with("glTF"), name, limits);
      break;
    case SceneFormat::kPly:
      scene = parse_ply(bytes, name, limits);
      break;
    case SceneFormat::kStl:
      scene = parse_stl(bytes, name, limits);
      break;
    case SceneFormat::kOff:
      scene = parse_off(text, name, limits);
      break;
    case SceneFormat::kAuto:
      break;
  }
  validate_scene(scene, limits);
  return scene;
}

SceneFormat format_of_path(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".json") return SceneFormat::kJson;
  if (ext == ".obj") return SceneFormat::kObj;
  if (ext == ".gltf") return SceneFormat::kGltf;
  if (ext == ".glb") return SceneFormat::kGlb;
  if (ext == ".ply") return SceneFormat::kPly;
  if (ext == ".stl") return SceneFormat::kStl;
  if (ext == ".off") return SceneFormat::kOff;
  return SceneFormat::kAuto;
}

std::vector<uint8_t> read_file(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw Error(ErrorCode::kIo,
                "cannot read \"" + path + "\": " +
                    (std::filesystem::exists(path, ec) ? "not a regular file" : "no such file"));
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(ErrorCode::kIo, "cannot open \"" + path + "\"");
  std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                             std::istreambuf_iterator<char>());
  if (in.bad()) throw Error(ErrorCode::kIo, "error while reading \"" + path + "\"");
  return bytes;
}

}  // namespace

Scene parse_scene_bytes(std::span<const uint8_t> bytes, SceneFormat format, const std::string& name,
                        const SceneLimits& limits) {
  return parse_bytes(bytes, format, name, limits, false);
}

Scene load_scene(std::span<const std::string> paths, const SceneLimits& limits) {
  if (paths.empty()) throw Error(ErrorCode::kInvalidArgument, "no input files");
  if (paths.size() == 1) {
    const std::filesystem::path path(paths[0]);
    const std::vector<uint8_t> bytes = read_file(paths[0]);
    return parse_bytes(bytes, format_of_path(path), path.stem().string(), limits, false);
  }
  std::vector<std::vector<uint8_t>> contents;
  std::vector<ScenePart> parts;
  if (paths.size() > limits.max_objects) {  // before reading any
    throw Error(ErrorCode::kLimitExceeded, std::to_string(paths.size()) +
                                               " files, more than the limit of " +
                                               std::to_string(limits.max_objects) + " objects");
  }
  contents.reserve(paths.size());
  for (const std::string& p : paths) {
    const std::filesystem::path path(p);
    contents.push_back(read_file(p));
    parts.push_back({path.stem().string(), contents.back(), format_of_path(path), "\"" + p + "\""});
  }
  return parse_scene_parts(parts, limits);
}

Scene parse_scene_parts(std::span<const ScenePart> parts, const SceneLimits& limits) {
  if (parts.empty()) throw Error(ErrorCode::kInvalidScene, "no meshes: a scene needs objects");
  if (parts.size() > limits.max_objects) {
    throw Error(ErrorCode::kLimitExceeded, std::to_string(parts.size()) +
                                               " meshes, more than the limit of " +
                                               std::to_string(limits.max_objects) + " objects");
  }
  Scene scene;
  std::unordered_map<std::string, size_t> part_of_label;
  for (size_t i = 0; i < parts.size(); ++i) {
    const ScenePart& part = parts[i];
    if (part.label.empty())
      throw Error(ErrorCode::kInvalidScene, part.source + " has no label (its name is the label)");
    auto [it, inserted] = part_of_label.emplace(part.label, i);
    if (!inserted) {
      throw Error(ErrorCode::kInvalidScene, parts[it->second].source + " and " + part.source +
                                                " have the same label \"" + part.label +
                                                "\" (labels must be unique)");
    }
    Scene piece;
    try {
      piece = parse_bytes(part.bytes, part.format, part.label, limits, true);
    } catch (const Error& e) {
      if (e.code() == ErrorCode::kInternal) throw;
      throw Error(e.code(), e.detail(), in_part(e.where(), i, part.label));
    }
    if (i == 0) {
      scene.dimension = piece.dimension;
    } else if (piece.dimension != scene.dimension) {
      throw Error(ErrorCode::kInvalidScene, part.source + " is " + std::to_string(piece.dimension) +
                                                "D but " + parts[0].source + " is " +
                                                std::to_string(scene.dimension) + "D");
    }
    scene.objects.push_back(merge_objects(piece, part.label));
    // Keep what the per-part validation removed (degenerate simplices, ...), now under the
    // part's label; validate_scene below recomputes the topology warnings on the merged object.
    for (SceneWarning& w : piece.warnings) {
      if (w.kind == WarningKind::kDegenerateSimplices && !w.object.empty() &&
          w.object != part.label) {
        w.detail = part.source + ", " + w.detail;
      }
      w.object = part.label;
      scene.warnings.push_back(std::move(w));
    }
  }
  validate_scene(scene, limits);
  return scene;
}

}  // namespace gvd::scene
