#pragma once
// The identify module's linear algebra (implemented in linear_algebra.cpp; private to
// ftid_identify): rank reports and the column-scaled QR that the general fit (fit.cpp and its
// steps, fit_steps.hpp) and the paper method (paper_method.cpp) both solve with. It depends on nothing else in the module, so
// either may include it (it sits below both).
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

/// Column-scaled, column-pivoted Householder QR of a tall matrix A (rows >= cols), factored once
/// and reused for the rank report, least-squares solutions and (A^T A)^{-1}:
///
///   A D^{-1} P = Q R      D = diag(column norms of A) (zero columns: kept zero, D = 1)
///
/// Identities (test/unit/identify/linear_algebra_test.cpp checks each against an SVD of A):
///   singular values of R  = those of A D^{-1}  (the condition number and rank of analyzeRank)
///   right singular vectors of A D^{-1} = P x those of R   (null-space participation)
///   argmin_x |A x - y|    = D^{-1} P R^{-1} (Q^T y)_{1..cols}
///   (A^T A)^{-1}          = D^{-1} P R^{-1} R^{-T} P^T D^{-1}
/// The factorisation is done in place: A is overwritten and must outlive the ScaledQR.
class ScaledQR {
 public:
  ScaledQR(Eigen::MatrixXd& A, double rank_tolerance);
  ScaledQR(const ScaledQR&) = delete;
  ScaledQR& operator=(const ScaledQR&) = delete;

  const RankReport& rank() const { return report_; }
  Eigen::Index rows() const { return qr_.rows(); }
  Eigen::Index cols() const { return qr_.cols(); }
  /// y <- Q^T y (full length: the first cols() entries feed solveHead(), the norm of the rest is
  /// the least-squares residual norm of y).
  void applyQt(Eigen::VectorXd& y) const;
  /// x = D^{-1} P R^{-1} z for the first cols() entries z of Q^T y.
  Eigen::VectorXd solveHead(const Eigen::Ref<const Eigen::VectorXd>& z) const;
  /// argmin_x |A x - y| (full rank required).
  Eigen::VectorXd solve(const Eigen::VectorXd& y) const;
  /// (A^T A)^{-1} (full rank required).
  Eigen::MatrixXd inverseGram() const;
  /// (J^T J)^{-1} for J = A - u v^T from Q^T u (applyQt of u) and v, without refactoring J:
  ///   J D^{-1} P = [Q_1, Q_2 e] [R - q w^T; -|r| w^T],  Q^T u = [q; r], e = r/|r|, w = P^T D^{-1} v,
  /// so (J^T J)^{-1} = D^{-1} P M^{-1} M^{-T} P^T D^{-1} with M the R of that (cols+1) x cols matrix.
  Eigen::MatrixXd inverseGramRankOneUpdate(const Eigen::VectorXd& qt_u, const Eigen::VectorXd& v) const;

 private:
  /// out(perm(i), perm(j)) = S(i, j) / (d(perm i) d(perm j)): from pivoted scaled to original.
  Eigen::MatrixXd unpivotUnscale(const Eigen::MatrixXd& S) const;

  Eigen::VectorXd norms_;  ///< column norms of A (0 for a zero column)
  Eigen::VectorXd scale_;  ///< D
  Eigen::ColPivHouseholderQR<Eigen::Ref<Eigen::MatrixXd>> qr_;
  RankReport report_;
};

/// Exact row compression. A least-squares problem whose stacked rows for axis a are D_a C_a (data
/// D_a: one row per sample, n x d; C_a: a constant d x k map) has, with the thin QR D_a = Q_a R_a,
/// the rows Q_a (R_a C_a); Q_a has orthonormal columns, so the stacked problem and the compressed
/// [R_0 C_0; R_1 C_1; ...] (min(n, d) rows per axis) have the same column norms, Gram matrix,
/// singular values, least-squares solutions and residual norms (a right-hand side is a column of
/// D_a, picked by C_a). Used by the paper method's stages and the fit's compressed tilt search.
///
/// R of the thin QR of D (min(n, d) x d, upper trapezoidal). D is overwritten.
Eigen::MatrixXd thinR(Eigen::MatrixXd& D);

/// Formats "a, b and c".
std::string joinNames(const std::vector<std::string>& names);

bool allFinite(const Eigen::Ref<const Eigen::MatrixXd>& m);

}  // namespace ftid::identify::internal
