// The residual's spectrum and autocorrelation (include/ftid/lab/spectrum.hpp, docs/analyze.md
// "The residual's spectrum"): Welch PSD with its own radix-2 FFT, the AR(1) noise model's PSD,
// the peak rule, the motion band and the autocorrelation.
#include "ftid/lab/spectrum.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "ftid/common/error.hpp"
#include "ftid/lab/analyze.hpp"

namespace ftid::lab {

namespace {

constexpr double kPi = 3.14159265358979323846;

bool isPowerOfTwo(std::size_t n) { return n > 0 && (n & (n - 1)) == 0; }

void bitReverse(std::vector<std::complex<double>>& x) {
  const std::size_t n = x.size();
  for (std::size_t i = 1, j = 0; i < n; ++i) {
    std::size_t bit = n >> 1;
    for (; (j & bit) != 0; bit >>= 1) j ^= bit;
    j ^= bit;
    if (i < j) std::swap(x[i], x[j]);
  }
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

/// The longest power-of-two segment in [min, max] that gives `target` segments (else the shortest
/// that gives at least one; 0 when none fits).
int chooseSegment(const std::vector<std::vector<double>>& runs, const SpectrumOptions& o) {
  auto count = [&](int len) {
    int k = 0;
    for (const auto& r : runs) k += static_cast<int>(r.size()) / len;
    return k;
  };
  int best = 0;
  for (int len = o.min_segment; len <= o.max_segment; len *= 2) {
    if (count(len) >= o.target_segments) best = len;
  }
  if (best == 0 && count(o.min_segment) >= 1) best = o.min_segment;
  return best;
}

/// Cuts row `axis` of m into the runs; excluded samples become 0.
std::vector<std::vector<double>> cut(const Eigen::Matrix<double, 6, Eigen::Dynamic>& m, int axis,
                                     const std::vector<std::pair<int, int>>& runs, const std::vector<char>& excluded) {
  std::vector<std::vector<double>> out;
  for (const auto& [b, e] : runs) {
    std::vector<double> x(static_cast<std::size_t>(e - b));
    for (int i = b; i < e; ++i) {
      const bool skip = !excluded.empty() && excluded[static_cast<std::size_t>(i)] != 0;
      x[static_cast<std::size_t>(i - b)] = skip ? 0.0 : m(axis, i);
    }
    out.push_back(std::move(x));
  }
  return out;
}

/// The frequency below which `fraction` of the modelled wrench's (non-DC) power lies, each axis
/// normalised by its own power and the six averaged.
double motionBand(const std::vector<std::vector<double>>& psd_per_axis, const std::vector<double>& f_hz,
                  double fraction) {
  const std::size_t n = f_hz.size();
  std::vector<double> sum(n, 0.0);
  for (const auto& p : psd_per_axis) {
    double total = 0.0;
    for (std::size_t k = 1; k < n; ++k) total += p[k];
    if (!(total > 0.0)) continue;
    for (std::size_t k = 1; k < n; ++k) sum[k] += p[k] / total;
  }
  double total = 0.0;
  for (std::size_t k = 1; k < n; ++k) total += sum[k];
  if (!(total > 0.0)) return 0.0;
  double acc = 0.0;
  for (std::size_t k = 1; k < n; ++k) {
    acc += sum[k];
    if (acc >= fraction * total) return f_hz[k];
  }
  return f_hz.back();
}

std::string ratioText(double r) {
  char b[32];
  std::snprintf(b, sizeof b, r >= 10.0 ? "%.0fx" : "%.1fx", r);
  return b;
}

}  // namespace

void fft(std::vector<std::complex<double>>& x) {
  const std::size_t n = x.size();
  if (!isPowerOfTwo(n)) throw ConfigError("fft: size " + std::to_string(n) + " is not a power of two");
  bitReverse(x);
  for (std::size_t len = 2; len <= n; len <<= 1) {
    const double ang = -2.0 * kPi / static_cast<double>(len);
    const std::complex<double> wl(std::cos(ang), std::sin(ang));
    for (std::size_t i = 0; i < n; i += len) {
      std::complex<double> w(1.0, 0.0);
      for (std::size_t j = 0; j < len / 2; ++j) {
        const std::complex<double> u = x[i + j], v = x[i + j + len / 2] * w;
        x[i + j] = u + v;
        x[i + j + len / 2] = u - v;
        w *= wl;
      }
    }
  }
}

std::vector<std::pair<int, int>> contiguousRuns(const std::vector<double>& t) {
  std::vector<std::pair<int, int>> runs;
  const int n = static_cast<int>(t.size());
  if (n < 2) return runs;
  std::vector<double> steps;
  for (int i = 1; i < n; ++i) {
    const double d = t[static_cast<std::size_t>(i)] - t[static_cast<std::size_t>(i - 1)];
    if (d > 0.0) steps.push_back(d);
  }
  const double dt = median(steps);
  int begin = 0;
  for (int i = 1; i <= n; ++i) {
    bool brk = i == n;
    if (!brk) {
      const double d = t[static_cast<std::size_t>(i)] - t[static_cast<std::size_t>(i - 1)];
      brk = !(d > 0.0) || d > 1.5 * dt;
    }
    if (brk) {
      if (i - begin >= 2) runs.emplace_back(begin, i);
      begin = i;
    }
  }
  return runs;
}

std::vector<double> welchPsd(const std::vector<std::vector<double>>& runs, double dt_s, int segment,
                             int* segments_used) {
  const auto len = static_cast<std::size_t>(segment);
  std::vector<double> w(len), psd(len / 2 + 1, 0.0);
  double w2 = 0.0;
  for (std::size_t i = 0; i < len; ++i) {
    w[i] = 0.5 - 0.5 * std::cos(2.0 * kPi * static_cast<double>(i) / static_cast<double>(len));  // periodic Hann
    w2 += w[i] * w[i];
  }
  int k_used = 0;
  std::vector<std::complex<double>> buf(len);
  for (const auto& r : runs) {
    for (std::size_t s = 0; s + len <= r.size(); s += len) {
      double mean = 0.0;
      for (std::size_t i = 0; i < len; ++i) mean += r[s + i] / static_cast<double>(len);
      for (std::size_t i = 0; i < len; ++i) buf[i] = {(r[s + i] - mean) * w[i], 0.0};
      fft(buf);
      for (std::size_t k = 0; k < psd.size(); ++k) {
        const double c = (k == 0 || k == len / 2) ? 1.0 : 2.0;
        psd[k] += c * std::norm(buf[k]) * dt_s / w2;
      }
      ++k_used;
    }
  }
  if (k_used > 0) {
    for (double& p : psd) p /= k_used;
  }
  if (segments_used != nullptr) *segments_used = k_used;
  return psd;
}

double ar1NoisePsd(double std, double phi, double f_hz, double dt_s) {
  const double c = std::cos(2.0 * kPi * f_hz * dt_s);
  return 2.0 * dt_s * std * std * (1.0 - phi * phi) / (1.0 - 2.0 * phi * c + phi * phi);
}

SpectralPeak findPeak(const std::vector<double>& psd, const std::vector<double>& noise_psd,
                      const std::vector<double>& f_hz, double dof, double alpha, double log_scale_sd,
                      double f_min_hz) {
  SpectralPeak pk;
  const std::size_t n = psd.size();
  if (n < 3) return pk;
  std::size_t best = 0;
  auto ratio = [&](std::size_t k) { return noise_psd[k] > 0.0 ? psd[k] / noise_psd[k] : 0.0; };
  for (std::size_t k = 1; k + 1 < n; ++k) {
    if (f_hz[k] > f_min_hz && (best == 0 || ratio(k) > ratio(best))) best = k;
  }
  if (best == 0) return pk;
  pk.ratio = ratio(best);
  pk.f_hz = f_hz[best];
  // The bin's own frequency (within half the resolution of the true one): an interpolation
  // between neighbours is biased where the peak sits on the slope of a larger one.
  const double p = chiSquareSurvivalUncertainScale(dof * pk.ratio, dof, log_scale_sd);
  pk.p_family = std::min(1.0, static_cast<double>(n - 2) * p);
  pk.significant = pk.p_family < alpha;
  return pk;
}

std::vector<double> autocorrelation(const std::vector<std::vector<double>>& runs, int max_lag) {
  std::vector<double> acf(static_cast<std::size_t>(std::max(0, max_lag) + 1), 0.0);
  for (const auto& r : runs) {
    double mean = 0.0;
    for (const double v : r) mean += v / static_cast<double>(r.size());
    for (std::size_t lag = 0; lag < acf.size() && lag < r.size(); ++lag) {
      double s = 0.0;
      for (std::size_t i = 0; i + lag < r.size(); ++i) s += (r[i] - mean) * (r[i + lag] - mean);
      acf[lag] += s;
    }
  }
  const double r0 = acf[0];
  for (double& v : acf) v = r0 > 0.0 ? v / r0 : 0.0;
  return acf;
}

double noiseLevelScaleSd(int n, double colour_scale_sd, bool declared_level) {
  if (declared_level) return 0.0;
  const double sampling = 3.8 / std::sqrt(static_cast<double>(std::max(1, n)));
  return std::sqrt(sampling * sampling + colour_scale_sd * colour_scale_sd);
}

ResidualSpectrum residualSpectrum(const SpectrumInput& in, const SpectrumOptions& options) {
  ResidualSpectrum s;
  s.alpha = options.alpha;
  s.noise_known = in.noise_known;
  s.log_scale_sd = in.log_scale_sd;
  const auto& t = *in.t;
  const auto runs = contiguousRuns(t);
  std::vector<double> steps;
  for (const auto& [b, e] : runs) {
    for (int i = b + 1; i < e; ++i) steps.push_back(t[static_cast<std::size_t>(i)] - t[static_cast<std::size_t>(i - 1)]);
  }
  s.dt_s = median(steps);
  std::array<std::vector<std::vector<double>>, 6> res;
  for (int a = 0; a < 6; ++a) res[static_cast<std::size_t>(a)] = cut(*in.residual, a, runs, in.excluded);
  s.segment = chooseSegment(res[0], options);
  if (s.segment == 0 || !(s.dt_s > 0.0)) {
    s.note = "too few consecutive samples for a spectrum (need " + std::to_string(options.min_segment) + ")";
    return s;
  }
  const int n_freq = s.segment / 2 + 1;
  for (int k = 0; k < n_freq; ++k) s.f_hz.push_back(k / (s.segment * s.dt_s));
  int max_run = 0;
  for (const auto& [b, e] : runs) max_run = std::max(max_run, e - b);
  const int lags = std::min(options.max_lags, max_run - 1);
  std::vector<std::vector<double>> motion_psd;
  for (int a = 0; a < 6; ++a) {
    AxisSpectrum& ax = s.axes[static_cast<std::size_t>(a)];
    ax.psd = welchPsd(res[static_cast<std::size_t>(a)], s.dt_s, s.segment, &s.segments);
    for (const double f : s.f_hz) ax.noise_psd.push_back(ar1NoisePsd(in.noise_std(a), in.noise_ar1(a), f, s.dt_s));
    ax.acf = autocorrelation(res[static_cast<std::size_t>(a)], lags);
    for (int k = 0; k <= lags; ++k) ax.noise_acf.push_back(std::pow(in.noise_ar1(a), k));
    if (in.modelled != nullptr) {
      int unused = 0;
      motion_psd.push_back(welchPsd(cut(*in.modelled, a, runs, {}), s.dt_s, s.segment, &unused));
    }
  }
  s.dof = 2.0 * s.segments;
  s.bins_tested = n_freq - 2;
  s.motion_band_hz = motion_psd.empty() ? 0.0 : motionBand(motion_psd, s.f_hz, options.motion_fraction);
  for (auto& ax : s.axes) {
    ax.peak = findPeak(ax.psd, ax.noise_psd, s.f_hz, s.dof, options.alpha, s.log_scale_sd);
    ax.peak.significant = ax.peak.significant && in.noise_known;
    ax.peak.in_motion_band = ax.peak.f_hz <= s.motion_band_hz;
    ax.beyond = findPeak(ax.psd, ax.noise_psd, s.f_hz, s.dof, options.alpha, s.log_scale_sd, s.motion_band_hz);
    ax.beyond.significant = ax.beyond.significant && in.noise_known;
  }
  s.valid = true;
  return s;
}

std::string spectrumRule(const ResidualSpectrum& s) {
  if (!s.valid) return "residual spectrum: " + s.note;
  char b[400];
  std::snprintf(b, sizeof b,
                "residual spectrum (Welch: %d Hann segments of %d samples, resolution %.3g Hz, up to %.4g Hz): a "
                "peak counts when min(1, %d x P(chi2(%g) >= %g x ratio)) < %.2g (the ratio: residual PSD / the noise "
                "model's)",
                s.segments, s.segment, s.f_hz.size() > 1 ? s.f_hz[1] : 0.0, s.f_hz.empty() ? 0.0 : s.f_hz.back(),
                s.bins_tested, s.dof, s.dof, s.alpha);
  return b;
}

std::string spectrumLine(const ResidualSpectrum& s, int axis) {
  if (!s.valid) return "";
  const AxisSpectrum& ax = s.axes[static_cast<std::size_t>(axis)];
  char band[64];
  std::snprintf(band, sizeof band, "motion band 0-%.3g Hz", s.motion_band_hz);
  std::string out = std::string(kWrenchAxisNames[axis]) + " residual: ";
  char b[200];
  if (ax.peak.significant) {
    std::snprintf(b, sizeof b, "peak %.3g Hz at %s the noise level", ax.peak.f_hz, ratioText(ax.peak.ratio).c_str());
    out += b;
    out += ax.peak.in_motion_band ? std::string(" (inside the ") + band + ": the model misses part of the motion)"
                                  : std::string(" (beyond the ") + band + ": a resonance or a filter)";
    if (ax.peak.in_motion_band && ax.beyond.significant) {
      std::snprintf(b, sizeof b, "; beyond the band: peak %.3g Hz at %s (a resonance or a filter)", ax.beyond.f_hz,
                    ratioText(ax.beyond.ratio).c_str());
      out += b;
    }
  } else {
    std::snprintf(b, sizeof b, "no peak beyond chance (largest %s at %.3g Hz); %s", ratioText(ax.peak.ratio).c_str(),
                  ax.peak.f_hz, band);
    out += b;
  }
  if (ax.acf.size() > 1) {
    std::snprintf(b, sizeof b, "; lag-1 autocorrelation %.2f (noise %.2f)", ax.acf[1], ax.noise_acf[1]);
    out += b;
  }
  return out;
}

}  // namespace ftid::lab
