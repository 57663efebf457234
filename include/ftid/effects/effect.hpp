#pragma once
// A model of the sensor reading is a composition of named physical effects (docs/effects.md).
// Each effect contributes columns to a regressor that is linear in the model's parameters:
//
//   wrench_model_S(sample) = Y(sample; tilt) * theta                       (6 x P) * (P)
//
// The base tilt (U, V) is the one nonlinear quantity: it enters through g_S in SampleContext and
// is estimated by the fitter (variable projection), not by the linear solve.
//
// Parameters are owned by exactly one effect, but an effect may add into the columns of
// parameters owned by another (rigid_body adds centripetal terms to the `mass_com_*` columns of
// `gravity`). Columns are resolved once in bind(), so addRegressor() is fast, allocation-free and
// real-time safe.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "ftid/common/types.hpp"

namespace ftid::effects {

/// Signals an effect needs beyond the kinematics and the wrench.
enum Signal : std::uint32_t {
  kSignalNone = 0,
  kSignalImu = 1u << 0,          ///< IMU columns (ax..alz)
  kSignalTemperature = 1u << 1,  ///< temp column
  kSignalTime = 1u << 2,         ///< t (always present in a log, but named for documentation)
  kSignalModelWrench = 1u << 3,  ///< the modelled wrench of the other effects (wrench_model_S)
  kSignalExtraColumn = 1u << 4,  ///< an extra log column by name
};

/// Everything an effect may read for one sample. Built from a log row and the robot kinematics
/// (ftid/samples/sample_builder.hpp, ftid/samples/context.hpp). Frames and units as in docs/conventions.md.
struct SampleContext {
  double t = 0.0;                        ///< [s] sample time: since the first sample of the log
                                         ///< (ftidd: of the session); orders and interpolates samples
  /// [s] the model's time, read by `time_drift` and the `t` signal: seconds since the parameter
  /// set's time origin on the host's UTC clock (docs/conventions.md, "Time and logs"). Equal to
  /// `t` for logs without a `host_time` column.
  double t_model = 0.0;
  JointVector q = JointVector::Zero();   ///< [rad]
  JointVector qd = JointVector::Zero();  ///< [rad/s]
  Mat3 R_BS = Mat3::Identity();          ///< sensor orientation in the robot base
  Vec3 p_BS_B = Vec3::Zero();            ///< sensor origin in the robot base [m]
  Vec3 w_S = Vec3::Zero();               ///< angular velocity of S in S [rad/s]
  Vec3 alpha_S = Vec3::Zero();           ///< angular acceleration of S in S [rad/s^2]
  Vec3 a_S = Vec3::Zero();               ///< acceleration of the S origin in S, no gravity [m/s^2]
  Vec3 g_S = Vec3(0.0, 0.0, -kStandardGravity);  ///< gravity in S for the current tilt [m/s^2]
  Wrench wrench_S = Wrench::Zero();      ///< measured reading [N, Nm]
  Vec3 imu_acc_S = Vec3::Zero();         ///< IMU specific force (if has_imu)
  Vec3 imu_w_S = Vec3::Zero();
  Vec3 imu_alpha_S = Vec3::Zero();
  double temp_degC = 0.0;                ///< (if has_temp)
  const double* extra = nullptr;         ///< this sample's extra log columns, or nullptr
  /// Names of the extra columns (same order as `extra`), or nullptr; read by generic effects such
  /// as poly(<column>,n). Set by whoever owns the names (e.g. the ContextSet's owner).
  const std::vector<std::string>* extra_names = nullptr;
  /// The modelled wrench of the effects that do not read it (effects::ModelEvaluator, the fitter).
  /// Read by `crosstalk` (kSignalModelWrench).
  Wrench wrench_model_S = Wrench::Zero();
  bool has_imu = false;
  bool has_temp = false;
  /// false for pose logs (docs/log-format.md): q and qd are unknown (zero); effects that read
  /// joint signals are unavailable (SignalSource::available).
  bool has_joints = true;
};

/// One parameter of an effect.
struct ParamInfo {
  std::string name;         ///< unique within a model, snake_case, e.g. "f0_x", "mass", "k_cable"
  std::string unit;         ///< SI unit, e.g. "N", "Nm", "kg", "kg*m", "kg*m^2", "N/degC", "s"
  std::string description;  ///< one line
};

/// Maps parameter names to regressor columns for one composed model.
class ParamIndex {
 public:
  /// Column of the named parameter, or -1 if the model has no such parameter.
  int column(const std::string& name) const;
  int size() const { return static_cast<int>(names_.size()); }
  const std::vector<std::string>& names() const { return names_; }
  void add(const std::string& name);  ///< throws ConfigError on a duplicate name

