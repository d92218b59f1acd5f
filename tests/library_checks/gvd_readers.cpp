// gvd's scene loader on the files tests/library_checks/openmesh_io.cpp reads: objects,
// vertices, faces, time and the first vertex to 17 digits, or the error. Not part of the
// build; against the build tree:
//   g++ -O2 -std=c++20 -Icore/include tests/library_checks/gvd_readers.cpp -o /tmp/gvd_readers \
//     build/core/libgvd_core.a build/kernels/libgvd_kernels.a build/core/libgvd_core.a \
//     -ltinygltf -lOpenCL -lpthread
#include <chrono>
#include <cstdio>

#include "gvd/scene/load_scene.h"
int main(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    auto t0 = std::chrono::steady_clock::now();
    try {
      std::vector<std::string> p{argv[i]};
      gvd::scene::Scene s = gvd::scene::load_scene(p);
      double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      size_t v = 0, f = 0;
      for (auto& o : s.objects) {
        v += o.vertices.size();
        f += o.simplices.size();
      }
      std::printf("%s: ok objects=%zu vertices=%zu faces=%zu %.3fs v0=(%.17g, %.17g, %.17g)\n",
                  argv[i], s.objects.size(), v, f, t, s.objects[0].vertices[0].x,
                  s.objects[0].vertices[0].y, s.objects[0].vertices[0].z);
    } catch (const std::exception& e) {
      std::printf("%s: error: %s\n", argv[i], e.what());
    }
  }
}
