#pragma once
// The steps of fitModel (private to ftid_identify; docs/identification.md), in the order it runs
// them, with the state they pass on in one FitState:
//   fit.cpp             set-up and checks of the data, the compressed tilt search's data
//                       (gravity_compression.hpp), the start and its rank check, the result
//   fit_search.cpp      the nonlinear search: variable projection (the linear solve at each phi)
//                       with Levenberg-damped Gauss-Newton on phi, the delay's start and window,
//                       the axis weights, the Gauss-Newton passes of the modelled-wrench effects
//   fit_statistics.cpp  at the optimum: the joint Jacobian, its rank, the condition number, the
//                       Newey-West covariance and the residual
// The fast path (compressed tilt search) and the general path share every step; where they
// differ, a step branches on FitState::compressed, and the two give the same numbers
// (test/unit/identify, CompressedTilt.*).
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "fit_problem.hpp"
#include "gravity_compression.hpp"
#include "ftid/identify/fit.hpp"

namespace ftid::identify::internal {

/// One fitModel call's state.
struct FitState {
  FitState(const Model& m, const std::vector<SampleContext>& c, const std::vector<int>& idx, const FitOptions& o)
      : model(m), contexts(c), indices(idx), options(o), pb(m, c, idx), L(m) {}

  const Model& model;
  const std::vector<SampleContext>& contexts;
  const std::vector<int>& indices;
  const FitOptions& options;
  Problem pb;
  const PhiLayout L;
  bool estimate_tilt = false;
  bool tilt_given = false;      ///< options fix the tilt
  int n_unknowns = 0;           ///< theta's and phi's
  bool try_compressed = false;  ///< a tilt-only model with FitOptions::compressed_tilt_search
  bool compressed = false;      ///< the compressed tilt search runs (gc holds the data)
  GravityCompression gc;
  Mat6X measured;               ///< the measured wrench, 6 x n (the general path's)
  PhiState st;
  std::vector<std::string> names;  ///< theta's
  Vec6 weights = Vec6::Ones();     ///< per-axis weights of the rows
  LinearSolution sol;              ///< at the current phi
  double delay_lo = -1e300;        ///< the delay's window (the active samples' range)
  double delay_hi = 1e300;
  double dt_mean = 0.0;            ///< mean sample spacing [s]

  const GravityCompression* gcp() const { return compressed ? &gc : nullptr; }
};

/// The nonlinear search from the start in f.st (fit_search.cpp): leaves phi in f.st, theta and
/// the weighted residual in f.sol, the axis weights in f.weights.
void searchNonlinear(FitState& f);

/// The statistics at the optimum (fit_statistics.cpp): the rank check of the joint Jacobian
/// (throws IdentificationError naming the columns it lacks), condition number, sigma^2,
/// covariance and standard deviations, and the unweighted residual, into *res.
void statisticsAtOptimum(FitState& f, FitResult* res);

}  // namespace ftid::identify::internal
