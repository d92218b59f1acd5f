#pragma once

// The octree's integer lattice: B = lattice_bits(D) bits per axis, Morton codes of cell corners
// and 64-bit keys of lattice points (with their decoders), cell sizes, and the maps between
// lattice points and unit-domain positions and boxes. All inline; from_unit clamps points
// outside the domain (and NaN) to its finest cells.

#include <cstdint>

#include "gvd/geometry/vec.h"
#include "gvd/scene/scene.h"

namespace gvd::octree::lattice {

/// Integer lattice of the octree: B = lattice_bits(D) bits per axis, so a cell at level l has
/// side 2^(B-l) lattice units and the unit domain is [0, 2^B]^D. Cells are identified by the
/// Morton code of their lower corner (x bit first) plus their level; vertices by a mixed-radix
/// key over [0, 2^B]^D that fits 64 bits.

inline uint64_t spread2(uint64_t x) {  // 32 -> 64 bits, one zero between bits
  x &= 0xffffffffull;
  x = (x | (x << 16)) & 0x0000ffff0000ffffull;
  x = (x | (x << 8)) & 0x00ff00ff00ff00ffull;
  x = (x | (x << 4)) & 0x0f0f0f0f0f0f0f0full;
  x = (x | (x << 2)) & 0x3333333333333333ull;
  x = (x | (x << 1)) & 0x5555555555555555ull;
  return x;
}
inline uint32_t compact2(uint64_t x) {
  x &= 0x5555555555555555ull;
  x = (x | (x >> 1)) & 0x3333333333333333ull;
  x = (x | (x >> 2)) & 0x0f0f0f0f0f0f0f0full;
  x = (x | (x >> 4)) & 0x00ff00ff00ff00ffull;
  x = (x | (x >> 8)) & 0x0000ffff0000ffffull;
  x = (x | (x >> 16)) & 0x00000000ffffffffull;
  return static_cast<uint32_t>(x);
}
inline uint64_t spread3(uint64_t x) {  // 21 -> 63 bits, two zeros between bits
  x &= 0x1fffffull;
  x = (x | (x << 32)) & 0x001f00000000ffffull;
  x = (x | (x << 16)) & 0x001f0000ff0000ffull;
  x = (x | (x << 8)) & 0x100f00f00f00f00full;
  x = (x | (x << 4)) & 0x10c30c30c30c30c3ull;
  x = (x | (x << 2)) & 0x1249249249249249ull;
  return x;
}
inline uint32_t compact3(uint64_t x) {
  x &= 0x1249249249249249ull;
  x = (x | (x >> 2)) & 0x10c30c30c30c30c3ull;
  x = (x | (x >> 4)) & 0x100f00f00f00f00full;
  x = (x | (x >> 8)) & 0x001f0000ff0000ffull;
  x = (x | (x >> 16)) & 0x001f00000000ffffull;
  x = (x | (x >> 32)) & 0x00000000001fffffull;
  return static_cast<uint32_t>(x);
}

/// Lattice coordinates of a point or cell corner.
struct Coord {
  uint32_t c[3] = {0, 0, 0};
};

inline uint64_t morton(int dim, const Coord& p) {
  if (dim == 2) return spread2(p.c[0]) | (spread2(p.c[1]) << 1);
  return spread3(p.c[0]) | (spread3(p.c[1]) << 1) | (spread3(p.c[2]) << 2);
}
inline Coord morton_decode(int dim, uint64_t code) {
  if (dim == 2) return {{compact2(code), compact2(code >> 1), 0}};
  return {{compact3(code), compact3(code >> 1), compact3(code >> 2)}};
}

inline uint64_t side_units(int dim) { return uint64_t{1} << scene::lattice_bits(dim); }

/// Side of a cell of `level` in lattice units.
inline uint64_t cell_size(int dim, int level) {
  return uint64_t{1} << (scene::lattice_bits(dim) - level);
}

/// Key of the lattice point p (coordinates in [0, 2^B]).
inline uint64_t vertex_key(int dim, const Coord& p) {
  const uint64_t r = side_units(dim) + 1;
  return p.c[0] + r * (p.c[1] + (dim == 3 ? r * uint64_t{p.c[2]} : 0));
}
inline Coord vertex_coord(int dim, uint64_t key) {
  // One branch per dimension, so that the divisor is a constant (multiply and shift instead
  // of a 64-bit division: positions are decoded from keys in every hot loop).
  Coord p;
  if (dim == 3) {
    constexpr uint64_t r = (uint64_t{1} << scene::lattice_bits(3)) + 1;
    p.c[0] = static_cast<uint32_t>(key % r);
    key /= r;
    p.c[1] = static_cast<uint32_t>(key % r);
    p.c[2] = static_cast<uint32_t>(key / r);
  } else {
    constexpr uint64_t r = (uint64_t{1} << scene::lattice_bits(2)) + 1;
    p.c[0] = static_cast<uint32_t>(key % r);
    p.c[1] = static_cast<uint32_t>(key / r);
  }
  return p;
}

/// Unit-domain position of a lattice point.
inline Vec3 to_unit(int dim, const Coord& p) {
  const double s = 1.0 / static_cast<double>(side_units(dim));
  return {p.c[0] * s, p.c[1] * s, dim == 3 ? p.c[2] * s : 0.0};
}

/// The lattice cell-corner coordinates of the finest cell containing unit point u (clamped).
inline Coord from_unit(int dim, Vec3 u) {
  const double n = static_cast<double>(side_units(dim));
  Coord p;
  for (int i = 0; i < dim; ++i) {
    double v = u[i] * n;
    if (!(v >= 0)) v = 0;  // also catches NaN
    if (v > n - 1) v = n - 1;
    p.c[i] = static_cast<uint32_t>(v);
  }
  return p;
}

/// Unit-domain box of a cell.
inline Box cell_box(int dim, const Coord& lo, int level) {
  const double s = 1.0 / static_cast<double>(side_units(dim));
  const double size = static_cast<double>(cell_size(dim, level)) * s;
  Box b;
  b.lo = to_unit(dim, lo);
  b.hi = b.lo + Vec3{size, size, dim == 3 ? size : 0.0};
  return b;
}

}  // namespace gvd::octree::lattice
