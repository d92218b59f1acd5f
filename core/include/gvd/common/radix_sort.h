#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "gvd/common/parallel.h"

namespace gvd {

/// Stable LSD radix sort of `items` by a 64-bit key (11 bits per pass): O(n), for the large
/// arrays of lattice keys and point hashes where comparison sorts dominate. Passes whose
/// digit is the same for every item are skipped (lattice keys rarely use all 64 bits). With
/// `threads` > 1 each pass counts and scatters contiguous parts in parallel (per-part
/// histograms, so the result is the same stable order).
template <class T, class KeyOf>
void radix_sort(std::vector<T>& items, KeyOf key_of, int threads = 1) {
  constexpr int kBits = 11;
  constexpr size_t kBuckets = size_t{1} << kBits;
  const size_t n = items.size();
  if (n < 2) return;
  const size_t parts = n < (size_t{1} << 16) ? 1 : static_cast<size_t>(std::max(threads, 1));
  const size_t part_size = (n + parts - 1) / parts;
  std::vector<T> tmp(n);
  std::vector<size_t> count(parts * kBuckets);  // [part][bucket]
  for (int shift = 0; shift < 64; shift += kBits) {
    std::fill(count.begin(), count.end(), 0);
    auto digit = [&](const T& x) {
      return static_cast<size_t>((key_of(x) >> shift) & (kBuckets - 1));
    };
    parallel_for(
        parts, static_cast<int>(parts),
        [&](size_t pb, size_t pe, int) {
          for (size_t part = pb; part < pe; ++part) {
            size_t* c = &count[part * kBuckets];
            for (size_t i = part * part_size; i < std::min(n, (part + 1) * part_size); ++i)
              ++c[digit(items[i])];
          }
        },
        1);
    // Skip a pass that would not move anything: one bucket holds every item.
    bool trivial = false;
    for (size_t bucket = 0; bucket < kBuckets && !trivial; ++bucket) {
      size_t total = 0;
      for (size_t part = 0; part < parts; ++part) total += count[part * kBuckets + bucket];
      if (total == n) trivial = true;
      if (total != 0) break;
    }
    if (trivial) continue;
    size_t sum = 0;
    for (size_t bucket = 0; bucket < kBuckets; ++bucket) {
      for (size_t part = 0; part < parts; ++part) {
        const size_t in_part = count[part * kBuckets + bucket];
        count[part * kBuckets + bucket] = sum;
        sum += in_part;
      }
    }
    parallel_for(
        parts, static_cast<int>(parts),
        [&](size_t pb, size_t pe, int) {
          for (size_t part = pb; part < pe; ++part) {
            size_t* next = &count[part * kBuckets];
            for (size_t i = part * part_size; i < std::min(n, (part + 1) * part_size); ++i)
              tmp[next[digit(items[i])]++] = items[i];
          }
        },
        1);
    items.swap(tmp);
  }
}

}  // namespace gvd
