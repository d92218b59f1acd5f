#pragma once

// The refinement loop between the distance transform and surfacing: decide which leaves must
// be split (find_cells_to_refine.h: foreign labels in non-empty leaves, §5 ambiguity, regions
// hidden between a leaf's vertices), plan the splits (the separation in one pass, certified
// pair cells left whole: pair_certificate.h), split (refine_octree) and update the distance
// field incrementally, until nothing is left to split or the round limits are reached.

#include <cstdint>
#include <functional>

#include "gvd/distance/compute_distances.h"
#include "gvd/distance/distance_field.h"
#include "gvd/distance/leaf_vertices.h"
#include "gvd/geometry/simplex_bvh.h"
#include "gvd/octree/build_octree.h"
#include "gvd/octree/contacts.h"
#include "gvd/octree/leaf_simplices.h"
#include "gvd/octree/octree.h"
#include "gvd/refine/pair_certificate.h"
#include "gvd/scene/scene.h"

namespace gvd::refine {

struct RefineLoopOptions {
  int max_rounds = 0;        ///< rounds of splitting in all
  int ambiguity_rounds = 0;  ///< rounds that may split ambiguous leaves (§5)
  int unseen_rounds = 0;     ///< rounds that may split leaves hiding an unseen region
  /// Ambiguity is resolved at most this many levels below the octree the loop starts from.
  int ambiguity_levels = 0;
  const octree::ContactPairs* contacts = nullptr;
  int contact_depth = 0;  ///< resolved (resolve_contact_depth)
  /// How splits rebuild the octree (its split_oracle keeps certified cells whole) and how
  /// the distance field is updated.
  octree::OctreeOptions octree;
  distance::DistanceOptions distance;
  /// With cones on in this certifier (the octree's split_oracle), the loop gives up after
  /// `cone_rounds` rounds (cones_unsettled). A cone certifies a cell and its children only
  /// (pair_certificate.h); where 2:1 balance splits its grandchildren next to a roof's apex
  /// that lies inside cells (two shafts whose apexes cannot both lie on lattice planes),
  /// they fail and are split, the balance that follows splits more, round after round, and
  /// leaves holding both objects can be left at the round limit. Without cones the loop
  /// settles as the paper's rule does: the caller builds the octree again without them.
  const PairCertifier* cone_certifier = nullptr;
  int cone_rounds = 24;
  /// Called after each round with an estimate of the fraction done (< 1).
  std::function<void(double)> progress;
  /// Optional: the junction cells (CellVerdict::kJunctionX...) the surfacer could not sweep
  /// as they stand (surface::unswept_junction_leaves); the loop splits them like leaves that
  /// hold a foreign label, and their children are asked again.
  std::function<std::vector<uint32_t>(const octree::Octree&, const distance::DistanceField&,
                                      const distance::LeafVertices&)>
      unswept_junctions;
};

struct RefineLoopResult {
  int rounds = 0;
  uint64_t unseen_left = 0;         ///< cells still hiding a region after the allowed rounds
  uint64_t ambiguous_at_limit = 0;  ///< ambiguous cells left (at a limit), surfaced by §6's rule
  uint64_t touching_leaves = 0;     ///< leaves that intersect several objects at the limit
  bool cones_unsettled = false;     ///< given up after cone_rounds rounds (cone_certifier)
};

/// Refines `octree` and `field` (its distance field), with the leaves' simplices and vertices
/// the octree build and the distance transform handed over beside them, all updated in place,
/// until no leaf must be split or the round limits are reached; the field's vertices end in
/// key order.
RefineLoopResult refine_until_resolved(octree::Octree& octree, octree::LeafSimplices& simplices,
                                       distance::DistanceField& field,
                                       distance::LeafVertices& leaf_vertices,
                                       const scene::UnitGeometry& geometry, const SimplexBvh& bvh,
                                       const RefineLoopOptions& options);

}  // namespace gvd::refine
