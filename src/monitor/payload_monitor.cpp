// The payload monitor (ftid/monitor/payload_monitor.hpp, docs/daemon.md "Payload monitor").
#include "ftid/monitor/payload_monitor.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <Eigen/Cholesky>

#include "ftid/common/error.hpp"
#include "ftid/effects/rigid_body.hpp"

namespace ftid::monitor {

namespace {

constexpr double kLog2Pi = 1.8378770664093453;
constexpr const char* kChangeParamNames[kChangeParams] = {
    "mass", "mass_com_x", "mass_com_y", "mass_com_z", "i_s_xx", "i_s_yy", "i_s_zz",
    "i_s_xy", "i_s_xz", "i_s_yz"};

void requirePositive(double value, const char* prefix, const char* name) {
  if (!(std::isfinite(value) && value > 0.0)) {
    throw ConfigError(std::string("key '") + prefix + name + "': must be a finite number > 0 (got " +
                      std::to_string(value) + ")");
  }
}

}  // namespace

const char* stateName(MonitorState state) noexcept {
  switch (state) {
    case MonitorState::kOk: return "ok";
    case MonitorState::kSuspect: return "suspect";
    case MonitorState::kChanged: return "changed";
  }
  return "?";
}

const char* eventName(EventKind kind) noexcept {
  return kind == EventKind::kPayloadChange ? "payload_change" : "contact";
}

void validate(const MonitorSettings& s, const char* p) {
  static constexpr const char* kAxes[6] = {"fx", "fy", "fz", "tx", "ty", "tz"};
  for (int i = 0; i < 6; ++i) {
    const std::string name = std::string("noise_std.") + kAxes[i];
    requirePositive(s.noise_std[i], p, name.c_str());
  }
  if (!(std::isfinite(s.onset_margin) && s.onset_margin >= 0.0)) {
    throw ConfigError(std::string("key '") + p + "onset_margin': must be a finite number >= 0");
  }
  requirePositive(s.onset_threshold, p, "onset_threshold");
  requirePositive(s.decision_threshold, p, "decision_threshold");
  requirePositive(s.contact_force_std_N, p, "contact_force_std_N");
  requirePositive(s.contact_torque_std_Nm, p, "contact_torque_std_Nm");
  requirePositive(s.contact_force_rate_N_s, p, "contact_force_rate_N_s");
  requirePositive(s.contact_torque_rate_Nm_s, p, "contact_torque_rate_Nm_s");
  requirePositive(s.prior_mass_std_kg, p, "prior_mass_std_kg");
  requirePositive(s.prior_mass_com_std_kg_m, p, "prior_mass_com_std_kg_m");
  requirePositive(s.prior_inertia_std_kg_m2, p, "prior_inertia_std_kg_m2");
  requirePositive(s.free_motion_turn_rad_s, p, "free_motion_turn_rad_s");
  requirePositive(s.free_motion_acc_m_s2, p, "free_motion_acc_m_s2");
  requirePositive(s.max_gap_s, p, "max_gap_s");
  requirePositive(s.restart_s, p, "restart_s");
  if (!(std::isfinite(s.min_change_s) && s.min_change_s >= 0.0 && s.min_change_s < s.restart_s)) {
    throw ConfigError(std::string("key '") + p + "min_change_s': must be >= 0 and below restart_s (" +
                      std::to_string(s.restart_s) + " s; an episode restarts before it could be decided), got " +
                      std::to_string(s.min_change_s));
  }
}

PayloadMonitor::PayloadMonitor(const MonitorSettings& settings)
    : settings_(settings), model_(effects::Model::fromName("gravity+linear_inertia+rigid_body")) {
  validate(settings_);
  for (int j = 0; j < kChangeParams; ++j) {
    columns_[j] = model_.paramIndex().column(kChangeParamNames[j]);
    if (columns_[j] < 0) throw ConfigError(std::string("payload monitor: no parameter ") + kChangeParamNames[j]);
  }
  y_work_.resize(6, model_.numParams());
  r_var_ = settings_.noise_std.cwiseAbs2();
  Eigen::Matrix<double, kChangeParams, 1> prior_std;
  prior_std << settings_.prior_mass_std_kg, Vec3::Constant(settings_.prior_mass_com_std_kg_m),
      Vec6::Constant(settings_.prior_inertia_std_kg_m2);
  p0_ = prior_std.cwiseAbs2().asDiagonal();
  reset();
}

void PayloadMonitor::reset() noexcept {
  status_ = MonitorStatus{};
  have_last_ = false;
  endEpisode();
}

void PayloadMonitor::startEpisode(double t) noexcept {
  delta_.setZero();
  p_ = p0_;
  c_mean_.setZero();
  c_var_ << Vec3::Constant(settings_.contact_force_std_N * settings_.contact_force_std_N),
      Vec3::Constant(settings_.contact_torque_std_Nm * settings_.contact_torque_std_Nm);
  sum0_ = sum1_ = sum2_ = 0.0;
  contact_confirmed_ = false;
  peak_force_N_ = 0.0;
  status_.episode = true;
  status_.onset_t = t;
  status_.samples = 0;
  status_.free_samples = 0;
  status_.log_bf_change = 0.0;
  status_.log_bf_contact = 0.0;
}

void PayloadMonitor::endEpisode() noexcept {
  status_.episode = false;
  status_.cusum = 0.0;
  status_.samples = 0;
  status_.free_samples = 0;
  status_.log_bf_change = 0.0;
  status_.log_bf_contact = 0.0;
  status_.change = ChangeEstimate{};
  if (status_.state == MonitorState::kSuspect) status_.state = MonitorState::kOk;
}

void PayloadMonitor::regressor(const MonitorSample& s) noexcept {
  effects::SampleContext ctx;
  ctx.g_S = s.g_S;
  ctx.a_S = s.a_S;
  ctx.w_S = s.w_S;
  ctx.alpha_S = s.alpha_S;
  model_.computeRegressor(ctx, y_work_);
  for (int j = 0; j < kChangeParams; ++j) y_.col(j) = y_work_.col(columns_[j]);
}

double PayloadMonitor::logNothing(const Wrench& r) const noexcept {
  double l = 0.0;
  for (int i = 0; i < 6; ++i) l -= 0.5 * (r[i] * r[i] / r_var_[i] + std::log(r_var_[i]) + kLog2Pi);
  return l;
}

double PayloadMonitor::updatePayload(const Wrench& r) noexcept {
  // Bayesian recursive least squares: predictive N(Y delta, Y P Y^T + R), then the update.
  const Wrench e = r - y_ * delta_;
  const Eigen::Matrix<double, kChangeParams, 6> py_t = p_ * y_.transpose();
  Mat6 s = y_ * py_t;
  s.diagonal() += r_var_;
  const Eigen::LLT<Mat6> llt(s);
  if (llt.info() != Eigen::Success) return -std::numeric_limits<double>::infinity();
  const Wrench s_inv_e = llt.solve(e);
  double log_det = 0.0;
  for (int i = 0; i < 6; ++i) log_det += 2.0 * std::log(llt.matrixL()(i, i));
  const Eigen::Matrix<double, kChangeParams, 6> gain = llt.solve(py_t.transpose()).transpose();
  delta_ += gain * e;
  p_ -= gain * py_t.transpose();
  p_ = 0.5 * (p_ + p_.transpose()).eval();
  return -0.5 * (e.dot(s_inv_e) + log_det + 6.0 * kLog2Pi);
}

double PayloadMonitor::updateContact(const Wrench& r, double dt) noexcept {
  // Per axis a scalar Kalman filter on a random walk (the contact wrench in S).
  double l = 0.0;
  for (int i = 0; i < 6; ++i) {
    const double rate = i < 3 ? settings_.contact_force_rate_N_s : settings_.contact_torque_rate_Nm_s;
    c_var_[i] += rate * rate * dt * dt;
    const double s = c_var_[i] + r_var_[i];
    const double e = r[i] - c_mean_[i];
    l -= 0.5 * (e * e / s + std::log(s) + kLog2Pi);
    const double k = c_var_[i] / s;
    c_mean_[i] += k * e;
    c_var_[i] *= (1.0 - k);
  }
  return l;
}

bool PayloadMonitor::freeMotion(const MonitorSample& s) const noexcept {
  const double g = s.g_S.norm();
  const double turn = g > 0.0 ? s.w_S.cross(s.g_S).norm() / g : 0.0;
  return turn >= settings_.free_motion_turn_rad_s || s.a_S.norm() >= settings_.free_motion_acc_m_s2;
}

void PayloadMonitor::fillEstimate() noexcept {
  ChangeEstimate& c = status_.change;
  c.delta = delta_;
  c.covariance = p_;
  c.delta_mass_kg = delta_[0];
  c.delta_mass_std_kg = std::sqrt(std::max(0.0, p_(0, 0)));
  for (int j = 0; j < 3; ++j) {
    c.delta_mass_com_kg_m[j] = delta_[1 + j];
    c.delta_mass_com_std_kg_m[j] = std::sqrt(std::max(0.0, p_(1 + j, 1 + j)));
  }
  const double dm = delta_[0];
  if (std::abs(dm) >= 3.0 * c.delta_mass_std_kg && dm != 0.0) {
    // c = d(mc) / dm; Jacobian [-d(mc)/dm^2, I/dm].
    for (int j = 0; j < 3; ++j) {
      c.delta_com_m[j] = delta_[1 + j] / dm;
      Eigen::Matrix<double, 1, 2> jac(-delta_[1 + j] / (dm * dm), 1.0 / dm);
      Eigen::Matrix2d cov;
      cov << p_(0, 0), p_(0, 1 + j), p_(1 + j, 0), p_(1 + j, 1 + j);
      c.delta_com_std_m[j] = std::sqrt(std::max(0.0, (jac * cov * jac.transpose())(0, 0)));
    }
  } else {
    c.delta_com_m.setConstant(std::numeric_limits<double>::quiet_NaN());
    c.delta_com_std_m.setConstant(std::numeric_limits<double>::quiet_NaN());
  }
}

MonitorEvent PayloadMonitor::makeEvent(EventKind kind, double t, bool confirmed, double log_bf) const noexcept {
  MonitorEvent e;
  e.kind = kind;
  e.t_onset = status_.onset_t;
  e.t_decided = t;
  e.duration_s = t - status_.onset_t;
  e.confirmed = confirmed;
  e.samples = status_.samples;
  e.free_samples = status_.free_samples;
  e.log_bayes_factor = log_bf;
  e.peak_force_N = peak_force_N_;
  e.change = status_.change;
  return e;
}

std::optional<MonitorEvent> PayloadMonitor::update(const MonitorSample& s) noexcept {
  if (!(std::isfinite(s.t) && s.g_S.allFinite() && s.a_S.allFinite() && s.w_S.allFinite() &&
        s.alpha_S.allFinite() && s.residual_S.allFinite())) {
    ++skipped_;
    return std::nullopt;
  }
  std::optional<MonitorEvent> event;
  const double dt = have_last_ ? s.t - last_t_ : 0.0;
  if (have_last_ && (dt <= 0.0 || dt > settings_.max_gap_s)) {
    // A gap (or time going back): the episode's filters cannot bridge it.
    if (status_.state == MonitorState::kSuspect && !contact_confirmed_) {
      event = makeEvent(EventKind::kContact, last_t_, false, status_.log_bf_contact);
    }
    if (status_.state != MonitorState::kChanged) endEpisode();
  }
  have_last_ = true;
  last_t_ = s.t;
  status_.t = s.t;
  const double step = dt > 0.0 && dt <= settings_.max_gap_s ? dt : 0.0;

  double chi2 = 0.0;
  for (int i = 0; i < 6; ++i) chi2 += s.residual_S[i] * s.residual_S[i] / r_var_[i];
  // Capped at twice the threshold, so that the end of a long, strong residual is seen within
  // about 2 onset_threshold / onset_margin samples.
  const double g = std::clamp(status_.cusum + chi2 - 6.0 - settings_.onset_margin, 0.0,
                              2.0 * settings_.onset_threshold);
  const bool changed = status_.state == MonitorState::kChanged;
  if (g <= 0.0 && !changed) {
    if (status_.episode) {
      // The residual is back in the noise: an undecided episode was a contact.
      if (status_.state == MonitorState::kSuspect && !contact_confirmed_) {
        event = makeEvent(EventKind::kContact, s.t, false, status_.log_bf_contact);
      }
      endEpisode();
    }
    return event;
  }
  status_.cusum = g;
  if (!status_.episode) {
    startEpisode(s.t);
  } else if (!changed && s.t - status_.onset_t > settings_.restart_s) {
    // A long undecided episode (a contact, or a change behind one): its hypotheses start again
    // from here, so that what remains after a push is judged on its own samples.
    const bool confirmed = contact_confirmed_;
    const double peak = peak_force_N_;
    startEpisode(s.t);
    contact_confirmed_ = confirmed;
    peak_force_N_ = peak;
  }

  regressor(s);
  const double l0 = logNothing(s.residual_S);
  const double l1 = updatePayload(s.residual_S);
  const double l2 = updateContact(s.residual_S, step);
  ++status_.samples;
  peak_force_N_ = std::max(peak_force_N_, s.residual_S.head<3>().norm());
  if (freeMotion(s)) {
    ++status_.free_samples;
    sum0_ += l0;
    sum1_ += l1;
    sum2_ += l2;
  }
  status_.log_bf_change = sum1_ - std::max(sum0_, sum2_);
  status_.log_bf_contact = sum2_ - std::max(sum0_, sum1_);
  fillEstimate();
  if (changed) return event;
  if (status_.state == MonitorState::kOk && g > settings_.onset_threshold) status_.state = MonitorState::kSuspect;
  if (status_.state != MonitorState::kSuspect) return event;
  if (status_.log_bf_change > settings_.decision_threshold && s.t - status_.onset_t >= settings_.min_change_s) {
    status_.state = MonitorState::kChanged;
    return makeEvent(EventKind::kPayloadChange, s.t, true, status_.log_bf_change);
  }
  if (!contact_confirmed_ && status_.log_bf_contact > settings_.decision_threshold) {
    contact_confirmed_ = true;
    return makeEvent(EventKind::kContact, s.t, true, status_.log_bf_contact);
  }
  return event;
}

}  // namespace ftid::monitor
