#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "gvd/graph/dual_graph.h"
#include "gvd/scene/scene.h"
#include "gvd/surface/gvd.h"

namespace gvd {

/// The GVD as binary glTF (contract in docs/FORMATS.md): one node per object with a non-empty cell
/// (name = label, extras = {"label", "object"}); 3D TRIANGLES oriented into the cell, 2D
/// LINES at z = 0; float32 POSITION, `_FEATURE_ID_0` (EXT_mesh_features, FLOAT, object on the
/// other side, nullFeatureId = object count for the domain box), `_CLEARANCE` (float) and
/// `COLOR_0` (RGB float, red = tight, blue = wide clearance). The scene's units, when it
/// declares them, are the asset's extras: {"units": "mm"}.
std::vector<uint8_t> gvd_to_glb(const Gvd& gvd, const Scene& scene);

/// An exploded view (paper §7.4) as binary glTF: one node per scene object (name = label,
/// extras = {"label", "object", "displacement"}) showing the object's own geometry (3D
/// TRIANGLES, 2D LINES at z = 0, a distinct colour each), and one animation "explode" that
/// moves every node linearly from its place to place + displacement over `seconds`. Units as
/// in gvd_to_glb.
std::vector<uint8_t> exploded_to_glb(const Scene& scene, std::span<const Vec3> displacement,
                                     double seconds = 2.0);

/// The same GVD with float64 coordinates as JSON: {"dimension", "objects":[{"object","label",
/// "positions":[[x,y(,z)]..], "other":[..], "clearance":[..], "simplices":[[i,j(,k)]..]}]}, and
/// "units" (Scene::units) when the scene declares them.
std::string gvd_to_json(const Gvd& gvd, const Scene& scene);

/// The dual graph JSON of docs/FORMATS.md: {"nodes":[{"object","label"}],"edges":[{"a","b","area",
/// "min_clearance"}]}, and "units" (Scene::units) when the scene declares them.
std::string graph_to_json(const DualGraph& graph, const Scene& scene);

/// Writes bytes to a file atomically (temporary file + rename); gvd::Error{kIo} on failure.
void write_file_atomic(const std::string& path, const void* data, size_t size);
void write_file_atomic(const std::string& path, const std::string& text);

/// Reads a whole file; gvd::Error{kIo} when it cannot be read.
std::vector<uint8_t> read_file_bytes(const std::string& path);

}  // namespace gvd
