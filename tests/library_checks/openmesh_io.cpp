// What OpenMesh's readers hand an importer, file by file: whether the read succeeded, the
// vertices and faces received, whether coordinates came through float or double calls, and
// the first vertex to 17 digits. The importer keeps every face (OpenMesh's half-edge mesh
// would drop non-manifold ones), so this measures the readers alone. Not part of the build:
// a measurement behind docs/ARCHITECTURE.md, "What we write by hand that a maintained library
// does". Needs Debian's libopenmesh-dev (not installed by the project's scripts, as gvd does
// not use OpenMesh):
//   g++ -O2 -std=c++17 tests/library_checks/openmesh_io.cpp -o /tmp/openmesh_io -lOpenMeshCore
//   for f in tests/data/formats/*.{obj,off,ply,stl} tests/data/malformed/*.{obj,off,ply,stl}; do
//     timeout 10 /tmp/openmesh_io $f 2>/dev/null || echo "$f: no answer within 10 s"; done
// (malformed/ply_no_end_header.ply never returns: OpenMesh prints "Unsupported entry type"
// without end, 63 MB in 10 s.) gvd's side: tests/library_checks/gvd_readers.cpp.
#include <OpenMesh/Core/IO/IOManager.hh>
#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/IO/Options.hh>
#include <OpenMesh/Core/IO/importer/BaseImporter.hh>
#include <array>
#include <chrono>
#include <cstdio>
#include <vector>
using namespace OpenMesh;
struct Collect : IO::BaseImporter {
  std::vector<std::array<double, 3>> v;
  std::vector<std::vector<int>> f;
  int floats = 0, doubles = 0;
  VertexHandle add_vertex(const Vec3f& p) override {
    ++floats;
    v.push_back({p[0], p[1], p[2]});
    return VertexHandle(int(v.size()) - 1);
  }
  VertexHandle add_vertex(const Vec3d& p) override {
    ++doubles;
    v.push_back({p[0], p[1], p[2]});
    return VertexHandle(int(v.size()) - 1);
  }
  VertexHandle add_vertex() override {
    v.push_back({0, 0, 0});
    return VertexHandle(int(v.size()) - 1);
  }
  HalfedgeHandle add_edge(VertexHandle, VertexHandle) override { return HalfedgeHandle(); }
  FaceHandle add_face(const VHandles& ix) override {
    std::vector<int> x;
    for (auto h : ix) x.push_back(h.idx());
    f.push_back(x);
    return FaceHandle(int(f.size()) - 1);
  }
  FaceHandle add_face(HalfedgeHandle) override { return FaceHandle(); }
  void add_face_texcoords(FaceHandle, VertexHandle, const std::vector<Vec2f>&) override {}
  void add_face_texcoords(FaceHandle, VertexHandle, const std::vector<Vec3f>&) override {}
  void set_face_texindex(FaceHandle, int) override {}
  void set_point(VertexHandle h, const Vec3f& p) override { v[h.idx()] = {p[0], p[1], p[2]}; }
  void set_halfedge(VertexHandle, HalfedgeHandle) override {}
  void set_normal(VertexHandle, const Vec3f&) override {}
  void set_normal(VertexHandle, const Vec3d&) override {}
  void set_color(VertexHandle, const Vec3uc&) override {}
  void set_color(VertexHandle, const Vec4uc&) override {}
  void set_color(VertexHandle, const Vec3f&) override {}
  void set_color(VertexHandle, const Vec4f&) override {}
  void set_texcoord(VertexHandle, const Vec2f&) override {}
  void set_status(VertexHandle, const Attributes::StatusInfo&) override {}
  void set_next(HalfedgeHandle, HalfedgeHandle) override {}
  void set_face(HalfedgeHandle, FaceHandle) override {}
  void request_face_texcoords2D() override {}
  void set_texcoord(HalfedgeHandle, const Vec2f&) override {}
  void set_texcoord(VertexHandle, const Vec3f&) override {}
  void set_texcoord(HalfedgeHandle, const Vec3f&) override {}
  void set_status(HalfedgeHandle, const Attributes::StatusInfo&) override {}
  void set_color(EdgeHandle, const Vec3uc&) override {}
  void set_color(EdgeHandle, const Vec4uc&) override {}
  void set_color(EdgeHandle, const Vec3f&) override {}
  void set_color(EdgeHandle, const Vec4f&) override {}
  void set_status(EdgeHandle, const Attributes::StatusInfo&) override {}
  void set_normal(FaceHandle, const Vec3f&) override {}
  void set_normal(FaceHandle, const Vec3d&) override {}
  void set_color(FaceHandle, const Vec3uc&) override {}
  void set_color(FaceHandle, const Vec4uc&) override {}
  void set_color(FaceHandle, const Vec3f&) override {}
  void set_color(FaceHandle, const Vec4f&) override {}
  void set_status(FaceHandle, const Attributes::StatusInfo&) override {}
  void add_texture_information(int, std::string) override {}
  size_t n_vertices() const override { return v.size(); }
  size_t n_faces() const override { return f.size(); }
  size_t n_edges() const override { return 0; }
};
int main(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    Collect c;
    IO::Options opt;
    auto t0 = std::chrono::steady_clock::now();
    bool ok = IO::IOManager().read(argv[i], c, opt);
    double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("%s: ok=%d vertices=%zu faces=%zu float_calls=%d double_calls=%d %.3fs", argv[i],
                ok, c.v.size(), c.f.size(), c.floats, c.doubles, s);
    if (!c.v.empty()) std::printf(" v0=(%.17g, %.17g, %.17g)", c.v[0][0], c.v[0][1], c.v[0][2]);
    std::printf("\n");
  }
}
