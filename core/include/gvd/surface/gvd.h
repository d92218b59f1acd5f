#pragma once

// The GVD's data: per object, the closed, oriented boundary of its generalized Voronoi cell as
// triangles (2D: segments) in user units, with the object across every vertex and its
// clearance. extract_gvd.h makes it.

#include <cstdint>
#include <vector>

#include "gvd/geometry/vec.h"
#include "gvd/scene/scene.h"

namespace gvd::surface {

/// The boundary of one object's generalized Voronoi cell.
/// 3D: triangles oriented so that their normal (right-hand rule, (b-a)x(c-a)) points into the
/// cell; 2D: segments with the cell on their left. Vertices are duplicated per object on the
/// other side, so a vertex's `other` is the other object of every simplex that uses it.
struct GvdCell {
  scene::ObjectId object = scene::kNoObject;
  std::vector<Vec3> positions;  ///< user units, double; z = 0 in 2D
  std::vector<scene::ObjectId>
      other;  ///< per vertex: object across the boundary, kNoObject = domain box
  std::vector<double> clearance;  ///< per vertex: distance to the nearest object (user units)
  std::vector<uint32_t> indices;  ///< 3 per triangle (3D) or 2 per segment (2D)
};

/// The generalized Voronoi diagram: one closed, oriented cell boundary per object.
struct Gvd {
  int dimension = 3;
  std::vector<GvdCell> cells;  ///< cells[i].object == i; empty when the object has no cell
};

}  // namespace gvd::surface
