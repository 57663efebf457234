// internal::ScaledQR (src/identify/linear_algebra.hpp) and identify::solveGram: each identity they
// document, checked against
// an independent formulation (a full SVD of the original matrix, or of the updated matrix formed
// explicitly), on seeded random matrices with badly scaled columns.
#include <gtest/gtest.h>

#include <random>

#include "linear_algebra.hpp"
#include "ftid/identify/normal_equations.hpp"

namespace ftid::identify::internal {
namespace {

/// Tall random matrix whose columns span several orders of magnitude (as in the regressors).
Eigen::MatrixXd randomTall(int rows, int cols, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> nd(0.0, 1.0);
  Eigen::MatrixXd A(rows, cols);
  for (int j = 0; j < cols; ++j) {
    const double scale = std::pow(10.0, (j % 4) - 1.5);
    for (int i = 0; i < rows; ++i) A(i, j) = scale * nd(rng);
  }
  return A;
}

Eigen::VectorXd randomVector(int rows, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> nd(0.0, 1.0);
  Eigen::VectorXd y(rows);
  for (int i = 0; i < rows; ++i) y(i) = nd(rng);
  return y;
}

double relDiff(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) { return (a - b).norm() / b.norm(); }

TEST(ScaledQR, ConditionNumberIsThatOfTheColumnScaledMatrix) {
  const Eigen::MatrixXd A = randomTall(300, 7, 1);
  const Eigen::VectorXd norms = A.colwise().norm().transpose();
  const Eigen::MatrixXd scaled = A * norms.cwiseInverse().asDiagonal();
  const Eigen::VectorXd s = Eigen::JacobiSVD<Eigen::MatrixXd>(scaled).singularValues();
  Eigen::MatrixXd work = A;
  const ScaledQR qr(work, 1e-9);
  EXPECT_EQ(qr.rank().rank, 7);
  EXPECT_NEAR(qr.rank().condition_number, s(0) / s(6), 1e-12 * s(0) / s(6));
  EXPECT_LT(relDiff(qr.rank().column_norms, norms), 1e-15);
  EXPECT_TRUE(qr.rank().unexcited_columns.empty());
}

TEST(ScaledQR, ConditionNumberAndRankMatchTheSvdFromWellToIllConditioned) {
  // Well-conditioned matrices take the eigenvalue route (condition number below 1e4), the others
  // the SVD: either way the condition number of the column-scaled matrix within the eigenvalue
  // route's documented bound (2e-7 relative for 16 columns) and the rank of the SVD's count,
  // across the boundary.
  std::mt19937_64 rng(11);
  std::normal_distribution<double> nd(0.0, 1.0);
  for (const double target : {1.0, 30.0, 900.0, 8e3, 1.2e4, 1e6, 1e11}) {
    SCOPED_TRACE(target);
    const int rows = 80;
    const int cols = 16;
    Eigen::MatrixXd G(rows, cols), H(cols, cols);
    for (int i = 0; i < rows; ++i) {
      for (int j = 0; j < cols; ++j) G(i, j) = nd(rng);
    }
    for (int i = 0; i < cols; ++i) {
      for (int j = 0; j < cols; ++j) H(i, j) = nd(rng);
    }
    // Orthonormal U (rows x cols) and V from the singular vectors of the random matrices.
    const Eigen::JacobiSVD<Eigen::MatrixXd> su(G, Eigen::ComputeThinU);
    const Eigen::JacobiSVD<Eigen::MatrixXd> sh(H, Eigen::ComputeFullU);
    const Eigen::MatrixXd U = su.matrixU();
    const Eigen::MatrixXd V = sh.matrixU();
    Eigen::VectorXd s(cols);
    for (int k = 0; k < cols; ++k) s(k) = std::pow(target, -static_cast<double>(k) / (cols - 1));
    const Eigen::MatrixXd A = U * s.asDiagonal() * V.transpose();
    const Eigen::VectorXd norms = A.colwise().norm().transpose();
    const Eigen::MatrixXd scaled = A * norms.cwiseInverse().asDiagonal();
    const Eigen::VectorXd sv = Eigen::JacobiSVD<Eigen::MatrixXd>(scaled).singularValues();
    const double expected = sv.maxCoeff() / sv.minCoeff();
    const int expected_rank = static_cast<int>((sv.array() > 1e-9 * sv.maxCoeff()).count());
    Eigen::MatrixXd work = A;
    const ScaledQR qr(work, 1e-9);
    EXPECT_EQ(qr.rank().rank, expected_rank);
    if (expected_rank == cols) {
      EXPECT_NEAR(qr.rank().condition_number, expected, 2e-7 * expected);
    }
    const RankReport r = analyzeRank(A, 1e-9);
    EXPECT_EQ(r.rank, expected_rank);
    if (expected_rank == cols) {
      EXPECT_NEAR(r.condition_number, expected, 2e-7 * expected);
    }
  }
}

TEST(ScaledQR, SolutionAndInverseGramMatchTheSvdOfA) {
  const Eigen::MatrixXd A = randomTall(300, 6, 2);
  const Eigen::VectorXd y = randomVector(300, 3);
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd x_svd = svd.solve(y);
  const Eigen::MatrixXd V = svd.matrixV();
  const Eigen::VectorXd s = svd.singularValues();
  const Eigen::MatrixXd gram_inv_svd = V * s.cwiseAbs2().cwiseInverse().asDiagonal() * V.transpose();

  Eigen::MatrixXd work = A;
  const ScaledQR qr(work, 1e-9);
  EXPECT_LT(relDiff(qr.solve(y), x_svd), 1e-12);
  EXPECT_LT(relDiff(qr.inverseGram(), gram_inv_svd), 1e-12);
  // The tail of Q^T y carries the residual norm.
  Eigen::VectorXd z = y;
  qr.applyQt(z);
  EXPECT_NEAR(z.tail(300 - 6).norm(), (y - A * x_svd).norm(), 1e-12 * y.norm());
}

TEST(ScaledQR, RankOneUpdateMatchesTheUpdatedMatrix) {
  // (J^T J)^{-1} for J = A - u v^T from A's factorisation equals that of J factored on its own.
  const Eigen::MatrixXd A = randomTall(200, 6, 4);
  const Eigen::VectorXd u = randomVector(200, 5);
  Eigen::VectorXd v = randomVector(6, 6);
  v.tail(3).setZero();  // as in the paper's force stage: only the gravity-vector columns change
  const Eigen::MatrixXd J = A - u * v.transpose();
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(J, Eigen::ComputeThinV);
  const Eigen::MatrixXd expected = svd.matrixV() * svd.singularValues().cwiseAbs2().cwiseInverse().asDiagonal() *
                                   svd.matrixV().transpose();
  Eigen::MatrixXd work = A;
  const ScaledQR qr(work, 1e-9);
  Eigen::VectorXd qt_u = u;
  qr.applyQt(qt_u);
  EXPECT_LT(relDiff(qr.inverseGramRankOneUpdate(qt_u, v), expected), 1e-11);
}

TEST(ScaledQR, RankDeficiencyNamesTheColumnsOfTheNullSpace) {
  Eigen::MatrixXd A = randomTall(100, 5, 7);
  A.col(3) = A.col(1) + 10.0 * A.col(4);  // null space spans columns 1, 3, 4 (comparable scaled weights)
  A.col(2).setZero();                           // a zero column is always named
  Eigen::MatrixXd work = A;
  const ScaledQR qr(work, 1e-9);
  EXPECT_EQ(qr.rank().rank, 3);
  EXPECT_EQ(qr.rank().unexcited_columns, (std::vector<int>{1, 2, 3, 4}));
  // Same report as the unpivoted analysis.
  const RankReport plain = analyzeRank(A, 1e-9);
  EXPECT_EQ(plain.rank, 3);
  EXPECT_EQ(plain.unexcited_columns, qr.rank().unexcited_columns);
}

// identify::solveGram (ftid/identify/normal_equations.hpp) against the SVD pseudo-inverse of the
// regressor itself: full rank (solution, inverse, condition number of the column-scaled matrix)
// and rank deficient (minimum-norm solution in scaled coordinates, null space).
TEST(SolveGram, MatchesTheSvdOfTheRegressor) {
  const Eigen::MatrixXd A = randomTall(200, 6, 21);
  const Eigen::VectorXd y = randomVector(200, 22);
  const GramSolution g = solveGram(A.transpose() * A, A.transpose() * y, true);
  EXPECT_EQ(g.rank, 6);
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeThinU | Eigen::ComputeThinV);
  EXPECT_LT(relDiff(g.x, svd.solve(y)), 1e-10);
  EXPECT_LT(relDiff(g.inverse, (A.transpose() * A).inverse()), 1e-9);
  const Eigen::VectorXd d = A.colwise().norm().transpose().cwiseInverse();
  const Eigen::JacobiSVD<Eigen::MatrixXd> scaled(A * d.asDiagonal());
  const Eigen::VectorXd s = scaled.singularValues();
  EXPECT_NEAR(g.condition, s(0) / s(s.size() - 1), 1e-6 * g.condition);
  EXPECT_EQ(g.null_space.cols(), 0);
}

TEST(SolveGram, RankDeficientGivesTheScaledMinimumNormSolution) {
  Eigen::MatrixXd A = randomTall(150, 5, 23);
  A.col(4) = 3.0 * A.col(2);  // one direction not determined
  const Eigen::VectorXd y = randomVector(150, 24);
  const GramSolution g = solveGram(A.transpose() * A, A.transpose() * y, true);
  EXPECT_EQ(g.rank, 4);
  ASSERT_EQ(g.null_space.cols(), 1);
  // Column-scaled coordinates: x = D z with z the minimum-norm solution of (A D) z = y.
  const Eigen::VectorXd d = A.colwise().norm().transpose().cwiseInverse();
  const Eigen::MatrixXd As = A * d.asDiagonal();
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(As, Eigen::ComputeThinU | Eigen::ComputeThinV);
  svd.setThreshold(1e-9);
  const Eigen::VectorXd x = d.asDiagonal() * svd.solve(y);
  EXPECT_LT(relDiff(g.x, x), 1e-8);
  // The null-space direction: A D v = 0, between columns 2 and 4 only.
  EXPECT_LT((As * g.null_space.col(0)).norm(), 1e-8);
  EXPECT_LT(std::abs(g.null_space(0, 0)) + std::abs(g.null_space(1, 0)) + std::abs(g.null_space(3, 0)), 1e-8);
}

}  // namespace
}  // namespace ftid::identify::internal
