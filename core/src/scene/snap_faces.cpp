// Flat faces of a rounded input (float32, or decimals with few digits) put back on exact
// planes (snap_faces.h).

#include "gvd/scene/snap_faces.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <iterator>
#include <unordered_map>
#include <utility>
#include <vector>

#include "gvd/common/cancel.h"
#include "gvd/common/parallel.h"
#include "gvd/geometry/simplex_bvh.h"
#include "gvd/geometry/symmetric_eigen.h"

namespace gvd::scene {

namespace {

/// A face's vertices lie within this many roundings of its plane.
constexpr double kFaceRoundings = 4;
/// Parallel faces join one normal while each stays within this many roundings (root mean
/// square) of its plane under it.
constexpr double kParallelRoundings = 2;
/// Faces whose normals differ by more than this are never tried together.
constexpr double kMaxTilt = 1e-4;
/// The longest move, in roundings, and its largest share of the distance to other objects.
constexpr double kMaxMoveRoundings = 16;
constexpr double kMaxMoveShare = 0.01;
/// A lone triangle is a face when every neighbour meets it at 20 degrees or more.
constexpr double kSharpCos = 0.9396926207859084;
/// Planes at a vertex are taken while the sine of their angles (2 planes) or the volume of
/// their unit normals (3) stays above this.
constexpr double kApart = 0.05;
/// Faces of a direction checked one by one when a face joins it or it is squared (the
/// largest; the rest together), and the largest directions others are squared against: a
/// soup of a million lone triangles is a million directions.
constexpr size_t kCheckedFaces = 16;
constexpr size_t kSquareTo = 64;
/// Moves shorter than this share of the largest coordinate are rounding, not moves.
constexpr double kStill = 0x1p-50;
constexpr size_t kCancelEvery = size_t{1} << 12;
constexpr const char* kCancelWhat = "snapping rounded faces";

/// xx, yy, zz, xy, xz, yz.
using Sym3 = std::array<double, 6>;

/// The unit eigenvector of the least eigenvalue of `m`.
Vec3 least_axis(const Sym3& m) {
  double a[3][3] = {{m[0], m[3], m[4]}, {m[3], m[1], m[5]}, {m[4], m[5], m[2]}};
  double v[3][3];
  symmetric_eigen(a, v);
  int k = 0;
  for (int i = 1; i < 3; ++i)
    if (a[i][i] < a[k][k]) k = i;
  const Vec3 n{v[0][k], v[1][k], v[2][k]};
  return n / norm(n);
}

/// n^T m n.
double along(const Sym3& m, Vec3 n) {
  return m[0] * n.x * n.x + m[1] * n.y * n.y + m[2] * n.z * n.z +
         2 * (m[3] * n.x * n.y + m[4] * n.x * n.z + m[5] * n.y * n.z);
}

Sym3 operator+(const Sym3& a, const Sym3& b) {
  Sym3 r;
  for (int i = 0; i < 6; ++i) r[i] = a[i] + b[i];
  return r;
}

/// A scatter matrix sum (p - c)(p - c)^T held in a frame whose third axis is near the normal
/// of the points' plane: n^T S n is then a sum of small terms, exact to the last bits,
/// where in x, y, z it is the small difference of large ones (a face of a unit part turned
/// against the axes, flat to 5e-11, has n^T S n ~ 1e-19 beside entries ~10: computed in x, y, z
/// it was rounding noise, and faces written with 10 decimals never joined their parallels).
struct FramedScatter {
  Vec3 axis[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  Sym3 s{};

  /// A frame whose third axis is n (unit).
  static FramedScatter around(Vec3 n) {
    FramedScatter f;
    const int i = std::abs(n.x) <= std::abs(n.y) && std::abs(n.x) <= std::abs(n.z)
                      ? 0
                      : (std::abs(n.y) <= std::abs(n.z) ? 1 : 2);
    Vec3 w;
    w[i] = 1;
    f.axis[0] = cross(n, w) / norm(cross(n, w));
    f.axis[1] = cross(n, f.axis[0]);
    f.axis[2] = n;
    return f;
  }
  Vec3 local(Vec3 v) const { return {dot(v, axis[0]), dot(v, axis[1]), dot(v, axis[2])}; }
  void add_point(Vec3 d) {
    const Vec3 q = local(d);
    s = s + Sym3{q.x * q.x, q.y * q.y, q.z * q.z, q.x * q.y, q.x * q.z, q.y * q.z};
  }
  /// n^T S n for a unit n (x, y, z).
  double along(Vec3 n) const { return scene::along(s, local(n)); }
  /// The same points' scatter, in this frame.
  Sym3 in_frame_of(const FramedScatter& other) const {
    // R[i][j] = other.axis[i] . axis[j]: this frame's coordinates to the other's.
    double r[3][3];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) r[i][j] = dot(other.axis[i], axis[j]);
    const double m[3][3] = {{s[0], s[3], s[4]}, {s[3], s[1], s[5]}, {s[4], s[5], s[2]}};
    double out[3][3] = {};
    for (int i = 0; i < 3; ++i)
      for (int k = i; k < 3; ++k)
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) out[i][k] += r[i][a] * m[a][b] * r[k][b];
    return {out[0][0], out[1][1], out[2][2], out[0][1], out[0][2], out[1][2]};
  }
  /// This plus `other`, in this frame.
  FramedScatter plus(const FramedScatter& other) const {
    FramedScatter f = *this;
    f.s = s + other.in_frame_of(*this);
    return f;
  }
  /// The unit eigenvector of the least eigenvalue (x, y, z).
  Vec3 least_normal() const {
    const Vec3 q = least_axis(s);
    const Vec3 n = axis[0] * q.x + axis[1] * q.y + axis[2] * q.z;
    return n / norm(n);
  }
};

/// Whether x is exactly a float32 (finite). By its bits, not by a round trip through float:
/// GCC 12.2 at -O2 folds a vectorised double -> float -> double round trip of neighbouring
/// values away (the truncation of .x and .y of a Vec3 is dropped; -fno-tree-slp-vectorize
/// keeps it).
bool float32_exact(double x) {
  if (x == 0) return true;
  if (!std::isfinite(x)) return false;
  int e = 0;
  std::frexp(x, &e);          // |x| = m 2^e, m in [0.5, 1)
  if (e > 128) return false;  // beyond float32's largest
  // Significant bits a float32 has at this magnitude: 24, fewer among the subnormals.
  const int bits = e >= -125 ? 24 : 24 - (-125 - e);
  if (bits <= 0) return false;
  const double scaled = std::ldexp(x, bits - e);  // an integer when x has no more bits
  return scaled == std::trunc(scaled);
}

/// A coordinate written as a decimal: its significant digits and the place of its last one
/// (10^last), from the shortest text that reads back as the same double (what a writer of
/// that many digits wrote, or a double's own 15 to 17).
struct Decimal {
  int digits = 0;
  int last = 0;
};
Decimal shortest_decimal(double x) {
  char text[32];
  const std::to_chars_result r =
      std::to_chars(text, text + sizeof text, x, std::chars_format::scientific);
  Decimal d;
  int exponent = 0;
  const char* p = text;
  if (*p == '-') ++p;
  for (; p < r.ptr && *p != 'e'; ++p)
    if (*p >= '0' && *p <= '9') ++d.digits;
  if (p < r.ptr) std::from_chars(p + 1 + (p[1] == '+' ? 1 : 0), r.ptr, exponent);
  d.last = exponent - (d.digits - 1);
  return d;
}

/// The rounding of a scene written as decimal text with few digits (an OBJ, an ASCII STL or
/// PLY, a JSON written with 8 decimals), 0 when it is not one: every coordinate's shortest
/// text has at most kMaxDecimalDigits significant digits (a computed double has 15 to 17),
/// and at least half the non-zero ones use up the writer's precision — the most decimal
/// places seen, or the most significant digits (so a scene written by hand, 0.2 and 0.451,
/// is not taken for a rounded one; nor one of integers, which is exact). Then the larger of
/// half a unit in that last place and half a unit in the last of that many significant
/// digits of the largest coordinate bounds what the writer lost, whichever way it wrote.
constexpr int kMaxDecimalDigits = 14;
double decimal_rounding(const Scene& scene, double largest, const std::atomic<bool>* cancel) {
  int most_digits = 0, least_last = 0;
  bool any = false;
  std::vector<Decimal> seen;
  for (const SceneObject& object : scene.objects) {
    for (size_t v = 0; v < object.vertices.size(); ++v) {
      if (v % kCancelEvery == 0) throw_if_cancelled(cancel, kCancelWhat);
      const Vec3& p = object.vertices[v];
      for (int i = 0; i < 3; ++i) {
        if (p[i] == 0) continue;
        const Decimal d = shortest_decimal(p[i]);
        if (d.digits > kMaxDecimalDigits) return 0;
        most_digits = std::max(most_digits, d.digits);
        least_last = any ? std::min(least_last, d.last) : d.last;
        any = true;
        seen.push_back(d);
      }
    }
  }
  if (!any || least_last >= 0) return 0;
  size_t full = 0;
  for (const Decimal& d : seen) full += d.digits == most_digits || d.last == least_last;
  if (2 * full < seen.size()) return 0;
  return std::max(0.5 * std::pow(10.0, least_last),
                  0.5 * std::pow(10.0, 1 - most_digits) * largest);
}

/// Edge-connected triangles of one object on one plane.
struct Group {
  uint32_t object = 0;
  std::vector<uint32_t> vertices;  ///< the object's, sorted, unique
  uint32_t triangles = 0;
  double area = 0;
  Vec3 centroid;
  FramedScatter scatter;  ///< sum of (p - centroid)(p - centroid)^T over the vertices
  Vec3 normal;            ///< unit, the way of the triangles' normals
  bool face = false;
  uint32_t plane = 0;  ///< index into the planes, for faces
};

/// Parallel faces under one normal.
struct Direction {
  FramedScatter scatter;  ///< its faces', in the frame of its first
  uint64_t vertices = 0;  ///< of its faces
  Vec3 normal;
  std::vector<uint32_t> members;  ///< groups
};

struct Plane {
  Vec3 normal;        ///< unit
  double offset = 0;  ///< normal . x on the plane
  double area = 0;
};

/// n or -n: the one whose largest component is positive.
Vec3 canonical(Vec3 n) {
  int big = 0;
  for (int k = 1; k < 3; ++k)
    if (std::abs(n[k]) > std::abs(n[big])) big = k;
  return n[big] < 0 ? n * -1.0 : n;
}

/// Whether canonical() could pick the other sign for a normal within kMaxTilt of n: its two
/// largest components are nearly as large (either could be the largest).
bool sign_ambiguous(Vec3 n) {
  double m[3] = {std::abs(n.x), std::abs(n.y), std::abs(n.z)};
  std::sort(m, m + 3);
  return m[2] - m[1] <= 4 * kMaxTilt;
}

/// Directions are binned on a grid of side 2 kMaxTilt: the bins a normal within kMaxTilt of n
/// can lie in are, per axis, those of n - kMaxTilt and n + kMaxTilt (one or two).
constexpr double kBin = 2 * kMaxTilt;
uint64_t bin_key(const int64_t q[3]) {
  uint64_t k = 0;
  for (int i = 0; i < 3; ++i)
    k = k * 0x9e3779b97f4a7c15ull + static_cast<uint64_t>(q[i] + (int64_t{1} << 40));
  return k;
}
uint64_t direction_key(Vec3 n) {
  const int64_t q[3] = {static_cast<int64_t>(std::floor(n.x / kBin)),
                        static_cast<int64_t>(std::floor(n.y / kBin)),
                        static_cast<int64_t>(std::floor(n.z / kBin))};
  return bin_key(q);
}
/// Calls f(key) for each bin a normal within kMaxTilt of n can lie in, until f returns true.
template <class F>
bool for_each_near_bin(Vec3 n, F&& f) {
  int64_t lo[3], hi[3];
  for (int i = 0; i < 3; ++i) {
    lo[i] = static_cast<int64_t>(std::floor((n[i] - kMaxTilt) / kBin));
    hi[i] = static_cast<int64_t>(std::floor((n[i] + kMaxTilt) / kBin));
  }
  int64_t q[3];
  for (q[0] = lo[0]; q[0] <= hi[0]; ++q[0])
    for (q[1] = lo[1]; q[1] <= hi[1]; ++q[1])
      for (q[2] = lo[2]; q[2] <= hi[2]; ++q[2])
        if (f(bin_key(q))) return true;
  return false;
}

}  // namespace

