#pragma once
// The general fit's problem (private to ftid_identify; fit.cpp, docs/identification.md): the
// subset of samples a fit runs on, the nonlinear parameters phi (tilt, mounting, delay) and their
// layout, the weighted regressor and prediction at given phi, the checks of the data, and the one
// linear solve of the variable projection. The compressed tilt search (gravity_compression.hpp)
// and the steps of fitModel (fit_steps.hpp) build on it.
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "ftid/common/types.hpp"
#include "ftid/effects/nonlinear.hpp"
#include "ftid/identify/fit.hpp"

namespace ftid::identify::internal {

using Mat6X = Eigen::Matrix<double, 6, Eigen::Dynamic>;
using effects::NonlinearParams;

constexpr double kAngleStep = 1e-6;       // [rad] numeric-Jacobian step for tilt and mounting
constexpr double kDelayStep = 1e-6;       // [s] numeric-Jacobian step for the delay
constexpr double kStepConverged = 1e-10;  // a rejected Gauss-Newton step this small ends the search
/// The compressed tilt search factors its per-axis data through the Gram matrix (rounding error
/// ~ cond^2 eps, about 1e-10 relative at this bound) only while the column-scaled regressor at the
/// start is at most this ill-conditioned; beyond it, Householder QR (rounding ~ cond eps).
constexpr double kGramConditionLimit = 1e3;

/// Which nonlinear parameters a model estimates, and where they sit in the vector phi.
struct PhiLayout {
  int tilt = -1;   ///< index of U (V follows), or -1
  int mount = -1;  ///< index of roll (pitch, yaw follow), or -1
  int delay = -1;  ///< index of the delay, or -1
  int size = 0;

  explicit PhiLayout(const Model& m) {
    if (m.estimatesTilt()) { tilt = size; size += 2; }
    if (m.estimatesMounting()) { mount = size; size += 3; }
    if (m.estimatesDelay()) { delay = size; size += 1; }
  }
  double step(int k) const { return k == delay ? kDelayStep : kAngleStep; }
  NonlinearParams params(const Eigen::VectorXd& phi, const NonlinearParams& fixed) const {
    NonlinearParams p = fixed;
    if (tilt >= 0) { p.tilt_u_rad = phi(tilt); p.tilt_v_rad = phi(tilt + 1); }
    if (mount >= 0) p.mount_rpy_rad = phi.segment<3>(mount);
    if (delay >= 0) p.delay_s = phi(delay);
    return p;
  }
  Eigen::VectorXd vector(const NonlinearParams& p) const {
    Eigen::VectorXd phi(size);
    if (tilt >= 0) { phi(tilt) = p.tilt_u_rad; phi(tilt + 1) = p.tilt_v_rad; }
    if (mount >= 0) phi.segment<3>(mount) = p.mount_rpy_rad;
    if (delay >= 0) phi(delay) = p.delay_s;
    return phi;
  }
};

/// The samples of one fit (indices into contexts) and what the fit knows of them: a model's
/// regressor and prediction at given nonlinear parameters, rows weighted per axis.
struct Problem {
  const Model& model;
  const std::vector<SampleContext>& contexts;
  const std::vector<int>& indices;
  int n = 0;
  int p = 0;
  bool override_gravity = false;  ///< recompute g_S from the tilt (else use ctx.g_S)
  bool mounting = false;
  bool delay = false;
  bool reads_wmodel = false;      ///< the model reads kSignalModelWrench
  std::vector<Wrench> wmodel;     ///< SampleContext::wrench_model_S per subset sample
  /// Gauss-Newton linearisation of the effects that read the modelled wrench (crosstalk): with
  /// gn_theta set (the current solution), the model (I + E) w_base(theta) is linearised at it,
  ///   f ~ (I + E0) Y_base theta + X(w_base0) e - E0 w_base0,
  /// so the base columns get E0 applied and the measurement gets + E0 w_base0 (buildRegressor's
  /// rhs); a plain fixed point (wrench_model_S frozen) converges far too slowly with noise.
  Eigen::VectorXd gn_theta;
  double gn_lambda = 0.0;         ///< Levenberg damping of theta towards gn_theta (scaled columns)
  std::vector<char> derived_col;  ///< columns owned by effects that read the modelled wrench
  std::vector<const effects::Effect*> derived_effects;  ///< those effects
  std::vector<char> active;       ///< samples whose delayed kinematics lie inside the data
  int n_active = 0;
  Eigen::VectorXd y;              ///< stacked measured wrench (6n)

