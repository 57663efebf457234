#pragma once
// Finite Fourier series excitation trajectory (paper Eq. 47-49) about a start pose q0:
//   q_i(t)   = q0_i + sum_{l=1..N} [ a_il/(w l) sin(w l t) - b_il/(w l) cos(w l t) ] + c_i
//   qd_i(t)  = sum_l [ a_il cos(w l t) + b_il sin(w l t) ]
//   qdd_i(t) = sum_l w l [ -a_il sin(w l t) + b_il cos(w l t) ]
// with w = 2 pi f_base and c_i = sum_l b_il/(w l) so that q(0) = q0. Joints that are not excited
// stay at q0. Rest-to-rest (qd = qdd = 0 at t = 0 and t = duration) holds when
// sum_l a_il = 0 and sum_l l b_il = 0 and duration is a whole number of base periods.
// evaluate() is real-time safe (no allocation); outside [0, duration] it holds q0 at rest.
#include <array>
#include <vector>

#include "ftid/common/types.hpp"

namespace ftid::trajectory {

struct TrajectoryPoint {
  JointVector q = JointVector::Zero();
  JointVector qd = JointVector::Zero();
  JointVector qdd = JointVector::Zero();
};

class FourierTrajectory {
 public:
  static constexpr int kMaxHarmonics = 16;

  FourierTrajectory() = default;
  /// a, b: [joint][harmonic] coefficients (harmonics beyond `harmonics` ignored).
  /// Throws std::invalid_argument for harmonics outside 1..kMaxHarmonics or non-positive f_base.
  FourierTrajectory(const JointVector& q0, double f_base_hz, int harmonics, double duration_s,
                    const std::array<std::array<double, kMaxHarmonics>, kNumJoints>& a,
                    const std::array<std::array<double, kMaxHarmonics>, kNumJoints>& b);

  TrajectoryPoint evaluate(double t_s) const noexcept;

  const JointVector& startPose() const noexcept { return q0_; }
  double baseFrequency() const noexcept { return f_base_; }
  int harmonics() const noexcept { return harmonics_; }
  double duration() const noexcept { return duration_; }
  double a(int joint, int harmonic) const noexcept { return a_[joint][harmonic]; }
  double b(int joint, int harmonic) const noexcept { return b_[joint][harmonic]; }

 private:
  JointVector q0_ = JointVector::Zero();
  JointVector c_ = JointVector::Zero();
  double f_base_ = 0.1;
  int harmonics_ = 0;
  double duration_ = 0.0;
  std::array<std::array<double, kMaxHarmonics>, kNumJoints> a_{};
  std::array<std::array<double, kMaxHarmonics>, kNumJoints> b_{};
};

}  // namespace ftid::trajectory
