// The watch over `ftid --identify`'s motion (identify_watch.hpp): per controller tick, the first of
// operator abort, this loop stalled (the gap since the previous tick exceeds the timeout), ftidd
// silent or our receive thread starved (no cycle sample for the timeout; told apart by the gap of
// our own calls and of the receive thread's polls), and an invalid sensor streak (a controller
// stall when it follows a gap of more than 3 periods in the robot's state packages within 1 s)
// sets the reason and stops the motion. Nothing here allocates, blocks or throws on the loop.
#include "identify_watch.hpp"

#include <utility>

#include "ftid/common/clock.hpp"

namespace ftid::cell::internal {

void cycleHook(void* context, const motion::RecordedTick& tick) noexcept {
  auto* c = static_cast<HookContext*>(context);
  const std::int64_t now = monotonicNs();
  const std::int64_t since_hook = c->last_hook_ns > 0 ? now - c->last_hook_ns : 0;
  c->last_hook_ns = now;
  const double rt = tick.state.timestamp;
  if (c->last_robot_time >= 0.0 && rt - c->last_robot_time > 3.0 * c->period) {
    c->last_robot_gap_at = rt;
    c->last_robot_gap_ms = static_cast<std::int64_t>((rt - c->last_robot_time) * 1000.0);
  }
  c->last_robot_time = rt;
  c->phase.store(static_cast<int>(tick.phase), std::memory_order_relaxed);
  if (tick.t_traj >= 0.0) c->elapsed.store(tick.t_traj, std::memory_order_relaxed);
  if (c->abort.load(std::memory_order_relaxed)) return;
  if (c->user_abort && c->user_abort->load(std::memory_order_relaxed)) {
    c->reason.store(1);
    c->abort.store(true);
    return;
  }
  // This loop itself was stopped or starved (SIGSTOP, overload): named first, whatever else the
  // gap caused (after SIGCONT the receive thread may already have caught up with ftidd's queued
  // data, and the robot program's watchdog may have stopped the program: this tick reports that).
  if (since_hook > c->timeout_ns) {
    c->detail_ms.store(since_hook / 1000000);
    c->reason.store(4);
    c->abort.store(true);
    return;
  }
  const std::int64_t age = now - c->recorder->lastReceiveNs();
  if (age > c->timeout_ns) {
    // Who went quiet? This loop itself (stopped or starved: the gap is between our own calls),
    // our LCM receive thread (it polls every 50 ms), or ftidd (our side is alive).
    const std::int64_t poll_age = now - c->recorder->lastPollNs();
    if (since_hook > c->timeout_ns) {
      c->detail_ms.store(since_hook / 1000000);
      c->reason.store(4);
    } else if (poll_age > c->timeout_ns) {
      c->detail_ms.store(poll_age / 1000000);
      c->reason.store(5);
    } else {
      c->reason.store(2);
    }
    c->abort.store(true);
    return;
  }
  if (c->recorder->invalidSensorStreak() > c->max_invalid) {
    // Right after a gap in the robot's own packages ftidd cannot pair samples with robot states:
    // that is a controller stall, not a silent sensor.
    if (rt - c->last_robot_gap_at < 1.0) {
      c->detail_ms.store(c->last_robot_gap_ms);
      c->reason.store(6);
    } else {
      c->reason.store(3);
    }
    c->abort.store(true);
  }
}

const char* phaseName(int p) {
  switch (p) {
    case 0: return "moving to start";
    case 1: return "settling";
    case 2: return "excitation";
    case 3: return "finishing";
    default: return "stopping";
  }
}

std::string abortReason(const HookContext& hook, std::string fallback) {
  std::string why = std::move(fallback);
  switch (hook.reason.load()) {
    case 1: why = "stopped by the operator (Ctrl-C)"; break;
    case 2: why = "ftidd stopped publishing (killed or stalled) during the motion"; break;
    case 3: why = "the F/T sensor went silent or invalid during the motion"; break;
    case 4:
      why = "ftid --identify itself was stopped or stalled for " + std::to_string(hook.detail_ms.load()) +
            " ms (SIGSTOP, or an overloaded host); ftidd was not at fault";
      break;
    case 5:
      why = "ftid --identify's receive thread was starved for " + std::to_string(hook.detail_ms.load()) +
            " ms (overloaded host), so ftidd's data could not be watched";
      break;
    case 6:
      why = "the robot controller stalled (no state package for " + std::to_string(hook.detail_ms.load()) +
            " ms), so ftidd could not pair sensor samples with robot states";
      break;
    default: break;
  }
  return why;
}

}  // namespace ftid::cell::internal
