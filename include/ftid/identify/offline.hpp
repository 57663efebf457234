#pragma once
// Offline pipelines behind `ftid identify` and `ftid compensate`: log file in, parameters or a
// compensated CSV out. The CLI only parses arguments and calls these.
#include <functional>
#include <string>
#include <vector>

#include <optional>

#include "ftid/samples/context.hpp"
#include "ftid/identify/fit_check.hpp"
#include "ftid/identify/fit_parameters.hpp"
#include "ftid/identify/setup_check.hpp"

namespace ftid::identify {

using ProgressFn = std::function<void(const std::string& line)>;

/// The model offline `ftid identify` fits when given neither --model nor --method: the cell's.
inline constexpr const char* kDefaultModel = "paper+rigid_body";
/// The default on a static log (no motion: the rotational terms cannot be seen).
inline constexpr const char* kDefaultStaticModel = "paper";

struct IdentifyRequest {
  std::string log_path;
  std::string method = "dynamic";  ///< paper method: "static" or "dynamic" (ignored with `model`)
  std::string model;               ///< non-empty: general fit of this model (e.g. "paper+rigid_body")
  /// `model` is the default (kDefaultModel): on a static log kDefaultStaticModel is fitted instead.
  bool model_is_default = false;
  std::string robot_urdf;          ///< URDF of the robot (config/ur10.urdf)
  samples::ContextOptions context; ///< sensor mount
  ProgressFn progress;             ///< optional progress lines
  std::optional<Vec6> noise_std;   ///< data-sheet noise for the fit check (else estimated)
  double max_delay_s = 1.0;        ///< models with sensor_delay: search range of the delay [s]
  /// Optional: gets the notes of the fit (a better tilt minimum found from another start, an
  /// undecided tilt; tilt_start.hpp). identifyLogFileChecked adds them to the check's warnings.
  std::vector<std::string>* notes = nullptr;
};

/// Reads the log, builds the contexts, identifies. Throws DataError (bad log), ConfigError (bad
/// robot/model/method), IdentificationError (data do not determine the parameters).
ParameterSet identifyLogFile(const IdentifyRequest& request);

/// The identification of `request` (method or model) on contexts.
ParameterSet identifyContexts(const std::vector<SampleContext>& samples, const IdentifyRequest& request);

/// identifyLogFile plus, with `check`, the held-out residual against the noise floor (fit_check.hpp).
/// The fit leaves out the glitches of a first fit's residual (robust_data.hpp), then checks on the
/// rest; the notes of the fit (tilt_start.hpp) and the glitches are the first of check.warnings.
struct CheckedIdentification {
  ParameterSet set;
  FitCheck check;
  int glitches = 0;  ///< samples left out of the fit as glitches
  SetupDiagnosis setup;  ///< with `check`: the set-up diagnosis before the fit (setup_check.hpp)
};
CheckedIdentification identifyLogFileChecked(const IdentifyRequest& request, bool check = true);
/// The same on contexts already built (request.log_path names them in messages).
CheckedIdentification identifyContextsChecked(const samples::ContextSet& contexts, const IdentifyRequest& request,
                                              bool check = true);

/// Human-readable table: parameter, value, std, unit; residual RMS per axis; condition number.
std::string formatParameterTable(const ParameterSet& set);

}  // namespace ftid::identify
