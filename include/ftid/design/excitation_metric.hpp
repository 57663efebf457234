#pragma once
// How well a motion determines the parameters of a model (docs/design.md §Objective).
//
// For each sample the contexts are built exactly as for identification (samples::buildContexts
// from the robot kinematics, tilt 0) and the model's regressor Y (6 x P) is computed with
// effects::Model::computeRegressor. Models that estimate the base tilt get two more columns, the
// sensitivity of the modelled wrench to U and V at the nominal parameters (the regressor needs
// parameter values only there):  J = [ Y,  d(Y theta_nom)/dU,  d(Y theta_nom)/dV ].
// Rows are weighted by the sensor noise (1/sigma per axis), as the identification weights axes.
//
//   information  M = sum_k w_k J_k^T diag(1/sigma^2) J_k        (w_k = samples represented)
//   cond         = condition number of the column-scaled stacked J (columns of unit norm)
//                = sqrt(cond(D M D)), D = diag(M)^-1/2
//   dopt         = -(1/P) log det(M / n)   (n = samples represented; per-sample information)
//   covariance   = M^-1  (predicted covariance of [theta, U, V] for white noise sigma)
#include <map>
#include <string>
#include <vector>

#include "ftid/common/types.hpp"
#include "ftid/effects/model.hpp"
#include "ftid/model/kinematics.hpp"
#include "ftid/trajectory/trajectory_io.hpp"

namespace ftid::design {

struct SampledMotion;

/// Nominal payload used where the metric needs parameter values (tilt columns, derived
/// quantities): the paper's Table 2 payload unless configured.
std::map<std::string, double> defaultNominalParameters();

/// Parses "fx=0.05,fy=0.05,fz=0.05,tx=0.01,ty=0.01,tz=0.01" (also "f=0.05,t=0.01"). Throws
/// ConfigError naming the bad item.
Vec6 parseNoise(const std::string& text);

class ExcitationMetric {
 public:
  /// nominal: values by parameter name (mass, mass_com_x.. or com_x..); missing ones are 0.
  ExcitationMetric(effects::Model model, const model::RobotKinematics& kinematics,
                   const trajectory::TrajectoryConstraints& constraints,
                   const std::map<std::string, double>& nominal, const Vec6& noise_sigma);

  const effects::Model& model() const { return model_; }
  int numColumns() const { return static_cast<int>(names_.size()); }
  /// Column names: the model's parameters, then tilt_u, tilt_v if estimated.
  const std::vector<std::string>& columnNames() const { return names_; }
  const Vec6& noise() const { return sigma_; }

  /// Information matrix of the sampled motion, each sample standing for `weight` samples.
  /// Also returns (if non-null) the sensor poses (R_BS, p_BS_B) from the same contexts.
  Eigen::MatrixXd information(const SampledMotion& motion, double weight,
                              std::vector<Eigen::Isometry3d>* sensor_poses = nullptr) const;

  /// The same information with the sensor's IMU (docs/design.md "Limits"): the IMU's predicted
  /// tilt covariance for this motion (identify::predictImuTiltCovariance: accelerometer noise
  /// acc_std, gyro noise gyro_std, accelerometer bias estimated) added as the information of an
  /// independent measurement of (U, V): info + H^T Cov_imu^-1 H (H picks tilt_u, tilt_v), the fused
  /// fit's information (identify/imu_fusion.hpp). Models without tilt: info unchanged. Each sample
  /// of `motion` stands for `weight` samples, as in information() (the IMU's information grows
  /// with the samples: Cov_imu / weight).
  Eigen::MatrixXd informationWithImu(const SampledMotion& motion, const Eigen::MatrixXd& info, double acc_std,
                                     double gyro_std, double weight = 1.0) const;

  /// Information of the stacked samples of a list of joint states.
  Eigen::MatrixXd information(const std::vector<JointVector>& q, const std::vector<JointVector>& qd,
                              const std::vector<JointVector>& qdd, double weight) const;

  /// Column-scaled condition number from an information matrix (inf if singular).
  static double conditionNumber(const Eigen::MatrixXd& info);
  /// -(1/P) log det(info / n); +inf if singular.
  static double dOptimality(const Eigen::MatrixXd& info, double n_samples);
  /// Columns whose direction is (nearly) not excited: small eigenvalues of the scaled matrix,
  /// reported by the largest components of their eigenvectors.
  std::vector<std::string> weakColumns(const Eigen::MatrixXd& info, double threshold = 1e-8) const;

  /// Predicted standard errors from info^-1: every column, plus derived com_x/y/z (from mass and
  /// mass_com_*) and weight. Empty if info is singular.
  std::map<std::string, double> predictedStd(const Eigen::MatrixXd& info) const;

 private:
  effects::Model model_;
  model::RobotKinematics kinematics_;
  trajectory::TrajectoryConstraints constraints_;
  Eigen::VectorXd theta_nom_;
  std::vector<std::string> names_;
  bool tilt_ = false;
  Vec6 sigma_;
  std::map<std::string, double> nominal_;
};

}  // namespace ftid::design
