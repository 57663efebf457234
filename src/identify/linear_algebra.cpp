// Rank analysis, condition numbers, exact row compression (linear_algebra.hpp) and the Gram solve
// for screening (ftid/identify/normal_equations.hpp).
#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>

#include "linear_algebra.hpp"
#include "ftid/identify/normal_equations.hpp"

namespace ftid::identify::internal {

namespace {

/// A column counts as zero (not excited) if its norm is 0 or negligible against the largest.
std::vector<bool> zeroColumns(const Eigen::VectorXd& norms) {
  const double max_norm = norms.size() > 0 ? norms.maxCoeff() : 0.0;
  std::vector<bool> zero(static_cast<std::size_t>(norms.size()), false);
  for (Eigen::Index j = 0; j < norms.size(); ++j) {
    const double n = norms(j);
    zero[static_cast<std::size_t>(j)] = !(n > 1e-300) || n <= 1e-14 * max_norm;
  }
  return zero;
}

/// Rank, condition number and null-space columns from the R factor (k x cols) of the column-scaled
/// matrix; column k of R is column original_column[k] of the matrix.
void reportFromR(const Eigen::MatrixXd& R, const std::vector<Eigen::Index>& original_column,
                 const std::vector<bool>& zero, double relative_tolerance, RankReport* report) {
  const Eigen::Index cols = static_cast<Eigen::Index>(zero.size());
  // Well-conditioned R (the usual case) without the SVD: the eigenvalues l of R^T R are the squared
  // singular values, each with an absolute rounding error of about cols * eps * l_max. Where
  // l_min > kWellConditioned l_max (condition number below 1e4) that is a relative error of at most
  // ~2e-7 on s_min = sqrt(l_min) (16 columns), and every singular value clears the rank tolerance (when it is at
  // most 1e-5): full rank, condition number sqrt(l_max / l_min). Otherwise the SVD decides (and
  // names the null space).
  constexpr double kWellConditioned = 1e-8;
  if (R.rows() == cols && cols > 0 && relative_tolerance <= 1e-5) {
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(R.transpose() * R, Eigen::EigenvaluesOnly);
    const double l_min = eig.eigenvalues()(0);
    const double l_max = eig.eigenvalues()(cols - 1);
    if (eig.info() == Eigen::Success && l_max > 0.0 && l_min > kWellConditioned * l_max) {
      report->rank = static_cast<int>(cols);
      report->condition_number = std::sqrt(l_max / l_min);
      return;
    }
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(R, Eigen::ComputeFullV);
  const Eigen::VectorXd& s = svd.singularValues();
  const double smax = s.size() > 0 ? s(0) : 0.0;
  report->rank = 0;
  for (Eigen::Index i = 0; i < s.size(); ++i) {
    if (s(i) > relative_tolerance * smax) ++report->rank;
  }
  const double smin = s.size() > 0 ? s(s.size() - 1) : 0.0;
  report->condition_number = smin > 0.0 ? smax / smin : std::numeric_limits<double>::infinity();
  if (report->rank < cols) {
    // Participation of each column in the null space; name those with at least a tenth of the
    // largest participation (and always zero columns).
    const Eigen::MatrixXd& V = svd.matrixV();
    Eigen::VectorXd participation = Eigen::VectorXd::Zero(cols);
    for (Eigen::Index k = 0; k < V.rows(); ++k) {
      double sum = 0.0;
      for (Eigen::Index c = report->rank; c < V.cols(); ++c) sum += V(k, c) * V(k, c);
      participation(original_column[static_cast<std::size_t>(k)]) = std::sqrt(sum);
    }
    const double pmax = participation.size() > 0 ? participation.maxCoeff() : 0.0;
    for (Eigen::Index j = 0; j < cols; ++j) {
      if (zero[static_cast<std::size_t>(j)] || participation(j) > 0.1 * pmax) {
        report->unexcited_columns.push_back(static_cast<int>(j));
      }
    }
  }
}

Eigen::VectorXd scaleColumnsInPlace(Eigen::MatrixXd& A, Eigen::VectorXd& norms) {
  norms = A.colwise().norm().transpose();
  const std::vector<bool> zero = zeroColumns(norms);
  Eigen::VectorXd scale = Eigen::VectorXd::Ones(A.cols());
  for (Eigen::Index j = 0; j < A.cols(); ++j) {
    if (zero[static_cast<std::size_t>(j)]) {
      A.col(j).setZero();
    } else {
      scale(j) = norms(j);
      A.col(j) /= norms(j);
    }
  }
  return scale;
}

}  // namespace

RankReport analyzeRank(const Eigen::MatrixXd& A, double relative_tolerance) {
  const Eigen::Index cols = A.cols();
  RankReport report;
  report.column_norms = A.colwise().norm().transpose();
  const std::vector<bool> zero = zeroColumns(report.column_norms);
  Eigen::MatrixXd scaled = A;
  for (Eigen::Index j = 0; j < cols; ++j) {
    if (zero[static_cast<std::size_t>(j)]) {
      scaled.col(j).setZero();
    } else {
      scaled.col(j) /= report.column_norms(j);
    }
  }
  Eigen::MatrixXd R;
  if (scaled.rows() >= cols) {
    Eigen::HouseholderQR<Eigen::Ref<Eigen::MatrixXd>> qr(scaled);
    R = qr.matrixQR().topRows(cols).triangularView<Eigen::Upper>();
  } else {
    R = scaled;  // fewer rows than columns: rank-deficient anyway; SVD of the scaled A directly
  }
  std::vector<Eigen::Index> identity(static_cast<std::size_t>(cols));
  for (Eigen::Index j = 0; j < cols; ++j) identity[static_cast<std::size_t>(j)] = j;
  reportFromR(R, identity, zero, relative_tolerance, &report);
  return report;
}

ScaledQR::ScaledQR(Eigen::MatrixXd& A, double rank_tolerance)
    : scale_(scaleColumnsInPlace(A, norms_)), qr_(A) {
  const Eigen::Index cols = A.cols();
  report_.column_norms = norms_;
  std::vector<Eigen::Index> original(static_cast<std::size_t>(cols));
  for (Eigen::Index k = 0; k < cols; ++k) original[static_cast<std::size_t>(k)] = qr_.colsPermutation().indices()(k);
  const Eigen::MatrixXd R = qr_.matrixQR().topRows(cols).triangularView<Eigen::Upper>();
  reportFromR(R, original, zeroColumns(norms_), rank_tolerance, &report_);
}

void ScaledQR::applyQt(Eigen::VectorXd& y) const { y.applyOnTheLeft(qr_.householderQ().adjoint()); }

Eigen::VectorXd ScaledQR::solveHead(const Eigen::Ref<const Eigen::VectorXd>& z) const {
  const Eigen::Index cols = qr_.cols();
  const Eigen::VectorXd xs =
      qr_.matrixQR().topLeftCorner(cols, cols).triangularView<Eigen::Upper>().solve(z.head(cols));
  Eigen::VectorXd x(cols);
  for (Eigen::Index k = 0; k < cols; ++k) {
    const Eigen::Index j = qr_.colsPermutation().indices()(k);
    x(j) = xs(k) / scale_(j);
  }
  return x;
}

Eigen::VectorXd ScaledQR::solve(const Eigen::VectorXd& y) const {
  Eigen::VectorXd z = y;
  applyQt(z);
  return solveHead(z);
}

Eigen::MatrixXd ScaledQR::unpivotUnscale(const Eigen::MatrixXd& S) const {
  const Eigen::Index cols = S.rows();
  const auto& perm = qr_.colsPermutation().indices();
  Eigen::MatrixXd out(cols, cols);
  for (Eigen::Index a = 0; a < cols; ++a) {
    for (Eigen::Index b = 0; b < cols; ++b) {
      out(perm(a), perm(b)) = S(a, b) / (scale_(perm(a)) * scale_(perm(b)));
    }
  }
  return out;
}

namespace {

/// R^{-1} R^{-T} for an upper-triangular R.
Eigen::MatrixXd inverseGramOfR(const Eigen::MatrixXd& R) {
  const Eigen::MatrixXd Rinv =
      R.triangularView<Eigen::Upper>().solve(Eigen::MatrixXd::Identity(R.rows(), R.cols()));
  return Rinv * Rinv.transpose();
}

}  // namespace

Eigen::MatrixXd ScaledQR::inverseGram() const {
  const Eigen::Index cols = qr_.cols();
  return unpivotUnscale(inverseGramOfR(qr_.matrixQR().topLeftCorner(cols, cols).triangularView<Eigen::Upper>()));
}

Eigen::MatrixXd ScaledQR::inverseGramRankOneUpdate(const Eigen::VectorXd& qt_u, const Eigen::VectorXd& v) const {
  const Eigen::Index cols = qr_.cols();
  const auto& perm = qr_.colsPermutation().indices();
  Eigen::VectorXd w(cols);  // P^T D^{-1} v
  for (Eigen::Index k = 0; k < cols; ++k) w(k) = v(perm(k)) / scale_(perm(k));
  Eigen::MatrixXd M(cols + 1, cols);
  M.topRows(cols) = qr_.matrixQR().topLeftCorner(cols, cols).triangularView<Eigen::Upper>();
  M.topRows(cols) -= qt_u.head(cols) * w.transpose();
  M.row(cols) = -qt_u.tail(qt_u.size() - cols).norm() * w.transpose();
  Eigen::HouseholderQR<Eigen::Ref<Eigen::MatrixXd>> qr(M);
  const Eigen::MatrixXd RM = qr.matrixQR().topRows(cols).triangularView<Eigen::Upper>();
  return unpivotUnscale(inverseGramOfR(RM));
}

Eigen::MatrixXd thinR(Eigen::MatrixXd& D) {
  const Eigen::Index r = std::min(D.rows(), D.cols());
  const Eigen::HouseholderQR<Eigen::Ref<Eigen::MatrixXd>> qr(D);
  return qr.matrixQR().topRows(r).triangularView<Eigen::Upper>();
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

namespace ftid::identify {

GramSolution solveGram(const Eigen::MatrixXd& G, const Eigen::VectorXd& h, bool want_inverse,
                       double relative_tolerance) {
  const Eigen::Index p = G.rows();
  GramSolution out;
  out.x = Eigen::VectorXd::Zero(p);
  if (p == 0) return out;
  Eigen::VectorXd d(p);
  for (Eigen::Index k = 0; k < p; ++k) d(k) = G(k, k) > 0.0 ? 1.0 / std::sqrt(G(k, k)) : 0.0;
  const Eigen::MatrixXd Gs = d.asDiagonal() * G * d.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(Gs);
  const Eigen::VectorXd& l = eig.eigenvalues();
  const double lmax = l.maxCoeff();
  Eigen::VectorXd linv = Eigen::VectorXd::Zero(p);
  double lmin_kept = lmax;
  for (Eigen::Index k = 0; k < p; ++k) {
    if (lmax > 0.0 && l(k) > relative_tolerance * lmax) {
      linv(k) = 1.0 / l(k);
      ++out.rank;
      lmin_kept = std::min(lmin_kept, l(k));
    }
  }
  out.condition = lmax > 0.0 ? std::sqrt(lmax / lmin_kept) : 0.0;
  const Eigen::MatrixXd& V = eig.eigenvectors();
  if (want_inverse && out.rank < p) {
    out.null_space.resize(p, p - out.rank);
    int c = 0;
    for (Eigen::Index k = 0; k < p; ++k) {
      if (linv(k) == 0.0) out.null_space.col(c++) = V.col(k);
    }
  }
  const Eigen::VectorXd hs = d.asDiagonal() * h;
  out.x = d.asDiagonal() * (V * (linv.asDiagonal() * (V.transpose() * hs)));
  if (want_inverse) out.inverse = d.asDiagonal() * V * linv.asDiagonal() * V.transpose() * d.asDiagonal();
  return out;
}

}  // namespace ftid::identify
