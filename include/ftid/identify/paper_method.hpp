#pragma once
// The paper's identification (Duan et al. 2022), derived from first principles
// (docs/identification.md; deviations from the paper: docs/conventions.md):
//
//  torque stage (Eq. 5-9):   t_i = -skew(f_i) c + k,   k = T0 - c x F0        unknowns c, k
//  force stage  (Eq. 14-20): f_i = R_BS,i^T L + F0                           unknowns L = m g_B, F0
//     dynamic (Eq. 31-38):   f_i + (G/g) a_S,i = R_BS,i^T L + F0, G = |L| from the previous
//                            iterate (fixed point started from the static solution)
//  then G = |L|, m = G/g, U = asin(-L_y/G), V = atan2(L_x, -L_z), T0 = k + c x F0 (Eq. 21-23).
// Both stages are stacked least-squares problems (3N rows, 6 unknowns) solved with Householder QR.
// Each is first compressed exactly (thin QR of the per-sample data: same solution, residual norm,
// singular values) and then factored once (column-scaled, column-pivoted QR); that one
// factorisation gives the rank check, every fixed-point solve, the condition number and the
// bread of the covariance (docs/identification.md, "Computation"). The covariance of [L, F0, c, k]
// is one Newey-West sandwich over both stages (uncertainty.hpp: holds for autocorrelated noise and
// includes the coupling of the stages); standard errors by the delta method through the transforms.
#include <string>
#include <vector>

#include "ftid/effects/effect.hpp"
#include "ftid/identify/fit_parameters.hpp"

namespace ftid::identify {

enum class PaperMethod {
  kStatic,   ///< Eq. 5-23: gravity only (rest poses or slow motion)
  kDynamic,  ///< Eq. 31-42: with the inertial term -m a_S
};

const char* toString(PaperMethod method);

struct PaperOptions {
  PaperMethod method = PaperMethod::kDynamic;
  int max_iterations = 200;       ///< dynamic fixed-point iterations on G
  double tolerance = 1e-15;       ///< relative change of G that ends the iteration
  double rank_tolerance = 1e-9;   ///< relative singular-value threshold (column-scaled regressors)
};

struct PaperResult {
  PaperMethod method = PaperMethod::kDynamic;
  double weight_N = 0.0;          ///< G
  double mass_kg = 0.0;           ///< G / g
  double tilt_u_rad = 0.0;
  double tilt_v_rad = 0.0;
  Vec3 com_S = Vec3::Zero();      ///< c [m]
  Vec3 f0_S = Vec3::Zero();       ///< F0 [N]
  Vec3 t0_S = Vec3::Zero();       ///< T0 [Nm]
  Vec3 gravity_force_B = Vec3::Zero();  ///< L = m g_B [N]
  Vec3 k = Vec3::Zero();          ///< k = T0 - c x F0 [Nm]
  /// Standard errors, same names as ParameterSet: mass, weight, com_*, f0_*, t0_*, tilt_*.
  std::vector<NamedValue> params;
  Eigen::Matrix<double, 6, Eigen::Dynamic> residual;  ///< reading - modelled wrench (6 x N)
  Vec6 residual_rms = Vec6::Zero();
  double condition_force = 0.0;   ///< column-scaled condition number of the force stage
  double condition_torque = 0.0;  ///< ... of the torque stage
  int iterations = 0;             ///< dynamic fixed-point iterations used
  /// Variance of the standard errors against the classical sigma^2 (A^T A)^-1 per stage, averaged
  /// over [L, F0, c, k] (about 1 for white noise; 4 for noise with lag-1 correlation 0.6).
  double variance_inflation = 1.0;
  int n_samples = 0;

  /// Parameter set in the names of the "paper" model (mass, mass_com_*, f0_*, t0_*, tilt).
  ParameterSet toParameterSet() const;
};

/// Runs the paper's method on the contexts (R_BS, a_S, wrench_S are used; g_S is not).
/// Throws IdentificationError naming the parameters that the data cannot determine.
PaperResult identifyPaper(const std::vector<effects::SampleContext>& contexts,
                          const PaperOptions& options = {});

/// Gravity vector L = m g_B (Eq. 15 corrected) -> G, U, V (Eq. 22-23).
void gravityToWeightAndTilt(const Vec3& L, double* weight_N, double* tilt_u_rad, double* tilt_v_rad);

}  // namespace ftid::identify
