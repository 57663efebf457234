// Real-time compensation (include/ftid/compensate/compensator.hpp).
#include "ftid/compensate/compensator.hpp"

#include <cmath>
#include <string>

#include "ftid/common/error.hpp"
#include "ftid/model/frames.hpp"

namespace ftid::compensate {

namespace {

bool finiteContext(const SampleContext& c, bool use_context_gravity) noexcept {
  bool ok = std::isfinite(c.t) && c.wrench_S.allFinite() && c.R_BS.allFinite() && c.w_S.allFinite() &&
            c.alpha_S.allFinite() && c.a_S.allFinite() && c.q.allFinite() && c.qd.allFinite();
  if (use_context_gravity) ok = ok && c.g_S.allFinite();
  if (c.has_imu) ok = ok && c.imu_acc_S.allFinite() && c.imu_w_S.allFinite() && c.imu_alpha_S.allFinite();
  if (c.has_temp) ok = ok && std::isfinite(c.temp_degC);
  return ok;
}

}  // namespace

Compensator::Compensator(const effects::Model& model, const Eigen::VectorXd& theta, double tilt_u_rad,
                         double tilt_v_rad, bool use_context_gravity)
    : model_(model),
      theta_(theta),
      g_B_(model::gravityInBase(tilt_u_rad, tilt_v_rad)),
      use_context_gravity_(use_context_gravity),
      needs_derivative_((model.signals() & effects::kSignalModelDerivative) != 0),
      Y_(6, model.numParams()) {
  if (theta.size() != model.numParams()) {
    throw ConfigError("compensator: " + std::to_string(theta.size()) + " parameters given, model '" +
                      model.name() + "' has " + std::to_string(model.numParams()));
  }
  if (!theta.allFinite() || !std::isfinite(tilt_u_rad) || !std::isfinite(tilt_v_rad)) {
    throw ConfigError("compensator: non-finite parameter or tilt");
  }
  Y_.setZero();
}

void Compensator::reset() noexcept {
  has_prev_ = false;
  dwdt_.setZero();
}

Status Compensator::compute(const SampleContext& ctx, Wrench* contact_S, Wrench* modelled_S) noexcept {
  if (!finiteContext(ctx, use_context_gravity_)) return Status::kInvalidInput;
  work_ = ctx;  // fixed-size copy (no allocation); ctx.extra is a pointer
  if (!use_context_gravity_) work_.g_S.noalias() = ctx.R_BS.transpose() * g_B_;
  if (needs_derivative_) work_.dwrench_model_dt = dwdt_;
  model_.computeRegressor(work_, Y_);
  Wrench modelled;
  modelled.noalias() = Y_ * theta_;
  if (!modelled.allFinite()) return Status::kInvalidInput;
  if (needs_derivative_) {
    // Backward difference of the modelled wrench, used at the next sample.
    const double dt = ctx.t - prev_t_;
    dwdt_ = (has_prev_ && dt > 0.0) ? Wrench((modelled - prev_modelled_) / dt) : Wrench::Zero();
    prev_modelled_ = modelled;
    prev_t_ = ctx.t;
    has_prev_ = true;
  }
  if (modelled_S != nullptr) *modelled_S = modelled;
  if (contact_S != nullptr) *contact_S = ctx.wrench_S - modelled;
  return Status::kOk;
}

}  // namespace ftid::compensate
