// Autocorrelation-robust parameter covariance (include/ftid/identify/uncertainty.hpp).
#include "ftid/identify/uncertainty.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

#include "concurrency.hpp"

namespace ftid::identify {

int automaticBandwidth(const Eigen::Ref<const Eigen::Matrix<double, 6, Eigen::Dynamic>>& residual, Vec6* ar1) {
  const Eigen::Index n = residual.cols();
  double num = 0.0, den = 0.0;
  Vec6 rho = Vec6::Zero();
  // The lag-0 and lag-1 sums of every axis in one pass along the (contiguous) samples.
  const Vec6 mean = n > 0 ? Vec6(residual.rowwise().mean()) : Vec6::Zero();
  Vec6 c0_all = Vec6::Zero();
  Vec6 c1_all = Vec6::Zero();
  Vec6 prev = n > 0 ? Vec6(residual.col(0) - mean) : Vec6::Zero();
  c0_all = prev.cwiseAbs2();
  for (Eigen::Index i = 1; i < n; ++i) {
    const Vec6 d = residual.col(i) - mean;
    c0_all += d.cwiseAbs2();
    c1_all += d.cwiseProduct(prev);
    prev = d;
  }
  for (int a = 0; a < 6; ++a) {
    const double c0 = c0_all(a);
    const double c1 = c1_all(a);
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

namespace {

/// Newey-West (Bartlett) sum of the autocovariances of the rows s_0..s_(n-1) of a series up to lag L,
///   Omega = Gamma_0 + sum_{l=1..L} (1 - l/(L+1)) (Gamma_l + Gamma_l^T),  Gamma_l = sum_i s_i s_(i-l)^T,
/// computed exactly as one product of moving sums (docs/identification.md, "Standard errors"):
/// with s_i = 0 outside 0..n-1 and c_t = s_t + s_(t-1) + ... + s_(t-L) for t = 0..n-1+L,
///   sum_t c_t c_t^T = sum_{l=-L..L} (L+1-|l|) Gamma_l = (L+1) Omega
/// (the pair (s_u, s_v), u - v = l >= 0, meets in L+1-l of the sums), so one (n+L) x k product
/// replaces L+1 lagged n x k products; the partial sums at both ends make it exact, no edge term.
/// The series is read through add_rows(first, count, dest): dest (count x k) += its rows
/// first..first+count-1, so a filtered series need not be stored; the moving sums are formed a
/// block of rows at a time (no (n+L) x k temporary).
template <class AddRows>
Eigen::MatrixXd neweyWest(Eigen::Index n, Eigen::Index k, int lag, const AddRows& add_rows) {
  const Eigen::Index L = std::max(0, lag);  // lags >= n add nothing (no overlap), as in the sum
  constexpr Eigen::Index kBlock = 256;
  // The sum over the blocks t0 in [begin, end) (block-aligned), into the lower triangle of omega.
  auto sumBlocks = [&](Eigen::Index begin, Eigen::Index end, Eigen::MatrixXd& omega) {
    omega.setZero(k, k);
    Eigen::MatrixXd C(kBlock, k);
    for (Eigen::Index t0 = begin; t0 < end; t0 += kBlock) {
      const Eigen::Index len = std::min(kBlock, end - t0);
      C.topRows(len).setZero();
      for (Eigen::Index l = 0; l <= L; ++l) {  // rows t of the block get s_(t-l), 0 <= t-l < n
        const Eigen::Index lo = std::max(t0, l);
        const Eigen::Index hi = std::min(t0 + len, n + l);
        if (hi > lo) add_rows(lo - l, hi - lo, C.middleRows(lo - t0, hi - lo));
      }
      omega.selfadjointView<Eigen::Lower>().rankUpdate(C.topRows(len).transpose(), 1.0 / static_cast<double>(L + 1));
    }
  };
  // From internal::kParallelRows rows on, two halves of the blocks (the second on a thread of its
  // own where there is a second core), added in order: the split depends on n and L alone.
  const Eigen::Index total = n + L;
  const Eigen::Index mid = total >= internal::kParallelRows ? ((total / 2 + kBlock - 1) / kBlock) * kBlock : total;
  std::array<Eigen::MatrixXd, 2> part;
  if (mid < total) {
    internal::runHalves([&] { sumBlocks(0, mid, part[0]); }, [&] { sumBlocks(mid, total, part[1]); });
    part[0] += part[1];
  } else {
    sumBlocks(0, total, part[0]);
  }
  Eigen::MatrixXd& omega = part[0];
  omega.triangularView<Eigen::StrictlyUpper>() = omega.transpose();
  return omega;
}

Eigen::MatrixXd neweyWest(const Eigen::Ref<const Eigen::MatrixXd>& S, int lag) {
  return neweyWest(S.rows(), S.cols(), lag, [&S](Eigen::Index first, Eigen::Index count, auto dest) {
    dest += S.middleRows(first, count);
  });
}

/// Andrews' AR(1) plug-in bandwidth over the columns of the prewhitened scores E (rows
/// e_i = s_(i+1) - a o s_i, i = 0..m-1, m = n - 1), each column standardised (equal weight):
/// alpha = mean_j 4 rho_j^2 / ((1 - rho_j)^2 (1 + rho_j)^2), rho_j = c1_j / c0_j,
/// L = floor(1.1447 (alpha m)^(1/3)). E is not formed: per column, with the sums of s
///   T0 = sum_(0..n-2) s_i^2, T1 = sum_(1..n-1) s_i^2, G1 = sum_(0..n-2) s_(i+1) s_i, G2 = sum_(1..n-2) s_(i+1) s_(i-1),
///   c0 = sum_i e_i^2          = T1 - 2 a G1 + a^2 T0
///   c1 = sum_i e_i e_(i-1)    = (G1 - s_1 s_0) - a G2 - a (T0 - s_0^2) + a^2 (G1 - s_(n-1) s_(n-2)).
/// The expansion loses ~eps T1 to cancellation: negligible while c0 is not tiny against T1 (an
/// unclamped a gives c0 = T1 - G1^2 / T0, at a clamped one c0 / T1 stays above ~1e-3); where
/// c0 < 1e-8 T1 that column's sums are taken from the filtered series itself.
int whitenedBandwidth(const Eigen::Ref<const Eigen::MatrixXd>& S, const Eigen::VectorXd& a) {
  const Eigen::Index n = S.rows();
  const Eigen::Index m = n - 1;
  if (m < 8) return 0;
  double alpha = 0.0;
  int cnt = 0;
  for (Eigen::Index j = 0; j < S.cols(); ++j) {
    const auto s = S.col(j);
    const double T0 = s.head(n - 1).squaredNorm();
    const double T1 = s.tail(n - 1).squaredNorm();
    const double G1 = s.tail(n - 1).dot(s.head(n - 1));
    const double G2 = s.segment(2, n - 2).dot(s.head(n - 2));
    const double aj = a(j);
    double c0 = T1 - 2.0 * aj * G1 + aj * aj * T0;
    double c1 = (G1 - s(1) * s(0)) - aj * G2 - aj * (T0 - s(0) * s(0)) + aj * aj * (G1 - s(n - 1) * s(n - 2));
    if (c0 < 1e-8 * T1) {
      const Eigen::VectorXd e = s.tail(m) - aj * s.head(m);
      c0 = e.squaredNorm();
      c1 = e.tail(m - 1).dot(e.head(m - 1));
    }
    if (!(c0 > 0.0)) continue;
    const double r = std::clamp(c1 / c0, -0.97, 0.97);
    alpha += 4.0 * r * r / (std::pow(1.0 - r, 2) * std::pow(1.0 + r, 2));
    ++cnt;
  }
  if (cnt == 0) return 0;
  alpha /= cnt;
  const double bw = 1.1447 * std::cbrt(alpha * static_cast<double>(m));
  return static_cast<int>(std::min<double>(std::floor(bw), static_cast<double>(m / 4)));
}

}  // namespace

CovarianceReport scoreCovariance(const Eigen::Ref<const Eigen::MatrixXd>& S,
                                 const Eigen::Ref<const Eigen::Matrix<double, 6, Eigen::Dynamic>>& R,
                                 const Eigen::MatrixXd& bread_inverse, int max_lag) {
  const Eigen::Index n = S.rows();
  const Eigen::Index k = S.cols();
  if (R.cols() != n || bread_inverse.rows() != k || bread_inverse.cols() != k) {
    throw std::invalid_argument("scoreCovariance: sizes scores " + std::to_string(n) + "x" + std::to_string(k) +
                                ", residual 6x" + std::to_string(R.cols()) + ", bread " +
                                std::to_string(bread_inverse.rows()) + "x" + std::to_string(bread_inverse.cols()) +
                                " do not match");
  }
  const Eigen::Index rows = 6 * n;
  CovarianceReport out;
  const int residual_lag = automaticBandwidth(R, &out.residual_ar1);
  out.score_ar1 = Eigen::VectorXd::Zero(k);
  Eigen::MatrixXd omega;
  if (max_lag >= 0) {
    out.lag = static_cast<int>(std::min<Eigen::Index>(max_lag, std::max<Eigen::Index>(0, n - 1)));
    omega = neweyWest(S, out.lag);
  } else if (n < 16) {
    out.lag = residual_lag;
    omega = neweyWest(S, out.lag);
  } else {
    // Prewhitened (Andrews-Monahan 1992, per score component): a_j from the lag-1 regression of
    // column j, e_i = s_i - a o s_(i-1), Newey-West of e with its own automatic bandwidth, then
    // recoloured: Omega = D^-1 Omega_e D^-1, D = diag(1 - a_j). The filter takes out most of the
    // correlation, which the Bartlett kernel alone underestimates by 10-20 % at lag-1 correlation 0.6.
    for (Eigen::Index j = 0; j < k; ++j) {
      const double den = S.col(j).head(n - 1).squaredNorm();
      const double a = den > 0.0 ? S.col(j).tail(n - 1).dot(S.col(j).head(n - 1)) / den : 0.0;
      out.score_ar1(j) = std::clamp(a, -0.9, 0.97);
    }
    const Eigen::VectorXd& a = out.score_ar1;
    out.lag = whitenedBandwidth(S, a);
    const Eigen::VectorXd d = (Eigen::VectorXd::Ones(k) - a).cwiseInverse();
    const Eigen::MatrixXd omega_e =
        neweyWest(n - 1, k, out.lag, [&S, &a](Eigen::Index first, Eigen::Index count, auto dest) {
          dest += S.middleRows(first + 1, count) - S.middleRows(first, count) * a.asDiagonal();
        });
    omega = d.asDiagonal() * omega_e * d.asDiagonal();
    omega *= static_cast<double>(n) / static_cast<double>(n - 1);
  }
  const double dof = static_cast<double>(rows - k);
  const double correction = dof > 0.0 ? static_cast<double>(rows) / dof : 1.0;
  out.covariance = correction * bread_inverse * omega * bread_inverse.transpose();
  out.covariance = 0.5 * (out.covariance + out.covariance.transpose());
  // Inflation against the classical covariance.
  const double sigma2 = dof > 0.0 ? R.squaredNorm() / dof : 0.0;
  double sum = 0.0;
  int cnt = 0;
  for (Eigen::Index j = 0; j < k; ++j) {
    const double classical = sigma2 * bread_inverse(j, j);
    if (classical > 0.0) {
      sum += out.covariance(j, j) / classical;
      ++cnt;
    }
  }
  out.variance_inflation = cnt > 0 ? sum / cnt : 1.0;
  return out;
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
  const Eigen::Map<const Eigen::Matrix<double, 6, Eigen::Dynamic>> R(r.data(), 6, n);
  // Scores, one row per sample.
  Eigen::MatrixXd S(n, k);
  for (Eigen::Index i = 0; i < n; ++i) S.row(i) = r.segment<6>(6 * i).transpose() * J.middleRows(6 * i, 6);
  return scoreCovariance(S, R, inverse_gram, max_lag);
}

}  // namespace ftid::identify
