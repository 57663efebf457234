#pragma once
// The residual's spectrum in the laboratory's reports (issue 22, sensor and mount dynamics):
// computed from an analysis, as text lines and as JSON. Private to ftid_lab.
#include <string>
#include <vector>

#include "ftid/fileio/json_text.hpp"
#include "ftid/lab/analyze.hpp"
#include "ftid/lab/spectrum.hpp"

namespace ftid::lab::detail {

/// The spectrum of the last model's held-out residual (final_residual with --explain, else the
/// starting model's), the motion band from its prediction, the noise model of the analysis.
/// `excluded` marks the evaluated samples left out as glitches (their residual counts as 0);
/// colour_scale_sd: colourScaleSd of the noise estimate.
ResidualSpectrum spectrumOfAnalysis(const AnalysisResult& r, const std::vector<char>& excluded,
                                    double colour_scale_sd);

/// The text block: the rule, then one line per axis ("" when there is no spectrum).
std::string spectrumText(const ResidualSpectrum& s);

/// JSON "spectrum" (per axis f_hz, psd, noise_psd, peak; the set-up and the rule) and
/// "autocorrelation" (lag step, per axis r and the noise model's), numbers at 4 significant digits.
Json spectrumJson(const ResidualSpectrum& s);
Json autocorrelationJson(const ResidualSpectrum& s);

}  // namespace ftid::lab::detail
