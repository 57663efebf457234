// Plausibility of a parameter set against what the robot and the sensor can carry (issue 26).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include <Eigen/Eigenvalues>

#include "ftid/effects/rigid_body.hpp"
#include "ftid/params/parameter_set.hpp"

namespace ftid::params {
namespace {

std::string fmt(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

double valueOr(const ParameterSet& set, const char* name, double fallback) {
  for (const auto& p : set.params) {
    if (p.name == name) return p.value;
  }
  return fallback;
}

// The largest relative standard error of i_s_* for which an impossible estimate is projected: the
// tensor's scale at least 3 standard errors, the same "determined" rule as identify's for the mass
// (identify/physical_check.hpp).
constexpr double kProjectMaxRelStd = 1.0 / 3.0;

constexpr const char* kAxisKeys[6] = {"f0_x", "f0_y", "f0_z", "t0_x", "t0_y", "t0_z"};

}  // namespace

std::optional<ParameterProblem> findParameterProblem(const ParameterSet& set, const PlausibilityLimits& limits) {
  if (auto problem = findParameterProblem(set)) return problem;
  const double mass = valueOr(set, "mass", 0.0);
  if (mass > limits.max_payload_kg) {
    return ParameterProblem{"parameters.mass", "mass " + fmt(mass) + " kg exceeds the robot's rated payload " +
                                                   fmt(limits.max_payload_kg) + " kg (" + limits.payload_source +
                                                   "): not a payload this robot can carry"};
  }
  const double g = limits.gravity_mps2;
  const Vec3 mc(valueOr(set, "mass_com_x", 0.0), valueOr(set, "mass_com_y", 0.0), valueOr(set, "mass_com_z", 0.0));
  for (int a = 0; a < 6; ++a) {
    const double offset = std::abs(valueOr(set, kAxisKeys[a], 0.0));
    double load = 0.0;
    if (a < 3) {
      load = mass * g;
    } else {
      const int k = a - 3;
      load = g * std::hypot(mc((k + 1) % 3), mc((k + 2) % 3));
    }
    const double worst = offset + load;
    if (worst > limits.sensor_range(a)) {
      static constexpr const char* kAxes[6] = {"Fx", "Fy", "Fz", "Tx", "Ty", "Tz"};
      const char* unit = a < 3 ? " N" : " Nm";
      return ParameterProblem{
          a < 3 ? std::string("parameters.mass") : std::string("parameters.mass_com_") + "xyz"[(a - 3 + 1) % 3],
          std::string("the model's static wrench reaches |") + kAxes[a] + "| = " + fmt(worst) + unit +
              " (offset " + fmt(offset) + " + gravity load " + fmt(load) + ") in the worst orientation, beyond the "
              "sensor's rated range " + fmt(limits.sensor_range(a)) + unit + " (" + limits.range_source + ")"};
    }
  }
  return std::nullopt;
}

std::string projectInertiaWithinUncertainty(ParameterSet* set, std::string* refused) {
  if (!findParameterProblem(*set).has_value()) return {};
  auto refuse = [refused](const std::string& why) {
    if (refused != nullptr) *refused = why;
    return std::string();
  };
  NamedValue* mass = nullptr;
  NamedValue* h[3] = {nullptr, nullptr, nullptr};
  NamedValue* is[6] = {nullptr, nullptr, nullptr, nullptr, nullptr, nullptr};
  const char* h_names[3] = {"mass_com_x", "mass_com_y", "mass_com_z"};
  for (auto& p : set->params) {
    if (p.name == "mass") mass = &p;
    for (int k = 0; k < 3; ++k) {
      if (p.name == h_names[k]) h[k] = &p;
    }
    for (int k = 0; k < 6; ++k) {
      if (p.name == effects::kInertiaParamNames[k]) is[k] = &p;
    }
  }
  for (const NamedValue* v : is) {
    if (v == nullptr) return {};
  }
  if (mass == nullptr || !(mass->value > 0.0)) return {};
  // The estimate must be a measurement of the tensor, not noise around it: every i_s_* standard
  // error at most kProjectMaxRelStd of the estimated tensor's own scale (its largest |eigenvalue|).
  {
    Vec6 v6;
    double max_std = 0.0;
    for (int k = 0; k < 6; ++k) {
      v6(k) = is[k]->value;
      max_std = std::max(max_std, is[k]->std);
    }
    const double scale = Eigen::SelfAdjointEigenSolver<Mat3>(effects::inertiaMatrix(v6)).eigenvalues().cwiseAbs().maxCoeff();
    if (!(std::isfinite(max_std) && max_std <= kProjectMaxRelStd * scale)) {
      return refuse("not projected: the inertia's standard errors (up to " + fmt(max_std) + " kg*m^2) are not small "
                    "against the tensor's own scale (" + fmt(scale) + " kg*m^2; at most " +
                    fmt(100.0 * kProjectMaxRelStd) + " % allowed): the data do not determine the inertia");
    }
  }
  Eigen::Matrix<double, 10, 1> p = Eigen::Matrix<double, 10, 1>::Zero();
  Eigen::Matrix<double, 10, 10> cov = Eigen::Matrix<double, 10, 10>::Zero();
  p(0) = mass->value;
  cov(0, 0) = mass->std * mass->std;
  for (int k = 0; k < 3; ++k) {
    if (h[k] != nullptr) {
      p(1 + k) = h[k]->value;
      cov(1 + k, 1 + k) = h[k]->std * h[k]->std;
    }
  }
  for (int k = 0; k < 6; ++k) {
    p(4 + k) = is[k]->value;
    cov(4 + k, 4 + k) = is[k]->std * is[k]->std;
  }
  const effects::InertiaAboutCom ic = effects::inertiaAboutCom(p, cov);
  if (!ic.valid_within_uncertainty) {
    return refuse("not projected: no physically possible inertia within 3 standard errors of the estimate");
  }
  Eigen::SelfAdjointEigenSolver<Mat3> eig(effects::inertiaMatrix(ic.value));
  Vec3 l = eig.eigenvalues();
  const Mat3 R = eig.eigenvectors();
  for (int pass = 0; pass < 4; ++pass) {
    l = l.cwiseMax(0.0);
    int big = 0;
    l.maxCoeff(&big);
    const double excess = l(big) - (l.sum() - l(big));
    if (excess <= 0.0) break;
    // Projection onto the half-space l_big <= sum of the others (normal (-1, -1, 1) / sqrt 3).
    l = (l.array() + excess / 3.0).matrix();
    l(big) -= 2.0 * excess / 3.0;  // the others + excess / 3 each, l_big - excess / 3
  }
  const Vec3 c = p.segment<3>(1) / p(0);
  const Mat3 I_C = R * l.asDiagonal() * R.transpose();
  const Mat3 I_S = I_C + p(0) * (c.squaredNorm() * Mat3::Identity() - c * c.transpose());
  const Vec6 v = effects::inertiaVector(I_S);
  ParameterSet projected = *set;
  double max_sigmas = 0.0;
  for (int k = 0; k < 6; ++k) {
    for (auto& q : projected.params) {
      if (q.name == effects::kInertiaParamNames[k]) {
        if (q.std > 0.0) max_sigmas = std::max(max_sigmas, std::abs(v(k) - q.value) / q.std);
        q.value = v(k);
      }
    }
  }
  if (findParameterProblem(projected).has_value()) return refuse("not projected: the projection is not possible either");
  const std::string note = "inertia projected to the nearest physically possible tensor (principal moments " +
                           fmt(ic.principal(0)) + ", " + fmt(ic.principal(1)) + ", " + fmt(ic.principal(2)) +
                           " -> " + fmt(l(0)) + ", " + fmt(l(1)) + ", " + fmt(l(2)) + " kg*m^2 about the centre of "
                           "mass; i_s_* moved by at most " + fmt(max_sigmas) + " standard errors)";
  projected.provenance.method += (projected.provenance.method.empty() ? "" : "; ") + note;
  *set = std::move(projected);
  return note;
}

}  // namespace ftid::params
