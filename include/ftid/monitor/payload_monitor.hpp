#pragma once
// The payload monitor (docs/daemon.md, "Payload monitor"): decides from the compensated residual
// whether the payload changed (an object grasped or released, a tool changed), something touches
// the tool (contact), or nothing happened. Pure math: no I/O, no clock; update() does not allocate.
//
// An episode starts when the residual's energy leaves the noise floor: a CUSUM
//   g_k = max(0, g_{k-1} + chi2_k - 6 - onset_margin),  chi2_k = sum_i (r_i / noise_std_i)^2,
// whose last zero is the onset tau; g > onset_threshold makes the state `suspect`. From tau on,
// three hypotheses predict each new residual r_k (Gaussian predictive densities):
//   H0 nothing:         r_k ~ N(0, R),                     R = diag(noise_std^2)
//   H1 payload change:  r_k = Y_k delta + n,  delta ~ N(0, P0) learnt by recursive least squares
//                       from the samples since tau (Bayesian, no forgetting); Y_k the rigid-body
//                       regressor of the effects gravity + linear_inertia + rigid_body, delta =
//                       [dm, d(m c) (3), dI_S (6)]: the change follows gravity and acceleration
//   H2 contact:         r_k = c_k + n, c_k a wrench in S of any direction, c_tau ~ N(0, C0), a
//                       random walk c_k = c_{k-1} + w_k (w_k ~ N(0, Q dt^2)): transient and arbitrary
// The one statistic is the log Bayes factor of the payload change against the better alternative,
//   Lambda_k = sum_{free j in [tau, k]} log p1(r_j) - max(sum log p0(r_j), sum log p2(r_j)),
// summed over the free-motion samples (below). Lambda > decision_threshold: payload change
// (state `changed`, latched until reset()); the contact's own Bayes factor over the better other
// hypothesis above the threshold, or the episode ending (g back to 0) first: contact. An episode
// still undecided (or decided as contact) after restart_s restarts its hypotheses at that sample.
//
// Free motion: a sample in which the gravity direction turns in S (|w_S x g_S| / |g_S| >=
// free_motion_turn_rad_s) or the sensor accelerates (|a_S| >= free_motion_acc_m_s2). Only such
// samples can tell a payload change (which follows g_S - a_S) from a steady push (which does not):
// while the arm stands still both explain a constant residual alike, and the monitor can only be
// suspect. Every sample since tau still feeds the estimates.
#include <cstdint>
#include <optional>

#include "ftid/common/types.hpp"
#include "ftid/effects/model.hpp"

