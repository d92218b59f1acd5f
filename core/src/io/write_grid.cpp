#include "gvd/io/write_grid.h"

#include <bit>
#include <cstdio>
#include <cstring>

#include "gvd/common/error.h"
#include "gvd/io/write_outputs.h"
#include "gvd/scene/units.h"

namespace gvd::io {

using namespace gvd::scene;
using namespace gvd::grid;

static_assert(std::endian::native == std::endian::little,
              "the grid files are written little endian from host memory");

namespace {

size_t value_size(GridValueType t) { return t == GridValueType::kFloat64 ? 8 : 4; }

const char* npy_descr(GridValueType t) {
  switch (t) {
    case GridValueType::kFloat32:
      return "<f4";
    case GridValueType::kFloat64:
      return "<f8";
    case GridValueType::kInt32:
      return "<i4";
  }
  return "?";
}

const char* nrrd_type(GridValueType t) {
  switch (t) {
    case GridValueType::kFloat32:
      return "float";
    case GridValueType::kFloat64:
      return "double";
    case GridValueType::kInt32:
      return "int32";
  }
  return "?";
}

std::string number(double v) {
  char s[40];
  std::snprintf(s, sizeof s, "%.17g", v);
  return s;
}

enum class FileKind { kNpy, kNrrd, kNhdr };

FileKind kind_of(const std::string& path) {
  auto ends = [&](const char* ext) {
    const size_t n = std::strlen(ext);
    return path.size() > n && path.compare(path.size() - n, n, ext) == 0;
  };
  if (ends(".npy")) return FileKind::kNpy;
  if (ends(".nrrd")) return FileKind::kNrrd;
  if (ends(".nhdr")) return FileKind::kNhdr;
  throw Error(ErrorCode::kInvalidArgument,
              "grid output '" + path + "': the name must end in .npy, .nrrd or .nhdr");
}

std::vector<std::string> write_values(const GridSpec& spec, GridValueType type, const void* data,
                                      const std::string& path, const std::string& comment,
                                      const std::string& units) {
  const size_t bytes = spec.cell_count() * value_size(type);
  switch (kind_of(path)) {
    case FileKind::kNpy: {
      const std::vector<uint64_t> shape = grid_shape(spec);
      const std::vector<uint8_t> file = npy_bytes(type, shape, data);
      write_file_atomic(path, file.data(), file.size());
      return {path};
    }
    case FileKind::kNrrd: {
      std::string file = nrrd_header(spec, type, "", comment, units);
      file.append(static_cast<const char*>(data), bytes);
      write_file_atomic(path, file);
      return {path};
    }
    case FileKind::kNhdr: {
      const std::string raw = path.substr(0, path.size() - 5) + ".raw";
      const size_t slash = raw.find_last_of('/');
      const std::string name = slash == std::string::npos ? raw : raw.substr(slash + 1);
      write_file_atomic(raw, data, bytes);
      write_file_atomic(path, nrrd_header(spec, type, name, comment, units));
      return {path, raw};
    }
  }
  return {};
}

}  // namespace

std::vector<uint64_t> grid_shape(const GridSpec& spec) {
  std::vector<uint64_t> shape;
  if (spec.dimension == 3) shape.push_back(static_cast<uint64_t>(spec.n[2]));
  shape.push_back(static_cast<uint64_t>(spec.n[1]));
  shape.push_back(static_cast<uint64_t>(spec.n[0]));
  return shape;
}

std::vector<uint8_t> npy_bytes(GridValueType type, std::span<const uint64_t> shape,
                               const void* data) {
  std::string dict =
      std::string("{'descr': '") + npy_descr(type) + "', 'fortran_order': False, 'shape': (";
  uint64_t count = 1;
  for (size_t i = 0; i < shape.size(); ++i) {
    dict += std::to_string(shape[i]);
    dict += shape.size() == 1 ? "," : (i + 1 < shape.size() ? ", " : "");
    count *= shape[i];
  }
  dict += "), }";
  // magic (6) + version (2) + header length (2) + dict + padding + '\n' = multiple of 64.
  const size_t unpadded = 10 + dict.size() + 1;
  const size_t total = (unpadded + 63) / 64 * 64;
  dict.append(total - unpadded, ' ');
  dict += '\n';
  if (dict.size() > 0xFFFF) throw Error(ErrorCode::kInvalidArgument, "npy header too long");
  const size_t bytes = count * value_size(type);
  // One buffer filled by memcpy (GCC 12 warns falsely on vector::insert of small arrays).
  std::vector<uint8_t> out(total + bytes);
  const uint8_t magic[8] = {0x93, 'N', 'U', 'M', 'P', 'Y', 1, 0};
  std::memcpy(out.data(), magic, 8);
  out[8] = static_cast<uint8_t>(dict.size() & 0xFF);
  out[9] = static_cast<uint8_t>(dict.size() >> 8);
  std::memcpy(out.data() + 10, dict.data(), dict.size());
  if (bytes > 0) std::memcpy(out.data() + total, data, bytes);
  return out;
}

std::string nrrd_header(const GridSpec& spec, GridValueType type, const std::string& data_file,
                        const std::string& comment, const std::string& units) {
  const int d = spec.dimension;
  std::string h = "NRRD0004\n";
  if (!comment.empty()) h += "# " + comment + "\n";
  h += std::string("type: ") + nrrd_type(type) + "\n";
  h += "dimension: " + std::to_string(d) + "\n";
  h += "space dimension: " + std::to_string(d) + "\n";
  h += "sizes:";
  for (int i = 0; i < d; ++i) h += " " + std::to_string(spec.n[static_cast<size_t>(i)]);
  h += "\nspace directions:";
  for (int i = 0; i < d; ++i) {
    h += " (";
    for (int j = 0; j < d; ++j) h += (j ? "," : "") + number(i == j ? spec.h : 0.0);
    h += ")";
  }
  h += "\nkinds:";
  for (int i = 0; i < d; ++i) h += " domain";
  h += "\nendian: little\nencoding: raw\nspace origin: (";
  for (int i = 0; i < d; ++i) h += (i ? "," : "") + number(spec.origin[i] + 0.5 * spec.h);
  h += ")\n";
  if (!units.empty()) {
    const std::string ascii = ascii_units(units);  // NRRD headers are ASCII text
    h += "space units:";
    for (int i = 0; i < d; ++i) h += " \"" + ascii + "\"";
    h += "\n";
  }
  if (!data_file.empty()) {
    h += "data file: " + data_file + "\n";
  } else {
    h += "\n";  // attached: the data follows the blank line
  }
  return h;
}

std::vector<uint8_t> grid_npy_bytes(const DistanceGrid& grid, bool labels, bool float64) {
  const std::vector<uint64_t> shape = grid_shape(grid.spec);
  if (labels) return npy_bytes(GridValueType::kInt32, shape, grid.label.data());
  if (float64) return npy_bytes(GridValueType::kFloat64, shape, grid.distance.data());
  const std::vector<float> f(grid.distance.begin(), grid.distance.end());
  return npy_bytes(GridValueType::kFloat32, shape, f.data());
}

std::vector<std::string> write_grid_distance(const DistanceGrid& grid, const std::string& path,
                                             bool float64) {
  kind_of(path);  // a bad name fails before any conversion
  const std::string comment = std::string("gvd grid distance, metric ") +
                              grid_metric_name(grid.metric) + ", negative inside closed objects";
  if (float64)
    return write_values(grid.spec, GridValueType::kFloat64, grid.distance.data(), path, comment,
                        grid.units);
  std::vector<float> f(grid.distance.size());
  for (size_t i = 0; i < f.size(); ++i) f[i] = static_cast<float>(grid.distance[i]);
  return write_values(grid.spec, GridValueType::kFloat32, f.data(), path, comment, grid.units);
}

std::vector<std::string> write_grid_labels(const DistanceGrid& grid, const std::string& path) {
  return write_values(grid.spec, GridValueType::kInt32, grid.label.data(), path,
                      "gvd grid labels: index of the nearest object, -1 = none", grid.units);
}

}  // namespace gvd::io
