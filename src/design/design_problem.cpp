// The designer's optimisation problem (design_problem.hpp): sampling the Fourier coefficients x at
// the design samples, the joint and workspace constraints aggregated by a Kreisselmeier-Steinhauser
// soft maximum (max_t g(t) <= KS(g) <= max_t g(t) + ln(K)/kKsRho, so KS <= 0 holds only when every
// sample satisfies its constraint), the objective (log10 condition number, D-optimality of the
// information matrix, or the soft maximum of predicted std / target), the scaling of a point into
// the feasible set, the per-stage budget and the progress line.
#include "design_problem.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ostream>

#include "ftid/effects/model.hpp"

namespace ftid::design::internal {

std::string fmt(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

std::vector<double> randomDirection(std::mt19937_64& rng, int n) {
  std::vector<double> x(static_cast<std::size_t>(n));
  for (double& v : x) v = 2.0 * uniform01(rng) - 1.0;
  return x;
}

double SoftMax::value() const {
  if (values_.empty()) return -1.0;
  double m = -kInf;
  for (double v : values_) {
    if (std::isnan(v)) return kInf;
    m = std::max(m, v);
  }
  if (!std::isfinite(m)) return m;
  double s = 0.0;
  for (double v : values_) s += std::exp(kKsRho * (v - m));
  return m + std::log(s) / kKsRho;
}

Problem::Problem(const DesignOptions& opt, const model::RobotKinematics& kin)
    : opt_(opt),
      param_(opt.q0, opt.joints, opt.harmonics, static_cast<double>(opt.periods) / opt.duration_s,
             opt.duration_s, opt.constraints),
      metric_(effects::Model::fromName(opt.model), kin, opt.constraints,
              opt.nominal.empty() ? defaultNominalParameters() : opt.nominal, opt.noise_sigma),
      start_(Clock::now()) {
  int K = opt.design_samples;
  if (K <= 0) K = std::max(120, 30 * opt.harmonics * opt.periods);
  param_.prepareSampling(K);
  represented_ = opt.duration_s * opt.servo_rate_hz;
  weight_ = represented_ / K;
  // Joint limits tightened by the margin, about q0.
  const auto& c = opt.constraints;
  for (int j : param_.joints()) {
    const int i = j - 1;
    const double m = 1.0 - opt.constraint_margin;
    up_.push_back((c.position_upper[i] - opt.q0[i]) * m);
    lo_.push_back((opt.q0[i] - c.position_lower[i]) * m);
    vel_.push_back(c.velocity[i] * m);
    acc_.push_back(c.acceleration[i] * m);
  }
  num_constraints_ = 4 * static_cast<int>(param_.joints().size()) +
                     static_cast<int>(c.tool.size() * (1 + c.keep_out.size()));
}

double Problem::jointScaleLimit(const std::vector<double>& x) const {
  SampledMotion mo;
  param_.sample(x.data(), mo);
  double s = kInf;
  const auto& joints = param_.joints();
  for (std::size_t k = 0; k < joints.size(); ++k) {
    const int i = joints[k] - 1;
    for (Eigen::Index t = 0; t < mo.q.cols(); ++t) {
      const double dq = mo.q(i, t) - opt_.q0[i];
      if (dq > 0.0) s = std::min(s, up_[k] / dq);
      if (dq < 0.0) s = std::min(s, lo_[k] / -dq);
      if (mo.qd(i, t) != 0.0) s = std::min(s, vel_[k] / std::abs(mo.qd(i, t)));
      if (mo.qdd(i, t) != 0.0) s = std::min(s, acc_[k] / std::abs(mo.qdd(i, t)));
    }
  }
  return s;
}

std::vector<double> Problem::makeFeasible(std::vector<double> x, double s_cap) {
  double s = std::min(s_cap, jointScaleLimit(x));
  if (!std::isfinite(s)) s = 0.0;
  auto scaled = [&](double f) {
    std::vector<double> y(x);
    for (double& v : y) v *= f;
    return y;
  };
  if (!evaluateConstraintsOnly(scaled(s))) {
    double lo = 0.0, hi = s;
    for (int it = 0; it < 30; ++it) {
      const double mid = 0.5 * (lo + hi);
      (evaluateConstraintsOnly(scaled(mid)) ? lo : hi) = mid;
    }
    s = lo;
  }
  return scaled(s);
}

const Evaluation& Problem::evaluate(const double* x) {
  const auto nn = static_cast<std::size_t>(n());
  if (have_cache_ && std::equal(x, x + nn, cache_x_.begin())) return cache_;
  if (stage_max_evals_ > 0 && stage_evals_ >= stage_max_evals_) throw BudgetSpent{};
  if (elapsed() > stage_deadline_) throw BudgetSpent{};
  cache_x_.assign(x, x + nn);
  cache_ = compute(x, true);
  have_cache_ = true;
  ++evals_;
  ++stage_evals_;
  if (cache_.feasible && cache_.objective < best_f_) {
    best_f_ = cache_.objective;
    best_cond_ = cache_.condition;
    best_x_ = cache_x_;
  }
  printProgress(false);
  return cache_;
}

double Problem::progressValue() const {
  switch (opt_.objective) {
    case Objective::kCondition:
      return best_cond_;
    case Objective::kLimits:
      return std::pow(10.0, best_f_);
    case Objective::kDOptimality:
      break;
  }
  return best_f_;
}

void Problem::printProgress(bool force) {
  if (opt_.progress == nullptr) return;
  const double now = elapsed();
  if (!force && now - last_print_ < 1.0) return;
  last_print_ = now;
  const double left = std::max(0.0, opt_.time_budget_s - now);
  char buf[256];
  std::snprintf(
      buf, sizeof buf,
      "design [%s] eval %ld | best %s %s | elapsed %.1f s | remaining %.1f s (budget)\n",
      stage_.c_str(), evals_,
      opt_.objective == Objective::kLimits ? "predicted std/target" : objectiveName(opt_.objective),
      std::isfinite(best_f_) ? fmt(progressValue()).c_str() : "(none feasible yet)",
      now, left);
  *opt_.progress << buf << std::flush;
}

Eigen::MatrixXd Problem::information(const std::vector<double>& x) const {
  SampledMotion mo;
  param_.sample(x.data(), mo);
  return metric_.information(mo, weight_);
}

double Problem::limitObjective(const Eigen::MatrixXd& info) const {
  const Eigen::MatrixXd full =
      opt_.targets_with_imu ? metric_.informationWithImu(motion_, info, opt_.imu_acc_std, opt_.imu_gyro_std, weight_)
                            : info;
  const auto predicted = metric_.predictedStd(full);
  if (predicted.empty()) return kPenalty;
  // The worst ratio predicted std / target, as a smooth soft maximum: the p-norm of the ratios
  // (max <= norm <= K^(1/p) max, so within 2^(1/kLimitNormP) of the max for up to two ties).
  double worst = 0.0;
  for (const auto& [key, target] : opt_.limit_targets) {
    const auto it = predicted.find(key);
    if (it == predicted.end() || !std::isfinite(it->second)) return kPenalty;
    worst = std::max(worst, it->second / target);
  }
  if (!(worst > 0.0)) return kPenalty;
  double sum = 0.0;
  for (const auto& [key, target] : opt_.limit_targets) sum += std::pow(predicted.at(key) / target / worst, kLimitNormP);
  return std::log10(worst) + std::log10(sum) / kLimitNormP;
}

Evaluation Problem::compute(const double* x, bool with_objective) {
  Evaluation e;
  param_.sample(x, motion_);
  const auto K = motion_.q.cols();
  const auto& c = opt_.constraints;
  SoftMax ks;
  const auto& joints = param_.joints();
  for (std::size_t k = 0; k < joints.size(); ++k) {
    const int i = joints[k] - 1;
    const double q0 = opt_.q0[i];
    ks.clear();
    for (Eigen::Index t = 0; t < K; ++t) ks.add((motion_.q(i, t) - q0) / up_[k] - 1.0);
    e.g.push_back(ks.value());
    ks.clear();
    for (Eigen::Index t = 0; t < K; ++t) ks.add((q0 - motion_.q(i, t)) / lo_[k] - 1.0);
    e.g.push_back(ks.value());
    ks.clear();
    for (Eigen::Index t = 0; t < K; ++t) {
      ks.add(motion_.qd(i, t) / vel_[k] - 1.0);
      ks.add(-motion_.qd(i, t) / vel_[k] - 1.0);
    }
    e.g.push_back(ks.value());
    ks.clear();
    for (Eigen::Index t = 0; t < K; ++t) {
      ks.add(motion_.qdd(i, t) / acc_[k] - 1.0);
      ks.add(-motion_.qdd(i, t) / acc_[k] - 1.0);
    }
    e.g.push_back(ks.value());
  }
  Eigen::MatrixXd info;
  if (with_objective || !c.tool.empty()) {
    info = metric_.information(motion_, weight_, &poses_);
  }
  for (const auto& tool : c.tool) {
    ks.clear();
    for (const auto& X : poses_)
      ks.add((c.floor_z_B + tool.radius - (X * tool.center_S).z()) / kWorkspaceScale);
    e.g.push_back(ks.value());
    for (const auto& ko : c.keep_out) {
      ks.clear();
      for (const auto& X : poses_) {
        ks.add((ko.radius + tool.radius - ((X * tool.center_S) - ko.center_B).norm()) /
               kWorkspaceScale);
      }
      e.g.push_back(ks.value());
    }
  }
  e.feasible = std::all_of(e.g.begin(), e.g.end(), [](double v) { return v <= 0.0; });
  if (with_objective) {
    e.condition = ExcitationMetric::conditionNumber(info);
    if (opt_.objective == Objective::kCondition) {
      e.objective = std::isfinite(e.condition) ? std::log10(e.condition) : kPenalty;
    } else if (opt_.objective == Objective::kLimits) {
      e.objective = limitObjective(info);
    } else {
      const double d = ExcitationMetric::dOptimality(info, represented_);
      e.objective = std::isfinite(d) ? d : kPenalty;
    }
  }
  return e;
}

}  // namespace ftid::design::internal
