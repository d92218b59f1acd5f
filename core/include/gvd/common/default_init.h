#pragma once

// An allocator with which `vector::resize(n)` leaves trivial elements uninitialised, and
// UninitVector, the std::vector that uses it: a big scratch array is then first touched (its pages
// faulted in) by the parallel loop that fills it rather than zeroed by one thread. Its new
// elements hold no defined value until written.

#include <memory>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>

namespace gvd {

/// An allocator whose value-initialisation (`vector::resize(n)`) default-initialises instead:
/// trivial elements are left as they are, so a big array is first touched (its pages faulted
/// in) by the parallel loop that fills it rather than by one thread zeroing it.
template <class T>
struct DefaultInitAllocator : std::allocator<T> {
  template <class U>
  struct rebind {
    using other = DefaultInitAllocator<U>;
  };
  DefaultInitAllocator() = default;
  template <class U>
  DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept {}
  template <class U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};

/// A vector for big scratch arrays of trivial elements that a parallel loop fills.
template <class T>
using UninitVector = std::vector<T, DefaultInitAllocator<T>>;

}  // namespace gvd
