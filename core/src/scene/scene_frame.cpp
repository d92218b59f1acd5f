// The octree's frame for a 3D scene (scene.h, scene_frame). Certified cells along a straight
// rim need the rim parallel to an octree axis (pair_certificate.h), so a part drawn at an
// angle would otherwise refine its rims to the gap; turning the octree to the scene's faces
// makes the cost of a tilted assembly that of the same assembly drawn along x, y, z. Only
// rims across a thin gap cost anything, so faces that another object comes near decide: a
// round shaft in its bore turns the octree to its own facets, whatever the housing's outside
// is drawn along.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <tuple>
#include <unordered_map>
#include <utility>
#include <vector>

#include "gvd/common/cancel.h"
#include "gvd/common/parallel.h"
#include "gvd/geometry/simplex_bvh.h"
#include "gvd/scene/scene.h"

namespace gvd::scene {

namespace {

/// Two unit normals are parallel (either sign) when the sine of their angle is below this.
constexpr double kParallel = 1e-7;
/// The frame must hold this share of the total area on its planes, and this much more than
/// the user's axes do.
constexpr double kMinShare = 0.1;
constexpr double kMinGain = 0.05;
/// First axes tried (the heaviest bins of the quantised normals).
constexpr size_t kCandidates = 4;
struct Facet {
  Vec3 n;  ///< unit normal, sign made canonical
  double area;
};

bool parallel(Vec3 a, Vec3 b) { return norm2(cross(a, b)) <= kParallel * kParallel; }

/// The area of facets parallel to d, and their area-weighted mean normal signed along d.
std::pair<double, Vec3> parallel_area(const std::vector<Facet>& facets, Vec3 d) {
  double area = 0;
  Vec3 mean;
  for (const Facet& f : facets) {
    if (!parallel(f.n, d)) continue;
    area += f.area;
    mean = mean + f.n * (dot(f.n, d) < 0 ? -f.area : f.area);
  }
  return {area, mean};
}

double aligned_area(const std::vector<Facet>& facets, const std::array<Vec3, 3>& frame) {
  double area = 0;
  for (const Facet& f : facets)
    if (parallel(f.n, frame[0]) || parallel(f.n, frame[1]) || parallel(f.n, frame[2]))
      area += f.area;
  return area;
}

/// A triangle faces another object across a thin gap when a triangle of that object is
/// parallel to it (within kFacingParallel), and its centroid lies within kFacing of the
/// scene's largest extent (the octree's 6th level) of that triangle's plane and projects into
/// it: flat faces across a gap, whose rims are what a frame can make cheap. Its area then
/// counts kFacingWeight times, so that the frame is chosen for those faces and the rest of
/// the scene only decides among frames that serve them equally. Curved meshes at a near
/// contact (two spheres' facets meeting at a point) do not face each other: no frame helps
/// them.
constexpr double kFacing = 1.0 / 64;
constexpr double kFacingParallel = 1e-4;
constexpr double kFacingWeight = 1000;
/// Triangles of other objects looked at per triangle at most: where many objects crowd one
/// place (800 coincident copies of a ball) the search would otherwise cost copies x
/// neighbours for every triangle (30 s for 288k triangles); a triangle whose partner is not
/// among the first ones counts as not facing, which only weakens the hint.
constexpr int kFacingCandidates = 64;
/// Triangles (or facets, bins) handled between two reads of the cancel flag: a facing search
/// costs up to kFacingCandidates exact tests, so 256 of them stay well under a millisecond;
/// the plain loops over facets read it every 16k.
constexpr size_t kCancelTriangles = 256;
constexpr size_t kCancelFacets = size_t{1} << 14;
constexpr const char* kCancelWhat = "the octree's frame";

/// The scene's triangles in one flat array (scene order) with their BVH, in user coordinates.
struct FlatScene {
  std::vector<Vec3> points;
  std::vector<Simplex> simplices;
  std::vector<uint32_t> object_of;
  SimplexBvh bvh;

