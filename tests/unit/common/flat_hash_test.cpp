#include "gvd/common/flat_hash.h"

#include <gtest/gtest.h>

#include <random>
#include <set>
#include <vector>

namespace gvd {
namespace {

std::vector<uint64_t> distinct_keys(size_t n, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::set<uint64_t> seen;
  std::vector<uint64_t> keys;
  while (keys.size() < n) {
    // Structured keys (as lattice keys are: small, clustered) and random ones.
    const uint64_t k = keys.size() % 2 ? rng() % (n * 8) : rng() >> 1;
    if (k != FlatMap64::kEmptyKey && seen.insert(k).second) keys.push_back(k);
  }
  return keys;
}

TEST(FlatMap64, OfDistinctKeysFindsEveryKeyAndNoOther) {
  for (size_t n : {size_t{0}, size_t{1}, size_t{1000}, size_t{300000}}) {
    const std::vector<uint64_t> keys = distinct_keys(n, 3 + n);
    const FlatMap64 map = FlatMap64::of_distinct_keys(keys, 2);
    EXPECT_EQ(map.size(), n);
    for (size_t i = 0; i < n; ++i) ASSERT_EQ(map.find(keys[i]), i) << "key " << i;
    std::mt19937_64 rng(11);
    const std::set<uint64_t> present(keys.begin(), keys.end());
    for (int i = 0; i < 10000; ++i) {
      const uint64_t k = rng() % (n * 8 + 16);
      if (!present.count(k)) {
        EXPECT_EQ(map.find(k), FlatMap64::kMissing);
      }
    }
    // The map stays usable for inserts.
    FlatMap64 grown = map;
    for (uint64_t k = 0; k < 1000; ++k) {
      const uint64_t key = (uint64_t{1} << 62) + k;
      EXPECT_EQ(grown.insert(key, static_cast<uint32_t>(n + k)), n + k);
    }
    for (size_t i = 0; i < n; ++i) ASSERT_EQ(grown.find(keys[i]), i);
  }
}

TEST(FlatMap64, OfDistinctKeysIsTheSameOnOneAndTwoThreads) {
  const std::vector<uint64_t> keys = distinct_keys(200000, 7);
  const FlatMap64 one = FlatMap64::of_distinct_keys(keys, 1);
  const FlatMap64 two = FlatMap64::of_distinct_keys(keys, 2);
  std::vector<std::pair<uint64_t, uint32_t>> a, b;
  one.for_each([&](uint64_t k, uint32_t v) { a.push_back({k, v}); });
  two.for_each([&](uint64_t k, uint32_t v) { b.push_back({k, v}); });
  EXPECT_EQ(a, b);  // the same layout (for_each walks the slots in order)
}

TEST(FlatMap64, TransformValuesRenumbersEveryEntry) {
  const std::vector<uint64_t> keys = distinct_keys(50000, 13);
  FlatMap64 map = FlatMap64::of_distinct_keys(keys, 2);
  map.transform_values([](uint32_t v) { return 3 * v + 1; }, 2);
  for (size_t i = 0; i < keys.size(); ++i) ASSERT_EQ(map.find(keys[i]), 3 * i + 1);
  EXPECT_EQ(map.size(), keys.size());
}

}  // namespace
}  // namespace gvd
