// The paper's two-stage identification (include/ftid/identify/paper_method.hpp).
#include "ftid/identify/paper_method.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "linear_algebra.hpp"
#include "ftid/common/error.hpp"
#include "ftid/identify/uncertainty.hpp"

namespace ftid::identify {

namespace {

using effects::SampleContext;

/// Names of the force-stage unknowns [L, F0] for messages: L is "the gravity vector in B".
std::string forceStageNames(const std::vector<int>& cols) {
  std::vector<std::string> names;
  bool gravity = false;
  for (int j : cols) {
    if (j < 3) {
      gravity = true;
    } else {
      const char* f0[3] = {"f0_x", "f0_y", "f0_z"};
      names.push_back(f0[j - 3]);
    }
  }
  if (gravity) names.push_back("the gravity vector in B (weight, tilt_u, tilt_v)");
  return internal::joinNames(names);
}

std::string torqueStageNames(const std::vector<int>& cols) {
  std::vector<std::string> names;
  const char* c[3] = {"com_x", "com_y", "com_z"};
  const char* t[3] = {"t0_x", "t0_y", "t0_z"};
  for (int j : cols) names.push_back(j < 3 ? c[j] : t[j - 3]);
  return internal::joinNames(names);
}

// Exact row compression (internal::thinR, linear_algebra.hpp): a stage's stacked rows for axis a
// are D_a C_a with data D_a (one row per sample) and a constant map C_a; the compressed
// [R_0 C_0; R_1 C_1; R_2 C_2] replaces the 3n-row problem.

/// Force stage, axis a: row [R_i(:, a)^T, 1, f_i(a), a_i(a)] D -> [R_i^T row a, e_a^T | f_i(a) | a_i(a)].
Eigen::MatrixXd forceRowMap(int a) {
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(6, 8);
  for (int j = 0; j < 3; ++j) C(j, j) = 1.0;
  C(3, 3 + a) = 1.0;
  C(4, 6) = 1.0;
  C(5, 7) = 1.0;
  return C;
}

/// Torque stage, axis a: row [f^T, 1 (, t^T)] -> row a of [-skew(f), I (| t)] (with_rhs: 7 x 7).
Eigen::MatrixXd torqueRowMap(int a, bool with_rhs) {
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(with_rhs ? 7 : 4, with_rhs ? 7 : 6);
  for (int j = 0; j < 3; ++j) C.block<1, 3>(j, 0) = (-skew(Vec3::Unit(j))).row(a);
  C(3, 3 + a) = 1.0;
  if (with_rhs) C(4 + a, 6) = 1.0;
  return C;
}

/// Compressed torque-stage problem from the shared data D = [f_i^T, 1 (, t_i^T)] (overwritten).
Eigen::MatrixXd compressTorqueStage(Eigen::MatrixXd& D, bool with_rhs) {
  const Eigen::MatrixXd R = internal::thinR(D);
  const Eigen::Index r = R.rows();
  Eigen::MatrixXd K(3 * r, with_rhs ? 7 : 6);
  for (int a = 0; a < 3; ++a) K.middleRows(a * r, r).noalias() = R * torqueRowMap(a, with_rhs);
  return K;
}

}  // namespace

const char* toString(PaperMethod method) {
  return method == PaperMethod::kStatic ? "static" : "dynamic";
}

void gravityToWeightAndTilt(const Vec3& L, double* weight_N, double* tilt_u_rad, double* tilt_v_rad) {
  const double G = L.norm();
  *weight_N = G;
  // L = G (cos U sin V, -sin U, -cos U cos V)  (docs/conventions.md; paper Eq. 15 corrected)
  const double s = G > 0.0 ? std::max(-1.0, std::min(1.0, -L.y() / G)) : 0.0;
  *tilt_u_rad = std::asin(s);
  *tilt_v_rad = std::atan2(L.x(), -L.z());
}

namespace {

/// Refuses too few samples (3 equations a sample and stage for 6 unknowns) and non-finite values.
void checkPaperInput(const std::vector<SampleContext>& contexts) {
  const int n = static_cast<int>(contexts.size());
  if (3 * n < 7) {
    throw IdentificationError("too few samples for the paper's method: " + std::to_string(n) +
                              " samples give " + std::to_string(3 * n) +
                              " equations per stage for 6 unknowns");
  }
  for (int i = 0; i < n; ++i) {
    const SampleContext& c = contexts[static_cast<std::size_t>(i)];
    if (!c.wrench_S.allFinite() || !c.R_BS.allFinite() || !c.a_S.allFinite()) {
      throw DataError("sample " + std::to_string(i) + " (t = " + std::to_string(c.t) +
                      " s) has a non-finite value");
    }
  }
}

/// The force stage's estimate l = [L, F0] and what the later steps need of it.
struct ForceStage {
  Vec3 L = Vec3::Zero();   ///< the gravity force in B [N]
  Vec3 F0 = Vec3::Zero();  ///< force offset [N]
  double G = 0.0;          ///< |L| [N]
  double m = 0.0;          ///< G / g [kg]
  Eigen::MatrixXd bread_inv;  ///< inverse of the stage's bread B_f (the covariance's sandwich)
  double condition = 0.0;
  int iterations = 0;
};

/// Bread of the force stage (the sandwich of stageCovariance): B_f = -d(sum_i A_i^T r_i)/dl.
/// Static: A^T A. Dynamic: the fixed point solves A^T (f + (G(l)/g) a - A l) = 0, so B_f =
/// A^T (A - a v^T) = A^T A - u v^T with u = A^T a, v = [L / (g G); 0] (the G dependence of the
/// inertial term). Returns B_f^-1 from gram_inv = (A^T A)^-1.
Eigen::MatrixXd forceStageBreadInverse(const std::vector<SampleContext>& contexts, const Eigen::MatrixXd& gram_inv,
                                       const Vec3& L, double G, bool dynamic) {
  if (!dynamic) return gram_inv;
  Vec6 u = Vec6::Zero();
  for (const SampleContext& c : contexts) {
    u.head<3>() += c.R_BS * c.a_S;  // A_i^T a_i, A_i = [R_BS,i^T, I]
    u.tail<3>() += c.a_S;
  }
  Vec6 v = Vec6::Zero();
  v.head<3>() = L / (kStandardGravity * G);
  // (G_f - u v^T)^-1 = (I - G_f^-1 u v^T)^-1 G_f^-1
  const Eigen::MatrixXd M = Eigen::MatrixXd::Identity(6, 6) - gram_inv * u * v.transpose();
  return M.partialPivLu().solve(gram_inv);
}

/// Force stage (Eq. 14-20; dynamic Eq. 31-38 corrected): f_i + (G/g) a_i = R_i^T L + F0.
/// Rows for axis a: [R_i(:, a)^T, e_a^T | f_i(a) | a_i(a)], compressed exactly (thinR) to 18 x 8.
/// One column-scaled pivoted QR of the compressed regressor serves the rank check, every
/// fixed-point solve (Q^T is linear: Q^T (f + s a) = Q^T f + s Q^T a) and (A^T A)^-1 for the
/// bread of the covariance.
ForceStage solveForceStage(const std::vector<SampleContext>& contexts, const PaperOptions& options, bool dynamic) {
  const int n = static_cast<int>(contexts.size());
  Eigen::MatrixXd K_f = Eigen::MatrixXd::Zero(18, 8);  // zero rows (n < 6) change nothing
  {
    // D[a] = [R_i(:, a)^T, 1, f_i(a), a_i(a)], one row per sample
    std::vector<Eigen::MatrixXd> D(3, Eigen::MatrixXd(n, 6));
    for (int i = 0; i < n; ++i) {
      const SampleContext& c = contexts[static_cast<std::size_t>(i)];
      for (int a = 0; a < 3; ++a) {
        Eigen::MatrixXd& Da = D[static_cast<std::size_t>(a)];
        Da.block<1, 3>(i, 0) = c.R_BS.col(a).transpose();
        Da(i, 3) = 1.0;
        Da(i, 4) = c.wrench_S(a);
        Da(i, 5) = c.a_S(a);
      }
    }
    for (int a = 0; a < 3; ++a) {
      const Eigen::MatrixXd R = internal::thinR(D[static_cast<std::size_t>(a)]);
      K_f.middleRows(6 * a, R.rows()).noalias() = R * forceRowMap(a);
    }
  }
  Eigen::MatrixXd Af = K_f.leftCols<6>();
  Eigen::VectorXd qt_f = K_f.col(6);  // f, then Q^T f
  Eigen::VectorXd qt_a = K_f.col(7);  // a, then Q^T a
  const internal::ScaledQR qr_f(Af, options.rank_tolerance);
  if (qr_f.rank().rank < 6) {
    throw IdentificationError("the data do not determine " + forceStageNames(qr_f.rank().unexcited_columns) +
                              " (force stage rank " + std::to_string(qr_f.rank().rank) +
                              " of 6): use more distinct sensor orientations");
  }
  ForceStage out;
  out.condition = qr_f.rank().condition_number;
  qr_f.applyQt(qt_f);
  const Vec6 l_f = qr_f.solveHead(qt_f.head<6>());
  Vec6 l = l_f;
  if (dynamic) {
    qr_f.applyQt(qt_a);
    const Vec6 l_a = qr_f.solveHead(qt_a.head<6>());  // l(G) = l_f + (G/g) l_a
    double G = l.head<3>().norm();
    for (int it = 0; it < options.max_iterations; ++it) {
      out.iterations = it + 1;
      l = l_f + (G / kStandardGravity) * l_a;
      const double G_new = l.head<3>().norm();
      const double change = std::abs(G_new - G);
      G = G_new;
      if (change <= options.tolerance * G) break;
    }
  }
  out.L = l.head<3>();
  out.F0 = l.tail<3>();
  out.G = out.L.norm();
  out.m = out.G / kStandardGravity;
  out.bread_inv = forceStageBreadInverse(contexts, qr_f.inverseGram(), out.L, out.G, dynamic);
  return out;
}

/// The torque stage's estimate h = [c, k].
struct TorqueStage {
  Vec3 c_S = Vec3::Zero();  ///< centre of mass in S [m]
  Vec3 k = Vec3::Zero();    ///< T0 - c x F0 [Nm]
  Eigen::MatrixXd gram_inv;  ///< (A_t^T A_t)^-1 of the measured-force regressor
  double condition = 0.0;
};

/// Torque stage (Eq. 5-9, corrected sign): t_i = -skew(f_i) c + k, k = T0 - c x F0.
/// The measured force already contains the inertial force -m a_S, so the same equation holds in
/// motion (no extra inertial term: paper Eq. 33/34/39 count it twice).
/// Rank from the regressor of the modelled (noise-free) force; solution, condition number and
/// covariance from that of the measured force. Both are compressed exactly.
TorqueStage solveTorqueStage(const std::vector<SampleContext>& contexts, const ForceStage& force,
                             const PaperOptions& options, bool dynamic) {
  const int n = static_cast<int>(contexts.size());
  // Data rows [f_i, 1, t_i] (measured force) and [f_model_i, 1].
  Eigen::MatrixXd D_meas(n, 7);
  Eigen::MatrixXd D_model(n, 4);
  for (int i = 0; i < n; ++i) {
    const SampleContext& c = contexts[static_cast<std::size_t>(i)];
    Vec3 model_f = c.R_BS.transpose() * force.L + force.F0;
    if (dynamic) model_f -= force.m * c.a_S;
    D_meas.block<1, 3>(i, 0) = c.wrench_S.head<3>().transpose();
    D_meas(i, 3) = 1.0;
    D_meas.block<1, 3>(i, 4) = c.wrench_S.tail<3>().transpose();
    D_model.block<1, 3>(i, 0) = model_f.transpose();
    D_model(i, 3) = 1.0;
  }
  Eigen::MatrixXd K_model = compressTorqueStage(D_model, false);
  const internal::RankReport rank_t_model = internal::analyzeRank(K_model, options.rank_tolerance);
  if (rank_t_model.rank < 6) {
    throw IdentificationError("the data do not determine " +
                              torqueStageNames(rank_t_model.unexcited_columns) +
                              " (torque stage rank " + std::to_string(rank_t_model.rank) +
                              " of 6): the payload force must take several non-parallel directions");
  }
  const Eigen::MatrixXd K_meas = compressTorqueStage(D_meas, true);
  Eigen::MatrixXd At = K_meas.leftCols<6>();
  Eigen::VectorXd qt_t = K_meas.col(6);
  const internal::ScaledQR qr_t(At, options.rank_tolerance);
  TorqueStage out;
  out.condition = qr_t.rank().condition_number;
  qr_t.applyQt(qt_t);
  const Vec6 h = qr_t.solveHead(qt_t.head<6>());
  out.c_S = h.head<3>();
  out.k = h.tail<3>();
  out.gram_inv = qr_t.inverseGram();
  return out;
}

/// Covariance of [L, F0, c, k]: one Newey-West sandwich over both stages (uncertainty.hpp), so
/// that it holds for autocorrelated (filtered) noise and includes the coupling of the stages
/// (the torque stage regresses on the measured, noisy force). Per sample i the scores are
///   force:  A_i^T r_f,i = [R_BS,i r_f,i; r_f,i],   r_f,i = f_i (+ m a_S,i) - R_BS,i^T L - F0
///   torque: A_t,i^T r_t,i = [f_i x r_t,i; r_t,i],   r_t,i = t_i - c x f_i - k
/// and the bread is blockdiag(B_f, A_t^T A_t).
CovarianceReport stageCovariance(const std::vector<SampleContext>& contexts, const ForceStage& force,
                                 const TorqueStage& torque, bool dynamic) {
  const int n = static_cast<int>(contexts.size());
  Eigen::MatrixXd scores(n, 12);
  Eigen::Matrix<double, 6, Eigen::Dynamic> stage_residual(6, n);
  for (int i = 0; i < n; ++i) {
    const SampleContext& c = contexts[static_cast<std::size_t>(i)];
    const Vec3 f = c.wrench_S.head<3>();
    Vec3 r_f = f - c.R_BS.transpose() * force.L - force.F0;
    if (dynamic) r_f += force.m * c.a_S;
    const Vec3 r_t = c.wrench_S.tail<3>() - torque.c_S.cross(f) - torque.k;
    stage_residual.col(i) << r_f, r_t;
    scores.block<1, 3>(i, 0) = (c.R_BS * r_f).transpose();
    scores.block<1, 3>(i, 3) = r_f.transpose();
    scores.block<1, 3>(i, 6) = f.cross(r_t).transpose();
    scores.block<1, 3>(i, 9) = r_t.transpose();
  }
  Eigen::MatrixXd bread_inv = Eigen::MatrixXd::Zero(12, 12);
  bread_inv.topLeftCorner<6, 6>() = force.bread_inv;
  bread_inv.bottomRightCorner<6, 6>() = torque.gram_inv;
  return scoreCovariance(scores, stage_residual, bread_inv);
}

/// The transforms (Eq. 21-23) into res (gravity force, offsets, centre of mass, weight, tilt,
/// mass) and res.params with their standard errors by the delta method from `cov_p`, the
/// covariance of p = [L, F0, c, k].
void reportParameters(const ForceStage& force, const TorqueStage& torque, const Eigen::MatrixXd& cov_p,
                      PaperResult& res) {
  const Vec3& L = force.L;
  const Vec3& F0 = force.F0;
  const Vec3& c_S = torque.c_S;
  const double G = force.G;
  const double m = force.m;
  res.gravity_force_B = L;
  res.k = torque.k;
  res.f0_S = F0;
  res.com_S = c_S;
  res.t0_S = torque.k + c_S.cross(F0);
  gravityToWeightAndTilt(L, &res.weight_N, &res.tilt_u_rad, &res.tilt_v_rad);
  res.mass_kg = m;

  // Outputs y = [G, U, V, F0 (3), c (3), T0 (3), m c (3)] as functions of p = [L, F0, c, k]:
  //   dG/dL = L^T / G;  U = asin(-L_y / G), V = atan2(L_x, -L_z);
  //   T0 = k + c x F0: dT0/dF0 = skew(c), dT0/dc = -skew(F0), dT0/dk = I;
  //   m c = (G / g) c: d/dL = c L^T / (g G), d/dc = m I.
  Eigen::Matrix<double, 15, 12> Jy = Eigen::Matrix<double, 15, 12>::Zero();
  const double u_arg = -L.y() / G;
  const double du = 1.0 / std::sqrt(std::max(1.0 - u_arg * u_arg, 1e-300));
  const double rxz = L.x() * L.x() + L.z() * L.z();
  Jy.block<1, 3>(0, 0) = L.transpose() / G;
  Jy.block<1, 3>(1, 0) = du * (-Vec3::UnitY().transpose() / G + L.y() * L.transpose() / (G * G * G));
  Jy.block<1, 3>(2, 0) << -L.z() / rxz, 0.0, L.x() / rxz;
  Jy.block<3, 3>(3, 3) = Mat3::Identity();
  Jy.block<3, 3>(6, 6) = Mat3::Identity();
  Jy.block<3, 3>(9, 3) = skew(c_S);
  Jy.block<3, 3>(9, 6) = -skew(F0);
  Jy.block<3, 3>(9, 9) = Mat3::Identity();
  Jy.block<3, 3>(12, 0) = c_S * L.transpose() / (kStandardGravity * G);
  Jy.block<3, 3>(12, 6) = m * Mat3::Identity();
  const Eigen::Matrix<double, 15, 15> cov_y = Jy * cov_p * Jy.transpose();
  auto sd = [&cov_y](int j) { return std::sqrt(std::max(cov_y(j, j), 0.0)); };
  const char* ax[3] = {"x", "y", "z"};
  res.params.push_back({"mass", m, sd(0) / kStandardGravity, "kg"});
  res.params.push_back({"weight", G, sd(0), "N"});
  for (int i = 0; i < 3; ++i) res.params.push_back({std::string("com_") + ax[i], c_S(i), sd(6 + i), "m"});
  for (int i = 0; i < 3; ++i) res.params.push_back({std::string("f0_") + ax[i], F0(i), sd(3 + i), "N"});
  for (int i = 0; i < 3; ++i) res.params.push_back({std::string("t0_") + ax[i], res.t0_S(i), sd(9 + i), "Nm"});
  res.params.push_back({"tilt_u", res.tilt_u_rad, sd(1), "rad"});
  res.params.push_back({"tilt_v", res.tilt_v_rad, sd(2), "rad"});
  for (int i = 0; i < 3; ++i) {
    res.params.push_back({std::string("mass_com_") + ax[i], m * c_S(i), sd(12 + i), "kg*m"});
  }
}

/// Residual of the full modelled wrench (what compensation leaves) into res.residual and
/// res.residual_rms, from res's L, F0, c, T0.
void fillResidual(const std::vector<SampleContext>& contexts, double m, bool dynamic, PaperResult& res) {
  const int n = static_cast<int>(contexts.size());
  res.residual.resize(6, n);
  for (int i = 0; i < n; ++i) {
    const SampleContext& c = contexts[static_cast<std::size_t>(i)];
    Vec3 payload_f = c.R_BS.transpose() * res.gravity_force_B;  // m g_S
    if (dynamic) payload_f -= m * c.a_S;
    Wrench model_w;
    model_w << payload_f + res.f0_S, res.com_S.cross(payload_f) + res.t0_S;
    res.residual.col(i) = c.wrench_S - model_w;
  }
  res.residual_rms = (res.residual.rowwise().squaredNorm() / n).cwiseSqrt();
}

}  // namespace

PaperResult identifyPaper(const std::vector<SampleContext>& contexts, const PaperOptions& options) {
  checkPaperInput(contexts);
  const bool dynamic = options.method == PaperMethod::kDynamic;
  PaperResult res;
  res.method = options.method;
  res.n_samples = static_cast<int>(contexts.size());
  const ForceStage force = solveForceStage(contexts, options, dynamic);
  res.condition_force = force.condition;
  res.iterations = force.iterations;
  const TorqueStage torque = solveTorqueStage(contexts, force, options, dynamic);
  res.condition_torque = torque.condition;
  const CovarianceReport hac = stageCovariance(contexts, force, torque, dynamic);
  res.variance_inflation = hac.variance_inflation;
  reportParameters(force, torque, hac.covariance, res);
  fillResidual(contexts, force.m, dynamic, res);
  return res;
}

ParameterSet PaperResult::toParameterSet() const {
  ParameterSet set;
  set.model = "paper";
  auto get = [this](const std::string& name) -> NamedValue {
    for (const auto& p : params) {
      if (p.name == name) return p;
    }
    return {name, 0.0, 0.0, ""};
  };
  for (const char* name : {"f0_x", "f0_y", "f0_z", "t0_x", "t0_y", "t0_z", "mass", "mass_com_x",
                           "mass_com_y", "mass_com_z"}) {
    set.params.push_back(get(name));
  }
  for (const char* name : {"weight", "com_x", "com_y", "com_z"}) set.derived.push_back(get(name));
  set.tilt_estimated = true;
  set.tilt_u_rad = tilt_u_rad;
  set.tilt_v_rad = tilt_v_rad;
  set.tilt_u_std = get("tilt_u").std;
  set.tilt_v_std = get("tilt_v").std;
  set.residual_rms = residual_rms;
  set.condition_number = std::max(condition_force, condition_torque);
  set.extras.push_back({"condition_number_force_stage", condition_force, 0.0, ""});
  set.extras.push_back({"condition_number_torque_stage", condition_torque, 0.0, ""});
  set.extras.push_back({"standard_error_variance_inflation", variance_inflation, 0.0, ""});
  set.extras.push_back({"fixed_point_iterations", static_cast<double>(iterations), 0.0, ""});
  set.provenance.method = std::string("paper-") + toString(method);
  set.provenance.n_samples = n_samples;
  return set;
}

}  // namespace ftid::identify
