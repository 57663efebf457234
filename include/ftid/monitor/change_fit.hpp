#pragma once
// Re-identification of a payload change from recorded monitor samples (ftidd's REIDENTIFY,
// docs/daemon.md "Re-identification"): a weighted least-squares fit of the change delta = [dm,
// d(m c), dI_S] on the rigid-body regressor (the payload monitor's, effects gravity +
// linear_inertia + rigid_body) to the compensated residuals, weights 1 / noise_std^2 per axis,
// with the monitor's prior as a weak regulariser for directions the motion does not excite.
// The new payload is the old one plus the change; offsets, tilt and the other effects stay.
//
// Validation (every failure gives its reason, nothing is loaded):
//   motion      at least min_free_fraction of the samples in free motion (payload_monitor.hpp)
//   precision   std(dm) <= max_mass_std_kg
//   residual    after the fit, the RMS of every axis <= max_residual_ratio x noise_std (a
//               contact or an unmodelled effect in the window does not fit)
//   physics     new mass > 0; the new inertia about its centre of mass positive definite and
//               within the triangle inequalities (3 standard errors of slack), when the model has
//               inertia parameters
#include <string>
#include <vector>

#include "ftid/monitor/payload_monitor.hpp"

namespace ftid::monitor {

struct ChangeFitOptions {
  double min_free_fraction = 0.5;
  double max_mass_std_kg = 0.05;
  double max_residual_ratio = 2.0;
};

struct ChangeFit {
  bool ok = false;
  std::string reason;                 ///< why not (empty when ok)
  int samples = 0;
  int free_samples = 0;
  ChangeEstimate change;              ///< the fitted change and its covariance
  Vec6 residual_rms_before = Vec6::Zero();
  Vec6 residual_rms_after = Vec6::Zero();
  /// The payload after the change: [m, m c (3), I_S (6)] = before + delta.
  ChangeVector payload_after = ChangeVector::Zero();
  bool inertia_checked = false;       ///< the physics check included the inertia
};

/// Fits the change over `samples` (in time order) on top of `payload_before` = [m, m c, I_S] (NaN
/// entries for the inertia when the parameter set has none: the inertia change is then not
/// checked). Never throws; an empty input is refused with a reason.
ChangeFit fitChange(const std::vector<MonitorSample>& samples, const ChangeVector& payload_before,
                    const MonitorSettings& settings, const ChangeFitOptions& options = {});

}  // namespace ftid::monitor
