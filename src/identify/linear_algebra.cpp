// Rank analysis, condition numbers and covariance helpers (fit_internal.hpp).
#include <algorithm>
#include <cmath>
#include <limits>

#include "fit_internal.hpp"

namespace ftid::identify::internal {

RankReport analyzeRank(const Eigen::MatrixXd& A, double relative_tolerance) {
  const Eigen::Index cols = A.cols();
  RankReport report;
  report.column_norms = A.colwise().norm().transpose();
  Eigen::MatrixXd scaled = A;
  std::vector<bool> zero(static_cast<std::size_t>(cols), false);
  double max_norm = 0.0;
  for (Eigen::Index j = 0; j < cols; ++j) max_norm = std::max(max_norm, report.column_norms(j));
  for (Eigen::Index j = 0; j < cols; ++j) {
    const double n = report.column_norms(j);
    if (!(n > 1e-300) || n <= 1e-14 * max_norm) {
      zero[static_cast<std::size_t>(j)] = true;
      scaled.col(j).setZero();
    } else {
      scaled.col(j) /= n;
    }
  }
  Eigen::MatrixXd R;
  if (scaled.rows() >= cols) {
    Eigen::HouseholderQR<Eigen::MatrixXd> qr(scaled);
    R = qr.matrixQR().topRows(cols).triangularView<Eigen::Upper>();
  } else {
    R = scaled;  // fewer rows than columns: rank-deficient anyway; SVD of A directly
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(R, Eigen::ComputeFullV);
  const Eigen::VectorXd s = svd.singularValues();
  const double smax = s.size() > 0 ? s(0) : 0.0;
  report.rank = 0;
  for (Eigen::Index i = 0; i < s.size(); ++i) {
    if (s(i) > relative_tolerance * smax) ++report.rank;
  }
  const double smin = s.size() > 0 ? s(s.size() - 1) : 0.0;
  report.condition_number = smin > 0.0 ? smax / smin : std::numeric_limits<double>::infinity();
  if (report.rank < cols) {
    // Participation of each column in the null space; name those with at least a tenth of the
    // largest participation (and always zero columns).
    const Eigen::MatrixXd& V = svd.matrixV();
    Eigen::VectorXd participation = Eigen::VectorXd::Zero(cols);
    for (Eigen::Index j = 0; j < cols; ++j) {
      for (Eigen::Index k = report.rank; k < V.cols(); ++k) participation(j) += V(j, k) * V(j, k);
      participation(j) = std::sqrt(participation(j));
    }
    double pmax = 0.0;
    for (Eigen::Index j = 0; j < cols; ++j) pmax = std::max(pmax, participation(j));
    for (Eigen::Index j = 0; j < cols; ++j) {
      if (zero[static_cast<std::size_t>(j)] || participation(j) > 0.1 * pmax) {
        report.unexcited_columns.push_back(static_cast<int>(j));
      }
    }
  }
  return report;
}

Eigen::MatrixXd inverseGram(const Eigen::MatrixXd& A) {
  const Eigen::Index cols = A.cols();
  const Eigen::VectorXd norms = A.colwise().norm().transpose();
  Eigen::MatrixXd scaled = A;
  for (Eigen::Index j = 0; j < cols; ++j) scaled.col(j) /= norms(j);
  Eigen::HouseholderQR<Eigen::MatrixXd> qr(scaled);
  const Eigen::MatrixXd R = qr.matrixQR().topRows(cols).triangularView<Eigen::Upper>();
  const Eigen::MatrixXd Rinv =
      R.triangularView<Eigen::Upper>().solve(Eigen::MatrixXd::Identity(cols, cols));
  const Eigen::MatrixXd inv_scaled = Rinv * Rinv.transpose();
  return norms.cwiseInverse().asDiagonal() * inv_scaled * norms.cwiseInverse().asDiagonal();
}

std::string joinNames(const std::vector<std::string>& names) {
  std::string out;
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (i > 0) out += (i + 1 == names.size()) ? " and " : ", ";
    out += names[i];
  }
  return out;
}

bool allFinite(const Eigen::Ref<const Eigen::MatrixXd>& m) { return m.allFinite(); }

}  // namespace ftid::identify::internal
