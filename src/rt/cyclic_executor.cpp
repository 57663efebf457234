#include "ftid/rt/cyclic_executor.hpp"

#include <cerrno>

namespace ftid::rt {

const char* loopExitName(LoopExit e) noexcept {
  switch (e) {
    case LoopExit::kCycleStopped: return "cycle finished";
    case LoopExit::kStopRequested: return "stop requested";
    case LoopExit::kTooManyMissed: return "too many missed cycles";
    case LoopExit::kDeviceFault: return "device fault";
  }
  return "unknown";
}

void sleepUntilNs(std::int64_t deadline_ns) noexcept {
  timespec ts{static_cast<time_t>(deadline_ns / 1'000'000'000), static_cast<long>(deadline_ns % 1'000'000'000)};
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

}  // namespace ftid::rt
