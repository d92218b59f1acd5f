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

/// Why leaves must be split before surfacing (paper §5 and the separation guarantee).
struct RefineReport {
  std::vector<uint32_t> leaves;     ///< leaves to split (all below the depth limit)
  uint64_t ambiguous = 0;           ///< ambiguous cells found (any depth)
  uint64_t ambiguous_at_limit = 0;  ///< ambiguous cells already at the depth limit
  uint64_t foreign_label = 0;       ///< non-empty leaves with a vertex labelled by another object
  uint64_t foreign_at_limit = 0;    ///< of those, at the depth limit
  uint64_t touching_leaves = 0;     ///< leaves that intersect several objects (at the limit)
};

/// Finds the leaves to subdivide (paper §5): a cell is ambiguous when collapsing the edges of
/// its boundary graph whose ends carry the same label does not leave a simplex of dimension
/// <= D (a complete graph on at most D + 1 distinct labels). In addition, a leaf that
/// intersects object o but has a vertex labelled with another object is split, so that the GVD
/// never passes through a non-empty leaf (and so never crosses an object) above the depth limit.
RefineReport find_cells_to_refine(const Octree& octree, const DistanceField& field, int threads = 0);

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
