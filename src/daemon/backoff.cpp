#include "ftid/daemon/backoff.hpp"

#include <algorithm>
#include <cmath>

namespace ftid::daemon {

Backoff::Backoff(BackoffPolicy policy) noexcept : policy_(policy) {
  if (!(policy_.min_s >= 1e-3)) policy_.min_s = 1e-3;  // also catches NaN
  if (!(policy_.max_s >= policy_.min_s)) policy_.max_s = policy_.min_s;
  if (!(policy_.factor >= 1.0)) policy_.factor = 1.0;
  current_s_ = policy_.min_s;
}

std::chrono::nanoseconds Backoff::next() noexcept {
  const double d = std::min(current_s_, policy_.max_s);
  current_s_ = std::min(current_s_ * policy_.factor, policy_.max_s);
  ++attempts_;
  return std::chrono::nanoseconds(static_cast<std::int64_t>(std::llround(d * 1e9)));
}

void Backoff::reset() noexcept {
  current_s_ = policy_.min_s;
  attempts_ = 0;
}

}  // namespace ftid::daemon
