// The IMU combined with a wrench fit (include/ftid/identify/imu_fusion.hpp).
#include "ftid/identify/imu_fusion.hpp"

#include <cmath>
#include <cstdio>

#include <Eigen/Geometry>

#include "ftid/common/error.hpp"

namespace ftid::identify {

namespace {

constexpr double kPiHere = 3.141592653589793;
constexpr double kRadToDeg = 180.0 / kPiHere;

double wrapAngle(double a) { return std::remainder(a, 2.0 * kPiHere); }

// The IMU estimators stop once a Gauss-Newton step is below 1e-12 (rad, s; imu.cpp), and the
// estimates are computed in double precision from kinematics: a difference below this resolution
// is not resolved. Its variance is part of every compared difference's covariance. It matters only
// when the IMU is noise-free (a simulator's default), where the residual-based covariance would
// otherwise be ~1e-35 and rounding alone would read as a disagreement.
constexpr double kEstimateResolution = 1e-12;

ImuComparison compare(const std::string& quantity, const Eigen::VectorXd& d, const Eigen::MatrixXd& S_estimates) {
  ImuComparison c;
  c.quantity = quantity;
  c.dof = static_cast<int>(d.size());
  c.limit = chiSquare999(c.dof);
  const Eigen::MatrixXd S =
      S_estimates + Eigen::MatrixXd::Identity(d.size(), d.size()) * (kEstimateResolution * kEstimateResolution);
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(S);
  const bool pd = ldlt.info() == Eigen::Success && ldlt.isPositive() && (ldlt.vectorD().array() > 0.0).all();
  c.chi2 = pd ? d.dot(ldlt.solve(d)) : (d.isZero(0.0) ? 0.0 : std::numeric_limits<double>::infinity());
  c.disagrees = c.chi2 > c.limit;
  return c;
}

Mat3 rpyRotation(const Vec3& rpy) {
  return (Eigen::AngleAxisd(rpy.z(), Vec3::UnitZ()) * Eigen::AngleAxisd(rpy.y(), Vec3::UnitY()) *
          Eigen::AngleAxisd(rpy.x(), Vec3::UnitX()))
      .toRotationMatrix();
}

void refreshDerived(FitResult& res) {
  const auto column = [&](const std::string& name) {
    for (std::size_t j = 0; j < res.params.size(); ++j) {
      if (res.params[j].name == name) return static_cast<int>(j);
    }
    return -1;
  };
  res.derived.clear();
  const int cm = column("mass");
  if (cm < 0) return;
  res.derived.push_back({"weight", kStandardGravity * res.theta(cm), kStandardGravity * res.theta_std(cm), "N"});
  const char* mc_names[3] = {"mass_com_x", "mass_com_y", "mass_com_z"};
  const char* com_names[3] = {"com_x", "com_y", "com_z"};
  for (int k = 0; k < 3; ++k) {
    const int cj = column(mc_names[k]);
    if (cj < 0) continue;
    const double m = res.theta(cm);
    const double mc = res.theta(cj);
    const Eigen::Vector2d grad(-mc / (m * m), 1.0 / m);
    Eigen::Matrix2d C;
    C << res.covariance(cm, cm), res.covariance(cm, cj), res.covariance(cj, cm), res.covariance(cj, cj);
    res.derived.push_back({com_names[k], mc / m, std::sqrt(std::max(grad.dot(C * grad), 0.0)), "m"});
  }
}

}  // namespace

double chiSquare999(int dof) {
  switch (dof) {
    case 1: return 10.828;
    case 2: return 13.816;
    case 3: return 16.266;
    default: throw std::invalid_argument("chiSquare999: dof " + std::to_string(dof) + " not tabulated");
  }
}

FitResult fuseImuTilt(const effects::Model& model, const std::vector<effects::SampleContext>& contexts,
                      const FitResult& wrench_fit, const AccTiltEstimate& imu_tilt) {
  if (!wrench_fit.tilt_estimated) throw IdentificationError("IMU fusion: the wrench fit estimates no tilt");
  const int p = static_cast<int>(wrench_fit.theta.size());
  const int k = static_cast<int>(wrench_fit.covariance.rows());
  const Eigen::MatrixXd& P = wrench_fit.covariance;
  const Eigen::MatrixXd PHt = P.middleCols(p, 2);  // tilt is the first nonlinear parameter
  const Eigen::Matrix2d S = P.block<2, 2>(p, p) + imu_tilt.tiltCovariance();
  const Eigen::LDLT<Eigen::Matrix2d> ldlt(S);
  if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().array() > 0.0).all()) {
    throw IdentificationError("IMU fusion: the combined tilt covariance is not positive definite");
  }
  const Eigen::Vector2d d(wrapAngle(imu_tilt.tilt_u_rad - wrench_fit.tilt_u_rad),
                          wrapAngle(imu_tilt.tilt_v_rad - wrench_fit.tilt_v_rad));
  const Eigen::MatrixXd K = ldlt.solve(PHt.transpose()).transpose();  // k x 2
  Eigen::VectorXd x(k);
  x.head(p) = wrench_fit.theta;
  x.tail(k - p) = Eigen::VectorXd::Zero(k - p);
  const Eigen::VectorXd dx = K * d;

  FitResult res = wrench_fit;
  res.theta = wrench_fit.theta + dx.head(p);
  res.covariance = P - K * S * K.transpose();
  res.covariance = 0.5 * (res.covariance + res.covariance.transpose()).eval();
  res.theta_std = res.covariance.diagonal().head(p).cwiseMax(0.0).cwiseSqrt();
  auto sd = [&](int j) { return std::sqrt(std::max(res.covariance(p + j, p + j), 0.0)); };
  res.tilt_u_rad = wrench_fit.tilt_u_rad + dx(p);
  res.tilt_v_rad = wrench_fit.tilt_v_rad + dx(p + 1);
  res.tilt_u_std = sd(0);
  res.tilt_v_std = sd(1);
  int next = 2;
  if (res.mounting_estimated) {
    for (int i = 0; i < 3; ++i) {
      res.mount_rpy_rad(i) += dx(p + next + i);
      res.mount_rpy_std(i) = sd(next + i);
    }
    next += 3;
  }
  if (res.delay_estimated) {
    res.delay_s += dx(p + next);
    res.delay_std = sd(next);
  }
  refreshDerived(res);
  // The fused fit's residual by the compensator's evaluation (excluded samples count as zero, as in fitModel).
  std::vector<int> all(contexts.size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  const Eigen::Matrix<double, 6, Eigen::Dynamic> predicted = predictWrench(model, res, contexts, all);
  Eigen::Matrix<double, 6, Eigen::Dynamic> r(6, static_cast<Eigen::Index>(contexts.size()));
  for (std::size_t i = 0; i < contexts.size(); ++i) {
    const auto col = static_cast<Eigen::Index>(i);
    r.col(col) = wrench_fit.residual.col(col).isZero(0.0) ? Vec6::Zero().eval()
                                                         : Vec6(contexts[i].wrench_S - predicted.col(col));
  }
  res.residual = r;
  const int n_active = std::max(1, res.n_samples - res.n_excluded);
  res.residual_rms = (res.residual.rowwise().squaredNorm() / n_active).cwiseSqrt();
  return res;
}