  Problem(const Model& m, const std::vector<SampleContext>& c, const std::vector<int>& idx);

  const SampleContext& at(int i) const { return contexts[static_cast<std::size_t>(indices[static_cast<std::size_t>(i)])]; }

  /// Sample i prepared for the nonlinear parameters (effects/nonlinear.hpp): the reading with the
  /// kinematics at t_i - delay (nearest end outside the data), the mounting rotation, gravity.
  void prepare(int i, const NonlinearParams& nl, const Vec3& g_B, const Mat3& R_SM, SampleContext* c) const;

  /// Marks the samples whose delayed kinematics stay inside the data for every delay in [lo, hi].
  void setActiveWindow(double lo, double hi);

  /// Regressor A (6n x p) for the nonlinear parameters, rows scaled by the axis weights and
  /// zero for inactive samples. wrench_model_S is that of wmodel, or zero if !with_derived (the
  /// regressor of the effects that do not read it: those effects are linear in it). With gn_theta
  /// set, the Gauss-Newton form (see gn_theta) and its measurement shift, weighted, in *rhs.
  void buildRegressor(const NonlinearParams& nl, const Vec6& weights, Eigen::MatrixXd* A,
                      bool with_derived = true, Eigen::VectorXd* rhs = nullptr) const;

  /// The stacked measurement y, weighted per axis (zero for inactive samples).
  Eigen::VectorXd weightedMeasurement(const Vec6& weights) const;

  /// Modelled wrench (6 x n, unweighted) of theta with effects::ModelEvaluator (the compensator's
  /// code); with reads_wmodel and !self_consistent, wrench_model_S comes from wmodel instead.
  Mat6X predict(const Eigen::VectorXd& theta, const NonlinearParams& nl) const;

  /// The prediction of the effects that do not read the modelled wrench (what crosstalk multiplies).
  std::vector<Wrench> basePrediction(const Eigen::VectorXd& theta, const NonlinearParams& nl) const;

  /// The prediction (6 x n, unweighted) with wrench_model_S = 0: the effects that read it add nothing.
  Mat6X predictWithoutDerived(const Eigen::VectorXd& theta, const NonlinearParams& nl) const;
};

struct LinearSolution {
  Eigen::VectorXd theta;
  Eigen::VectorXd residual;  ///< weighted, stacked
};

/// The least-squares solution of A theta = yw (column-pivoted Householder QR) and its residual.
LinearSolution solveLinear(const Eigen::MatrixXd& A, const Eigen::VectorXd& yw);

/// 0 if every field the fit reads is finite, NaN otherwise (x * 0 is 0 for every finite x and NaN
/// for +-inf and NaN): the one list of the fields, for the fast pass and for naming the sample.
double nonFiniteProbe(const SampleContext& c);

/// Throws DataError naming the first sample of pb with a non-finite value.
void checkFinite(const Problem& pb);

/// Throws DataError naming the first sample that is not later than the one before it (a delay
/// needs a time series).
void checkTimeOrder(const Problem& pb);

/// A static pose set (noise.hpp, poseGroups: the robot at rest) cannot show a delay: the reading
/// does not change while a pose is held, and the jump between poses is not motion that the
/// kinematics describe. Refuse rather than report a number.
void checkNotStatic(const Problem& pb, const Model& model);

/// The nonlinear parameters during the search: phi (PhiLayout) and the fixed rest.
struct PhiState {
  Eigen::VectorXd phi;
  NonlinearParams fixed;  ///< values of the parameters the model does not estimate
  int iterations = 0;
  NonlinearParams params(const PhiLayout& L) const { return L.params(phi, fixed); }
};

/// The stacked vector v (6n) as a 6 x n matrix.
Mat6X unstack(const Eigen::VectorXd& v, int n);

}  // namespace ftid::identify::internal
