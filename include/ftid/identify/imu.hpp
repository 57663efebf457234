#pragma once
// Payload-independent estimators from the sensor's IMU (docs/identification.md, "The IMU as a
// measurement"). Pure math on sample contexts (no I/O); not for the real-time loop.
//
// The IMU sits in the sensor; its frame M may be rotated against the configured S (R_SM, the
// conventions' mounting rotation) and its stream may lag the robot's kinematics by tau_i (the IMU
// sample stamped t belongs to the kinematics of t - tau_i, the sign of `delay`). With the
// kinematic motion of S from the contexts (R_BS, w_S, alpha_S, a_S, interpolated at t - tau_i),
// the two sensors measure:
//
//   gyro:   y_k = R_SM^T w_S(t_k - tau_i) + b_g + noise                                   (G)
//   accel:  z_k = R_SM^T (a_S(t_k - tau_i) - R_BS(t_k - tau_i)^T g_B(U, V)) + b_a + noise (A)
//
// with g_B(U, V) the gravity in B for the base tilt (docs/conventions.md, |g_B| = 9.80665).
// Neither involves the payload. estimateGyroMount() solves (G) for R_SM, b_g and tau_i: the delay
// from a scan of the rotation-aligned cross-correlation of the angular rates (the Wahba cost
// profiled over a grid of delays, a parabola through the best three points), R_SM and b_g in
// closed form at that delay (Wahba's problem on the centred rates by SVD; b_g = mean(y) - R_SM^T
// mean(w)), then all seven jointly by Gauss-Newton (the delay's column is -R_SM^T alpha_S).
// estimateAccTilt() solves (A) for U, V and b_a by Gauss-Newton from the linear solution for
// (g_B, b_a); the bias is estimated jointly only when the orientations determine it (else it is
// held at zero and said so).
// Standard errors: sigma^2 (J^T J)^-1 with sigma^2 the residual variance per axis (white IMU noise;
// the kinematics taken as exact). The rotation's uncertainty is that of the small rotation
// d with R_SM = (I - skew(d)) R_SM_hat, about S's axes (near identity: roll, pitch, yaw).
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "ftid/common/types.hpp"
#include "ftid/effects/effect.hpp"

namespace ftid::identify {

struct ImuOptions {
  bool estimate_delay = true;      ///< estimate the IMU stream's delay (else 0)
  double max_delay_s = 0.2;        ///< delay search range +-max_delay_s [s]
  bool estimate_acc_bias = true;   ///< estimate the accelerometer bias where the motion allows
  /// Smallest reciprocal condition number of the column-scaled (U, V, b_a) Jacobian at which the
  /// accelerometer bias counts as determined.
  double bias_rcond = 1e-3;
  int max_iterations = 20;         ///< Gauss-Newton iterations of each estimator
};

/// Result of (G). covariance is over [d (3), b_g (3), tau_i (1)] (the delay's row and column are
/// zero when the delay is not estimated).
struct GyroMountEstimate {
  Mat3 R_SM = Mat3::Identity();    ///< the IMU frame M in the configured S
  Vec3 rpy_rad = Vec3::Zero();     ///< R_SM = Rz(yaw) Ry(pitch) Rx(roll)
  Vec3 rotation_std_rad = Vec3::Zero();  ///< std of d (about S's x, y, z)
  Vec3 bias_radps = Vec3::Zero();
  Vec3 bias_std_radps = Vec3::Zero();
  bool delay_estimated = false;
  double delay_s = 0.0;            ///< the IMU sample stamped t belongs to the kinematics of t - delay
  double delay_std_s = 0.0;
  double sigma_radps = 0.0;        ///< residual RMS per axis
  int n_used = 0;                  ///< samples whose delayed kinematics lie inside the data
  Eigen::Matrix<double, 7, 7> covariance = Eigen::Matrix<double, 7, 7>::Zero();
};

/// Result of (A). covariance is over [U, V, b_a (3)] (the bias rows zero when not estimated).
struct AccTiltEstimate {
  double tilt_u_rad = 0.0;
  double tilt_v_rad = 0.0;
  double tilt_u_std = 0.0;
  double tilt_v_std = 0.0;
  bool bias_estimated = false;     ///< false: the orientations do not determine it (held at 0)
  Vec3 bias_mps2 = Vec3::Zero();
  Vec3 bias_std_mps2 = Vec3::Zero();
  double sigma_mps2 = 0.0;         ///< residual RMS per axis
  int n_used = 0;
  Eigen::Matrix<double, 5, 5> covariance = Eigen::Matrix<double, 5, 5>::Zero();
  Eigen::Matrix2d tiltCovariance() const { return covariance.topLeftCorner<2, 2>(); }
};

struct ImuEstimate {
  GyroMountEstimate gyro;
  AccTiltEstimate acc;
  /// Rows left out because they hold the previous row's IMU reading (freshImuRows: an IMU slower
  /// than the log, sample-and-hold); 0 when every row has a new one.
  int held_rows = 0;
  int typical_hold_rows = 1;  ///< median rows each held reading spans (the log's rate over the IMU's)
};

/// The rows whose IMU reading is new: a row whose nine IMU values (ax..alz) equal the previous
/// row's bit for bit while the robot moved (q, qd or R_BS changed) holds that reading (an IMU
/// slower than the log, sample-and-hold: docs/log-format.md "Held readings"). A held reading
/// paired with a newer robot state reads as a lag of about half the IMU's period (a 100 Hz IMU in
/// a 500 Hz log: 3.9 ms, a "disagreement" with the configured delay). *held: rows left out;
/// *typical: the median rows each reading spans. Empty result when none is held (use `contexts`).
std::vector<effects::SampleContext> freshImuRows(const std::vector<effects::SampleContext>& contexts, int* held,
                                                 int* typical);

/// Kinematic motion of S at time s, interpolated between the contexts around it (R_BS by slerp,
/// w_S by cubic Hermite with alpha_S as its derivative, a_S and alpha_S linearly). False when s
/// lies outside the data or in a gap (neighbours further apart than 1.5 times the median step).
struct KinematicsAt {
  Mat3 R_BS = Mat3::Identity();
  Vec3 w_S = Vec3::Zero();
  Vec3 alpha_S = Vec3::Zero();
  Vec3 a_S = Vec3::Zero();
};
class KinematicsInterpolator {
 public:
  /// Contexts in time order (t strictly increasing; throws DataError otherwise, naming the sample).
  explicit KinematicsInterpolator(const std::vector<effects::SampleContext>& contexts);
  /// The kinematics at time s (false outside the data or across a gap). rotation = false leaves
  /// out->R_BS untouched (the slerp is most of the cost; the gyro's fits need only the rates).
  bool at(double s, KinematicsAt* out, bool rotation = true) const;
  double step() const { return step_; }