std::string apparentTiltReason(const effects::Model& model) {
  const std::string absorbers = model.tiltAbsorbers();
  if (absorbers.empty()) return "";
  return "tilt not compared: " + model.name() + " folds the horizontal pull of " + absorbers +
         " into its tilt (an apparent tilt, docs/effects.md); the base's mounting tilt is the IMU's";
}

std::vector<ImuComparison> compareImuWithFit(const FitResult& fit, const ImuEstimate& imu) {
  std::vector<ImuComparison> out;
  char line[260];
  const int p = static_cast<int>(fit.theta.size());
  if (fit.tilt_estimated) {
    const Eigen::Vector2d d(wrapAngle(imu.acc.tilt_u_rad - fit.tilt_u_rad), wrapAngle(imu.acc.tilt_v_rad - fit.tilt_v_rad));
    ImuComparison c = compare("tilt", d, fit.covariance.block(p, p, 2, 2) + imu.acc.tiltCovariance());
    std::snprintf(line, sizeof(line),
                  "tilt: IMU U %.4f V %.4f deg, wrench U %.4f V %.4f deg; difference %.4f / %.4f deg, "
                  "chi2 %.3g (limit %.3g)",
                  imu.acc.tilt_u_rad * kRadToDeg, imu.acc.tilt_v_rad * kRadToDeg, fit.tilt_u_rad * kRadToDeg,
                  fit.tilt_v_rad * kRadToDeg, d(0) * kRadToDeg, d(1) * kRadToDeg, c.chi2, c.limit);
    c.message = line;
    out.push_back(c);
  }
  std::optional<MountEstimate> mount;
  if (fit.mounting_estimated) mount = MountEstimate{fit.mount_rpy_rad, fit.mount_rpy_std};
  std::optional<DelayEstimate> delay;
  if (fit.delay_estimated) delay = DelayEstimate{fit.delay_s, fit.delay_std};
  for (auto& c : compareImuMountAndDelay(mount, delay, imu.gyro)) {
    if (c.quantity == "mount" && fit.mounting_estimated) {
      // The fit's full mount covariance (correlations included) instead of its diagonal.
      const int m0 = p + 2 * static_cast<int>(fit.tilt_estimated);
      const Eigen::AngleAxisd aa(imu.gyro.R_SM * rpyRotation(fit.mount_rpy_rad).transpose());
      const Eigen::Vector3d d = aa.angle() * aa.axis();
      const Eigen::Matrix3d S = imu.gyro.covariance.topLeftCorner<3, 3>() + fit.covariance.block(m0, m0, 3, 3);
      c = compare("mount", d, S);
      std::snprintf(line, sizeof(line), "mount: the gyro's frame is rotated by %.3f deg against the wrench fit's mounting, chi2 %.3g (limit %.3g)",
                    aa.angle() * kRadToDeg, c.chi2, c.limit);
      c.message = line;
    }
    out.push_back(c);
  }
  return out;
}

