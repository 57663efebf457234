// Offline pipelines (include/ftid/identify/offline.hpp).
#include "ftid/identify/offline.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <vector>

#include <sys/stat.h>
#include <unistd.h>

#include "ftid/common/default_files.hpp"
#include "ftid/common/error.hpp"
#include "ftid/common/shell_quote.hpp"
#include "ftid/effects/model.hpp"
#include "ftid/effects/signal_source.hpp"
#include "ftid/fileio/atomic_file.hpp"
#include "ftid/fileio/json_text.hpp"
#include "ftid/identify/fit.hpp"
#include "ftid/identify/noise.hpp"
#include "ftid/identify/paper_method.hpp"
#include "ftid/identify/physical_check.hpp"
#include "ftid/identify/robust_data.hpp"
#include "ftid/identify/setup_check.hpp"
#include "ftid/identify/tilt_start.hpp"
#include "ftid/logio/log.hpp"
#include "ftid/model/kinematics.hpp"

namespace ftid::identify {

namespace {

void say(const ProgressFn& progress, const std::string& line) {
  if (progress) progress(line);
}

}  // namespace

ParameterSet identifyContexts(const std::vector<SampleContext>& samples, const IdentifyRequest& request) {
  return identifyContexts(samples, request, nullptr);
}

namespace {

/// The IMU's estimates for the request, or nullopt (reason in the report) when not used.
std::optional<ImuEstimate> imuEstimateFor(const std::vector<SampleContext>& samples, const IdentifyRequest& request,
                                          ImuReport* report) {
  if (request.imu == IdentifyRequest::ImuUse::kOff) return std::nullopt;
  const bool has_imu = !samples.empty() && samples.front().has_imu;
  if (!has_imu) {
    if (request.imu == IdentifyRequest::ImuUse::kOn) {
      throw DataError("--imu on: the log has no IMU columns (ax..alz, docs/log-format.md)");
    }
    report->not_used_reason = "the log has no IMU columns";
    return std::nullopt;
  }
  try {
    return estimateImu(samples, request.imu_options);
  } catch (const DataError& e) {
    if (request.imu == IdentifyRequest::ImuUse::kOn) throw;
    report->not_used_reason = e.what();
    return std::nullopt;
  }
}

void noteComparisons(ImuReport* report) {
  for (const auto& c : report->comparisons) {
    if (c.disagrees) {
      const bool configured = c.message.find("configured") != std::string::npos;
      std::string advice = "a set-up error or a bad IMU";
      if (configured && c.quantity == "mount") {
        advice += "; check the sensor mount (X_FS), or add `mounting` to the model if the wrench turns with the IMU";
      } else if (configured && c.quantity == "delay") {
        advice += "; if the wrench shares the IMU's stream, add `sensor_delay` to the model";
      } else if (c.quantity == "delay") {
        advice += "; or a lag only the wrench has (a compliant mount or the sensor's filter), which `ftid analyze "
                  "--explain` separates from the stream delay";
      }
      report->warnings.push_back("the IMU and the " + std::string(configured ? "configuration" : "wrench") +
                                 " disagree on the " + c.quantity + " beyond their uncertainties (" + c.message +
                                 "): " + advice);
    }
  }
}

}  // namespace

ParameterSet identifyContexts(const std::vector<SampleContext>& samples, const IdentifyRequest& request,
                              ImuReport* imu_report) {
  ImuReport scratch;
  ImuReport* report = imu_report != nullptr ? imu_report : &scratch;
  *report = ImuReport{};
  const std::optional<ImuEstimate> imu = imuEstimateFor(samples, request, report);
  if (imu) {
    report->used = true;
    report->estimate = *imu;
  }
  ParameterSet set;
  if (!request.model.empty()) {
    const Model model = Model::fromName(request.model);
    // A model that reads a signal the log lacks (a pose log has no joint angles) cannot be fitted.
    const std::string miss = model.cannotFit(samples);
    if (!miss.empty()) throw IdentificationError(miss);
    FitOptions fo;
    fo.max_delay_s = request.max_delay_s;
    if (imu && model.estimatesTilt()) {
      // The IMU's tilt starts the tilt search: no wrong minimum from a poor paper-stage start
      // (fitModelMultiStart keeps a given start as the only one).
      fo.tilt_u_rad = imu->acc.tilt_u_rad;
      fo.tilt_v_rad = imu->acc.tilt_v_rad;
    }
    MultiStartFit multi = fitModelMultiStart(model, samples, fo);
    if (request.notes != nullptr) {
      for (auto& n : multi.notes) request.notes->push_back(std::move(n));
    }
    FitResult fit = std::move(multi.fit);
    if (imu) {
      report->comparisons = compareImuWithFit(fit, *imu);
      if (fit.tilt_estimated) report->tilt_not_compared = apparentTiltReason(model);
      if (!report->tilt_not_compared.empty()) {
        auto& cs = report->comparisons;
        cs.erase(std::remove_if(cs.begin(), cs.end(), [](const ImuComparison& c) { return c.quantity == "tilt"; }),
                 cs.end());
      }
      const bool tilt_agrees = !report->comparisons.empty() && report->comparisons.front().quantity == "tilt" &&
                               !report->comparisons.front().disagrees;
      if (fit.tilt_estimated && tilt_agrees) {
        fit = fuseImuTilt(model, samples, fit, imu->acc);
        report->fused = true;
      }
      noteComparisons(report);
    }
    set = toParameterSet(fit);
    if (report->fused) set.provenance.method += "+imu";
  } else {
    PaperOptions o;
    if (request.method == "static") {
      o.method = PaperMethod::kStatic;
    } else if (request.method == "dynamic") {
      o.method = PaperMethod::kDynamic;
    } else {
      throw ConfigError("--method must be 'static' or 'dynamic', not '" + request.method + "'");
    }
    const PaperResult r = identifyPaper(samples, o);
    set = r.toParameterSet();
    if (imu && set.tilt_estimated) {
      report->comparisons.push_back(compareImuTilt(set.tilt_u_rad, set.tilt_v_rad, set.tilt_u_std, set.tilt_v_std, imu->acc));
      noteComparisons(report);
    }
  }
  return set;
}

ParameterSet identifyLogFile(const IdentifyRequest& request) {
  return identifyLogFileChecked(request, false).set;
}

std::vector<NamedValue> imuBiasEntries(const ImuEstimate& imu, std::string* left_out) {
  std::vector<NamedValue> out;
  const AccTiltEstimate& acc = imu.acc;
  const GyroMountEstimate& gyro = imu.gyro;
  // A bias no working IMU has (params::kMaxImu*) is left out, so that a broken IMU never blocks
  // the payload's parameter file (compensation with the kinematics does not need the IMU).
  const bool acc_ok = acc.bias_estimated && acc.bias_mps2.cwiseAbs().maxCoeff() <= params::kMaxImuAccBias_mps2;
  const bool gyro_ok = gyro.bias_radps.cwiseAbs().maxCoeff() <= params::kMaxImuGyroBias_radps;
  for (int k = 0; k < 3 && acc_ok; ++k) {
    out.push_back({params::kImuBiasNames[k], acc.bias_mps2(k), acc.bias_std_mps2(k), "m/s^2"});
  }
  for (int k = 0; k < 3 && gyro_ok; ++k) {
    out.push_back({params::kImuBiasNames[3 + k], gyro.bias_radps(k), gyro.bias_std_radps(k), "rad/s"});
  }
  if (left_out != nullptr && ((acc.bias_estimated && !acc_ok) || !gyro_ok)) {
    *left_out = std::string("the IMU's ") + (gyro_ok ? "accelerometer" : (acc.bias_estimated && !acc_ok ? "accelerometer and gyro" : "gyro")) +
                " bias is beyond what a working IMU has (2 m/s^2, 0.2 rad/s): not written to the parameter file "
                "(a broken IMU, or one in other units; compensation with the IMU's motion would be wrong)";
  }
  return out;
}

std::vector<NamedValue> imuBiasEntriesOf(const std::vector<SampleContext>& samples, std::string* note) {
  if (samples.empty() || !samples.front().has_imu) return {};
  try {
    return imuBiasEntries(estimateImu(samples), note);
  } catch (const Error& e) {
    if (note != nullptr) *note = std::string("the IMU's biases are not estimated (") + e.what() + ")";
    return {};
  }
}

CheckedIdentification identifyLogFileChecked(const IdentifyRequest& request, bool check) {
  samples::ContextOptions options = request.context;
  options.drop_held_readings = true;  // a held reading is no measurement (held_readings.hpp)
  const samples::ContextSet contexts =
      samples::loadLogContexts(request.log_path, request.robot_urdf, options, request.progress);
  IdentifyRequest fitted = request;
  if (request.model_is_default && holdsStill(contexts.samples)) {
    fitted.model = kDefaultStaticModel;
    fitted.model_is_default = false;
    say(request.progress, std::string("the robot holds still in this log: fitting '") + kDefaultStaticModel +
                              "' (the default '" + kDefaultModel + "' needs motion)");
  }
  CheckedIdentification out = identifyContextsChecked(contexts, fitted, check);
  for (const std::string* note : {&contexts.held_note, &contexts.thinned_note}) {
    if (!note->empty()) out.check.warnings.insert(out.check.warnings.begin(), *note);
  }
  return out;
}

CheckedIdentification identifyContextsChecked(const samples::ContextSet& contexts, const IdentifyRequest& request,
                                              bool check) {
  CheckedIdentification out;
  if (check) {
    say(request.progress, "checking the set-up (wrench frame, mount, angle units) against the kinematics");
    const bool fits_mount = !request.model.empty() && Model::fromName(request.model).estimatesMounting();
    out.setup = diagnoseSetup(contexts.samples, request.context, !fits_mount);
    for (const auto& l : out.setup.lines) say(request.progress, l);
  }
  if (!request.model.empty()) {
    const Model model = Model::fromName(request.model);
    say(request.progress, "fitting model '" + model.name() + "' (" + std::to_string(model.numParams()) +
                              " linear parameters" + (model.estimatesTilt() ? " + tilt" : "") + ")");
  } else {
    say(request.progress, "paper method (" + request.method + "): force stage, torque stage");
  }
  std::vector<std::string> notes;
  IdentifyRequest main_fit = request;
  main_fit.notes = &notes;
  // The one robust data treatment (robust_data.hpp): saturated samples, then the glitches found in
  // the first fit's residual are left out of the fit, as `ftid analyze` and the cell leave them out.
  const RobustIdentification robust =
      leaveOutBadSamples(contexts.samples, request.saturation, [&](const std::vector<SampleContext>& kept) {
        notes.clear();
        return identifyContexts(kept, main_fit, &out.imu);
      });
  for (const auto& s : robust.saturation.axes) say(request.progress, saturationLine(s));
  out.glitches = static_cast<int>(robust.glitches.samples.size());
  if (out.glitches > 0) {
    say(request.progress, std::to_string(out.glitches) + " glitch" + (out.glitches == 1 ? "" : "es") +
                              " (isolated samples beyond " + std::to_string(static_cast<int>(kGlitchThreshold)) +
                              " robust standard deviations) left out; re-fitted");
  }
  out.set = robust.set;
  const std::vector<SampleContext>& fitted = robust.fittedOn(contexts.samples);
  out.varying_mass = varyingMass(out.set, fitted);
  out.set.provenance.data_file = request.log_path;
  out.set.time_origin_unix_s = contexts.time_origin_unix_s;  // NaN without a host_time column
  if (out.imu.used) {
    std::string left_out;
    out.set.imu = imuBiasEntries(out.imu.estimate, &left_out);
    if (!left_out.empty()) out.imu.warnings.push_back(left_out);
  }
  if (check) {
    say(request.progress, "checking the fit on 5 held-out blocks against the noise floor");
    const std::string model = request.model.empty() ? out.set.model : request.model;
    out.check = checkFit(
        fitted, [&](const std::vector<SampleContext>& train) { return identifyContexts(train, request, nullptr); },
        "ftid analyze " + shellQuote(request.log_path) + " --model " + shellQuote(model) + " --explain", request.noise_std);
  }
  if (out.glitches > 0) {
    out.check.glitches += out.glitches;
    notes.push_back(std::to_string(out.glitches) + " glitch" + (out.glitches == 1 ? "" : "es") +
                    " (isolated spikes beyond " + std::to_string(static_cast<int>(kGlitchThreshold)) +
                    " robust standard deviations of the first fit's residual) left out of the fit and the held-out "
                    "residual, as `ftid analyze` leaves them out");
  }
  out.check.saturation = robust.saturation.axes;  // saturation (issue 22)
  for (const auto& s : robust.saturation.axes) notes.push_back(saturationLine(s));
  notes.insert(notes.begin(), out.setup.lines.begin(), out.setup.lines.end());
  out.check.warnings.insert(out.check.warnings.begin(), notes.begin(), notes.end());
  return out;
}

namespace {

/// For a model whose tilt absorbs an effect's uniform pull (Effect::foldsIntoTilt): what the tilt
/// means and where the base's own tilt comes from; "" otherwise.
std::string apparentTiltNote(const std::string& model) {
  std::string absorbers;
  try {
    absorbers = effects::Model::fromName(model).tiltAbsorbers();
  } catch (const ConfigError&) {
    return "";
  }
  if (absorbers.empty()) return "";
  return "  (an APPARENT tilt: the horizontal pull of " + absorbers +
         " is folded into it (docs/effects.md); the base's mounting tilt is the IMU's, or that of a model "
         "without " + absorbers + " fitted on a motion where the pull is absent)\n";
}

}  // namespace

std::string formatParameterTable(const ParameterSet& set) {
  std::ostringstream os;
  char line[160];
  os << "model " << set.model << ", method " << set.provenance.method << ", " << set.provenance.n_samples
     << " samples\n";
  std::snprintf(line, sizeof(line), "%-14s %14s %12s  %s\n", "parameter", "value", "std", "unit");
  os << line;
  auto row = [&](const std::string& name, double value, double sd, const std::string& unit) {
    std::snprintf(line, sizeof(line), "%-14s %14.6g %12.3g  %s\n", name.c_str(), value, sd, unit.c_str());
    os << line;
  };
  for (const auto& p : set.params) row(p.name, p.value, p.std, p.unit);
  for (const auto& p : set.derived) row(p.name, p.value, p.std, p.unit);
  if (set.tilt_estimated) {
    constexpr double kDeg = 180.0 / 3.141592653589793;
    row("tilt_u", set.tilt_u_rad, set.tilt_u_std, "rad");
    row("tilt_v", set.tilt_v_rad, set.tilt_v_std, "rad");
    std::snprintf(line, sizeof(line), "  (tilt U = %.4f deg, V = %.4f deg)\n", set.tilt_u_rad * kDeg,
                  set.tilt_v_rad * kDeg);
    os << line;
    os << apparentTiltNote(set.model);
  }
  os << "residual RMS:";
  for (int a = 0; a < 6; ++a) {
    std::snprintf(line, sizeof(line), " %s %.4g%s", kWrenchAxisNames[a], set.residual_rms(a), a < 3 ? " N," : (a < 5 ? " Nm," : " Nm"));
    os << line;
  }
  std::snprintf(line, sizeof(line), "\ncondition number: %.4g\n", set.condition_number);
  os << line;
  for (const auto& e : set.extras) {
    std::snprintf(line, sizeof(line), "  %s: %.4g\n", e.name.c_str(), e.value);
    os << line;
  }
  return os.str();
}

std::string formatImuReport(const ImuReport& report) {
  std::ostringstream os;
  if (!report.used) {
    if (!report.not_used_reason.empty()) os << "IMU not used: " << report.not_used_reason << "\n";
    return os.str();
  }
  os << formatImuEstimate(report.estimate);
  if (report.fused) {
    os << "  fused: the IMU's tilt is fused with the wrench's (docs/identification.md)\n";
  } else if (!report.tilt_not_compared.empty()) {
    os << "  not fused; " << report.tilt_not_compared << "\n";
  } else {
    os << "  not fused (the model estimates no tilt, or the IMU and the wrench disagree on it)\n";
  }
  for (const auto& c : report.comparisons) os << "  " << (c.disagrees ? "DISAGREE " : "agree    ") << c.message << "\n";
  for (const auto& w : report.warnings) os << "WARNING: " << w << "\n";
  return os.str();
}

std::string imuReportJson(const ImuReport& r) {
  Json imu = Json::object();
  imu["used"] = r.used;
  if (!r.used) {
    imu["not_used_reason"] = r.not_used_reason;
    return jsonText(imu);
  }
  const ImuEstimate& e = r.estimate;
  auto vec = [](const Vec3& v) { return Json::array({jsonNumber(v.x()), jsonNumber(v.y()), jsonNumber(v.z())}); };
  imu["fused"] = r.fused;
  if (!r.tilt_not_compared.empty()) imu["tilt_not_compared"] = r.tilt_not_compared;
  imu["tilt_u"] = jsonNumber(e.acc.tilt_u_rad);
  imu["tilt_u_std"] = jsonNumber(e.acc.tilt_u_std);
  imu["tilt_v"] = jsonNumber(e.acc.tilt_v_rad);
  imu["tilt_v_std"] = jsonNumber(e.acc.tilt_v_std);
  imu["acc_bias_estimated"] = e.acc.bias_estimated;
  imu["acc_bias"] = vec(e.acc.bias_mps2);
  imu["acc_bias_std"] = vec(e.acc.bias_std_mps2);
  imu["acc_noise"] = jsonNumber(e.acc.sigma_mps2);
  imu["gyro_bias"] = vec(e.gyro.bias_radps);
  imu["gyro_bias_std"] = vec(e.gyro.bias_std_radps);
  imu["gyro_noise"] = jsonNumber(e.gyro.sigma_radps);
  imu["mount_rpy"] = vec(e.gyro.rpy_rad);
  imu["mount_rotation_std"] = vec(e.gyro.rotation_std_rad);
  imu["delay"] = jsonNumber(e.gyro.delay_s);
  imu["delay_std"] = jsonNumber(e.gyro.delay_std_s);
  Json comps = Json::array();
  for (const auto& c : r.comparisons) {
    comps.push_back({{"quantity", c.quantity}, {"chi2", jsonNumber(c.chi2)}, {"dof", c.dof},
                     {"limit", jsonNumber(c.limit)}, {"disagrees", c.disagrees}, {"message", c.message}});
  }
  imu["comparisons"] = std::move(comps);
  imu["warnings"] = r.warnings;
  return jsonText(imu);
}

std::string identificationJson(const CheckedIdentification& id, bool imu_consulted, const PhysicalValidity& validity) {
  if (!imu_consulted) return identificationJson(id.set, id.check, validity);
  Json j = Json::parse(identificationJson(id.set, id.check, validity));
  j["imu"] = Json::parse(imuReportJson(id.imu));
  return jsonText(j);
}

}  // namespace ftid::identify
