// The fitting engine of the model laboratory (engine.hpp).
#include "engine.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "ftid/identify/normal_equations.hpp"

namespace ftid::lab::detail {

namespace {

/// The core's data treatment of a dataset: the blocks are the filter runs, the glitches' rows are
/// left out of the prewhitened fits.
identify::DataTreatment treatmentOf(const Dataset& d) {
  identify::DataTreatment t;
  t.axis_weights = d.weights;
  t.ar1 = d.ar1;
  for (const Block& b : d.blocks) t.filter_start.push_back(b.begin);
  if (!d.excluded.empty()) t.row_weights = identify::exclusionWeights(d.excluded, d.ar1, t.filter_start, d.size());
  t.segment_start = d.segment_start;
  t.n_fit = d.n_fit;
  t.max_delay_s = d.max_delay_s;
  return t;
}

}  // namespace

Engine::Engine(Dataset data) : data_(std::move(data)), core_(data_.ctx, treatmentOf(data_)) {
  for (int f = 0; f < data_.foldCount(); ++f) {
    const Block& b = data_.blocks[static_cast<std::size_t>(data_.testBlock(f))];
    for (int i = b.begin; i < b.end; ++i) test_samples_.push_back(i);
  }
}

namespace {

/// Weighted SSE of theta on a block whose augmented Gram [X y]^T [X y] is G.
double sseFromGram(const Eigen::MatrixXd& G, const Eigen::VectorXd& theta) {
  const Eigen::Index p = theta.size();
  const double v = G(p, p) - 2.0 * theta.dot(G.col(p).head(p)) + theta.dot(G.topLeftCorner(p, p) * theta);
  return std::max(0.0, v);
}

}  // namespace

Solution Engine::solve(const Design& X, bool with_folds, const Design* raw) const {
  const bool with_series = raw != nullptr;
  const int p = static_cast<int>(X.cols()) - 1;
  const std::size_t nb = data_.blocks.size();
  // Augmented Gram of every (block, axis): the core's filter runs are the blocks.
  const std::vector<std::array<Eigen::MatrixXd, 6>> G = core_.runGrams(X);
  std::vector<Eigen::MatrixXd> Gb(nb);
  for (std::size_t b = 0; b < nb; ++b) {
    Gb[b] = Eigen::MatrixXd::Zero(p + 1, p + 1);
    for (int a = 0; a < 6; ++a) Gb[b] += G[b][static_cast<std::size_t>(a)];
  }
  Solution sol;
  sol.p = p;
  Eigen::MatrixXd Gf = Eigen::MatrixXd::Zero(p + 1, p + 1);
  for (std::size_t b = 0; b < nb; ++b) {
    if (data_.blocks[b].fit) Gf += Gb[b];
  }
  const identify::GramSolution full = identify::solveGram(Gf.topLeftCorner(p, p), Gf.col(p).head(p), true);
  sol.theta = full.x;
  sol.rank = full.rank;
  sol.null_space = full.null_space;
  sol.condition_number = full.condition;
  int excluded_fit = 0;
  for (int i = 0; i < data_.n_fit; ++i) excluded_fit += excluded(i) ? 1 : 0;
  sol.rows_fit = 6 * (data_.n_fit - excluded_fit);
  sol.sse_fit = sseFromGram(Gf, sol.theta);
  // Per-axis sums in N^2 / Nm^2: whitened sums / w^2 / (1 - phi^2) (the marginal scale).
  Vec6 to_raw;
  for (int a = 0; a < 6; ++a) {
    to_raw(a) = 1.0 / (data_.weights(a) * data_.weights(a) * std::max(1e-6, 1.0 - data_.ar1(a) * data_.ar1(a)));
  }
  for (std::size_t b = 0; b < nb; ++b) {
    if (!data_.blocks[b].fit) continue;
    for (int a = 0; a < 6; ++a) sol.sse_fit_axis(a) += sseFromGram(G[b][static_cast<std::size_t>(a)], sol.theta) * to_raw(a);
  }
  sol.sigma2 = sol.sse_fit / std::max(1, sol.rows_fit - sol.rank);
  sol.covariance = sol.sigma2 * full.inverse;
  if (!with_folds) return sol;
  sol.n_heldout = 0;
  for (int i : test_samples_) sol.n_heldout += excluded(i) ? 0 : 1;
  if (with_series) sol.heldout_residual.resize(6, static_cast<Eigen::Index>(test_samples_.size()));
  int col = 0;
  for (int f = 0; f < data_.foldCount(); ++f) {
    Eigen::MatrixXd Gt = Eigen::MatrixXd::Zero(p + 1, p + 1);
    for (std::size_t b = 0; b < nb; ++b) {
      if (data_.trains(f, static_cast<int>(b))) Gt += Gb[b];
    }
    const identify::GramSolution fold = identify::solveGram(Gt.topLeftCorner(p, p), Gt.col(p).head(p), false);
    const int tb = data_.testBlock(f);
    const Block& blk = data_.blocks[static_cast<std::size_t>(tb)];
    const int nbk = blk.end - blk.begin;
    for (int a = 0; a < 6; ++a) {
      const double sse = sseFromGram(G[static_cast<std::size_t>(tb)][static_cast<std::size_t>(a)], fold.x);
      sol.sse_heldout += sse;
      sol.sse_heldout_axis(a) += sse * to_raw(a);
      if (with_series) {
        const auto rows = raw->middleRows(6 * blk.begin + a * nbk, nbk);
        const Eigen::VectorXd r = (rows.col(p) - rows.leftCols(p) * fold.x) / data_.weights(a);
        sol.heldout_residual.row(a).segment(col, nbk) = r.transpose();
      }
    }
    col += nbk;
  }
  if (with_series) {
    // Exact per-axis sums from the explicit residual in N / Nm, without the excluded samples.
    sol.sse_heldout_axis.setZero();
    for (std::size_t k = 0; k < test_samples_.size(); ++k) {
      if (!excluded(test_samples_[k])) sol.sse_heldout_axis += sol.heldout_residual.col(static_cast<Eigen::Index>(k)).cwiseAbs2();
    }
    if (data_.ar1.cwiseAbs().maxCoeff() == 0.0) {
      // White: the weighted total from the same sums (the Gram formula loses digits when the fit
      // is near perfect, e.g. noise-free data).
      sol.sse_heldout = sol.sse_heldout_axis.cwiseProduct(data_.weights.cwiseAbs2()).sum();
    }
  }
  return sol;
}

std::pair<Linearization, Solution> Engine::fitFully(const effects::Model& model, const Linearization& start) const {
  Linearization lin = core_.fit(model, start);
  // The folds at the converged linearisation; the derived signals of this model for candidates.
  const Design raw = core_.rawDesign(model, lin);
  Design X = raw;
  core_.whiten(X, 0, static_cast<int>(X.cols()));
  Solution sol = solve(X, true, &raw);
  core_.completeDerived(model, lin, sol.theta);
  return {lin, sol};
}

}  // namespace ftid::lab::detail