std::vector<ImuComparison> compareImuMountAndDelay(const std::optional<MountEstimate>& mount,
                                                   const std::optional<DelayEstimate>& delay,
                                                   const GyroMountEstimate& gyro) {
  std::vector<ImuComparison> out;
  char line[260];
  {
    const Mat3 R_ref = mount ? rpyRotation(mount->rpy_rad) : Mat3::Identity();
    const Eigen::AngleAxisd aa(gyro.R_SM * R_ref.transpose());
    const Eigen::Vector3d d = aa.angle() * aa.axis();
    Eigen::Matrix3d S = gyro.covariance.topLeftCorner<3, 3>();
    if (mount) S += mount->rpy_std.cwiseAbs2().asDiagonal();
    ImuComparison c = compare("mount", d, S);
    std::snprintf(line, sizeof(line), "mount: the gyro's frame is rotated by %.3f deg against the %s, chi2 %.3g (limit %.3g)",
                  aa.angle() * kRadToDeg, mount ? "given mounting" : "configured sensor frame", c.chi2, c.limit);
    c.message = line;
    out.push_back(c);
  }
  if (gyro.delay_estimated) {
    const double ref = delay ? delay->delay_s : 0.0;
    Eigen::VectorXd d(1);
    d(0) = gyro.delay_s - ref;
    Eigen::MatrixXd S(1, 1);
    S(0, 0) = gyro.covariance(6, 6) + (delay ? delay->delay_std * delay->delay_std : 0.0);
    ImuComparison c = compare("delay", d, S);
    std::snprintf(line, sizeof(line), "delay: IMU stream %.2f ms, %s %.2f ms, chi2 %.3g (limit %.3g)", gyro.delay_s * 1e3,
                  delay ? "given" : "configured", ref * 1e3, c.chi2, c.limit);
    c.message = line;
    out.push_back(c);
  }
  return out;
}

ImuComparison compareImuTilt(double u_rad, double v_rad, double u_std, double v_std, const AccTiltEstimate& imu) {
  const Eigen::Vector2d d(wrapAngle(imu.tilt_u_rad - u_rad), wrapAngle(imu.tilt_v_rad - v_rad));
  Eigen::Matrix2d S = imu.tiltCovariance();
  S(0, 0) += u_std * u_std;
  S(1, 1) += v_std * v_std;
  ImuComparison c = compare("tilt", d, S);
  char line[200];
  std::snprintf(line, sizeof(line), "tilt: IMU U %.4f V %.4f deg, wrench U %.4f V %.4f deg, chi2 %.3g (limit %.3g)",
                imu.tilt_u_rad * kRadToDeg, imu.tilt_v_rad * kRadToDeg, u_rad * kRadToDeg, v_rad * kRadToDeg, c.chi2,
                c.limit);
  c.message = line;
  return c;
}

}  // namespace ftid::identify
