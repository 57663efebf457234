// File front end of the model laboratory (include/ftid/lab/analyze.hpp).
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

void writeTextFileAtomically(const std::string& path, const std::string& text) {
  writeFileAtomically(path, text);  // ftid/fileio/atomic_file.hpp
}

}  // namespace ftid::lab
