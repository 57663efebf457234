#pragma once
// Per-thread scratch memory of the compressed tilt search (gravity_compression.hpp; private to
// ftid_identify). Header-only: one class, used by GravityCompression alone.
#include <cstddef>
#include <memory>

namespace ftid::identify::internal {

/// Scratch memory of the compressed tilt search (the rows of B_a and the scores, ~80 doubles per
/// sample), kept per thread between calls. Fresh pages cost a page fault each (1-1.5 us on the
/// development VM): at 1,251 samples the ~290 faults of a fit's transient matrices were a third of
/// its time, paid again on every call once glibc returns the memory. A repeated fit
/// (cross-validation, a cell that re-identifies, a benchmark) reuses the pages; capacity beyond
/// kKeptDoubles (64 MB) is released when the call ends. A nested lease on the same thread (none
/// today) gets memory of its own.
class ThreadScratch {
 public:
  ThreadScratch() : arena_(threadArena()) {
    if (arena_.in_use) {
      own_ = true;
    } else {
      arena_.in_use = true;
    }
  }
  ~ThreadScratch() {
    if (own_) return;
    arena_.in_use = false;
    if (arena_.capacity > kKeptDoubles) {
      arena_.data.reset();
      arena_.capacity = 0;
    }
  }
  ThreadScratch(const ThreadScratch&) = delete;
  ThreadScratch& operator=(const ThreadScratch&) = delete;

  /// At least `count` doubles, uninitialised contents (earlier contents are lost when it grows).
  double* reserve(std::size_t count) {
    Arena& a = own_ ? local_ : arena_;
    if (a.capacity < count) {
      a.data.reset();  // the old block first: peak memory is one block
      a.data = std::unique_ptr<double[]>(new double[count]);  // not zeroed: every entry is written before it is read
      a.capacity = count;
    }
    return a.data.get();
  }

 private:
  static constexpr std::size_t kKeptDoubles = std::size_t{8} << 20;  // 64 MB
  struct Arena {
    std::unique_ptr<double[]> data;
    std::size_t capacity = 0;
    bool in_use = false;
  };
  static Arena& threadArena() {
    static thread_local Arena arena;
    return arena;
  }
  Arena& arena_;
  Arena local_;
  bool own_ = false;
};

}  // namespace ftid::identify::internal
