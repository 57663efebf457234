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
// compute() is real-time safe: no heap allocation (workspace and ring preallocated at
// construction), no exceptions, no locks, no I/O. Non-finite input is rejected with
// Status::kInvalidInput and the outputs are left untouched. One instance per thread.
#include <vector>

#include "ftid/common/status.hpp"
#include "ftid/effects/nonlinear.hpp"

namespace ftid::compensate {

using effects::NonlinearParams;
using effects::SampleContext;

class Compensator {
 public:
  /// The highest sample rate the delay ring is sized for [Hz]: ring = |tau| * rate * 1.25 + 8.
  static constexpr double kMaxRateHz = 2000.0;

  /// theta ordered as model.paramIndex(); nonlinear parameters as fitted (those the model does
  /// not estimate are ignored except the tilt, which always sets gravity). Throws ConfigError if
  /// theta has the wrong size, a value is not finite, or |delay| > 10 s.
  Compensator(const effects::Model& model, const Eigen::VectorXd& theta, const NonlinearParams& nonlinear);
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

 private:
  const SampleContext& ringAt(int i) const noexcept;  ///< 0 = oldest
  void push(const SampleContext& ctx) noexcept;
  Status evaluate(const SampleContext& reading, Wrench* contact_S, Wrench* modelled_S) noexcept;

  effects::ModelEvaluator eval_;
  NonlinearParams nl_;
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
