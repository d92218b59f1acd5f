#pragma once

#include <cstdint>

namespace gvd {

/// A segment (2D: v[0], v[1]; v[2] = 0) or a triangle (3D) of one object, by vertex index.
struct Simplex {
  uint32_t v[3] = {0, 0, 0};
};

}  // namespace gvd
