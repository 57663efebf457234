// File front end of the model laboratory (include/ftid/lab/analyze.hpp).
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>

#include "ftid/common/default_files.hpp"
#include "ftid/common/error.hpp"
#include "ftid/fileio/atomic_file.hpp"
#include "ftid/samples/context.hpp"
#include "ftid/identify/offline.hpp"
#include "ftid/identify/setup_check.hpp"
#include "ftid/lab/analyze.hpp"
#include "ftid/logio/log.hpp"
#include "ftid/model/kinematics.hpp"

namespace ftid::lab {

AnalysisResult analyzeLogFiles(const AnalyzeFilesRequest& request) {
  const auto& progress = request.options.progress;
  auto say = [&](const std::string& s) {
    if (progress) progress(s);
  };
  const std::string urdf = request.robot_urdf.empty() ? defaultRobotUrdf() : request.robot_urdf;
  const model::RobotKinematics kin = model::RobotKinematics::fromUrdfFile(urdf);
  say("reading " + request.log_path);
  const logio::LogData log = logio::readLog(request.log_path);
  say(std::to_string(log.samples.size()) + " samples, robot " + urdf);
  samples::ContextSet fit = samples::buildContexts(log, kin, request.context);
  for (auto& c : fit.samples) c.extra_names = &fit.extra_names;
  samples::ContextSet val;
  if (!request.validate_path.empty()) {
    say("reading " + request.validate_path);
    const logio::LogData vlog = logio::readLog(request.validate_path);
    // The model's time of the validation log counts from the fitted log's origin, as ftidd and
    // `ftid compensate` would with the identified parameters (docs/conventions.md, "Time and logs").
    samples::ContextOptions vopt = request.context;
    if (std::isfinite(fit.time_origin_unix_s)) vopt.time_origin_unix_s = fit.time_origin_unix_s;
    val = samples::buildContexts(vlog, kin, vopt);
    if (val.extra_names != fit.extra_names) {
      throw DataError(request.validate_path + ": its extra columns differ from those of " + request.log_path);
    }
    for (auto& c : val.samples) c.extra_names = &val.extra_names;
  }
  AnalysisResult result = analyze(fit.samples, request.validate_path.empty() ? nullptr : &val.samples,
                                  request.options, request.log_path, request.validate_path);
  result.robot_urdf = urdf;
  return result;
}

void checkEnoughSamples(const samples::ContextSet& fit, const AnalyzeFilesRequest& request) {
  const bool validate = !request.validate_path.empty();
  const int folds = request.options.folds;
  const std::size_t need = validate ? 20 : 20 * static_cast<std::size_t>(folds);
  if (fit.size() >= need) return;
  double max_w = 0.0;
  for (const auto& c : fit.samples) max_w = std::max(max_w, c.w_S.norm());
  const int pose_col = fit.extraIndex("pose");
  std::size_t poses = 0;
  for (std::size_t i = 0; i < fit.size(); ++i) {
    const std::size_t k = fit.extra_names.size();
    if (pose_col < 0 || i == 0 || fit.extra_rows[i * k + static_cast<std::size_t>(pose_col)] !=
                                      fit.extra_rows[(i - 1) * k + static_cast<std::size_t>(pose_col)]) {
      ++poses;
    }
  }
  const bool is_static = max_w < 1e-3;
  std::string what = request.log_path + ": " + std::to_string(fit.size()) +
                     " samples are too few for the analysis (need " + std::to_string(need) +
                     (validate ? ")" : ": 20 per held-out block x " + std::to_string(folds) + " blocks)") +
                     ". What would do: ";
  if (is_static) {
    const std::size_t per_pose = (need + poses - 1) / std::max<std::size_t>(poses, 1);
    what += "repeated readings at each pose (e.g. " + std::to_string(std::max<std::size_t>(per_pose, 2)) +
            " at each of the " + std::to_string(poses) + " poses, consecutive rows with a 'pose' column: their "
            "spread is the noise floor) or more poses; ";
  } else {
    what += "a longer recording; ";
  }
  if (!validate && folds > 2) what += "fewer held-out blocks (--folds 2 needs 40); ";
  if (!validate) what += "a separate validation log (--validate LOG2: 20 samples each); ";
  what += std::string("or the identification alone: ftid identify --log ") + request.log_path +
          (is_static ? " --method static" : "") + " (docs/analyze.md)";
  throw DataError(what);
}

AnalysisResult analyzeRecordings(const AnalyzeFilesRequest& request) {
  const auto& say = request.options.progress;
  samples::ContextOptions options = request.context;
  options.drop_held_readings = true;  // a held reading is no measurement (held_readings.hpp)
  samples::ContextSet fit = samples::loadLogContexts(request.log_path, request.robot_urdf, options, say);
  applyTimeWindow(fit, request.t_from, request.t_to, request.log_path);  // --t-from, --t-to (change points)
  checkEnoughSamples(fit, request);
  // The set-up diagnosis (identify's, setup_check.hpp) on the log as it was read.
  for (const auto& l : identify::diagnoseSetup(fit.samples, request.context).lines) {
    if (say) say(l);
  }
  samples::ContextSet val;
  if (!request.validate_path.empty()) {
    // The validation log's model time counts from the fitted log's origin (as analyzeLogFiles).
    samples::ContextOptions vopt = options;
    vopt.input.wrench_log.clear();
    if (std::isfinite(fit.time_origin_unix_s)) vopt.time_origin_unix_s = fit.time_origin_unix_s;
    val = samples::loadLogContexts(request.validate_path, request.robot_urdf, vopt, say);
    if (val.extra_names != fit.extra_names) {
      throw DataError(request.validate_path + ": its extra columns differ from those of " + request.log_path);
    }
  }
  AnalysisResult result = analyze(fit.samples, request.validate_path.empty() ? nullptr : &val.samples,
                                  request.options, request.log_path, request.validate_path);
  result.robot_urdf = request.robot_urdf.empty() ? defaultRobotUrdf() : request.robot_urdf;
  for (const std::string* note : {&val.held_note, &fit.held_note, &val.thinned_note, &fit.thinned_note}) {
    if (!note->empty()) result.warnings.insert(result.warnings.begin(), *note);
  }
  return result;
}

void writeTextFileAtomically(const std::string& path, const std::string& text) {
  writeFileAtomically(path, text);  // ftid/fileio/atomic_file.hpp
}

}  // namespace ftid::lab
