#pragma once

// The distance transform (paper §4): the closest point of every octree vertex, by the BVH or
// the backend's kernel, and its incremental update after a refinement.

#include <atomic>
#include <functional>

#include "gvd/distance/distance_field.h"
#include "gvd/distance/leaf_vertices.h"
#include "gvd/geometry/simplex_bvh.h"
#include "gvd/octree/leaf_simplices.h"
#include "gvd/octree/octree.h"
#include "gvd/scene/scene.h"

namespace gvd::distance {

class ClosestPointSolver;

/// How compute_distances assigns closest points to the vertices of empty leaves.
enum class DistanceMethod {
  /// The exact closest point of every vertex, by the BVH (or the backend's kernel), in one
  /// data-parallel batch. The default: on the benchmark scenes it is 4-5x cheaper than the
  /// wavefront (which is serial) and every distance is exact.
  kExact,
  /// The paper's Algorithm 1 (§4): exact points for the non-empty vertices only, then the
  /// wavefront expansion over visible vertices (distances within 3/2 of the true ones), then
  /// exact points where the GVD crosses a leaf (exact_near_gvd).
  kWavefront,
};

/// Options of the distance transform.
struct DistanceOptions {
  int threads = 0;                            ///< 0 = all cores
  const std::atomic<bool>* cancel = nullptr;  ///< stop with gvd::Error{kCancelled}
  DistanceMethod method = DistanceMethod::kExact;
  /// kWavefront only: after the wavefront, give every vertex of a leaf with mixed labels (a leaf
  /// the GVD crosses) its exact closest point, repeating while new leaves become mixed. The GVD is
  /// then surfaced from exact points at both ends of every crossed edge, and ambiguity tests
  /// see true labels instead of wavefront noise. Costs one bounded BVH query per such vertex.
  bool exact_near_gvd = true;
  /// Computes the exact closest points in batches (the OpenCL kernel or the CPU twin of
  /// closest_points.h); null = SimplexBvh::nearest on `threads` threads. Same results.
  ClosestPointSolver* solver = nullptr;
  /// kWavefront only, optional: the simplices of each leaf (the octree build's), whose
  /// distances bound the search of the non-empty vertices' closest points.
  const octree::LeafSimplices* leaf_simplices = nullptr;
  /// Optional: the fraction of the exact closest-point queries done, called from the calling
  /// thread between batches of them (for the progress display).
  std::function<void(double)> progress;
};

/// The exact closest point of one vertex among all simplices (the per-item function of the
/// initialisation; the OpenCL kernel runs the same item, closest_point_item.h). `upper2` bounds the
/// search.
ClosestHit closest_for_vertex(const SimplexBvh& bvh, Vec3 position, double upper2 = 1e300);

/// Paper §4, COMPUTE_DISTANCES. With DistanceMethod::kExact (the default) every vertex gets
/// its exact closest point by the BVH, O(V log M), data-parallel. With kWavefront (the
/// paper's Algorithm 1): exact closest points for every non-empty vertex (a vertex of a leaf
/// that intersects an object), then a wavefront expansion in increasing distance that pushes
/// closest points to visible vertices (vertices on the boundary of a common leaf),
/// O(V log V) on a 2:1-balanced tree, serial. `lists` (optional) receives the boundary
/// vertices of every leaf, which the refinement's checks, its next update and the surfacing
/// read.
DistanceField compute_distances(const octree::Octree& octree, const scene::UnitGeometry& geometry,
                                const SimplexBvh& bvh, const DistanceOptions& options = {},
                                LeafVertices* lists = nullptr);
/// The same after a refinement: `previous` supplies exact points already computed for the
/// same vertex keys. With `previous_octree` (the octree `previous` was computed on, which
/// `octree` refines) and `previous_lists` (its leaves' vertices), the topology is updated
/// incrementally: vertices keep their indices (new ones are appended, so keys are no longer
/// sorted — see sort_vertices) and only changed leaves are looked up again.
DistanceField compute_distances(const octree::Octree& octree, const scene::UnitGeometry& geometry,
                                const SimplexBvh& bvh, const DistanceOptions& options,
                                const DistanceField& previous,
                                const octree::Octree* previous_octree = nullptr,
                                const LeafVertices* previous_lists = nullptr,
                                LeafVertices* lists = nullptr);
/// The incremental update, consuming `previous` (its vertex set moves into the new field
/// instead of being copied), `previous_octree` (freed once its leaves are matched) and
/// `lists`: in, previous's; out, the new field's, grown in place. The result is the same.
DistanceField compute_distances(const octree::Octree& octree, const scene::UnitGeometry& geometry,
                                const SimplexBvh& bvh, const DistanceOptions& options,
                                DistanceField&& previous, octree::Octree&& previous_octree,
                                LeafVertices& lists);

/// Puts the vertices in key order (as a fresh compute_distances has them), permuting every
/// per-vertex array and renumbering `lists` (optional; the field's leaves' vertices). O(V),
/// parallel on `threads` (0 = all cores).
void sort_vertices(DistanceField& field, LeafVertices* lists = nullptr, int threads = 0);

}  // namespace gvd::distance
