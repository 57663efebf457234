#pragma once
// Real-time compensation (paper Eq. 24-30, docs/conventions.md "Contact (compensated) wrench"):
//
//   modelled_S = Y(ctx; U, V) * theta          (offsets + gravity + inertia + every other effect)
//   contact_S  = ctx.wrench_S - modelled_S
//
// compute() is real-time safe: no heap allocation (regressor preallocated at construction), no
// exceptions, no locks, no I/O. Non-finite input is rejected with Status::kInvalidInput and the
// outputs are left untouched. One instance per thread (it keeps the preallocated workspace and the
// previous modelled wrench for effects that read its time derivative).
#include "ftid/common/status.hpp"
#include "ftid/effects/model.hpp"

namespace ftid::compensate {

using effects::SampleContext;

class Compensator {
 public:
  /// theta ordered as model.paramIndex(); tilt in rad. Throws ConfigError if theta has the wrong
  /// size or is not finite. If use_context_gravity, ctx.g_S is used as given instead of
  /// R_BS^T g_B(U, V) (e.g. gravity from an IMU).
  Compensator(const effects::Model& model, const Eigen::VectorXd& theta, double tilt_u_rad,
              double tilt_v_rad, bool use_context_gravity = false);

  /// contact_S = reading - modelled; either output may be nullptr.
  Status compute(const SampleContext& ctx, Wrench* contact_S, Wrench* modelled_S) noexcept;

  /// Forgets the previous sample (time-derivative state), e.g. after a gap in the data.
  void reset() noexcept;

  const effects::Model& model() const noexcept { return model_; }
  const Eigen::VectorXd& theta() const noexcept { return theta_; }

 private:
  effects::Model model_;
  Eigen::VectorXd theta_;
  Vec3 g_B_;
  bool use_context_gravity_;
  bool needs_derivative_;
  Eigen::Matrix<double, 6, Eigen::Dynamic> Y_;
  SampleContext work_;
  Wrench prev_modelled_ = Wrench::Zero();
  Wrench dwdt_ = Wrench::Zero();
  double prev_t_ = 0.0;
  bool has_prev_ = false;
};

}  // namespace ftid::compensate
