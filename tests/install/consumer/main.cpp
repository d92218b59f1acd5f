// gvd in-process, through the stable API gvd/gvd.h (docs/CPP.md). Two unit cubes 0.1 apart,
// built from arrays: their GVD is the mirror plane between them, which makes every answer
// below known in advance. With a scene file, the program computes it and writes its dual
// graph instead: gvd_example SCENE GRAPH.json [cpu|opencl|auto].

#include <gvd/gvd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace {

int failures = 0;

void expect(bool ok, const std::string& what) {
  std::printf("%s %s\n", ok ? "ok  " : "FAIL", what.c_str());
  if (!ok) ++failures;
}

// An axis-aligned box as a closed triangle mesh (outward normals).
void add_box(gvd::api::Scene& scene, const std::string& label, double x0, double y0, double z0,
             double x1, double y1, double z1) {
  const std::vector<double> vertices = {x0, y0, z0, x1, y0, z0, x1, y1, z0, x0, y1, z0,
                                        x0, y0, z1, x1, y0, z1, x1, y1, z1, x0, y1, z1};
  const std::vector<uint32_t> triangles = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                                           1, 2, 6, 1, 6, 5, 2, 3, 7, 2, 7, 6, 3, 0, 4, 3, 4, 7};
  scene.add(label, vertices, triangles);
}

