#pragma once
// The fitting engine of the model laboratory (private to ftid_lab).
//
// All fits are weighted linear least squares on the stacked regressor, rows scaled by the axis
// weights 1 / noise floor. The data are cut into blocks; the normal matrices of the blocks are
// formed once per design, so the fit of every fold is a sum of block matrices and costs P^3, not
// N P^2 (10 s at 1 kHz: 60,000 rows). Solves are identify::solveGram (ftid/identify/normal_equations.hpp):
// the column-equilibrated normal matrix with an eigen-decomposition (pseudo-inverse: directions
// below 1e-12 of the largest eigenvalue, i.e. a condition number of 1e6 of the scaled regressor,
// count as not determined).
//
// The stacking (prewhitening, exclusions), the nonlinear parameters (tilt, mounting, delay) and
// the signals derived from the modelled wrench are identify's fitting core
// (identify::NonlinearFit, ftid/identify/nonlinear_fit.hpp): fitFully() runs its Gauss-Newton and
// then the folds, which re-fit every linear parameter plus a first-order correction of the
// nonlinear ones, holding the linearisation point of the full fit.
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "ftid/effects/model.hpp"
#include "ftid/identify/nonlinear_fit.hpp"
#include "ftid/lab/analyze.hpp"

namespace ftid::lab::detail {

using identify::Mat6X;

struct Block {
  int begin = 0;   ///< first sample
  int end = 0;     ///< one past the last
  bool fit = true; ///< part of the fitting data (false: external validation log)
};

struct Dataset {
  std::vector<SampleContext> ctx;  ///< fitting samples, then validation samples
  int n_fit = 0;
  std::vector<Block> blocks;       ///< k-fold: the folds; external: [fit, validate]
  bool external = false;
  Vec6 weights = Vec6::Ones();     ///< 1 / innovation std of the noise (= 1 / noise floor if white)
  Vec6 ar1 = Vec6::Zero();         ///< lag-1 noise correlation per axis: rows are prewhitened
                                   ///< x_i - phi x_{i-1} along time inside each block (first row
                                   ///< of a block scaled by sqrt(1 - phi^2), Prais-Winsten)
  std::vector<char> excluded;      ///< per sample: a glitch, left out of every fit and sum
  bool static_data = false;        ///< a static pose set (the robot at rest in every sample)
  std::vector<int> segment_start;  ///< sample index where a log starts (for time derivatives)
  double max_delay_s = 1.0;        ///< delay search range of `sensor_delay` [s]

  int size() const { return static_cast<int>(ctx.size()); }
  /// Test block of fold f, and whether block b is in the training set of fold f.
  int foldCount() const { return external ? 1 : static_cast<int>(blocks.size()); }
  int testBlock(int f) const { return external ? 1 : f; }
  bool trains(int f, int b) const {
    return blocks[static_cast<std::size_t>(b)].fit && (external || b != f);
  }
};

/// The linearisation point (identify's fitting core, ftid/identify/nonlinear_fit.hpp).
using identify::Linearization;

/// Result of solving one design on the blocks.
struct Solution {
  int p = 0;                    ///< columns (parameters + tilt columns)
  int rank = 0;
  Eigen::VectorXd theta;        ///< full-data (all fit blocks) solution
  Eigen::MatrixXd covariance;   ///< sigma^2 (X^T W X)^+ of the full-data solution (weighted)
  /// Directions the data do not determine (rank < p): unit columns over the parameters in
  /// column-scaled coordinates (entries show which parameters enter only in that combination).
  Eigen::MatrixXd null_space;
  double sse_fit = 0.0;         ///< weighted in-sample SSE of the full-data fit
  double sigma2 = 0.0;
  int rows_fit = 0;
  double condition_number = 0.0;
  Vec6 sse_fit_axis = Vec6::Zero();  ///< unweighted, per axis
  Mat6X heldout_residual;       ///< N / Nm, test samples in order of the test blocks (with raw)
  double sse_heldout = 0.0;     ///< weighted
  Vec6 sse_heldout_axis = Vec6::Zero();  ///< unweighted
  int n_heldout = 0;            ///< test samples not excluded
};

/// The lab's folds and held-out sums over identify's fitting core (identify::NonlinearFit: the
/// stacking, the nonlinear parameters, the derived signals). The core's filter runs are the blocks.
class Engine {
 public:
  explicit Engine(Dataset data);
  const Dataset& data() const { return data_; }
  const identify::NonlinearFit& core() const { return core_; }

