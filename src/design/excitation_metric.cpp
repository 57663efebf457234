// Excitation metric: information matrix, condition number, D-optimality and predicted standard
// errors of a model's parameters for a sampled motion (see header and docs/design.md).
#include "ftid/design/excitation_metric.hpp"

#include "ftid/identify/imu.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "ftid/common/error.hpp"
#include "ftid/design/parametrization.hpp"
#include "ftid/samples/context.hpp"
#include "ftid/logio/log.hpp"
#include "ftid/model/frames.hpp"

namespace ftid::design {

namespace {
constexpr double kTiltStep = 1e-6;  // [rad], central difference for the tilt columns (exact for
                                    // regressors linear in g_S up to rounding)
}

std::map<std::string, double> defaultNominalParameters() {
  // Paper Table 2 payload (Duan et al. 2022).
  const double m = 8.862 / kStandardGravity;
  return {{"mass", m},      {"com_x", 0.005}, {"com_y", 0.002}, {"com_z", 0.051}, {"f0_x", -0.6672},
          {"f0_y", 0.8565}, {"f0_z", 0.3538}, {"t0_x", 0.0228}, {"t0_y", 0.0084}, {"t0_z", 0.0080}};
}

Vec6 parseNoise(const std::string& text) {
  Vec6 sigma = Vec6::Constant(std::numeric_limits<double>::quiet_NaN());
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    const auto eq = item.find('=');
    if (eq == std::string::npos)
      throw ConfigError("--noise: expected axis=value, got '" + item + "'");
    const std::string key = item.substr(0, eq);
    double v = 0.0;
    try {
      std::size_t used = 0;
      v = std::stod(item.substr(eq + 1), &used);
      if (used != item.size() - eq - 1) throw std::invalid_argument("trailing");
    } catch (const std::exception&) {
      throw ConfigError("--noise: '" + item + "': value is not a number");
    }
    if (!(v > 0.0) || !std::isfinite(v))
      throw ConfigError("--noise: '" + item + "': must be positive");
    bool known = false;
    for (int i = 0; i < 6; ++i) {
      const std::string axis = kWrenchAxisNames[i];
      if (key == axis || (key == "f" && i < 3) || (key == "t" && i >= 3)) {
        sigma[i] = v;
        known = true;
      }
    }
    if (!known)
      throw ConfigError("--noise: unknown axis '" + key +
                        "' (fx fy fz tx ty tz, or f / t for all three)");
  }
  for (int i = 0; i < 6; ++i) {
    if (std::isnan(sigma[i])) {
      throw ConfigError(std::string("--noise: no value for axis ") + kWrenchAxisNames[i] +
                        " (give all six)");
    }
  }
  return sigma;
}

ExcitationMetric::ExcitationMetric(effects::Model model, const model::RobotKinematics& kinematics,
                                   const trajectory::TrajectoryConstraints& constraints,
                                   const std::map<std::string, double>& nominal,
                                   const Vec6& noise_sigma)
    : model_(std::move(model)),
      kinematics_(kinematics),
      constraints_(constraints),
      sigma_(noise_sigma),
      nominal_(nominal) {
  if (!(sigma_.array() > 0.0).all() || !sigma_.allFinite())
    throw ConfigError("noise: all six sigmas must be positive");
  const auto& names = model_.paramIndex().names();
  theta_nom_ = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(names.size()));
  auto get = [&](const std::string& k, double& v) {
    auto it = nominal_.find(k);
    if (it == nominal_.end()) return false;
    v = it->second;
    return true;
  };
  for (std::size_t i = 0; i < names.size(); ++i) {
    double v = 0.0;
    if (get(names[i], v)) {
      theta_nom_[static_cast<Eigen::Index>(i)] = v;
    } else if (names[i].rfind("mass_com_", 0) == 0) {
      double m = 0.0, c = 0.0;
      if (get("mass", m) && get("com_" + names[i].substr(9), c))
        theta_nom_[static_cast<Eigen::Index>(i)] = m * c;
    }
    names_.push_back(names[i]);
  }
  tilt_ = model_.estimatesTilt();
  if (tilt_) {
    names_.emplace_back("tilt_u");
    names_.emplace_back("tilt_v");
  }
}

