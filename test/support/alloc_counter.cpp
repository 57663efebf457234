#include "alloc_counter.hpp"

#include <malloc.h>

#include <cerrno>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <new>
#include <string>

#include <Eigen/Core>

// glibc exposes its allocator under __libc_* names. Defining the malloc family and every global
// operator new/delete in the test binary interposes them for the whole process (glibc's own
// internal calls, e.g. strdup, and libstdc++ go through the interposed symbols), so the counter
// sees every allocation. Each replacement counts once, by its own entry point, and then calls
// glibc's allocator directly (never another replaced function), so one allocation counts once.
extern "C" {
void* __libc_malloc(std::size_t size);
void* __libc_calloc(std::size_t n, std::size_t size);
void* __libc_realloc(void* p, std::size_t size);
void* __libc_memalign(std::size_t alignment, std::size_t size);
void* __libc_valloc(std::size_t size);
void* __libc_pvalloc(std::size_t size);
void __libc_free(void* p);
}

namespace {

using ftid::test::AllocKind;
constexpr int kKinds = static_cast<int>(AllocKind::kCount);

// Plain arrays of integers: zero-initialised TLS, no constructor, no allocation on first access.
thread_local int t_active = 0;
thread_local std::size_t t_count[kKinds] = {};
thread_local std::size_t t_total = 0;
thread_local std::size_t t_frees = 0;

inline void note(AllocKind kind) noexcept {
  if (t_active > 0) {
    ++t_count[static_cast<int>(kind)];
    ++t_total;
  }
}
inline void noteFree() noexcept {
  if (t_active > 0) ++t_frees;
}

bool isPowerOfTwo(std::size_t x) { return x != 0 && (x & (x - 1)) == 0; }

/// operator new semantics: retry through the new-handler, then throw std::bad_alloc.
void* newOrThrow(std::size_t size) {
  if (size == 0) size = 1;
  for (;;) {
    if (void* p = __libc_malloc(size)) return p;
    std::new_handler h = std::get_new_handler();
    if (h == nullptr) throw std::bad_alloc();
    h();
  }
}
void* newAlignedOrThrow(std::size_t size, std::align_val_t al) {
  if (size == 0) size = 1;
  for (;;) {
    if (void* p = __libc_memalign(static_cast<std::size_t>(al), size)) return p;
    std::new_handler h = std::get_new_handler();
    if (h == nullptr) throw std::bad_alloc();
    h();
  }
}
void* newNothrow(std::size_t size) noexcept {
  try {
    return newOrThrow(size);
  } catch (...) {
    return nullptr;
  }
}
void* newAlignedNothrow(std::size_t size, std::align_val_t al) noexcept {
  try {
    return newAlignedOrThrow(size, al);
  } catch (...) {
    return nullptr;
  }
}
inline void release(void* p) noexcept {
  if (p == nullptr) return;
  noteFree();
  __libc_free(p);
}

}  // namespace

// --- C allocation functions ---------------------------------------------------------------------
extern "C" {
void* malloc(std::size_t size) noexcept {
  note(AllocKind::kMalloc);
  return __libc_malloc(size);
}
void* calloc(std::size_t n, std::size_t size) noexcept {
  note(AllocKind::kCalloc);
  return __libc_calloc(n, size);
}
void* realloc(void* p, std::size_t size) noexcept {
  note(AllocKind::kRealloc);
  return __libc_realloc(p, size);
}
void* reallocarray(void* p, std::size_t n, std::size_t size) noexcept {
  note(AllocKind::kReallocArray);
  if (size != 0 && n > SIZE_MAX / size) {
    errno = ENOMEM;
    return nullptr;
  }
  return __libc_realloc(p, n * size);
}
void* aligned_alloc(std::size_t alignment, std::size_t size) noexcept {
  note(AllocKind::kAlignedAlloc);
  if (!isPowerOfTwo(alignment)) {
    errno = EINVAL;
    return nullptr;
  }
  return __libc_memalign(alignment, size);
}
int posix_memalign(void** out, std::size_t alignment, std::size_t size) noexcept {
  note(AllocKind::kPosixMemalign);
  if (!isPowerOfTwo(alignment) || alignment % sizeof(void*) != 0) return EINVAL;
  const int saved = errno;
  void* p = __libc_memalign(alignment, size);
  errno = saved;  // posix_memalign reports through its return value only
  if (p == nullptr) return ENOMEM;
  *out = p;
  return 0;
}
void* memalign(std::size_t alignment, std::size_t size) noexcept {
  note(AllocKind::kMemalign);
  return __libc_memalign(alignment, size);
}
void* valloc(std::size_t size) noexcept {
  note(AllocKind::kValloc);
  return __libc_valloc(size);
}
void* pvalloc(std::size_t size) noexcept {
  note(AllocKind::kPvalloc);
  return __libc_pvalloc(size);
}
void free(void* p) noexcept { release(p); }
}

