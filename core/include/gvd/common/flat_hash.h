#pragma once

// FlatMap64, the open-addressing hash map from 64-bit keys to 32-bit values behind the octree's
// O(1) cell and vertex lookups: one flat array of 12-byte slots, at most half full unless told
// otherwise, key ~0 reserved. Cheap to build and to share read-only across threads; its parallel
// build from distinct keys gives the same layout whatever the number of threads.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "gvd/common/default_init.h"
#include "gvd/common/radix_sort.h"

namespace gvd {

/// Open-addressing hash map from 64-bit keys to 32-bit values (linear probing; load at most
/// 1/2, or a higher bound given for a big map whose misses are mostly answered elsewhere,
/// such as the octree vertices' map behind its filter). The key ~0 is reserved. Used for O(1)
/// octree cell and vertex lookups; one flat array, so it is cheap to build and to share read-only
/// across threads. A key and its value share a slot (one cache line per hit, not two).
class FlatMap64 {
 public:
  static constexpr uint64_t kEmptyKey = ~0ull;
  static constexpr uint32_t kMissing = ~0u;

  /// The default bound on the load, in percent.
  static constexpr uint32_t kDefaultMaxLoad = 50;

  FlatMap64() { rehash(16); }
  explicit FlatMap64(size_t expected) { rehash(capacity_for(expected)); }
  /// An empty map for `expected` keys, at most `max_load` percent full (50 ... 90), whose
  /// (big) table is cleared on `threads` threads.
  FlatMap64(size_t expected, int threads, uint32_t max_load = kDefaultMaxLoad)
      : max_load_(max_load) {
    const size_t capacity = capacity_for(expected);
    slots_.resize(capacity);  // left uninitialised (DefaultInitAllocator), cleared below
    parallel_for(
        capacity, threads,
        [&](size_t b, size_t e, int) {
          std::fill(slots_.begin() + static_cast<std::ptrdiff_t>(b),
                    slots_.begin() + static_cast<std::ptrdiff_t>(e), Slot{kEmptyKey, 0});
        },
        size_t{1} << 16);
  }

  /// The map keys[i] -> i of distinct keys, built on `threads` threads: the table is cut into
  /// ranges of slots, each range filled by one thread with the keys whose search starts there
  /// (in index order), and the few whose probe runs past their range's end are inserted
  /// afterwards. The layout is the same whatever the threads.
  /// `room`: keys that may be inserted later without a rehash.
  static FlatMap64 of_distinct_keys(std::span<const uint64_t> keys, int threads,
                                    uint32_t max_load = kDefaultMaxLoad, size_t room = 0) {
    FlatMap64 map(keys.size() + room, threads, max_load);
    const size_t capacity = map.slots_.size();
    size_t ranges = 1;
    while (ranges < 64 && ranges * 4096 < capacity) ranges *= 2;
    const size_t range_size = capacity / ranges;
    // The key indices by range, made as they are scattered (no array of all indices first:
    // this runs in the refinement, near its peak).
    std::vector<uint32_t> by_range;
    const std::vector<size_t> start = bucket_scatter_made(
        keys.size(), [](size_t i) { return static_cast<uint32_t>(i); }, by_range, ranges,
        [&](uint32_t i) { return std::min(map.slot(keys[i]) / range_size, ranges - 1); }, threads);
    std::vector<std::vector<uint32_t>> overflow(ranges);
    parallel_for(
        ranges, threads,
        [&](size_t rb, size_t re, int) {
          for (size_t r = rb; r < re; ++r) {
            const size_t end = r + 1 == ranges ? capacity : (r + 1) * range_size;
            for (size_t k = start[r]; k < start[r + 1]; ++k) {
              const uint32_t i = by_range[k];
              size_t j = map.slot(keys[i]);
              while (j < end && map.slots_[j].key != kEmptyKey) ++j;
              if (j == end) {
                overflow[r].push_back(i);
              } else {
                map.slots_[j] = {keys[i], i};
              }
            }
          }
        },
        1);
    map.size_ = keys.size();
    for (const auto& list : overflow) {
      for (const uint32_t i : list) {
        size_t j = map.slot(keys[i]);
        while (map.slots_[j].key != kEmptyKey) j = map.next(j);
        map.slots_[j] = {keys[i], i};
      }
    }
    return map;
  }

