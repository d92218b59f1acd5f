// gvd-server's operator new and delete: malloc and free, with each block's size charged to
// the calling thread's MemoryAccount (gvd/common/memory_account.h), so that the memory
// limits charge a job for what it holds itself (a job's worker thread and the threads that
// work for it run under the job's account; other threads have none and are not counted).
// The size charged is the block's usable size, the same when it is freed, on whatever thread.

#include <malloc.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <new>

#include "gvd/common/memory_account.h"

namespace {

void charge(void* p, int64_t sign) {
  if (p != nullptr && gvd::charging_memory())
    gvd::charge_memory(sign * static_cast<int64_t>(malloc_usable_size(p)));
}

/// malloc (align 0) or posix_memalign, charged; the new handler's loop, then bad_alloc.
void* allocate(std::size_t size, std::size_t align = 0) {
  if (size == 0) size = 1;
  for (;;) {
    void* p = nullptr;
    if (align == 0) {
      p = std::malloc(size);
    } else if (posix_memalign(&p, std::max(align, sizeof(void*)), size) != 0) {
      p = nullptr;
    }
    if (p != nullptr) {
      charge(p, +1);
      return p;
    }
    std::new_handler handler = std::get_new_handler();
    if (handler == nullptr) throw std::bad_alloc();
    handler();
  }
}

/// The nothrow forms: null where the others throw.
void* allocate_or_null(std::size_t size, std::size_t align = 0) noexcept {
  try {
    return allocate(size, align);
  } catch (...) {
    return nullptr;
  }
}

void release(void* p) noexcept {
  charge(p, -1);
  std::free(p);
}

}  // namespace

void* operator new(std::size_t size) { return allocate(size); }
void* operator new[](std::size_t size) { return allocate(size); }
void* operator new(std::size_t size, const std::nothrow_t&) noexcept {
  return allocate_or_null(size);
}
void* operator new[](std::size_t size, const std::nothrow_t&) noexcept {
  return allocate_or_null(size);
}
void* operator new(std::size_t size, std::align_val_t align) {
  return allocate(size, static_cast<std::size_t>(align));
}
void* operator new[](std::size_t size, std::align_val_t align) {
  return allocate(size, static_cast<std::size_t>(align));
}
void* operator new(std::size_t size, std::align_val_t align, const std::nothrow_t&) noexcept {
  return allocate_or_null(size, static_cast<std::size_t>(align));
}
void* operator new[](std::size_t size, std::align_val_t align, const std::nothrow_t&) noexcept {
  return allocate_or_null(size, static_cast<std::size_t>(align));
}

void operator delete(void* p) noexcept { release(p); }
void operator delete[](void* p) noexcept { release(p); }
void operator delete(void* p, std::size_t) noexcept { release(p); }
void operator delete[](void* p, std::size_t) noexcept { release(p); }
void operator delete(void* p, std::align_val_t) noexcept { release(p); }
void operator delete[](void* p, std::align_val_t) noexcept { release(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { release(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { release(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { release(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { release(p); }
void operator delete(void* p, std::align_val_t, const std::nothrow_t&) noexcept { release(p); }
void operator delete[](void* p, std::align_val_t, const std::nothrow_t&) noexcept { release(p); }