// --- Global operator new / delete (every replaceable overload) ----------------------------------
void* operator new(std::size_t size) {
  note(AllocKind::kNew);
  return newOrThrow(size);
}
void* operator new[](std::size_t size) {
  note(AllocKind::kNewArray);
  return newOrThrow(size);
}
void* operator new(std::size_t size, const std::nothrow_t&) noexcept {
  note(AllocKind::kNewNothrow);
  return newNothrow(size);
}
void* operator new[](std::size_t size, const std::nothrow_t&) noexcept {
  note(AllocKind::kNewArrayNothrow);
  return newNothrow(size);
}
void* operator new(std::size_t size, std::align_val_t al) {
  note(AllocKind::kNewAligned);
  return newAlignedOrThrow(size, al);
}
void* operator new[](std::size_t size, std::align_val_t al) {
  note(AllocKind::kNewArrayAligned);
  return newAlignedOrThrow(size, al);
}
void* operator new(std::size_t size, std::align_val_t al, const std::nothrow_t&) noexcept {
  note(AllocKind::kNewAlignedNothrow);
  return newAlignedNothrow(size, al);
}
void* operator new[](std::size_t size, std::align_val_t al, const std::nothrow_t&) noexcept {
  note(AllocKind::kNewArrayAlignedNothrow);
  return newAlignedNothrow(size, al);
}
void operator delete(void* p) noexcept { release(p); }
void operator delete[](void* p) noexcept { release(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { release(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { release(p); }
void operator delete(void* p, std::size_t) noexcept { release(p); }
void operator delete[](void* p, std::size_t) noexcept { release(p); }
void operator delete(void* p, std::align_val_t) noexcept { release(p); }
void operator delete[](void* p, std::align_val_t) noexcept { release(p); }
void operator delete(void* p, std::align_val_t, const std::nothrow_t&) noexcept { release(p); }
void operator delete[](void* p, std::align_val_t, const std::nothrow_t&) noexcept { release(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { release(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { release(p); }

namespace ftid::test {

const char* toString(AllocKind kind) {
  switch (kind) {
    case AllocKind::kMalloc: return "malloc";
    case AllocKind::kCalloc: return "calloc";
    case AllocKind::kRealloc: return "realloc";
    case AllocKind::kReallocArray: return "reallocarray";
    case AllocKind::kAlignedAlloc: return "aligned_alloc";
    case AllocKind::kPosixMemalign: return "posix_memalign";
    case AllocKind::kMemalign: return "memalign";
    case AllocKind::kValloc: return "valloc";
    case AllocKind::kPvalloc: return "pvalloc";
    case AllocKind::kNew: return "operator_new";
    case AllocKind::kNewArray: return "operator_new_array";
    case AllocKind::kNewNothrow: return "operator_new_nothrow";
    case AllocKind::kNewArrayNothrow: return "operator_new_array_nothrow";
    case AllocKind::kNewAligned: return "operator_new_aligned";
    case AllocKind::kNewArrayAligned: return "operator_new_array_aligned";
    case AllocKind::kNewAlignedNothrow: return "operator_new_aligned_nothrow";
    case AllocKind::kNewArrayAlignedNothrow: return "operator_new_array_aligned_nothrow";
    case AllocKind::kCount: break;
  }
  return "unknown";
}

ScopedAllocationCounter::ScopedAllocationCounter() noexcept : start_(), start_total_(t_total), start_frees_(t_frees) {
  for (int k = 0; k < kKinds; ++k) start_[k] = t_count[k];
  ++t_active;
}
ScopedAllocationCounter::~ScopedAllocationCounter() {
  if (std::this_thread::get_id() == owner_) --t_active;
}
std::size_t ScopedAllocationCounter::count() const noexcept { return t_total - start_total_; }
std::size_t ScopedAllocationCounter::count(AllocKind kind) const noexcept {
  const int k = static_cast<int>(kind);
  return (k >= 0 && k < kKinds) ? t_count[k] - start_[k] : 0;
}
std::size_t ScopedAllocationCounter::frees() const noexcept { return t_frees - start_frees_; }
std::size_t allocationsOnThisThread() noexcept { return t_total; }

namespace {

/// Makes the pointer observable to the optimiser, so an allocate/free pair cannot be elided.
inline void escape(const void* p) { asm volatile("" : : "g"(p) : "memory"); }

struct alignas(64) OverAligned {
  double x[8];
};

}  // namespace

void allocateDeliberately(AllocKind kind) {
  constexpr std::size_t kSize = 96;
  constexpr std::size_t kAlign = 64;
  const auto al = static_cast<std::align_val_t>(kAlign);
  switch (kind) {
    case AllocKind::kMalloc: {
      void* p = std::malloc(kSize);
      escape(p);
      std::free(p);
      return;
    }
    case AllocKind::kCalloc: {
      void* p = std::calloc(4, kSize);
      escape(p);
      std::free(p);
      return;
    }
    case AllocKind::kRealloc: {
      void* p = std::realloc(nullptr, kSize);
      escape(p);
      std::free(p);
      return;
    }
    case AllocKind::kReallocArray: {
      void* p = ::reallocarray(nullptr, 4, kSize);
      escape(p);
      std::free(p);
      return;
    }
    case AllocKind::kAlignedAlloc: {
      void* p = std::aligned_alloc(kAlign, 2 * kAlign);
      escape(p);
      std::free(p);
      return;
    }
    case AllocKind::kPosixMemalign: {
      void* p = nullptr;
      if (::posix_memalign(&p, kAlign, kSize) != 0) throw std::bad_alloc();
      escape(p);
      std::free(p);
      return;
    }
    case AllocKind::kMemalign: {
      void* p = ::memalign(kAlign, kSize);
      escape(p);
      std::free(p);
      return;
    }
    case AllocKind::kValloc: {
      void* p = ::valloc(kSize);
      escape(p);
      std::free(p);
      return;
    }
    case AllocKind::kPvalloc: {
      void* p = ::pvalloc(kSize);
      escape(p);
      std::free(p);
      return;
    }
    case AllocKind::kNew: {
      void* p = ::operator new(kSize);
      escape(p);
      ::operator delete(p);
      return;
    }
    case AllocKind::kNewArray: {
      void* p = ::operator new[](kSize);
      escape(p);
      ::operator delete[](p);
      return;
    }
    case AllocKind::kNewNothrow: {
      void* p = ::operator new(kSize, std::nothrow);
      escape(p);
      ::operator delete(p, std::nothrow);
      return;
    }
    case AllocKind::kNewArrayNothrow: {
      void* p = ::operator new[](kSize, std::nothrow);
      escape(p);
      ::operator delete[](p, std::nothrow);
      return;
    }
    case AllocKind::kNewAligned: {
      void* p = ::operator new(kSize, al);
      escape(p);
      ::operator delete(p, al);
      return;
    }
    case AllocKind::kNewArrayAligned: {
      void* p = ::operator new[](kSize, al);
      escape(p);
      ::operator delete[](p, al);
      return;
    }
    case AllocKind::kNewAlignedNothrow: {
      void* p = ::operator new(kSize, al, std::nothrow);
      escape(p);
      ::operator delete(p, al, std::nothrow);
      return;
    }
    case AllocKind::kNewArrayAlignedNothrow: {
      void* p = ::operator new[](kSize, al, std::nothrow);
      escape(p);
      ::operator delete[](p, al, std::nothrow);
      return;
    }
    case AllocKind::kCount:
      break;
  }
  throw std::invalid_argument("allocateDeliberately: no such allocation kind");
}

std::vector<AllocKind> allAllocKinds() {
  std::vector<AllocKind> kinds;
  for (int k = 0; k < kKinds; ++k) kinds.push_back(static_cast<AllocKind>(k));
  return kinds;
}

std::vector<IndirectAllocation> indirectAllocations() {
  return {
      // The example: an over-aligned make_unique (new-expression -> aligned operator new).
      {"make_unique_over_aligned", AllocKind::kNewAligned,
       [] {
         auto p = std::make_unique<OverAligned>();
         escape(p.get());
       }},
      {"new_expression_over_aligned_array", AllocKind::kNewArrayAligned,
       [] {
         auto p = std::make_unique<OverAligned[]>(3);
         escape(p.get());
       }},
      {"std_string_heap", AllocKind::kNew,
       [] {
         std::string s(200, 'x');
         escape(s.data());
       }},
      {"eigen_dynamic_vector", AllocKind::kMalloc,
       [] {
         Eigen::VectorXd v = Eigen::VectorXd::Constant(64, 1.0);
         escape(v.data());
       }},
      // glibc calls malloc internally: the interposed malloc must see that too.
      {"libc_internal_strdup", AllocKind::kMalloc,
       [] {
         char* s = ::strdup("a string for strdup");
         escape(s);
         std::free(s);
       }},
  };
}

}  // namespace ftid::test