  FlatScene(const Scene& scene, const std::atomic<bool>* cancel) {
    points.reserve(scene.vertex_count());
    simplices.reserve(scene.simplex_count());
    object_of.reserve(scene.simplex_count());
    for (size_t o = 0; o < scene.objects.size(); ++o) {
      throw_if_cancelled(cancel, kCancelWhat);
      const SceneObject& object = scene.objects[o];
      const auto base = static_cast<uint32_t>(points.size());
      points.insert(points.end(), object.vertices.begin(), object.vertices.end());
      for (const Simplex& s : object.simplices) {
        Simplex t = s;
        for (int j = 0; j < 3; ++j) t.v[j] += base;
        simplices.push_back(t);
        object_of.push_back(static_cast<uint32_t>(o));
      }
    }
    // Only objects facing each other need it (one object faces nothing).
    if (scene.objects.size() >= 2) bvh = SimplexBvh(3, points, simplices, object_of, cancel);
  }
};

/// Whether each triangle, in scene order, faces another object (above); `normals` are the
/// triangles' unit normals (zero for degenerate ones, which face nothing).
std::vector<char> facing_triangles(const Scene& scene, const FlatScene& flat,
                                   const std::vector<Vec3>& normals, double reach, int threads,
                                   const std::atomic<bool>* cancel) {
  const std::vector<Vec3>& points = flat.points;
  const std::vector<Simplex>& simplices = flat.simplices;
  const std::vector<uint32_t>& object_of = flat.object_of;
  const SimplexBvh& bvh = flat.bvh;
  std::vector<char> facing(simplices.size(), 0);
  if (scene.objects.size() < 2) return facing;
  parallel_for(simplices.size(), resolve_threads(threads), [&](size_t begin, size_t end, int) {
    for (size_t i = begin; i < end; ++i) {
      if ((i - begin) % kCancelTriangles == 0) throw_if_cancelled(cancel, kCancelWhat);
      const Vec3 n = normals[i];
      if (!(norm2(n) > 0)) continue;
      const Simplex& t = simplices[i];
      const Vec3 a = points[t.v[0]], b = points[t.v[1]], c = points[t.v[2]];
      const Vec3 centroid = (a + b + c) / 3.0;
      Box box;
      for (const Vec3& v : {a, b, c}) box.extend(v);
      box.lo = box.lo - Vec3{reach, reach, reach};
      box.hi = box.hi + Vec3{reach, reach, reach};
      int looked = 0;
      bvh.visit_overlapping(
          box,
          [&](uint32_t s) {
            if (object_of[s] == object_of[i]) return true;
            if (++looked > kFacingCandidates) return false;
            const Vec3 m = normals[s];
            if (!(norm2(m) > 0) || norm(cross(n, m)) > kFacingParallel) return true;
            const Vec3 u0 = points[simplices[s].v[0]], u1 = points[simplices[s].v[1]],
                       u2 = points[simplices[s].v[2]];
            const double h = dot(centroid - u0, m);
            if (std::abs(h) > reach) return true;
            // The centroid's foot on the plane inside the triangle (edge functions along m).
            const Vec3 foot = centroid - m * h;
            const double tol = -1e-12 * norm2(u1 - u0);
            if (dot(cross(u1 - u0, foot - u0), m) < tol ||
                dot(cross(u2 - u1, foot - u1), m) < tol || dot(cross(u0 - u2, foot - u2), m) < tol)
              return true;
            facing[i] = 1;
            return false;
          },
          object_of[i]);
    }
  });
  return facing;
}

/// The frame of faces (scene_frame) from the triangles' unit normals, areas and facing flags.
std::array<Vec3, 3> frame_of_faces(const std::vector<Vec3>& normals,
                                   const std::vector<double>& areas,
                                   const std::vector<char>& facing,
                                   const std::atomic<bool>* cancel) {
  const std::array<Vec3, 3> world = {Vec3{1, 0, 0}, Vec3{0, 1, 0}, Vec3{0, 0, 1}};
  std::vector<Facet> facets;
  facets.reserve(normals.size());
  double total = 0;
  for (size_t i = 0; i < normals.size(); ++i) {
    if (i % kCancelFacets == 0) throw_if_cancelled(cancel, kCancelWhat);
    if (!(areas[i] > 0)) continue;
    Vec3 n = normals[i];
    // Canonical sign: the largest component positive (a tie flips some; the exact recount
    // below counts both signs).
    int big = 0;
    for (int k = 1; k < 3; ++k)
      if (std::abs(n[k]) > std::abs(n[big])) big = k;
    if (n[big] < 0) n = n * -1.0;
    const double weight = areas[i] * (facing[i] != 0 ? kFacingWeight : 1.0);
    facets.push_back({n, weight});
    total += weight;
  }
  if (!(total > 0)) return world;

  // Bins of the normals quantised to 1e-6: the frames are ranked on them, then the chosen one
  // is measured on the facets.
  struct Bin {
    double area = 0;
    Vec3 sum;  ///< area-weighted normals, signed along the first member
    Vec3 n;    ///< their mean direction
  };
  auto key = [](Vec3 n) {
    uint64_t k = 0;
    for (int i = 0; i < 3; ++i)
      k = k * 0x9e3779b97f4a7c15ull + static_cast<uint64_t>(std::llround(n[i] * 1e6) + (1ll << 40));
    return k;
  };
  std::unordered_map<uint64_t, Bin> bins;
  for (size_t i = 0; i < facets.size(); ++i) {
    if (i % kCancelFacets == 0) throw_if_cancelled(cancel, kCancelWhat);
    const Facet& f = facets[i];
    Bin& b = bins[key(f.n)];
    b.sum = b.sum + f.n * (dot(b.sum, f.n) < 0 ? -f.area : f.area);
    b.area += f.area;
  }
  std::vector<Bin> sorted;
  sorted.reserve(bins.size());
  for (auto& [k, b] : bins) {
    if (!(norm(b.sum) > 0)) continue;
    b.n = b.sum / norm(b.sum);
    sorted.push_back(b);
  }
  std::sort(sorted.begin(), sorted.end(), [](const Bin& x, const Bin& y) {
    if (x.area != y.area) return x.area > y.area;
    return std::make_tuple(x.n.x, x.n.y, x.n.z) < std::make_tuple(y.n.x, y.n.y, y.n.z);
  });
  // Ranking on bins: parallel within a few bin widths.
  constexpr double kBinParallel = 4e-6;
  auto bin_parallel = [&](Vec3 a, Vec3 b) {
    return norm2(cross(a, b)) <= kBinParallel * kBinParallel;
  };
  auto frame_of = [&](Vec3 first, std::array<Vec3, 3>& frame) {
    Vec3 second;
    bool found = false;
    for (const Bin& b : sorted) {
      if (std::abs(dot(b.n, first)) <= kBinParallel) {
        second = b.n;
        found = true;
        break;
      }
    }
    if (!found) {
      // Nothing perpendicular: the user's axis least along the first.
      int least = 0;
      for (int i = 1; i < 3; ++i)
        if (std::abs(first[i]) < std::abs(first[least])) least = i;
      second = world[least];
    }
    second = second - first * dot(second, first);
    second = second / norm(second);
    frame = {first, second, cross(first, second)};
    return found;
  };
  std::array<Vec3, 3> frame = world;
  double best_area = -1;
  for (size_t c = 0; c < std::min(kCandidates, sorted.size()); ++c) {
    std::array<Vec3, 3> f;
    frame_of(sorted[c].n, f);
    double area = 0;
    for (const Bin& b : sorted)
      if (bin_parallel(b.n, f[0]) || bin_parallel(b.n, f[1]) || bin_parallel(b.n, f[2]))
        area += b.area;
    if (area > best_area) {
      best_area = area;
      frame = f;
    }
  }
  // Measured on the facets: each of the first two axes as the mean normal of its facets.
  const auto [first_area, first_mean] = parallel_area(facets, frame[0]);
  if (!(first_area > 0 && norm(first_mean) > 0)) return world;
  const Vec3 first = first_mean / norm(first_mean);
  Vec3 second = frame[1];
  const auto [second_area, second_mean] = parallel_area(facets, second);
  if (second_area > 0 && norm(second_mean) > 0) second = second_mean / norm(second_mean);
  second = second - first * dot(second, first);
  second = second / norm(second);
  frame = {first, second, cross(first, second)};
  // Worth turning only for a good share of the area (a few facets of a tessellated sphere
  // that happen to be square to each other are not a frame).
  const double area = aligned_area(facets, frame);
  if (!(area >= kMinShare * total && area > aligned_area(facets, world) + kMinGain * total))
    return world;

  // Nearest the user's axes: the permutation with the largest |cos| to x, y, z, each axis
  // signed towards its own, then the least aligned flipped if that made it a reflection.
  std::array<int, 3> order = {0, 1, 2}, best_order = order;
  double best_fit = -1;
  do {
    double fit = 0;
    for (int i = 0; i < 3; ++i) fit += std::abs(frame[order[i]][i]);
    if (fit > best_fit + 1e-12) {
      best_fit = fit;
      best_order = order;
    }
  } while (std::next_permutation(order.begin(), order.end()));
  std::array<Vec3, 3> out;
  for (int i = 0; i < 3; ++i) {
    out[i] = frame[best_order[i]];
    if (out[i][i] < 0) out[i] = out[i] * -1.0;
  }
  if (dot(cross(out[0], out[1]), out[2]) < 0) {
    int least = 0;
    for (int i = 1; i < 3; ++i)
      if (std::abs(out[i][i]) < std::abs(out[least][least])) least = i;
    out[least] = out[least] * -1.0;
  }
  out[2] = cross(out[0], out[1]);  // right-handed to the last bit
  return out;
}

/// A rim of straddled_rims: one edge of it.
struct StraddledEdge {
  double coordinate;  ///< along the straddled axis (the edge's own)
  double length;
  Vec3 middle;
  Vec3 from, to;
  uint32_t object;
  int along;  ///< the axis the edge runs along
};

/// Where the bisector's roof over a straddled rim has its apex: the coordinate along
/// axes[k] of the point of the curve C = {d_own = d_other} in the cross-section through the
/// edge's middle where C is extreme along the third axis w (lines along axes[k] meet C twice
/// on one side of it and at most once on each side). C is found on lines along w beside the
/// edge's middle (d_own - d_other changes sign across the gap: negative in the own object,
/// positive in the other; a root counts only where it lies between its two closest points, so
/// that the unsigned distances' equal points inside an object's material do not). The apex
/// need not lie over the edge: where a shaft's corner of 60 degrees faces its bore's, the apex
/// lies between the two corners, a fraction of the gap from each, and lines along w through the
/// bore's corner itself run along the bore's face and meet no C. So the lines are sampled over
/// a few gaps on both sides; each run of lines that meet C is found to its ends (by bisection)
/// and sampled again densely; the sample nearest the edge whose root lies beyond both
/// neighbours' is the roof's extreme to within a sample, and golden section finds it between
/// those neighbours (C is a roof there: one extreme). Exact distances to the meshes.
/// std::nullopt when there is no such roof within a few gaps of the edge (then the edge's own
/// coordinate is used).
std::optional<double> roof_apex(const FlatScene& flat, const std::array<Vec3, 3>& axes,
                                const StraddledEdge& edge, int k, const std::atomic<bool>* cancel) {
  const SimplexBvh& bvh = flat.bvh;
  const Vec3 p = edge.middle;
  const ClosestHit other_hit = bvh.nearest_excluding(p, &edge.object, 1);
  if (!other_hit.found()) return std::nullopt;
  const uint32_t other = flat.object_of[other_hit.simplex];
  const double gap = std::sqrt(other_hit.dist2);
  if (!(gap > 0)) return std::nullopt;
  const Vec3 m = axes[k], w = axes[3 - k - edge.along];
  auto f = [&](Vec3 x) {
    return std::sqrt(bvh.nearest_in_object(x, edge.object).dist2) -
           std::sqrt(bvh.nearest_in_object(x, other).dist2);
  };
  const double reach = 8 * gap, span = 4 * gap;
  // The root of f on the line p + m t + w s, s in [-reach, reach], by bisection (sign: the
  // side of w on which the other object lies there).
  auto root = [&](double t) -> std::optional<double> {
    throw_if_cancelled(cancel, kCancelWhat);  // ~110 evaluations of f (2 distances each)
    const Vec3 base = p + m * t;
    double side = 0;
    for (const double sign : {1.0, -1.0})
      if (f(base - w * (sign * reach)) < 0 && f(base + w * (sign * reach)) > 0) side = sign;
    if (side == 0) return std::nullopt;
    double lo = -reach, hi = reach;
    for (int i = 0; i < 200 && hi - lo > 1e-16 * reach; ++i) {
      const double mid = 0.5 * (lo + hi);
      if (mid <= lo || mid >= hi) break;
      (f(base + w * (side * mid)) < 0 ? lo : hi) = mid;
    }
    const double s = 0.5 * (lo + hi);
    const Vec3 x = base + w * (side * s);
    const Vec3 a = bvh.nearest_in_object(x, edge.object).point;
    const Vec3 b = bvh.nearest_in_object(x, other).point;
    if (!(dot(x - a, x - b) < 0)) return std::nullopt;  // not between the objects
    return s * side;
  };
  struct Sample {
    double t;
    std::optional<double> h;
  };
  auto sample = [&](double lo, double hi, int n) {
    std::vector<Sample> out(static_cast<size_t>(n) + 1);
    for (int i = 0; i <= n; ++i) {
      out[i].t = lo + (hi - lo) * i / n;
      out[i].h = root(out[i].t);
    }
    return out;
  };
  constexpr int kSamples = 32;  // on 8 gaps: a quarter gap apart
  const std::vector<Sample> coarse = sample(-span, span, kSamples);
  // Each run of lines that meet C, to its ends, sampled again.
  auto end_of_run = [&](double in, double out) {
    for (int i = 0; i < 30; ++i) {
      const double mid = 0.5 * (in + out);
      (root(mid) ? in : out) = mid;
    }
    return in;
  };
  double best_t = 0, best_lo = 0, best_hi = 0, sense = 0;
  bool found = false;
  for (size_t i = 0; i < coarse.size();) {
    if (!coarse[i].h) {
      ++i;
      continue;
    }
    size_t j = i;
    while (j + 1 < coarse.size() && coarse[j + 1].h) ++j;
    const double lo = i > 0 ? end_of_run(coarse[i].t, coarse[i - 1].t) : coarse[i].t;
    const double hi =
        j + 1 < coarse.size() ? end_of_run(coarse[j].t, coarse[j + 1].t) : coarse[j].t;
    i = j + 1;
    if (!(hi > lo)) continue;
    const std::vector<Sample> fine = sample(lo, hi, kSamples);
    for (size_t n = 1; n + 1 < fine.size(); ++n) {
      if (!fine[n - 1].h || !fine[n].h || !fine[n + 1].h) continue;
      const double h = *fine[n].h, l = *fine[n - 1].h, r = *fine[n + 1].h;
      double s = 0;
      if (h > l && h > r) s = 1;
      if (h < l && h < r) s = -1;
      if (s != 0 && (!found || std::abs(fine[n].t) < std::abs(best_t))) {
        found = true;
        best_t = fine[n].t;
        best_lo = fine[n - 1].t;
        best_hi = fine[n + 1].t;
        sense = s;
      }
    }
  }
  if (!found) return std::nullopt;
  constexpr double kGolden = 0.6180339887498949;
  double lo = best_lo, hi = best_hi;
  const double width = hi - lo;
  double x1 = hi - kGolden * (hi - lo), x2 = lo + kGolden * (hi - lo);
  std::optional<double> h1 = root(x1), h2 = root(x2);
  for (int i = 0; i < 200 && hi - lo > 1e-15 * width; ++i) {
    if (!h1 || !h2) return std::nullopt;
    if (sense * *h1 >= sense * *h2) {
      hi = x2;
      x2 = x1;
      h2 = h1;
      x1 = hi - kGolden * (hi - lo);
      h1 = root(x1);
    } else {
      lo = x1;
      x1 = x2;
      h1 = h2;
      x2 = lo + kGolden * (hi - lo);
      h2 = root(x2);
    }
  }
  return dot(p, m) + 0.5 * (lo + hi);
}

/// Rims across a thin gap whose two faces' normals straddle an axis of the cross-section
/// (pair_certificate.h, the cones): per axis k of `axes`, the straight rims along another
/// axis whose faces' normals lie on both sides of axes[k] (components of both signs along
/// it), grouped by their coordinate along axes[k], the most length first, each with the apex
/// of the bisector's roof over its longest edge (roof_apex). Only edges whose two triangles
/// both face another object (facing_triangles) count, and only edges of a consistently
/// oriented, manifold part of a mesh (vertices matched by position).
std::array<std::vector<StraddledRims>, 3> straddled_rims(const Scene& scene, const FlatScene& flat,
                                                         const std::vector<Vec3>& normals,
                                                         const std::vector<char>& facing,
                                                         const std::array<Vec3, 3>& axes,
                                                         double extent,
                                                         const std::atomic<bool>* cancel) {
  constexpr double kAlong = 1e-12;    // an edge along an axis: |sin| below this
  constexpr double kStraddle = 1e-9;  // a normal's component counts by its sign above this
  std::array<std::vector<StraddledEdge>, 3> found;
  size_t first = 0;  // the object's first triangle in scene order
  for (uint32_t oi = 0; oi < scene.objects.size(); ++oi) {
    throw_if_cancelled(cancel, kCancelWhat);
    const SceneObject& object = scene.objects[oi];
    const auto own = facing.begin() + static_cast<std::ptrdiff_t>(first);
    if (std::none_of(own, own + static_cast<std::ptrdiff_t>(object.simplices.size()),
                     [](char f) { return f != 0; })) {
      first += object.simplices.size();  // nothing of it faces another object
      continue;
    }
    // Vertices matched by position (an unwelded mesh still has rims): the first index there.
    std::unordered_map<Vec3, uint32_t, PositionHash> first_at;
    std::vector<uint32_t> canonical(object.vertices.size());
    for (uint32_t v = 0; v < object.vertices.size(); ++v)
      canonical[v] = first_at.emplace(object.vertices[v], v).first->second;
    // Directed edges of facing triangles: (from, to) -> triangle, -1 when repeated. An edge
    // is a rim when its reverse belongs to another facing triangle of the object.
    std::unordered_map<uint64_t, int64_t> directed;
    for (size_t t = 0; t < object.simplices.size(); ++t) {
      if (!facing[first + t]) continue;
      const Simplex& s = object.simplices[t];
      for (int e = 0; e < 3; ++e) {
        const uint64_t key = uint64_t{canonical[s.v[e]]} << 32 | canonical[s.v[(e + 1) % 3]];
        auto [it, inserted] = directed.emplace(key, static_cast<int64_t>(t));
        if (!inserted) it->second = -1;
      }
    }
    for (const auto& [key, t] : directed) {
      const auto from = static_cast<uint32_t>(key >> 32), to = static_cast<uint32_t>(key);
      if (t < 0 || from > to) continue;  // each undirected edge once
      const auto back = directed.find(uint64_t{to} << 32 | from);
      if (back == directed.end() || back->second < 0) continue;
      const Vec3 p = object.vertices[from], q = object.vertices[to];
      const double length = dist(p, q);
      if (!(length > 0)) continue;
      const Vec3 d = (q - p) / length;
      const Vec3 n[2] = {normals[first + static_cast<size_t>(t)],
                         normals[first + static_cast<size_t>(back->second)]};
      for (int e = 0; e < 3; ++e) {
        if (norm2(cross(d, axes[e])) > kAlong * kAlong) continue;
        for (int k = 0; k < 3; ++k) {
          if (k == e) continue;
          const double a = dot(n[0], axes[k]), b = dot(n[1], axes[k]);
          if ((a > kStraddle && b < -kStraddle) || (a < -kStraddle && b > kStraddle))
            found[k].push_back({dot(p, axes[k]), length, (p + q) * 0.5, p, q, oi, e});
        }
      }
    }
    first += object.simplices.size();
  }
  std::array<std::vector<StraddledRims>, 3> out;
  for (int k = 0; k < 3; ++k) {
    std::vector<StraddledEdge>& f = found[k];
    std::sort(f.begin(), f.end(), [](const StraddledEdge& x, const StraddledEdge& y) {
      return std::tie(x.coordinate, x.length) < std::tie(y.coordinate, y.length);
    });
    // Edges at one coordinate (to 1e-9 of the extent) make one group.
    struct Group {
      size_t begin, end;
      double length;
    };
    std::vector<Group> groups;
    for (size_t i = 0; i < f.size();) {
      size_t j = i;
      double length = 0;
      while (j < f.size() && f[j].coordinate - f[i].coordinate <= 1e-9 * extent)
        length += f[j++].length;
      groups.push_back({i, j, length});
      i = j;
    }
    std::stable_sort(groups.begin(), groups.end(),
                     [](const Group& x, const Group& y) { return x.length > y.length; });
    if (groups.size() > kMaxStraddledGroups) groups.resize(kMaxStraddledGroups);
    for (const Group& group : groups) {
      // The longest edges first; the longest one stands for the group's apex.
      std::sort(f.begin() + static_cast<std::ptrdiff_t>(group.begin),
                f.begin() + static_cast<std::ptrdiff_t>(group.end),
                [](const StraddledEdge& x, const StraddledEdge& y) { return x.length > y.length; });
      const StraddledEdge& longest = f[group.begin];
      StraddledRims rims;
      rims.axis = k;
      rims.apex = roof_apex(flat, axes, longest, k, cancel).value_or(longest.coordinate);
      rims.length = group.length;
      for (size_t i = group.begin; i < group.end && rims.edges.size() < kMaxStraddledEdges; ++i)
        rims.edges.push_back({f[i].from, f[i].to});
      out[k].push_back(std::move(rims));
    }
  }
  return out;
}

}  // namespace

SceneFrame analyse_scene_frame(const Scene& scene, bool turn, int threads,
                               const std::atomic<bool>* cancel) {
  SceneFrame out;
  if (scene.dimension != 3) return out;
  Box bounds;
  for (const SceneObject& o : scene.objects)
    for (const Vec3& v : o.vertices) bounds.extend(v);
  const Vec3 side = bounds.hi - bounds.lo;
  const double extent = std::max({side.x, side.y, side.z});
  if (!(extent > 0) || !std::isfinite(extent)) return out;
  // Unit normals (zero for degenerate triangles), with their areas.
  std::vector<Vec3> normals;
  std::vector<double> areas;
  normals.reserve(scene.simplex_count());
  areas.reserve(scene.simplex_count());
  for (const SceneObject& o : scene.objects) {
    throw_if_cancelled(cancel, kCancelWhat);
    for (const Simplex& s : o.simplices) {
      const Vec3 c =
          cross(o.vertices[s.v[1]] - o.vertices[s.v[0]], o.vertices[s.v[2]] - o.vertices[s.v[0]]);
      const double len = norm(c);
      const bool ok = len > 0 && std::isfinite(len);
      normals.push_back(ok ? c / len : Vec3{});
      areas.push_back(ok ? 0.5 * len : 0.0);
    }
  }
  const FlatScene flat(scene, cancel);
  const std::vector<char> facing =
      facing_triangles(scene, flat, normals, kFacing * extent, threads, cancel);
  if (turn) out.axes = frame_of_faces(normals, areas, facing, cancel);
  out.straddled = straddled_rims(scene, flat, normals, facing, out.axes, extent, cancel);
  return out;
}

std::array<Vec3, 3> scene_frame(const Scene& scene) { return analyse_scene_frame(scene).axes; }

}  // namespace gvd::scene
