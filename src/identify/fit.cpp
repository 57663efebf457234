// General weighted least-squares fit of a composed model with variable projection on the tilt
// (include/ftid/identify/fit.hpp, docs/identification.md).
#include "ftid/identify/fit.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "fit_internal.hpp"
#include "ftid/common/error.hpp"
#include "ftid/identify/paper_method.hpp"
#include "ftid/identify/uncertainty.hpp"
#include "ftid/model/frames.hpp"

namespace ftid::identify {

namespace {

using Mat6X = Eigen::Matrix<double, 6, Eigen::Dynamic>;
using effects::kSignalModelDerivative;

constexpr double kTiltStep = 1e-6;  // [rad] numeric-Jacobian step
constexpr double kTiltConverged = 1e-10;  // [rad] a rejected Gauss-Newton step this small ends the search

struct Problem {
  const Model& model;
  const std::vector<SampleContext>& contexts;
  const std::vector<int>& indices;
  int n = 0;
  int p = 0;
  bool estimate_tilt = false;
  bool override_gravity = false;  ///< recompute g_S from the tilt (else use ctx.g_S)
  bool needs_derivative = false;  ///< the model reads kSignalModelDerivative signals
  std::vector<Wrench> dwdt;       ///< SampleContext::dwrench_model_dt per subset sample
  std::vector<Wrench> wmodel;     ///< SampleContext::wrench_model_S per subset sample
  Eigen::VectorXd y;              ///< stacked measured wrench (6n)

  Problem(const Model& m, const std::vector<SampleContext>& c, const std::vector<int>& idx)
      : model(m), contexts(c), indices(idx) {}

  const SampleContext& at(int i) const { return contexts[static_cast<std::size_t>(indices[static_cast<std::size_t>(i)])]; }

  /// Regressor A (6n x p) for the tilt (u, v), rows scaled by the axis weights. The signals
  /// derived from the modelled wrench are those of dwdt / wmodel, or zero if !with_derived (the
  /// regressor of the effects that do not read them: those effects are linear in the signals).
  void buildRegressor(double u, double v, const Vec6& weights, Eigen::MatrixXd* A,
                      bool with_derived = true) const {
    A->resize(6 * n, p);
    const Vec3 g_B = model::gravityInBase(u, v);
    Eigen::Matrix<double, 6, Eigen::Dynamic> Y(6, p);
    SampleContext c;
    for (int i = 0; i < n; ++i) {
      c = at(i);
      if (override_gravity) c.g_S = c.R_BS.transpose() * g_B;
      if (needs_derivative) {
        c.dwrench_model_dt = with_derived ? dwdt[static_cast<std::size_t>(i)] : Wrench::Zero();
        c.wrench_model_S = with_derived ? wmodel[static_cast<std::size_t>(i)] : Wrench::Zero();
      }
      model.computeRegressor(c, Y);
      A->middleRows(6 * i, 6) = weights.asDiagonal() * Y;
    }
  }

