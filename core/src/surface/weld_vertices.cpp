// Welding: one vertex per (position, pair of objects), the exact clearance once per position,
// and the cells' vertex and simplex arrays (extract_gvd.h, weld_gvd).
#include <algorithm>
#include <cmath>
#include <tuple>
#include <type_traits>

#include "gvd/common/error.h"
#include "gvd/common/parallel.h"
#include "gvd/common/radix_sort.h"
#include "gvd/surface/extract_gvd.h"
#include "leaf_pieces.h"

namespace gvd::surface {

using namespace gvd::scene;

namespace {

using detail::position_hash;
using detail::SurfaceChunk;

// Turns counts per [part][object] into each part's first index per object (the sum of the
// parts before it) and returns the totals per object.
std::vector<uint32_t> part_starts(std::vector<uint32_t>& base, size_t parts, size_t objects) {
  std::vector<uint32_t> total(objects, 0);
  for (size_t p = 0; p < parts; ++p) {
    for (size_t o = 0; o < objects; ++o) {
      const uint32_t in_part = base[p * objects + o];
      base[p * objects + o] = total[o];
      total[o] += in_part;
    }
  }
  return total;
}

}  // namespace

Gvd weld_gvd(LeafPieces&& pieces, const UnitGeometry& geometry, const SimplexBvh& bvh,
             const Domain& domain, const SurfaceOptions& options) {
  GVD_CHECK(pieces.impl_ != nullptr, "weld_gvd: the pieces were already welded");
  const int dim = geometry.dimension;
  const int threads = resolve_threads(options.threads);
  const int arity = dim == 2 ? 2 : 3;
  std::vector<SurfaceChunk> chunks = std::move(pieces.impl_->chunks);
  pieces.impl_.reset();
  // All records by one index, chunk by chunk (the chunk found by a binary search over their
  // starts: no array of pointers). A chunk's triangles index its own records.
  std::vector<size_t> chunk_start(chunks.size() + 1, 0);
  for (size_t c = 0; c < chunks.size(); ++c)
    chunk_start[c + 1] = chunk_start[c] + chunks[c].corners.size();
  const size_t nc = chunk_start.back();
  auto chunk_of = [&](size_t r) {
    return static_cast<size_t>(std::upper_bound(chunk_start.begin(), chunk_start.end(), r) -
                               chunk_start.begin() - 1);
  };
  auto record = [&](size_t r) -> SurfaceChunk::Corner& {
    const size_t c = chunk_of(r);
    return chunks[c].corners[r - chunk_start[c]];
  };
  auto sides_of = [&](size_t r) -> uint8_t& {
    const size_t c = chunk_of(r);
    return chunks[c].sides[r - chunk_start[c]];
  };
  // Vertices: one per (object, other object, exact position). Identical points are made
  // contiguous by sorting the records by the hash of their position: a counting sort into
  // buckets by the hash's top bits (the 16-byte keys made as they are scattered, never held
  // twice), then each bucket sorted on its own (both parallel). Within a run of one hash the
  // records are then sorted by position and pair, which also keeps the points of a 64-bit
  // collision (not expected) apart. Only the order of the records is kept.
  std::vector<uint32_t> order(nc);  // the records in sorted order
  {
    struct Keyed {
      uint64_t hash;
      uint32_t record;
    };
    std::vector<Keyed> keyed;
    constexpr int kBucketBits = 12;
    const std::vector<size_t> bucket_begin = bucket_scatter_made(
        nc,
        [&](size_t i) {
          return Keyed{position_hash(record(i).p), static_cast<uint32_t>(i)};
        },
        keyed, size_t{1} << kBucketBits,
        [](const Keyed& x) { return static_cast<size_t>(x.hash >> (64 - kBucketBits)); }, threads);
    auto same_point_and_pair = [&](uint32_t x, uint32_t y) {
      const SurfaceChunk::Corner& a = record(x);
      const SurfaceChunk::Corner& b = record(y);
      return std::tie(a.p.x, a.p.y, a.p.z, a.lo, a.hi, x) <
             std::tie(b.p.x, b.p.y, b.p.z, b.lo, b.hi, y);
    };
    parallel_for(
        size_t{1} << kBucketBits, threads,
        [&](size_t bb, size_t be, int) {
          for (size_t bucket = bb; bucket < be; ++bucket) {
            const size_t first = bucket_begin[bucket], last = bucket_begin[bucket + 1];
            std::sort(keyed.begin() + static_cast<std::ptrdiff_t>(first),
                      keyed.begin() + static_cast<std::ptrdiff_t>(last),
                      [](const Keyed& x, const Keyed& y) {
                        return std::tie(x.hash, x.record) < std::tie(y.hash, y.record);
                      });
            for (size_t i = first; i < last;) {
              size_t j = i + 1;
              while (j < last && keyed[j].hash == keyed[i].hash) ++j;
              for (size_t k = i; k < j; ++k) order[k] = keyed[k].record;
              if (j - i > 1)
                std::sort(order.begin() + static_cast<std::ptrdiff_t>(i),
                          order.begin() + static_cast<std::ptrdiff_t>(j), same_point_and_pair);
              i = j;
            }
          }
        },
        64);
  }

  // The records in sorted order (no copy, the chunks hold them); runs of
  // one position; within a run, groups of one pair, whose records' sides together say which
  // of the pair's objects get a vertex.
  auto sorted = [&](size_t i) -> SurfaceChunk::Corner& { return record(order[i]); };
  auto sorted_sides = [&](size_t i) -> uint8_t& { return sides_of(order[i]); };
  std::vector<uint8_t> new_group(nc);
  std::vector<size_t> run_start;
  {
    std::vector<uint8_t> new_point(nc);
    parallel_for(nc, threads, [&](size_t b, size_t e, int) {
      for (size_t i = b; i < e; ++i) {
        const SurfaceChunk::Corner* before = i == 0 ? nullptr : &sorted(i - 1);
        const SurfaceChunk::Corner& c = sorted(i);
        new_point[i] = before == nullptr || c.p != before->p;
        new_group[i] = new_point[i] || c.lo != before->lo || c.hi != before->hi;
      }
    });
    // The sides of each group, on its first record.
    parallel_for(nc, threads, [&](size_t b, size_t e, int) {
      for (size_t i = b; i < e; ++i) {
        if (!new_group[i]) continue;
        for (size_t j = i + 1; j < nc && !new_group[j]; ++j) sorted_sides(i) |= sorted_sides(j);
      }
    });
    for (size_t i = 0; i < nc; ++i)
      if (new_point[i]) run_start.push_back(i);
    run_start.push_back(nc);
  }
  const size_t runs = run_start.size() - 1;

  // Exact clearance once per distinct point; the last answer of the thread bounds the search
  // (the points come in the leaves' order, so it is close: on the spheres this bound alone is
  // as fast as one from a closest point of the leaf).
  // In the order the leaves made them (Z order, so nearby queries follow each other and
  // share the BVH's cache lines) rather than in hash order.
  std::vector<std::pair<uint64_t, uint32_t>> run_order(runs);
  parallel_for(runs, threads, [&](size_t b, size_t e, int) {
    for (size_t r = b; r < e; ++r) {
      uint32_t first = order[run_start[r]];
      for (size_t i = run_start[r] + 1; i < run_start[r + 1]; ++i)
        first = std::min(first, order[i]);
      run_order[r] = {first, static_cast<uint32_t>(r)};
    }
  });
  radix_sort(
      run_order, [](const std::pair<uint64_t, uint32_t>& x) { return x.first; }, threads);
  std::vector<double> run_clearance(runs);
  parallel_for(
      runs, threads,
      [&](size_t b, size_t e, int) {
        Vec3 previous;  // the last answer: a point on an object next to this one
        bool have_previous = false;
        for (size_t o = b; o < e; ++o) {
          const size_t r = run_order[o].second;
          const Vec3 p = sorted(run_start[r]).p;
          const double bound2 = have_previous ? dist2(p, previous) * (1 + 1e-9) : 1e300;
          const ClosestHit hit = bvh.nearest(p, bound2);
          run_clearance[r] = std::sqrt(hit.found() ? hit.dist2 : bound2) * domain.side;
          have_previous = hit.found();
          if (have_previous) previous = hit.point;
        }
      },
      1024);
  std::vector<std::pair<uint64_t, uint32_t>>().swap(run_order);

  Gvd gvd;
  gvd.dimension = dim;
  gvd.cells.resize(geometry.object_count);
  for (uint32_t o = 0; o < geometry.object_count; ++o) gvd.cells[o].object = o;
  // Per-object arrays filled in parallel: the runs (then the chunks' simplices) are cut into
  // parts; a part's first vertex (simplex) of each object goes where the counts of the parts
  // before it end, so the order is the serial one.
  const size_t objects = geometry.object_count;
  const size_t parts =
      std::min<size_t>(std::max<size_t>(runs, 1), 8 * static_cast<size_t>(threads));
  std::vector<size_t> part_run(parts + 1);
  for (size_t p = 0; p <= parts; ++p) part_run[p] = runs * p / parts;
  std::vector<uint32_t> vertex_base(parts * objects, 0);  // [part][object]
  parallel_for(
      parts, threads,
      [&](size_t b, size_t e, int) {
        for (size_t p = b; p < e; ++p) {
          for (size_t i = run_start[part_run[p]]; i < run_start[part_run[p + 1]]; ++i) {
            if (!new_group[i]) continue;
            const SurfaceChunk::Corner& c = sorted(i);
            if (sorted_sides(i) & 1) ++vertex_base[p * objects + c.lo];
            if (sorted_sides(i) & 2) ++vertex_base[p * objects + c.hi];
          }
        }
      },
      1);
  const std::vector<uint32_t> vertices = part_starts(vertex_base, parts, objects);
  for (GvdCell& cell : gvd.cells) {
    cell.positions.resize(vertices[cell.object]);
    cell.other.resize(vertices[cell.object]);
    cell.clearance.resize(vertices[cell.object]);
  }
  // Each record then holds the vertex of each side in place of its position, which its run
  // has read before (set_vertices).
  parallel_for(
      parts, threads,
      [&](size_t b, size_t e, int) {
        for (size_t p = b; p < e; ++p) {
          uint32_t* next = &vertex_base[p * objects];  // the part's next vertex per object
          uint32_t at[2] = {0, 0};
          for (size_t r = part_run[p]; r < part_run[p + 1]; ++r) {
            const Vec3 user = domain.from_unit(sorted(run_start[r]).p);
            for (size_t i = run_start[r]; i < run_start[r + 1]; ++i) {
              SurfaceChunk::Corner& c = sorted(i);
              if (new_group[i]) {
                const ObjectId pair[2] = {c.lo, c.hi};
                for (int side = 0; side < 2; ++side) {
                  if (!(sorted_sides(i) >> side & 1)) continue;
                  const ObjectId o = pair[side];
                  GvdCell& cell = gvd.cells[o];
                  at[side] = next[o]++;
                  cell.positions[at[side]] = user;
                  cell.other[at[side]] = pair[1 - side];
                  cell.clearance[at[side]] = run_clearance[r];
                }
              }
              detail::set_vertices(c, at[0], at[1]);
            }
          }
        }
      },
      1);
  // The sorting state is done with; the chunks' simplices take their vertices from the
  // records (twins written out as two), whose memory then goes before the cells' simplices
  // are written.
  auto release = [](auto& v) { std::remove_reference_t<decltype(v)>().swap(v); };
  release(order);
  release(new_group);
  release(run_start);
  release(run_clearance);
  parallel_for(
      chunks.size(), threads,
      [&](size_t b, size_t e, int) {
        for (size_t c = b; c < e; ++c) {
          SurfaceChunk& chunk = chunks[c];
          auto welded = [&](SurfaceChunk::Simplex t) {
            for (int k = 0; k < arity; ++k)
              t.v[k] = detail::vertex_of(chunk.corners[t.v[k]], t.object);
            return t;
          };
          std::vector<SurfaceChunk::Simplex> both;
          both.reserve(chunk.simplices.size() +
                       static_cast<size_t>(std::count(chunk.twin.begin(), chunk.twin.end(), 1)));
          for (size_t i = 0; i < chunk.simplices.size(); ++i) {
            both.push_back(welded(chunk.simplices[i]));
            if (chunk.twin[i]) both.push_back(welded(chunk.twin_of(chunk.simplices[i])));
          }
          chunk.simplices = std::move(both);
          release(chunk.twin);
          release(chunk.sides);
          release(chunk.corners);
        }
      },
      1);
  // Simplices: parts of whole chunks.
  const size_t simplex_parts = std::min(chunks.size(), 8 * static_cast<size_t>(threads));
  std::vector<size_t> part_chunk(simplex_parts + 1);
  for (size_t p = 0; p <= simplex_parts; ++p) part_chunk[p] = chunks.size() * p / simplex_parts;
  std::vector<uint32_t> simplex_base(simplex_parts * objects, 0);
  parallel_for(
      simplex_parts, threads,
      [&](size_t b, size_t e, int) {
        for (size_t p = b; p < e; ++p)
          for (size_t c = part_chunk[p]; c < part_chunk[p + 1]; ++c)
            for (const SurfaceChunk::Simplex& t : chunks[c].simplices)
              ++simplex_base[p * objects + t.object];
      },
      1);
  const std::vector<uint32_t> simplices = part_starts(simplex_base, simplex_parts, objects);
  for (GvdCell& cell : gvd.cells) cell.indices.resize(size_t{simplices[cell.object]} * arity);
  parallel_for(
      simplex_parts, threads,
      [&](size_t b, size_t e, int) {
        for (size_t p = b; p < e; ++p) {
          uint32_t* next = &simplex_base[p * objects];
          for (size_t c = part_chunk[p]; c < part_chunk[p + 1]; ++c) {
            for (const SurfaceChunk::Simplex& t : chunks[c].simplices) {
              uint32_t* out = &gvd.cells[t.object].indices[size_t{next[t.object]++} * arity];
              for (int k = 0; k < arity; ++k) out[k] = t.v[k];
            }
          }
        }
      },
      1);
  return gvd;
}

}  // namespace gvd::surface
