#pragma once

// Simplex: one segment (2D) or triangle (3D) of an object, by the indices of its vertices in that
// object (a segment uses v[0] and v[1] and leaves v[2] = 0).

#include <cstdint>

namespace gvd {

/// A segment (2D: v[0], v[1]; v[2] = 0) or a triangle (3D) of one object, by vertex index.
struct Simplex {
  uint32_t v[3] = {0, 0, 0};
};

}  // namespace gvd
