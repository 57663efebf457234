#include "ftid/rt/loop_stats.hpp"

#include <cstdio>

namespace ftid::rt {

void LatencyHistogram::add(std::int64_t ns) noexcept {
  if (ns < 0) ns = 0;
  const std::int64_t us = ns / 1000;
  if (us < kBins) {
    ++bins[static_cast<std::size_t>(us)];
  } else {
    ++overflow;
  }
  if (count == 0 || ns > max_ns) max_ns = ns;
  if (count == 0 || ns < min_ns) min_ns = ns;
  ++count;
  sum_ns += static_cast<double>(ns);
}

std::int64_t LatencyHistogram::quantileNs(double p) const noexcept {
  if (count == 0) return 0;
  const double target = p * static_cast<double>(count);
  std::uint64_t acc = 0;
  for (int i = 0; i < kBins; ++i) {
    acc += bins[static_cast<std::size_t>(i)];
    if (static_cast<double>(acc) >= target && acc > 0) {
      const std::int64_t edge = static_cast<std::int64_t>(i + 1) * 1000;
      return edge < max_ns ? edge : max_ns;
    }
  }
  return max_ns;
}

void LoopStats::recordCycle(std::int64_t wakeup_ns, std::int64_t compute_ns, std::int64_t period_ns) noexcept {
  ++cycles;
  wakeup.add(wakeup_ns);
  compute.add(compute_ns);
  if (compute_ns > period_ns) ++overruns;
}

std::string LoopStats::summary(const char* title) const {
  auto line = [](const char* name, const LatencyHistogram& h) {
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "  %-8s n=%llu mean=%.1f us p50=%.0f us p99=%.0f us p99.9=%.0f us max=%.1f us (>2 ms: %llu)\n",
                  name, static_cast<unsigned long long>(h.count), h.meanNs() / 1e3,
                  static_cast<double>(h.quantileNs(0.5)) / 1e3, static_cast<double>(h.quantileNs(0.99)) / 1e3,
                  static_cast<double>(h.quantileNs(0.999)) / 1e3, static_cast<double>(h.max_ns) / 1e3,
                  static_cast<unsigned long long>(h.overflow));
    return std::string(buf);
  };
  char head[256];
  std::snprintf(head, sizeof head, "%s: %llu cycles, %llu overruns, %llu missed, %llu packets lost\n", title,
                static_cast<unsigned long long>(cycles), static_cast<unsigned long long>(overruns),
                static_cast<unsigned long long>(missed), static_cast<unsigned long long>(packets_lost));
  return head + line("wake-up", wakeup) + line("compute", compute);
}

}  // namespace ftid::rt