 private:
  std::size_t firstAfter(double s) const;  ///< the first j with t_[j] > s (t_.size() if none)
  const std::vector<effects::SampleContext>& c_;
  std::vector<double> t_;
  double step_ = 0.0;
};

/// Solves (G). Throws DataError when the contexts have no IMU, are too few (< 20 samples inside
/// the data) or the rates do not determine the rotation (rotation about fewer than two axes).
GyroMountEstimate estimateGyroMount(const std::vector<effects::SampleContext>& contexts,
                                    const ImuOptions& options = {});

/// Solves (A) with the IMU frame R_SM and delay from the gyro (or known). Throws DataError when
/// the contexts have no IMU or are too few.
AccTiltEstimate estimateAccTilt(const std::vector<effects::SampleContext>& contexts, const Mat3& R_SM,
                                double delay_s, const ImuOptions& options = {});

/// Both: the gyro first (R_SM, delay), then the accelerometer in that frame and at that delay.
ImuEstimate estimateImu(const std::vector<effects::SampleContext>& contexts, const ImuOptions& options = {});

/// Predicted covariance of the IMU's tilt (U, V) for a motion, before any data (the designer's
/// prediction, docs/design.md): the Fisher information of (A) over [U, V, b_a] for white
/// accelerometer noise acc_std, A = sum_k J_k^T J_k / acc_std^2 (J_k as in estimateAccTilt, at
/// R_SM = I and the tilt of the contexts' g_S), the cross-information B with the IMU rotation d,
/// and the gyro's information over [d, b_g] for white noise gyro_std (the sum of the centred
/// skew(w_k)^T skew(w_k) / gyro_std^2): the sequential estimator's covariance
///   A^-1 + G Cov_d G^T,   G = -A^-1 B,   Cov_d = the gyro's covariance of d (b_g marginalised)
/// (the accelerometer at the gyro's frame; the delay's share is left out). With bias_estimated
/// false the bias is held (A over U, V only). Returns a 2 x 2 matrix with infinite entries when the
/// motion does not determine the tilt.
Eigen::Matrix2d predictImuTiltCovariance(const std::vector<effects::SampleContext>& contexts, double acc_std,
                                         double gyro_std, bool bias_estimated = true);

/// Human-readable lines (tilt, biases, mount, delay with standard errors).
std::string formatImuEstimate(const ImuEstimate& estimate);

}  // namespace ftid::identify
