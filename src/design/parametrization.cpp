// Rest-to-rest Fourier parametrisation: elimination of the dependent coefficients (see header and
// docs/design.md) and fast sampling through a precomputed harmonic basis.
#include "ftid/design/parametrization.hpp"

#include <algorithm>
#include <cmath>
#include <set>
#include <string>

#include "ftid/common/error.hpp"

namespace ftid::design {

namespace {
constexpr double kTwoPi = 6.283185307179586;

std::string fmt(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}
}  // namespace

RestToRestParametrization::RestToRestParametrization(
    const JointVector& q0, std::vector<int> joints, int harmonics, double base_frequency_hz,
    double duration_s, const trajectory::TrajectoryConstraints& limits)
    : q0_(q0),
      joints_(std::move(joints)),
      harmonics_(harmonics),
      f_base_(base_frequency_hz),
      duration_(duration_s) {
  if (joints_.empty()) throw ConfigError("joints: at least one joint must be excited");
  std::set<int> seen;
  for (int j : joints_) {
    if (j < 1 || j > kNumJoints)
      throw ConfigError("joints: joint numbers are 1..6, got " + std::to_string(j));
    if (!seen.insert(j).second)
      throw ConfigError("joints: joint " + std::to_string(j) + " listed twice");
  }
  if (harmonics_ < 2 || harmonics_ > trajectory::FourierTrajectory::kMaxHarmonics) {
    throw ConfigError("harmonics: need 2.." +
                      std::to_string(trajectory::FourierTrajectory::kMaxHarmonics) +
                      " (rest-to-rest fixes the first harmonic, so N = 1 cannot move), got " +
                      std::to_string(harmonics_));
  }
  if (!(f_base_ > 0.0) || !std::isfinite(f_base_))
    throw ConfigError("base frequency must be positive");
  if (!(duration_ > 0.0) || !std::isfinite(duration_))
    throw ConfigError("duration must be positive");
  const double periods = duration_ * f_base_;
  if (std::abs(periods - std::round(periods)) > 1e-9 || std::round(periods) < 1.0) {
    throw ConfigError("duration " + fmt(duration_) +
                      " s is not a whole number of base periods (base frequency " + fmt(f_base_) +
                      " Hz): rest-to-rest needs duration * base frequency to be an integer");
  }
  if (!q0_.allFinite()) throw ConfigError("q0 is not finite");
  const double w = kTwoPi * f_base_;
  for (int j : joints_) {
    const int i = j - 1;
    const double range =
        std::min(limits.position_upper[i] - q0_[i], q0_[i] - limits.position_lower[i]);
    if (!(range > 0.0)) {
      throw ConfigError("q0: joint " + std::to_string(j) + " start angle " + fmt(q0_[i]) +
                        " rad is not strictly inside its position limits [" +
                        fmt(limits.position_lower[i]) + ", " + fmt(limits.position_upper[i]) +
                        "] rad");
    }
    if (!(limits.velocity[i] > 0.0) || !(limits.acceleration[i] > 0.0)) {
      throw ConfigError("limits: joint " + std::to_string(j) +
                        " needs positive velocity and acceleration limits");
    }
    for (int kind = 0; kind < 2; ++kind) {
      for (int l = 2; l <= harmonics_; ++l) {
        const double wl = w * l;
        scales_.push_back(std::min({limits.velocity[i], limits.acceleration[i] / wl, range * wl}));
      }
    }
  }
}

void RestToRestParametrization::coefficients(const double* x, Coefficients& a,
                                             Coefficients& b) const {
  for (auto& row : a) row.fill(0.0);
  for (auto& row : b) row.fill(0.0);
  const int n = harmonics_;
  int k = 0;
  for (int j : joints_) {
    const auto ju = static_cast<std::size_t>(j - 1);
    double sum_a = 0.0, sum_lb = 0.0;
    for (int l = 2; l <= n; ++l, ++k) {
      const double v = scales_[static_cast<std::size_t>(k)] * x[k];
      a[ju][static_cast<std::size_t>(l - 1)] = v;
      sum_a += v;
    }
    for (int l = 2; l <= n; ++l, ++k) {
      const double v = scales_[static_cast<std::size_t>(k)] * x[k];
      b[ju][static_cast<std::size_t>(l - 1)] = v;
      sum_lb += l * v;
    }
    a[ju][0] = -sum_a;   // qd(0) = sum_l a_l = 0
    b[ju][0] = -sum_lb;  // qdd(0) = w sum_l l b_l = 0
  }
}

std::vector<double> RestToRestParametrization::variables(const Coefficients& a,
                                                         const Coefficients& b) const {
  std::vector<double> x;
  x.reserve(static_cast<std::size_t>(numVariables()));
  std::size_t k = 0;
  for (int j : joints_) {
    const auto ju = static_cast<std::size_t>(j - 1);
    for (int l = 2; l <= harmonics_; ++l)
      x.push_back(a[ju][static_cast<std::size_t>(l - 1)] / scales_[k++]);
    for (int l = 2; l <= harmonics_; ++l)
      x.push_back(b[ju][static_cast<std::size_t>(l - 1)] / scales_[k++]);
  }
  return x;
}

trajectory::FourierTrajectory RestToRestParametrization::trajectory(const double* x) const {
  Coefficients a, b;
  coefficients(x, a, b);
  return trajectory::FourierTrajectory(q0_, f_base_, harmonics_, duration_, a, b);
}

void RestToRestParametrization::prepareSampling(int num_samples) {
  if (num_samples < 2) throw ConfigError("design sampling needs at least 2 samples");
  const auto K = static_cast<Eigen::Index>(num_samples);
  times_.resize(static_cast<std::size_t>(num_samples));
  const double w = kTwoPi * f_base_;
  b_qa_.resize(harmonics_, K);
  b_qb_.resize(harmonics_, K);
  b_va_.resize(harmonics_, K);
  b_vb_.resize(harmonics_, K);
  b_aa_.resize(harmonics_, K);
  b_ab_.resize(harmonics_, K);
  for (Eigen::Index k = 0; k < K; ++k) {
    const double t = duration_ * static_cast<double>(k) / static_cast<double>(K);
    times_[static_cast<std::size_t>(k)] = t;
    for (int l = 1; l <= harmonics_; ++l) {
      const double wl = w * l;
      const double s = std::sin(wl * t), c = std::cos(wl * t);
      b_qa_(l - 1, k) = s / wl;
      b_qb_(l - 1, k) = (1.0 - c) / wl;
      b_va_(l - 1, k) = c;
      b_vb_(l - 1, k) = s;
      b_aa_(l - 1, k) = -wl * s;
      b_ab_(l - 1, k) = wl * c;
    }
  }
}

void RestToRestParametrization::sample(const double* x, SampledMotion& out) const {
  const auto K = static_cast<Eigen::Index>(times_.size());
  out.t = times_;
  out.q.resize(kNumJoints, K);
  out.qd.resize(kNumJoints, K);
  out.qdd.resize(kNumJoints, K);
  for (int i = 0; i < kNumJoints; ++i) {
    out.q.row(i).setConstant(q0_[i]);
  }
  out.qd.setZero();
  out.qdd.setZero();
  Coefficients a, b;
  coefficients(x, a, b);
  Eigen::VectorXd ca(harmonics_), cb(harmonics_);
  for (int j : joints_) {
    const auto ju = static_cast<std::size_t>(j - 1);
    for (int l = 0; l < harmonics_; ++l) {
      ca[l] = a[ju][static_cast<std::size_t>(l)];
      cb[l] = b[ju][static_cast<std::size_t>(l)];
    }
    out.q.row(j - 1).noalias() += ca.transpose() * b_qa_ + cb.transpose() * b_qb_;
    out.qd.row(j - 1).noalias() += ca.transpose() * b_va_ + cb.transpose() * b_vb_;
    out.qdd.row(j - 1).noalias() += ca.transpose() * b_aa_ + cb.transpose() * b_ab_;
  }
}

}  // namespace ftid::design
