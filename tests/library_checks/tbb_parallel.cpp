// gvd's radix_sort and parallel_for beside TBB's parallel_sort and parallel_for, on two
// threads: sorting 48-bit keys with a payload (as octree and hash keys are), and the cost of
// starting many short loops (a compute runs a few hundred). Not part of the build: a
// measurement behind docs/ARCHITECTURE.md, "What we write by hand that a maintained library
// does". Needs Debian's libtbb-dev:
//   g++ -O2 -std=c++20 -Icore/include tests/library_checks/tbb_parallel.cpp -o /tmp/tbb_parallel
//   -ltbb -lpthread
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <random>

#include "gvd/common/parallel.h"
#include "gvd/common/radix_sort.h"
struct Item {
  uint64_t key;
  uint32_t payload;
};
static double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
int main() {
  tbb::global_control gc(tbb::global_control::max_allowed_parallelism, 2);
  for (size_t n : {size_t(1) << 16, size_t(1) << 20, size_t(8) << 20}) {
    std::mt19937_64 rng(1);
    std::vector<Item> base(n);
    // Morton-like keys: 3 x 16-bit coordinates interleaved (48 bits used), as octree keys.
    for (size_t i = 0; i < n; ++i) base[i] = {rng() & ((uint64_t(1) << 48) - 1), uint32_t(i)};
    double best[3] = {1e9, 1e9, 1e9};
    for (int rep = 0; rep < 5; ++rep) {
      auto a = base;
      double t = now();
      gvd::radix_sort(
          a, [](const Item& x) { return x.key; }, 2);
      best[0] = std::min(best[0], now() - t);
      auto b = base;
      t = now();
      tbb::parallel_sort(b.begin(), b.end(),
                         [](const Item& x, const Item& y) { return x.key < y.key; });
      best[1] = std::min(best[1], now() - t);
      auto c = base;
      t = now();
      std::sort(c.begin(), c.end(), [](const Item& x, const Item& y) { return x.key < y.key; });
      best[2] = std::min(best[2], now() - t);
      for (size_t i = 0; i < n; ++i)
        if (a[i].key != b[i].key) {
          std::printf("MISMATCH\n");
          return 1;
        }
    }
    std::printf(
        "sort n=%zu: gvd radix_sort(2 threads) %.4f s, tbb::parallel_sort %.4f s, std::sort %.4f "
        "s\n",
        n, best[0], best[1], best[2]);
  }
  // Loop overhead: many short loops, as the pipeline runs hundreds per compute.
  std::vector<double> v(4096, 1.0);
  for (size_t n : {size_t(4096), size_t(1) << 20}) {
    std::vector<double> w(n, 1.0);
    const int loops = n == 4096 ? 20000 : 200;
    double t = now();
    for (int l = 0; l < loops; ++l)
      gvd::parallel_for(
          n, 2,
          [&](size_t b, size_t e, int) {
            for (size_t i = b; i < e; ++i) w[i] = w[i] * 1.0000001 + 1e-9;
          },
          256);
    const double ours = (now() - t) / loops;
    t = now();
    for (int l = 0; l < loops; ++l)
      tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 256),
                        [&](const tbb::blocked_range<size_t>& r) {
                          for (size_t i = r.begin(); i < r.end(); ++i)
                            w[i] = w[i] * 1.0000001 + 1e-9;
                        });
    const double theirs = (now() - t) / loops;
    std::printf("parallel_for n=%zu (grain 256): gvd %.2f us per loop, tbb %.2f us per loop\n", n,
                ours * 1e6, theirs * 1e6);
  }
}
