#pragma once

// Surfacing (paper §6): the GVD's triangles (2D: segments) from the octree and its distance
// field, watertight across level changes, each emitted once per side and oriented into its
// cell, with the exact clearance at every vertex, in user units. extract_gvd does it in one
// call; surface_leaves and weld_gvd in two halves, so that the caller can free memory between.

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <utility>
#include <vector>

#include "gvd/distance/distance_field.h"
#include "gvd/distance/leaf_vertices.h"
#include "gvd/geometry/simplex_bvh.h"
#include "gvd/octree/octree.h"
#include "gvd/scene/scene.h"
#include "gvd/surface/gvd.h"

namespace gvd::surface {

/// The plane GVD on one face of a junction cell (CellVerdict::kJunctionX...): segments
/// between points (unit domain, on the face's plane), the first object of each pair on the
/// left of its segment seen from + the face's axis. Points are shared: where segments meet,
/// they meet at one point. Made by pipeline::junction_face_gvd.
struct FaceGvd {
  std::vector<Vec3> points;
  std::vector<std::pair<uint32_t, uint32_t>> segments;
  std::vector<std::pair<scene::ObjectId, scene::ObjectId>> pairs;  ///< per segment: left, right
};

/// Options of the surfacing stage.
struct SurfaceOptions {
  int threads = 0;
  const std::atomic<bool>* cancel = nullptr;
  /// Optional: the fraction of the leaves surfaced, called from the calling thread between
  /// batches of them (for the progress display).
  std::function<void(double)> progress;
  /// Skew extruded pair cells (CellVerdict::kSkew): the direction e of the cell `box`, from
  /// its own certificate (the octree's mark does not hold it); false when it has none. Needed
  /// when the octree has such cells (compute_gvd sets it from its PairCertifier); without it
  /// they are surfaced as ordinary cells.
  std::function<bool(const Box& box, Vec3& along)> skew_direction;
  /// Junction cells (CellVerdict::kJunctionX...): the GVD on the face `face` (flat along
  /// `axis`) from that face alone; false when none crosses it. Needed when the octree has
  /// such cells; without it they are surfaced as ordinary cells.
  std::function<bool(const Box& face, int axis, FaceGvd& out)> junction_face;
};

/// Paper §6: bisector points (eq. 1, clamped to the edge) on every octree edge whose ends
/// differ in label; on each (sub)face segments from the bisectors to their centroid; in 3D
/// triangles from those segments to the cell's bisector centroid. Faces are surfaced on their
/// finest subdivision and in a canonical order, so the two cells of a face produce identical
/// pieces (watertight across level changes). Cells are closed by the domain box. Every
/// simplex is emitted once per side, oriented into that side's cell; vertices carry the
/// exact clearance (distance to the nearest object, BVH). Output in user units.
Gvd extract_gvd(const octree::Octree& octree, const distance::DistanceField& field,
                const scene::UnitGeometry& geometry, const SimplexBvh& bvh,
                const scene::Domain& domain, const SurfaceOptions& options = {});

/// extract_gvd in two halves, so that a caller can free between them what only the first
/// needs (the leaves' vertex lists): memory peaks in the second, where the pieces
/// of all leaves are welded into shared vertices. `surface_leaves` surfaces every leaf;
/// `weld_gvd` merges equal corners, measures the clearances and writes the cells, and needs
/// nothing of the field. The result is extract_gvd's.
class LeafPieces {
 public:
  LeafPieces();
  ~LeafPieces();
  LeafPieces(LeafPieces&&) noexcept;
  LeafPieces& operator=(LeafPieces&&) noexcept;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  friend LeafPieces surface_leaves(const octree::Octree&, const distance::DistanceField&,
                                   const scene::UnitGeometry&, const SimplexBvh&,
                                   const SurfaceOptions&);
  friend LeafPieces surface_leaves_releasing_lists(const octree::Octree&,
                                                   const distance::DistanceField&,
                                                   distance::LeafVertices&,
                                                   const scene::UnitGeometry&, const SimplexBvh&,
                                                   const SurfaceOptions&);
  friend Gvd weld_gvd(LeafPieces&&, const scene::UnitGeometry&, const SimplexBvh&,
                      const scene::Domain&, const SurfaceOptions&);
};
LeafPieces surface_leaves(const octree::Octree& octree, const distance::DistanceField& field,
                          const scene::UnitGeometry& geometry, const SimplexBvh& bvh,
                          const SurfaceOptions& options = {});
/// surface_leaves reading each leaf's vertices from `leaf_vertices` (the distance transform's
/// lists for `field`) rather than by key, which give up their rows as soon as surfacing no
/// longer reads them: those of the leaves that emit nothing (on the spheres, four in five) once
/// the others are known, the rest at the end. The lists beside the pieces are what memory
/// peaks on at the end of surfacing. The pieces are surface_leaves'.
LeafPieces surface_leaves_releasing_lists(const octree::Octree& octree,
                                          const distance::DistanceField& field,
                                          distance::LeafVertices& leaf_vertices,
                                          const scene::UnitGeometry& geometry,
                                          const SimplexBvh& bvh,
                                          const SurfaceOptions& options = {});
Gvd weld_gvd(LeafPieces&& pieces, const scene::UnitGeometry& geometry, const SimplexBvh& bvh,
             const scene::Domain& domain, const SurfaceOptions& options = {});

/// The junction cells (CellVerdict::kJunctionX...) whose GVD the surfacer could not sweep as
/// they stand: an end face's pieces that do not pair with the other end's, a side face whose
/// pieces are no rungs, a plane GVD whose ends on the border are not the face's spokes (its
/// edges' labels hide a crossing). The refinement splits them (refine.h); surfacing such a
/// cell as an ordinary one would put pieces through its objects. Needs
/// options.junction_face; `rows` (optional) as in surface_leaves_releasing_lists.
std::vector<uint32_t> unswept_junction_leaves(const octree::Octree& octree,
                                              const distance::DistanceField& field,
                                              const distance::LeafVertices* rows,
                                              const scene::UnitGeometry& geometry,
                                              const SimplexBvh& bvh, const SurfaceOptions& options);

}  // namespace gvd::surface