  /// Weighted regressor of the model at the linearisation (plus the Jacobian columns lin asks for)
  /// with the weighted measurement as its last column, prewhitened, excluded samples' rows zero.
  /// Row-major; rows ordered block by block, inside a block axis by axis, so every (block, axis)
  /// is a contiguous row range (identify::NonlinearFit::rowOf).
  using Design = identify::NonlinearFit::Design;
  Design design(const effects::Model& model, const Linearization& lin) const { return core_.design(model, lin); }
  /// Same without prewhitening and exclusions (for the reported residual series).
  Design rawDesign(const effects::Model& model, const Linearization& lin) const {
    return core_.rawDesign(model, lin);
  }
  /// with_folds = false skips the held-out part; with `raw` (rawDesign of the same model) fills
  /// Solution::heldout_residual in N / Nm and takes the per-axis held-out sums from it (needed only
  /// for the reported model). Without it the per-axis sums are the whitened ones scaled by
  /// 1 / (1 - phi^2) (the marginal scale of AR(1) noise).
  Solution solve(const Design& X, bool with_folds = true, const Design* raw = nullptr) const;
  /// Contexts with g_S and the derived signals of the linearisation filled in.
  std::vector<SampleContext> prepared(const Linearization& lin) const { return core_.prepared(lin); }
  /// Design of `cand` = `base` + more effects, from the base design (identify::NonlinearFit::designExtended).
  Design designExtended(const effects::Model& base, const Design& base_design, const effects::Model& cand,
                        const Linearization& lin, const std::vector<SampleContext>& prepared_ctx) const {
    return core_.designExtended(base, base_design, cand, lin, prepared_ctx);
  }

  /// Full nonlinear fit (identify::NonlinearFit::fit) from `start`, then the folds at the
  /// converged linearisation. Returns that linearisation (Jacobian columns of the model's nonlinear
  /// parameters at the fitted theta, derived signals) and its solution.
  std::pair<Linearization, Solution> fitFully(const effects::Model& model, const Linearization& start) const;
  /// Initial linearisation (identify::NonlinearFit::initial).
  Linearization initial(const effects::Model& model) const { return core_.initial(model); }

  /// Modelled wrench (unweighted, 6 x N) of theta (first P entries) at the linearisation.
  Mat6X predict(const effects::Model& model, const Linearization& lin, const Eigen::VectorXd& theta,
                bool exclude_derived) const {
    return core_.predict(model, lin, theta, exclude_derived);
  }
  /// Jacobian columns of the nonlinear parameters at the linearisation (identify::NonlinearFit).
  void tiltColumns(const effects::Model& model, Linearization& lin, const Eigen::VectorXd& theta) const {
    core_.tiltColumns(model, lin, theta);
  }
  void mountColumns(const effects::Model& model, Linearization& lin, const Eigen::VectorXd& theta) const {
    core_.mountColumns(model, lin, theta);
  }
  void delayColumn(const effects::Model& model, Linearization& lin, const Eigen::VectorXd& theta) const {
    core_.delayColumn(model, lin, theta);
  }

  /// Indices of the evaluated (test) samples in order.
  const std::vector<int>& testSamples() const { return test_samples_; }
  bool excluded(int i) const {
    return !data_.excluded.empty() && data_.excluded[static_cast<std::size_t>(i)] != 0;
  }

 private:
  Dataset data_;
  identify::NonlinearFit core_;
  std::vector<int> test_samples_;
};

}  // namespace ftid::lab::detail
