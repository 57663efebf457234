#pragma once
// The watch over `ftid --identify`'s motion (private to ftid::cell; identify_watch.cpp): the
// real-time motion hook that aborts the motion when ftidd's cycle stream, the sensor, this process
// or the controller fails, and the operator's sentence for each abort reason.
//
// Abort reasons: 0 none, 1 user, 2 ftidd silent, 3 sensor invalid, 4 this process was stalled
// (SIGSTOP, overload), 5 our receive thread was starved, 6 the controller stalled. The first
// reason found stops the motion (HookContext::abort, read by motion::runOnRobot every cycle, which
// then stops the arm); later ticks do not overwrite it.
#include <atomic>
#include <cstdint>
#include <string>

#include "ftid/cell/cycle_recorder.hpp"
#include "ftid/motion/robot_session.hpp"

namespace ftid::cell::internal {

/// Shared between the real-time hook and the UI thread (atomics only).
struct HookContext {
  const CycleRecorder* recorder = nullptr;
  const std::atomic<bool>* user_abort = nullptr;
  std::atomic<bool> abort{false};
  std::atomic<int> reason{0};
  std::atomic<std::int64_t> detail_ms{0};  ///< the gap behind reasons 4..6 [ms]
  std::int64_t timeout_ns = 250000000;
  std::int64_t max_invalid = 5;
  double period = 0.008;                   ///< controller period [s] (configured)
  std::atomic<double> elapsed{0.0};
  std::atomic<int> phase{0};
  // Loop-thread state.
  std::int64_t last_hook_ns = 0;
  double last_robot_time = -1.0;
  double last_robot_gap_at = -1e300;       ///< robot time of the last state-package gap
  std::int64_t last_robot_gap_ms = 0;
};

/// The motion loop's per-tick hook (context: HookContext). Real-time: no allocation, no blocking.
void cycleHook(void* context, const motion::RecordedTick& tick) noexcept;

/// The progress line's name of a motion phase (motion::RecordedTick::phase).
const char* phaseName(int p);

/// Why the motion was aborted, for the operator: the hook's reason, or `fallback` (the runner's own
/// status and message) when the hook found none.
std::string abortReason(const HookContext& hook, std::string fallback);

}  // namespace ftid::cell::internal
