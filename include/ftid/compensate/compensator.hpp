#pragma once
// Real-time compensation (paper Eq. 24-30, docs/conventions.md "Contact (compensated) wrench",
// docs/effects.md "How each effect is compensated online"):
//
//   modelled = ModelEvaluator(prepared context)      (every effect, crosstalk included)
//   contact  = reading - modelled,  or with crosstalk (I + E)^-1 reading - w_base
//              (effects::ModelEvaluator::contact: the calibration error is undone on the contact too)
//
// The prepared context is the one the fit uses (effects/nonlinear.hpp): mounting rotation
// applied to the kinematics, g = R_BM^T g_B(U, V), and, with a delay tau, the kinematics at the
// reading's time minus tau, interpolated from a fixed ring of recent samples:
//   tau > 0 (the reading lags): each reading is paired with the state tau earlier; the output
//           belongs to the current reading; the first tau seconds give Status::kNotReady.
//   tau < 0 (the reading leads): the newest reading whose state (|tau| later) has arrived is
//           output, so the output is |tau| late; outputTime() tells which reading it is.
// Nothing differentiates the compensator's own output.
//
// Motion from the IMU (MotionSource::kImu, docs/effects.md "Motion from the IMU"): the prepared
// context's motion of S is taken from the IMU instead of the kinematics,
//   w_S = imu_w_S - b_g,   alpha_S = imu_alpha_S,   a_S = (imu_acc_S - b_a) + g_S
// with g_S from the kinematic orientation and the tilt as above, so that a_S - g_S, the specific
// force every inertial effect reads, is the accelerometer's. The IMU is taken in the robot state's
// time, as `sensor_delay` defines it (the wrench lags the robot state and the IMU): with a delay its
// channels are interpolated at the reading's kinematics time like the rest of the motion. Its axes
// are taken as the sensor's (the gyro's mount check in `ftid identify` and the lab says when they
// are not). A reading without the IMU gives Status::kInvalidInput. A model whose tilt is apparent
// (Model::tiltAbsorbers: the tilt holds a cable's uniform pull) is refused at construction: the
// IMU measures gravity, so the pull folded into the tilt would be lost.
//
// compute() is real-time safe: no heap allocation (workspace and ring preallocated at
// construction), no exceptions, no locks, no I/O. Non-finite input is rejected with
// Status::kInvalidInput and the outputs are left untouched. One instance per thread.
#include <vector>

#include "ftid/common/status.hpp"
#include "ftid/effects/nonlinear.hpp"

namespace ftid::compensate {

using effects::NonlinearParams;
using effects::SampleContext;

/// Where the compensation takes the motion of S from (above).
enum class MotionSource { kKinematics, kImu };

/// The IMU's biases in its own frame (ftid identify writes them to the parameter file's `imu`).
struct ImuBiases {
  Vec3 acc_mps2 = Vec3::Zero();
  Vec3 gyro_radps = Vec3::Zero();
};

struct CompensatorOptions {
  MotionSource motion = MotionSource::kKinematics;
  ImuBiases imu_bias;  ///< subtracted from the IMU's readings with MotionSource::kImu
};

class Compensator {
 public:
  /// The highest sample rate the delay ring is sized for [Hz]: ring = |tau| * rate * 1.25 + 8.
  static constexpr double kMaxRateHz = 2000.0;

  /// theta ordered as model.paramIndex(); nonlinear parameters as fitted (those the model does
  /// not estimate are ignored except the tilt, which always sets gravity). Throws ConfigError if
  /// theta has the wrong size, a value is not finite, or |delay| > 10 s.
  Compensator(const effects::Model& model, const Eigen::VectorXd& theta, const NonlinearParams& nonlinear);
  /// The same with the motion's source; throws ConfigError also for non-finite biases and for
  /// MotionSource::kImu with a model whose tilt is apparent (above).
  Compensator(const effects::Model& model, const Eigen::VectorXd& theta, const NonlinearParams& nonlinear,
              const CompensatorOptions& options);
  /// Paper-style: tilt only.
  Compensator(const effects::Model& model, const Eigen::VectorXd& theta, double tilt_u_rad,
              double tilt_v_rad);

  /// contact = reading - modelled; either output may be nullptr. kNotReady while a delay line
  /// fills, kInvalidInput for non-finite input or output.
  Status compute(const SampleContext& ctx, Wrench* contact_S, Wrench* modelled_S) noexcept;

  /// Time (SampleContext::t) of the reading the last successful output belongs to.
  double outputTime() const noexcept { return output_t_; }

  /// Forgets the history (delay line), e.g. after a gap in the data.
  void reset() noexcept;

  const effects::Model& model() const noexcept { return eval_.model(); }
  const Eigen::VectorXd& theta() const noexcept { return eval_.theta(); }
  const NonlinearParams& nonlinear() const noexcept { return nl_; }
  const CompensatorOptions& options() const noexcept { return options_; }

 private:
  const SampleContext& ringAt(int i) const noexcept;  ///< 0 = oldest
  void push(const SampleContext& ctx) noexcept;
  Status evaluate(const SampleContext& reading, Wrench* contact_S, Wrench* modelled_S) noexcept;

  effects::ModelEvaluator eval_;
  NonlinearParams nl_;
  CompensatorOptions options_;
  Vec3 g_B_;
  Mat3 R_SM_;
  bool mounting_;
  double delay_s_;                  ///< 0 unless the model estimates a delay
  std::vector<SampleContext> ring_; ///< fixed capacity; used only when delay_s_ != 0
  int ring_head_ = 0;               ///< index of the oldest entry
  int ring_count_ = 0;
  SampleContext work_;
  double output_t_ = 0.0;
};

}  // namespace ftid::compensate
