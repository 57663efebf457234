// The paper's two-stage identification (include/ftid/identify/paper_method.hpp).
#include "ftid/identify/paper_method.hpp"

#include <cmath>
#include <string>

#include "fit_internal.hpp"
#include "ftid/common/error.hpp"

namespace ftid::identify {

namespace {

using effects::SampleContext;
using Mat6X = Eigen::Matrix<double, 6, Eigen::Dynamic>;

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

PaperResult identifyPaper(const std::vector<SampleContext>& contexts, const PaperOptions& options) {
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
  const bool dynamic = options.method == PaperMethod::kDynamic;
  PaperResult res;
  res.method = options.method;
  res.n_samples = n;

  // ---- Force stage (Eq. 14-20; dynamic Eq. 31-38 corrected): f_i + (G/g) a_i = R_i^T L + F0.
  Eigen::MatrixXd Af(3 * n, 6);
  Eigen::VectorXd f(3 * n);
  for (int i = 0; i < n; ++i) {
    const SampleContext& c = contexts[static_cast<std::size_t>(i)];
    Af.block<3, 3>(3 * i, 0) = c.R_BS.transpose();
    Af.block<3, 3>(3 * i, 3) = Mat3::Identity();
    f.segment<3>(3 * i) = c.wrench_S.head<3>();
  }
  const internal::RankReport rank_f = internal::analyzeRank(Af, options.rank_tolerance);
  if (rank_f.rank < 6) {
    throw IdentificationError("the data do not determine " + forceStageNames(rank_f.unexcited_columns) +
                              " (force stage rank " + std::to_string(rank_f.rank) +
                              " of 6): use more distinct sensor orientations");
  }
  res.condition_force = rank_f.condition_number;
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr_f(Af);
  Eigen::Matrix<double, 6, 1> l = qr_f.solve(f);
  if (dynamic) {
    Eigen::VectorXd rhs = f;
    double G = l.head<3>().norm();
    for (int it = 0; it < options.max_iterations; ++it) {
      res.iterations = it + 1;
      for (int i = 0; i < n; ++i) {
        rhs.segment<3>(3 * i) = f.segment<3>(3 * i) + (G / kStandardGravity) * contexts[static_cast<std::size_t>(i)].a_S;
      }
      l = qr_f.solve(rhs);
      const double G_new = l.head<3>().norm();
      const double change = std::abs(G_new - G);
      G = G_new;
      if (change <= options.tolerance * G) break;
    }
  }
  const Vec3 L = l.head<3>();
  const Vec3 F0 = l.tail<3>();
  const double G = L.norm();
  const double m = G / kStandardGravity;

  // Force-stage covariance from the Jacobian of the stage model at the solution.
  Eigen::MatrixXd Jf = Af;
  Eigen::VectorXd rf(3 * n);
  for (int i = 0; i < n; ++i) {
    const SampleContext& c = contexts[static_cast<std::size_t>(i)];
    Vec3 model_f = c.R_BS.transpose() * L + F0;
    if (dynamic) {
      model_f -= m * c.a_S;
      Jf.block<3, 3>(3 * i, 0) -= c.a_S * L.transpose() / (kStandardGravity * G);
    }
    rf.segment<3>(3 * i) = c.wrench_S.head<3>() - model_f;
  }
  const double s2_f = rf.squaredNorm() / (3 * n - 6);
  const Eigen::MatrixXd cov_l = s2_f * internal::inverseGram(Jf);

  // ---- Torque stage (Eq. 5-9, corrected sign): t_i = -skew(f_i) c + k, k = T0 - c x F0.
  // The measured force already contains the inertial force -m a_S, so the same equation holds in
  // motion (no extra inertial term: paper Eq. 33/34/39 count it twice).
  Eigen::MatrixXd At(3 * n, 6);
  Eigen::MatrixXd At_model(3 * n, 6);  // same with the modelled (noise-free) force, for the rank
  Eigen::VectorXd t(3 * n);
  for (int i = 0; i < n; ++i) {
    const SampleContext& c = contexts[static_cast<std::size_t>(i)];
    const Vec3 fi = c.wrench_S.head<3>();
    At.block<3, 3>(3 * i, 0) = -skew(fi);
    At.block<3, 3>(3 * i, 3) = Mat3::Identity();
    Vec3 model_f = c.R_BS.transpose() * L + F0;
    if (dynamic) model_f -= m * c.a_S;
    At_model.block<3, 3>(3 * i, 0) = -skew(model_f);
    At_model.block<3, 3>(3 * i, 3) = Mat3::Identity();
    t.segment<3>(3 * i) = c.wrench_S.tail<3>();
  }
  const internal::RankReport rank_t_model = internal::analyzeRank(At_model, options.rank_tolerance);
  if (rank_t_model.rank < 6) {
    throw IdentificationError("the data do not determine " +
                              torqueStageNames(rank_t_model.unexcited_columns) +
                              " (torque stage rank " + std::to_string(rank_t_model.rank) +
                              " of 6): the payload force must take several non-parallel directions");
  }
  const internal::RankReport rank_t = internal::analyzeRank(At, options.rank_tolerance);
  res.condition_torque = rank_t.condition_number;
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr_t(At);
  const Eigen::Matrix<double, 6, 1> h = qr_t.solve(t);
  const Vec3 c_S = h.head<3>();
  const Vec3 k = h.tail<3>();
  const Eigen::VectorXd rt = t - At * h;
  const double s2_t = rt.squaredNorm() / (3 * n - 6);
  const Eigen::MatrixXd cov_h = s2_t * internal::inverseGram(At);

  // ---- Transforms (Eq. 21-23) and the delta method.
  res.gravity_force_B = L;
  res.k = k;
  res.f0_S = F0;
  res.com_S = c_S;
  res.t0_S = k + c_S.cross(F0);
  gravityToWeightAndTilt(L, &res.weight_N, &res.tilt_u_rad, &res.tilt_v_rad);
  res.mass_kg = m;

  const Eigen::Matrix3d cov_L = cov_l.topLeftCorner<3, 3>();
  const Eigen::Matrix3d cov_F0 = cov_l.bottomRightCorner<3, 3>();
  // d(G, U, V)/dL
  Eigen::Matrix3d Jg;
  const double u_arg = -L.y() / G;
  const double du = 1.0 / std::sqrt(std::max(1.0 - u_arg * u_arg, 1e-300));
  const double rxz = L.x() * L.x() + L.z() * L.z();
  Jg.row(0) = L.transpose() / G;
  Jg.row(1) = du * (-Vec3::UnitY().transpose() / G + L.y() * L.transpose() / (G * G * G));
  Jg.row(2) << -L.z() / rxz, 0.0, L.x() / rxz;
  const Eigen::Matrix3d cov_guv = Jg * cov_L * Jg.transpose();
  const Eigen::Matrix3d cov_c = cov_h.topLeftCorner<3, 3>();
  // T0 = k + c x F0 = k - skew(F0) c = k + skew(c) F0 (stages treated as independent)
  Eigen::Matrix<double, 3, 6> Jt;
  Jt.leftCols<3>() = -skew(F0);
  Jt.rightCols<3>() = Mat3::Identity();
  const Eigen::Matrix3d cov_t0 = Jt * cov_h * Jt.transpose() + skew(c_S) * cov_F0 * skew(c_S).transpose();
  // m c: d/dG = c/g, d/dc = m
  const Eigen::Matrix3d cov_mc = c_S * c_S.transpose() * cov_guv(0, 0) / (kStandardGravity * kStandardGravity) +
                                 m * m * cov_c;
  auto sd = [](double var) { return std::sqrt(std::max(var, 0.0)); };
  const char* ax[3] = {"x", "y", "z"};
  res.params.push_back({"mass", m, sd(cov_guv(0, 0)) / kStandardGravity, "kg"});
  res.params.push_back({"weight", G, sd(cov_guv(0, 0)), "N"});
  for (int i = 0; i < 3; ++i) res.params.push_back({std::string("com_") + ax[i], c_S(i), sd(cov_c(i, i)), "m"});
  for (int i = 0; i < 3; ++i) res.params.push_back({std::string("f0_") + ax[i], F0(i), sd(cov_F0(i, i)), "N"});
  for (int i = 0; i < 3; ++i) res.params.push_back({std::string("t0_") + ax[i], res.t0_S(i), sd(cov_t0(i, i)), "Nm"});
  res.params.push_back({"tilt_u", res.tilt_u_rad, sd(cov_guv(1, 1)), "rad"});
  res.params.push_back({"tilt_v", res.tilt_v_rad, sd(cov_guv(2, 2)), "rad"});
  for (int i = 0; i < 3; ++i) {
    res.params.push_back({std::string("mass_com_") + ax[i], m * c_S(i), sd(cov_mc(i, i)), "kg*m"});
  }

  // ---- Residual of the full modelled wrench (what compensation leaves).
  res.residual.resize(6, n);
  for (int i = 0; i < n; ++i) {
    const SampleContext& c = contexts[static_cast<std::size_t>(i)];
    Vec3 payload_f = c.R_BS.transpose() * L;  // m g_S
    if (dynamic) payload_f -= m * c.a_S;
    Wrench model_w;
    model_w << payload_f + F0, c_S.cross(payload_f) + res.t0_S;
    res.residual.col(i) = c.wrench_S - model_w;
  }
  res.residual_rms = (res.residual.rowwise().squaredNorm() / n).cwiseSqrt();
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
  set.extras.push_back({"fixed_point_iterations", static_cast<double>(iterations), 0.0, ""});
  set.provenance.method = std::string("paper-") + toString(method);
  set.provenance.n_samples = n_samples;
  return set;
}

}  // namespace ftid::identify
