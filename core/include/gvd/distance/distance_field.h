#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "gvd/common/growable_array.h"
#include "gvd/geometry/simplex_bvh.h"
#include "gvd/octree/octree.h"
#include "gvd/octree/vertices.h"
#include "gvd/scene/scene.h"

namespace gvd::distance {

class ClosestPointSolver;

/// Label and closest point of every octree vertex (paper §4), in unit-domain coordinates.
struct DistanceField {
  octree::OctreeVertices vertices;
  std::vector<scene::ObjectId> label;  ///< per vertex; kNoObject when no object was reached
  std::vector<uint32_t> point;         ///< per vertex: index into `closest`, kNoVertex if none
  std::vector<Vec3> closest;           ///< closest points on objects (shared between vertices)
  std::vector<uint8_t> exact;          ///< per vertex: 1 = exact closest point
  /// Per vertex: 1 when new or changed since the `previous` field (all 1 without one).
  std::vector<uint8_t> changed;
  uint64_t exact_count = 0;     ///< non-empty vertices initialised exactly
  uint64_t exact_reused = 0;    ///< of those, taken from the previous field (refinement)
  uint64_t exact_near_gvd = 0;  ///< empty vertices made exact because the GVD crosses their cell

  /// The boundary vertices of every leaf (CSR over leaves: vertex ids and their slots in
  /// the leaf's LeafGrid). Built by compute_distances and kept for the refinement checks and
  /// the surfacing; empty in a field loaded from disk.
  std::vector<uint32_t> leaf_begin;
  /// Grown in place by a refinement's update (the rows of unchanged leaves move up within it),
  /// so that the old and the new lists, the refinement's largest arrays, are never both held.
  GrowableArray<uint32_t> leaf_vertex;
  /// Per leaf: bit k set when slot k of its LeafGrid holds a vertex; the leaf's row of
  /// leaf_vertex lists those vertices in slot order.
  std::vector<uint32_t> leaf_slots;

  size_t size() const { return label.size(); }
  /// Frees the per-leaf lists (grid() then looks vertices up by key, as in a loaded field).
  void drop_leaf_lists() {
    std::vector<uint32_t>().swap(leaf_begin);
    leaf_vertex.release();
    std::vector<uint32_t>().swap(leaf_slots);
  }
  /// Keeps the per-leaf lists of `leaves` (ascending) only: the other rows are emptied in
  /// place and their slot masks set to 0, and the array shrinks to what is left. O(entries).
  void keep_leaf_lists_of(std::span<const uint32_t> leaves);
  /// The LeafGrid of a leaf, from its CSR row when it has one (a non-zero slot mask), else by
  /// key lookups.
  octree::LeafGrid grid(const octree::Octree& octree, uint32_t leaf) const;
  /// Distance from vertex v to its assigned closest point (unit domain; inf if none).
  double distance(uint32_t v) const;
  size_t memory_bytes() const;
};

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
/// O(V log V) on a 2:1-balanced tree, serial.
/// `previous` (optional) supplies exact points already computed for the same vertex keys.
/// With `previous_octree` (the octree `previous` was computed on, which `octree` refines), the
/// topology is updated incrementally: vertices keep their indices (new ones are appended, so
/// keys are no longer sorted — see sort_vertices) and only changed leaves are looked up again.
DistanceField compute_distances(const octree::Octree& octree, const scene::UnitGeometry& geometry,
                                const SimplexBvh& bvh, const DistanceOptions& options = {},
                                const DistanceField* previous = nullptr,
                                const octree::Octree* previous_octree = nullptr);
/// The same update after a refinement, consuming `previous` (its vertex set moves into the new
/// field instead of being copied) and `previous_octree` (freed once its leaves are matched);
/// the result is the same.
DistanceField compute_distances(const octree::Octree& octree, const scene::UnitGeometry& geometry,
                                const SimplexBvh& bvh, const DistanceOptions& options,
                                DistanceField&& previous, octree::Octree&& previous_octree);

/// Puts the vertices in key order (as a fresh compute_distances has them), permuting every
/// per-vertex array and the leaf CSR. O(V), parallel on `threads` (0 = all cores).
void sort_vertices(DistanceField& field, int threads = 0);

}  // namespace gvd::distance
