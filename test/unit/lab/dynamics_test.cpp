// The reading's filters of the laboratory's dynamics search (include/ftid/lab/dynamics.hpp)
// against independent formulations: a steady sinusoid's amplitude and phase against the analytic
// frequency response, and a step's response against RK4 integration of the ODE at 20x the rate.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <vector>

#include "ftid/lab/dynamics.hpp"

namespace ftid {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDt = 0.008;

/// Amplitude and phase of x (after the transient) against sin(2 pi f t): least squares on sin, cos.
std::complex<double> response(const std::vector<double>& x, double f) {
  double ss = 0, sc = 0, cc = 0, xs = 0, xc = 0;
  for (std::size_t i = x.size() / 2; i < x.size(); ++i) {
    const double s = std::sin(2 * kPi * f * static_cast<double>(i) * kDt), c = std::cos(2 * kPi * f * static_cast<double>(i) * kDt);
    ss += s * s;
    sc += s * c;
    cc += c * c;
    xs += x[i] * s;
    xc += x[i] * c;
  }
  const double det = ss * cc - sc * sc;
  const double a = (xs * cc - xc * sc) / det, b = (xc * ss - xs * sc) / det;  // x = a sin + b cos
  return {a, b};  // a + i b = H (sin -> Im e^{iwt}: H = a + i b)
}

std::vector<double> sine(double f, int n) {
  std::vector<double> x(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) x[static_cast<std::size_t>(i)] = std::sin(2 * kPi * f * i * kDt);
  return x;
}

TEST(DynamicsFilter, SecondOrderMatchesTheAnalyticResponseAtResonanceAndBelow) {
  const double fn = 3.0, zeta = 0.1;
  for (const double f : {0.5, 1.0, 3.0}) {
    auto x = sine(f, 6000);
    lab::secondOrderFilter(x, fn, zeta, kDt);
    const std::complex<double> s(0.0, 2 * kPi * f), w(2 * kPi * fn, 0.0);
    const std::complex<double> h = w * w / (s * s + 2.0 * zeta * w * s + w * w);
    const std::complex<double> got = response(x, f);
    // Tustin warps frequencies other than f_n by (w dt)^2 / 12 at most: 1 % at 3 Hz, 125 Hz.
    EXPECT_NEAR(std::abs(got), std::abs(h), 0.01 * std::abs(h)) << f;
    EXPECT_NEAR(std::arg(got), std::arg(h), 0.01) << f;
  }
}

TEST(DynamicsFilter, FirstOrderMatchesTheAnalyticResponse) {
  const double fc = 5.0;
  // Tustin warps frequencies other than f_c: (pi f dt)^2 / 3 of the frequency, 2 % at 10 Hz.
  for (const double f : {1.0, 5.0, 10.0}) {
    auto x = sine(f, 4000);
    lab::firstOrderFilter(x, fc, kDt);
    const std::complex<double> h = 1.0 / (1.0 + std::complex<double>(0.0, f / fc));
    const std::complex<double> got = response(x, f);
    EXPECT_NEAR(std::abs(got), std::abs(h), 0.025 * std::abs(h)) << f;
    EXPECT_NEAR(std::arg(got), std::arg(h), 0.025) << f;
  }
}

TEST(DynamicsFilter, StepResponseMatchesRk4OfTheOde) {
  // At rest at 0, then a unit step: the filter's samples against RK4 at dt / 20.
  const double fn = 3.0, zeta = 0.1, w = 2 * kPi * fn;
  std::vector<double> x(400, 1.0);
  x[0] = 0.0;
  lab::secondOrderFilter(x, fn, zeta, kDt);
  double y = 0.0, v = 0.0;
  const int sub = 20;
  const double h = kDt / sub;
  auto acc = [&](double yy, double vv, double u) { return w * w * (u - yy) - 2 * zeta * w * vv; };
  double max_err = 0.0;
  for (std::size_t i = 1; i < x.size(); ++i) {
    for (int k = 0; k < sub; ++k) {
      // The input steps at sample 0 -> 1; Tustin sees it as a ramp over the first step.
      const double u0 = i == 1 ? static_cast<double>(k) / sub : 1.0, u1 = i == 1 ? static_cast<double>(k + 1) / sub : 1.0;
      const double um = 0.5 * (u0 + u1);
      const double k1y = v, k1v = acc(y, v, u0);
      const double k2y = v + 0.5 * h * k1v, k2v = acc(y + 0.5 * h * k1y, v + 0.5 * h * k1v, um);
      const double k3y = v + 0.5 * h * k2v, k3v = acc(y + 0.5 * h * k2y, v + 0.5 * h * k2v, um);
      const double k4y = v + h * k3v, k4v = acc(y + h * k3y, v + h * k3v, u1);
      y += h / 6 * (k1y + 2 * k2y + 2 * k3y + k4y);
      v += h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v);
    }
    max_err = std::max(max_err, std::abs(x[i] - y));
  }
  EXPECT_LT(max_err, 0.03);  // of a response that overshoots to 1.73
  EXPECT_NEAR(x.back(), 1.0, 0.01);  // DC gain 1
}

}  // namespace
}  // namespace ftid
