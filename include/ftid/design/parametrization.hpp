#pragma once
// Rest-to-rest Fourier parametrisation of an excitation trajectory (docs/design.md
// §Parametrisation).
//
// Joint i (excited) follows paper Eq. 47-49 about q0 (ftid/trajectory/fourier_trajectory.hpp):
//   q_i(t)   = q0_i + sum_{l=1..N} [ a_il/(w l) sin(w l t) + b_il/(w l) (1 - cos(w l t)) ]
//   qd_i(t)  = sum_l [ a_il cos(w l t) + b_il sin(w l t) ]
//   qdd_i(t) = sum_l w l [ -a_il sin(w l t) + b_il cos(w l t) ]
// q(0) = q0 holds by construction, and with a duration of whole base periods q(T) = q0,
// qd(T) = qd(0), qdd(T) = qdd(0). Rest-to-rest then needs exactly two linear conditions per joint:
//   qd_i(0)  = sum_l a_il     = 0   =>  a_i1 = - sum_{l>=2} a_il
//   qdd_i(0) = w sum_l l b_il = 0   =>  b_i1 = - sum_{l>=2} l b_il
// The dependent first-harmonic coefficients are eliminated, so every point of the 2 (N-1) J
// dimensional search space is exactly rest-to-rest (no equality constraints for the optimiser).
// The free coefficients are scaled to x in [-1, 1]: a_il = s_il x, with the single-harmonic bound
//   s_il = min( v_i, a_max_i / (w l), r_i w l ),   r_i = min(q_upper_i - q0_i, q0_i - q_lower_i)
// (a lone harmonic of amplitude s_il stays within that joint's limits).
#include <array>
#include <vector>

#include "ftid/common/types.hpp"
#include "ftid/trajectory/fourier_trajectory.hpp"
#include "ftid/trajectory/trajectory_io.hpp"

namespace ftid::design {

using Coefficients =
    std::array<std::array<double, trajectory::FourierTrajectory::kMaxHarmonics>, kNumJoints>;

/// q, qd, qdd of all six joints at K sample times (6 x K each).
struct SampledMotion {
  std::vector<double> t;
  Eigen::Matrix<double, kNumJoints, Eigen::Dynamic> q, qd, qdd;
};

class RestToRestParametrization {
 public:
  /// joints: 1-based, distinct, in 1..6. harmonics >= 2 (N = 1 leaves no free coefficient).
  /// duration_s must be periods / base_frequency_hz for an integer periods >= 1.
  /// Throws ConfigError with a clear message on invalid input.
  RestToRestParametrization(const JointVector& q0, std::vector<int> joints, int harmonics,
                            double base_frequency_hz, double duration_s,
                            const trajectory::TrajectoryConstraints& limits);

  int numVariables() const { return static_cast<int>(joints_.size()) * 2 * (harmonics_ - 1); }
  const std::vector<int>& joints() const { return joints_; }
  int harmonics() const { return harmonics_; }
  double baseFrequency() const { return f_base_; }
  double duration() const { return duration_; }
  const JointVector& startPose() const { return q0_; }
  /// Scale s_k of variable k (coefficient = s_k x_k), [rad/s].
  const std::vector<double>& scales() const { return scales_; }

  /// x (numVariables) -> full coefficient tables, dependent coefficients filled in.
  void coefficients(const double* x, Coefficients& a, Coefficients& b) const;
  /// Inverse on the free coefficients (the dependent ones are ignored).
  std::vector<double> variables(const Coefficients& a, const Coefficients& b) const;
  trajectory::FourierTrajectory trajectory(const double* x) const;

  /// Precomputes the harmonic basis at K uniformly spaced times t_k = k T / K (k = 0..K-1; t = T
  /// repeats t = 0 for a periodic trajectory).
  void prepareSampling(int num_samples);
  int numSamples() const { return static_cast<int>(times_.size()); }
  /// Fills `out` (sized on first use) with the motion at the prepared sample times. O(6 N K).
  void sample(const double* x, SampledMotion& out) const;

 private:
  JointVector q0_;
  std::vector<int> joints_;  ///< 1-based
  int harmonics_;
  double f_base_;
  double duration_;
  std::vector<double> scales_;
  std::vector<double> times_;
  // basis (N x K): sin(wlt)/(wl), (1-cos(wlt))/(wl), cos, sin, -wl sin, wl cos
  Eigen::MatrixXd b_qa_, b_qb_, b_va_, b_vb_, b_aa_, b_ab_;
};

}  // namespace ftid::design
