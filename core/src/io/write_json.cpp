// JSON outputs (GVD with float64 coordinates, dual graph) and the file helpers of io/.
#include <errno.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "gvd/common/error.h"
#include "gvd/io/write_outputs.h"

namespace gvd::io {

using namespace gvd::scene;
using namespace gvd::surface;
using namespace gvd::graph;

namespace {

using nlohmann::json;

/// A point as a JSON array of `dimension` coordinates. nlohmann prints doubles with the
/// shortest representation that reads back to the same double, so coordinates round-trip.
json point_json(Vec3 p, int dimension) {
  GVD_CHECK(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z),
            "output point must be finite");
  return dimension == 2 ? json::array({p.x, p.y}) : json::array({p.x, p.y, p.z});
}

const std::string& label_of(const Scene& scene, ObjectId object) {
  GVD_CHECK(object < scene.objects.size(), "object index out of range of the scene");
  return scene.objects[object].label;
}

std::string errno_text(int error) { return std::generic_category().message(error); }

[[noreturn]] void throw_io(const std::string& what, const std::string& path, int error) {
  throw Error(ErrorCode::kIo, what + " '" + path + "': " + errno_text(error));
}

/// Writes all of `data` to `fd`, retrying on EINTR and short writes; returns 0 or an errno.
int write_all(int fd, const unsigned char* data, size_t size) {
  while (size > 0) {
    const ssize_t written = ::write(fd, data, size);
    if (written < 0) {
      if (errno == EINTR) continue;
      return errno;
    }
    data += written;
    size -= static_cast<size_t>(written);
  }
  return 0;
}

std::string directory_of(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  if (slash == std::string::npos) return ".";
  if (slash == 0) return "/";
  return path.substr(0, slash);
}

}  // namespace

void write_gvd_json(const Gvd& gvd, const Scene& scene,
                    const std::function<void(std::string_view)>& sink) {
  GVD_CHECK(gvd.dimension == 2 || gvd.dimension == 3, "gvd dimension must be 2 or 3");
  GVD_CHECK(gvd.cells.size() <= scene.objects.size(), "gvd has more cells than scene objects");
  const size_t k = static_cast<size_t>(gvd.dimension);  // vertices per simplex
  // Written piece by piece, as nlohmann's compact dump of the whole document would print it
  // (keys in order, its number formatting), without holding that document (a large GVD's took
  // several times the result's memory): arrays go out in blocks of elements, each block
  // dumped by nlohmann without its brackets.
  std::string block;
  auto array = [&](size_t n, auto&& element) {
    sink("[");
    constexpr size_t kBlock = 4096;
    for (size_t first = 0; first < n; first += kBlock) {
      json part = json::array();
      for (size_t i = first; i < std::min(n, first + kBlock); ++i) part.push_back(element(i));
      block = part.dump();
      if (first > 0) sink(",");
      sink(std::string_view(block).substr(1, block.size() - 2));
    }
    sink("]");
  };
  sink("{\"dimension\":" + std::to_string(gvd.dimension) +
       ",\"null_feature_id\":" + std::to_string(scene.objects.size()) + ",\"objects\":[");
  bool first_object = true;
  for (size_t i = 0; i < gvd.cells.size(); ++i) {
    const GvdCell& cell = gvd.cells[i];
    if (cell.indices.empty()) continue;  // the same cells as the GLB: only non-empty ones
    const size_t n = cell.positions.size();
    GVD_CHECK(cell.object == i, "gvd cell i must belong to object i");
    GVD_CHECK(cell.other.size() == n && cell.clearance.size() == n,
              "gvd cell attributes must have one value per vertex");
    GVD_CHECK(cell.indices.size() % k == 0, "gvd cell indices must form whole simplices");
    sink(first_object ? "{\"clearance\":" : ",{\"clearance\":");
    first_object = false;
    array(n, [&](size_t v) {
      GVD_CHECK(std::isfinite(cell.clearance[v]), "gvd cell clearance must be finite");
      return json(cell.clearance[v]);
    });
    sink(",\"label\":" + json(scene.objects[i].label).dump() + ",\"object\":" + std::to_string(i) +
         ",\"other\":");
    array(n, [&](size_t v) {
      if (cell.other[v] == kNoObject) return json(-1);
      GVD_CHECK(cell.other[v] < scene.objects.size(), "gvd cell 'other' out of range");
      return json(cell.other[v]);
    });
    sink(",\"positions\":");
    array(n, [&](size_t v) { return point_json(cell.positions[v], gvd.dimension); });
    sink(",\"simplices\":");
    array(cell.indices.size() / k, [&](size_t t) {
      json simplex = json::array();
      for (size_t j = 0; j < k; ++j) {
        GVD_CHECK(cell.indices[t * k + j] < n, "gvd cell index out of range");
        simplex.push_back(cell.indices[t * k + j]);
      }
      return simplex;
    });
    sink("}");
  }
  sink("]");
  if (!scene.units.empty()) sink(",\"units\":" + json(scene.units).dump());
  sink("}");
}

