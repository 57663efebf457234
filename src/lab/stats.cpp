// Noise-floor estimate and the chi-square tail used by the significance test (analyze.hpp).
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "ftid/common/error.hpp"
#include "ftid/lab/analyze.hpp"

namespace ftid::lab {

double estimateNoiseStd(const std::vector<double>& x) {
  if (x.size() < 8) throw DataError("noise floor: need at least 8 samples, got " + std::to_string(x.size()));
  std::vector<double> d(x.size() - 4);
  for (std::size_t i = 0; i + 4 < x.size(); ++i) {
    d[i] = std::abs(x[i] - 4.0 * x[i + 1] + 6.0 * x[i + 2] - 4.0 * x[i + 3] + x[i + 4]);
  }
  const auto mid = d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2);
  std::nth_element(d.begin(), mid, d.end());
  const double mad = *mid;  // median of |d| (d has zero median for white noise)
  return 1.482602218505602 * mad / std::sqrt(70.0);
}

namespace {

/// Regularized lower incomplete gamma P(a, x) by its series (x < a + 1).
double gammaSeries(double a, double x) {
  double sum = 1.0 / a;
  double term = sum;
  for (int n = 1; n < 10000; ++n) {
    term *= x / (a + n);
    sum += term;
    if (std::abs(term) < std::abs(sum) * 1e-16) break;
  }
  return sum * std::exp(-x + a * std::log(x) - std::lgamma(a));
}

/// Regularized upper incomplete gamma Q(a, x) by its continued fraction (x >= a + 1), Lentz.
double gammaContinuedFraction(double a, double x) {
  const double tiny = 1e-300;
  double b = x + 1.0 - a;
  double c = 1.0 / tiny;
  double d = 1.0 / b;
  double h = d;
  for (int i = 1; i < 10000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1.0) < 1e-16) break;
  }
  return std::exp(-x + a * std::log(x) - std::lgamma(a)) * h;
}

}  // namespace

double chiSquareSurvival(double statistic, double dof) {
  if (!(dof > 0.0)) return 1.0;
  if (!(statistic > 0.0)) return 1.0;
  if (!std::isfinite(statistic)) return 0.0;
  const double a = 0.5 * dof;
  const double x = 0.5 * statistic;
  if (x < a + 1.0) return std::clamp(1.0 - gammaSeries(a, x), 0.0, 1.0);
  return std::clamp(gammaContinuedFraction(a, x), 0.0, 1.0);
}

namespace {

/// E_z[survival(statistic exp(-s z))], z standard normal: the trapezoid rule over |z| <= 8 in
/// steps of 0.05 (the integrand is smooth; the normal weights sum to 1 within 1e-12).
template <class Survival>
double averageOverScale(const Survival& survival, double statistic, double log_scale_sd) {
  constexpr double kStep = 0.05;
  constexpr int kHalf = 160;
  double p = 0.0, wsum = 0.0;
  for (int i = -kHalf; i <= kHalf; ++i) {
    const double z = i * kStep;
    const double w = std::exp(-0.5 * z * z);
    p += w * survival(statistic * std::exp(-log_scale_sd * z));
    wsum += w;
  }
  return std::clamp(p / wsum, 0.0, 1.0);
}

double normalUpperTail(double z) { return 0.5 * std::erfc(z / std::sqrt(2.0)); }

}  // namespace

double chiSquareSurvivalUncertainScale(double statistic, double dof, double log_scale_sd) {
  if (!(log_scale_sd > 0.0)) return chiSquareSurvival(statistic, dof);
  if (!(dof > 0.0) || !(statistic > 0.0)) return 1.0;
  if (!std::isfinite(statistic)) return 0.0;
  return averageOverScale([dof](double x) { return chiSquareSurvival(x, dof); }, statistic, log_scale_sd);
}

double weightedChiSquareSurvival(const std::vector<double>& lambda, double x) {
  if (std::isnan(x)) return 1.0;
  double mean = 0.0, var = 0.0, lmax = 0.0, lmin = 0.0;
  for (double l : lambda) {
    mean += l;
    var += 2.0 * l * l;
    lmax = std::max(lmax, l);
    lmin = std::min(lmin, l);
  }
  if (!(lmax > 0.0)) return 1.0;  // no chance of a positive value: nothing to measure against
  if (x == std::numeric_limits<double>::infinity()) return 0.0;
  const double sd = std::sqrt(var);
  // Near and below the mean the decision is never at stake: the normal approximation.
  if (x <= mean + 0.5 * sd) return std::clamp(normalUpperTail((x - mean) / sd), 0.0, 1.0);
  // Saddlepoint (Lugannani-Rice) in the upper tail: K(t) = -1/2 sum ln(1 - 2 l t) on
  // (1 / (2 lmin), 1 / (2 lmax)); K'(t) = x is solved for t in (0, 1 / (2 lmax)) by bisection.
  const auto dK = [&lambda](double t) {
    double d = 0.0;
    for (double l : lambda) d += l / (1.0 - 2.0 * l * t);
    return d;
  };
  double lo = 0.0, hi = 0.5 / lmax;
  for (int it = 0; it < 200 && hi - lo > 1e-15 * hi; ++it) {
    const double mid = 0.5 * (lo + hi);
    (dK(mid) < x ? lo : hi) = mid;
  }
  const double t = 0.5 * (lo + hi);
  double K = 0.0, d2k = 0.0;
  for (double l : lambda) {
    const double a = 1.0 - 2.0 * l * t;
    K += -0.5 * std::log(a);
    d2k += 2.0 * l * l / (a * a);
  }
  const double w = std::sqrt(std::max(0.0, 2.0 * (t * x - K)));
  const double v = t * std::sqrt(d2k);
  if (!(w > 1e-6) || !(v > 0.0)) return std::clamp(normalUpperTail((x - mean) / sd), 0.0, 1.0);
  const double density = std::exp(-0.5 * w * w) / std::sqrt(2.0 * 3.141592653589793);
  return std::clamp(normalUpperTail(w) + density * (1.0 / v - 1.0 / w), 0.0, 1.0);
}

double weightedChiSquareSurvivalUncertainScale(const std::vector<double>& lambda, double x, double log_scale_sd) {
  if (!(log_scale_sd > 0.0) || !(x > 0.0) || !std::isfinite(x)) return weightedChiSquareSurvival(lambda, x);
  return averageOverScale([&lambda](double y) { return weightedChiSquareSurvival(lambda, y); }, x, log_scale_sd);
}

}  // namespace ftid::lab
