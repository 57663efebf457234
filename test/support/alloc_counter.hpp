#pragma once
// Counts heap allocations made by the current thread while a ScopedAllocationCounter is alive.
// Link ftid_test_alloc_counter into a test binary: it replaces, for that binary, every entry point
// through which memory can be taken from the heap, so libstdc++, libc-internal and Eigen
// allocations are all seen:
//   - every global operator new (plain, array, nothrow, std::align_val_t, and their combinations),
//   - malloc, calloc, realloc, reallocarray, aligned_alloc, posix_memalign, memalign, valloc, pvalloc,
// and, counted separately, every operator delete (plain, sized, aligned, nothrow, arrays) and free.
//
//   ftid::test::ScopedAllocationCounter counter;
//   compensator.compute(...);                 // real-time call under test
//   EXPECT_EQ(counter.count(), 0u);
//
// The counter proves itself: test/support/alloc_controls.hpp instantiates, in every test/rt_safety
// binary, one positive control per kind below (a deliberate allocation the counter must see, by the
// entry point it went through).
#include <cstddef>
#include <thread>
#include <vector>

namespace ftid::test {

/// The entry point an allocation went through.
enum class AllocKind {
  kMalloc,
  kCalloc,
  kRealloc,
  kReallocArray,
  kAlignedAlloc,
  kPosixMemalign,
  kMemalign,
  kValloc,
  kPvalloc,
  kNew,                     ///< operator new(size_t)
  kNewArray,                ///< operator new[](size_t)
  kNewNothrow,              ///< operator new(size_t, nothrow_t)
  kNewArrayNothrow,         ///< operator new[](size_t, nothrow_t)
  kNewAligned,              ///< operator new(size_t, align_val_t)
  kNewArrayAligned,         ///< operator new[](size_t, align_val_t)
  kNewAlignedNothrow,       ///< operator new(size_t, align_val_t, nothrow_t)
  kNewArrayAlignedNothrow,  ///< operator new[](size_t, align_val_t, nothrow_t)
  kCount
};

/// "malloc", "operator new[](size_t, align_val_t)", ...
const char* toString(AllocKind kind);

class ScopedAllocationCounter {
 public:
  ScopedAllocationCounter() noexcept;
  ~ScopedAllocationCounter();
  ScopedAllocationCounter(const ScopedAllocationCounter&) = delete;
  ScopedAllocationCounter& operator=(const ScopedAllocationCounter&) = delete;
  /// Allocations of every kind counted on this thread since construction.
  std::size_t count() const noexcept;
  /// Allocations through one entry point since construction.
  std::size_t count(AllocKind kind) const noexcept;
  /// Deallocations (free, every operator delete) on this thread since construction.
  std::size_t frees() const noexcept;

 private:
  std::size_t start_[static_cast<int>(AllocKind::kCount)];
  std::size_t start_total_;
  std::size_t start_frees_;
  /// The thread it counts on. Destroyed on another thread (a fake's counter that outlives its
  /// loop thread), it leaves that thread's counting alone: decrementing there used to switch off
  /// every later counter of the destroying thread (the positive controls then failed when a
  /// binary ran all its cases in one process).
  std::thread::id owner_ = std::this_thread::get_id();
};

/// Total allocations counted on this thread while any counter was active.
std::size_t allocationsOnThisThread() noexcept;

// --- Positive controls ------------------------------------------------------------------------

/// One deliberate allocation of the given kind (through exactly that entry point), released
/// again. The compiler cannot drop it (the pointer escapes). Used by the positive controls.
void allocateDeliberately(AllocKind kind);

/// Further deliberate allocations that reach the heap indirectly: the kind the counter must
/// report for each is given (e.g. std::make_unique of an over-aligned type -> kNewAligned).
struct IndirectAllocation {
  const char* name;            ///< test-name friendly: letters, digits, underscores
  AllocKind expected_kind;
  void (*run)();
};
std::vector<IndirectAllocation> indirectAllocations();

/// Every kind (for parameterised tests).
std::vector<AllocKind> allAllocKinds();

}  // namespace ftid::test
