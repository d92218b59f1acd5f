#pragma once

// The properties every GVD result must have, checked by the brute-force oracles of
// oracles.h (gtest assertions; for the test programs).

#include <cstddef>
#include <functional>

#include "gvd/pipeline/pipeline.h"

namespace gvd::test {

/// Size of the finest octree cell next to a point, in user units.
double local_cell(const result::GvdResult& r, Vec3 p);

/// Stride that visits about `budget` of `n` items (brute-force oracles are O(scene size)).
inline size_t stride_for(size_t n, size_t budget = 3000) { return n <= budget ? 1 : n / budget; }

/// Closure of every cell; on an evenly spread sample: no GVD simplex crosses an object,
/// interface vertices are equidistant from their two objects (within two local cells) and
/// those are the nearest ones, at most 0.5 % of the area faces the wrong way (`oriented`,
/// when given, limits that count to the interfaces of the pairs it accepts), and the
/// distance field is never below the truth, within the 3/2 factor, exact where it says so.
void expect_valid(const result::GvdResult& r,
                  const std::function<bool(scene::ObjectId, scene::ObjectId)>& oriented = nullptr);

}  // namespace gvd::test
