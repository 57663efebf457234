#pragma once
// Helpers shared by the general fit and the paper method (private to ftid_identify).
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "ftid/common/types.hpp"

namespace ftid::identify::internal {

/// Singular-value analysis of a column-scaled matrix A (rows x cols): condition number and the
/// columns that take part in its (numerical) null space.
struct RankReport {
  int rank = 0;
  double condition_number = 0.0;       ///< sigma_max / sigma_min of the column-scaled matrix
  std::vector<int> unexcited_columns;  ///< columns with participation > 0.1 in the null space
  Eigen::VectorXd column_norms;        ///< norms used for scaling (0 for a zero column)
};

/// Scales columns to unit norm, QR, SVD of R. Zero columns are reported as not excited.
RankReport analyzeRank(const Eigen::MatrixXd& A, double relative_tolerance);

/// (A^T A)^{-1} from a QR of the column-scaled A (never forms A^T A). A must have full rank.
Eigen::MatrixXd inverseGram(const Eigen::MatrixXd& A);

/// Formats "a, b and c".
std::string joinNames(const std::vector<std::string>& names);

bool allFinite(const Eigen::Ref<const Eigen::MatrixXd>& m);

}  // namespace ftid::identify::internal
