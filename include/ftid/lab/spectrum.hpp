#pragma once
// The residual's spectrum and autocorrelation (docs/analyze.md, "The residual's spectrum"): per
// axis, a Welch power spectral density of the held-out residual against the noise model's own
// spectrum (the estimated noise floor with its AR(1) colour), the band where the modelled wrench
// has its power (the motion), and one rule for calling a peak: the largest ratio of the residual's
// PSD to the noise's over the tested frequencies counts only when its chi-square tail probability,
// times the number of frequencies tested, is below alpha (so white noise at the estimated level
// gives a false peak on an axis with probability at most alpha).
//
// Offline (not real-time). Units: forces N, torques Nm; PSD one-sided in unit^2/Hz.
#include <array>
#include <complex>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "ftid/common/types.hpp"

namespace ftid::lab {

struct SpectrumOptions {
  int max_segment = 1024;   ///< samples per Welch segment at most (a power of two): bounds the cost and the output
  int min_segment = 32;     ///< at least (below: no spectrum)
  int target_segments = 8;  ///< the longest segment that still gives this many (averaging vs resolution)
  double alpha = 1e-3;      ///< family-wise level of the peak rule (per axis)
  int max_lags = 100;       ///< autocorrelation lags (each one sample)
  double motion_fraction = 0.99;  ///< the motion band holds this fraction of the modelled wrench's power
};

struct SpectralPeak {
  double f_hz = 0.0;        ///< frequency of the bin with the largest PSD ratio (+- half the resolution)
  double ratio = 0.0;       ///< residual PSD / noise PSD there (1 = the noise level)
  double p_family = 1.0;    ///< min(1, bins tested x its chi-square tail probability)
  bool significant = false; ///< p_family < alpha: a peak beyond chance
  bool in_motion_band = false;
};

struct AxisSpectrum {
  std::vector<double> psd;        ///< Welch PSD of the residual at ResidualSpectrum::f_hz [unit^2/Hz]
  std::vector<double> noise_psd;  ///< the noise model's PSD at the same frequencies
  SpectralPeak peak;              ///< the largest ratio over all tested frequencies
  /// The largest ratio above the motion band (a resonance or a filter shows there even when the
  /// misfit of the motion itself is larger), judged with the same family (all tested bins).
  SpectralPeak beyond;
  std::vector<double> acf;        ///< residual autocorrelation at lags 0, 1, .. (acf[0] = 1)
  std::vector<double> noise_acf;  ///< the noise model's (ar1^k)
};

struct ResidualSpectrum {
  bool valid = false;
  std::string note;               ///< why not valid, or what the noise level means
  bool noise_known = true;        ///< false: the noise floor is not observable (no peak claims)
  double dt_s = 0.0;              ///< sampling interval (median)
  int segment = 0;                ///< samples per Welch segment (Hann window, no overlap)
  int segments = 0;               ///< segments averaged (K)
  double dof = 0.0;               ///< chi-square degrees of freedom of each PSD value (2 K)
  int bins_tested = 0;            ///< frequencies searched for a peak (DC and Nyquist excluded)
  double alpha = 0.0;
  double log_scale_sd = 0.0;      ///< uncertainty of the estimated noise level (sd of ln sigma^2)
  double motion_band_hz = 0.0;    ///< the motion's band is 0 .. this
  std::vector<double> f_hz;       ///< 0 .. Nyquist in steps of 1 / (segment dt)
  std::array<AxisSpectrum, 6> axes;
};

/// In-place radix-2 FFT (size a power of two; throws ConfigError otherwise): X_k = sum x_n e^{-2 pi i k n / N}.
void fft(std::vector<std::complex<double>>& x);

/// Runs of consecutive samples [begin, end): a new run starts where the time step exceeds 1.5x
/// the median step (a gap, a new log) or is not positive (time going back). Runs shorter than 2
/// are dropped.
std::vector<std::pair<int, int>> contiguousRuns(const std::vector<double>& t);

/// Welch PSD of the runs (each a series): Hann segments of `segment` samples, without overlap,
/// each with its mean removed; one-sided, PSD_k = c |X_k|^2 / (fs sum w^2) with c = 2 except at
/// DC and Nyquist, averaged over segments. Returns the PSD (segment / 2 + 1 values) and sets
/// *segments_used (0: no segment fits).
std::vector<double> welchPsd(const std::vector<std::vector<double>>& runs, double dt_s, int segment,
                             int* segments_used);

/// One-sided PSD of AR(1) noise of marginal std `std` and lag-1 correlation `phi` at f [Hz]:
/// 2 dt std^2 (1 - phi^2) / (1 - 2 phi cos(2 pi f dt) + phi^2); it integrates to std^2 over 0 .. fs/2.
double ar1NoisePsd(double std, double phi, double f_hz, double dt_s);

/// The peak rule on one axis: the bin k in 1 .. n-2 (only those above f_min_hz) with the largest
/// psd/noise_psd; under the noise model each PSD value is noise_psd chi2(dof)/dof, so
/// p = P(chi2(dof) >= dof ratio) (with the noise level's own uncertainty log_scale_sd,
/// chiSquareSurvivalUncertainScale) and p_family = min(1, (n - 2) p) (all tested bins, whatever
/// f_min_hz); significant when p_family < alpha. No bin above f_min_hz: ratio 0, not significant.
SpectralPeak findPeak(const std::vector<double>& psd, const std::vector<double>& noise_psd,
                      const std::vector<double>& f_hz, double dof, double alpha, double log_scale_sd,
                      double f_min_hz = 0.0);

/// Autocorrelation at lags 0..max_lag over pairs within each run (each run's mean removed):
/// r_k = sum x_i x_{i+k} / sum x_i^2 (the biased estimator; r_0 = 1, or 0 for an all-zero input).
std::vector<double> autocorrelation(const std::vector<std::vector<double>>& runs, int max_lag);

/// Uncertainty (sd of ln sigma^2) of a noise level estimated from n samples by the robust 4th
/// differences (MAD efficiency and the differences' correlation: 3.8 / sqrt(n)), combined with the
/// colour's (colour_scale_sd); 0 when the level is declared (data sheet: declared_level).
double noiseLevelScaleSd(int n, double colour_scale_sd, bool declared_level);

/// The whole diagnosis: runs from t, the residual's and the modelled wrench's PSD per axis, the
/// noise model's PSD, the peak rule, the motion band and the autocorrelation. `excluded` (may be
/// empty) marks samples (glitches) whose residual is replaced by 0. noise_known = false: the
/// spectrum is shown but no peak is called significant.
struct SpectrumInput {
  const std::vector<double>* t = nullptr;
  const Eigen::Matrix<double, 6, Eigen::Dynamic>* residual = nullptr;
  const Eigen::Matrix<double, 6, Eigen::Dynamic>* modelled = nullptr;  ///< may be null: no motion band
  std::vector<char> excluded;
  Vec6 noise_std = Vec6::Zero();
  Vec6 noise_ar1 = Vec6::Zero();
  bool noise_known = true;
  double log_scale_sd = 0.0;
};
ResidualSpectrum residualSpectrum(const SpectrumInput& in, const SpectrumOptions& options = {});

/// One line per axis for the text summary, e.g. "fz residual: peak 2.97 Hz at 18x the noise level
/// (beyond the motion band 0-1.2 Hz: a resonance or a filter); lag-1 autocorrelation 0.93 (noise 0.00)".
std::string spectrumLine(const ResidualSpectrum& s, int axis);
/// The rule and the set-up in one line (segments, resolution, alpha).
std::string spectrumRule(const ResidualSpectrum& s);

}  // namespace ftid::lab
