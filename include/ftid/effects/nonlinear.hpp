#pragma once
// The model's nonlinear parameters and how they transform a sample before the (linear) regressor.
// One code path for the fit, `ftid analyze`, `ftid compensate` and ftidd (docs/effects.md):
//
//   tilt      g_S = R_BM^T g_B(U, V)                          (g_B from model::gravityInBase)
//   mounting  the sensor's true frame M is rotated against the configured S by
//             R_SM = Rz(yaw) Ry(pitch) Rx(roll); every kinematic quantity is re-expressed in M:
//               R_BM = R_BS R_SM,  w_M = R_SM^T w_S,  alpha_M = R_SM^T alpha_S,  a_M = R_SM^T a_S
//             (the IMU and the wrench are measured in M already and are not rotated). With
//             `mounting`, every sensor-frame parameter and the contact wrench are in M.
//   delay     the reading at time t belongs to the kinematics at t - delay (either sign):
//             the kinematic fields are interpolated linearly in time between the two samples
//             that bracket t - delay; the reading's own fields (t, wrench, temperature, extra
//             columns) are kept.
//   crosstalk the effects that read kSignalModelWrench get SampleContext::wrench_model_S = the
//             modelled wrench of all other effects (two regressor evaluations, see ModelEvaluator).
//
// Everything here is real-time safe (no allocation after construction, no exceptions, no I/O).
#include <vector>

#include "ftid/effects/model.hpp"

namespace ftid::effects {

/// Nonlinear parameters of a model (those it does not estimate keep their defaults).
struct NonlinearParams {
  double tilt_u_rad = 0.0;             ///< base tilt U (R_WB = Rx(U) Ry(V), docs/conventions.md)
  double tilt_v_rad = 0.0;             ///< base tilt V
  Vec3 mount_rpy_rad = Vec3::Zero();   ///< roll, pitch, yaw of M in S: R_SM = Rz(y) Ry(p) Rx(r)
  double delay_s = 0.0;                ///< the reading lags the kinematics by this [s]
};

/// Names of the nonlinear parameters as they appear in parameter files and results.
inline constexpr const char* kMountParamNames[3] = {"mount_roll", "mount_pitch", "mount_yaw"};
inline constexpr const char* kDelayParamName = "delay";

/// R_SM = Rz(yaw) Ry(pitch) Rx(roll).
Mat3 mountingRotation(const Vec3& rpy_rad) noexcept;

/// Re-expresses the kinematic quantities of ctx (given in the configured frame S) in the true
/// sensor frame M: R_BS <- R_BS R_SM, w, alpha, a, g <- R_SM^T (.). Identity: for R_SM = 1 the
/// context is unchanged.
void applyMounting(const Mat3& R_SM, SampleContext* ctx) noexcept;

/// Kinematic fields (q, qd, R_BS, p_BS_B, w_S, alpha_S, a_S, g_S, IMU) of `out` set to
/// (1 - s) a + s b, 0 <= s <= 1; all other fields of `out` are left as they are.
void interpolateKinematics(const SampleContext& a, const SampleContext& b, double s,
                           SampleContext* out) noexcept;

/// The sample whose kinematics are at time t_s, from a series sorted by time (index 0 oldest),
/// read through `at(i)`. Finds the bracketing pair by bisection and interpolates. Returns false
/// if t_s lies outside [at(0).t, at(n-1).t] (by more than 1e-9 s).
template <typename At>
bool kinematicsAt(At&& at, int n, double t_s, SampleContext* out) noexcept {
  if (n <= 0) return false;
  constexpr double kEps = 1e-9;
  const double t0 = at(0).t;
  const double t1 = at(n - 1).t;
  if (!(t_s >= t0 - kEps && t_s <= t1 + kEps)) return false;
  if (n == 1 || t_s <= t0) {
    interpolateKinematics(at(0), at(0), 0.0, out);
    return true;
  }
  if (t_s >= t1) {
    interpolateKinematics(at(n - 1), at(n - 1), 0.0, out);
    return true;
  }
  int lo = 0;
  int hi = n - 1;  // at(lo).t <= t_s < at(hi).t
  while (hi - lo > 1) {
    const int mid = lo + (hi - lo) / 2;
    if (at(mid).t <= t_s) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  const double dt = at(hi).t - at(lo).t;
  const double s = dt > 0.0 ? (t_s - at(lo).t) / dt : 0.0;
  interpolateKinematics(at(lo), at(hi), s, out);
  return true;
}

/// The linear map E of the effects that read the modelled wrench (they are linear in it): column k
/// is their contribution sum_j Y_j(ctx with wrench_model_S = e_k) theta_j. Y is a 6 x P
/// workspace (overwritten); real-time safe. `ctx` is taken by value (its wrench_model_S is changed).
Mat6 modelWrenchMap(const std::vector<const Effect*>& effects, SampleContext ctx, const Eigen::VectorXd& theta,
                    Eigen::Ref<Eigen::Matrix<double, 6, Eigen::Dynamic>> Y) noexcept;

/// Effects of `model` that read the modelled wrench (kSignalModelWrench), e.g. crosstalk.
std::vector<const Effect*> modelWrenchEffects(const Model& model);

/// Evaluates a model with fixed parameters, sample by sample (real-time safe after construction).
///   modelled = Y(ctx) theta, where effects reading kSignalModelWrench see
///   ctx.wrench_model_S = Y(ctx with wrench_model_S = 0) theta   (the other effects' wrench).
/// The context must already be prepared (g_S, mounting and delay applied).
class ModelEvaluator {
 public:
  /// Throws ConfigError if theta's size does not match the model.
  ModelEvaluator(const Model& model, const Eigen::VectorXd& theta);

  /// The modelled wrench of one prepared sample. `ctx` is copied into a fixed workspace.
  Wrench evaluate(const SampleContext& ctx) noexcept;

  /// The contact wrench of a prepared sample whose reading is ctx.wrench_S:
  ///   reading = (I + E)(w_base + contact)   =>   contact = (I + E)^-1 reading - w_base,
  /// with w_base the wrench of the effects that do not read the modelled wrench and E their map
  /// (modelWrenchMap; E = 0 without such effects, so contact = reading - modelled). A sensor
  /// calibration error distorts the contact as much as the payload, so it is undone on both.
  /// *modelled (optional) = (I + E) w_base, what the sensor reads without contact.
  Wrench contact(const SampleContext& ctx, Wrench* modelled) noexcept;

  const Model& model() const noexcept { return model_; }
  const Eigen::VectorXd& theta() const noexcept { return theta_; }
  bool readsModelWrench() const noexcept { return reads_model_wrench_; }

 private:
  Model model_;
  Eigen::VectorXd theta_;
  bool reads_model_wrench_;
  std::vector<const Effect*> wrench_effects_;
  Eigen::Matrix<double, 6, Eigen::Dynamic> Y_;
  SampleContext work_;
};

}  // namespace ftid::effects
