#pragma once
// Sensor and mount dynamics in the laboratory (issue 22; docs/effects.md "Dynamics of the
// reading"): the reading y is the modelled wrench u seen through a filter,
//   mount_dynamics (2nd order):  y'' + 2 zeta w y' + w^2 y = w^2 u   (w = 2 pi f_n)
//   sensor_filter  (1st order):  y' = w_c (u - y)                     (w_c = 2 pi f_c)
// For fixed (f_n, zeta) or f_c the reading is linear in the model's parameters: every regressor
// column is filtered along time (within each log), and the laboratory searches the filter's
// parameters on a grid, refined, judging the best by the held-out error and a chi-square test
// with the grid's Bonferroni correction (docs/analyze.md). Offline only: neither ftidd nor
// `ftid compensate` inverts these filters (docs/effects.md says why).
#include <string>
#include <vector>

#include "ftid/common/types.hpp"

namespace ftid::lab {

/// The 2nd-order response, in place, on a uniformly sampled series (Tustin with the frequency
/// prewarped to f_n, so the resonance stays at f_n), starting at rest at x[0] (y = u, y' = 0).
void secondOrderFilter(std::vector<double>& x, double f_hz, double zeta, double dt_s);
/// The 1st-order low-pass, in place (Tustin prewarped to f_c), starting at rest at x[0].
void firstOrderFilter(std::vector<double>& x, double f_hz, double dt_s);

/// The laboratory's search for dynamics of the reading on its last model.
struct DynamicsCheck {
  bool tested = false;
  std::string note;              ///< why not tested, or ""
  std::string effect;            ///< "mount_dynamics" or "sensor_filter": the better one
  double f_hz = 0.0;             ///< natural frequency (mount) or cut-off (filter)
  double zeta = 0.0;             ///< damping (mount only)
  double relative_reduction = 0.0;  ///< of the held-out sum of squares against the model alone
  Vec6 residual_rms = Vec6::Zero(); ///< held-out, per axis, with the filter
  double p_value = 1.0;          ///< chi-square(2 or 1) of the in-sample gain
  double family_p = 1.0;         ///< min(1, grid points x p)
  int grid_points = 0;
  bool significant = false;      ///< family_p < alpha and the held-out error falls beyond the margin
  /// A filter lags the reading by about its group delay at low frequency (2 zeta / w_n, or 1 / w_c),
  /// which a model's `sensor_delay` takes first on the path: at the motion's frequencies the two
  /// trade off. With a significant filter and a last model that fits sensor_delay, the search above
  /// relinearises the delay at the model's delay minus each trial's lag, the wrench's own delay is
  /// fitted through the filter found, and the IMU's stream delay (payload-free) is judged against
  /// it (detail::judgeDelayAgainstLag, docs/effects.md "Dynamics of the reading").
  struct DelayAgainstLag {
    bool tested = false;
    double lag_s = 0.0;           ///< the (joint search's) filter's group delay at low frequency
    double model_delay_s = 0.0;   ///< the last model's delay (fitted without a filter)
    /// The wrench's own delay fitted through the filter (no standard error is given: with the
    /// filter's parameters free, a delay and the lag trade off along a ridge).
    double delay_s = 0.0;
    bool imu_compared = false;    ///< the IMU's stream delay was judged against it
    double imu_delay_s = 0.0;
    std::string held_effect;      ///< the filter searched again with the delay held at the IMU's
    double held_f_hz = 0.0, held_zeta = 0.0, held_lag_s = 0.0;
    /// min(1, m p), p the chi-square(1) tail of the in-sample gain of the free delay over the delay
    /// held at the IMU's, each with its own best filter (the filter's parameters profiled out)
    double family_p = 1.0;
    bool delay_is_lag = false;    ///< the rule does not take it: the model's delay is the IMU's plus the lag
    std::string reason;           ///< the rule's reason when it does not take it
  } delay;
};

/// One line for the text summary ("" when not tested).
std::string dynamicsLine(const DynamicsCheck& d, const Vec6& noise_floor);
/// The delay against the filter's lag in words ("" when not tested).
std::string delayAgainstLagLine(const DynamicsCheck& d);

}  // namespace ftid::lab
