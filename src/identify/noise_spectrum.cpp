// refineNoiseFloor: the noise's AR(1) model from the spectrum of a model residual
// (include/ftid/identify/noise.hpp, docs/identification.md); the first estimate, from the
// readings, is in noise.cpp.
#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "ftid/identify/noise.hpp"
#include "noise_internal.hpp"

namespace ftid::identify {

using internal::ar1FromDifferences;
using internal::differenceStdOf;
using internal::fmt;
using internal::kColouredPhi;

namespace {

constexpr int kWelchSegment = 256;
constexpr double kHomogeneityChi2 = 20.515;  // chi-square(5) quantile 0.999

/// Welch periodogram of the segments (Hann window, 50 % overlap, segment length L), normalised so
/// that white noise of variance s^2 gives s^2 at every frequency. Frequencies k / L cycles a
/// sample, k = 0..L/2. Returns an empty vector if no segment is long enough.
std::vector<double> welch(const std::vector<std::vector<double>>& segments, int L, int* averaged = nullptr) {
  std::vector<double> P(static_cast<std::size_t>(L / 2 + 1), 0.0);
  std::vector<double> w(static_cast<std::size_t>(L));
  double wsum = 0.0;
  for (int j = 0; j < L; ++j) {
    w[static_cast<std::size_t>(j)] = 0.5 - 0.5 * std::cos(2.0 * 3.141592653589793 * (j + 0.5) / L);
    wsum += w[static_cast<std::size_t>(j)] * w[static_cast<std::size_t>(j)];
  }
  std::vector<double> c(static_cast<std::size_t>(L)), sn(static_cast<std::size_t>(L));
  for (int j = 0; j < L; ++j) {
    c[static_cast<std::size_t>(j)] = std::cos(2.0 * 3.141592653589793 * j / L);
    sn[static_cast<std::size_t>(j)] = std::sin(2.0 * 3.141592653589793 * j / L);
  }
  int count = 0;
  std::vector<double> x(static_cast<std::size_t>(L));
  for (const auto& seg : segments) {
    for (std::size_t start = 0; start + static_cast<std::size_t>(L) <= seg.size(); start += static_cast<std::size_t>(L / 2)) {
      double mean = 0.0;
      for (int j = 0; j < L; ++j) mean += seg[start + static_cast<std::size_t>(j)] / L;
      for (int j = 0; j < L; ++j) x[static_cast<std::size_t>(j)] = (seg[start + static_cast<std::size_t>(j)] - mean) * w[static_cast<std::size_t>(j)];
      for (int k = 0; k <= L / 2; ++k) {
        double re = 0.0, im = 0.0;
        std::size_t m = 0;  // (k j) mod L
        for (int j = 0; j < L; ++j) {
          re += x[static_cast<std::size_t>(j)] * c[m];
          im -= x[static_cast<std::size_t>(j)] * sn[m];
          m += static_cast<std::size_t>(k);
          if (m >= static_cast<std::size_t>(L)) m -= static_cast<std::size_t>(L);
        }
        P[static_cast<std::size_t>(k)] += (re * re + im * im) / wsum;
      }
      ++count;
    }
  }
  if (averaged != nullptr) *averaged = count;
  if (count == 0) return {};
  for (double& v : P) v /= count;
  return P;
}

/// Marginal std of AR(1) noise with coefficient phi from the Welch spectrum over [k_lo, L/2):
/// s_e^2 = mean(P / shape), std = s_e / sqrt(1 - phi^2).
double spectralLevel(const std::vector<double>& P, int L, int k_lo, double phi) {
  const int k_hi = L / 2;
  double s2 = 0.0;
  for (int k = k_lo; k < k_hi; ++k) {
    const double wk = 2.0 * 3.141592653589793 * k / L;
    s2 += P[static_cast<std::size_t>(k)] * (1.0 - 2.0 * phi * std::cos(wk) + phi * phi) / (k_hi - k_lo);
  }
  return std::sqrt(s2 / (1.0 - phi * phi));
}

constexpr int kPhiGrid = 495;  // phi = 0, 0.002, ..., 0.99

/// Profiled Whittle cost of AR(1) noise on the spectrum P over bins [k_lo, L/2) for every phi of
/// the grid (phi = 0.002 g): nb log(mean_k(P_k / g_k)) + sum_k log g_k with
/// g_k = 1 / (1 - 2 phi cos w_k + phi^2) (the innovation variance profiled out). The Nyquist bin
/// is excluded (real-valued, half the averaging). Empty if fewer than 12 bins.
std::vector<double> whittleCost(const std::vector<double>& P, int L, int k_lo) {
  const int k_hi = L / 2;
  if (k_hi - k_lo < 12) return {};
  const int nb = k_hi - k_lo;
  std::vector<double> cost(kPhiGrid + 1);
  for (int g = 0; g <= kPhiGrid; ++g) {
    const double phi = g * 2e-3;
    double mean = 0.0, logg = 0.0;
    for (int k = k_lo; k < k_hi; ++k) {
      const double wk = 2.0 * 3.141592653589793 * k / L;
      const double inv_shape = 1.0 - 2.0 * phi * std::cos(wk) + phi * phi;
      mean += P[static_cast<std::size_t>(k)] * inv_shape / nb;
      logg -= std::log(inv_shape);
    }
    cost[static_cast<std::size_t>(g)] = nb * std::log(std::max(mean, 1e-300)) + logg;
  }
  return cost;
}

/// Standard error of the phi minimising `cost` (grid index g) when the log-likelihood is
/// -info x cost: 1 / sqrt(info x curvature), the curvature over +-0.01 (inside the grid).
double curvatureStd(const std::vector<double>& cost, int g, double info) {
  constexpr int kStep = 5;
  const int c = std::clamp(g, kStep, kPhiGrid - kStep);
  const double h = kStep * 2e-3;
  const double curv = (cost[static_cast<std::size_t>(c + kStep)] - 2.0 * cost[static_cast<std::size_t>(c)] +
                       cost[static_cast<std::size_t>(c - kStep)]) / (h * h);
  return curv > 0.0 ? 1.0 / std::sqrt(info * curv) : 1.0;
}

/// Grid index of the smallest cost.
int argmin(const std::vector<double>& cost) {
  return static_cast<int>(std::min_element(cost.begin(), cost.end()) - cost.begin());
}

/// The boundaries of the residual's segments: their start indices (or {0}), then n.
std::vector<int> segmentBounds(const std::vector<int>& segment_starts, int n) {
  std::vector<int> starts = segment_starts.empty() ? std::vector<int>{0} : segment_starts;
  starts.push_back(n);
  return starts;
}

/// The spectrum's segment length L: Welch with 256-sample segments when there are at least four of
/// them; a shorter run gets one Hann-tapered periodogram of its longest segment (even length),
/// whose finer frequency resolution lets the band above the motion start lower and hold many more
/// bins (a 4 s run at 125 Hz: the band from 3-4 Hz instead of 21 Hz with 64-sample segments).
int spectrumLength(const std::vector<int>& starts, int n) {
  int longest = 0;
  for (std::size_t s = 0; s + 1 < starts.size(); ++s) longest = std::max(longest, starts[s + 1] - starts[s]);
  return n >= 4 * kWelchSegment ? kWelchSegment : longest - longest % 2;
}

/// The first bin of the noise's band, k_lo = max(2, 3 k_motion + 2): 99.9 % of the joint-velocity
/// power lies below bin k_motion, and the model error is made of the motion (and its products: a
/// few times its frequencies), so the noise is fitted above 3 k_motion. 2 if L < 2 or no motion.
int noiseBandStart(const std::vector<SampleContext>& ctx, const std::vector<int>& starts, int L) {
  int k_lo = 2;
  if (L < 2) return k_lo;
  std::vector<double> total;
  for (int j = 0; j < kNumJoints; ++j) {
    std::vector<std::vector<double>> segs;
    for (std::size_t s = 0; s + 1 < starts.size(); ++s) {
      std::vector<double> seg;
      for (int i = starts[s]; i < starts[s + 1]; ++i) seg.push_back(ctx[static_cast<std::size_t>(i)].qd(j));
      segs.push_back(std::move(seg));
    }
    const auto P = welch(segs, L);
    if (total.empty()) total.assign(P.size(), 0.0);
    for (std::size_t k = 0; k < P.size() && k < total.size(); ++k) total[k] += P[k];
  }
  double sum = 0.0;
  for (std::size_t k = 1; k < total.size(); ++k) sum += total[k];
  double acc = 0.0;
  int k_motion = 1;
  for (std::size_t k = 1; k < total.size(); ++k) {
    acc += total[k];
    if (acc >= 0.999 * sum) {
      k_motion = static_cast<int>(k);
      break;
    }
  }
  if (sum > 0.0) k_lo = std::max(k_lo, 3 * k_motion + 2);
  return k_lo;
}

/// 1 for each of the first n samples the glitch test (detectOutliers at 6 sigma) flags, else 0.
std::vector<char> glitchMask(const Eigen::Matrix<double, 6, Eigen::Dynamic>& residual, int n,
                             const std::vector<int>& segment_starts) {
  const Outliers glitches = detectOutliers(residual.leftCols(n), true, 6.0, segment_starts);
  std::vector<char> bad(static_cast<std::size_t>(n), 0);
  for (int i : glitches.samples) bad[static_cast<std::size_t>(i)] = 1;
  return bad;
}

/// Axis a of the residual cut into its segments (bounds: segmentBounds), with each run of glitches
/// (bad) replaced by the line between its nearest good neighbours: glitches would add a white floor
/// to the spectrum.
std::vector<std::vector<double>> bridgedSegments(
    const Eigen::Matrix<double, 6, Eigen::Dynamic>& residual, int a, const std::vector<int>& starts,
    const std::vector<char>& bad) {
  std::vector<std::vector<double>> segs;
  for (std::size_t s = 0; s + 1 < starts.size(); ++s) {
    std::vector<double> seg;
    for (int i = starts[s]; i < starts[s + 1]; ++i) seg.push_back(residual(a, i));
    segs.push_back(std::move(seg));
  }
  for (std::size_t s = 0; s + 1 < starts.size(); ++s) {
    auto& seg = segs[s];
    const int len = static_cast<int>(seg.size());
    int j = 0;
    while (j < len) {
      if (!bad[static_cast<std::size_t>(starts[s] + j)]) {
        ++j;
        continue;
      }
      int e = j;
      while (e < len && bad[static_cast<std::size_t>(starts[s] + e)]) ++e;
      const double left = j > 0 ? seg[static_cast<std::size_t>(j - 1)] : (e < len ? seg[static_cast<std::size_t>(e)] : 0.0);
      const double right = e < len ? seg[static_cast<std::size_t>(e)] : left;
      for (int k = j; k < e; ++k) {
        const double w = static_cast<double>(k - j + 1) / static_cast<double>(e - j + 1);
        seg[static_cast<std::size_t>(k)] = (1.0 - w) * left + w * right;
      }
      j = e;
    }
  }
  return segs;
}

/// The residual per axis, cut into segments with its glitches bridged, and its spectra.
struct ResidualSpectra {
  std::array<std::vector<std::vector<double>>, 6> segs;
  std::array<std::vector<double>, 6> P, cost;  ///< Welch spectrum and Whittle cost per axis
  int averaged = 0;                            ///< segments averaged in a spectrum
  bool spectra = false;                        ///< every axis has a spectrum and a cost
};

/// The residual's segments per axis (bridgedSegments) and, while every axis so far has one, the
/// spectrum (Welch over segments of length L) and the Whittle cost of each phi of the grid from
/// bin k_lo; spectra = false when L < 2 or some axis has too few bins.
ResidualSpectra residualSpectra(const Eigen::Matrix<double, 6, Eigen::Dynamic>& residual,
                                const std::vector<int>& starts, const std::vector<char>& bad,
                                int L, int k_lo) {
  ResidualSpectra r;
  r.spectra = L >= 2;
  for (int a = 0; a < 6; ++a) {
    r.segs[a] = bridgedSegments(residual, a, starts, bad);
    if (r.spectra) {
      r.P[a] = welch(r.segs[a], L, &r.averaged);
      if (!r.P[a].empty()) r.cost[a] = whittleCost(r.P[a], L, k_lo);
    }
    r.spectra = r.spectra && !r.cost[a].empty();
  }
  return r;
}

/// The AR(1) coefficient per axis on the grid and its standard error; common: one phi for all six.
struct Ar1Fit {
  Vec6 phi = Vec6::Zero();
  Vec6 phi_std = Vec6::Zero();
  bool common = false;
};

/// One sensor filter colours all six axes alike (each axis is a fixed combination of the same
/// filtered gauges): phi is fitted jointly (six times the data) unless the axes' own fits differ
/// beyond chance (likelihood ratio 2 info (joint - sum of own minima), 5 degrees of freedom, level
/// 0.001).
Ar1Fit fitAr1(const std::array<std::vector<double>, 6>& cost, int averaged) {
  Ar1Fit fit;
  // The cost is a log-likelihood in units of `info`: averaged segments (Hann, 50 % overlap:
  // 1.056 segments' worth of overlap each) sharpen it, the taper's correlation of neighbouring
  // bins blunts it (Hann: sum w^4 L / (sum w^2)^2 = 35/18; Dahlhaus 1988).
  const double info = (averaged > 1 ? averaged / 1.0556 : 1.0) / (35.0 / 18.0);
  std::vector<double> joint(kPhiGrid + 1, 0.0);
  double separate = 0.0;
  for (int a = 0; a < 6; ++a) {
    const int g = argmin(cost[a]);
    fit.phi(a) = g * 2e-3;
    fit.phi_std(a) = curvatureStd(cost[a], g, info);
    separate += cost[a][static_cast<std::size_t>(g)];
    for (int k = 0; k <= kPhiGrid; ++k) joint[static_cast<std::size_t>(k)] += cost[a][static_cast<std::size_t>(k)];
  }
  const int gc = argmin(joint);
  const double lr = 2.0 * info * (joint[static_cast<std::size_t>(gc)] - separate);
  if (lr < kHomogeneityChi2) {
    fit.common = true;
    fit.phi.setConstant(gc * 2e-3);
    fit.phi_std.setConstant(curvatureStd(joint, gc, info));
  }
  return fit;
}

/// Sets each axis's ar1 (below kColouredPhi: 0, white), ar1_std and std: the spectral level above
/// the motion's band for the fitted phi, or without a spectrum the residual's own 4th differences.
void setAxisFloors(NoiseFloor& f, const ResidualSpectra& r, const Ar1Fit& fit, int L, int k_lo) {
  for (int a = 0; a < 6; ++a) {
    double ph = r.spectra ? fit.phi(a) : ar1FromDifferences(r.segs[a]);  // too short for a spectrum
    if (ph < kColouredPhi) ph = 0.0;
    f.ar1(a) = ph;
    f.ar1_std(a) = ph > 0.0 ? fit.phi_std(a) : 0.0;
    // White: today's estimator; coloured: the spectral level above the motion's band.
    if (r.spectra) {
      f.std(a) = spectralLevel(r.P[a], L, k_lo, ph);  // phi = 0: the flat level of white noise
    } else {
      // The residual's own 4th differences, not the readings' (f.difference_std): a reading
      // clipped flat on most samples has a zero spread there although the kept samples are noisy.
      f.std(a) = differenceStdOf(r.segs[a], f.difference_std(a)) * std::sqrt(70.0 / differenceVarianceFactor(ph, 1));
    }
  }
}

/// The refined floor's method (coloured if any axis has ar1 > 0, else white) and detail, in words.
void describeRefinedFloor(NoiseFloor& f, bool common, bool spectra) {
  if (f.ar1.maxCoeff() > 0.0) {
    f.method = NoiseMethod::kColoured;
    f.detail = "coloured (low-pass filtered) noise: lag-1 correlation " +
               (common ? fmt(f.ar1.maxCoeff()) + " +- " + fmt(f.ar1_std.maxCoeff()) + " common to the six axes"
                       : "up to " + fmt(f.ar1.maxCoeff())) +
               (spectra ? " (AR(1) fitted to the residual's spectrum above the motion's band)"
                        : " (from the residual's differences)");
  } else {
    f.method = NoiseMethod::kWhite;
    f.detail = spectra ? "white noise: flat spectrum of the residual above the motion's band"
                       : "white noise: robust spread of the 4th-order differences of the residual";
  }
}

}  // namespace

void refineNoiseFloor(NoiseFloor& f, const Eigen::Matrix<double, 6, Eigen::Dynamic>& residual,
                      const std::vector<SampleContext>& ctx, const std::vector<int>& segment_starts) {
  if (f.method != NoiseMethod::kWhite && f.method != NoiseMethod::kColoured) return;
  const int n = static_cast<int>(std::min<Eigen::Index>(residual.cols(), static_cast<Eigen::Index>(ctx.size())));
  const std::vector<int> starts = segmentBounds(segment_starts, n);
  const int L = spectrumLength(starts, n);
  const int k_lo = noiseBandStart(ctx, starts, L);
  const std::vector<char> bad = glitchMask(residual, n, segment_starts);
  const ResidualSpectra spectra = residualSpectra(residual, starts, bad, L, k_lo);
  const Ar1Fit fit = spectra.spectra ? fitAr1(spectra.cost, spectra.averaged) : Ar1Fit{};
  setAxisFloors(f, spectra, fit, L, k_lo);
  describeRefinedFloor(f, fit.common, spectra.spectra);
}

}  // namespace ftid::identify