  /// Whether `n` more keys fit without a rehash.
  bool has_room(size_t n) const { return (size_ + n) * 100 <= slots_.size() * max_load_; }
  /// Makes room for `n` keys in all (one rehash, if the table is too small for them).
  void reserve(size_t n) {
    if (capacity_for(n) > slots_.size()) rehash(capacity_for(n));
  }
  /// Inserts key -> value unless present; returns the stored value (existing or new).
  uint32_t insert(uint64_t key, uint32_t value) {
    if (full()) rehash(capacity_for(2 * size_));
    size_t i = slot(key);
    while (slots_[i].key != kEmptyKey) {
      if (slots_[i].key == key) return slots_[i].value;
      i = next(i);
    }
    slots_[i] = {key, value};
    ++size_;
    return value;
  }
  /// Sets key -> value (inserting or overwriting).
  void set(uint64_t key, uint32_t value) {
    if (full()) rehash(capacity_for(2 * size_));
    size_t i = slot(key);
    while (slots_[i].key != kEmptyKey) {
      if (slots_[i].key == key) {
        slots_[i].value = value;
        return;
      }
      i = next(i);
    }
    slots_[i] = {key, value};
    ++size_;
  }
  /// The value for key, or kMissing.
  uint32_t find(uint64_t key) const {
    size_t i = slot(key);
    while (slots_[i].key != kEmptyKey) {
      if (slots_[i].key == key) return slots_[i].value;
      i = next(i);
    }
    return kMissing;
  }
  bool contains(uint64_t key) const { return find(key) != kMissing; }
  /// Starts loading the slot where a search for key begins (a hint; no effect on results).
  /// Issuing the prefetches of several keys before finding them overlaps their cache misses.
  void prefetch(uint64_t key) const { __builtin_prefetch(&slots_[slot(key)]); }
  size_t size() const { return size_; }
  size_t memory_bytes() const { return slots_.size() * sizeof(Slot); }

  /// Replaces every stored value v by f(v), in one parallel sweep over the table.
  template <class F>
  void transform_values(F&& f, int threads) {
    parallel_for(
        slots_.size(), threads,
        [&](size_t b, size_t e, int) {
          for (size_t i = b; i < e; ++i)
            if (slots_[i].key != kEmptyKey) slots_[i].value = f(slots_[i].value);
        },
        size_t{1} << 14);
  }
  /// Calls f(key, value) for every entry (unordered).
  template <class F>
  void for_each(F&& f) const {
    for (const Slot& s : slots_)
      if (s.key != kEmptyKey) f(s.key, s.value);
  }

 private:
  size_t capacity_for(size_t n) const {
    return std::max<size_t>(16, (n + 1) * 100 / max_load_ + 1);
  }
  bool full() const { return (size_ + 1) * 100 > slots_.size() * max_load_; }
  size_t next(size_t i) const { return i + 1 == slots_.size() ? 0 : i + 1; }
  size_t slot(uint64_t key) const {
    // A murmur-style mix (octree keys are highly structured), then scaled to the table by a
    // multiply-shift (any table size, no power of two).
    uint64_t h = key;
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdull;
    h ^= h >> 33;
    h *= 0xc4ceb9fe1a85ec53ull;
    h ^= h >> 33;
    __extension__ using Wide = unsigned __int128;
    return static_cast<size_t>((static_cast<Wide>(h) * slots_.size()) >> 64);
  }
  // 12 bytes, not 16: the tables are the largest index of the refinement (the vertex map
  // ~40 B per vertex at 16). A key may straddle a cache line (x86 loads it unaligned).
  struct __attribute__((packed, aligned(4))) Slot {
    uint64_t key;
    uint32_t value;
  };
  static_assert(sizeof(Slot) == 12);
  void rehash(size_t capacity) {
    UninitVector<Slot> old = std::move(slots_);
    slots_.assign(capacity, Slot{kEmptyKey, 0});
    size_ = 0;
    for (const Slot& s : old) {
      if (s.key == kEmptyKey) continue;
      size_t j = slot(s.key);
      while (slots_[j].key != kEmptyKey) j = next(j);
      slots_[j] = s;
      ++size_;
    }
  }

  UninitVector<Slot> slots_;
  size_t size_ = 0;
  uint32_t max_load_ = kDefaultMaxLoad;  ///< percent
};

}  // namespace gvd
