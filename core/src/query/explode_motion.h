#pragma once

// Collision-free exploded views (GvdIndex::explode): how much of each object's displacement
// can be kept so that no two objects meet while all of them move at once, each along its
// vector from t = 0 to t = 1 (the animation of exploded_to_glb).

#include <cstdint>
#include <span>
#include <vector>

#include "gvd/geometry/simplex_bvh.h"
#include "gvd/scene/scene.h"

namespace gvd {

/// Factors of the kept displacement tried, largest first; the last (0: the object stays) is
/// always safe, so the answer always exists.
inline constexpr double kExplodeFactors[] = {1.0, 0.5, 0.25, 0.125, 0.0625, 0.0};

/// For every object (index = object), the factor f of kExplodeFactors kept: objects are
/// taken in `order` (the anchor and ring 1 first), and each keeps the largest f such that,
/// with the objects before it moving by their kept displacements and those after it not
/// moving, no pair it belongs to comes closer than half of min(its gap at t = 0, `margin`)
/// at any t in [0, 1]. Certified, not sampled: conservative advancement on exact mesh
/// distances (a pair whose distance is d at t cannot meet before t + d / |relative motion|).
/// Pairs that touch at t = 0 are checked from t = 1e-4 on and must come apart. `displacement`
/// is in user units; `geometry` / `bvh` are the result's unit-domain scene (bvh built with
/// the objects of the simplices).
std::vector<double> collision_free_factors(const UnitGeometry& geometry, const SimplexBvh& bvh,
                                           const Domain& domain, std::span<const Vec3> displacement,
                                           std::span<const uint32_t> order, double margin);

}  // namespace gvd
