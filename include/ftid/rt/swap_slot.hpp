#pragma once
// OwnedSwapSlot<T>: hands a new heap object (built off the loop) to the loop thread and takes
// the replaced one back, without the loop ever allocating, freeing, locking or blocking.
//
//   non-RT:  slot.post(std::move(fresh));    // frees anything the loop has retired, then offers
//   RT:      if (T* now = slot.tryAcquire()) current = now;   // at the start of a cycle
//   non-RT:  slot.collectRetired();          // frees the replaced object (also done by post())
//
// Only one non-RT thread may call post()/collectRetired()/current-at-shutdown, and only one loop
// thread tryAcquire()/current(). The loop keeps using its current object until it swaps; it swaps
// only when the previous retired object has been collected, so at most three objects exist.
#include <atomic>
#include <cstdint>
#include <memory>

namespace ftid::rt {

template <class T>
class OwnedSwapSlot {
 public:
  OwnedSwapSlot() = default;
  explicit OwnedSwapSlot(std::unique_ptr<T> initial) : current_(initial.release()) {
    if (current_ != nullptr) version_.store(1, std::memory_order_relaxed);
  }
  ~OwnedSwapSlot() {
    delete pending_.exchange(nullptr);
    delete retired_.exchange(nullptr);
    delete current_;
  }
  OwnedSwapSlot(const OwnedSwapSlot&) = delete;
  OwnedSwapSlot& operator=(const OwnedSwapSlot&) = delete;

  /// Non-RT: offer a new object; the loop takes it at its next tryAcquire() (then version()
  /// increases and hasPending() turns false). A still-pending older offer is replaced and freed
  /// here (the loop never saw it).
  void post(std::unique_ptr<T> fresh) {
    collectRetired();
    delete pending_.exchange(fresh.release(), std::memory_order_acq_rel);
  }

  /// Non-RT: frees the object the loop replaced, if any. Returns true if it freed one.
  bool collectRetired() {
    T* old = retired_.exchange(nullptr, std::memory_order_acq_rel);
    delete old;
    return old != nullptr;
  }

  /// RT: takes a pending object if there is one and the previous retired one has been
  /// collected. Returns the new current object, or nullptr if nothing changed.
  T* tryAcquire() noexcept {
    if (pending_.load(std::memory_order_acquire) == nullptr) return nullptr;
    if (retired_.load(std::memory_order_acquire) != nullptr) return nullptr;  // collect first
    T* fresh = pending_.exchange(nullptr, std::memory_order_acq_rel);
    if (fresh == nullptr) return nullptr;
    retired_.store(current_, std::memory_order_release);
    current_ = fresh;
    version_.fetch_add(1, std::memory_order_release);
    return fresh;
  }

  /// RT (loop thread): the object in use (nullptr before the first one).
  T* current() const noexcept { return current_; }
  /// Any thread: number of objects the loop has taken into use (including the initial one).
  std::uint32_t version() const noexcept { return version_.load(std::memory_order_acquire); }
  /// Any thread: true if an offer is waiting for the loop.
  bool hasPending() const noexcept { return pending_.load(std::memory_order_acquire) != nullptr; }

 private:
  T* current_ = nullptr;  // loop thread only
  std::atomic<T*> pending_{nullptr};
  std::atomic<T*> retired_{nullptr};
  std::atomic<std::uint32_t> version_{0};
};

}  // namespace ftid::rt
