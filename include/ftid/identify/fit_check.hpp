#pragma once
// Does the identified model explain the data? (docs/identification.md, "Does the model fit?")
//
// The identification is repeated on K contiguous time blocks left out in turn (the same method on
// the rest), each block is predicted by the fit that did not see it, and the held-out residual RMS
// per axis is compared with the noise floor (ftid/identify/noise.hpp). Above 1.2x on any axis the
// model misses something: one warning line names the `ftid analyze` command that finds what.
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "ftid/identify/noise.hpp"
#include "ftid/identify/fit_parameters.hpp"
#include "ftid/identify/saturation.hpp"

namespace ftid::identify {

struct FitCheck {
  NoiseFloor noise;
  Vec6 heldout_rms = Vec6::Zero();       ///< [N, Nm]
  /// heldout_rms / noise floor per axis; NaN when the noise floor is not observable.
  Vec6 residual_to_noise = Vec6::Zero();
  int folds = 0;
  int glitches = 0;                      ///< isolated spikes left out of the held-out sums
  /// Saturation (issue 22): axes at a range limit, their samples left out of the fit and the
  /// held-out sums (saturation.hpp); filled by identifyContextsChecked.
  std::vector<SaturatedAxis> saturation;
  std::vector<std::string> warnings;     ///< one line each
};

/// The identification to repeat on the training blocks.
using IdentifyFn = std::function<ParameterSet(const std::vector<SampleContext>&)>;

/// `analyze_command` is what the warning tells the user to run. `noise_std`: the data sheet's
/// noise (else estimated). Throws what `identify` throws only if the full-data identification
/// would; a fold that cannot be identified is skipped (and said in a warning).
FitCheck checkFit(const std::vector<SampleContext>& ctx, const IdentifyFn& identify, const std::string& analyze_command,
                  const std::optional<Vec6>& noise_std = std::nullopt, int folds = 5);

/// Text lines: the held-out residual against the noise floor per axis, then the warnings.
std::string formatFitCheck(const FitCheck& check);

/// JSON object (ftid/fileio/json_text.hpp policy): "noise_floor", "noise_method", "heldout_rms",
/// "residual_to_noise", "glitches", "saturation" ([{axis, side, value, count, fraction, times, source}]), "warnings".
std::string fitCheckJson(const FitCheck& check);

/// The `ftid identify --json` object: toJson(set)'s keys followed by fitCheckJson(check)'s
/// (docs/identification.md "Outputs").
std::string identificationJson(const ParameterSet& set, const FitCheck& check);

}  // namespace ftid::identify
