#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace gvd {

/// Stable LSD radix sort of `items` by a 64-bit key (16 bits per pass, 4 passes): O(n), for
/// the large arrays of lattice keys and point hashes where comparison sorts dominate.
template <class T, class KeyOf>
void radix_sort(std::vector<T>& items, KeyOf key_of) {
  std::vector<T> tmp(items.size());
  std::vector<size_t> count(size_t{1} << 16);
  for (int shift = 0; shift < 64; shift += 16) {
    std::fill(count.begin(), count.end(), 0);
    for (const T& x : items) ++count[(key_of(x) >> shift) & 0xffff];
    size_t sum = 0;
    for (size_t& c : count) {
      const size_t n = c;
      c = sum;
      sum += n;
    }
    for (const T& x : items) tmp[count[(key_of(x) >> shift) & 0xffff]++] = x;
    items.swap(tmp);
  }
}

}  // namespace gvd
