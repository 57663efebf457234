// The residual's spectrum (include/ftid/lab/spectrum.hpp) on synthetic series: the FFT against a
// plain DFT, Parseval as an independent identity, the AR(1) noise PSD's integral, the peak rule's
// false-alarm rate on white and coloured noise, a sinusoid buried in noise at a known SNR, the
// runs at gaps, the autocorrelation and the motion band. Milliseconds; seeded.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <random>
#include <vector>

#include "ftid/common/error.hpp"
#include "ftid/lab/spectrum.hpp"

namespace ftid {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDt = 0.008;  // 125 Hz, the cell's rate

std::vector<double> whiteNoise(std::mt19937_64& rng, int n, double sd) {
  std::normal_distribution<double> g(0.0, sd);
  std::vector<double> x(static_cast<std::size_t>(n));
  for (double& v : x) v = g(rng);
  return x;
}

std::vector<double> ar1Noise(std::mt19937_64& rng, int n, double sd, double phi) {
  std::normal_distribution<double> g(0.0, sd * std::sqrt(1.0 - phi * phi));
  std::vector<double> x(static_cast<std::size_t>(n));
  double v = g(rng) / std::sqrt(1.0 - phi * phi);
  for (double& xi : x) {
    xi = v;
    v = phi * v + g(rng);
  }
  return x;
}

std::vector<double> noisePsd(const std::vector<double>& f, double sd, double phi) {
  std::vector<double> out;
  for (const double fk : f) out.push_back(lab::ar1NoisePsd(sd, phi, fk, kDt));
  return out;
}

std::vector<double> freqs(int segment) {
  std::vector<double> f;
  for (int k = 0; k <= segment / 2; ++k) f.push_back(k / (segment * kDt));
  return f;
}

TEST(Spectrum, FftMatchesAPlainDft) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> g;
  const int n = 64;
  std::vector<std::complex<double>> x(n);
  for (auto& v : x) v = {g(rng), g(rng)};
  auto y = x;
  lab::fft(y);
  for (int k = 0; k < n; ++k) {
    std::complex<double> s = 0.0;
    for (int j = 0; j < n; ++j) s += x[static_cast<std::size_t>(j)] * std::polar(1.0, -2.0 * kPi * k * j / n);
    EXPECT_NEAR(std::abs(y[static_cast<std::size_t>(k)] - s), 0.0, 1e-9) << k;
  }
  std::vector<std::complex<double>> bad(48);
  EXPECT_THROW(lab::fft(bad), Error);
}

TEST(Spectrum, ParsevalThePsdIntegratesToTheWindowedMeanSquare) {
  // One segment: sum_k PSD_k df equals sum (w (x - mean))^2 / sum w^2, computed in time.
  std::mt19937_64 rng(12);
  const int len = 256;
  auto x = whiteNoise(rng, len, 0.7);
  for (int i = 0; i < len; ++i) x[static_cast<std::size_t>(i)] += 0.3 * std::sin(0.1 * i);
  int k_used = 0;
  const auto psd = lab::welchPsd({x}, kDt, len, &k_used);
  ASSERT_EQ(k_used, 1);
  double integral = 0.0;
  for (const double p : psd) integral += p / (len * kDt);
  double mean = 0.0, num = 0.0, w2 = 0.0;
  for (const double v : x) mean += v / len;
  for (int i = 0; i < len; ++i) {
    const double w = 0.5 - 0.5 * std::cos(2.0 * kPi * i / len);
    num += std::pow(w * (x[static_cast<std::size_t>(i)] - mean), 2);
    w2 += w * w;
  }
  EXPECT_NEAR(integral, num / w2, 1e-9 * num / w2);
  // Many segments of white noise: the integral is the variance (within its sampling spread).
  const auto y = whiteNoise(rng, 64 * len, 0.7);
  const auto psd2 = lab::welchPsd({y}, kDt, len, &k_used);
  EXPECT_EQ(k_used, 64);
  double integral2 = 0.0;
  for (const double p : psd2) integral2 += p / (len * kDt);
  EXPECT_NEAR(integral2, 0.49, 0.49 * 0.03);
}

TEST(Spectrum, Ar1NoisePsdIntegratesToTheVarianceAndMatchesTheSeriesPsd) {
  for (const double phi : {0.0, 0.5, 0.9}) {
    double integral = 0.0;
    const int m = 20000;
    const double fn = 0.5 / kDt;
    for (int k = 0; k < m; ++k) integral += lab::ar1NoisePsd(0.3, phi, (k + 0.5) * fn / m, kDt) * fn / m;
    EXPECT_NEAR(integral, 0.09, 1e-6) << phi;
  }
  // A simulated AR(1) series' Welch PSD against the formula, averaged over bands of 8 bins.
  std::mt19937_64 rng(13);
  const auto x = ar1Noise(rng, 400 * 128, 0.3, 0.8);
  int k_used = 0;
  const auto psd = lab::welchPsd({x}, kDt, 128, &k_used);
  const auto model = noisePsd(freqs(128), 0.3, 0.8);
  // From bin 3: bins 1-2 lie within the Hann main lobe of DC and lose power to each segment's
  // mean removal (conservative for the peak rule).
  for (int b = 3; b + 8 < 64; b += 8) {
    double m = 0.0, e = 0.0;
    for (int k = b; k < b + 8; ++k) {
      m += psd[static_cast<std::size_t>(k)];
      e += model[static_cast<std::size_t>(k)];
    }
    EXPECT_NEAR(m / e, 1.0, 0.06) << "band from bin " << b;
  }
}

