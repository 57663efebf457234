#include "ftid/trajectory/fourier_trajectory.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace ftid::trajectory {

namespace {
constexpr double kTwoPi = 6.283185307179586;
}

FourierTrajectory::FourierTrajectory(const JointVector& q0, double f_base_hz, int harmonics, double duration_s,
                                     const std::array<std::array<double, kMaxHarmonics>, kNumJoints>& a,
                                     const std::array<std::array<double, kMaxHarmonics>, kNumJoints>& b)
    : q0_(q0), f_base_(f_base_hz), harmonics_(harmonics), duration_(duration_s), a_(a), b_(b) {
  if (harmonics < 1 || harmonics > kMaxHarmonics) {
    throw std::invalid_argument("FourierTrajectory: harmonics must be in 1.." + std::to_string(kMaxHarmonics) +
                                ", got " + std::to_string(harmonics));
  }
  if (!(f_base_hz > 0.0) || !std::isfinite(f_base_hz)) {
    throw std::invalid_argument("FourierTrajectory: base frequency must be positive and finite");
  }
  if (!(duration_s >= 0.0) || !std::isfinite(duration_s)) {
    throw std::invalid_argument("FourierTrajectory: duration must be non-negative and finite");
  }
  if (!q0.allFinite()) throw std::invalid_argument("FourierTrajectory: start pose q0 is not finite");
  const double w = kTwoPi * f_base_;
  for (int j = 0; j < kNumJoints; ++j) {
    double c = 0.0;
    for (int l = 0; l < kMaxHarmonics; ++l) {
      const auto ju = static_cast<std::size_t>(j);
      const auto lu = static_cast<std::size_t>(l);
      if (l >= harmonics_) {
        a_[ju][lu] = 0.0;
        b_[ju][lu] = 0.0;
        continue;
      }
      if (!std::isfinite(a_[ju][lu]) || !std::isfinite(b_[ju][lu])) {
        throw std::invalid_argument("FourierTrajectory: coefficient of joint " + std::to_string(j + 1) +
                                    ", harmonic " + std::to_string(l + 1) + " is not finite");
      }
      c += b_[ju][lu] / (w * (l + 1));
    }
    c_[j] = c;
  }
}

TrajectoryPoint FourierTrajectory::evaluate(double t_s) const noexcept {
  TrajectoryPoint p;
  p.q = q0_;
  if (harmonics_ == 0 || !(t_s >= 0.0) || t_s > duration_) return p;  // hold q0 at rest outside
  const double w = kTwoPi * f_base_;
  for (int l = 0; l < harmonics_; ++l) {
    const double wl = w * (l + 1);
    const double s = std::sin(wl * t_s);
    const double c = std::cos(wl * t_s);
    const auto lu = static_cast<std::size_t>(l);
    for (int j = 0; j < kNumJoints; ++j) {
      const auto ju = static_cast<std::size_t>(j);
      const double aj = a_[ju][lu];
      const double bj = b_[ju][lu];
      p.q[j] += (aj * s - bj * c) / wl;
      p.qd[j] += aj * c + bj * s;
      p.qdd[j] += wl * (-aj * s + bj * c);
    }
  }
  p.q += c_;
  return p;
}

}  // namespace ftid::trajectory
