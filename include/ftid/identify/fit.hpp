#pragma once
// General identification of a composed model (ftid/effects/model.hpp):
//
//   minimise  sum_i || W (w_i - Y_i(U, V) theta) ||^2        over theta (linear) and U, V (tilt)
//
// W = diag of per-axis weights (1 / residual RMS of that axis, estimated from an unweighted fit and
// re-estimated once). theta is solved with Householder QR on the stacked regressor (never normal
// equations; the compressed tilt search below compresses per axis through the Gram matrix only
// when the column-scaled regressor is well conditioned); the tilt, when the model contains the
// `tilt` effect, by variable projection: an
// outer Levenberg-damped Gauss-Newton on (U, V) with a numeric Jacobian of the stacked residual,
// started from the paper's force stage (direction of the identified gravity vector in B).
// The other nonlinear parameters (effects/nonlinear.hpp) join the tilt in the same outer search:
// the `mounting` rotation (roll, pitch, yaw of the true sensor frame against the configured one)
// and the `sensor_delay` (an exact time shift of the kinematics, found by a scan of the shifted
// prediction over +-max_delay_s, the first-order estimate -tau dw/dt as one more start, then
// refined with the others). Effects that read kSignalModelWrench (crosstalk) get
// SampleContext::wrench_model_S = the prediction of the other effects, iterated to a fixed point
// (first pass: the measured wrench stands in for it); predictions use effects::ModelEvaluator,
// the same code as the compensator.
// predictWrench fills them the same way. Details and the uncertainty model: docs/identification.md.
#include <optional>
#include <string>
#include <vector>

#include "ftid/effects/model.hpp"
#include "ftid/effects/nonlinear.hpp"

namespace ftid::identify {

using effects::Model;
using effects::SampleContext;

struct FitOptions {
  /// Models with `tilt`: initial guess (default: from the paper's force stage).
  /// Models without `tilt`: if set, g_S is recomputed for this tilt; if unset, ctx.g_S is used.
  std::optional<double> tilt_u_rad;
  std::optional<double> tilt_v_rad;
  /// Models with `mounting`: initial roll, pitch, yaw [rad] (default 0; fitModelMultiStart starts
  /// from the best of the 24 axis-aligned rotations, tilt_start.hpp).
  std::optional<Vec3> mount_rpy_rad;
  bool axis_weights = true;        ///< per-axis weights 1/RMS (re-estimated once)
  int max_tilt_iterations = 50;    ///< outer Gauss-Newton iterations on (U, V)
  int derivative_iterations = 8;   ///< Gauss-Newton passes for effects that read the modelled wrench
  /// Models with `sensor_delay`: the delay is searched in [-max_delay_s, +max_delay_s] [s].
  double max_delay_s = 1.0;
  /// Relative threshold on the pivots / singular values of the column-scaled regressor below which
  /// a direction counts as not excited (rank deficiency).
  double rank_tolerance = 1e-9;
  /// Models whose only nonlinear parameters are the tilt: solve the tilt search on the per-axis
  /// compressed regressor (Gram factor, or Householder QR when the condition number exceeds 1e3;
  /// its cost per step independent of the number of samples; same minimiser and statistics up to
  /// rounding, docs/identification.md). false: the general path
  /// (every step rebuilds and refactors the stacked regressor), kept as the reference.
  bool compressed_tilt_search = true;
};

/// A parameter derived from the fitted ones (com_x = mass_com_x / mass, weight = m g, ...).
struct DerivedParam {
  std::string name;
  double value = 0.0;
  double std = 0.0;
  std::string unit;
};

struct FitResult {
  std::string model_name;               ///< canonical model name
  std::vector<effects::ParamInfo> params;  ///< column order of theta
  Eigen::VectorXd theta;                ///< fitted linear parameters
  Eigen::VectorXd theta_std;            ///< standard errors of theta
  /// Covariance of [theta; U; V] (tilt rows/cols only when estimated) including the tilt coupling.
  Eigen::MatrixXd covariance;
  bool tilt_estimated = false;
  bool tilt_applied = false;            ///< g_S was recomputed from the tilt (else ctx.g_S used)
  double tilt_u_rad = 0.0;              ///< tilt used (estimated, given, or 0)
  double tilt_v_rad = 0.0;
  double tilt_u_std = 0.0;
  double tilt_v_std = 0.0;
  bool mounting_estimated = false;      ///< model has `mounting`
  Vec3 mount_rpy_rad = Vec3::Zero();    ///< roll, pitch, yaw of the true sensor frame in S
  Vec3 mount_rpy_std = Vec3::Zero();
  bool delay_estimated = false;         ///< model has `sensor_delay`
  double delay_s = 0.0;                 ///< the reading lags the kinematics by this
  double delay_std = 0.0;
  int n_excluded = 0;                   ///< samples whose delayed kinematics lie outside the log
  std::vector<DerivedParam> derived;    ///< com_x/y/z, weight (when the model has gravity)
  Eigen::Matrix<double, 6, Eigen::Dynamic> residual;  ///< measured - modelled, per sample (6 x N)
  Vec6 residual_rms = Vec6::Zero();     ///< per axis, unweighted [N, Nm]
  Vec6 axis_weights = Vec6::Ones();     ///< weights used in the final solve
  double condition_number = 0.0;        ///< of the column-scaled (weighted) regressor [theta, U, V]
  double sigma2 = 0.0;                  ///< weighted residual variance (about 1 with axis weights)
  int n_samples = 0;
  int tilt_iterations = 0;