/// Peaks called on `seeds` series of noise analysed against the noise model (sd, phi_model).
int falsePeaks(int seeds, double phi_true, double phi_model, double alpha, std::uint64_t seed0) {
  const int segment = 128;
  int count = 0;
  for (int s = 0; s < seeds; ++s) {
    std::mt19937_64 rng(seed0 + static_cast<std::uint64_t>(s));
    // Two runs, as a log with a gap: 10 s in all.
    const auto a = ar1Noise(rng, 700, 0.05, phi_true), b = ar1Noise(rng, 550, 0.05, phi_true);
    int k_used = 0;
    const auto psd = lab::welchPsd({a, b}, kDt, segment, &k_used);
    const auto pk = lab::findPeak(psd, noisePsd(freqs(segment), 0.05, phi_model), freqs(segment), 2.0 * k_used,
                                  alpha, 0.0);
    count += pk.significant ? 1 : 0;
  }
  return count;
}

TEST(Spectrum, WhiteNoiseGivesNoSignificantPeakOverFiftySeeds) {
  EXPECT_EQ(falsePeaks(50, 0.0, 0.0, 1e-3, 1000), 0);
}

TEST(Spectrum, FalseAlarmRateIsWithinTheStatedLevel) {
  // At alpha = 0.05 the rule (Bonferroni over the bins) calls a peak on at most 5 % of noise
  // series: 400 series, at most 20 expected; allow the binomial spread (3 sd = 13).
  const int white = falsePeaks(400, 0.0, 0.0, 0.05, 2000);
  EXPECT_LE(white, 33);
  const int coloured = falsePeaks(400, 0.8, 0.8, 0.05, 3000);
  EXPECT_LE(coloured, 33);
  // Not vacuous: the same rule at a level of 0.5 does call peaks on noise.
  EXPECT_GE(falsePeaks(400, 0.0, 0.0, 0.5, 2000), 40);
}

TEST(Spectrum, ColouredNoiseAgainstAWhiteModelIsAPeak) {
  // The noise model's colour matters: AR(1) noise at 0.8 read as white piles up at low frequency.
  EXPECT_GE(falsePeaks(20, 0.8, 0.0, 1e-3, 4000), 19);
}

TEST(Spectrum, ASinusoidBuriedInNoiseIsFoundAtItsFrequency) {
  // SNR: amplitude A = 0.6 sigma. On a bin centre the Hann PSD of A sin is A^2 dt L / 3 against
  // the noise's 2 dt sigma^2: ratio A^2 L / (6 sigma^2) = 7.7 at L = 128.
  const int segment = 128;
  const double sd = 0.05, amp = 0.6 * sd;
  for (const double f0 : {24.0 / (segment * kDt), 3.0}) {
    std::mt19937_64 rng(5);
    auto x = whiteNoise(rng, 1250, sd);
    for (int i = 0; i < 1250; ++i) x[static_cast<std::size_t>(i)] += amp * std::sin(2.0 * kPi * f0 * i * kDt + 0.3);
    int k_used = 0;
    const auto psd = lab::welchPsd({x}, kDt, segment, &k_used);
    const auto pk = lab::findPeak(psd, noisePsd(freqs(segment), sd, 0.0), freqs(segment), 2.0 * k_used, 1e-3, 0.0);
    EXPECT_TRUE(pk.significant) << f0;
    EXPECT_NEAR(pk.f_hz, f0, 0.5 / (segment * kDt)) << f0;  // within half a bin
    if (f0 != 3.0) {
      EXPECT_NEAR(pk.ratio, amp * amp * segment / (6.0 * sd * sd), 0.35 * 7.7);
    }
  }
}

TEST(Spectrum, RunsSplitAtGapsAndBackwardTime) {
  std::vector<double> t;
  for (int i = 0; i < 10; ++i) t.push_back(i * kDt);
  for (int i = 0; i < 5; ++i) t.push_back(1.0 + i * kDt);  // a gap
  for (int i = 0; i < 4; ++i) t.push_back(i * kDt);        // a second log, time going back
  const auto runs = lab::contiguousRuns(t);
  ASSERT_EQ(runs.size(), 3U);
  EXPECT_EQ(runs[0], std::make_pair(0, 10));
  EXPECT_EQ(runs[1], std::make_pair(10, 15));
  EXPECT_EQ(runs[2], std::make_pair(15, 19));
}

