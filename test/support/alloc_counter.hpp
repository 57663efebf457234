#pragma once
// Counts heap allocations made by the current thread while a ScopedAllocationCounter is alive.
// Link ftid_test_alloc_counter into a test binary: it replaces the global operator new/delete
// and malloc-family entry points of that binary, so libstdc++ and Eigen allocations are seen.
//
//   ftid::test::ScopedAllocationCounter counter;
//   compensator.compute(...);                 // real-time call under test
//   EXPECT_EQ(counter.count(), 0u);
#include <cstddef>

namespace ftid::test {

class ScopedAllocationCounter {
 public:
  ScopedAllocationCounter() noexcept;
  ~ScopedAllocationCounter();
  ScopedAllocationCounter(const ScopedAllocationCounter&) = delete;
  ScopedAllocationCounter& operator=(const ScopedAllocationCounter&) = delete;
  /// Allocations (malloc, calloc, realloc, operator new) counted on this thread so far.
  std::size_t count() const noexcept;

 private:
  std::size_t start_;
};

/// Total allocations counted on this thread while any counter was active.
std::size_t allocationsOnThisThread() noexcept;

}  // namespace ftid::test
