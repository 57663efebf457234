#pragma once
// The offline compensation pipeline behind `ftid compensate`: a log file and a parameter file in,
// a compensated CSV out, through the real-time compensator (ftidd's code) and the one sample
// builder (ftid/samples/sample_builder.hpp). The CLI only parses arguments and calls it.
#include <string>

#include "ftid/common/types.hpp"
#include "ftid/compensate/compensator.hpp"
#include "ftid/samples/context.hpp"

namespace ftid::params {
struct ParameterSet;
}  // namespace ftid::params

namespace ftid::compensate {

struct CompensateRequest {
  std::string log_path;
  std::string params_path;
  std::string out_csv;
  std::string robot_urdf;
  samples::ContextOptions context;
  /// kImu: the motion of S from the log's IMU columns, less the parameter file's `imu` biases
  /// (compensator.hpp; a log without the IMU columns is a DataError).
  MotionSource motion = MotionSource::kKinematics;
};

struct CompensateSummary {
  int n_samples = 0;                ///< rows written
  int n_without_kinematics = 0;     ///< samples left out: their delayed kinematics lie outside the log
  Vec6 raw_rms = Vec6::Zero();      ///< RMS of the reading
  Vec6 contact_rms = Vec6::Zero();  ///< RMS of the compensated (contact) wrench
  /// For a model that reads time (time_drift, the t signal) whose time cannot be placed as ftidd
  /// places it: why (the log has no host_time column, or the set has no time origin); else empty.
  std::string time_note;
  /// With MotionSource::kImu and a set without the IMU's biases: what that means; else empty.
  std::string imu_note;
};

/// Writes OUT.csv (atomically) with columns t, fx..tz (contact wrench = reading - modelled) and
/// model_fx..model_tz (modelled wrench), one row per log sample, through the real-time
/// compensator (ftidd's code). With a `sensor_delay`, samples whose delayed kinematics lie outside
/// the log (the first |delay| seconds, or the last ones for a negative delay) are left out.
CompensateSummary compensateLogFile(const CompensateRequest& request);
/// The same with the parameter set already read (and checked) from request.params_path (used in
/// messages): the caller's checked set is the set used, the file is not read again.
CompensateSummary compensateLogFile(const CompensateRequest& request, const params::ParameterSet& set);

}  // namespace ftid::compensate
