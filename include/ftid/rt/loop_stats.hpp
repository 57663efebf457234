#pragma once
// Per-cycle statistics in fixed storage (docs/architecture.md). update*() are real-time safe and
// cheap; the struct is trivially copyable so the loop can publish snapshots through a Mailbox and
// a normal thread can format them (summary()).
#include <array>
#include <cstdint>
#include <string>

namespace ftid::rt {

/// Histogram with 1 us bins up to kBins us; larger values land in the overflow bin.
struct LatencyHistogram {
  static constexpr int kBins = 2000;
  std::array<std::uint32_t, kBins> bins{};
  std::uint64_t overflow = 0;
  std::uint64_t count = 0;
  std::int64_t max_ns = 0;
  std::int64_t min_ns = 0;
  double sum_ns = 0.0;

  void add(std::int64_t ns) noexcept;
  /// Value below which a fraction p (0..1) of the samples lie, in ns (bin upper edge; the max if
  /// the quantile falls into the overflow bin). 0 if empty.
  std::int64_t quantileNs(double p) const noexcept;
  double meanNs() const noexcept { return count ? sum_ns / static_cast<double>(count) : 0.0; }
};

struct LoopStats {
  LatencyHistogram wakeup;   ///< wake-up latency: actual wake/arrival minus expected [ns]
  LatencyHistogram compute;  ///< cycle work: wake-up to end of the cycle body [ns]
  std::uint64_t cycles = 0;          ///< cycles executed (state received / timer fired)
  std::uint64_t overruns = 0;        ///< cycle work longer than the period
  std::uint64_t missed = 0;          ///< timeouts waiting for the device, or timer periods skipped
  std::uint64_t packets_lost = 0;    ///< device packages lost (timestamp gaps, drained backlog)
  std::uint32_t max_consecutive_missed = 0;

  void recordCycle(std::int64_t wakeup_ns, std::int64_t compute_ns, std::int64_t period_ns) noexcept;
  void recordMissed() noexcept { ++missed; }
  void recordLost(std::uint64_t n) noexcept { packets_lost += n; }
  /// Multi-line human-readable summary (allocates: not for the loop).
  std::string summary(const char* title = "loop") const;
};

}  // namespace ftid::rt
