#pragma once
// Exponential backoff between connection attempts (ftidd's robot and sensor links, at start and
// after a link loss; docs/operations.md, "Link loss and reconnect"):
//
//   Backoff b({0.2, 5.0});
//   for (;;) { if (tryConnect()) { b.reset(); break; } sleep(b.next()); }   // 0.2, 0.4, ... 5, 5
//
// The k-th delay (k = 0, 1, ...) is min(min_s * factor^k, max_s): never below min_s, never above
// max_s, non-decreasing. Plain value type; not thread-safe.
#include <chrono>
#include <cstdint>

namespace ftid::daemon {

struct BackoffPolicy {
  double min_s = 0.2;   ///< first delay [s] (> 0)
  double max_s = 5.0;   ///< bound on every delay [s] (>= min_s)
  double factor = 2.0;  ///< growth per failed attempt (>= 1)
};

class Backoff {
 public:
  /// Out-of-range values are clamped (min_s to >= 1 ms, max_s to >= min_s, factor to >= 1); the
  /// daemon configuration has validated them already.
  explicit Backoff(BackoffPolicy policy = {}) noexcept;
  /// The delay before the next attempt; advances the sequence.
  std::chrono::nanoseconds next() noexcept;
  /// After a success: the next delay is min_s again.
  void reset() noexcept;
  /// Delays handed out since construction or the last reset().
  std::uint32_t attempts() const noexcept { return attempts_; }
  const BackoffPolicy& policy() const noexcept { return policy_; }

 private:
  BackoffPolicy policy_;
  double current_s_;
  std::uint32_t attempts_ = 0;
};

}  // namespace ftid::daemon
