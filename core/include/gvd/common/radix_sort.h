#pragma once

// Stable sorts of large arrays: bucket_scatter (a counting sort by bucket index that returns each
// bucket's start), bucket_scatter_made (the same over items made on demand, with no second array
// of them) and radix_sort (by a 64-bit key, O(n), 11 bits a pass). With `threads` > 1 the parts
// are counted and scattered in parallel, and the order is the same whatever the threads.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "gvd/common/parallel.h"

namespace gvd {

/// bucket_scatter of the items item_at(0 .. n-1), made where they are needed (twice: to count,
/// then to scatter) instead of read from an array: no second array of them is ever held.
template <class T, class ItemAt, class BucketOf>
std::vector<size_t> bucket_scatter_made(size_t n, ItemAt&& item_at, std::vector<T>& out,
                                        size_t buckets, BucketOf&& bucket_of, int threads,
                                        bool skip_if_one_bucket = false) {
  const size_t parts = n < (size_t{1} << 16) ? 1 : static_cast<size_t>(std::max(threads, 1));
  const size_t part_size = (n + parts - 1) / parts;
  std::vector<size_t> count(parts * buckets, 0);  // [part][bucket]
  parallel_for(
      parts, static_cast<int>(parts),
      [&](size_t pb, size_t pe, int) {
        for (size_t part = pb; part < pe; ++part) {
          size_t* c = &count[part * buckets];
          for (size_t i = part * part_size; i < std::min(n, (part + 1) * part_size); ++i)
            ++c[bucket_of(item_at(i))];
        }
      },
      1);
  std::vector<size_t> start(buckets + 1, 0);
  size_t sum = 0;
  for (size_t bucket = 0; bucket < buckets; ++bucket) {
    start[bucket] = sum;
    for (size_t part = 0; part < parts; ++part) {
      const size_t in_part = count[part * buckets + bucket];
      count[part * buckets + bucket] = sum;
      sum += in_part;
    }
    if (skip_if_one_bucket && sum == n && start[bucket] == 0) return {};
  }
  start[buckets] = sum;
  out.resize(n);
  parallel_for(
      parts, static_cast<int>(parts),
      [&](size_t pb, size_t pe, int) {
        for (size_t part = pb; part < pe; ++part) {
          size_t* next = &count[part * buckets];
          for (size_t i = part * part_size; i < std::min(n, (part + 1) * part_size); ++i) {
            const T& item = item_at(i);
            out[next[bucket_of(item)]++] = item;
          }
        }
      },
      1);
  return start;
}

/// Stable counting sort of `items` into `out` (resized) by `bucket_of(item)` in [0, buckets).
/// With `threads` > 1 contiguous parts are counted and scattered in parallel (one histogram
/// per part, so the order is the same whatever the threads). Returns the start of every
/// bucket in `out` (buckets + 1 entries); with `skip_if_one_bucket`, returns an empty vector
/// and leaves `out` alone when every item falls in one bucket.
template <class T, class BucketOf>
std::vector<size_t> bucket_scatter(const std::vector<T>& items, std::vector<T>& out, size_t buckets,
                                   BucketOf&& bucket_of, int threads,
                                   bool skip_if_one_bucket = false) {
  return bucket_scatter_made(
      items.size(), [&](size_t i) -> const T& { return items[i]; }, out, buckets, bucket_of,
      threads, skip_if_one_bucket);
}

/// Stable LSD radix sort of `items` by a 64-bit key (11 bits per pass): O(n), for the large
/// arrays of lattice keys and point hashes where comparison sorts dominate. Passes whose
/// digit is the same for every item are skipped (lattice keys rarely use all 64 bits). With
/// `threads` > 1 each pass counts and scatters in parallel (bucket_scatter).
template <class T, class KeyOf>
void radix_sort(std::vector<T>& items, KeyOf key_of, int threads = 1) {
  constexpr int kBits = 11;
  constexpr size_t kBuckets = size_t{1} << kBits;
  if (items.size() < 2) return;
  std::vector<T> tmp;
  for (int shift = 0; shift < 64; shift += kBits) {
    auto digit = [&](const T& x) {
      return static_cast<size_t>((key_of(x) >> shift) & (kBuckets - 1));
    };
    if (bucket_scatter(items, tmp, kBuckets, digit, threads, true).empty()) continue;
    items.swap(tmp);
  }
}

}  // namespace gvd
