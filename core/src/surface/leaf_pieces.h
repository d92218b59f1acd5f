// What surfacing hands to welding (surface/cell_surfacer.cpp -> surface/weld_vertices.cpp):
// the pieces of each leaf, deduplicated per leaf into (point, pair of objects) records.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <vector>

#include "gvd/surface/extract_gvd.h"

namespace gvd::surface::detail {

// One oriented simplex of one object's cell boundary (2D uses p[0], p[1]).
struct Piece {
  Vec3 p[3];
  scene::ObjectId object;
  scene::ObjectId other;
};

// A hash of a point's exact coordinates (-0 and +0 alike): equal points, equal hashes.
inline uint64_t position_hash(Vec3 p) {
  uint64_t h = 0x9e3779b97f4a7c15ull;
  for (double d : {p.x, p.y, p.z}) {
    if (d == 0) d = 0.0;  // -0 and +0 are the same point
    uint64_t bits;
    std::memcpy(&bits, &d, sizeof bits);
    h ^= bits + 0x9e3779b97f4a7c15ull + (h << 6) + (h >> 2);
    h *= 0xff51afd7ed558ccdull;
    h ^= h >> 33;
  }
  return h;
}

// The surface of a range of leaves: distinct (point, pair of objects) records of each leaf and
// simplices over them (indices into `corners`, local to the chunk). A point between objects a
// and b is one record for both sides; `sides` says which of them has a vertex there (bit 0:
// the lower object, bit 1: the higher one), so the records are half as many as the corners.
struct SurfaceChunk {
  // 32 bytes: these records are what memory peaks on at the end of surfacing and in the weld.
  struct Corner {
    Vec3 p;                  // the weld writes the record's vertices over it once p is used
    scene::ObjectId lo, hi;  // the pair, lo < hi (hi = kNoObject on the domain box)
  };
  static_assert(sizeof(Corner) == 32);
  struct Simplex {
    uint32_t v[3];
    scene::ObjectId object;
  };
  std::vector<Corner> corners;
  std::vector<uint8_t> sides;  // per corner
  std::vector<Simplex> simplices;
  // Surfacing emits each interface piece twice, once per side, the second right after the
  // first with its first two corners swapped and the pair's other object: such a second one
  // is not stored, its first's `twin` is set instead (half the simplices held until the
  // weld, which writes both; per object the order of the simplices is the same).
  std::vector<uint8_t> twin;

  // The simplex of the other side of a twinned one (corners as records of this chunk).
  Simplex twin_of(const Simplex& t) const {
    const Corner& c = corners[t.v[0]];
    return {{t.v[1], t.v[0], t.v[2]}, t.object == c.lo ? c.hi : c.lo};
  }

  // Appends one leaf's pieces, merging equal (point, pair) within the leaf (a small
  // open-addressing table over the leaf's records; the scan covers only a collision chain).
  void add(const std::vector<Piece>& pieces, int arity) {
    const size_t first = corners.size();
    const size_t first_simplex = simplices.size();
    size_t bits = 6;
    while ((size_t{1} << bits) < 4 * pieces.size() * arity) ++bits;
    const size_t mask = (size_t{1} << bits) - 1;
    table.assign(mask + 1, kEmpty);
    for (const Piece& piece : pieces) {
      Simplex t{{0, 0, 0}, piece.object};
      const scene::ObjectId lo = std::min(piece.object, piece.other);
      const scene::ObjectId hi = std::max(piece.object, piece.other);
      const uint8_t side = piece.object == lo ? 1 : 2;
      for (int k = 0; k < arity; ++k) {
        const Vec3& p = piece.p[k];
        size_t slot = (position_hash(p) ^ (uint64_t{lo} * 0x9e3779b97f4a7c15ull) ^ hi) & mask;
        uint32_t at = kEmpty;
        for (; table[slot] != kEmpty; slot = (slot + 1) & mask) {
          const Corner& c = corners[first + table[slot]];
          if (c.p == p && c.lo == lo && c.hi == hi) {
            at = static_cast<uint32_t>(first + table[slot]);
            break;
          }
        }
        if (at == kEmpty) {
          at = static_cast<uint32_t>(corners.size());
          table[slot] = static_cast<uint32_t>(at - first);
          corners.push_back({p, lo, hi});
          sides.push_back(side);
        } else {
          sides[at] |= side;
        }
        t.v[k] = at;
      }
      if (simplices.size() > first_simplex && !twin.back()) {
        const Simplex& last = simplices.back();
        if (last.object == piece.other && t.v[0] == last.v[1] && t.v[1] == last.v[0] &&
            (arity == 2 || t.v[2] == last.v[2])) {
          twin.back() = 1;
          continue;
        }
      }
      simplices.push_back(t);
      twin.push_back(0);
    }
  }

 private:
  static constexpr uint32_t kEmpty = 0xFFFFFFFFu;
  std::vector<uint32_t> table;  // scratch of add(): slot -> record - first
};

// The weld's vertices of a record (the lower object's, the higher one's), written over its
// position once that is no longer read.
inline void set_vertices(SurfaceChunk::Corner& c, uint32_t lo_vertex, uint32_t hi_vertex) {
  const uint32_t v[2] = {lo_vertex, hi_vertex};
  static_assert(sizeof v == sizeof c.p.x);
  std::memcpy(&c.p.x, v, sizeof v);
}
inline uint32_t vertex_of(const SurfaceChunk::Corner& c, scene::ObjectId object) {
  uint32_t v[2];
  std::memcpy(v, &c.p.x, sizeof v);
  return v[object == c.lo ? 0 : 1];
}

}  // namespace gvd::surface::detail

namespace gvd::surface {

struct LeafPieces::Impl {
  std::vector<detail::SurfaceChunk> chunks;
};

}  // namespace gvd::surface