namespace ftid::monitor {

/// Number of parameters of a payload change: [dm, d(m c)_x,y,z, dI_S xx,yy,zz,xy,xz,yz].
inline constexpr int kChangeParams = 10;
using ChangeVector = Eigen::Matrix<double, kChangeParams, 1>;
using ChangeMatrix = Eigen::Matrix<double, kChangeParams, kChangeParams>;

enum class MonitorState : std::uint8_t { kOk = 0, kSuspect = 1, kChanged = 2 };
enum class EventKind : std::uint8_t { kPayloadChange = 0, kContact = 1 };

const char* stateName(MonitorState state) noexcept;  ///< "ok", "suspect", "changed"
const char* eventName(EventKind kind) noexcept;      ///< "payload_change", "contact"

/// One sample the monitor reads: the compensated residual and the motion the model used.
struct MonitorSample {
  double t = 0.0;                          ///< [s], increasing
  Vec3 g_S = Vec3(0.0, 0.0, -kStandardGravity);  ///< gravity in S [m/s^2]
  Vec3 a_S = Vec3::Zero();                 ///< acceleration of the S origin in S, no gravity [m/s^2]
  Vec3 w_S = Vec3::Zero();                 ///< [rad/s]
  Vec3 alpha_S = Vec3::Zero();             ///< [rad/s^2]
  Wrench residual_S = Wrench::Zero();      ///< contact wrench = reading - model [N, Nm]
};

/// The settings (ftidd config section `monitor`, docs/daemon.md; defaults measured, see
/// docs/performance.md "Payload monitor").
struct MonitorSettings {
  /// Residual floor per axis with the right parameters (sensor noise plus model error) [N, Nm].
  Vec6 noise_std = (Vec6() << 0.3, 0.3, 0.3, 0.03, 0.03, 0.03).finished();
  double onset_margin = 6.0;          ///< CUSUM drift above the chi2 mean of 6
  double onset_threshold = 40.0;      ///< g above it: suspect
  double decision_threshold = 12.0;   ///< log Bayes factor for a decision [nats]
  double contact_force_std_N = 10.0;  ///< C0: the contact's spread at its onset
  double contact_torque_std_Nm = 1.0;
  double contact_force_rate_N_s = 40.0;   ///< Q: how fast a contact's force may change [N/s]
  double contact_torque_rate_Nm_s = 4.0;
  double prior_mass_std_kg = 5.0;         ///< P0 of a payload change
  double prior_mass_com_std_kg_m = 0.5;
  double prior_inertia_std_kg_m2 = 0.02;
  double free_motion_turn_rad_s = 0.05;   ///< free motion: gravity turns in S at least this fast
  double free_motion_acc_m_s2 = 0.3;      ///< or the sensor accelerates at least this much
  double max_gap_s = 0.1;                 ///< a longer gap between samples ends the episode
  /// An episode undecided for this long (or decided as contact) starts its hypotheses again at
  /// the current sample: a payload change during or right after a push is judged on its own.
  double restart_s = 1.0;
  /// A payload change persists: it is decided only once its episode has lasted this long [s]
  /// (0 = at the first sample the Bayes factor allows). A spike of a few samples that the change
  /// hypothesis happens to fit (a knock, a timing glitch) ends before it.
  double min_change_s = 0.1;
};

/// Throws ConfigError naming the key (prefix + name) for a value out of range.
void validate(const MonitorSettings& settings, const char* key_prefix = "monitor.");

/// The estimated change since the onset with its standard errors.
struct ChangeEstimate {
  double delta_mass_kg = 0.0;
  double delta_mass_std_kg = 0.0;
  Vec3 delta_mass_com_kg_m = Vec3::Zero();  ///< d(m c) [kg m]
  Vec3 delta_mass_com_std_kg_m = Vec3::Zero();
  /// Centre of mass of the added (dm > 0) or removed (dm < 0) mass in S [m] = d(m c) / dm, with
  /// first-order standard errors; NaN while |dm| is below 3 standard errors.
  Vec3 delta_com_m = Vec3::Zero();
  Vec3 delta_com_std_m = Vec3::Zero();
  ChangeVector delta = ChangeVector::Zero();  ///< [dm, d(m c), dI_S]
  ChangeMatrix covariance = ChangeMatrix::Zero();
};

struct MonitorStatus {
  MonitorState state = MonitorState::kOk;
  double t = 0.0;                  ///< time of the last sample
  double onset_t = 0.0;            ///< tau's time (valid while an episode runs)
  bool episode = false;            ///< an episode runs (g > 0)
  int samples = 0;                 ///< samples since the onset
  int free_samples = 0;            ///< of which in free motion
  double cusum = 0.0;              ///< g
  double log_bf_change = 0.0;      ///< Lambda (payload change vs the better alternative)
  double log_bf_contact = 0.0;     ///< contact vs the better alternative
  ChangeEstimate change;
};

struct MonitorEvent {
  EventKind kind = EventKind::kContact;
  double t_onset = 0.0;            ///< onset tau [s]
  double t_decided = 0.0;          ///< when decided (contact: confirmed or ended) [s]
  double duration_s = 0.0;         ///< contact: onset to end or decision
  bool confirmed = false;          ///< contact: its Bayes factor crossed the threshold (else it ended first)
  int samples = 0;
  int free_samples = 0;
  double log_bayes_factor = 0.0;   ///< of the decided hypothesis over the better other one
  double peak_force_N = 0.0;       ///< largest |residual force| in the episode
  ChangeEstimate change;           ///< the payload change's estimate at the decision
};

class PayloadMonitor {
 public:
  /// Validates the settings (ConfigError naming the key).
  explicit PayloadMonitor(const MonitorSettings& settings);

  /// Feeds one sample. Returns the event that this sample decided, if any. Non-finite samples are
  /// skipped (counted). Does not allocate or throw.
  std::optional<MonitorEvent> update(const MonitorSample& sample) noexcept;

  const MonitorStatus& status() const noexcept { return status_; }
  int skippedSamples() const noexcept { return skipped_; }
  /// Forgets everything (new parameters loaded): state ok.
  void reset() noexcept;
  const MonitorSettings& settings() const noexcept { return settings_; }

 private:
  void startEpisode(double t) noexcept;
  void endEpisode() noexcept;
  void regressor(const MonitorSample& s) noexcept;
  double updatePayload(const Wrench& r) noexcept;  ///< returns log p1(r)
  double updateContact(const Wrench& r, double dt) noexcept;
  double logNothing(const Wrench& r) const noexcept;
  bool freeMotion(const MonitorSample& s) const noexcept;
  void fillEstimate() noexcept;
  MonitorEvent makeEvent(EventKind kind, double t, bool confirmed, double log_bf) const noexcept;

  MonitorSettings settings_;
  effects::Model model_;
  int columns_[kChangeParams] = {};
  Eigen::Matrix<double, 6, Eigen::Dynamic> y_work_;
  Eigen::Matrix<double, 6, kChangeParams> y_;
  Vec6 r_var_;
  ChangeMatrix p0_;
  // Episode state.
  ChangeVector delta_;
  ChangeMatrix p_;
  Vec6 c_mean_;
  Vec6 c_var_;
  double sum0_ = 0.0, sum1_ = 0.0, sum2_ = 0.0;
  double last_t_ = 0.0;
  bool have_last_ = false;
  bool contact_confirmed_ = false;
  double peak_force_N_ = 0.0;
  int skipped_ = 0;
  MonitorStatus status_;
};

}  // namespace ftid::monitor
