// Real-time compensation (include/ftid/compensate/compensator.hpp).
#include "ftid/compensate/compensator.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "ftid/common/error.hpp"
#include "ftid/model/frames.hpp"

namespace ftid::compensate {

namespace {

bool finiteContext(const SampleContext& c) noexcept {
  bool ok = std::isfinite(c.t) && c.wrench_S.allFinite() && c.R_BS.allFinite() && c.w_S.allFinite() &&
            c.alpha_S.allFinite() && c.a_S.allFinite() && c.q.allFinite() && c.qd.allFinite() &&
            c.p_BS_B.allFinite();
  if (c.has_imu) ok = ok && c.imu_acc_S.allFinite() && c.imu_w_S.allFinite() && c.imu_alpha_S.allFinite();
  if (c.has_temp) ok = ok && std::isfinite(c.temp_degC);
  return ok;
}

constexpr double kMaxDelayS = 10.0;

int ringCapacity(double delay_s) {
  if (delay_s == 0.0) return 0;
  return static_cast<int>(std::ceil(std::abs(delay_s) * Compensator::kMaxRateHz * 1.25)) + 8;
}

}  // namespace

Compensator::Compensator(const effects::Model& model, const Eigen::VectorXd& theta,
                         const NonlinearParams& nonlinear)
    : Compensator(model, theta, nonlinear, CompensatorOptions{}) {}

Compensator::Compensator(const effects::Model& model, const Eigen::VectorXd& theta,
                         const NonlinearParams& nonlinear, const CompensatorOptions& options)
    : eval_(model, theta),
      nl_(nonlinear),
      options_(options),
      g_B_(model::gravityInBase(nonlinear.tilt_u_rad, nonlinear.tilt_v_rad)),
      R_SM_(effects::mountingRotation(nonlinear.mount_rpy_rad)),
      mounting_(model.estimatesMounting()),
      delay_s_(model.estimatesDelay() ? nonlinear.delay_s : 0.0) {
  if (!theta.allFinite() || !std::isfinite(nonlinear.tilt_u_rad) || !std::isfinite(nonlinear.tilt_v_rad) ||
      !nonlinear.mount_rpy_rad.allFinite() || !std::isfinite(nonlinear.delay_s)) {
    throw ConfigError("compensator: non-finite parameter, tilt, mounting angle or delay");
  }
  if (!options.imu_bias.acc_mps2.allFinite() || !options.imu_bias.gyro_radps.allFinite()) {
    throw ConfigError("compensator: non-finite IMU bias");
  }
  if (options.motion == MotionSource::kImu && !model.tiltAbsorbers().empty()) {
    throw ConfigError("compensator: model '" + model.name() + "' folds the pull of " + model.tiltAbsorbers() +
                      " into an apparent tilt, which the motion from the IMU (a measured gravity) would drop: "
                      "compensate it with the kinematics' motion (docs/effects.md \"Motion from the IMU\")");
  }
  if (std::abs(delay_s_) > kMaxDelayS) {
    throw ConfigError("compensator: delay " + std::to_string(delay_s_) + " s is beyond +-" +
                      std::to_string(kMaxDelayS) + " s");
  }
  if (!mounting_) R_SM_.setIdentity();
  ring_.resize(static_cast<std::size_t>(ringCapacity(delay_s_)));
}

Compensator::Compensator(const effects::Model& model, const Eigen::VectorXd& theta, double tilt_u_rad,
                         double tilt_v_rad)
    : Compensator(model, theta, NonlinearParams{tilt_u_rad, tilt_v_rad, Vec3::Zero(), 0.0}) {}

void Compensator::reset() noexcept {
  ring_head_ = 0;
  ring_count_ = 0;
}

const SampleContext& Compensator::ringAt(int i) const noexcept {
  const int cap = static_cast<int>(ring_.size());
  return ring_[static_cast<std::size_t>((ring_head_ + i) % cap)];
}

void Compensator::push(const SampleContext& ctx) noexcept {
  const int cap = static_cast<int>(ring_.size());
  if (ring_count_ > 0 && !(ctx.t > ringAt(ring_count_ - 1).t)) reset();  // time went back: restart
  if (ring_count_ < cap) {
    ring_[static_cast<std::size_t>((ring_head_ + ring_count_) % cap)] = ctx;
    ++ring_count_;
  } else {
    ring_[static_cast<std::size_t>(ring_head_)] = ctx;
    ring_head_ = (ring_head_ + 1) % cap;
  }
}

// `work_` holds the reading with its kinematics already at the right time.
Status Compensator::evaluate(const SampleContext& reading, Wrench* contact_S, Wrench* modelled_S) noexcept {
  if (mounting_) effects::applyMounting(R_SM_, &work_);
  work_.g_S.noalias() = work_.R_BS.transpose() * g_B_;
  if (options_.motion == MotionSource::kImu) {
    // The IMU at the reading's kinematics time (the header): a_S - g_S is the specific force.
    if (!reading.has_imu || !work_.has_imu) return Status::kInvalidInput;
    work_.w_S = work_.imu_w_S - options_.imu_bias.gyro_radps;
    work_.alpha_S = work_.imu_alpha_S;
    work_.a_S = work_.imu_acc_S - options_.imu_bias.acc_mps2 + work_.g_S;
  }
  work_.wrench_S = reading.wrench_S;
  Wrench modelled;
  const Wrench contact = eval_.contact(work_, &modelled);
  if (!modelled.allFinite() || !contact.allFinite()) return Status::kInvalidInput;
  output_t_ = reading.t;
  if (modelled_S != nullptr) *modelled_S = modelled;
  if (contact_S != nullptr) *contact_S = contact;
  return Status::kOk;
}

Status Compensator::compute(const SampleContext& ctx, Wrench* contact_S, Wrench* modelled_S) noexcept {
  if (!finiteContext(ctx)) return Status::kInvalidInput;
  if (delay_s_ == 0.0) {
    work_ = ctx;  // fixed-size copy (no allocation); ctx.extra is a pointer
    return evaluate(ctx, contact_S, modelled_S);
  }
  push(ctx);
  auto at = [this](int i) -> const SampleContext& { return ringAt(i); };
  if (delay_s_ > 0.0) {
    // The current reading belongs to the kinematics at t - tau.
    work_ = ctx;
    if (!effects::kinematicsAt(at, ring_count_, ctx.t - delay_s_, &work_)) return Status::kNotReady;
    return evaluate(ctx, contact_S, modelled_S);
  }
  // tau < 0: the newest reading r with t_r + |tau| <= t_now (its kinematics have arrived).
  const double t_needed = ctx.t + delay_s_;  // = t_now - |tau|
  int r = ring_count_ - 1;
  while (r >= 0 && ringAt(r).t > t_needed + 1e-9) --r;
  if (r < 0) return Status::kNotReady;
  const SampleContext& reading = ringAt(r);
  work_ = reading;
  if (!effects::kinematicsAt(at, ring_count_, reading.t - delay_s_, &work_)) return Status::kNotReady;
  return evaluate(reading, contact_S, modelled_S);
}

}  // namespace ftid::compensate
