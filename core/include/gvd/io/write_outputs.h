#pragma once

// Output files of a finished GVD: the GVD as binary glTF or as float64 JSON, the dual graph as
// JSON and an exploded view (paper §7.4) as animated binary glTF, in the forms docs/FORMATS.md
// gives. write_glb_file and write_json_file write a GVD without first holding the whole file in
// memory. Files are written atomically (temporary file + rename); a failed read or write throws
// gvd::Error{kIo}.

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "gvd/graph/dual_graph.h"
#include "gvd/scene/scene.h"
#include "gvd/surface/gvd.h"

namespace gvd::io {

/// The GVD as binary glTF (contract in docs/FORMATS.md): one node per object with a non-empty cell
/// (name = label, extras = {"label", "object"}); 3D TRIANGLES oriented into the cell, 2D
/// LINES at z = 0; float32 POSITION, `_FEATURE_ID_0` (EXT_mesh_features, FLOAT, object on the
/// other side, nullFeatureId = object count for the domain box), `_CLEARANCE` (float) and
/// `COLOR_0` (RGB float, red = tight, blue = wide clearance). The scene's units, when it
/// declares them, are the asset's extras: {"units": "mm"}.
std::vector<uint8_t> gvd_to_glb(const surface::Gvd& gvd, const scene::Scene& scene);

/// A binary glTF file in two parts, so that a large one is written without being held twice:
/// the file is `head` (the 12-byte header, the JSON chunk and the binary chunk's 8-byte
/// header) followed by `bin` (the binary chunk's data, padded to 4 bytes; empty when the GVD
/// is). gvd_to_glb's bytes are gvd_glb_file's `head` + `bin`.
struct GlbFile {
  std::vector<uint8_t> head;
  std::vector<uint8_t> bin;
  /// The whole file in one array (bin is freed).
  std::vector<uint8_t> bytes() &&;
};
GlbFile gvd_glb_file(const surface::Gvd& gvd, const scene::Scene& scene);

/// An exploded view (paper §7.4) as binary glTF: one node per scene object (name = label,
/// extras = {"label", "object", "displacement"}) showing the object's own geometry (3D
/// TRIANGLES, 2D LINES at z = 0, a distinct colour each), and one animation "explode" that
/// moves every node linearly from its place to place + displacement over `seconds`. Units as
/// in gvd_to_glb.
std::vector<uint8_t> exploded_to_glb(const scene::Scene& scene, std::span<const Vec3> displacement,
                                     double seconds = 2.0);

/// The same GVD with float64 coordinates as JSON: {"dimension", "objects":[{"object","label",
/// "positions":[[x,y(,z)]..], "other":[..], "clearance":[..], "simplices":[[i,j(,k)]..]}]}, and
/// "units" (Scene::units) when the scene declares them.
std::string gvd_to_json(const surface::Gvd& gvd, const scene::Scene& scene);
/// The same JSON handed to `sink` piece by piece (its bytes are gvd_to_json's), for writing a
/// large GVD without holding its text.
void write_gvd_json(const surface::Gvd& gvd, const scene::Scene& scene,
                    const std::function<void(std::string_view)>& sink);

/// The dual graph JSON of docs/FORMATS.md: {"nodes":[{"object","label"}],"edges":[{"a","b","area",
/// "min_clearance"}]}, and "units" (Scene::units) when the scene declares them.
std::string graph_to_json(const graph::DualGraph& graph, const scene::Scene& scene);

/// Writes bytes to a file atomically (temporary file + rename); gvd::Error{kIo} on failure.
void write_file_atomic(const std::string& path, const void* data, size_t size);
void write_file_atomic(const std::string& path, const std::string& text);
/// The same for a file written piece by piece, so that it need not be held in memory whole:
/// `produce` calls its argument with each piece in order.
void write_file_atomic(
    const std::string& path,
    const std::function<void(const std::function<void(std::string_view)>&)>& produce);

/// gvd_to_glb and gvd_to_json written to a file atomically, without first holding the whole
/// file in memory (the GLB's buffer once, the JSON in pieces).
void write_glb_file(const std::string& path, const surface::Gvd& gvd, const scene::Scene& scene);
void write_json_file(const std::string& path, const surface::Gvd& gvd, const scene::Scene& scene);

/// Reads a whole file; gvd::Error{kIo} when it cannot be read.
std::vector<uint8_t> read_file_bytes(const std::string& path);

}  // namespace gvd::io
