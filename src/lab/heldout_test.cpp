// The held-out test of the laboratory's one rule (lab_internal.hpp, heldOutNullWeights; docs/analyze.md,
// "The verdict: one rule").
#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Dense>

#include "ftid/identify/normal_equations.hpp"
#include "lab_internal.hpp"

namespace ftid::lab::detail {

namespace {

Eigen::MatrixXd pseudoInverse(const Eigen::MatrixXd& G) {
  return identify::solveGram(G, Eigen::VectorXd::Zero(G.rows()), true).inverse;
}

Eigen::MatrixXd select(const Eigen::MatrixXd& G, const std::vector<int>& s) {
  const auto n = static_cast<Eigen::Index>(s.size());
  Eigen::MatrixXd out(n, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index j = 0; j < n; ++j) out(i, j) = G(s[static_cast<std::size_t>(i)], s[static_cast<std::size_t>(j)]);
  }
  return out;
}

/// Symmetric square root of a positive semi-definite matrix (negative rounding clipped to 0).
Eigen::MatrixXd psdSqrt(const Eigen::MatrixXd& G) {
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(0.5 * (G + G.transpose()));
  const Eigen::VectorXd root = eig.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  return eig.eigenvectors() * root.asDiagonal() * eig.eigenvectors().transpose();
}

}  // namespace

std::vector<double> heldOutNullWeights(const Engine& eng, const Engine::Design& Z, const std::vector<int>& simple_cols) {
  const Dataset& data = eng.data();
  const int p = static_cast<int>(Z.cols()) - 1;
  const int p0 = static_cast<int>(simple_cols.size());
  const int nb = static_cast<int>(data.blocks.size());
  const auto grams = eng.core().runGrams(Z);
  std::vector<Eigen::MatrixXd> Gb(static_cast<std::size_t>(nb));
  for (int b = 0; b < nb; ++b) {
    Eigen::MatrixXd g = Eigen::MatrixXd::Zero(p, p);
    for (const auto& ga : grams[static_cast<std::size_t>(b)]) g += ga.topLeftCorner(p, p);
    Gb[static_cast<std::size_t>(b)] = std::move(g);
  }
  // u_b = Z_b^T e_b, stacked: U (nb p). Selection of the simpler model's columns.
  Eigen::MatrixXd sel = Eigen::MatrixXd::Zero(p0, p);
  for (int k = 0; k < p0; ++k) sel(k, simple_cols[static_cast<std::size_t>(k)]) = 1.0;
  const int dim = nb * p;
  Eigen::MatrixXd W = Eigen::MatrixXd::Zero(dim, dim);
  for (int f = 0; f < data.foldCount(); ++f) {
    const int h = data.testBlock(f);
    Eigen::MatrixXd GT = Eigen::MatrixXd::Zero(p, p);
    for (int b = 0; b < nb; ++b) {
      if (data.trains(f, b)) GT += Gb[static_cast<std::size_t>(b)];
    }
    const Eigen::MatrixXd train_inv = pseudoInverse(GT);
    const Eigen::MatrixXd simple_inv = pseudoInverse(select(GT, simple_cols));
    // c_f = C U (the richer fold fit), b_f = P U (the simpler one), u_h = E U.
    Eigen::MatrixXd C = Eigen::MatrixXd::Zero(p, dim), P = Eigen::MatrixXd::Zero(p0, dim), E = Eigen::MatrixXd::Zero(p, dim);
    for (int b = 0; b < nb; ++b) {
      if (!data.trains(f, b)) continue;
      C.middleCols(b * p, p) = train_inv;
      P.middleCols(b * p, p) = simple_inv * sel;
    }
    E.middleCols(h * p, p).setIdentity();
    const Eigen::MatrixXd& Gh = Gb[static_cast<std::size_t>(h)];
    const Eigen::MatrixXd ES = sel * E;
    // SSE_h(simple) - SSE_h(rich) = -2 u_hS' b + b' G_hSS b + 2 u_h' c - c' G_h c (e_h' e_h cancels).
    const Eigen::MatrixXd Wf = -2.0 * ES.transpose() * P + P.transpose() * (sel * Gh * sel.transpose()) * P +
                               2.0 * E.transpose() * C - C.transpose() * Gh * C;
    W += 0.5 * (Wf + Wf.transpose());
  }
  // U ~ N(0, sigma^2 blockdiag(G_b)): with U = sigma D^(1/2) z, Delta / sigma^2 = z' D^(1/2) W D^(1/2) z.
  Eigen::MatrixXd Dh = Eigen::MatrixXd::Zero(dim, dim);
  for (int b = 0; b < nb; ++b) Dh.block(b * p, b * p, p, p) = psdSqrt(Gb[static_cast<std::size_t>(b)]);
  const Eigen::MatrixXd M = Dh * W * Dh;
  const Eigen::VectorXd lambda = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(0.5 * (M + M.transpose()), Eigen::EigenvaluesOnly).eigenvalues();
  std::vector<double> all(lambda.data(), lambda.data() + lambda.size());
  double scale = 0.0;
  for (double l : all) scale = std::max(scale, std::abs(l));
  std::vector<double> kept;
  for (double l : all) {
    if (std::abs(l) > 1e-10 * scale) kept.push_back(l);
  }
  return kept;
}

double heldOutPValue(const RankContext& rc, const Engine::Design& simple, const Engine::Design& rich,
                     const FitView& rich_view, double simple_sse_heldout, const Solution& rich_sol) {
  // The null's design: the simpler model's own columns, then the columns the richer one adds (its
  // effects may also add terms to the simpler model's columns, and its nonlinear parameters may sit
  // at another linearisation: the law is that of adding E's new columns to M's design).
  const Eigen::Index p0 = simple.cols() - 1;
  std::vector<Eigen::Index> added;
  for (std::size_t k = 0; k < rich_view.added.size() && static_cast<Eigen::Index>(k) + 1 < rich.cols(); ++k) {
    if (rich_view.added[k]) added.push_back(static_cast<Eigen::Index>(k));
  }
  Engine::Design Z(simple.rows(), p0 + static_cast<Eigen::Index>(added.size()) + 1);
  Z.leftCols(p0) = simple.leftCols(p0);
  for (std::size_t k = 0; k < added.size(); ++k) Z.col(p0 + static_cast<Eigen::Index>(k)) = rich.col(added[k]);
  Z.col(Z.cols() - 1) = simple.col(p0);
  std::vector<int> simple_cols(static_cast<std::size_t>(p0));
  for (Eigen::Index k = 0; k < p0; ++k) simple_cols[static_cast<std::size_t>(k)] = static_cast<int>(k);
  const double gain = (simple_sse_heldout - rich_sol.sse_heldout) / std::max(rich_sol.sigma2, 1e-300);
  return weightedChiSquareSurvivalUncertainScale(heldOutNullWeights(rc.eng, Z, simple_cols), gain, rc.scale_sd);
}

}  // namespace ftid::lab::detail
