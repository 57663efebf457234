#pragma once
// Normal-equation (Gram) solves for screening many candidate models (ftid analyze's fold fits):
// the Gram matrix G = X^T X of a weighted regressor and h = X^T y are formed once per data block,
// so a fit on any union of blocks is a sum of small matrices and costs P^3, not N P^2. Final fits
// of one model use QR instead (fitModel; src/identify/linear_algebra.hpp), which does not square
// the condition number. Implemented in src/identify/linear_algebra.cpp.
#include <Eigen/Dense>

namespace ftid::identify {

struct GramSolution {
  Eigen::VectorXd x;           ///< minimum-norm solution of G x = h (pseudo-inverse)
  Eigen::MatrixXd inverse;     ///< pseudo-inverse of G (if asked for)
  int rank = 0;
  double condition = 0.0;      ///< of the column-scaled regressor: sqrt of that of the scaled G
  Eigen::MatrixXd null_space;  ///< dropped directions (columns, in column-scaled coordinates; if asked for)
};

/// Pseudo-inverse solve of G x = h on the column-equilibrated G (D G D with D = diag(G)^{-1/2}; a
/// zero diagonal gives a zero column): eigenvalues below relative_tolerance times the largest
/// count as not determined (1e-12: a condition number of 1e6 of the scaled regressor).
GramSolution solveGram(const Eigen::MatrixXd& G, const Eigen::VectorXd& h, bool want_inverse,
                       double relative_tolerance = 1e-12);

}  // namespace ftid::identify
