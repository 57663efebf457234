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

/// The warning when some axis has a significant peak beyond the motion band, naming the axes,
/// frequencies and ratios; "" otherwise. Its reading follows `dynamics` (the search on the same
/// model): a resonance or a filter of the reading, unless the search ran and found none, when it is
/// a disturbance of its own (pushes, contacts, vibration).
/// `missing`: the effect the analysis recommends adding to the model whose residual this is ("" when
/// none, or when the spectrum is of the path's last model): a peak is then first that effect's to
/// explain, and the warning says so instead of calling it a disturbance or the reading's dynamics.
std::string spectrumWarning(const ResidualSpectrum& s, const DynamicsCheck& dynamics, const std::string& missing = "");

/// The text block: the rule, then one line per axis ("" when there is no spectrum).
std::string spectrumText(const ResidualSpectrum& s);

/// JSON "spectrum" (per axis f_hz, psd, noise_psd, peak; the set-up and the rule) and
/// "autocorrelation" (lag step, per axis r and the noise model's), numbers at 4 significant digits.
Json spectrumJson(const ResidualSpectrum& s);
Json autocorrelationJson(const ResidualSpectrum& s);
/// JSON "dynamics": the search for a filter of the reading (ftid/lab/dynamics.hpp).
Json dynamicsJson(const DynamicsCheck& d);
/// The warning when the search found one ("" otherwise).
std::string dynamicsWarning(const DynamicsCheck& d, const Vec6& noise_floor);

}  // namespace ftid::lab::detail
