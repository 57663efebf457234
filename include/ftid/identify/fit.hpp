#pragma once
// General identification of a composed model (ftid/effects/model.hpp):
//
//   minimise  sum_i || W (w_i - Y_i(U, V) theta) ||^2        over theta (linear) and U, V (tilt)
//
// W = diag of per-axis weights (1 / residual RMS of that axis, estimated from an unweighted fit and
// re-estimated once). theta is solved with Householder QR on the stacked regressor (never normal
// equations); the tilt, when the model contains the `tilt` effect, by variable projection: an
// outer Levenberg-damped Gauss-Newton on (U, V) with a numeric Jacobian of the stacked residual,
// started from the paper's force stage (direction of the identified gravity vector in B).
// Effects that read kSignalModelDerivative get the signals derived from the current fit, and the
// fit is iterated (a fixed point; first pass: the measured wrench stands in for the model):
//   SampleContext::dwrench_model_dt  central time difference of the current model prediction
//                                    (sensor_delay)
//   SampleContext::wrench_model_S    the current prediction without the effects that read these
//                                    signals (crosstalk: reading = (I + E) w_model)
// predictWrench fills them the same way. Details and the uncertainty model: docs/identification.md.
#include <optional>
#include <string>
#include <vector>

#include "ftid/effects/model.hpp"

namespace ftid::identify {

using effects::Model;
using effects::SampleContext;

struct FitOptions {
  /// Models with `tilt`: initial guess (default: from the paper's force stage).
  /// Models without `tilt`: if set, g_S is recomputed for this tilt; if unset, ctx.g_S is used.
  std::optional<double> tilt_u_rad;
  std::optional<double> tilt_v_rad;
  bool axis_weights = true;        ///< per-axis weights 1/RMS (re-estimated once)
  int max_tilt_iterations = 50;    ///< outer Gauss-Newton iterations on (U, V)
  int derivative_iterations = 4;   ///< refits for effects that read the modelled wrench or its d/dt
  /// Relative threshold on the pivots / singular values of the column-scaled regressor below which
  /// a direction counts as not excited (rank deficiency).
  double rank_tolerance = 1e-9;
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
  std::vector<DerivedParam> derived;    ///< com_x/y/z, weight (when the model has gravity)
  Eigen::Matrix<double, 6, Eigen::Dynamic> residual;  ///< measured - modelled, per sample (6 x N)
  Vec6 residual_rms = Vec6::Zero();     ///< per axis, unweighted [N, Nm]
  Vec6 axis_weights = Vec6::Ones();     ///< weights used in the final solve
  double condition_number = 0.0;        ///< of the column-scaled (weighted) regressor [theta, U, V]
  double sigma2 = 0.0;                  ///< weighted residual variance (about 1 with axis weights)
  int n_samples = 0;
  int tilt_iterations = 0;

  /// Value / std of a parameter or derived parameter (also "tilt_u", "tilt_v"); throws
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

/// Modelled wrench for given theta and tilt (shared by predictWrench and the fitter).
Eigen::Matrix<double, 6, Eigen::Dynamic> predictWrench(const Model& model, const Eigen::VectorXd& theta,
                                                       std::optional<double> tilt_u_rad,
                                                       std::optional<double> tilt_v_rad,
                                                       const std::vector<SampleContext>& contexts,
                                                       const std::vector<int>& indices);

}  // namespace ftid::identify
