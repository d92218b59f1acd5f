#pragma once

// Reading scenes: the native JSON and the mesh formats (OBJ, glTF/GLB, PLY, STL, OFF), from one
// file or merged from several parts, one object per part, and validated within SceneLimits.
// Also the writers of scenes and warnings as JSON and the reader of warnings. Failures throw
// gvd::Error.

#include <atomic>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "gvd/scene/scene.h"

namespace gvd::scene {

/// Input formats the scene loader understands.
enum class SceneFormat { kAuto, kJson, kObj, kGltf, kGlb, kPly, kStl, kOff };

/// Parses the native scene JSON (docs/FORMATS.md) ({"dimension":..,"objects":[..]} and an
/// optional "units": a length unit of units.h, kept canonical in Scene::units) and validates
/// it. Errors name the JSON path, object label and index; an unknown unit names "units".
/// `cancel` (may be null) is read between objects and while validating (validate_scene).
Scene parse_scene_json(std::string_view text, const SceneLimits& limits = {},
                       const std::atomic<bool>* cancel = nullptr);

/// Parses an in-memory file in the given format (kAuto sniffs the content). `name` is used
/// for error messages and, for single-object formats (PLY/STL/OFF), as the label.
/// OBJ: each `o`/`g` group is an object (faces before any group form an object named
/// after `name`); 2D is never inferred from OBJ/PLY/STL/OFF/glTF: they are 3D.
Scene parse_scene_bytes(std::span<const uint8_t> bytes, SceneFormat format, const std::string& name,
                        const SceneLimits& limits = {});

/// One input of a scene made of several: a mesh file, or a part of a multipart upload.
struct ScenePart {
  std::string label;  ///< the object's label (a file's stem, a part's name)
  std::span<const uint8_t> bytes;
  SceneFormat format = SceneFormat::kAuto;
  std::string source;  ///< how messages name it: "\"meshes/a.ply\"", "part \"a\""
};

/// A scene of one object per part: the objects a part holds (OBJ groups, glTF nodes) are
/// merged into one named after the part. Every part has the scene's dimension and a label of
/// its own; the part count is checked against the object limit before any is parsed. Each
/// part's warnings are kept under its label (degenerate simplices, which validation removed,
/// name the part's source); the topology warnings are those of the merged objects. Validated.
/// The one merge of the CLI's several files and the server's multipart uploads.
Scene parse_scene_parts(std::span<const ScenePart> parts, const SceneLimits& limits = {});

/// Loads a scene from files: one scene file (JSON, OBJ, GLB/glTF), or several mesh files
/// (PLY/STL/OFF/OBJ), one object each, labelled by file stem (parse_scene_parts). Validated.
Scene load_scene(std::span<const std::string> paths, const SceneLimits& limits = {});

/// Serialises a scene to the native JSON (for round trips and the job store); "units" only
/// when the scene declares them.
std::string scene_to_json(const Scene& scene);

/// The one JSON form of warnings, in every document that lists them (the saved result, `gvd
/// info --json`, the job's status, the job store): [{"kind","object","count","detail"}], kind
/// by its stable name (warning_kind_name).
std::string warnings_to_json(const std::vector<SceneWarning>& warnings);
/// Reads warnings_to_json's form back. gvd::Error{kInvalidArgument} naming the entry when it is
/// not that form or its kind is no WarningKind's name.
std::vector<SceneWarning> warnings_from_json(std::string_view text);

}  // namespace gvd::scene
