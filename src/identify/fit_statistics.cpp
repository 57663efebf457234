// The statistics of fitModel at the optimum (fit_steps.hpp): the joint Jacobian of the weighted
// model with respect to [theta, phi], one factorisation of it for the rank check, the condition
// number and the autocorrelation-robust (Newey-West) covariance, and the unweighted residual. The
// compressed tilt search gives the same numbers from its per-axis factors and rows
// (gravity_compression.hpp).
#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "fit_steps.hpp"
#include "linear_algebra.hpp"
#include "ftid/common/error.hpp"
#include "ftid/identify/uncertainty.hpp"
#include "ftid/model/frames.hpp"

namespace ftid::identify::internal {

namespace {

/// The joint Jacobian at the solution and what the covariance needs beside it.
struct JointJacobian {
  /// Weighted, 6N x (p + phi) (general) or compressed, rows() x (p + 2) (the same column norms,
  /// singular values and (J^T J)^{-1}); factored in place by the ScaledQR.
  Eigen::MatrixXd J;
  Eigen::MatrixXd J_weighted;  ///< general: J before the factorisation
  Eigen::VectorXd r_weighted;  ///< general: the weighted residual per sample
  /// Compressed: the Newey-West scores directly (no 6N-row Jacobian), in gc's scratch.
  std::optional<Eigen::Map<const Eigen::MatrixXd>> scores;
  Mat6X residual_compressed;   ///< compressed: the unweighted residual from the rows of B_a
  /// Gravity and its derivatives in the tilt (central differences: the regressor is affine in it).
  Vec3 g_B;
  Vec3 dg_u;
  Vec3 dg_v;
};

JointJacobian jointJacobian(FitState& f, const NonlinearParams& nl) {
  Problem& pb = f.pb;
  const PhiLayout& L = f.L;
  JointJacobian jj;
  const double h_tilt = 1e-5;
  jj.g_B = model::gravityInBase(nl.tilt_u_rad, nl.tilt_v_rad);
  jj.dg_u = (model::gravityInBase(nl.tilt_u_rad + h_tilt, nl.tilt_v_rad) -
             model::gravityInBase(nl.tilt_u_rad - h_tilt, nl.tilt_v_rad)) / (2.0 * h_tilt);
  jj.dg_v = (model::gravityInBase(nl.tilt_u_rad, nl.tilt_v_rad + h_tilt) -
             model::gravityInBase(nl.tilt_u_rad, nl.tilt_v_rad - h_tilt)) / (2.0 * h_tilt);
  if (f.compressed) {
    // Compressed J for the rank, condition number and (J^T J)^{-1}; the per-sample rows from B_a.
    jj.J = f.gc.compressedJacobian(jj.g_B, jj.dg_u, jj.dg_v, f.sol.theta, f.weights);
    jj.scores.emplace(f.gc.scores(jj.g_B, jj.dg_u, jj.dg_v, f.sol.theta, f.weights, &jj.residual_compressed));
    return jj;
  }
  jj.J.resize(6 * pb.n, f.n_unknowns);
  Eigen::MatrixXd A;
  pb.buildRegressor(nl, f.weights, &A);
  jj.J.leftCols(pb.p) = A;
  Eigen::MatrixXd Ap, Am;
  for (int j = 0; j < L.size; ++j) {
    const double h = j == L.delay ? std::max(1e-5, 0.05 * f.dt_mean) : 1e-5;
    PhiState sp = f.st;
    PhiState sm = f.st;
    sp.phi(j) += h;
    sm.phi(j) -= h;
    pb.buildRegressor(sp.params(L), f.weights, &Ap);
    pb.buildRegressor(sm.params(L), f.weights, &Am);
    jj.J.col(pb.p + j) = (Ap - Am) * f.sol.theta / (2.0 * h);
  }
  jj.J_weighted = jj.J;  // the QR factors J in place; the covariance needs it
  jj.r_weighted = f.sol.residual;
  return jj;
}

/// The names of the joint Jacobian's columns: theta's, then phi's.
std::vector<std::string> jointNames(const FitState& f) {
  std::vector<std::string> all_names = f.names;
  if (f.L.tilt >= 0) {
    all_names.push_back("tilt_u");
    all_names.push_back("tilt_v");
  }
  if (f.L.mount >= 0) {
    for (const char* m : effects::kMountParamNames) all_names.push_back(m);
  }
  if (f.L.delay >= 0) all_names.push_back(effects::kDelayParamName);
  return all_names;
}

/// One factorisation of J for the rank check, the condition number and the covariance; throws
/// IdentificationError naming the columns the data do not determine.
void factorJacobian(FitState& f, JointJacobian* jj, std::optional<internal::ScaledQR>* qr) {
  qr->emplace(jj->J, f.options.rank_tolerance);
  if (f.compressed && f.gc.gram() &&
      ((*qr)->rank().rank < f.n_unknowns || (*qr)->rank().condition_number > kGramConditionLimit)) {
    // The start's check saw only theta's columns: with the tilt's, J is too ill-conditioned for the
    // Gram factor (or rank-deficient: name the columns from the exact one). Householder QR instead.
    qr->reset();
    f.gc.factor(false);
    jj->J = f.gc.compressedJacobian(jj->g_B, jj->dg_u, jj->dg_v, f.sol.theta, f.weights);
    qr->emplace(jj->J, f.options.rank_tolerance);
  }
  const internal::RankReport& rr = (*qr)->rank();
  if (rr.rank < f.n_unknowns) {
    const std::vector<std::string> all_names = jointNames(f);
    std::vector<std::string> bad;
    for (int j : rr.unexcited_columns) bad.push_back(all_names[static_cast<std::size_t>(j)]);
    throw IdentificationError("the data do not determine " + internal::joinNames(bad) + " of model '" +
                              f.model.name() + "' (rank " + std::to_string(rr.rank) + " of " +
                              std::to_string(f.n_unknowns) +
                              "): excite them with more distinct orientations/motions");
  }
}

/// sigma^2, the autocorrelation-robust (Newey-West) covariance (holds for filtered noise,
/// uncertainty.hpp) and the standard deviations of theta and phi.
void covarianceAt(const FitState& f, const JointJacobian& jj, const internal::ScaledQR& qr_j, FitResult* res) {
  const Problem& pb = f.pb;
  const PhiLayout& L = f.L;
  res->condition_number = qr_j.rank().condition_number;
  const int dof = 6 * pb.n_active - f.n_unknowns;
  if (f.compressed) {
    // The same sandwich from the scores (robustCovariance is scoreCovariance of J's scores).
    const Mat6X r_w = f.weights.asDiagonal() * jj.residual_compressed;
    res->sigma2 = dof > 0 ? r_w.squaredNorm() / dof : 0.0;
    res->covariance = scoreCovariance(*jj.scores, r_w, qr_j.inverseGram()).covariance;
  } else {
    res->sigma2 = dof > 0 ? f.sol.residual.squaredNorm() / dof : 0.0;
    res->covariance = robustCovariance(jj.J_weighted, jj.r_weighted, qr_j.inverseGram()).covariance;
  }
  res->theta_std = res->covariance.diagonal().head(pb.p).cwiseMax(0.0).cwiseSqrt();
  auto sd = [&](int j) { return std::sqrt(std::max(res->covariance(pb.p + j, pb.p + j), 0.0)); };
  if (L.tilt >= 0) {
    res->tilt_u_std = sd(L.tilt);
    res->tilt_v_std = sd(L.tilt + 1);
  }
  if (L.mount >= 0) {
    for (int k = 0; k < 3; ++k) res->mount_rpy_std(k) = sd(L.mount + k);
  }
  if (L.delay >= 0) res->delay_std = sd(L.delay);
}

}  // namespace

void statisticsAtOptimum(FitState& f, FitResult* res) {
  const Problem& pb = f.pb;
  const NonlinearParams nl = f.st.params(f.L);
  JointJacobian jj = jointJacobian(f, nl);
  std::optional<internal::ScaledQR> qr_j;
  factorJacobian(f, &jj, &qr_j);
  covarianceAt(f, jj, *qr_j, res);
  // Unweighted residual (the compensator's evaluation; compressed: the same model from the rows of
  // B_a, affine in g_S); excluded samples count as zero.
  res->residual = f.compressed ? std::move(jj.residual_compressed) : Mat6X(f.measured - pb.predict(f.sol.theta, nl));
  for (int i = 0; i < pb.n; ++i) {
    if (!pb.active[static_cast<std::size_t>(i)]) res->residual.col(i).setZero();
  }
  res->residual_rms = (res->residual.rowwise().squaredNorm() / std::max(1, pb.n_active)).cwiseSqrt();
}

}  // namespace ftid::identify::internal
