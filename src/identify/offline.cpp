// Offline pipelines (include/ftid/identify/offline.hpp).
#include "ftid/identify/offline.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>

#include <sys/stat.h>
#include <unistd.h>

#include "ftid/common/default_files.hpp"
#include "ftid/common/error.hpp"
#include "ftid/effects/signal_source.hpp"
#include "ftid/fileio/atomic_file.hpp"
#include "ftid/identify/fit.hpp"
#include "ftid/identify/noise.hpp"
#include "ftid/identify/paper_method.hpp"
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
  ParameterSet set;
  if (!request.model.empty()) {
    const Model model = Model::fromName(request.model);
    // Pose logs have no joint angles: a model that reads them cannot be fitted (say which effect).
    for (const auto& e : model.effectList()) {
      const std::string n = e->name();
      const auto open = n.find('(');
      if (open == std::string::npos || samples.empty()) continue;
      const auto end = n.find_first_of(",)", open);
      try {
        const auto src = effects::SignalSource::parse(n.substr(open + 1, end - open - 1));
        if (!src.available(samples.front())) {
          throw IdentificationError("effect " + n + " needs the signal '" + src.name() +
                                    "', which the log does not have" +
                                    (samples.front().has_joints ? std::string()
                                                                         : " (a pose log has no joint angles)"));
        }
      } catch (const ConfigError&) {
        // not a signal argument (e.g. temperature_drift(20))
      }
    }
    FitOptions fo;
    fo.max_delay_s = request.max_delay_s;
    MultiStartFit fit = fitModelMultiStart(model, samples, fo);
    if (request.notes != nullptr) {
      for (auto& n : fit.notes) request.notes->push_back(std::move(n));
    }
    set = toParameterSet(fit.fit);
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
  }
  return set;
}

ParameterSet identifyLogFile(const IdentifyRequest& request) {
  return identifyLogFileChecked(request, false).set;
}

CheckedIdentification identifyLogFileChecked(const IdentifyRequest& request, bool check) {
  const samples::ContextSet contexts = samples::loadLogContexts(request.log_path, request.robot_urdf, request.context, request.progress);
  CheckedIdentification out;
  if (request.model_is_default) {
    bool is_static = false;
    (void)poseGroups(contexts.samples, &is_static);
    if (is_static) {
      IdentifyRequest at_rest = request;
      at_rest.model = kDefaultStaticModel;
      at_rest.model_is_default = false;
      say(request.progress, std::string("the robot holds still in this log: fitting '") + kDefaultStaticModel +
                                "' (the default '" + kDefaultModel + "' needs motion)");
      return identifyContextsChecked(contexts, at_rest, check);
    }
  }
  return identifyContextsChecked(contexts, request, check);
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
  // The one robust data treatment (robust_data.hpp): glitches found in the first fit's residual are
  // left out of the fit, as `ftid analyze` and the cell leave them out.
  const ParameterSet first = identifyContexts(contexts.samples, main_fit);
  const RobustIdentification robust =
      leaveOutGlitches(contexts.samples, first, [&](const std::vector<SampleContext>& kept) {
        notes.clear();
        return identifyContexts(kept, main_fit);
      });
  out.glitches = static_cast<int>(robust.glitches.samples.size());
  if (out.glitches > 0) {
    say(request.progress, std::to_string(out.glitches) + " glitch" + (out.glitches == 1 ? "" : "es") +
                              " (isolated samples beyond " + std::to_string(static_cast<int>(kGlitchThreshold)) +
                              " robust standard deviations) left out; re-fitted");
  }
  out.set = robust.set;
  out.set.provenance.data_file = request.log_path;
  out.set.time_origin_unix_s = contexts.time_origin_unix_s;  // NaN without a host_time column
  if (check) {
    say(request.progress, "checking the fit on 5 held-out blocks against the noise floor");
    const std::string model = request.model.empty() ? out.set.model : request.model;
    out.check = checkFit(
        robust.samples, [&](const std::vector<SampleContext>& train) { return identifyContexts(train, request); },
        "ftid analyze " + request.log_path + " --model " + model + " --explain", request.noise_std);
  }
  if (out.glitches > 0) {
    out.check.glitches += out.glitches;
    notes.push_back(std::to_string(out.glitches) + " glitch" + (out.glitches == 1 ? "" : "es") +
                    " (isolated spikes beyond " + std::to_string(static_cast<int>(kGlitchThreshold)) +
                    " robust standard deviations of the first fit's residual) left out of the fit and the held-out "
                    "residual, as `ftid analyze` leaves them out");
  }
  notes.insert(notes.begin(), out.setup.lines.begin(), out.setup.lines.end());
  out.check.warnings.insert(out.check.warnings.begin(), notes.begin(), notes.end());
  return out;
}

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

}  // namespace ftid::identify
