#pragma once
// Latest-value mailbox (triple buffer) for T with a non-allocating copy (trivially copyable
// types, fixed-size Eigen): one writer, one reader, both wait-free, no torn reads, no locks. The writer always writes into its private slot and then
// swaps it with the shared "middle" slot; the reader swaps the middle slot into its private slot
// when a new value is flagged. Intermediate values are overwritten (latest wins).
#include <array>
#include <atomic>
#include <cstdint>
#include <type_traits>

namespace ftid::rt {

template <class T>
class Mailbox {
  // Slots are accessed exclusively by one side at a time, so T only needs a copy that neither
  // allocates nor throws: trivially copyable types, or fixed-size aggregates such as Eigen
  // fixed-size matrices (ftid::drivers::ur::ArmState).
  static_assert(std::is_copy_assignable_v<T> && std::is_default_constructible_v<T>,
                "Mailbox<T>: T must be default-constructible and copy-assignable");

 public:
  /// Writer side (RT, wait-free).
  void tryPush(const T& value) noexcept {
    buffers_[write_index_] = value;
    const std::uint8_t previous =
        middle_.exchange(static_cast<std::uint8_t>(write_index_ | kFreshBit), std::memory_order_acq_rel);
    write_index_ = previous & kIndexMask;
    writes_.fetch_add(1, std::memory_order_release);
  }
  /// Reader side (wait-free). Copies the newest value into *value and returns true if a value was
  /// written since the previous successful tryPop(); otherwise returns false and leaves *value.
  bool tryPop(T* value) noexcept {
    if ((middle_.load(std::memory_order_relaxed) & kFreshBit) == 0) return false;
    const std::uint8_t previous = middle_.exchange(read_index_, std::memory_order_acq_rel);
    read_index_ = previous & kIndexMask;
    *value = buffers_[read_index_];
    return true;
  }
  /// Reader side: the newest value ever written (false if none yet).
  bool readLatest(T* value) noexcept {
    // writes_ is incremented after the slot exchange, so a non-zero count seen here guarantees
    // that tryPop() below (or an earlier one) has taken a written slot.
    if (writes_.load(std::memory_order_acquire) == 0) return false;
    if (!tryPop(value)) *value = buffers_[read_index_];
    return true;
  }
  /// Number of tryPush() calls so far.
  std::uint64_t writes() const noexcept { return writes_.load(std::memory_order_relaxed); }

 private:
  static constexpr std::uint8_t kFreshBit = 0x4;
  static constexpr std::uint8_t kIndexMask = 0x3;
  std::array<T, 3> buffers_{};
  alignas(64) std::atomic<std::uint8_t> middle_{1};
  alignas(64) std::uint8_t write_index_ = 0;  // writer-private
  alignas(64) std::uint8_t read_index_ = 2;   // reader-private
  std::atomic<std::uint64_t> writes_{0};
};

}  // namespace ftid::rt
