#include "gvd/refine/refine.h"

#include <algorithm>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "gvd/common/peak_memory.h"
#include "gvd/distance/compute_distances.h"
#include "gvd/octree/build_octree.h"
#include "gvd/refine/find_cells_to_refine.h"

namespace gvd::refine {

using namespace gvd::scene;
using namespace gvd::octree;
using namespace gvd::distance;

namespace {

// Per leaf of `after` (a refinement of `before`: every leaf lies in one leaf of `before`),
// the entry of `levels` of the leaf of `before` that holds it. Both leaf arrays are sorted by
// Morton code, and each leaf of `before` covers a contiguous run of codes: one merge, O(N).
std::vector<uint8_t> inherit_levels(const Octree& before, const Octree& after,
                                    std::span<const uint8_t> levels) {
  std::vector<uint8_t> out(after.leaf_count());
  size_t j = 0;
  for (size_t i = 0; i < out.size(); ++i) {
    while (j + 1 < before.leaf_count() && before.code[j + 1] <= after.code[i]) ++j;
    out[i] = levels[j];
  }
  return out;
}

}  // namespace

RefineLoopResult refine_until_resolved(Octree& octree, LeafSimplices& simplices,
                                       DistanceField& field, LeafVertices& leaf_vertices,
                                       const UnitGeometry& geometry, const SimplexBvh& bvh,
                                       const RefineLoopOptions& options) {
  const int dim = geometry.dimension;
  const int threads = options.octree.threads;
  RefineLoopResult out;
  RefineReport report;
  // Ambiguity limits count levels from the octree before any refinement: per leaf, the level
  // of the first octree's leaf that holds it (1 B per leaf; the first octree itself would be
  // 9 B per leaf, held beside the replaced and the new one in every later round).
  std::vector<uint8_t> base_level = octree.level;
  RefineOptions find_options;
  find_options.threads = threads;
  find_options.base_level = base_level;
  find_options.ambiguity_levels = options.ambiguity_levels;
  find_options.geometry = &geometry;
  find_options.bvh = &bvh;
  find_options.contacts = options.contacts;
  find_options.contact_depth = options.contact_depth;
  find_options.leaf_simplices = &simplices;
  find_options.leaf_vertices = &leaf_vertices;
  uint64_t ambiguity_seen = 0;  // ambiguous cells found by any pass
  int rounds = 0;
  for (;;) {
    find_options.changed_only = rounds > 0;
    report = find_cells_to_refine(octree, field, find_options);
    ambiguity_seen += report.ambiguous_count;
    const bool split_ambiguous = rounds < options.ambiguity_rounds;
    const bool split_unseen = rounds < options.unseen_rounds;
    std::vector<uint32_t> unswept;
    if (options.unswept_junctions && rounds < options.max_rounds)
      unswept = options.unswept_junctions(octree, field, leaf_vertices);
    if ((report.foreign_leaves.empty() && (!split_unseen || report.unseen_leaves.empty()) &&
         (!split_ambiguous || report.ambiguous_leaves.empty()) && unswept.empty()) ||
        rounds >= options.max_rounds) {
      break;
    }
    if (rounds >= options.cone_rounds && options.cone_certifier != nullptr &&
        options.cone_certifier->cones()) {
      out.cones_unsettled = true;  // the caller starts again without cones
      break;
    }
    ++rounds;
    if (options.progress) options.progress(std::min(0.99, rounds / 8.0));
    SeparationPlan plan = plan_separation_splits(
        octree, simplices, geometry, bvh, report.foreign_leaves, threads, options.contacts,
        options.contact_depth, options.octree.split_oracle);
    std::vector<CellRef>& splits = plan.splits;
    // Ambiguous and unseen leaves are split two levels at once: that halves the rounds, and
    // the flagged leaves are few (in 2D junctions are points; in 3D only junction cells).
    const size_t planned = splits.size();
    if (split_ambiguous) {
      for (uint32_t leaf : report.ambiguous_leaves) splits.push_back(cell_of(octree, leaf));
    }
    if (split_unseen) {
      for (uint32_t leaf : report.unseen_leaves) splits.push_back(cell_of(octree, leaf));
    }
    const size_t flagged_end = splits.size();
    for (size_t i = planned; i < flagged_end; ++i)
      for (uint32_t c = 0; c < (1u << dim); ++c) splits.push_back(child_cell(dim, splits[i], c));
    for (uint32_t leaf : unswept) splits.push_back(cell_of(octree, leaf));
    Octree previous = std::move(octree);
    // The vertex index (key -> vertex, ~16 B per vertex) is not read while the octree is
    // rebuilt, where the old and the new octree are held at once: a large one goes before and
    // is built again once the old octree has given up its simplex lists. A small one (a few
    // MB) stays: rebuilding it cost ~3 ms a round on the maze, about a tenth of its time.
    const bool keep_index = field.vertices.indexed() && field.vertices.size() < kSmallVertexIndex;
    if (!keep_index) field.vertices.drop_index();
    {
      LeafSimplices refined;
      octree = refine_octree(previous, simplices, geometry, splits, options.octree, plan.certified,
                             &refined);
      // The replaced octree is only looked up from now on (its leaves pass their base levels
      // on, and the distance update matches them, then frees it): its simplex lists go before
      // the update, where the refinement's memory peaks.
      simplices = std::move(refined);
    }
    heap_checkpoint(octree.leaf_count());
    previous.keep_cells_only();
    base_level = inherit_levels(previous, octree, base_level);
    find_options.base_level = base_level;
    if (!keep_index) field.vertices.rebuild_index(threads);
    DistanceOptions distance_options = options.distance;
    distance_options.leaf_simplices = &simplices;
    DistanceField next = compute_distances(octree, geometry, bvh, distance_options,
                                           std::move(field), std::move(previous), leaf_vertices);
    field = std::move(next);
  }
  sort_vertices(field, &leaf_vertices, threads);  // incremental rounds appended vertices
  // The last report holds the thin regions no round resolved (earlier ones were split).
  out.unseen_left = report.unseen_count;
  if (rounds > 0 && ambiguity_seen > 0) {
    // The last rounds looked only at changed leaves: count the ambiguity left over all of
    // them (the other checks have nothing left to find). Not needed when no pass found any:
    // the first looked at every leaf, the later ones at every leaf that changed.
    find_options.changed_only = false;
    find_options.geometry = nullptr;
    find_options.bvh = nullptr;
    report = find_cells_to_refine(octree, field, find_options);
  }
  out.rounds = rounds;
  out.ambiguous_at_limit = report.ambiguous_at_limit + report.ambiguous_leaves.size();
  out.touching_leaves = report.touching_leaves;
  return out;
}

}  // namespace gvd::refine
