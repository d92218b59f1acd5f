// The C++ side of the Python nearest benchmark (tests/bench/python_nearest_bench.py, run by
// `make bench`): batch nearest through the facade gvd/gvd.h on the same saved result and the
// same points as the Python module, timed the same way (the call alone, the index built by a
// warm-up call first). Prints one JSON line: best seconds of `repeats` calls, the point count
// and checksums of the answers (so the script can tell both answered the same).
//   gvd_bench_api_nearest RESULT.gvd POINTS.f64 REPEATS THREADS
// POINTS.f64: raw native float64, dimension() numbers per point.

#include <gvd/gvd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  if (argc != 5) {
    std::fprintf(stderr, "usage: %s RESULT.gvd POINTS.f64 REPEATS THREADS\n", argv[0]);
    return 2;
  }
  try {
    const gvd::api::Result result = gvd::api::load(argv[1]);
    std::ifstream in(argv[2], std::ios::binary | std::ios::ate);
    if (!in) throw gvd::Error(gvd::ErrorCode::kIo, std::string("cannot read ") + argv[2]);
    std::vector<double> points(static_cast<size_t>(in.tellg()) / sizeof(double));
    in.seekg(0);
    in.read(reinterpret_cast<char*>(points.data()),
            static_cast<std::streamsize>(points.size() * sizeof(double)));
    const int repeats = std::max(1, std::stoi(argv[3]));
    const int threads = std::stoi(argv[4]);

    gvd::api::NearestBatch batch = result.nearest(std::span<const double>(points.data(), 3000),
                                                  false, threads);  // builds the index
    double best = 1e300;
    for (int r = 0; r < repeats; ++r) {
      const auto t0 = std::chrono::steady_clock::now();
      batch = result.nearest(points, false, threads);
      const auto t1 = std::chrono::steady_clock::now();
      best = std::min(best, std::chrono::duration<double>(t1 - t0).count());
    }
    long long objects = 0;
    double distances = 0;
    for (size_t i = 0; i < batch.object.size(); ++i) {
      objects += batch.object[i];
      if (std::isfinite(batch.distance[i])) distances += batch.distance[i];
    }
    std::printf(
        "{\"best_s\": %.6f, \"points\": %zu, \"object_sum\": %lld, \"distance_sum\": %.17g}\n",
        best, batch.object.size(), objects, distances);
    return 0;
  } catch (const gvd::Error& e) {
    std::fprintf(stderr, "gvd_bench_api_nearest: %s\n", e.what());
    return 1;
  }
}