 private:
  std::vector<std::string> names_;
};

class Effect {
 public:
  virtual ~Effect() = default;

  /// Registry name as typed on the command line, e.g. "rigid_body" or "harmonic(q4,2)".
  virtual std::string name() const = 0;
  /// One-line physical meaning, printed by `ftid analyze`.
  virtual std::string description() const = 0;
  /// Parameters this effect owns (may be empty: e.g. linear_inertia uses gravity's parameters).
  virtual std::vector<ParamInfo> params() const = 0;
  /// Effects whose parameters this effect needs (e.g. {"gravity"}); the model adds them or errors.
  virtual std::vector<std::string> requires() const { return {}; }
  /// Bitmask of Signal values this effect reads.
  virtual std::uint32_t signals() const { return kSignalNone; }
  /// Names of the scalar signals this effect reads (ftid/effects/signal_source.hpp), e.g. {"q4"}
  /// for harmonic(q4,2); Model::missingSignal checks that a log carries each.
  virtual std::vector<std::string> signalNames() const { return {}; }
  /// True for the tilt effect: the fitter estimates U, V when the model contains it.
  virtual bool estimatesTilt() const { return false; }
  /// True for `mounting`: the fitter estimates the sensor's mounting rotation (effects/nonlinear.hpp).
  virtual bool estimatesMounting() const { return false; }
  /// True for `sensor_delay`: the fitter estimates the reading's delay (effects/nonlinear.hpp).
  virtual bool estimatesDelay() const { return false; }
  /// True if part of this effect is a uniform force field in B that the fitted tilt absorbs (cable:
  /// its horizontal pull, docs/effects.md): a model with it fits an apparent tilt, not the base's
  /// mounting tilt, and a mass that may carry part of the pull.
  virtual bool foldsIntoTilt() const { return false; }

  /// True if this effect's regressor is Y(ctx) = Y(ctx with g_S = 0) + sum_j g_S(j) D_j with slopes
  /// D_j that depend on no field of ctx (e.g. gravity: the force m g_S at the centre of mass). The
  /// compressed tilt search (identify/gravity_compression.cpp) then evaluates the effect once per sample, at
  /// g_S = 0, and forms its gravity columns from D_j (taken once from addRegressor at g_S = e_j).
  /// Default false (the fitter evaluates the effect at g_S = 0 and at three gravity directions).
  virtual bool constantGravitySlope() const { return false; }

  /// True if the effect makes the payload's mass vary from sample to sample (payload(s)); its
  /// payloadMassChange is then not always 0.
  virtual bool changesPayloadMass() const { return false; }
  /// The change of the payload's mass this effect makes at `ctx`, with the model's parameters
  /// `theta` (one value per ParamIndex column; after bind()). payload(s): sum_k dmass_k (s - ref)^k.
  /// Identity (tested): at a sample with no motion and g_S = e_z, row 2 of this effect's regressor
  /// times theta equals this change.
  virtual double payloadMassChange(const SampleContext& ctx, const Eigen::VectorXd& theta) const {
    (void)ctx;
    (void)theta;
    return 0.0;
  }

  /// Resolve the columns this effect writes. Called once when the model is composed.
  /// Throws ConfigError if a parameter it needs is missing.
  virtual void bind(const ParamIndex& index) = 0;

  /// Add this effect's contribution for one sample into Y (6 rows, one column per model
  /// parameter). Must not allocate, throw or do I/O (real-time safe: used by the compensator), and
  /// must keep no state (no mutable members): the fit calls it for two halves of the samples on
  /// two threads at once (identify/gravity_compression.cpp, from 4,096 samples).
  virtual void addRegressor(const SampleContext& ctx,
                            Eigen::Ref<Eigen::Matrix<double, 6, Eigen::Dynamic>> Y) const noexcept = 0;

  virtual std::unique_ptr<Effect> clone() const = 0;
};

/// Helper for bind(): the column of `param`, or ConfigError naming the effect and the parameter.
int requireColumn(const ParamIndex& index, const std::string& param, const std::string& effect);

}  // namespace ftid::effects
