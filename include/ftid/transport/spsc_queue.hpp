#pragma once
// Bounded wait-free single-producer/single-consumer queue and a latest-value mailbox, used to
// hand data from the real-time loop to the non-real-time publisher. Both sides never block and
// never allocate after construction (storage is inline).
//
//   producer (RT):   queue.tryPush(record)  -> false (and counted) when full
//   consumer:        while (queue.tryPop(&record)) { ... }
#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>

namespace ftid::transport {

template <class T, std::size_t Capacity>
class SpscQueue {
  static_assert(Capacity >= 2 && (Capacity & (Capacity - 1)) == 0, "Capacity: power of two");

 public:
  /// Producer side. Copies value into the next slot; false if the queue is full.
  bool tryPush(const T& value) noexcept {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    if (head - tail_.load(std::memory_order_acquire) >= Capacity) {
      dropped_.fetch_add(1, std::memory_order_relaxed);
      return false;
    }
    slots_[head & (Capacity - 1)] = value;
    head_.store(head + 1, std::memory_order_release);
    return true;
  }

  /// Consumer side. Copies the oldest value out; false if the queue is empty.
  bool tryPop(T* value) noexcept {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_.load(std::memory_order_acquire)) return false;
    *value = slots_[tail & (Capacity - 1)];
    tail_.store(tail + 1, std::memory_order_release);
    return true;
  }

  /// Approximate number of queued values (exact when called from either side while the
  /// other is idle).
  std::size_t sizeApprox() const noexcept {
    return head_.load(std::memory_order_acquire) - tail_.load(std::memory_order_acquire);
  }
  /// Values refused by tryPush because the queue was full.
  std::uint64_t dropped() const noexcept { return dropped_.load(std::memory_order_relaxed); }
  static constexpr std::size_t capacity() noexcept { return Capacity; }

 private:
  alignas(64) std::atomic<std::size_t> head_{0};
  alignas(64) std::atomic<std::size_t> tail_{0};
  alignas(64) std::atomic<std::uint64_t> dropped_{0};
  std::array<T, Capacity> slots_{};
};

}  // namespace ftid::transport
