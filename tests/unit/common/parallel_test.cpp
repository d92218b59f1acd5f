#include "gvd/common/parallel.h"

#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <thread>
#include <vector>

namespace gvd {
namespace {

// Every index visited exactly once, by chunks of the given grain.
void expect_covers(size_t n, int threads, size_t grain) {
  std::vector<std::atomic<int>> seen(n);
  parallel_for(
      n, threads,
      [&](size_t b, size_t e, int t) {
        EXPECT_GE(t, 0);
        EXPECT_LT(t, std::max(threads, 1));
        for (size_t i = b; i < e; ++i) seen[i].fetch_add(1);
      },
      grain);
  for (size_t i = 0; i < n; ++i) ASSERT_EQ(seen[i].load(), 1) << "index " << i;
}

TEST(ParallelFor, CoversEveryIndexOnceOverManyCalls) {
  for (int round = 0; round < 200; ++round) {
    expect_covers(1000 + round, 2, 7);
    expect_covers(50, 4, 1);
    expect_covers(0, 2, 16);
    expect_covers(10, 1, 1);
  }
}

TEST(ParallelFor, NestedAndConcurrentLoopsFinish) {
  // A loop inside a loop (the kept workers are busy: the inner one starts its own threads),
  // and loops started from two threads at once.
  std::atomic<long> sum{0};
  auto nested = [&] {
    parallel_for(
        64, 2,
        [&](size_t b, size_t e, int) {
          for (size_t i = b; i < e; ++i) {
            parallel_for(
                100, 2, [&](size_t ib, size_t ie, int) { sum += static_cast<long>(ie - ib); }, 10);
          }
        },
        4);
  };
  std::thread other(nested);
  nested();
  other.join();
  EXPECT_EQ(sum.load(), 2 * 64 * 100);
}

TEST(ParallelFor, RethrowsTheFirstErrorAndStaysUsable) {
  EXPECT_THROW(parallel_for(
                   1000, 2,
                   [](size_t b, size_t, int) {
                     if (b >= 500) throw std::runtime_error("boom");
                   },
                   10),
               std::runtime_error);
  expect_covers(5000, 2, 13);  // the kept workers are free again
}

}  // namespace
}  // namespace gvd
