// Autocorrelation-robust parameter covariance (include/ftid/identify/uncertainty.hpp).
#include "ftid/identify/uncertainty.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace ftid::identify {

int automaticBandwidth(const Eigen::Ref<const Eigen::Matrix<double, 6, Eigen::Dynamic>>& residual, Vec6* ar1) {
  const Eigen::Index n = residual.cols();
  double num = 0.0, den = 0.0;
  Vec6 rho = Vec6::Zero();
  for (int a = 0; a < 6; ++a) {
    const auto x = residual.row(a);
    const double mean = x.mean();
    double c0 = 0.0, c1 = 0.0;
    for (Eigen::Index i = 0; i < n; ++i) {
      const double d = x(i) - mean;
      c0 += d * d;
      if (i > 0) c1 += d * (x(i - 1) - mean);
    }
    if (!(c0 > 0.0)) continue;
    const double r = std::clamp(c1 / c0, -0.97, 0.97);
    rho(a) = r;
    const double s4 = std::pow(c0 / static_cast<double>(n), 2);
    num += 4.0 * r * r * s4 / (std::pow(1.0 - r, 6) * std::pow(1.0 + r, 2));
    den += s4 / std::pow(1.0 - r, 4);
  }
  if (ar1 != nullptr) *ar1 = rho;
  if (!(den > 0.0) || n < 8) return 0;
  const double alpha = num / den;
  const double bw = 1.1447 * std::cbrt(alpha * static_cast<double>(n));
  return static_cast<int>(std::min<double>(std::floor(bw), static_cast<double>(n / 4)));
}

CovarianceReport robustCovariance(const Eigen::Ref<const Eigen::MatrixXd>& J, const Eigen::Ref<const Eigen::VectorXd>& r,
                                  const Eigen::MatrixXd& inverse_gram, int max_lag) {
  const Eigen::Index rows = J.rows();
  const Eigen::Index k = J.cols();
  if (rows % 6 != 0 || r.size() != rows || inverse_gram.rows() != k || inverse_gram.cols() != k) {
    throw std::invalid_argument("robustCovariance: sizes J " + std::to_string(rows) + "x" + std::to_string(k) +
                                ", r " + std::to_string(r.size()) + ", (J^T J)^-1 " +
                                std::to_string(inverse_gram.rows()) + " do not match (rows = 6 n)");
  }
  const Eigen::Index n = rows / 6;
  CovarianceReport out;
  const Eigen::Map<const Eigen::Matrix<double, 6, Eigen::Dynamic>> R(r.data(), 6, n);
  out.lag = max_lag >= 0 ? static_cast<int>(std::min<Eigen::Index>(max_lag, std::max<Eigen::Index>(0, n - 1)))
                         : automaticBandwidth(R, &out.residual_ar1);
  if (max_lag >= 0) automaticBandwidth(R, &out.residual_ar1);
  // Scores, one row per sample.
  Eigen::MatrixXd S(n, k);
  for (Eigen::Index i = 0; i < n; ++i) S.row(i) = r.segment<6>(6 * i).transpose() * J.middleRows(6 * i, 6);
  Eigen::MatrixXd omega = S.transpose() * S;
  for (int l = 1; l <= out.lag; ++l) {
    const double w = 1.0 - static_cast<double>(l) / (out.lag + 1);
    const Eigen::MatrixXd g = S.bottomRows(n - l).transpose() * S.topRows(n - l);
    omega += w * (g + g.transpose());
  }
  const double dof = static_cast<double>(rows - k);
  const double correction = dof > 0.0 ? static_cast<double>(rows) / dof : 1.0;
  out.covariance = correction * inverse_gram * omega * inverse_gram;
  out.covariance = 0.5 * (out.covariance + out.covariance.transpose());
  // Inflation against the classical covariance.
  const double sigma2 = dof > 0.0 ? r.squaredNorm() / dof : 0.0;
  double sum = 0.0;
  int cnt = 0;
  for (Eigen::Index j = 0; j < k; ++j) {
    const double classical = sigma2 * inverse_gram(j, j);
    if (classical > 0.0) {
      sum += out.covariance(j, j) / classical;
      ++cnt;
    }
  }
  out.variance_inflation = cnt > 0 ? sum / cnt : 1.0;
  return out;
}

}  // namespace ftid::identify