FaceSnap snap_rounded_faces(Scene& scene, int threads, const std::atomic<bool>* cancel) {
  FaceSnap report;
  if (scene.dimension != 3 || scene.objects.size() < 2) return report;
  double largest = 0;
  bool float32 = true;
  for (const SceneObject& object : scene.objects) {
    throw_if_cancelled(cancel, kCancelWhat);
    for (const Vec3& p : object.vertices) {
      float32 = float32 && float32_exact(p.x) && float32_exact(p.y) && float32_exact(p.z);
      largest = std::max({largest, std::abs(p.x), std::abs(p.y), std::abs(p.z)});
    }
  }
  if (!(largest > 0)) return report;
  const double rounding =
      float32 ? std::ldexp(largest, -24) : decimal_rounding(scene, largest, cancel);
  if (!(rounding > 0)) return report;
  report.rounding = rounding;
  report.float32 = float32;
  const double face_tol = kFaceRoundings * rounding;

  // Faces: edge-connected triangles whose normals agree within what rounding their vertices
  // can tilt them by, grown from the largest, then fitted and kept when every vertex lies
  // within face_tol of the fitted plane.
  std::vector<Group> groups;
  std::vector<std::vector<int32_t>> group_of(scene.objects.size());
  for (uint32_t o = 0; o < scene.objects.size(); ++o) {
    const SceneObject& object = scene.objects[o];
    const size_t count = object.simplices.size();
    std::vector<Vec3> normal(count);
    std::vector<double> area(count), altitude(count);
    for (size_t t = 0; t < count; ++t) {
      if (t % kCancelEvery == 0) throw_if_cancelled(cancel, kCancelWhat);
      const Simplex& s = object.simplices[t];
      const Vec3 a = object.vertices[s.v[0]], b = object.vertices[s.v[1]],
                 c = object.vertices[s.v[2]];
      const Vec3 n = cross(b - a, c - a);
      const double twice = norm(n);
      const double longest = std::sqrt(std::max({dist2(a, b), dist2(b, c), dist2(c, a)}));
      area[t] = twice / 2;
      altitude[t] = longest > 0 ? twice / longest : 0;
      normal[t] = twice > 0 ? n / twice : Vec3{};
    }
    const std::vector<uint32_t> across = triangles_across(object, cancel, kCancelWhat);
    auto agree = [&](uint32_t t, uint32_t u) {
      if (!(altitude[t] > 0) || !(altitude[u] > 0) || dot(normal[t], normal[u]) <= 0) return false;
      const double tilt = 2 * std::sqrt(3.0) * rounding * (1 / altitude[t] + 1 / altitude[u]);
      return norm(cross(normal[t], normal[u])) <= 2 * tilt;
    };
    std::vector<uint32_t> order(count);
    for (uint32_t t = 0; t < count; ++t) order[t] = t;
    std::sort(order.begin(), order.end(), [&](uint32_t x, uint32_t y) {
      return area[x] != area[y] ? area[x] > area[y] : x < y;
    });
    // Per triangle: its face's index in `groups`, or not seen yet, seen in no face, or in
    // the group being grown. Only faces are kept (a curved mesh's lone triangles would cost
    // a group each).
    constexpr int32_t kUnseen = -1, kNoFace = -2, kGrowing = -3;
    std::vector<int32_t>& of = group_of[o];
    of.assign(count, kUnseen);
    std::vector<uint32_t> stack, members;
    size_t seeds = 0;
    for (const uint32_t seed : order) {
      if (of[seed] != kUnseen || !(area[seed] > 0)) continue;
      if (++seeds % kCancelEvery == 0) throw_if_cancelled(cancel, kCancelWhat);
      Group g;
      g.object = o;
      of[seed] = kGrowing;
      stack.assign(1, seed);
      members.clear();
      Vec3 weighted;
      while (!stack.empty()) {
        const uint32_t t = stack.back();
        stack.pop_back();
        members.push_back(t);
        weighted = weighted + normal[t] * area[t];
        g.area += area[t];
        for (int e = 0; e < 3; ++e) {
          const uint32_t u = across[t * 3 + e];
          if (u == kNoNeighbour || of[u] != kUnseen || !agree(t, u)) continue;
          of[u] = kGrowing;
          stack.push_back(u);
        }
      }
      g.triangles = static_cast<uint32_t>(members.size());
      for (uint32_t t : members)
        for (int k = 0; k < 3; ++k) g.vertices.push_back(object.simplices[t].v[k]);
      std::sort(g.vertices.begin(), g.vertices.end());
      g.vertices.erase(std::unique(g.vertices.begin(), g.vertices.end()), g.vertices.end());
      for (uint32_t v : g.vertices) g.centroid = g.centroid + object.vertices[v];
      g.centroid = g.centroid / static_cast<double>(g.vertices.size());
      // Fitted twice: in x, y, z for the frame, then in that frame.
      for (uint32_t v : g.vertices) g.scatter.add_point(object.vertices[v] - g.centroid);
      g.scatter = FramedScatter::around(g.scatter.least_normal());
      for (uint32_t v : g.vertices) g.scatter.add_point(object.vertices[v] - g.centroid);
      g.normal = g.scatter.least_normal();
      if (dot(g.normal, weighted) < 0) g.normal = g.normal * -1.0;
      bool flat = true;
      for (uint32_t v : g.vertices)
        flat = flat && std::abs(dot(object.vertices[v] - g.centroid, g.normal)) <= face_tol;
      bool sharp = g.triangles >= 2;
      if (g.triangles == 1) {
        sharp = true;
        for (int e = 0; e < 3; ++e) {
          const uint32_t u = across[seed * 3 + e];
          if (u != kNoNeighbour && dot(normal[seed], normal[u]) > kSharpCos) sharp = false;
        }
      }
      g.face = flat && sharp;
      const int32_t id = g.face ? static_cast<int32_t>(groups.size()) : kNoFace;
      for (uint32_t t : members) of[t] = id;
      if (g.face) groups.push_back(std::move(g));
    }
  }

  // Directions: faces by decreasing area, each joining the first direction (within kMaxTilt)
  // under whose joint normal it, the direction's largest faces and all of them together stay
  // within kParallelRoundings.
  std::vector<uint32_t> faces;
  for (uint32_t i = 0; i < groups.size(); ++i)
    if (groups[i].face) faces.push_back(i);
  report.faces = faces.size();
  if (faces.empty()) return report;
  std::sort(faces.begin(), faces.end(), [&](uint32_t x, uint32_t y) {
    return groups[x].area != groups[y].area ? groups[x].area > groups[y].area : x < y;
  });
  const double parallel_tol2 = kParallelRoundings * kParallelRoundings * rounding * rounding;
  // Under normal n, each of a direction's largest faces (the first to join it) stays within
  // kParallelRoundings of its plane. The others count only together (so that a direction of
  // many faces costs no more per face); a face that fits badly is caught where its vertices
  // move (at most kMaxMoveRoundings).
  auto largest_fit = [&](const Direction& d, Vec3 n) {
    for (size_t k = 0; k < std::min(d.members.size(), kCheckedFaces); ++k) {
      const Group& m = groups[d.members[k]];
      if (m.scatter.along(n) > parallel_tol2 * static_cast<double>(m.vertices.size())) return false;
    }
    return true;
  };
  std::vector<Direction> directions;
  std::unordered_map<uint64_t, std::vector<uint32_t>> bins;
  for (size_t i = 0; i < faces.size(); ++i) {
    if (i % kCancelEvery == 0) throw_if_cancelled(cancel, kCancelWhat);
    const uint32_t f = faces[i];
    const Group& g = groups[f];
    auto fits = [&](const Direction& d, const FramedScatter& joint, Vec3 n) {
      const auto count = static_cast<double>(g.vertices.size());
      return g.scatter.along(n) <= parallel_tol2 * count &&
             joint.along(n) <= parallel_tol2 * (static_cast<double>(d.vertices) + count) &&
             largest_fit(d, n);
    };
    // Directions are binned by their first face's canonical normal; a face looks in the bins
    // around its own, and around the opposite one where the sign could go either way.
    int64_t joined = -1;
    const Vec3 key_normal = canonical(g.normal);
    for (int sign = 1; sign >= (sign_ambiguous(key_normal) ? -1 : 1) && joined < 0; sign -= 2) {
      for_each_near_bin(key_normal * sign, [&](uint64_t key) {
        const auto bin = bins.find(key);
        if (bin == bins.end()) return false;
        for (uint32_t c : bin->second) {
          Direction& d = directions[c];
          if (norm(cross(d.normal, g.normal)) > kMaxTilt) continue;
          const FramedScatter joint = d.scatter.plus(g.scatter);
          const Vec3 n = joint.least_normal();
          if (!fits(d, joint, n)) continue;
          d.scatter = joint;
          d.vertices += g.vertices.size();
          d.normal = n;
          d.members.push_back(f);
          joined = c;
          return true;
        }
        return false;
      });
    }
    if (joined < 0) {
      joined = static_cast<int64_t>(directions.size());
      Direction d;
      d.scatter = g.scatter;
      d.vertices = g.vertices.size();
      d.normal = g.normal;
      d.members.push_back(f);
      directions.push_back(std::move(d));
      bins[direction_key(key_normal)].push_back(static_cast<uint32_t>(joined));
    }
  }

  // Square corners: each direction, the most area first, is made exactly perpendicular to
  // the earlier ones (of the kSquareTo largest) it is perpendicular to within kMaxTilt, where
  // its faces stay within kParallelRoundings of their planes under the turned normal. (Fitted
  // one by one, the directions of a box drawn at an angle are square only to ~1e-8, and the
  // certificates of a rim need the faces beside it square to the octree's axes.)
  {
    std::vector<double> area(directions.size(), 0);
    std::vector<uint32_t> order(directions.size());
    for (uint32_t d = 0; d < directions.size(); ++d) {
      order[d] = d;
      for (uint32_t m : directions[d].members) area[d] += groups[m].area;
    }
    std::sort(order.begin(), order.end(), [&](uint32_t x, uint32_t y) {
      return area[x] != area[y] ? area[x] > area[y] : x < y;
    });
    std::vector<Vec3> square;  // the largest directions so far
    for (size_t i = 0; i < order.size(); ++i) {
      if (i % kCancelEvery == 0) throw_if_cancelled(cancel, kCancelWhat);
      Direction& d = directions[order[i]];
      const Vec3 n = d.normal;
      std::vector<Vec3> across;
      for (const Vec3& s : square)
        if (std::abs(dot(n, s)) <= kMaxTilt) across.push_back(s);
      Vec3 turned = n;
      if (across.size() == 1) {
        turned = n - across[0] * dot(n, across[0]);
      } else if (across.size() >= 2) {
        for (size_t j = 1; j < across.size(); ++j) {
          const Vec3 c = cross(across[0], across[j]);
          if (norm(c) >= kApart) {
            turned = dot(c, n) < 0 ? c * -1.0 : c;
            break;
          }
        }
        if (turned == n) turned = n - across[0] * dot(n, across[0]);
      }
      turned = turned / norm(turned);
      if (turned != n &&
          d.scatter.along(turned) <= parallel_tol2 * static_cast<double>(d.vertices) &&
          largest_fit(d, turned))
        d.normal = turned;
      if (square.size() < kSquareTo) square.push_back(d.normal);
    }
  }

  // Planes: within a direction, faces the same way whose offsets lie within face_tol of the
  // first of a run share its mean offset. Then a run facing the other way within face_tol
  // that holds a face of one of the same objects is glued to it (a slot's wall standing on
  // its floor, written as two boxes of one object: the wall's underside on the floor's top):
  // both take their mean offset, so that the glued faces stay coplanar. Faces of different
  // objects facing each other are never moved together (that would close a gap).
  std::vector<Plane> planes;
  struct Run {
    int side;
    uint32_t plane;
    double weight;
    std::vector<uint32_t> objects;  ///< sorted, unique
  };
  std::vector<Run> runs;
  for (const Direction& d : directions) {
    runs.clear();
    struct Entry {
      int side;
      double offset;
      uint32_t group;
    };
    std::vector<Entry> entries;
    for (uint32_t m : d.members)
      entries.push_back(
          {dot(groups[m].normal, d.normal) < 0 ? -1 : 1, dot(d.normal, groups[m].centroid), m});
    std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) {
      return a.side != b.side ? a.side < b.side : a.offset < b.offset;
    });
    for (size_t i = 0; i < entries.size();) {
      size_t j = i;
      double weighted = 0, weight = 0, area = 0;
      bool same = true;
      while (j < entries.size() && entries[j].side == entries[i].side &&
             entries[j].offset - entries[i].offset <= face_tol) {
        const Group& g = groups[entries[j].group];
        const auto w = static_cast<double>(g.vertices.size());
        weighted += w * entries[j].offset;
        weight += w;
        area += g.area;
        same = same && entries[j].offset == entries[i].offset;
        ++j;
      }
      Plane plane;
      plane.normal = d.normal;
      plane.offset = same ? entries[i].offset : weighted / weight;
      plane.area = area;
      Run run{entries[i].side, static_cast<uint32_t>(planes.size()), weight, {}};
      for (size_t k = i; k < j; ++k) {
        groups[entries[k].group].plane = run.plane;
        run.objects.push_back(groups[entries[k].group].object);
      }
      std::sort(run.objects.begin(), run.objects.end());
      run.objects.erase(std::unique(run.objects.begin(), run.objects.end()), run.objects.end());
      planes.push_back(plane);
      runs.push_back(std::move(run));
      i = j;
    }
    // Runs are sorted by side, then offset: each one facing down (-1) against the nearest
    // facing up within face_tol that shares an object.
    std::vector<uint8_t> glued(runs.size(), 0);
    for (size_t a = 0; a < runs.size() && runs[a].side < 0; ++a) {
      size_t best = runs.size();
      double best_gap = face_tol;
      for (size_t b = 0; b < runs.size(); ++b) {
        if (runs[b].side < 0 || glued[b]) continue;
        const double gap = std::abs(planes[runs[b].plane].offset - planes[runs[a].plane].offset);
        if (gap > best_gap) continue;
        std::vector<uint32_t> common;
        std::set_intersection(runs[a].objects.begin(), runs[a].objects.end(),
                              runs[b].objects.begin(), runs[b].objects.end(),
                              std::back_inserter(common));
        if (common.empty()) continue;
        best = b;
        best_gap = gap;
      }
      if (best == runs.size()) continue;
      glued[a] = glued[best] = 1;
      Plane& down = planes[runs[a].plane];
      Plane& up = planes[runs[best].plane];
      const double mean = (down.offset * runs[a].weight + up.offset * runs[best].weight) /
                          (runs[a].weight + runs[best].weight);
      down.offset = up.offset = mean;
    }
  }
  report.planes = planes.size();

  // Each vertex's planes, the largest first, taken while well apart; the move to where they
  // meet.
  struct Move {
    uint32_t object;
    uint32_t vertex;
    Vec3 to;
  };
  std::vector<Move> moves;
  for (uint32_t o = 0; o < scene.objects.size(); ++o) {
    throw_if_cancelled(cancel, kCancelWhat);
    const SceneObject& object = scene.objects[o];
    std::vector<std::pair<uint32_t, uint32_t>> at;  // (vertex, plane)
    for (size_t t = 0; t < object.simplices.size(); ++t) {
      const int32_t gi = group_of[o][t];
      if (gi < 0 || !groups[gi].face) continue;
      for (int k = 0; k < 3; ++k) at.push_back({object.simplices[t].v[k], groups[gi].plane});
    }
    std::sort(at.begin(), at.end());
    at.erase(std::unique(at.begin(), at.end()), at.end());
    std::vector<uint32_t> mine;
    for (size_t i = 0; i < at.size();) {
      if (i % kCancelEvery == 0) throw_if_cancelled(cancel, kCancelWhat);
      const uint32_t v = at[i].first;
      mine.clear();
      for (; i < at.size() && at[i].first == v; ++i) mine.push_back(at[i].second);
      std::sort(mine.begin(), mine.end(), [&](uint32_t x, uint32_t y) {
        return planes[x].area != planes[y].area ? planes[x].area > planes[y].area : x < y;
      });
      std::array<const Plane*, 3> chosen{};
      int n = 0;
      for (uint32_t pi : mine) {
        const Plane& q = planes[pi];
        if (n == 1 && !(norm(cross(chosen[0]->normal, q.normal)) >= kApart)) continue;
        if (n == 2 &&
            !(std::abs(dot(cross(chosen[0]->normal, chosen[1]->normal), q.normal)) >= kApart))
          continue;
        chosen[n++] = &q;
        if (n == 3) break;
      }
      const Vec3 p = object.vertices[v];
      double r[3];
      for (int k = 0; k < n; ++k) r[k] = chosen[k]->offset - dot(chosen[k]->normal, p);
      Vec3 step;
      if (n == 1) {
        step = chosen[0]->normal * r[0];
      } else if (n == 2) {
        const Vec3 a = chosen[0]->normal, b = chosen[1]->normal;
        const double ab = dot(a, b), det = 1 - ab * ab;
        step = a * ((r[0] - ab * r[1]) / det) + b * ((r[1] - ab * r[0]) / det);
      } else {
        const Vec3 a = chosen[0]->normal, b = chosen[1]->normal, c = chosen[2]->normal;
        const double det = dot(a, cross(b, c));
        step = (cross(b, c) * r[0] + cross(c, a) * r[1] + cross(a, b) * r[2]) / det;
      }
      const Vec3 to = p + step;
      // A move within a few units in the last place is the planes' own rounding: the vertex is
      // on them already (to the certificates' 1e-12, by far).
      if (!(norm(step) > kStill * largest)) continue;
      if (!(dist(to, p) <= kMaxMoveRoundings * rounding)) {
        ++report.refused;
        continue;
      }
      moves.push_back({o, v, to});
    }
  }

  // No gap may change by more than 2 % of itself: a vertex moves by at most 1 % of the
  // distance from each of its triangles to every other object (a point of a triangle moves
  // by no more than its farthest-moving vertex).
  if (!moves.empty()) {
    std::vector<std::vector<int64_t>> move_of(scene.objects.size());
    for (uint32_t o = 0; o < scene.objects.size(); ++o)
      move_of[o].assign(scene.objects[o].vertices.size(), -1);
    for (size_t i = 0; i < moves.size(); ++i)
      move_of[moves[i].object][moves[i].vertex] = static_cast<int64_t>(i);
    std::vector<Vec3> points;
    std::vector<Simplex> simplices;
    std::vector<uint32_t> object_of;
    std::vector<double> reach;        // per simplex with a moving vertex: its largest move / 1 %
    std::vector<uint32_t> moving;     // those simplices
    std::vector<Simplex> moving_own;  // with the object's own vertex indices
    for (uint32_t o = 0; o < scene.objects.size(); ++o) {
      const SceneObject& object = scene.objects[o];
      const auto base = static_cast<uint32_t>(points.size());
      points.insert(points.end(), object.vertices.begin(), object.vertices.end());
      for (Simplex s : object.simplices) {
        double most = 0;
        for (const uint32_t k : s.v)
          if (move_of[o][k] >= 0)
            most = std::max(most, dist(moves[move_of[o][k]].to, object.vertices[k]));
        if (most > 0) {
          moving.push_back(static_cast<uint32_t>(simplices.size()));
          moving_own.push_back(s);
          reach.push_back(most / kMaxMoveShare);
        }
        for (uint32_t& k : s.v) k += base;
        simplices.push_back(s);
        object_of.push_back(o);
      }
    }
    const SimplexBvh bvh(3, points, simplices, object_of, cancel);
    // Per moving simplex, the distance to the nearest other object when it is within reach.
    std::vector<double> near(moving.size(), 1e300);
    parallel_for(
        moving.size(), resolve_threads(threads),
        [&](size_t begin, size_t end, int) {
          throw_if_cancelled(cancel, kCancelWhat);
          for (size_t i = begin; i < end; ++i) {
            const Simplex& s = simplices[moving[i]];
            const Vec3 q[3] = {points[s.v[0]], points[s.v[1]], points[s.v[2]]};
            const ClosestHit hit =
                bvh.closest_to_simplex(q, reach[i] * reach[i], object_of[moving[i]]);
            if (hit.found()) near[i] = std::sqrt(hit.dist2);
          }
        },
        256);
    std::vector<char> refuse(moves.size(), 0);
    for (size_t i = 0; i < moving.size(); ++i) {
      if (near[i] == 1e300) continue;
      const uint32_t o = object_of[moving[i]];
      for (const uint32_t k : moving_own[i].v) {
        const int64_t m = move_of[o][k];
        if (m >= 0 && dist(moves[m].to, scene.objects[o].vertices[k]) > kMaxMoveShare * near[i])
          refuse[m] = 1;
      }
    }
    for (size_t i = 0; i < moves.size(); ++i) {
      const Move& m = moves[i];
      Vec3& p = scene.objects[m.object].vertices[m.vertex];
      if (refuse[i] != 0) {
        ++report.refused;
        continue;
      }
      report.max_move = std::max(report.max_move, dist(m.to, p));
      ++report.vertices;
      p = m.to;
    }
  }
  return report;
}

}  // namespace gvd::scene
