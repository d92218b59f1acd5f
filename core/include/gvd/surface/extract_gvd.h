#pragma once

#include <atomic>
#include <cstdint>
#include <vector>

#include "gvd/distance/distance_field.h"
#include "gvd/geometry/simplex_bvh.h"
#include "gvd/octree/octree.h"
#include "gvd/scene/scene.h"
#include "gvd/surface/gvd.h"

namespace gvd {

/// Options of the surfacing stage.
struct SurfaceOptions {
  int threads = 0;
  const std::atomic<bool>* cancel = nullptr;
};

/// Paper §6: bisector points (eq. 1, clamped to the edge) on every octree edge whose ends
/// differ in label; on each (sub)face segments from the bisectors to their centroid; in 3D
/// triangles from those segments to the cell's bisector centroid. Faces are surfaced on their
/// finest subdivision and in a canonical order, so the two cells of a face produce identical
/// pieces (watertight across level changes). Cells are closed by the domain box. Every
/// simplex is emitted once per side, oriented into that side's cell; vertices carry the
/// exact clearance (distance to the nearest object, BVH). Output in user units.
Gvd extract_gvd(const Octree& octree, const DistanceField& field, const UnitGeometry& geometry,
                const SimplexBvh& bvh, const Domain& domain, const SurfaceOptions& options = {});

}  // namespace gvd
