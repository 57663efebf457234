#pragma once
// Offline pipelines behind `ftid identify` and `ftid compensate`: log file in, parameters or a
// compensated CSV out. The CLI only parses arguments and calls these.
#include <functional>
#include <cstddef>
#include <string>
#include <vector>

#include <optional>

#include "ftid/samples/context.hpp"
#include "ftid/identify/fit_check.hpp"
#include "ftid/identify/fit_parameters.hpp"
#include "ftid/identify/imu.hpp"
#include "ftid/identify/imu_fusion.hpp"
#include "ftid/identify/physical_check.hpp"
#include "ftid/identify/saturation.hpp"
#include "ftid/identify/setup_check.hpp"

namespace ftid::identify {

using ProgressFn = std::function<void(const std::string& line)>;

/// The model offline `ftid identify` fits when given neither --model nor --method: the cell's.
inline constexpr const char* kDefaultModel = "paper+rigid_body";
/// The default on a static log (no motion: the rotational terms cannot be seen).
inline constexpr const char* kDefaultStaticModel = "paper";
/// `ftid identify --max-rows` default: an ftid log's rows held (about 1 GB; docs/log-format.md "Limits").
inline constexpr std::size_t kDefaultIdentifyMaxRows = 500000;

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
  /// The sensor's IMU (docs/identification.md, "The IMU as a measurement"): kOff ignores it (the
  /// wrench-only result, bit for bit), kAuto uses it when the log has the IMU columns (`ftid
  /// identify`'s default), kOn requires them. Used: the IMU's tilt starts the tilt search and is
  /// fused into a general fit with `tilt` (when the two agree); tilt, mount and delay compared.
  enum class ImuUse { kOff, kAuto, kOn };
  ImuUse imu = ImuUse::kOff;
  ImuOptions imu_options;
  /// Saturation (issue 22): the rated range (`--rated-range`); flat tops are always looked for.
  SaturationOptions saturation;
};

/// What the IMU said (filled when it was used or failed).
struct ImuReport {
  bool used = false;                 ///< the IMU's estimates exist
  std::string not_used_reason;       ///< why not (kAuto: no IMU columns, too little rotation, ...)
  ImuEstimate estimate;
  bool fused = false;                ///< the IMU's tilt was fused into the general fit
  /// Why the model's tilt was neither compared with the IMU's nor fused (apparentTiltReason in
  /// imu_fusion.hpp; "" when it was, or when the model estimates no tilt).
  std::string tilt_not_compared;
  std::vector<ImuComparison> comparisons;
  std::vector<std::string> warnings; ///< one line per disagreement (a set-up error or a bad IMU)
};

/// Reads the log, builds the contexts, identifies. Throws DataError (bad log), ConfigError (bad
/// robot/model/method), IdentificationError (data do not determine the parameters).
ParameterSet identifyLogFile(const IdentifyRequest& request);

/// The identification of `request` (method or model) on contexts.
ParameterSet identifyContexts(const std::vector<SampleContext>& samples, const IdentifyRequest& request);
/// Same, filling `imu` (may be nullptr) with the IMU's estimates and comparisons.
ParameterSet identifyContexts(const std::vector<SampleContext>& samples, const IdentifyRequest& request,
                              ImuReport* imu);

/// identifyLogFile plus, with `check`, the held-out residual against the noise floor (fit_check.hpp).
/// The fit leaves out the glitches of a first fit's residual (robust_data.hpp), then checks on the
/// rest; the notes of the fit (tilt_start.hpp) and the glitches are the first of check.warnings.
struct CheckedIdentification {
  ParameterSet set;
  FitCheck check;
  ImuReport imu;
  int glitches = 0;  ///< samples left out of the fit as glitches
  SetupDiagnosis setup;  ///< with `check`: the set-up diagnosis before the fit (setup_check.hpp)
  /// A mass that moves with a signal: its smallest value over the fitted samples (physical_check.hpp).
  std::optional<VaryingMass> varying_mass;
};
CheckedIdentification identifyLogFileChecked(const IdentifyRequest& request, bool check = true);
/// The same on contexts already built (request.log_path names them in messages).
CheckedIdentification identifyContextsChecked(const samples::ContextSet& contexts, const IdentifyRequest& request,
                                              bool check = true);

/// The IMU's biases as a parameter file's `imu` entries (params::kImuBiasNames; compensation with
/// the motion from the IMU subtracts them): the gyro's, and the accelerometer's when the motion
/// determined it (estimate.acc.bias_estimated). A bias beyond what a working IMU has
/// (params::kMaxImuAccBias_mps2, kMaxImuGyroBias_radps) is left out, and `left_out` (if given) says so.
std::vector<NamedValue> imuBiasEntries(const ImuEstimate& estimate, std::string* left_out = nullptr);

/// The IMU's biases of a run for its parameter file: estimateImu(samples), then imuBiasEntries.
/// Empty when the samples have no IMU (note untouched) or the motion cannot determine them (`note`
/// says why); `note` also gets imuBiasEntries' word on a bias left out.
std::vector<NamedValue> imuBiasEntriesOf(const std::vector<SampleContext>& samples, std::string* note);

/// Human-readable table: parameter, value, std, unit; residual RMS per axis; condition number.
std::string formatParameterTable(const ParameterSet& set);

/// Text lines of the IMU report (estimates, comparisons, warnings); empty when the IMU was off.
std::string formatImuReport(const ImuReport& report);

/// The IMU report as one JSON object (the keys of identificationJson's "imu"; also `ftid analyze`'s).
std::string imuReportJson(const ImuReport& report);

/// `ftid identify --json`'s object: identificationJson(set, check, validity) plus, when the IMU was
/// consulted, the key "imu" (docs/identification.md "Outputs").
std::string identificationJson(const CheckedIdentification& id, bool imu_consulted, const PhysicalValidity& validity);

}  // namespace ftid::identify
