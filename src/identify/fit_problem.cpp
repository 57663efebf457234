// The general fit's problem (fit_problem.hpp).
#include "fit_problem.hpp"

#include <algorithm>
#include <string>
#include <vector>

#include "ftid/common/error.hpp"
#include "ftid/identify/noise.hpp"
#include "ftid/model/frames.hpp"

namespace ftid::identify::internal {

using effects::kSignalModelWrench;

Problem::Problem(const Model& m, const std::vector<SampleContext>& c, const std::vector<int>& idx)
    : model(m), contexts(c), indices(idx), n(static_cast<int>(idx.size())), p(m.numParams()),
      mounting(m.estimatesMounting()), delay(m.estimatesDelay()),
      reads_wmodel((m.signals() & kSignalModelWrench) != 0),
      derived_col(static_cast<std::size_t>(m.numParams()), 0),
      derived_effects(effects::modelWrenchEffects(m)),
      active(static_cast<std::size_t>(idx.size()), 1), n_active(static_cast<int>(idx.size())) {
  for (const auto& e : m.effectList()) {
    if ((e->signals() & kSignalModelWrench) == 0) continue;
    for (const auto& info : e->params()) {
      const int col = m.paramIndex().column(info.name);
      if (col >= 0) derived_col[static_cast<std::size_t>(col)] = 1;
    }
  }
}

void Problem::prepare(int i, const NonlinearParams& nl, const Vec3& g_B, const Mat3& R_SM, SampleContext* c) const {
  *c = at(i);
  if (delay && nl.delay_s != 0.0) {
    const double ts = std::clamp(c->t - nl.delay_s, at(0).t, at(n - 1).t);
    effects::kinematicsAt([this](int k) -> const SampleContext& { return at(k); }, n, ts, c);
  }
  if (mounting) effects::applyMounting(R_SM, c);
  if (override_gravity) c->g_S = c->R_BS.transpose() * g_B;
}

void Problem::setActiveWindow(double lo, double hi) {
  n_active = 0;
  for (int i = 0; i < n; ++i) {
    const double t = at(i).t;
    const bool ok = !delay || (t - hi >= at(0).t - 1e-9 && t - lo <= at(n - 1).t + 1e-9);
    active[static_cast<std::size_t>(i)] = ok ? 1 : 0;
    n_active += ok ? 1 : 0;
  }
}

void Problem::buildRegressor(const NonlinearParams& nl, const Vec6& weights, Eigen::MatrixXd* A,
                    bool with_derived, Eigen::VectorXd* rhs) const {
  A->resize(6 * n, p);
  const bool gn = with_derived && reads_wmodel && gn_theta.size() == p;
  if (rhs != nullptr) rhs->setZero(6 * n);
  const Vec3 g_B = model::gravityInBase(nl.tilt_u_rad, nl.tilt_v_rad);
  const Mat3 R_SM = effects::mountingRotation(nl.mount_rpy_rad);
  Eigen::Matrix<double, 6, Eigen::Dynamic> Y(6, p);
  Eigen::Matrix<double, 6, Eigen::Dynamic> Y2(6, p);
  SampleContext c;
  for (int i = 0; i < n; ++i) {
    if (!active[static_cast<std::size_t>(i)]) {
      A->middleRows(6 * i, 6).setZero();
      continue;
    }
    prepare(i, nl, g_B, R_SM, &c);
    c.wrench_model_S = (reads_wmodel && with_derived) ? wmodel[static_cast<std::size_t>(i)] : Wrench::Zero();
    model.computeRegressor(c, Y);
    if (gn) {
      // E0 as a 6 x 6 matrix for this sample: the derived effects are linear in wrench_model_S,
      // so column k is their contribution with wrench_model_S = e_k (only those effects run).
      const Mat6 E0 = effects::modelWrenchMap(derived_effects, c, gn_theta, Y2);
      const Wrench shift = E0 * wmodel[static_cast<std::size_t>(i)];
      for (int j = 0; j < p; ++j) {
        if (!derived_col[static_cast<std::size_t>(j)]) Y.col(j) += E0 * Y.col(j);
      }
      if (rhs != nullptr) rhs->segment<6>(6 * i) = weights.cwiseProduct(shift);
    }
    A->middleRows(6 * i, 6) = weights.asDiagonal() * Y;
  }
}

Eigen::VectorXd Problem::weightedMeasurement(const Vec6& weights) const {
  Eigen::VectorXd yw(6 * n);
  for (int i = 0; i < n; ++i) {
    yw.segment<6>(6 * i) = active[static_cast<std::size_t>(i)] ? Vec6(weights.cwiseProduct(y.segment<6>(6 * i)))
                                                               : Vec6::Zero();
  }
  return yw;
}

Mat6X Problem::predict(const Eigen::VectorXd& theta, const NonlinearParams& nl) const {
  const Vec3 g_B = model::gravityInBase(nl.tilt_u_rad, nl.tilt_v_rad);
  const Mat3 R_SM = effects::mountingRotation(nl.mount_rpy_rad);
  effects::ModelEvaluator eval(model, theta);
  Mat6X out(6, n);
  SampleContext c;
  for (int i = 0; i < n; ++i) {
    prepare(i, nl, g_B, R_SM, &c);
    out.col(i) = eval.evaluate(c);
  }
  return out;
}

std::vector<Wrench> Problem::basePrediction(const Eigen::VectorXd& theta, const NonlinearParams& nl) const {
  const Mat6X w = predictWithoutDerived(theta, nl);
  std::vector<Wrench> out(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) out[static_cast<std::size_t>(i)] = w.col(i);
  return out;
}

Mat6X Problem::predictWithoutDerived(const Eigen::VectorXd& theta, const NonlinearParams& nl) const {
  const Vec3 g_B = model::gravityInBase(nl.tilt_u_rad, nl.tilt_v_rad);
  const Mat3 R_SM = effects::mountingRotation(nl.mount_rpy_rad);
  Eigen::Matrix<double, 6, Eigen::Dynamic> Y(6, p);
  Mat6X out(6, n);
  SampleContext c;
  for (int i = 0; i < n; ++i) {
    prepare(i, nl, g_B, R_SM, &c);
    c.wrench_model_S.setZero();
    model.computeRegressor(c, Y);
    out.col(i) = Y * theta;
  }
  return out;
}

LinearSolution solveLinear(const Eigen::MatrixXd& A, const Eigen::VectorXd& yw) {
  LinearSolution s;
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
  s.theta = qr.solve(yw);
  s.residual = yw - A * s.theta;
  return s;
}

double nonFiniteProbe(const SampleContext& c) {
  return (c.wrench_S.array() * 0.0).sum() + (c.R_BS.array() * 0.0).sum() + (c.w_S.array() * 0.0).sum() +
         (c.alpha_S.array() * 0.0).sum() + (c.a_S.array() * 0.0).sum() + (c.g_S.array() * 0.0).sum() +
         c.t * 0.0 + c.t_model * 0.0 + (c.imu_acc_S.array() * 0.0).sum() + (c.imu_w_S.array() * 0.0).sum() +
         (c.imu_alpha_S.array() * 0.0).sum() + c.temp_degC * 0.0;
}

void checkFinite(const Problem& pb) {
  double zero = 0.0;
  for (int i = 0; i < pb.n; ++i) zero += nonFiniteProbe(pb.at(i));
  if (zero == 0.0) return;
  // Name the first sample with a non-finite value.
  for (int i = 0; i < pb.n; ++i) {
    const SampleContext& c = pb.at(i);
    if (nonFiniteProbe(c) != 0.0) {
      throw DataError("sample " + std::to_string(pb.indices[static_cast<std::size_t>(i)]) +
                      " (t = " + std::to_string(c.t) + " s) has a non-finite value");
    }
  }
}

Mat6X unstack(const Eigen::VectorXd& v, int n) {
  return Eigen::Map<const Mat6X>(v.data(), 6, n);
}

void checkTimeOrder(const Problem& pb) {
  for (int i = 1; i < pb.n; ++i) {
    if (!(pb.at(i).t > pb.at(i - 1).t)) {
      throw DataError("model with sensor_delay: sample " + std::to_string(pb.indices[static_cast<std::size_t>(i)]) +
                      " (t = " + std::to_string(pb.at(i).t) +
                      " s) is not later than the one before it; a delay needs a time series");
    }
  }
}

void checkNotStatic(const Problem& pb, const Model& model) {
  std::vector<SampleContext> subset;
  subset.reserve(static_cast<std::size_t>(pb.n));
  for (int i = 0; i < pb.n; ++i) subset.push_back(pb.at(i));
  if (holdsStill(subset)) {
    throw IdentificationError("model '" + model.name() +
                              "' estimates a sensor delay, but the log is a static pose set (the robot is at "
                              "rest): a delay shows only while the wrench changes with the motion; fit it on an "
                              "excitation run, or leave sensor_delay out");
  }
}

}  // namespace ftid::identify::internal
