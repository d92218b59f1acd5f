#pragma once

// Compaction of a surfaced GVD in place: flat parts of each interface merged into large pieces
// (curved parts too, within CompactOptions::curved_tolerance), every cell kept closed and
// oriented and every piece clear of the objects. O(GVD size). Removed vertices take their
// clearances with them, so build the dual graph first.

#include <atomic>
#include <cstdint>

#include "gvd/geometry/simplex_bvh.h"
#include "gvd/scene/scene.h"
#include "gvd/surface/gvd.h"

namespace gvd::surface {

struct CompactStats {
  uint64_t simplices_before = 0;  ///< over all cells (each interface simplex once per side)
  uint64_t simplices_after = 0;
};

/// Compact output: the GVD's pieces as large as its geometry needs, not as the octree. A
/// vertex inside a flat (2D: straight) part of one interface — every simplex around it in one
/// plane (line), to 1e-12 relative, its link a closed loop — is removed and its star
/// re-triangulated from the link (ear clipping: the star is a simple, star-shaped polygon, so
/// the new triangles cover exactly the old ones). Boundary vertices of an interface (where it
/// meets another interface, the domain box or a curved part) stay, so every cell stays closed
/// and oriented, no simplex moves off the surface it was on (none can cross an object), and
/// every simplex keeps both its objects. Curved parts are left as they are unless
/// CompactOptions::curved_tolerance allows them to move (then the cells stay closed and
/// oriented, and every piece stays clear of the objects, but volumes and areas change within
/// that tolerance). Removed vertices
/// take their clearance with them: the dual graph must be built before (its clearances and
/// areas are those of the full-resolution GVD, which this does not change). O(GVD size).
struct CompactOptions {
  int threads = 0;
  /// Curved parts too: a vertex whose star is not flat is removed when the new patch stays
  /// within this fraction of the least clearance at the star's vertices of the surfaced GVD
  /// (the bound accumulates over removals) and every new triangle keeps clear of every
  /// object by half that clearance (exact triangle distances through `bvh`, unit domain, and
  /// `domain`). 0, or no bvh: flat parts only (nothing moves).
  double curved_tolerance = 0;
  const SimplexBvh* bvh = nullptr;
  const scene::Domain* domain = nullptr;
  /// Set: stop with gvd::Error{kCancelled} (polled every 4096 vertices of a cell).
  const std::atomic<bool>* cancel = nullptr;
};
CompactStats compact_gvd(Gvd& gvd, const CompactOptions& options = {});

}  // namespace gvd::surface