void write_json_file(const std::string& path, const Gvd& gvd, const Scene& scene) {
  write_file_atomic(path, [&](const std::function<void(std::string_view)>& put) {
    write_gvd_json(gvd, scene, put);
  });
}

std::string gvd_to_json(const Gvd& gvd, const Scene& scene) {
  std::string out;
  write_gvd_json(gvd, scene, [&](std::string_view s) { out.append(s); });
  return out;
}

std::string graph_to_json(const DualGraph& graph, const Scene& scene) {
  GVD_CHECK(graph.node_count <= scene.objects.size(), "dual graph has more nodes than objects");
  json nodes = json::array();
  for (size_t i = 0; i < scene.objects.size(); ++i) {
    nodes.push_back({{"object", i}, {"label", scene.objects[i].label}});
  }
  json edges = json::array();
  for (const DualEdge& edge : graph.edges) {
    GVD_CHECK(std::isfinite(edge.area) && std::isfinite(edge.min_clearance),
              "dual edge measures must be finite");
    edges.push_back({{"a", edge.a},
                     {"b", edge.b},
                     {"label_a", label_of(scene, edge.a)},
                     {"label_b", label_of(scene, edge.b)},
                     {"area", edge.area},
                     {"min_clearance", edge.min_clearance},
                     {"tightest_point", point_json(edge.tightest_point, scene.dimension)},
                     {"gap", edge.gap >= 0 ? json(edge.gap) : json(nullptr)},
                     {"touching", edge.touching}});
  }
  json out = {{"nodes", std::move(nodes)}, {"edges", std::move(edges)}};
  if (!scene.units.empty()) out["units"] = scene.units;
  return out.dump();
}

void write_file_atomic(const std::string& path, const void* data, size_t size) {
  write_file_atomic(path, [&](const std::function<void(std::string_view)>& put) {
    put(std::string_view(static_cast<const char*>(data), size));
  });
}

void write_file_atomic(
    const std::string& path,
    const std::function<void(const std::function<void(std::string_view)>&)>& produce) {
  // A process-wide counter makes temporary names unique between threads of this process (the
  // pid separates processes); O_EXCL guards against anything left over by a crashed run.
  static std::atomic<uint64_t> counter{0};
  const std::string tmp =
      path + ".tmp." + std::to_string(::getpid()) + "." + std::to_string(counter.fetch_add(1));

  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) throw_io("cannot create a temporary file for", path, errno);
  // Small pieces are gathered into writes of about 1 MiB; large ones go out as they are.
  constexpr size_t kBuffer = size_t{1} << 20;
  std::string buffer;
  int error = 0;
  auto flush = [&] {
    if (error == 0 && !buffer.empty())
      error = write_all(fd, reinterpret_cast<const unsigned char*>(buffer.data()), buffer.size());
    buffer.clear();
  };
  try {
    produce([&](std::string_view piece) {
      if (error != 0) return;
      if (piece.size() >= kBuffer) {
        flush();
        if (error == 0)
          error = write_all(fd, reinterpret_cast<const unsigned char*>(piece.data()), piece.size());
        return;
      }
      if (buffer.size() + piece.size() > kBuffer) flush();
      if (buffer.capacity() < kBuffer) buffer.reserve(kBuffer);
      buffer.append(piece);
    });
    flush();
  } catch (...) {
    ::close(fd);
    ::unlink(tmp.c_str());
    throw;
  }
  if (error == 0 && ::fsync(fd) != 0) error = errno;
  if (::close(fd) != 0 && error == 0) error = errno;
  if (error == 0 && ::rename(tmp.c_str(), path.c_str()) != 0) error = errno;
  if (error != 0) {
    ::unlink(tmp.c_str());
    throw_io("cannot write", path, error);
  }
  // Make the rename itself durable. Best effort: some file systems refuse fsync on a directory,
  // and the file is already complete and in place.
  const int dir = ::open(directory_of(path).c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir >= 0) {
    ::fsync(dir);
    ::close(dir);
  }
}

void write_file_atomic(const std::string& path, const std::string& text) {
  write_file_atomic(path, text.data(), text.size());
}

std::vector<uint8_t> read_file_bytes(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw_io("cannot open", path, errno);
  std::vector<uint8_t> bytes;
  struct stat info {};
  if (::fstat(fd, &info) == 0 && info.st_size > 0) bytes.reserve(static_cast<size_t>(info.st_size));
  unsigned char chunk[1 << 16];
  for (;;) {
    const ssize_t got = ::read(fd, chunk, sizeof chunk);
    if (got < 0) {
      if (errno == EINTR) continue;
      const int error = errno;
      ::close(fd);
      throw_io("cannot read", path, error);
    }
    if (got == 0) break;
    bytes.insert(bytes.end(), chunk, chunk + got);
  }
  ::close(fd);
  return bytes;
}

}  // namespace gvd::io