int two_cubes() {
  const double gap = 0.1;
  const double mid = 1 + gap / 2;  // the plane x = mid is the GVD
  gvd::api::Scene scene(3);
  add_box(scene, "left", 0, 0, 0, 1, 1, 1);
  add_box(scene, "right", 1 + gap, 0, 0, 2 + gap, 1, 1);

  gvd::api::ComputeOptions options;  // the defaults of `gvd compute`
  std::string last_stage;
  options.progress = [&](std::string_view stage, double) { last_stage = stage; };
  const gvd::api::Result result = gvd::api::compute(scene, options);
  expect(last_stage == "done", "progress reported up to \"done\"");

  // The dual graph: one edge, the gap measured exactly, the clearance half of it, and the
  // interface the whole cross-section of the domain (the bounding box made a cube of side
  // 2.1, padded by 5 % on every side: 2.31 x 2.31).
  const std::vector<gvd::api::Edge> graph = result.graph();
  expect(graph.size() == 1 && graph[0].a == 0 && graph[0].b == 1, "one dual-graph edge");
  const gvd::api::Edge& edge = graph.at(0);
  expect(std::abs(edge.gap - gap) < 1e-12, "gap " + std::to_string(edge.gap));
  expect(std::abs(edge.min_clearance - gap / 2) < 1e-12,
         "min_clearance " + std::to_string(edge.min_clearance));
  expect(std::abs(edge.area - 2.31 * 2.31) < 1e-6, "interface area " + std::to_string(edge.area));

  const std::vector<gvd::api::Neighbor> ring = result.neighbors("left", 2);
  expect(ring.size() == 1 && result.label(ring[0].object) == "right", "neighbours of left");

  // Nearest objects of a batch of points (x, y, z each); the last is outside the domain.
  const std::vector<double> points = {mid - 0.02, 0.5, 0.5, mid + 0.03, 0.5, 0.5,
                                      0.5,        0.5, 1.4, 50,         0,   0};
  const gvd::api::NearestBatch nearest = result.nearest(points);
  // Exact: the nearest object and the distance to it (`fast` = true: never below the true
  // one, and within 3/2 of it where the octree proves it).
  auto near = [&](size_t i, gvd::api::Object object, double distance) {
    return nearest.object[i] == object && std::abs(nearest.distance[i] - distance) <= 1e-12;
  };
  expect(near(0, 0, mid - 0.02 - 1), "nearest to the left of the plane");
  expect(near(1, 1, 1 + gap - (mid + 0.03)), "nearest to the right of the plane");
  expect(near(2, 0, 0.4) && std::abs(nearest.closest[8] - 1) < 1e-9, "nearest above the left cube");
  expect(nearest.object[3] == gvd::api::kNone && std::isnan(nearest.distance[3]),
         "a point outside the domain has no nearest object");
  // The cubes are closed: a point says whether it is inside, with the distance signed.
  const std::vector<double> within = {0.5, 0.5, 0.6};
  const gvd::api::NearestBatch in = result.nearest(within);
  expect(nearest.inside[0] == 0 && nearest.signed_distance[0] == nearest.distance[0],
         "outside the left cube: positive");
  expect(in.object[0] == 0 && in.inside[0] == 1 && in.signed_distance[0] == -in.distance[0] &&
             in.distance[0] >= 0.4 - 1e-12 && in.distance[0] <= 1.5 * 0.4,
         "inside the left cube: negative, 0.4 from its top face");

  // A path from above one cube to above the other, and one from inside a cube (none).
  const std::vector<double> from = {0.5, 0.5, 1.3}, to = {1.6, 0.5, 1.3};
  const gvd::api::Path path = result.path(from, to);
  expect(
      path.found && path.points.size() >= 6 && path.min_clearance > 0 && path.length >= 1.1 - 1e-12,
      "path of length " + std::to_string(path.length));
  const std::vector<double> inside = {0.5, 0.5, 0.5};
  expect(!result.path(inside, to).found, "no path from inside a cube");

  // The cell of "left" as arrays: closed by the domain box, its boundary towards "right" on
  // the plane x = mid (to 1e-6: the surfaced GVD is as exact as its octree cells).
  const gvd::api::Cell cell = result.cell("left");
  double max_x = -1e300, off_plane = 0;
  int facing_right = 0;
  for (size_t v = 0; v < cell.other.size(); ++v) {
    max_x = std::max(max_x, cell.vertices[3 * v]);
    if (cell.other[v] != 1) continue;
    ++facing_right;
    off_plane = std::max(off_plane, std::abs(cell.vertices[3 * v] - mid));
  }
  expect(
      facing_right > 0 && off_plane < 1e-6 && max_x < mid + 1e-6 && cell.simplices.size() % 3 == 0,
      "cell of left: " + std::to_string(cell.simplices.size() / 3) + " triangles, " +
          std::to_string(facing_right) + " vertices on the plane (off by " +
          std::to_string(off_plane) + ")");

  // Files: the whole result (reloadable), the GVD as glTF.
  result.save("two_cubes.gvd");
  result.write_glb("two_cubes.glb");
  const gvd::api::Result loaded = gvd::api::load("two_cubes.gvd");
  expect(loaded.graph().size() == 1 && loaded.graph()[0].gap == edge.gap, "saved and loaded");

  // Errors are gvd::Error with a code and a detail saying where.
  try {
    result.neighbors("middle");
    expect(false, "an unknown label throws");
  } catch (const gvd::Error& e) {
    expect(e.code() == gvd::ErrorCode::kNotFound, std::string("unknown label: ") + e.what());
  }
  std::atomic<bool> cancel{true};
  options.cancel = &cancel;
  try {
    gvd::api::compute(scene, options);
    expect(false, "a cancelled computation throws");
  } catch (const gvd::Error& e) {
    expect(e.code() == gvd::ErrorCode::kCancelled, std::string("cancelled: ") + e.what());
  }
  return failures == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  std::printf("gvd %s\n", std::string(gvd::api::version()).c_str());
  try {
    if (argc < 3) return two_cubes();
    gvd::api::ComputeOptions options;
    if (argc > 3) options.backend = argv[3];
    const gvd::api::Result result = gvd::api::compute(gvd::api::Scene::load(argv[1]), options);
    result.write_graph_json(argv[2]);
    std::printf("%d objects, %zu dual-graph edges -> %s\n", result.size(), result.graph().size(),
                argv[2]);
    return 0;
  } catch (const gvd::Error& e) {
    std::fprintf(stderr, "gvd_example: %s\n", e.what());
    return 1;
  }
}
