#pragma once
// The laboratory's search for sensor and mount dynamics on its last model (ftid/lab/dynamics.hpp).
// Private to ftid_lab.
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
DynamicsCheck checkDynamics(const RankContext& rc, const Fitted& last, double motion_band_hz, bool spectral_peak);

}  // namespace ftid::lab::detail
