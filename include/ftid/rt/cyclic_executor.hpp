#pragma once
// Cyclic executors for ONE loop thread (docs/architecture.md: the robot is the clock). Templated on the cycle type: no
// std::function, no virtual calls, nothing allocates, nothing throws.
//
// Device-clocked (the robot is the clock): each cycle starts when the device delivers the state
// for that tick. The Cycle type provides
//     Status      waitForTick(std::chrono::nanoseconds timeout) noexcept;  // kOk/kTimeout/kFault
//     CycleAction onTick() noexcept;                                       // compute + send
//     CycleAction onMissed(std::uint32_t consecutive_missed) noexcept;     // e.g. hold the arm
// A wait that times out (timeout = timeout_periods x period, default 1.5) is a missed cycle.
// Wake-up latency is the arrival time minus the expected arrival (previous arrival + period),
// floored at 0; compute time is arrival to the end of onTick().
//
// Timer-clocked (no device clock): absolute-deadline clock_nanosleep(CLOCK_MONOTONIC,
// TIMER_ABSTIME); the Cycle provides  CycleAction onTimer(std::int64_t deadline_ns) noexcept;
// Wake-up latency is wake time minus the deadline. On an overrun the skipped periods are counted
// as missed and the schedule re-anchors instead of bursting, unless the loop is at most
// catch_up_periods behind: then the late cycles run back to back, each with its own deadline (a
// simulated device clock that must not lose ticks to a short host hiccup). The deadlines are
// always whole periods apart, so a cycle sees skipped periods as a jump of its deadline. A zero
// period runs the cycles back to back without sleeping (a simulation faster than real time).
#include <atomic>
#include <chrono>
#include <cstdint>
#include <ctime>
#include <limits>

#include "ftid/common/clock.hpp"
#include "ftid/common/status.hpp"
#include "ftid/rt/loop_stats.hpp"

namespace ftid::rt {

enum class CycleAction : std::uint8_t { kContinue, kStop };

enum class LoopExit : std::uint8_t {
  kCycleStopped,   ///< the cycle returned kStop
  kStopRequested,  ///< the external stop flag was set
  kTooManyMissed,  ///< max_consecutive_missed timeouts in a row
  kDeviceFault,    ///< waitForTick() returned kFault
};
const char* loopExitName(LoopExit e) noexcept;

struct ExecutorConfig {
  std::chrono::nanoseconds period{8'000'000};
  double timeout_periods = 1.5;               ///< device wait timeout in periods
  std::uint32_t max_consecutive_missed = 3;   ///< device-clocked: give up after this many
  /// Timer-clocked: an overrun of at most this many periods is caught up (the late cycles run at
  /// once) instead of skipped. 0: always skip.
  std::uint32_t catch_up_periods = 0;
};

/// CLOCK_MONOTONIC in ns (ftid/common/clock.hpp).
using ftid::monotonicNs;

/// Sleeps until an absolute CLOCK_MONOTONIC time (retries on EINTR).
void sleepUntilNs(std::int64_t deadline_ns) noexcept;

template <class Cycle>
LoopExit runDeviceClocked(Cycle& cycle, const ExecutorConfig& cfg, LoopStats* stats,
                          const std::atomic<bool>* stop_requested = nullptr) noexcept {
  const std::int64_t period_ns = cfg.period.count();
  const auto timeout = std::chrono::nanoseconds(
      static_cast<std::int64_t>(static_cast<double>(period_ns) * cfg.timeout_periods));
  std::int64_t last_arrival = 0;
  std::uint32_t consecutive_missed = 0;
  for (;;) {
    if (stop_requested && stop_requested->load(std::memory_order_relaxed)) return LoopExit::kStopRequested;
    const Status s = cycle.waitForTick(timeout);
    const std::int64_t arrival = monotonicNs();
    if (s == Status::kFault) return LoopExit::kDeviceFault;
    if (s != Status::kOk) {
      stats->recordMissed();
      ++consecutive_missed;
      if (consecutive_missed > stats->max_consecutive_missed) stats->max_consecutive_missed = consecutive_missed;
      if (cycle.onMissed(consecutive_missed) == CycleAction::kStop) return LoopExit::kCycleStopped;
      if (consecutive_missed >= cfg.max_consecutive_missed) return LoopExit::kTooManyMissed;
      last_arrival = 0;
      continue;
    }
    consecutive_missed = 0;
    const std::int64_t wake = last_arrival ? arrival - (last_arrival + period_ns) : 0;
    last_arrival = arrival;
    const CycleAction action = cycle.onTick();
    const std::int64_t end = monotonicNs();
    stats->recordCycle(wake > 0 ? wake : 0, end - arrival, period_ns);
    if (action == CycleAction::kStop) return LoopExit::kCycleStopped;
  }
}

template <class Cycle>
LoopExit runTimerClocked(Cycle& cycle, const ExecutorConfig& cfg, LoopStats* stats,
                         const std::atomic<bool>* stop_requested = nullptr) noexcept {
  const std::int64_t period_ns = cfg.period.count();
  std::int64_t next = monotonicNs() + period_ns;
  for (;;) {
    if (stop_requested && stop_requested->load(std::memory_order_relaxed)) return LoopExit::kStopRequested;
    if (period_ns > 0) sleepUntilNs(next);
    const std::int64_t wake = monotonicNs();
    const CycleAction action = cycle.onTimer(next);
    const std::int64_t end = monotonicNs();
    stats->recordCycle(period_ns > 0 ? wake - next : 0, end - wake,
                      period_ns > 0 ? period_ns : std::numeric_limits<std::int64_t>::max());
    if (action == CycleAction::kStop) return LoopExit::kCycleStopped;
    if (period_ns <= 0) {  // free-running
      next = end;
      continue;
    }
    next += period_ns;
    if (end > next) {  // overran one or more deadlines
      const std::int64_t behind = (end - next) / period_ns + 1;  // deadlines already past
      if (behind > static_cast<std::int64_t>(cfg.catch_up_periods)) {  // skip them, do not burst
        stats->missed += static_cast<std::uint64_t>(behind);
        next += behind * period_ns;
      }
    }
  }
}

}  // namespace ftid::rt
