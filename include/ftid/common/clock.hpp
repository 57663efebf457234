#pragma once
// The one set of clock helpers (real-time safe: clock_gettime only, no allocation, no throw).
//   monotonicNs(): CLOCK_MONOTONIC [ns], for timeouts, deadlines and loop timing.
//   realtimeNs(), realtimeUs(): CLOCK_REALTIME [ns], [us since the epoch], the clock of the
//   published records' utime / recv_utime and of command timestamps.
#include <cstdint>
#include <ctime>

namespace ftid {

inline std::int64_t monotonicNs() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

inline std::int64_t realtimeNs() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

inline std::int64_t realtimeUs() noexcept { return realtimeNs() / 1000; }

}  // namespace ftid
