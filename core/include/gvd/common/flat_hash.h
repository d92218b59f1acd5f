#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace gvd {

/// Open-addressing hash map from 64-bit keys to 32-bit values (linear probing, power-of-two
/// capacity, load <= 1/2). The key ~0 is reserved. Used for O(1) octree cell and vertex
/// lookups; flat arrays only, so it is cheap to build and to share read-only across threads.
class FlatMap64 {
 public:
  static constexpr uint64_t kEmptyKey = ~0ull;
  static constexpr uint32_t kMissing = ~0u;

  FlatMap64() { rehash(16); }
  explicit FlatMap64(size_t expected) { rehash(capacity_for(expected)); }

  /// Inserts key -> value unless present; returns the stored value (existing or new).
  uint32_t insert(uint64_t key, uint32_t value) {
    if (2 * (size_ + 1) > keys_.size()) rehash(keys_.size() * 2);
    size_t i = slot(key);
    while (keys_[i] != kEmptyKey) {
      if (keys_[i] == key) return values_[i];
      i = (i + 1) & mask_;
    }
    keys_[i] = key;
    values_[i] = value;
    ++size_;
    return value;
  }
  /// Sets key -> value (inserting or overwriting).
  void set(uint64_t key, uint32_t value) {
    if (2 * (size_ + 1) > keys_.size()) rehash(keys_.size() * 2);
    size_t i = slot(key);
    while (keys_[i] != kEmptyKey) {
      if (keys_[i] == key) {
        values_[i] = value;
        return;
      }
      i = (i + 1) & mask_;
    }
    keys_[i] = key;
    values_[i] = value;
    ++size_;
  }
  /// Overwrites the value of a key already present (never inserts, so several threads may
  /// call it for different keys at once); returns false when the key is missing.
  bool assign_existing(uint64_t key, uint32_t value) {
    size_t i = slot(key);
    while (keys_[i] != kEmptyKey) {
      if (keys_[i] == key) {
        values_[i] = value;
        return true;
      }
      i = (i + 1) & mask_;
    }
    return false;
  }
  /// The value for key, or kMissing.
  uint32_t find(uint64_t key) const {
    size_t i = slot(key);
    while (keys_[i] != kEmptyKey) {
      if (keys_[i] == key) return values_[i];
      i = (i + 1) & mask_;
    }
    return kMissing;
  }
  bool contains(uint64_t key) const { return find(key) != kMissing; }
  size_t size() const { return size_; }
  size_t memory_bytes() const { return keys_.size() * (sizeof(uint64_t) + sizeof(uint32_t)); }

  /// Calls f(key, value) for every entry (unordered).
  template <class F>
  void for_each(F&& f) const {
    for (size_t i = 0; i < keys_.size(); ++i)
      if (keys_[i] != kEmptyKey) f(keys_[i], values_[i]);
  }

 private:
  static size_t capacity_for(size_t n) {
    size_t c = 16;
    while (c < 2 * n + 2) c *= 2;
    return c;
  }
  size_t slot(uint64_t key) const {
    // Fibonacci hashing after a murmur-style mix: octree keys are highly structured.
    uint64_t h = key;
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdull;
    h ^= h >> 33;
    h *= 0xc4ceb9fe1a85ec53ull;
    h ^= h >> 33;
    return static_cast<size_t>(h) & mask_;
  }
  void rehash(size_t capacity) {
    std::vector<uint64_t> old_keys = std::move(keys_);
    std::vector<uint32_t> old_values = std::move(values_);
    keys_.assign(capacity, kEmptyKey);
    values_.assign(capacity, 0);
    mask_ = capacity - 1;
    size_ = 0;
    for (size_t i = 0; i < old_keys.size(); ++i) {
      if (old_keys[i] == kEmptyKey) continue;
      size_t j = slot(old_keys[i]);
      while (keys_[j] != kEmptyKey) j = (j + 1) & mask_;
      keys_[j] = old_keys[i];
      values_[j] = old_values[i];
      ++size_;
    }
  }

  std::vector<uint64_t> keys_;
  std::vector<uint32_t> values_;
  size_t mask_ = 0;
  size_t size_ = 0;
};

}  // namespace gvd