  /// The nonlinear parameters as the compensator takes them.
  effects::NonlinearParams nonlinear() const;

  /// Value / std of a parameter or derived parameter (also "tilt_u", "tilt_v", "mount_roll",
  /// "mount_pitch", "mount_yaw", "delay"); throws
  /// std::out_of_range naming it if absent.
  double value(const std::string& name) const;
  double stddev(const std::string& name) const;
  bool has(const std::string& name) const;
};

/// Fits the model to all contexts. Throws IdentificationError if the data cannot determine the
/// parameters (naming those not excited), DataError for non-finite input.
FitResult fitModel(const Model& model, const std::vector<SampleContext>& contexts,
                   const FitOptions& options = {});

/// Same, on the subset contexts[indices[k]] (no copy of the contexts; for cross-validation).
/// Derivative signals are computed along the subset order, so pass contiguous blocks.
FitResult fitModel(const Model& model, const std::vector<SampleContext>& contexts,
                   const std::vector<int>& indices, const FitOptions& options = {});

/// Modelled wrench (6 x N) for the contexts with the fitted theta and tilt (e.g. held-out data).
Eigen::Matrix<double, 6, Eigen::Dynamic> predictWrench(const Model& model, const FitResult& fit,
                                                       const std::vector<SampleContext>& contexts);
Eigen::Matrix<double, 6, Eigen::Dynamic> predictWrench(const Model& model, const FitResult& fit,
                                                       const std::vector<SampleContext>& contexts,
                                                       const std::vector<int>& indices);

/// Time derivative of a 6 x n series w sampled at times t: central differences, one-sided at the
/// ends of each segment (segment_start: the first sample of each log, in order; empty: one log),
/// zero where the two neighbours are not later than one another. The one implementation for the
/// fit's first-order delay estimate and the lab's derived signals.
Eigen::Matrix<double, 6, Eigen::Dynamic> timeDerivative(const std::vector<double>& t,
                                                        const Eigen::Matrix<double, 6, Eigen::Dynamic>& w,
                                                        const std::vector<int>& segment_start = {});

/// Initial tilt (U, V) for a model with `tilt`, the fit's and the lab's start: the paper's static
/// force stage on contexts[indices[k]] (direction of the identified gravity vector in B). False
/// (and u, v untouched) if the paper's method cannot determine it.
bool initialTilt(const std::vector<SampleContext>& contexts, const std::vector<int>& indices, double* tilt_u_rad,
                 double* tilt_v_rad);

/// Start for a delay (docs/identification.md): the prediction series `predicted` (6 x n, at times
/// t, of a model without the delay) is shifted by each delay on a grid over [-max, max] (linear
/// interpolation) and compared with `measured`; the first-order estimate (regression of the
/// residual on -d predicted/dt) is one more candidate. Returns the delay with the smallest weighted
/// mean square difference over the samples the shift keeps inside the data (0 if none is better).
double initialDelayEstimate(const std::vector<double>& t, const Eigen::Matrix<double, 6, Eigen::Dynamic>& measured,
                            const Eigen::Matrix<double, 6, Eigen::Dynamic>& predicted, const Vec6& weights,
                            double max_delay_s);

/// Modelled wrench for given theta and nonlinear parameters; gravity from the tilt if
/// apply_tilt, else ctx.g_S. Samples whose delayed kinematics lie outside the data use the
/// nearest end.
Eigen::Matrix<double, 6, Eigen::Dynamic> predictWrench(const Model& model, const Eigen::VectorXd& theta,
                                                       const effects::NonlinearParams& nonlinear,
                                                       bool apply_tilt,
                                                       const std::vector<SampleContext>& contexts,
                                                       const std::vector<int>& indices);

/// Modelled wrench for given theta and tilt (no mounting or delay).
Eigen::Matrix<double, 6, Eigen::Dynamic> predictWrench(const Model& model, const Eigen::VectorXd& theta,
                                                       std::optional<double> tilt_u_rad,
                                                       std::optional<double> tilt_v_rad,
                                                       const std::vector<SampleContext>& contexts,
                                                       const std::vector<int>& indices);

}  // namespace ftid::identify