  Eigen::VectorXd weightedMeasurement(const Vec6& weights) const {
    Eigen::VectorXd yw(6 * n);
    for (int i = 0; i < n; ++i) yw.segment<6>(6 * i) = weights.cwiseProduct(y.segment<6>(6 * i));
    return yw;
  }
};

struct LinearSolution {
  Eigen::VectorXd theta;
  Eigen::VectorXd residual;  ///< weighted, stacked
};

LinearSolution solveLinear(const Eigen::MatrixXd& A, const Eigen::VectorXd& yw) {
  LinearSolution s;
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
  s.theta = qr.solve(yw);
  s.residual = yw - A * s.theta;
  return s;
}

/// Variable-projection residual for tilt (u, v).
LinearSolution projectedResidual(const Problem& pb, double u, double v, const Vec6& w,
                                 const Eigen::VectorXd& yw, Eigen::MatrixXd* A) {
  pb.buildRegressor(u, v, w, A);
  return solveLinear(*A, yw);
}

struct TiltState {
  double u = 0.0;
  double v = 0.0;
  int iterations = 0;
};

/// Levenberg-damped Gauss-Newton on (u, v) minimising the projected residual.
LinearSolution fitTilt(const Problem& pb, const Vec6& w, int max_iterations, TiltState* tilt) {
  const Eigen::VectorXd yw = pb.weightedMeasurement(w);
  Eigen::MatrixXd A;
  LinearSolution cur = projectedResidual(pb, tilt->u, tilt->v, w, yw, &A);
  if (!pb.estimate_tilt) return cur;
  double cost = cur.residual.squaredNorm();
  double lambda = 1e-6;
  for (int it = 0; it < max_iterations; ++it) {
    tilt->iterations = it + 1;
    Eigen::MatrixXd J(cur.residual.size(), 2);
    J.col(0) = (projectedResidual(pb, tilt->u + kTiltStep, tilt->v, w, yw, &A).residual - cur.residual) / kTiltStep;
    J.col(1) = (projectedResidual(pb, tilt->u, tilt->v + kTiltStep, w, yw, &A).residual - cur.residual) / kTiltStep;
    const Eigen::Vector2d jn = J.colwise().norm();
    if (!(jn.minCoeff() > 0.0)) break;
    bool accepted = false;
    Eigen::Vector2d step = Eigen::Vector2d::Zero();
    for (int attempt = 0; attempt < 12 && !accepted; ++attempt) {
      // Damped step from the augmented least-squares problem [J; sqrt(lambda) D] d = [-r; 0].
      Eigen::MatrixXd Ja(J.rows() + 2, 2);
      Ja.topRows(J.rows()) = J;
      Ja.bottomRows(2) = (std::sqrt(lambda) * jn).asDiagonal();
      Eigen::VectorXd ra = Eigen::VectorXd::Zero(J.rows() + 2);
      ra.head(J.rows()) = -cur.residual;
      step = Ja.householderQr().solve(ra);
      LinearSolution trial = projectedResidual(pb, tilt->u + step(0), tilt->v + step(1), w, yw, &A);
      const double trial_cost = trial.residual.squaredNorm();
      if (trial_cost <= cost) {
        tilt->u += step(0);
        tilt->v += step(1);
        cur = std::move(trial);
        const double old_cost = cost;
        cost = trial_cost;
        lambda = std::max(lambda * 0.1, 1e-12);
        accepted = true;
        if (step.norm() < 1e-13 || old_cost - cost <= 1e-15 * old_cost) return cur;
      } else if (step.norm() < kTiltConverged) {
        // At the minimum the cost changes only by rounding and a step is as likely to be rejected
        // as accepted: stop instead of re-solving with ever more damping (up to 12 solves).
        return cur;
      } else {
        lambda *= 10.0;
      }
    }
    if (!accepted) break;
  }
  return cur;
}

Mat6X unstack(const Eigen::VectorXd& v, int n) {
  return Eigen::Map<const Mat6X>(v.data(), 6, n);
}

/// Central time differences of a 6 x n signal along the subset order.
std::vector<Wrench> timeDerivative(const Problem& pb, const Mat6X& w) {
  std::vector<Wrench> d(static_cast<std::size_t>(pb.n), Wrench::Zero());
  for (int i = 0; i < pb.n; ++i) {
    const int a = std::max(i - 1, 0);
    const int b = std::min(i + 1, pb.n - 1);
    const double dt = pb.at(b).t - pb.at(a).t;
    if (b > a && dt > 0.0) d[static_cast<std::size_t>(i)] = (w.col(b) - w.col(a)) / dt;
  }
  return d;
}

Mat6X predictStacked(const Problem& pb, const Eigen::VectorXd& theta, double u, double v,
                     bool with_derived = true) {
  Eigen::MatrixXd A;
  pb.buildRegressor(u, v, Vec6::Ones(), &A, with_derived);
  return unstack(A * theta, pb.n);
}

std::vector<Wrench> columns(const Mat6X& w) {
  std::vector<Wrench> out(static_cast<std::size_t>(w.cols()));
  for (Eigen::Index i = 0; i < w.cols(); ++i) out[static_cast<std::size_t>(i)] = w.col(i);
  return out;
}

/// The signals derived from the model for theta (docs/identification.md, "The general fit"):
/// d/dt of the current prediction, and the prediction without the effects that read these
/// signals (what `crosstalk` multiplies).
void updateDerivedSignals(Problem& pb, const Eigen::VectorXd& theta, double u, double v) {
  const Mat6X full = predictStacked(pb, theta, u, v);
  pb.wmodel = columns(predictStacked(pb, theta, u, v, false));
  pb.dwdt = timeDerivative(pb, full);
}

void checkFinite(const Problem& pb) {
  for (int i = 0; i < pb.n; ++i) {
    const SampleContext& c = pb.at(i);
    const bool ok = c.wrench_S.allFinite() && c.R_BS.allFinite() && c.w_S.allFinite() &&
                    c.alpha_S.allFinite() && c.a_S.allFinite() && c.g_S.allFinite() &&
                    std::isfinite(c.t) && c.imu_acc_S.allFinite() && c.imu_w_S.allFinite() &&
                    c.imu_alpha_S.allFinite() && std::isfinite(c.temp_degC);
    if (!ok) {
      throw DataError("sample " + std::to_string(pb.indices[static_cast<std::size_t>(i)]) +
                      " (t = " + std::to_string(c.t) + " s) has a non-finite value");
    }
  }
}

std::vector<std::string> paramNames(const Model& model) { return model.paramIndex().names(); }

}  // namespace

double FitResult::value(const std::string& name) const {
  for (std::size_t j = 0; j < params.size(); ++j) {
    if (params[j].name == name) return theta(static_cast<Eigen::Index>(j));
  }
  for (const auto& d : derived) {
    if (d.name == name) return d.value;
  }
  if (name == "tilt_u") return tilt_u_rad;
  if (name == "tilt_v") return tilt_v_rad;
  throw std::out_of_range("fit result has no parameter '" + name + "'");
}

double FitResult::stddev(const std::string& name) const {
  for (std::size_t j = 0; j < params.size(); ++j) {
    if (params[j].name == name) return theta_std(static_cast<Eigen::Index>(j));
  }
  for (const auto& d : derived) {
    if (d.name == name) return d.std;
  }
  if (name == "tilt_u") return tilt_u_std;
  if (name == "tilt_v") return tilt_v_std;
  throw std::out_of_range("fit result has no parameter '" + name + "'");
}

bool FitResult::has(const std::string& name) const {
  try {
    (void)value(name);
    return true;
  } catch (const std::out_of_range&) {
    return false;
  }
}

FitResult fitModel(const Model& model, const std::vector<SampleContext>& contexts,
                   const FitOptions& options) {
  std::vector<int> all(contexts.size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  return fitModel(model, contexts, all, options);
}

FitResult fitModel(const Model& model, const std::vector<SampleContext>& contexts,
                   const std::vector<int>& indices, const FitOptions& options) {
  Problem pb(model, contexts, indices);
  pb.n = static_cast<int>(indices.size());
  pb.p = model.numParams();
  pb.estimate_tilt = model.estimatesTilt();
  pb.override_gravity = pb.estimate_tilt || (options.tilt_u_rad && options.tilt_v_rad);
  pb.needs_derivative = (model.signals() & kSignalModelDerivative) != 0;
  for (int idx : indices) {
    if (idx < 0 || static_cast<std::size_t>(idx) >= contexts.size()) {
      throw std::out_of_range("fitModel: sample index " + std::to_string(idx) + " out of range");
    }
  }
  const int n_unknowns = pb.p + (pb.estimate_tilt ? 2 : 0);
  if (pb.p == 0) throw IdentificationError("model '" + model.name() + "' has no parameters to fit");
  if (6 * pb.n < n_unknowns + 1) {
    throw IdentificationError("too few samples: " + std::to_string(pb.n) + " samples give " +
                              std::to_string(6 * pb.n) + " equations for " +
                              std::to_string(n_unknowns) + " unknowns of model '" + model.name() + "'");
  }
  checkFinite(pb);
  pb.y.resize(6 * pb.n);
  Mat6X measured(6, pb.n);
  for (int i = 0; i < pb.n; ++i) {
    pb.y.segment<6>(6 * i) = pb.at(i).wrench_S;
    measured.col(i) = pb.at(i).wrench_S;
  }
  if (pb.needs_derivative) {
    // First pass: the measured wrench stands in for the modelled one.
    pb.dwdt = timeDerivative(pb, measured);
    pb.wmodel = columns(measured);
  }

  // Initial tilt.
  TiltState tilt;
  if (options.tilt_u_rad) tilt.u = *options.tilt_u_rad;
  if (options.tilt_v_rad) tilt.v = *options.tilt_v_rad;
  if (pb.estimate_tilt && !(options.tilt_u_rad && options.tilt_v_rad)) {
    // The paper's force stage (static): direction of the identified gravity vector in B.
    std::vector<SampleContext> subset;
    subset.reserve(indices.size());
    for (int idx : indices) subset.push_back(contexts[static_cast<std::size_t>(idx)]);
    try {
      PaperOptions po;
      po.method = PaperMethod::kStatic;
      const PaperResult pr = identifyPaper(subset, po);
      tilt.u = pr.tilt_u_rad;
      tilt.v = pr.tilt_v_rad;
    } catch (const Error&) {
      // Not determinable by the paper's method: start level; the rank check below decides.
    }
  }

  const std::vector<std::string> names = paramNames(model);
  // Rank of the linear part at the initial tilt.
  {
    Eigen::MatrixXd A;
    pb.buildRegressor(tilt.u, tilt.v, Vec6::Ones(), &A);
    const internal::RankReport rr = internal::analyzeRank(A, options.rank_tolerance);
    if (rr.rank < pb.p) {
      std::vector<std::string> bad;
      for (int j : rr.unexcited_columns) bad.push_back(names[static_cast<std::size_t>(j)]);
      throw IdentificationError("the data do not determine " + internal::joinNames(bad) +
                                " of model '" + model.name() + "' (rank " + std::to_string(rr.rank) +
                                " of " + std::to_string(pb.p) +
                                "): excite them with more distinct orientations/motions");
    }
  }

  Vec6 weights = Vec6::Ones();
  LinearSolution sol;
  auto runFit = [&](int derivative_passes, int tilt_iterations) {
    sol = fitTilt(pb, weights, tilt_iterations, &tilt);
    for (int k = 0; k < derivative_passes; ++k) {
      updateDerivedSignals(pb, sol.theta, tilt.u, tilt.v);
      sol = fitTilt(pb, weights, tilt_iterations, &tilt);
    }
  };
  // The unweighted pass only has to give the per-axis residual RMS for the weights: a few tilt
  // iterations suffice; the weighted pass then converges fully from there.
  runFit(pb.needs_derivative ? options.derivative_iterations : 0,
         options.axis_weights ? std::min(options.max_tilt_iterations, 4) : options.max_tilt_iterations);
  if (options.axis_weights) {
    const Mat6X r = unstack(sol.residual, pb.n);
    const Vec6 rms = (r.rowwise().squaredNorm() / pb.n).cwiseSqrt();
    const double floor = std::max(1e-3 * rms.maxCoeff(), 1e-12);
    for (int a = 0; a < 6; ++a) weights(a) = 1.0 / std::max(rms(a), floor);
    runFit(pb.needs_derivative ? 2 : 0, options.max_tilt_iterations);
  }

  FitResult res;
  res.model_name = model.name();
  res.params = model.params();
  res.theta = sol.theta;
  res.tilt_estimated = pb.estimate_tilt;
  res.tilt_applied = pb.override_gravity;
  res.tilt_u_rad = pb.override_gravity ? tilt.u : 0.0;
  res.tilt_v_rad = pb.override_gravity ? tilt.v : 0.0;
  res.tilt_iterations = tilt.iterations;
  res.axis_weights = weights;
  res.n_samples = pb.n;

  // Joint Jacobian of the weighted model wrt [theta, U, V] at the solution.
  Eigen::MatrixXd J(6 * pb.n, n_unknowns);
  {
    Eigen::MatrixXd A;
    pb.buildRegressor(tilt.u, tilt.v, weights, &A);
    J.leftCols(pb.p) = A;
    if (pb.estimate_tilt) {
      Eigen::MatrixXd Ap, Am;
      const double h = 1e-5;
      pb.buildRegressor(tilt.u + h, tilt.v, weights, &Ap);
      pb.buildRegressor(tilt.u - h, tilt.v, weights, &Am);
      J.col(pb.p) = (Ap - Am) * sol.theta / (2.0 * h);
      pb.buildRegressor(tilt.u, tilt.v + h, weights, &Ap);
      pb.buildRegressor(tilt.u, tilt.v - h, weights, &Am);
      J.col(pb.p + 1) = (Ap - Am) * sol.theta / (2.0 * h);
    }
  }
  std::vector<std::string> all_names = names;
  if (pb.estimate_tilt) {
    all_names.push_back("tilt_u");
    all_names.push_back("tilt_v");
  }
  // One factorisation of J for the rank check, the condition number and the covariance.
  const Eigen::MatrixXd J_weighted = J;  // the QR factors J in place; the covariance needs it
  const internal::ScaledQR qr_j(J, options.rank_tolerance);
  const internal::RankReport& rr = qr_j.rank();
  if (rr.rank < n_unknowns) {
    std::vector<std::string> bad;
    for (int j : rr.unexcited_columns) bad.push_back(all_names[static_cast<std::size_t>(j)]);
    throw IdentificationError("the data do not determine " + internal::joinNames(bad) + " of model '" +
                              model.name() + "' (rank " + std::to_string(rr.rank) + " of " +
                              std::to_string(n_unknowns) +
                              "): excite them with more distinct orientations/motions");
  }
  res.condition_number = rr.condition_number;
  const int dof = 6 * pb.n - n_unknowns;
  res.sigma2 = dof > 0 ? sol.residual.squaredNorm() / dof : 0.0;
  // Autocorrelation-robust (Newey-West) covariance: holds for filtered noise (uncertainty.hpp).
  res.covariance = robustCovariance(J_weighted, sol.residual, qr_j.inverseGram()).covariance;
  res.theta_std = res.covariance.diagonal().head(pb.p).cwiseMax(0.0).cwiseSqrt();
  if (pb.estimate_tilt) {
    res.tilt_u_std = std::sqrt(std::max(res.covariance(pb.p, pb.p), 0.0));
    res.tilt_v_std = std::sqrt(std::max(res.covariance(pb.p + 1, pb.p + 1), 0.0));
  }

  // Unweighted residual.
  res.residual = measured - predictStacked(pb, sol.theta, tilt.u, tilt.v);
  res.residual_rms = (res.residual.rowwise().squaredNorm() / pb.n).cwiseSqrt();

  // Derived parameters: com = mass_com / mass, weight = m g (delta method).
  const auto& index = model.paramIndex();
  const int cm = index.column("mass");
  if (cm >= 0) {
    res.derived.push_back({"weight", kStandardGravity * res.theta(cm),
                           kStandardGravity * res.theta_std(cm), "N"});
    const char* mc_names[3] = {"mass_com_x", "mass_com_y", "mass_com_z"};
    const char* com_names[3] = {"com_x", "com_y", "com_z"};
    for (int k = 0; k < 3; ++k) {
      const int cj = index.column(mc_names[k]);
      if (cj < 0) continue;
      const double m = res.theta(cm);
      const double mc = res.theta(cj);
      Eigen::Vector2d grad(-mc / (m * m), 1.0 / m);
      Eigen::Matrix2d C;
      C << res.covariance(cm, cm), res.covariance(cm, cj), res.covariance(cj, cm), res.covariance(cj, cj);
      res.derived.push_back({com_names[k], mc / m, std::sqrt(std::max(grad.dot(C * grad), 0.0)), "m"});
    }
  }
  return res;
}

Eigen::Matrix<double, 6, Eigen::Dynamic> predictWrench(const Model& model, const Eigen::VectorXd& theta,
                                                       std::optional<double> tilt_u_rad,
                                                       std::optional<double> tilt_v_rad,
                                                       const std::vector<SampleContext>& contexts,
                                                       const std::vector<int>& indices) {
  if (theta.size() != model.numParams()) {
    throw std::invalid_argument("predictWrench: theta has " + std::to_string(theta.size()) +
                                " entries, model '" + model.name() + "' has " +
                                std::to_string(model.numParams()) + " parameters");
  }
  Problem pb(model, contexts, indices);
  pb.n = static_cast<int>(indices.size());
  pb.p = model.numParams();
  pb.override_gravity = tilt_u_rad.has_value() && tilt_v_rad.has_value();
  pb.needs_derivative = (model.signals() & kSignalModelDerivative) != 0;
  const double u = tilt_u_rad.value_or(0.0);
  const double v = tilt_v_rad.value_or(0.0);
  if (pb.needs_derivative) {
    pb.dwdt.assign(static_cast<std::size_t>(pb.n), Wrench::Zero());
    pb.wmodel = columns(predictStacked(pb, theta, u, v, false));
  }
  Mat6X out = predictStacked(pb, theta, u, v);
  if (pb.needs_derivative) {
    for (int k = 0; k < 3; ++k) {
      pb.dwdt = timeDerivative(pb, out);
      out = predictStacked(pb, theta, u, v);
    }
  }
  return out;
}

Eigen::Matrix<double, 6, Eigen::Dynamic> predictWrench(const Model& model, const FitResult& fit,
                                                       const std::vector<SampleContext>& contexts,
                                                       const std::vector<int>& indices) {
  std::optional<double> u, v;
  if (fit.tilt_applied) {
    u = fit.tilt_u_rad;
    v = fit.tilt_v_rad;
  }
  return predictWrench(model, fit.theta, u, v, contexts, indices);
}

Eigen::Matrix<double, 6, Eigen::Dynamic> predictWrench(const Model& model, const FitResult& fit,
                                                       const std::vector<SampleContext>& contexts) {
  std::vector<int> all(contexts.size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  return predictWrench(model, fit, contexts, all);
}

}  // namespace ftid::identify
