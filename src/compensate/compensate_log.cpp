// Compensation of a whole log file (include/ftid/compensate/compensate_log.hpp).
#include "ftid/compensate/compensate_log.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

#include "ftid/common/error.hpp"
#include "ftid/compensate/compensator.hpp"
#include "ftid/effects/model.hpp"
#include "ftid/effects/signal_source.hpp"
#include "ftid/fileio/atomic_file.hpp"
#include "ftid/params/parameter_set.hpp"

namespace ftid::compensate {

CompensateSummary compensateLogFile(const CompensateRequest& request) {
  return compensateLogFile(request, params::readParameterFile(request.params_path));
}

CompensateSummary compensateLogFile(const CompensateRequest& request, const params::ParameterSet& set) {
  checkOutputPath(request.out_csv);  // refuse a symlink, device, FIFO or directory before the work
  const effects::Model model = effects::Model::fromName(set.model);
  const Eigen::VectorXd theta = params::thetaFor(model, set, request.params_path);
  // The model's time from the set's time origin, as ftidd does (docs/conventions.md).
  samples::ContextOptions context = request.context;
  context.time_origin_unix_s = set.time_origin_unix_s;
  const samples::ContextSet contexts = samples::loadLogContexts(request.log_path, request.robot_urdf, context);
  if (const std::string miss = model.cannotFit(contexts.samples); !miss.empty()) {
    throw DataError(request.log_path + ": cannot be compensated with " + request.params_path + ": " + miss);
  }
  CompensateSummary summary;
  CompensatorOptions options;
  options.motion = request.motion;
  if (request.motion == MotionSource::kImu) {
    const bool has_imu = std::all_of(contexts.samples.begin(), contexts.samples.end(),
                                     [](const effects::SampleContext& c) { return c.has_imu; });
    if (!has_imu) {
      throw DataError(request.log_path + ": has no IMU columns (ax..alz): the motion from the IMU needs them "
                      "(compensate with the kinematics instead: leave out --motion imu)");
    }
    const Vec6 bias = params::imuBiasesOf(set);
    options.imu_bias.acc_mps2 = bias.head<3>();
    options.imu_bias.gyro_radps = bias.tail<3>();
    if (set.imu.empty()) {
      summary.imu_note = request.params_path + " has no IMU biases (identified without the IMU): the IMU's readings "
                         "are used as they are; identify with the IMU (`ftid identify --imu on`) to have them";
    }
  }
  Compensator comp(model, theta, params::nonlinearFor(model, set, request.params_path), options);

  if ((model.signals() & effects::kSignalTime) != 0) {
    if (!std::isfinite(contexts.time_origin_unix_s)) {
      summary.time_note = request.log_path + " has no host_time column: the model's time (" + set.model +
                          ") runs from the log's first sample, not from the parameter set's time origin "
                          "(docs/conventions.md, \"Time and logs\")";
    } else if (!std::isfinite(set.time_origin_unix_s)) {
      summary.time_note = request.params_path + " has no time_origin (written before time origins): the model's "
                          "time runs from the log's first sample, as ftidd's runs from its first valid cycle";
    }
  }
  std::ostringstream os;
  os << "t,fx,fy,fz,tx,ty,tz,model_fx,model_fy,model_fz,model_tx,model_ty,model_tz\n";
  char buf[64];
  double last_t = -std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < contexts.size(); ++i) {
    const effects::SampleContext& ctx = contexts.samples[i];
    Wrench contact, modelled;
    const Status st = comp.compute(ctx, &contact, &modelled);
    if (st == Status::kNotReady) {
      ++summary.n_without_kinematics;
      continue;
    }
    if (st != Status::kOk) {
      throw DataError(request.log_path + ": sample " + std::to_string(i) + " cannot be compensated (non-finite)");
    }
    // With a negative delay the output belongs to an earlier reading (comp.outputTime()).
    const double t_out = comp.outputTime();
    if (!(t_out > last_t)) continue;
    last_t = t_out;
    ++summary.n_samples;
    summary.raw_rms += (contact + modelled).cwiseAbs2();
    summary.contact_rms += contact.cwiseAbs2();
    std::snprintf(buf, sizeof(buf), "%.9f", t_out + contexts.t_origin);
    os << buf;
    for (int a = 0; a < 6; ++a) {
      std::snprintf(buf, sizeof(buf), ",%.9g", contact(a));
      os << buf;
    }
    for (int a = 0; a < 6; ++a) {
      std::snprintf(buf, sizeof(buf), ",%.9g", modelled(a));
      os << buf;
    }
    os << "\n";
  }
  summary.n_without_kinematics = static_cast<int>(contexts.size()) - summary.n_samples;
  if (summary.n_samples > 0) {
    summary.raw_rms = (summary.raw_rms / summary.n_samples).cwiseSqrt();
    summary.contact_rms = (summary.contact_rms / summary.n_samples).cwiseSqrt();
  }
  try {
    writeFileAtomically(request.out_csv, os.str());
  } catch (const FileError& e) {
    throw ConfigError(e.what());
  }
  return summary;
}

}  // namespace ftid::compensate