TEST(Spectrum, AutocorrelationOfWhiteAr1AndASinusoid) {
  std::mt19937_64 rng(14);
  const auto w = lab::autocorrelation({whiteNoise(rng, 20000, 1.0)}, 5);
  EXPECT_DOUBLE_EQ(w[0], 1.0);
  for (int k = 1; k <= 5; ++k) EXPECT_NEAR(w[static_cast<std::size_t>(k)], 0.0, 0.03);
  const auto r = lab::autocorrelation({ar1Noise(rng, 20000, 1.0, 0.7)}, 3);
  EXPECT_NEAR(r[1], 0.7, 0.03);
  EXPECT_NEAR(r[2], 0.49, 0.04);
  std::vector<double> s(5000);
  for (std::size_t i = 0; i < s.size(); ++i) s[i] = std::sin(2.0 * kPi * 3.0 * static_cast<double>(i) * kDt);
  const auto c = lab::autocorrelation({s}, 10);
  for (int k = 0; k <= 10; ++k) EXPECT_NEAR(c[static_cast<std::size_t>(k)], std::cos(2.0 * kPi * 3.0 * k * kDt), 0.01);
}

TEST(Spectrum, ResidualSpectrumMarksTheMotionBandAndAPeakBeyondIt) {
  // Modelled wrench: 0.4 and 0.8 Hz motion; residual: noise plus a 3 Hz ring on fz only.
  const int n = 1250;
  std::vector<double> t;
  Eigen::Matrix<double, 6, Eigen::Dynamic> res(6, n), mod(6, n);
  std::mt19937_64 rng(15);
  std::normal_distribution<double> g(0.0, 0.05);
  for (int i = 0; i < n; ++i) {
    const double ti = i * kDt;
    t.push_back(ti);
    for (int a = 0; a < 6; ++a) {
      mod(a, i) = 5.0 * std::sin(2.0 * kPi * 0.4 * ti + a) + 2.0 * std::sin(2.0 * kPi * 0.8 * ti);
      res(a, i) = g(rng) + (a == 2 ? 0.1 * std::sin(2.0 * kPi * 3.0 * ti) : 0.0);
    }
  }
  lab::SpectrumInput in;
  in.t = &t;
  in.residual = &res;
  in.modelled = &mod;
  in.noise_std = Vec6::Constant(0.05);
  in.log_scale_sd = lab::noiseLevelScaleSd(n, 0.0, false);
  const auto s = lab::residualSpectrum(in);
  ASSERT_TRUE(s.valid);
  EXPECT_EQ(s.segment, 128);
  EXPECT_EQ(s.segments, 9);
  EXPECT_GT(s.motion_band_hz, 0.7);
  EXPECT_LT(s.motion_band_hz, 2.5);
  EXPECT_TRUE(s.axes[2].peak.significant);
  EXPECT_FALSE(s.axes[2].peak.in_motion_band);
  EXPECT_NEAR(s.axes[2].peak.f_hz, 3.0, 0.3);
  for (int a : {0, 1, 3, 4, 5}) EXPECT_FALSE(s.axes[static_cast<std::size_t>(a)].peak.significant) << a;
  EXPECT_NE(lab::spectrumLine(s, 2).find("beyond the motion band"), std::string::npos) << lab::spectrumLine(s, 2);
  EXPECT_NE(lab::spectrumLine(s, 0).find("no peak beyond chance"), std::string::npos);
  // Not observable noise: shown, never called a peak.
  in.noise_known = false;
  EXPECT_FALSE(lab::residualSpectrum(in).axes[2].peak.significant);
}

}  // namespace
}  // namespace ftid

namespace ftid {
namespace {

TEST(Spectrum, ALongLogKeepsTheOutputBounded) {
  // 100,000 samples: segments of at most 1,024 samples, so at most 513 frequencies per axis and
  // 101 autocorrelation lags, whatever the log's length.
  const int n = 100000;
  std::vector<double> t;
  Eigen::Matrix<double, 6, Eigen::Dynamic> res(6, n);
  std::mt19937_64 rng(16);
  std::normal_distribution<double> g(0.0, 0.05);
  for (int i = 0; i < n; ++i) {
    t.push_back(i * 0.001);
    for (int a = 0; a < 6; ++a) res(a, i) = g(rng);
  }
  lab::SpectrumInput in;
  in.t = &t;
  in.residual = &res;
  in.noise_std = Vec6::Constant(0.05);
  const auto s = lab::residualSpectrum(in);
  ASSERT_TRUE(s.valid);
  EXPECT_EQ(s.segment, 1024);
  EXPECT_EQ(s.segments, n / 1024);
  EXPECT_EQ(s.f_hz.size(), 513U);
  EXPECT_EQ(s.axes[0].acf.size(), 101U);
  for (const auto& ax : s.axes) EXPECT_FALSE(ax.peak.significant);
}

}  // namespace
}  // namespace ftid
