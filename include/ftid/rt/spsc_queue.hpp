#pragma once
// Wait-free single-producer/single-consumer ring for T with a non-allocating copy (trivially copyable, fixed-size Eigen) (e.g. the RT loop
// pushes samples, a normal-priority thread pops and publishes). Capacity is a power of two fixed
// at compile time; storage is inline, nothing allocates. tryPush() drops (returns false) when
// full and counts the drop; it never blocks.
#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <type_traits>

namespace ftid::rt {

template <class T, std::size_t Capacity>
class SpscQueue {
  // Slots are accessed exclusively by one side at a time, so T only needs a copy that neither
  // allocates nor throws: trivially copyable types, or fixed-size aggregates such as Eigen
  // fixed-size matrices (ftid::drivers::ur::ArmState).
  static_assert(std::is_copy_assignable_v<T> && std::is_default_constructible_v<T>,
                "SpscQueue<T>: T must be default-constructible and copy-assignable");
  static_assert(Capacity >= 2 && (Capacity & (Capacity - 1)) == 0, "Capacity must be a power of two");

 public:
  /// Producer side (RT). False if full (the item is dropped and counted).
  bool tryPush(const T& item) noexcept {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    const std::size_t tail = tail_.load(std::memory_order_acquire);
    if (head - tail >= Capacity) {
      dropped_.fetch_add(1, std::memory_order_relaxed);
      return false;
    }
    slots_[head & (Capacity - 1)] = item;
    head_.store(head + 1, std::memory_order_release);
    return true;
  }
  /// Consumer side. False if empty.
  bool tryPop(T* item) noexcept {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);
    const std::size_t head = head_.load(std::memory_order_acquire);
    if (tail == head) return false;
    *item = slots_[tail & (Capacity - 1)];
    tail_.store(tail + 1, std::memory_order_release);
    return true;
  }
  /// Approximate number of queued items (exact when called from either end while the other idles).
  std::size_t size() const noexcept {
    return head_.load(std::memory_order_acquire) - tail_.load(std::memory_order_acquire);
  }
  bool empty() const noexcept { return size() == 0; }
  static constexpr std::size_t capacity() noexcept { return Capacity; }
  /// Items dropped by tryPush() because the queue was full.
  std::uint64_t dropped() const noexcept { return dropped_.load(std::memory_order_relaxed); }

 private:
  alignas(64) std::atomic<std::size_t> head_{0};  // written by the producer
  alignas(64) std::atomic<std::size_t> tail_{0};  // written by the consumer
  alignas(64) std::atomic<std::uint64_t> dropped_{0};
  std::array<T, Capacity> slots_{};
};

}  // namespace ftid::rt