Eigen::MatrixXd ExcitationMetric::information(const SampledMotion& motion, double weight,
                                              std::vector<Eigen::Isometry3d>* sensor_poses) const {
  const auto K = static_cast<std::size_t>(motion.q.cols());
  logio::LogData log;
  log.source = "<designed trajectory>";
  log.has_wrench = true;  // zero readings: the regressor does not read them
  log.samples.resize(K);
  for (std::size_t k = 0; k < K; ++k) {
    auto& s = log.samples[k];
    s.t = motion.t[k];
    s.q = motion.q.col(static_cast<Eigen::Index>(k));
    s.qd = motion.qd.col(static_cast<Eigen::Index>(k));
    s.qdd = motion.qdd.col(static_cast<Eigen::Index>(k));
  }
  samples::ContextOptions opts;
  opts.R_FS = constraints_.R_FS;
  opts.p_FS_F = constraints_.p_FS_F;
  samples::ContextSet ctxs = samples::buildContexts(log, kinematics_, opts);

  const int P = model_.numParams();
  const int C = numColumns();
  Eigen::Matrix<double, 6, Eigen::Dynamic> Y(6, P), Yp(6, P), Ym(6, P);
  Eigen::Matrix<double, 6, Eigen::Dynamic> J(6, C);
  Eigen::MatrixXd info = Eigen::MatrixXd::Zero(C, C);
  const Vec6 inv_sigma = sigma_.cwiseInverse();
  const bool imu = (model_.signals() & effects::kSignalImu) != 0;
  const Vec3 g_p_u = model::gravityInBase(kTiltStep, 0.0),
             g_m_u = model::gravityInBase(-kTiltStep, 0.0);
  const Vec3 g_p_v = model::gravityInBase(0.0, kTiltStep),
             g_m_v = model::gravityInBase(0.0, -kTiltStep);
  if (sensor_poses != nullptr) sensor_poses->resize(K);
  for (std::size_t k = 0; k < ctxs.samples.size(); ++k) {
    effects::SampleContext& ctx = ctxs.samples[k];
    if (imu) {  // an ideal IMU rigidly on S (docs/conventions.md: acc = R_WS^T (a_W - g_W))
      ctx.imu_acc_S = ctx.a_S - ctx.g_S;
      ctx.imu_w_S = ctx.w_S;
      ctx.imu_alpha_S = ctx.alpha_S;
      ctx.has_imu = true;
    }
    model_.computeRegressor(ctx, Y);
    J.leftCols(P) = Y;
    if (tilt_) {
      const Vec3 g0 = ctx.g_S;
      const Mat3 Rt = ctx.R_BS.transpose();
      ctx.g_S = Rt * g_p_u;
      model_.computeRegressor(ctx, Yp);
      ctx.g_S = Rt * g_m_u;
      model_.computeRegressor(ctx, Ym);
      J.col(P) = (Yp - Ym) * theta_nom_ / (2.0 * kTiltStep);
      ctx.g_S = Rt * g_p_v;
      model_.computeRegressor(ctx, Yp);
      ctx.g_S = Rt * g_m_v;
      model_.computeRegressor(ctx, Ym);
      J.col(P + 1) = (Yp - Ym) * theta_nom_ / (2.0 * kTiltStep);
      ctx.g_S = g0;
    }
    J = inv_sigma.asDiagonal() * J;
    info.noalias() += weight * (J.transpose() * J);
    if (sensor_poses != nullptr) {
      Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
      X.linear() = ctx.R_BS;
      X.translation() = ctx.p_BS_B;
      (*sensor_poses)[k] = X;
    }
  }
  return info;
}

Eigen::MatrixXd ExcitationMetric::information(const std::vector<JointVector>& q,
                                              const std::vector<JointVector>& qd,
                                              const std::vector<JointVector>& qdd,
                                              double weight) const {
  SampledMotion m;
  const auto K = static_cast<Eigen::Index>(q.size());
  m.q.resize(kNumJoints, K);
  m.qd.resize(kNumJoints, K);
  m.qdd.resize(kNumJoints, K);
  for (Eigen::Index k = 0; k < K; ++k) {
    const auto ku = static_cast<std::size_t>(k);
    m.t.push_back(static_cast<double>(k));
    m.q.col(k) = q[ku];
    m.qd.col(k) = qd[ku];
    m.qdd.col(k) = qdd[ku];
  }
  return information(m, weight);
}

namespace {
bool scaled(const Eigen::MatrixXd& info, Eigen::MatrixXd& S) {
  const Eigen::VectorXd d = info.diagonal();
  if (!(d.array() > 0.0).all() || !d.allFinite()) return false;
  const Eigen::VectorXd s = d.cwiseSqrt().cwiseInverse();
  S = s.asDiagonal() * info * s.asDiagonal();
  return true;
}
}  // namespace

double ExcitationMetric::conditionNumber(const Eigen::MatrixXd& info) {
  Eigen::MatrixXd S;
  if (!scaled(info, S)) return std::numeric_limits<double>::infinity();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(S, Eigen::EigenvaluesOnly);
  const double lmin = es.eigenvalues().minCoeff();
  const double lmax = es.eigenvalues().maxCoeff();
  if (!(lmin > lmax * 1e-16)) return std::numeric_limits<double>::infinity();
  return std::sqrt(lmax / lmin);
}

