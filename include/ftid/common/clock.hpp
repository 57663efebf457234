#pragma once
// The one set of clock helpers (real-time safe: clock_gettime only, no allocation, no throw).
//   monotonicNs(), monotonicUs(): CLOCK_MONOTONIC [ns], [us], for timeouts, deadlines, loop
//   timing and the ages of sensor samples (docs/conventions.md, "Host clocks").
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

inline std::int64_t monotonicUs() noexcept { return monotonicNs() / 1000; }

inline std::int64_t realtimeNs() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

inline std::int64_t realtimeUs() noexcept { return realtimeNs() / 1000; }

/// A record's recv_utime [us since the epoch] as seconds since the epoch: the clock of the model's
/// time (docs/conventions.md, "Time and logs"). ftidd and the logs' host_time column use this one
/// conversion, so the same recorded value gives the same double on both paths.
inline double hostTimeSeconds(std::int64_t utime_us) noexcept { return static_cast<double>(utime_us) * 1e-6; }

}  // namespace ftid
