#pragma once
// Parameter covariance that holds when the residuals are correlated in time (low-pass filtered
// sensor streams, slow model error) and under robust (0/1 or IRLS) weights
// (docs/identification.md, "Standard errors").
//
// For the stacked weighted least-squares problem J theta ~ y (rows 6 i + a: sample i, axis a;
// samples in time order), residual r and G = J^T J:
//
//   s_i   = sum_a J_(6i+a)^T r_(6i+a)                     (score of sample i, k-vector)
//   Gamma_l = sum_i s_i s_(i-l)^T
//   Omega = Gamma_0 + sum_{l=1..L} (1 - l/(L+1)) (Gamma_l + Gamma_l^T)      (Newey-West, Bartlett)
//   Cov   = 6n / (6n - k) G^-1 Omega G^-1
//
// with the bandwidth L chosen automatically (Andrews 1991, AR(1) plug-in for the Bartlett kernel,
// from each axis' lag-1 residual correlation rho_a and variance s_a^2):
//
//   alpha = sum_a 4 rho_a^2 s_a^4 / ((1 - rho_a)^6 (1 + rho_a)^2)  /  sum_a s_a^4 / (1 - rho_a)^4
//   L     = floor(1.1447 (alpha n)^(1/3))       (at most n / 4)
//
// For white residuals L is 0 or 1 and Cov equals the classical sigma^2 G^-1 up to sampling noise.
// Robust weights: pass J and r with the rows of each sample multiplied by the square root of its
// weight (an excluded glitch: zero rows); the sandwich then holds for the weighted estimator.
// From 4,096 rows the Newey-West sum runs in two halves, the second on a short-lived thread of its
// own when the caller may use two CPUs (the split depends on the row count alone: the same result
// either way). Not for the real-time loop.
#include <Eigen/Dense>

#include "ftid/common/types.hpp"

namespace ftid::identify {

struct CovarianceReport {
  Eigen::MatrixXd covariance;   ///< k x k
  int lag = 0;                  ///< bandwidth L used (of the prewhitened scores when prewhitened)
  Eigen::VectorXd score_ar1;    ///< prewhitening coefficients a_j per parameter (0: not prewhitened)
  Vec6 residual_ar1 = Vec6::Zero();  ///< lag-1 correlation of the residual per axis
  /// Ratio of the HAC variance to the classical sigma^2 G^-1 variance, averaged over the
  /// parameters (1 for white residuals; > 1 when correlated residuals make the fit less certain).
  double variance_inflation = 1.0;
};

/// J: 6n x k, r: 6n, inverse_gram = (J^T J)^-1. Throws std::invalid_argument on mismatched sizes.
/// max_lag >= 0: plain Newey-West with that L. max_lag < 0 (the default): prewhitened (Andrews and
/// Monahan 1992) per score component j: a_j = the lag-1 regression coefficient of s_.j (clamped to
/// [-0.9, 0.97]), e_i = s_i - a o s_(i-1), Omega_e = Newey-West of e with the bandwidth above
/// computed from e's columns (each standardised), Omega = n/(n-1) D^-1 Omega_e D^-1,
/// D = diag(1 - a_j); fewer than 16 samples: plain Newey-West with the residual's bandwidth.
/// The Bartlett kernel alone underestimates the long-run variance of strongly correlated scores
/// (by 20-35 % in variance at lag-1 correlation 0.6 and n ~ 1000); the filter takes out most of
/// the correlation before the kernel sees it.
CovarianceReport robustCovariance(const Eigen::Ref<const Eigen::MatrixXd>& J, const Eigen::Ref<const Eigen::VectorXd>& r,
                                  const Eigen::MatrixXd& inverse_gram, int max_lag = -1);

/// The same Newey-West sandwich from the per-sample scores, for estimators that are not one
/// stacked least-squares problem (the paper's two stages, a fixed point): scores (n x k, row i =
/// s_i^T, time order), the per-axis residual (6 x n; it sets the bandwidth and the classical
/// comparison) and the inverse bread B^-1 (k x k): B = -d(sum_i s_i)/d theta, which is J^T J for
/// least squares. Cov = 6n / (6n - k) B^-1 Omega B^-T. Throws std::invalid_argument on mismatched
/// sizes. robustCovariance() is this with s_i = sum_a J_(6i+a)^T r_(6i+a) and B^-1 = (J^T J)^-1.
CovarianceReport scoreCovariance(const Eigen::Ref<const Eigen::MatrixXd>& scores,
                                 const Eigen::Ref<const Eigen::Matrix<double, 6, Eigen::Dynamic>>& residual,
                                 const Eigen::MatrixXd& bread_inverse, int max_lag = -1);

/// The automatic bandwidth for per-axis residuals (6 x n, time along columns).
int automaticBandwidth(const Eigen::Ref<const Eigen::Matrix<double, 6, Eigen::Dynamic>>& residual, Vec6* ar1 = nullptr);

}  // namespace ftid::identify
