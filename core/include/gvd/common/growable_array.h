#pragma once

// GrowableArray, an array of trivially copyable elements that grows with realloc: a big block
// grows by remapping its pages, so growing never holds the old and the new array at once as
// std::vector's copy does. New elements are left uninitialised; a failed allocation throws
// std::bad_alloc.

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <new>
#include <type_traits>
#include <utility>

namespace gvd {

/// An array of trivially copyable elements that grows with realloc. A big block (mapped on its
/// own: use_returning_heap, or glibc's default above 32 MiB) then grows by remapping its pages,
/// so growing never holds the old and the new array at once as std::vector's copy does. New
/// elements are left uninitialised.
template <class T>
class GrowableArray {
  static_assert(std::is_trivially_copyable_v<T>);

 public:
  GrowableArray() = default;
  GrowableArray(const GrowableArray& other) { *this = other; }
  GrowableArray(GrowableArray&& other) noexcept
      : data_(std::exchange(other.data_, nullptr)), size_(std::exchange(other.size_, 0)) {}
  GrowableArray& operator=(const GrowableArray& other) {
    if (this != &other) {
      resize(other.size_);
      if (size_ > 0) std::memcpy(data_, other.data_, size_ * sizeof(T));
    }
    return *this;
  }
  GrowableArray& operator=(GrowableArray&& other) noexcept {
    if (this != &other) {
      std::free(data_);
      data_ = std::exchange(other.data_, nullptr);
      size_ = std::exchange(other.size_, 0);
    }
    return *this;
  }
  ~GrowableArray() { std::free(data_); }

  /// Resizes to n elements, keeping the first min(n, size()); the rest is uninitialised.
  void resize(size_t n) {
    if (n == 0) {
      std::free(data_);
      data_ = nullptr;
      size_ = 0;
      return;
    }
    if (n > SIZE_MAX / sizeof(T)) throw std::bad_alloc();
    void* p = std::realloc(data_, n * sizeof(T));
    if (p == nullptr) throw std::bad_alloc();
    data_ = static_cast<T*>(p);
    size_ = n;
  }
  /// Frees the block.
  void release() { resize(0); }

  size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  T* data() { return data_; }
  const T* data() const { return data_; }
  T* begin() { return data_; }
  T* end() { return data_ + size_; }
  const T* begin() const { return data_; }
  const T* end() const { return data_ + size_; }
  T& operator[](size_t i) { return data_[i]; }
  const T& operator[](size_t i) const { return data_[i]; }
  friend bool operator==(const GrowableArray& x, const GrowableArray& y) {
    return std::equal(x.begin(), x.end(), y.begin(), y.end());
  }

 private:
  T* data_ = nullptr;
  size_t size_ = 0;
};

}  // namespace gvd
