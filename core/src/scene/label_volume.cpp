// Labelled voxel volumes: the .npy reader and the boundary surfaces of the labels.
#include "gvd/scene/label_volume.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <set>
#include <string_view>
#include <unordered_map>

#include "gvd/common/cancel.h"
#include "gvd/common/error.h"

namespace gvd {
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

}  // namespace gvd
