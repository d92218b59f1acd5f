// Labelled voxel volumes: the .npy reader and the boundary surfaces of the labels.
#include "gvd/scene/label_volume.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <set>
#include <string_view>
#include <tuple>
#include <unordered_map>

#include "gvd/common/cancel.h"
#include "gvd/common/error.h"

namespace gvd::scene {

namespace {

/// Not a .npy file gvd reads (no magic, an unknown version): the format is wrong.
[[noreturn]] void malformed(const std::string& name, const std::string& why) {
  throw Error(ErrorCode::kUnsupportedFormat, "\"" + name + "\" is not a label volume .npy: " + why);
}

/// A .npy file whose header or data is not a label volume (a float dtype, 1 or 4 dimensions,
/// a truncated file): the format is right, its content wrong, as a mesh file's broken data
/// is. `why` names the field (dtype, shape, ...).
[[noreturn]] void invalid(const std::string& name, const std::string& why) {
  throw Error(ErrorCode::kInvalidScene, "\"" + name + "\" is not a label volume: " + why);
}

/// The value of `key` in the header dict ('key': value), as the text up to the next ',' at
/// depth 0 or the closing brace.
std::string header_value(std::string_view header, std::string_view key, const std::string& name) {
  const std::string quoted = "'" + std::string(key) + "'";
  const size_t at = header.find(quoted);
  if (at == std::string_view::npos) invalid(name, "the header has no " + quoted);
  size_t p = header.find(':', at + quoted.size());
  if (p == std::string_view::npos) invalid(name, "the header's " + quoted + " has no value");
  ++p;
  int depth = 0;
  size_t end = p;
  for (; end < header.size(); ++end) {
    const char c = header[end];
    if (c == '(' || c == '[') ++depth;
    if (c == ')' || c == ']') --depth;
    if ((c == ',' && depth == 0) || (c == '}' && depth == 0) || depth < 0) break;
  }
  std::string v(header.substr(p, end - p));
  const auto blank = [](char c) { return c == ' ' || c == '\t'; };
  while (!v.empty() && blank(v.front())) v.erase(v.begin());
  while (!v.empty() && blank(v.back())) v.pop_back();
  return v;
}

/// Voxels decoded between two reads of the cancel flag (well under a millisecond).
constexpr uint64_t kCancelVoxels = uint64_t{1} << 16;

template <class T>
uint64_t load_label(const uint8_t* p, size_t index, const std::string& name) {
  T v;
  std::memcpy(&v, p + index * sizeof(T), sizeof(T));
  if constexpr (std::is_signed_v<T>) {
    if (v < 0) {
      throw Error(ErrorCode::kInvalidScene, "\"" + name + "\": voxel " + std::to_string(index) +
                                                " has the negative label " + std::to_string(v));
    }
  }
  return static_cast<uint64_t>(v);
}

}  // namespace

LabelVolumeHeader read_label_volume_header(std::span<const uint8_t> bytes,
                                           const std::string& name) {
  static const uint8_t kMagic[6] = {0x93, 'N', 'U', 'M', 'P', 'Y'};
  if (bytes.size() < 10 || std::memcmp(bytes.data(), kMagic, 6) != 0) {
    malformed(name, "no numpy magic (\\x93NUMPY)");
  }
  const int major = bytes[6];
  size_t header_len = 0, header_at = 0;
  if (major == 1) {
    header_len = bytes[8] | (size_t{bytes[9]} << 8);
    header_at = 10;
  } else if (major == 2 || major == 3) {
    if (bytes.size() < 12) invalid(name, "truncated header");
    header_len =
        bytes[8] | (size_t{bytes[9]} << 8) | (size_t{bytes[10]} << 16) | (size_t{bytes[11]} << 24);
    header_at = 12;
  } else {
    malformed(name, "format version " + std::to_string(major) + " (1, 2 or 3 are read)");
  }
  if (bytes.size() < header_at + header_len) invalid(name, "truncated header");
  const std::string_view header(reinterpret_cast<const char*>(bytes.data() + header_at),
                                header_len);
  std::string descr = header_value(header, "descr", name);
  if (descr.size() < 2 || (descr.front() != '\'' && descr.front() != '"')) {
    invalid(name, "dtype (descr) " + descr + " is not a string");
  }
  descr = descr.substr(1, descr.size() - 2);
  const std::string fortran = header_value(header, "fortran_order", name);
  if (fortran != "True" && fortran != "False") invalid(name, "fortran_order " + fortran);
  std::string shape_text = header_value(header, "shape", name);
  std::vector<uint64_t> shape;
  for (size_t i = 0; i < shape_text.size();) {
    if (std::isdigit(static_cast<unsigned char>(shape_text[i]))) {
      size_t j = i;
      uint64_t v = 0;
      while (j < shape_text.size() && std::isdigit(static_cast<unsigned char>(shape_text[j]))) {
        if (v > (uint64_t{1} << 40)) invalid(name, "a dimension of the shape is too large");
        v = v * 10 + static_cast<uint64_t>(shape_text[j] - '0');
        ++j;
      }
      shape.push_back(v);
      i = j;
    } else {
      ++i;
    }
  }
  if (shape.size() != 2 && shape.size() != 3) {
    invalid(name, "shape " + shape_text + ": a label volume has 2 or 3 dimensions, not " +
                      std::to_string(shape.size()));
  }
  for (uint64_t s : shape)
    if (s == 0) invalid(name, "shape " + shape_text + " has no voxels");
  // Little-endian (or single-byte) integers only.
  const char order = descr.empty() ? '?' : descr[0];
  const std::string kind = descr.size() > 1 ? descr.substr(1) : "";
  if (order == '>' || (order != '<' && order != '|' && order != '=')) {
    invalid(name, "dtype " + descr +
                      " is not little-endian (labels are read as little-endian "
                      "integers: convert with .astype('<u4'))");
  }
  size_t width = 0;
  if (kind == "i1" || kind == "u1") width = 1;
  if (kind == "i2" || kind == "u2") width = 2;
  if (kind == "i4" || kind == "u4") width = 4;
  if (kind == "i8" || kind == "u8") width = 8;
  if (width == 0) {
    invalid(name, "dtype " + descr +
                      " is not an integer type (labels are integers: int8 .. int64, "
                      "uint8 .. uint64)");
  }

  LabelVolumeHeader h;
  h.dimension = static_cast<int>(shape.size());
  // numpy's C order: (ny, nx) or (nz, ny, nx) with x fastest.
  h.size = {shape.back(), shape[shape.size() - 2], shape.size() == 3 ? shape[0] : 1};
  h.width = static_cast<int>(width);
  h.is_signed = kind[0] == 'i';
  h.fortran_order = fortran == "True";
  h.data_offset = header_at + header_len;
  // The product of the axes checked against the data's size one factor at a time: a shape
  // whose product overflows 64 bits must not wrap around to a small count.
  const uint64_t room = (bytes.size() - h.data_offset) / width;
  uint64_t count = 1;
  bool fits = true;
  for (const uint64_t n : h.size) {
    if (n > room / count) fits = false;
    if (!fits) break;
    count *= n;
  }
  if (!fits) {
    invalid(name, "truncated: the data holds fewer than the " + std::to_string(count) +
                      " values of shape " + shape_text);
  }
  return h;
}

LabelVolume read_label_volume_npy(std::span<const uint8_t> bytes, const std::string& name,
                                  const std::atomic<bool>* cancel) {
  const LabelVolumeHeader h = read_label_volume_header(bytes, name);
  LabelVolume v;
  v.dimension = h.dimension;
  v.size = h.size;
  const uint64_t count = h.voxel_count();
  const uint8_t* data = bytes.data() + h.data_offset;
  v.labels.resize(count);
  const bool signed_kind = h.is_signed;
  for (uint64_t n = 0; n < count; ++n) {
    if (n % kCancelVoxels == 0) throw_if_cancelled(cancel, "reading the label volume");
    // The voxel n of x-fastest order is stored at `at` (Fortran order: the first axis fastest).
    uint64_t at = n;
    if (h.fortran_order) {
      const uint64_t i = n % v.size[0], j = (n / v.size[0]) % v.size[1],
                     k = n / (v.size[0] * v.size[1]);
      // Fortran order over the numpy shape: the numpy axis 0 (z in 3D, y in 2D) fastest.
      at = v.dimension == 3 ? k + v.size[2] * (j + v.size[1] * i) : j + v.size[1] * i;
    }
    uint64_t label = 0;
    switch (h.width) {
      case 1:
        label =
            signed_kind ? load_label<int8_t>(data, at, name) : load_label<uint8_t>(data, at, name);
        break;
      case 2:
        label = signed_kind ? load_label<int16_t>(data, at, name)
                            : load_label<uint16_t>(data, at, name);
        break;
      case 4:
        label = signed_kind ? load_label<int32_t>(data, at, name)
                            : load_label<uint32_t>(data, at, name);
        break;
      default:
        label = signed_kind ? load_label<int64_t>(data, at, name)
                            : load_label<uint64_t>(data, at, name);
        break;
    }
    v.labels[n] = label;
  }
  return v;
}

namespace {

/// A boundary face of a label (3D: a voxel face, 2D: a pixel edge) on the lattice plane
/// `plane` square to axis `axis`, its lower corner at (u, w) on the plane's own axes u =
/// axis + 1, w = axis + 2 (mod 3), so that e_u x e_w = e_axis (2D: u is the other axis, w = 0).
/// `up`: the label lies below the plane, so the (outward) face looks up the axis.
struct BoundaryFace {
  uint64_t label;
  uint32_t axis_side;  // 2 * axis + up
  uint32_t plane;
  uint32_t w, u;
  auto key() const { return std::tie(label, axis_side, plane, w, u); }
};

/// A maximal run-stacked rectangle [u0, u1] x [w0, w1] of one label's faces on one plane and
/// side (lattice coordinates of its corners; 2D: a run [u0, u1], w0 = 0, w1 = 1).
struct FaceRect {
  uint32_t axis_side, plane;
  uint32_t u0, u1, w0, w1;
};

/// The rectangles covering one label's faces of one plane and side, `faces` sorted by (w, u):
/// each row's maximal runs, a run stacked onto the rectangle below it when that one ends on
/// the row beneath with the same extent. Not the fewest rectangles (that is a harder problem)
/// but O(faces), and a box's side is one rectangle.
void stack_runs(std::span<const BoundaryFace> faces, std::vector<FaceRect>& out) {
  std::vector<FaceRect> open, next;  // rectangles that reach the previous row, by u0
  size_t at = 0;
  while (at < faces.size()) {
    const uint32_t w = faces[at].w;
    next.clear();
    size_t o = 0;
    while (at < faces.size() && faces[at].w == w) {
      const uint32_t u0 = faces[at].u;
      uint32_t u1 = u0 + 1;
      ++at;
      while (at < faces.size() && faces[at].w == w && faces[at].u == u1) {
        ++u1;
        ++at;
      }
      while (o < open.size() && open[o].u0 < u0) out.push_back(open[o++]);
      if (o < open.size() && open[o].u0 == u0 && open[o].u1 == u1 && open[o].w1 == w) {
        FaceRect r = open[o++];
        r.w1 = w + 1;
        next.push_back(r);
      } else {
        next.push_back({faces[at - 1].axis_side, faces[at - 1].plane, u0, u1, w, w + 1});
      }
    }
    while (o < open.size()) out.push_back(open[o++]);
    std::swap(open, next);
  }
  out.insert(out.end(), open.begin(), open.end());
}

/// A lattice point as (axis of a line through it, its coordinates on the two other axes
/// (b + 1, b + 2 mod 3), its coordinate on b): sorted, the points on each axis-parallel line
/// in order, so that those inside a rectangle's side are one binary search away.
using LinePoint = std::array<uint32_t, 4>;

}  // namespace

Scene scene_from_label_volume(const LabelVolume& volume, const LabelVolumeOptions& options,
                              const SceneLimits& limits) {
  const int dim = volume.dimension;
  if (dim != 2 && dim != 3) {
    throw Error(ErrorCode::kInvalidArgument, "a label volume has 2 or 3 dimensions");
  }
  for (int a = 0; a < dim; ++a) {
    if (!(options.spacing[a] > 0) || !std::isfinite(options.spacing[a])) {
      throw Error(ErrorCode::kInvalidArgument,
                  "the voxel spacing must be positive and finite on every axis");
    }
  }
  const uint64_t nx = volume.size[0], ny = volume.size[1], nz = dim == 3 ? volume.size[2] : 1;
  GVD_CHECK(volume.labels.size() == nx * ny * nz, "the labels fill the volume");
  auto label_at = [&](int64_t i, int64_t j, int64_t k) -> std::optional<uint64_t> {
    if (i < 0 || j < 0 || k < 0 || i >= static_cast<int64_t>(nx) || j >= static_cast<int64_t>(ny) ||
        k >= static_cast<int64_t>(nz)) {
      return std::nullopt;
    }
    return volume.labels[(static_cast<uint64_t>(k) * ny + static_cast<uint64_t>(j)) * nx +
                         static_cast<uint64_t>(i)];
  };
  // The objects, by label; each collects its boundary on the shared voxel corners.
  struct Builder {
    SceneObject object;
    std::unordered_map<uint64_t, uint32_t> local;  // corner id -> vertex index
  };
  std::map<uint64_t, Builder> objects;
  std::set<std::pair<uint64_t, uint64_t>> touching;  // labels with a voxel face in common
  const uint64_t cx = nx + 1, cy = ny + 1;
  auto corner = [&](Builder& b, uint64_t i, uint64_t j, uint64_t k) {
    const uint64_t id = (k * cy + j) * cx + i;
    const auto [it, added] =
        b.local.try_emplace(id, static_cast<uint32_t>(b.object.vertices.size()));
    if (added) {
      b.object.vertices.push_back(
          {options.origin[0] + static_cast<double>(i) * options.spacing[0],
           options.origin[1] + static_cast<double>(j) * options.spacing[1],
           dim == 3 ? options.origin[2] + static_cast<double>(k) * options.spacing[2] : 0.0});
    }
    return it->second;
  };
  // The lattice point on plane `plane` square to axis a at (u, w) of the plane's axes.
  auto lattice = [&](int a, uint32_t plane, uint32_t u, uint32_t w) {
    std::array<uint32_t, 3> p{0, 0, 0};
    p[a] = plane;
    if (dim == 3) {
      p[(a + 1) % 3] = u;
      p[(a + 2) % 3] = w;
    } else {
      p[1 - a] = u;
    }
    return p;
  };
  auto vertex = [&](Builder& b, const std::array<uint32_t, 3>& p) {
    return corner(b, p[0], p[1], p[2]);
  };
  // One label's rectangles as simplices on the shared lattice points. A side of a rectangle
  // takes as vertices the corners of the label's other rectangles that lie on it (in its
  // plane or square to it): without them a side would meet several edges of its neighbours
  // (a T-junction) and the surface would no longer be closed edge to edge. No other rectangle
  // corner lies inside a rectangle: there the label fills one side of the plane and not the
  // other, so no other face of the label can reach it.
  auto emit_merged = [&](Builder& b, std::span<const FaceRect> rects,
                         std::vector<LinePoint>& points) {
    points.clear();
    for (const FaceRect& r : rects) {
      const int a = static_cast<int>(r.axis_side / 2);
      const uint32_t ws[2] = {r.w0, r.w1};
      for (const uint32_t u : {r.u0, r.u1}) {
        for (int t = 0; t < (dim == 3 ? 2 : 1); ++t) {
          const std::array<uint32_t, 3> p = lattice(a, r.plane, u, ws[t]);
          for (int line = 0; line < dim; ++line)
            points.push_back(
                {static_cast<uint32_t>(line), p[(line + 1) % 3], p[(line + 2) % 3], p[line]});
        }
      }
    }
    std::sort(points.begin(), points.end());
    points.erase(std::unique(points.begin(), points.end()), points.end());
    // The corners strictly inside the side from p (along axis `line`) to coordinate `hi`.
    std::vector<uint32_t> inside;
    auto inner = [&](const std::array<uint32_t, 3>& p, int line, uint32_t hi) {
      inside.clear();
      const LinePoint lo{static_cast<uint32_t>(line), p[(line + 1) % 3], p[(line + 2) % 3],
                         p[line] + 1};
      for (auto it = std::lower_bound(points.begin(), points.end(), lo);
           it != points.end() && (*it)[0] == lo[0] && (*it)[1] == lo[1] && (*it)[2] == lo[2] &&
           (*it)[3] < hi;
           ++it)
        inside.push_back((*it)[3]);
      return inside;
    };
    for (const FaceRect& r : rects) {
      const int a = static_cast<int>(r.axis_side / 2);
      const bool up = (r.axis_side & 1) != 0;  // the face looks up axis a
      if (dim == 2) {
        // A run of pixel edges along the other axis, split where another run ends on it.
        // Counter-clockwise around the region: +x goes up, -x down, +y left, -y right.
        const int u = 1 - a;
        const bool forward = (a == 0) == up;
        std::vector<uint32_t> cuts = inner(lattice(a, r.plane, r.u0, 0), u, r.u1);
        cuts.insert(cuts.begin(), r.u0);
        cuts.push_back(r.u1);
        for (size_t t = 0; t + 1 < cuts.size(); ++t) {
          const uint32_t s = vertex(b, lattice(a, r.plane, cuts[t], 0));
          const uint32_t e = vertex(b, lattice(a, r.plane, cuts[t + 1], 0));
          b.object.simplices.push_back(forward ? Simplex{{s, e, 0}} : Simplex{{e, s, 0}});
        }
        continue;
      }
      const int u = (a + 1) % 3, w = (a + 2) % 3;
      // The sides' points in increasing coordinate, corners included: bottom (w = w0) and top
      // (w = w1) along u, left (u = u0) and right (u = u1) along w.
      auto side = [&](uint32_t u_at, uint32_t w_at, int along, uint32_t hi) {
        std::vector<uint32_t> s = inner(lattice(a, r.plane, u_at, w_at), along, hi);
        s.insert(s.begin(), along == u ? u_at : w_at);
        s.push_back(hi);
        return s;
      };
      const std::vector<uint32_t> bottom = side(r.u0, r.w0, u, r.u1),
                                  top = side(r.u0, r.w1, u, r.u1), left = side(r.u0, r.w0, w, r.w1),
                                  right = side(r.u1, r.w0, w, r.w1);
      // Triangles counter-clockwise in (u, w), i.e. facing +e_a; reversed for the faces
      // that look down the axis (outward either way, as the voxel faces are).
      auto triangle = [&](uint32_t x, uint32_t y, uint32_t z) {
        b.object.simplices.push_back(up ? Simplex{{x, y, z}} : Simplex{{x, z, y}});
      };
      auto at = [&](uint32_t pu, uint32_t pw) { return vertex(b, lattice(a, r.plane, pu, pw)); };
      // A strip between two opposite sides when the other two have no extra point: every
      // triangle has vertices on both sides, so none is degenerate, and there is no added
      // vertex. Chain `A` runs along the side at its lower end, `B` along the opposite one.
      auto strip = [&](const std::vector<uint32_t>& pa, const std::vector<uint32_t>& pb,
                       auto&& point_a, auto&& point_b) {
        size_t i = 0, j = 0;
        while (i + 1 < pa.size() || j + 1 < pb.size()) {
          if (j + 1 == pb.size() || (i + 1 < pa.size() && pa[i + 1] <= pb[j + 1])) {
            triangle(point_a(pa[i]), point_a(pa[i + 1]), point_b(pb[j]));
            ++i;
          } else {
            triangle(point_a(pa[i]), point_b(pb[j + 1]), point_b(pb[j]));
            ++j;
          }
        }
      };
      if (left.size() == 2 && right.size() == 2) {
        strip(
            bottom, top, [&](uint32_t x) { return at(x, r.w0); },
            [&](uint32_t x) { return at(x, r.w1); });
      } else if (bottom.size() == 2 && top.size() == 2) {
        // Turned a quarter counter-clockwise: the right side is the lower one.
        strip(
            right, left, [&](uint32_t x) { return at(r.u1, x); },
            [&](uint32_t x) { return at(r.u0, x); });
      } else {
        // Extra points on adjacent sides: any triangulation without an inner vertex would
        // need a diagonal from one of them, so fan from the centre, which is no side's.
        std::vector<uint32_t> loop;
        for (const uint32_t x : bottom) loop.push_back(at(x, r.w0));
        loop.pop_back();
        for (const uint32_t x : right) loop.push_back(at(r.u1, x));
        loop.pop_back();
        for (auto x = top.rbegin(); x != top.rend(); ++x) loop.push_back(at(*x, r.w1));
        loop.pop_back();
        for (auto x = left.rbegin(); x != left.rend(); ++x) loop.push_back(at(r.u0, *x));
        loop.pop_back();
        std::array<double, 3> c{};
        for (int t = 0; t < 3; ++t) c[t] = static_cast<double>(lattice(a, r.plane, 0, 0)[t]);
        c[u] = (static_cast<double>(r.u0) + static_cast<double>(r.u1)) / 2;
        c[w] = (static_cast<double>(r.w0) + static_cast<double>(r.w1)) / 2;
        const auto centre = static_cast<uint32_t>(b.object.vertices.size());
        b.object.vertices.push_back({options.origin[0] + c[0] * options.spacing[0],
                                     options.origin[1] + c[1] * options.spacing[1],
                                     options.origin[2] + c[2] * options.spacing[2]});
        for (size_t t = 0; t < loop.size(); ++t)
          triangle(centre, loop[t], loop[(t + 1) % loop.size()]);
      }
    }
  };
  const bool merge = options.faces == VolumeFaces::kMerged;
  if (merge) {
    // The faces are kept as 32-bit lattice coordinates until they are merged.
    for (int a = 0; a < dim; ++a) {
      if (volume.size[a] >= (uint64_t{1} << 31)) {
        throw Error(ErrorCode::kInvalidArgument,
                    "a label volume has at most 2^31 - 1 voxels along an axis");
      }
    }
  }
  std::vector<BoundaryFace> faces;  // merge: every boundary face, merged below
  const uint64_t rows = ny * nz;
  uint64_t next_report = 0;  // the row at which the next percent is reported
  for (uint64_t k = 0; k < nz; ++k) {
    for (uint64_t j = 0; j < ny; ++j) {
      throw_if_cancelled(options.cancel, "reading the label volume");
      if (const uint64_t row = k * ny + j; options.progress && row >= next_report) {
        options.progress(static_cast<double>(row) / static_cast<double>(rows));
        next_report = row + std::max<uint64_t>(1, rows / 100);
      }
      for (uint64_t i = 0; i < nx; ++i) {
        const uint64_t label = volume.labels[(k * ny + j) * nx + i];
        if (options.background && label == *options.background) continue;
        Builder& b = objects[label];
        const uint64_t at[3] = {i, j, k};
        for (int a = 0; a < dim; ++a) {
          for (const int side : {1, -1}) {
            int64_t n[3] = {static_cast<int64_t>(i), static_cast<int64_t>(j),
                            static_cast<int64_t>(k)};
            n[a] += side;
            const std::optional<uint64_t> other = label_at(n[0], n[1], n[2]);
            if (other && *other == label) continue;
            if (other && !(options.background && *other == *options.background) && side > 0)
              touching.emplace(std::min(label, *other), std::max(label, *other));
            // The face between the voxel and its neighbour on `side` of axis a, oriented
            // outward: corners base, base + u, base + u + w, base + w with e_u x e_w = e_a.
            uint64_t base[3] = {at[0], at[1], at[2]};
            if (side > 0) base[a] += 1;
            if (merge) {
              const int u = dim == 3 ? (a + 1) % 3 : 1 - a;
              const uint64_t w = dim == 3 ? base[(a + 2) % 3] : 0;
              faces.push_back({label, static_cast<uint32_t>(2 * a + (side > 0)),
                               static_cast<uint32_t>(base[a]), static_cast<uint32_t>(w),
                               static_cast<uint32_t>(base[u])});
              continue;
            }
            if (dim == 2) {
              const int u = 1 - a;  // the other axis
              uint64_t p[3] = {base[0], base[1], 0}, q[3] = {base[0], base[1], 0};
              q[u] += 1;
              // Counter-clockwise around the region: +x goes up, -x down, +y left, -y right.
              const bool forward = (a == 0) == (side > 0);
              const uint32_t s = corner(b, p[0], p[1], 0), e = corner(b, q[0], q[1], 0);
              b.object.simplices.push_back(forward ? Simplex{{s, e, 0}} : Simplex{{e, s, 0}});
              continue;
            }
            const int u = (a + 1) % 3, w = (a + 2) % 3;
            uint64_t c[4][3];
            for (int t = 0; t < 4; ++t) std::copy(base, base + 3, c[t]);
            c[1][u] += 1;
            c[2][u] += 1;
            c[2][w] += 1;
            c[3][w] += 1;
            uint32_t v[4];
            for (int t = 0; t < 4; ++t) v[t] = corner(b, c[t][0], c[t][1], c[t][2]);
            if (side > 0) {
              b.object.simplices.push_back({{v[0], v[1], v[2]}});
              b.object.simplices.push_back({{v[0], v[2], v[3]}});
            } else {
              b.object.simplices.push_back({{v[0], v[2], v[1]}});
              b.object.simplices.push_back({{v[0], v[3], v[2]}});
            }
          }
        }
      }
    }
  }
  if (merge) {
    std::sort(faces.begin(), faces.end(),
              [](const BoundaryFace& x, const BoundaryFace& y) { return x.key() < y.key(); });
    std::vector<FaceRect> rects;
    std::vector<LinePoint> points;
    for (size_t first = 0; first < faces.size();) {
      throw_if_cancelled(options.cancel, "merging the label volume's faces");
      const uint64_t label = faces[first].label;
      size_t last = first;
      while (last < faces.size() && faces[last].label == label) ++last;
      rects.clear();
      for (size_t g = first; g < last;) {
        size_t h = g;
        while (h < last && faces[h].axis_side == faces[g].axis_side &&
               faces[h].plane == faces[g].plane)
          ++h;
        stack_runs(std::span<const BoundaryFace>(faces).subspan(g, h - g), rects);
        g = h;
      }
      emit_merged(objects.at(label), rects, points);
      first = last;
    }
  }
  Scene scene;
  scene.dimension = dim;
  for (auto& [label, b] : objects) {
    b.object.label = "label_" + std::to_string(label);
    scene.objects.push_back(std::move(b.object));
  }
  if (scene.objects.empty()) {
    throw Error(ErrorCode::kInvalidScene,
                "the label volume has no label other than the background: nothing to compute");
  }
  validate_scene(scene, limits, options.cancel);
  if (!touching.empty()) {
    // True to what the pipeline does with them (docs/FORMATS.md): where two labels touch
    // their boundary surfaces coincide, and exact ties between the two copies of a face go to
    // the label a point is inside (gvd_better_hit_sided).
    scene.warnings.push_back(
        {WarningKind::kLabelsTouch, "", touching.size(),
         std::to_string(touching.size()) +
             " pairs of labels share voxel faces: they are touching pairs (gap 0) whose "
             "interface is their shared boundary, resolved down to the contact depth; labels "
             "that meet only along a voxel edge or corner may also come out as neighbours, "
             "with a small interface"});
  }
  return scene;
}

}  // namespace gvd::scene
