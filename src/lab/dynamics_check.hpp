#pragma once
// The laboratory's search for sensor and mount dynamics on its last model (ftid/lab/dynamics.hpp).
// Private to ftid_lab.
#include "ftid/identify/offline.hpp"
#include "ftid/lab/dynamics.hpp"
#include "lab_internal.hpp"

namespace ftid::lab::detail {

/// Filters the regressor and Jacobian columns of `last`'s raw design through each filter of a
/// grid (mount: 12 f_n log-spaced from max(0.5 Hz, half the motion band) to 0.4 x the sample rate,
/// zeta 0.05, 0.15, 0.4, 1; filter: the same 12 f_c), re-solves, refines the best (golden sections
/// in log f_n, zeta, log f_n between the neighbouring grid points), takes the better of the two
/// kinds, solves it with the folds and judges it: the held-out error
/// falls by more than options.search_heldout_margin (1 %) and min(1, grid x p) < family_alpha, p the chi-square
/// tail of the in-sample gain (2 dof for the mount, 1 for the filter). Searched only when the last
/// model leaves something (spectral_peak: a significant peak on some axis; or a held-out residual
/// above 1.2x the noise floor on some axis) unless options.always_search_dynamics.
/// `seed` (optional): a filter of the same kind that starts the refinement where it fits better than
/// the grid, and is kept where the refinement ends worse than it.
DynamicsCheck checkDynamics(const RankContext& rc, const Fitted& last, double motion_band_hz, bool spectral_peak,
                            const DynamicsCheck* seed = nullptr);

/// With `d` (checkDynamics on `last`: the joint search of the filter and the delay) significant and
/// `last` fitting sensor_delay: the wrench's own delay through d's filter (Gauss-Newton from the
/// model's delay minus the filter's lag), and, with the IMU's stream delay (`imu` used, its delay
/// estimated), the model with its delay held at the IMU's and the filter searched again against the
/// joint fit, judged by the laboratory's one rule (decide; p the chi-square(1) tail of the in-sample
/// gain, as for the dynamics; the analysis's family m). Not taken: the model's delay is the IMU's
/// plus the filter's lag. Fills d->delay.
void judgeDelayAgainstLag(const RankContext& rc, const Fitted& last, const identify::ImuReport& imu,
                          double motion_band_hz, DynamicsCheck* d);

}  // namespace ftid::lab::detail
