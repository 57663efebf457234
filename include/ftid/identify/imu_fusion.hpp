#pragma once
// The IMU's payload-free answers (ftid/identify/imu.hpp) combined with a wrench fit
// (docs/identification.md, "The IMU as a measurement"): the IMU's tilt fused into the fit, and
// the two compared where both answer (tilt, mounting, delay).
//
// Fusion. The wrench fit x = [theta; U; V; mount; delay] with covariance P (its sandwich
// covariance) and the accelerometer's tilt z = (U, V) with covariance R are independent
// estimates. The fused estimate minimises the stacked cost
//     |x - x_w|^2_{P^-1} + |z - H x|^2_{R^-1}          (H picks U, V)
// which is the wrench fit's own cost to second order around its minimum (variable projection:
// the projected cost is quadratic in the nonlinear parameters there, with Hessian P^-1) plus the
// IMU's rows with their weights. Its solution is one Gauss-Newton step of the stacked problem:
//     S = H P H^T + R,   K = P H^T S^-1,   x = x_w + K (z - H x_w),   P_fused = P - K S K^T.
// The linear parameters follow the tilt through their correlation with it (in P); mounting and
// delay likewise. Exact for a fit linear in the tilt near its minimum; the tilt difference is a
// few wrench standard errors at most (else the two disagree, below), where the curvature of the
// projected cost changes by less than a percent.
//
// Comparison. d = z - H x_w with covariance S: chi2 = d^T S^-1 d against the chi-square quantile
// of probability 0.999 (13.82 for 2 degrees of freedom). Beyond it the IMU and the wrench
// disagree: a set-up error (a wrong sensor mount, a wrong robot model, a contact) or a bad IMU.
// The gyro's mount rotation and delay are compared with the fit's `mounting` / `sensor_delay`
// when the model has them (the same test, 3 and 1 degrees of freedom), and otherwise against the
// configured frame (identity) and no delay.
#include <optional>
#include <string>
#include <vector>

#include "ftid/identify/fit.hpp"
#include "ftid/identify/imu.hpp"

namespace ftid::identify {

/// One comparison of the IMU with the wrench fit (or with the configuration).
struct ImuComparison {
  std::string quantity;   ///< "tilt", "mount", "delay"
  double chi2 = 0.0;
  int dof = 0;
  double limit = 0.0;     ///< the 0.999 quantile of chi-square with dof degrees of freedom
  bool disagrees = false;
  std::string message;    ///< one line, also when they agree
};

/// The fused fit (see above). Requires a fit with the tilt estimated; throws IdentificationError
/// otherwise, or when the combined covariance is not positive definite. `model`/`contexts` give the
/// fused fit's residual (the compensator's evaluation, as fitModel's).
FitResult fuseImuTilt(const effects::Model& model, const std::vector<effects::SampleContext>& contexts,
                      const FitResult& wrench_fit, const AccTiltEstimate& imu_tilt);

/// Why `model`'s tilt is not the base's mounting tilt, so that the IMU's tilt can neither check nor
/// be fused into it: "" for most models; for a model that folds a uniform pull into its tilt
/// (effects::Model::tiltAbsorbers(), e.g. `cable`) a sentence naming it. Such a model's tilt
/// differs from the IMU's by the pull's horizontal part, which is no set-up error.
std::string apparentTiltReason(const effects::Model& model);

/// The comparisons that apply: tilt (when the fit estimates it), mount and delay (against the fit's
/// `mounting` / `sensor_delay`, or against the configuration when the model has none).
std::vector<ImuComparison> compareImuWithFit(const FitResult& wrench_fit, const ImuEstimate& imu);

/// A value with its standard error (for compareImuMountAndDelay).
struct MountEstimate {
  Vec3 rpy_rad = Vec3::Zero();   ///< R_SM = Rz(yaw) Ry(pitch) Rx(roll)
  Vec3 rpy_std = Vec3::Zero();   ///< taken as the std of the rotation about S's axes (small angles)
};
struct DelayEstimate {
  double delay_s = 0.0;
  double delay_std = 0.0;
};

/// For callers with their own answer for the sensor's mount and delay (the laboratory's `mounting`
/// and `sensor_delay`, a configuration): the gyro's frame and delay against them. An absent mount
/// or delay is compared with the configured frame (identity) and no delay (zero uncertainty).
/// compareImuWithFit() is this plus the tilt.
std::vector<ImuComparison> compareImuMountAndDelay(const std::optional<MountEstimate>& mount,
                                                   const std::optional<DelayEstimate>& delay,
                                                   const GyroMountEstimate& gyro);

/// Tilt only, for fits reported as a parameter set (the paper's method): the wrench tilt's standard
/// errors taken as independent.
ImuComparison compareImuTilt(double u_rad, double v_rad, double u_std, double v_std, const AccTiltEstimate& imu);

/// The 0.999 quantile of chi-square for 1, 2 or 3 degrees of freedom.
double chiSquare999(int dof);

}  // namespace ftid::identify