double ExcitationMetric::dOptimality(const Eigen::MatrixXd& info, double n_samples) {
  Eigen::LLT<Eigen::MatrixXd> llt(info / n_samples);
  if (llt.info() != Eigen::Success) return std::numeric_limits<double>::infinity();
  const double logdet = 2.0 * llt.matrixL().toDenseMatrix().diagonal().array().log().sum();
  if (!std::isfinite(logdet)) return std::numeric_limits<double>::infinity();
  return -logdet / static_cast<double>(info.rows());
}

std::vector<std::string> ExcitationMetric::weakColumns(const Eigen::MatrixXd& info,
                                                       double threshold) const {
  std::vector<std::string> out;
  Eigen::MatrixXd S;
  if (!scaled(info, S)) {
    for (Eigen::Index i = 0; i < info.rows(); ++i) {
      if (!(info(i, i) > 0.0)) out.push_back(names_[static_cast<std::size_t>(i)]);
    }
    return out;
  }
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(S);
  const double lmax = es.eigenvalues().maxCoeff();
  for (Eigen::Index e = 0; e < S.rows(); ++e) {
    if (es.eigenvalues()[e] > threshold * lmax) continue;
    for (Eigen::Index i = 0; i < S.rows(); ++i) {
      const std::string& n = names_[static_cast<std::size_t>(i)];
      if (std::abs(es.eigenvectors()(i, e)) > 0.3 &&
          std::find(out.begin(), out.end(), n) == out.end()) {
        out.push_back(n);
      }
    }
  }
  return out;
}

Eigen::MatrixXd ExcitationMetric::informationWithImu(const SampledMotion& motion, const Eigen::MatrixXd& info,
                                                     double acc_std, double gyro_std, double weight) const {
  if (!tilt_) return info;
  const auto K = static_cast<std::size_t>(motion.q.cols());
  logio::LogData log;
  log.source = "<designed trajectory>";
  log.has_wrench = true;
  log.samples.resize(K);
  for (std::size_t k = 0; k < K; ++k) {
    auto& s = log.samples[k];
    s.t = motion.t[k];
    s.q = motion.q.col(static_cast<Eigen::Index>(k));
    s.qd = motion.qd.col(static_cast<Eigen::Index>(k));
    s.qdd = motion.qdd.col(static_cast<Eigen::Index>(k));
  }
  samples::ContextOptions opts;
  opts.R_FS = constraints_.R_FS;
  opts.p_FS_F = constraints_.p_FS_F;
  const samples::ContextSet ctxs = samples::buildContexts(log, kinematics_, opts);
  const Eigen::Matrix2d cov = identify::predictImuTiltCovariance(ctxs.samples, acc_std, gyro_std, true);
  Eigen::MatrixXd out = info;
  if (!cov.allFinite()) return out;
  const int P = model_.numParams();
  out.block(P, P, 2, 2) += weight * cov.inverse();
  return out;
}

std::map<std::string, double> ExcitationMetric::predictedStd(const Eigen::MatrixXd& info) const {
  std::map<std::string, double> out;
  Eigen::MatrixXd S;
  if (!scaled(info, S)) return out;
  // Invert the scaled matrix (better conditioned), then unscale.
  Eigen::LDLT<Eigen::MatrixXd> ldlt(S);
  if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().array() > 0.0).all()) return out;
  const Eigen::VectorXd s = info.diagonal().cwiseSqrt().cwiseInverse();
  const Eigen::MatrixXd cov =
      s.asDiagonal() * ldlt.solve(Eigen::MatrixXd::Identity(S.rows(), S.cols())) * s.asDiagonal();
  for (std::size_t i = 0; i < names_.size(); ++i) {
    const auto ii = static_cast<Eigen::Index>(i);
    out[names_[i]] = std::sqrt(std::max(0.0, cov(ii, ii)));
  }
  const auto& idx = model_.paramIndex();
  const int im = idx.column("mass");
  if (im >= 0) {
    const double m = theta_nom_[im];
    out["weight"] = kStandardGravity * out["mass"];
    const char* axes[3] = {"x", "y", "z"};
    for (int a = 0; a < 3; ++a) {
      const int ic = idx.column(std::string("mass_com_") + axes[a]);
      if (ic < 0 || !(m > 0.0)) continue;
      // com = mc / m:  d com = (d mc - com d m) / m
      const double com = theta_nom_[ic] / m;
      Eigen::VectorXd g = Eigen::VectorXd::Zero(cov.rows());
      g[ic] = 1.0 / m;
      g[im] = -com / m;
      out[std::string("com_") + axes[a]] = std::sqrt(std::max(0.0, g.dot(cov * g)));
    }
  }
  return out;
}

}  // namespace ftid::design
