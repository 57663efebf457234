// scoreCovariance (include/ftid/identify/uncertainty.hpp) against the closed form: for scores that
// are an AR(1) series s_i = rho s_(i-1) + e_i (innovation variance q), the long-run variance of
// their sum is n q / (1 - rho)^2, so with bread 1 the covariance must be about
// 6n/(6n-1) n q / (1 - rho)^2. Also: robustCovariance is scoreCovariance of its own scores, and the
// Newey-West sum (computed as one product of moving sums) equals the lagged-sum formula written out
// here, at every lag up to n - 1 (the ends of the series included).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include "concurrency.hpp"
#include "ftid/identify/uncertainty.hpp"

namespace ftid::identify {
namespace {

Eigen::MatrixXd ar1Scores(int n, double rho, double q, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  Eigen::MatrixXd S(n, 1);
  double x = std::sqrt(q / (1.0 - rho * rho)) * n01(rng);
  for (int i = 0; i < n; ++i) {
    x = rho * x + std::sqrt(q) * n01(rng);
    S(i, 0) = x;
  }
  return S;
}

TEST(ScoreCovariance, LongRunVarianceOfAnAr1ScoreSeries) {
  const int n = 20000;
  const double q = 2.0;
  const Eigen::MatrixXd bread = Eigen::MatrixXd::Identity(1, 1);
  for (const double rho : {0.0, 0.6, 0.9}) {
    SCOPED_TRACE(rho);
    const Eigen::MatrixXd S = ar1Scores(n, rho, q, 77);
    // The residual only sets the classical comparison here (and the fallback bandwidth).
    const Eigen::Matrix<double, 6, Eigen::Dynamic> R = Eigen::Matrix<double, 6, Eigen::Dynamic>::Ones(6, n);
    const CovarianceReport rep = scoreCovariance(S, R, bread);
    const double truth = (6.0 * n / (6.0 * n - 1.0)) * n * q / std::pow(1.0 - rho, 2);
    EXPECT_NEAR(rep.covariance(0, 0) / truth, 1.0, 0.1) << "lag " << rep.lag << " a " << rep.score_ar1(0);
    EXPECT_NEAR(rep.score_ar1(0), rho, 0.03);
    if (rho > 0.0) {
      // Without the correlation (L = 0) the variance is (1 - rho) / (1 + rho) of the truth.
      const CovarianceReport white = scoreCovariance(S, R, bread, 0);
      EXPECT_NEAR(white.covariance(0, 0) / truth, (1.0 - rho) / (1.0 + rho), 0.05);
    }
  }
}

TEST(ScoreCovariance, RobustCovarianceIsTheSandwichOfItsScores) {
  const int n = 300;
  std::mt19937_64 rng(5);
  std::normal_distribution<double> n01(0.0, 1.0);
  Eigen::MatrixXd J(6 * n, 3);
  Eigen::VectorXd r(6 * n);
  for (int i = 0; i < 6 * n; ++i) {
    for (int j = 0; j < 3; ++j) J(i, j) = n01(rng) + (j == 0 ? 1.0 : 0.0);
    r(i) = n01(rng);
  }
  const Eigen::MatrixXd Ginv = (J.transpose() * J).inverse();
  Eigen::MatrixXd S(n, 3);
  for (int i = 0; i < n; ++i) S.row(i) = r.segment<6>(6 * i).transpose() * J.middleRows(6 * i, 6);
  const Eigen::Map<const Eigen::Matrix<double, 6, Eigen::Dynamic>> R(r.data(), 6, n);
  const CovarianceReport a = robustCovariance(J, r, Ginv);
  const CovarianceReport b = scoreCovariance(S, R, Ginv);
  EXPECT_LT((a.covariance - b.covariance).norm(), 1e-12 * b.covariance.norm());
  EXPECT_THROW(scoreCovariance(S.topRows(n - 1), R, Ginv), std::invalid_argument);
}

/// Omega = Gamma_0 + sum_{l=1..L} (1 - l/(L+1)) (Gamma_l + Gamma_l^T), Gamma_l = sum_i s_i s_(i-l)^T,
/// term by term (the textbook formula; uncertainty.cpp computes it from moving sums).
Eigen::MatrixXd laggedSumNeweyWest(const Eigen::MatrixXd& S, int lag) {
  const Eigen::Index n = S.rows();
  Eigen::MatrixXd omega = Eigen::MatrixXd::Zero(S.cols(), S.cols());
  for (int l = 0; l <= lag; ++l) {
    Eigen::MatrixXd gamma = Eigen::MatrixXd::Zero(S.cols(), S.cols());
    for (Eigen::Index i = l; i < n; ++i) gamma += S.row(i).transpose() * S.row(i - l);
    const double w = 1.0 - static_cast<double>(l) / (lag + 1);
    omega += l == 0 ? gamma : Eigen::MatrixXd(w * (gamma + gamma.transpose()));
  }
  return omega;
}

TEST(ScoreCovariance, NeweyWestEqualsTheLaggedSumFormula) {
  // Correlated, non-zero-mean scores with a large first and last row (the edges matter); 600 rows
  // span several of the implementation's blocks of rows, 5,000 its two halves (from 4,096 rows).
  for (const int n : {61, 600, 5000}) {
    std::mt19937_64 rng(11 + static_cast<std::uint64_t>(n));
    std::normal_distribution<double> n01(0.0, 1.0);
    Eigen::MatrixXd S(n, 3);
    Eigen::RowVector3d x = Eigen::RowVector3d::Zero();
    for (int i = 0; i < n; ++i) {
      x = 0.7 * x + Eigen::RowVector3d(n01(rng) + 0.5, n01(rng), 2.0 * n01(rng) - 1.0);
      S.row(i) = x;
    }
    S.row(0) *= 20.0;
    S.row(n - 1) *= -15.0;
    const Eigen::Matrix<double, 6, Eigen::Dynamic> R = Eigen::Matrix<double, 6, Eigen::Dynamic>::Ones(6, n);
    const Eigen::MatrixXd bread = Eigen::MatrixXd::Identity(3, 3);
    const double correction = 6.0 * n / (6.0 * n - 3.0);  // scoreCovariance's 6n / (6n - k)
    for (int lag : {0, 1, 2, 7, 30, 300, n - 1}) {
      if (lag > n - 1 || (n > 1000 && lag > 300)) continue;  // the written-out sum is O(n lag)
      SCOPED_TRACE("n " + std::to_string(n) + " lag " + std::to_string(lag));
      const CovarianceReport rep = scoreCovariance(S, R, bread, lag);
      ASSERT_EQ(rep.lag, lag);
      const Eigen::MatrixXd ref = correction * laggedSumNeweyWest(S, lag);
      EXPECT_LT((rep.covariance - ref).cwiseAbs().maxCoeff(), 1e-12 * ref.cwiseAbs().maxCoeff());
    }
  }
}

/// Correlated, non-zero-mean scores (n x 3) with large first and last rows.
Eigen::MatrixXd edgyScores(int n, double rho, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  Eigen::MatrixXd S(n, 3);
  Eigen::RowVector3d x = Eigen::RowVector3d::Zero();
  for (int i = 0; i < n; ++i) {
    x = rho * x + Eigen::RowVector3d(n01(rng) + 0.5, n01(rng), 2.0 * n01(rng) - 1.0);
    S.row(i) = x;
  }
  S.row(0) *= 20.0;
  S.row(n - 1) *= -15.0;
  return S;
}

TEST(ScoreCovariance, PrewhitenedEqualsTheFormulaOnTheFilteredSeriesWrittenOut) {
  // The default (prewhitened) estimate against uncertainty.hpp's definition computed here on the
  // explicitly filtered series E: a_j, E = S_(1..) - S_(..n-2) diag(a), the bandwidth from E's
  // columns, the lagged-sum Newey-West of E, recoloured by D = diag(1 - a).
  for (const int n : {61, 600, 3000, 5000}) {
    for (const double rho : {0.0, 0.5, 0.95}) {
      SCOPED_TRACE("n " + std::to_string(n) + " rho " + std::to_string(rho));
      const Eigen::MatrixXd S = edgyScores(n, rho, 31 + static_cast<std::uint64_t>(n));
      const Eigen::Index k = S.cols();
      Eigen::VectorXd a(k);
      for (Eigen::Index j = 0; j < k; ++j) {
        a(j) = std::clamp(S.col(j).tail(n - 1).dot(S.col(j).head(n - 1)) / S.col(j).head(n - 1).squaredNorm(), -0.9,
                          0.97);
      }
      const Eigen::MatrixXd E = S.bottomRows(n - 1) - S.topRows(n - 1) * a.asDiagonal();
      const Eigen::Index m = n - 1;
      double alpha = 0.0;
      for (Eigen::Index j = 0; j < k; ++j) {
        const double r = std::clamp(E.col(j).tail(m - 1).dot(E.col(j).head(m - 1)) / E.col(j).squaredNorm(), -0.97, 0.97);
        alpha += 4.0 * r * r / (std::pow(1.0 - r, 2) * std::pow(1.0 + r, 2));
      }
      alpha /= static_cast<double>(k);
      const int lag = static_cast<int>(std::min<double>(std::floor(1.1447 * std::cbrt(alpha * m)), static_cast<double>(m / 4)));
      const Eigen::VectorXd d = (Eigen::VectorXd::Ones(k) - a).cwiseInverse();
      const double correction = 6.0 * n / (6.0 * n - static_cast<double>(k));
      const Eigen::MatrixXd ref = correction * static_cast<double>(n) / static_cast<double>(n - 1) *
                                  (d.asDiagonal() * laggedSumNeweyWest(E, lag) * d.asDiagonal());
      const Eigen::Matrix<double, 6, Eigen::Dynamic> R = Eigen::Matrix<double, 6, Eigen::Dynamic>::Ones(6, n);
      const CovarianceReport rep = scoreCovariance(S, R, Eigen::MatrixXd::Identity(k, k));
      EXPECT_EQ(rep.lag, lag);
      EXPECT_LT((rep.score_ar1 - a).cwiseAbs().maxCoeff(), 1e-15);
      EXPECT_LT((rep.covariance - ref).cwiseAbs().maxCoeff(), 1e-11 * ref.cwiseAbs().maxCoeff());
    }
  }
}

TEST(ScoreCovariance, TwoHalvesOnTwoThreadsOrOneGiveTheSameBits) {
  // From 4,096 rows the Newey-West sum runs in two halves; with internal::serialOnly both run on
  // this thread (as on a one-CPU machine): the same partial sums in the same order.
  const Eigen::MatrixXd S = edgyScores(6000, 0.8, 99);
  const Eigen::Matrix<double, 6, Eigen::Dynamic> R = Eigen::Matrix<double, 6, Eigen::Dynamic>::Ones(6, 6000);
  const Eigen::MatrixXd bread = Eigen::MatrixXd::Identity(3, 3);
  const CovarianceReport two = scoreCovariance(S, R, bread);
  internal::serialOnly() = true;
  const CovarianceReport one = scoreCovariance(S, R, bread);
  internal::serialOnly() = false;
  EXPECT_GT(two.lag, 0);
  EXPECT_EQ(one.lag, two.lag);
  EXPECT_EQ(one.covariance, two.covariance);
}

TEST(ScoreCovariance, AutomaticBandwidthIsAndrewsPlugInOfTheResidualAxes) {
  // Andrews' AR(1) plug-in (uncertainty.hpp) written out per axis on a residual with non-zero
  // means, different scales and correlations per axis.
  for (const int n : {40, 2000}) {
    SCOPED_TRACE(n);
    std::mt19937_64 rng(3 + static_cast<std::uint64_t>(n));
    std::normal_distribution<double> n01(0.0, 1.0);
    Eigen::Matrix<double, 6, Eigen::Dynamic> R(6, n);
    for (int a = 0; a < 6; ++a) {
      double x = 0.0;
      for (int i = 0; i < n; ++i) {
        x = 0.15 * a * x + (1.0 + a) * n01(rng);
        R(a, i) = x + 0.3 * a;
      }
    }
    double num = 0.0, den = 0.0;
    Vec6 rho_ref;
    for (int a = 0; a < 6; ++a) {
      const Eigen::RowVectorXd x = R.row(a).array() - R.row(a).mean();
      const double c0 = x.squaredNorm();
      const double r = std::clamp(x.tail(n - 1).dot(x.head(n - 1)) / c0, -0.97, 0.97);
      rho_ref(a) = r;
      const double s4 = std::pow(c0 / n, 2);
      num += 4.0 * r * r * s4 / (std::pow(1.0 - r, 6) * std::pow(1.0 + r, 2));
      den += s4 / std::pow(1.0 - r, 4);
    }
    const int expected = static_cast<int>(std::min<double>(std::floor(1.1447 * std::cbrt(num / den * n)), n / 4));
    Vec6 rho;
    EXPECT_EQ(automaticBandwidth(R, &rho), expected);
    EXPECT_LT((rho - rho_ref).cwiseAbs().maxCoeff(), 1e-12);
  }
}

}  // namespace
}  // namespace ftid::identify
