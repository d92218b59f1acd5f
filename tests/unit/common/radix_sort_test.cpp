#include "gvd/common/radix_sort.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

namespace gvd {
namespace {

// Against std::stable_sort, with keys that exercise skipped passes (all high bits equal), on
// one thread and two (parallel counting must give the same stable order).
TEST(RadixSort, MatchesAStableSortOnOneAndTwoThreads) {
  std::mt19937_64 rng(3);
  for (const uint64_t mask : {~0ull, 0xffffull, 0x3ull}) {
    std::vector<std::pair<uint64_t, uint32_t>> items(200000);
    for (uint32_t i = 0; i < items.size(); ++i) items[i] = {rng() & mask, i};
    auto expected = items;
    std::stable_sort(expected.begin(), expected.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    for (int threads : {1, 2}) {
      auto got = items;
      radix_sort(
          got, [](const auto& x) { return x.first; }, threads);
      EXPECT_EQ(got, expected) << "mask " << mask << ", threads " << threads;
    }
  }
}

TEST(BucketScatter, GroupsByBucketStablyAndReportsStarts) {
  std::vector<uint32_t> items(100000);
  std::mt19937 rng(8);
  for (uint32_t& x : items) x = rng() % 1000;
  for (int threads : {1, 2}) {
    std::vector<uint32_t> out;
    const std::vector<size_t> start = bucket_scatter(
        items, out, 10, [](uint32_t x) { return size_t{x / 100}; }, threads);
    ASSERT_EQ(start.size(), 11u);
    EXPECT_EQ(start.back(), items.size());
    for (size_t b = 0; b < 10; ++b) {
      std::vector<uint32_t> want;
      for (uint32_t x : items)
        if (x / 100 == b) want.push_back(x);
      EXPECT_EQ(std::vector<uint32_t>(out.begin() + static_cast<std::ptrdiff_t>(start[b]),
                                      out.begin() + static_cast<std::ptrdiff_t>(start[b + 1])),
                want)
          << "bucket " << b;
    }
    // All in one bucket: skipped on request, `out` untouched.
    std::vector<uint32_t> untouched{7};
    EXPECT_TRUE(bucket_scatter(
                    items, untouched, 10, [](uint32_t) { return size_t{3}; }, threads, true)
                    .empty());
    EXPECT_EQ(untouched, std::vector<uint32_t>{7});
  }
}

}  // namespace
}  // namespace gvd
