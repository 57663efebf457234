#include "alloc_counter.hpp"

#include <cstdlib>
#include <new>

// glibc exposes its allocator under __libc_* names; interposing malloc in the test binary lets us
// count every allocation (operator new in libstdc++ calls malloc).
extern "C" {
void* __libc_malloc(std::size_t size);
void* __libc_calloc(std::size_t n, std::size_t size);
void* __libc_realloc(void* p, std::size_t size);
void __libc_free(void* p);
}

namespace {
thread_local int t_active = 0;
thread_local std::size_t t_count = 0;
inline void noteAllocation() noexcept {
  if (t_active > 0) ++t_count;
}
}  // namespace

extern "C" {
void* malloc(std::size_t size) {
  noteAllocation();
  return __libc_malloc(size);
}
void* calloc(std::size_t n, std::size_t size) {
  noteAllocation();
  return __libc_calloc(n, size);
}
void* realloc(void* p, std::size_t size) {
  noteAllocation();
  return __libc_realloc(p, size);
}
void free(void* p) { __libc_free(p); }
}

namespace ftid::test {

ScopedAllocationCounter::ScopedAllocationCounter() noexcept : start_(t_count) { ++t_active; }
ScopedAllocationCounter::~ScopedAllocationCounter() { --t_active; }
std::size_t ScopedAllocationCounter::count() const noexcept { return t_count - start_; }
std::size_t allocationsOnThisThread() noexcept { return t_count; }

}  // namespace ftid::test
