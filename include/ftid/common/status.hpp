#pragma once
// Status values and fault bits used inside the real-time loop (no exceptions there).
#include <atomic>
#include <cstdint>

namespace ftid {

enum class Status : std::uint8_t {
  kOk = 0,
  kTimeout,        ///< a device did not deliver within its deadline
  kInvalidInput,   ///< non-finite or out-of-range input
  kStale,          ///< data too old to use
  kRejected,       ///< a command was refused by the last-hop safety check
  kFault,          ///< a device reported a fault (protective stop, bus-off, ...)
  kNotReady,       ///< not enough history yet (e.g. a compensator's delay line is filling)
};

/// Fault bits, combined in a FaultWord. Set from the loop with fetch_or, read by the supervisor.
enum FaultBit : std::uint32_t {
  kFaultNone = 0,
  kFaultRobotTimeout = 1u << 0,
  kFaultRobotStopped = 1u << 1,      ///< protective/emergency stop, program stopped, mode change
  kFaultTargetRejected = 1u << 2,    ///< a servo target failed the last-hop check
  kFaultSensorStale = 1u << 3,
  kFaultSensorInvalid = 1u << 4,     ///< out-of-range value, counter gap, error frame
  kFaultOverrun = 1u << 5,
  kFaultPublishDropped = 1u << 6,
  kFaultTrackingError = 1u << 7,
  kFaultRobotClock = 1u << 8,        ///< the controller's clock stopped, jumped or ran at a wrong rate
};

/// Flags of the compensated wrench that are not faults (compensated_wrench_t.fault_bits, bits
/// 65536 and 131072, clear of the fault bits below them): set by the payload monitor (docs/daemon.md, "Payload monitor") on every wrench
/// while a payload change is suspected or confirmed. Never raised in the supervisor's FaultWord.
enum WrenchFlag : std::uint32_t {
  kFlagPayloadSuspect = 1u << 16,  ///< something acts on the tool: contact, or a change not yet decided
  kFlagPayloadChanged = 1u << 17,  ///< the payload changed: the compensation is wrong until re-identified
};
inline constexpr std::uint32_t kWrenchFlagMask = kFlagPayloadSuspect | kFlagPayloadChanged;

class FaultWord {
 public:
  void raise(std::uint32_t bits) noexcept { bits_.fetch_or(bits, std::memory_order_relaxed); }
  std::uint32_t bits() const noexcept { return bits_.load(std::memory_order_relaxed); }
  std::uint32_t clear() noexcept { return bits_.exchange(0, std::memory_order_relaxed); }

 private:
  std::atomic<std::uint32_t> bits_{0};
};

}  // namespace ftid
