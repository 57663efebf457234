// Every supported recording as one native log (include/ftid/logio/input.hpp).
#include "ftid/logio/input.hpp"

#include <algorithm>

#include "ftid/common/error.hpp"
#include "ftid/fileio/atomic_file.hpp"
#include "ftid/fileio/input_file.hpp"
#include "ftid/logio/table.hpp"

namespace ftid::logio {

std::vector<bool> stairSteps(const std::vector<bool>& same, const std::vector<int>& moving) {
  const std::size_t n = same.size();
  std::vector<bool> drop(n, false);
  std::size_t i = 0;
  while (i < n) {
    if (!same[i]) {
      ++i;
      continue;
    }
    std::size_t end = i;  // the run of repeats [i, end)
    while (end < n && same[end]) ++end;
    for (std::size_t k = i; k < end; ++k) {
      const int m = k < moving.size() ? moving[k] : -1;
      drop[k] = m == 1 || (m < 0 && end - i <= kMaxStairRun);
    }
    i = end;
  }
  return drop;
}

std::size_t dropRepeatedPoses(LogData& log) {
  if (log.has_joints || log.samples.size() < 2) return 0;
  for (const char* motion : {"kin_wx", "kin_alx", "kin_ax"}) {
    if (log.extraIndex(motion) >= 0) return 0;  // the motion is given, nothing is differenced
  }
  std::vector<std::size_t> pose_cols;
  for (const char* name : {"qx", "qy", "qz", "qw", "rx", "ry", "rz", "px", "py", "pz"}) {
    const int k = log.extraIndex(name);
    if (k >= 0) pose_cols.push_back(static_cast<std::size_t>(k));
  }
  if (pose_cols.empty()) return 0;
  const std::size_t n = log.samples.size();
  std::vector<bool> same(n, false);
  for (std::size_t i = 1; i < n; ++i) {
    same[i] = std::all_of(pose_cols.begin(), pose_cols.end(),
                          [&](std::size_t c) { return log.extra_columns[c][i] == log.extra_columns[c][i - 1]; });
  }
  const std::vector<bool> drop = stairSteps(same, std::vector<int>(n, -1));
  std::size_t kept = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (drop[i]) continue;
    log.samples[kept] = log.samples[i];
    for (auto& c : log.extra_columns) c[kept] = c[i];
    ++kept;
  }
  log.samples.resize(kept);
  for (auto& c : log.extra_columns) c.resize(kept);
  return n - kept;
}

InputLog readInput(const std::string& path, const InputOptions& options) {
  InputLog in;
  if (isDirectory(path)) {
    in = readRosbag2(path, options);
    if (options.wrench_log.empty()) return in;  // aligned with the bag's wrench topic
  } else {
    const std::string text = readLogText(path);
    if (isUrRecordHeader(headerRow(text))) {
      const Table table = parseTable(text, path);
      in = urRecordToLog(table, options);
    } else {
      const LogKind kind = options.wrench_log.empty() ? LogKind::kMeasurement : LogKind::kTrajectory;
      in.log = parseLogText(text, path, kind, options.read);
      in.format = "ftid log";
      const std::size_t n = in.log.samples.size();
      const std::size_t dropped = dropRepeatedPoses(in.log);
      if (dropped > 0) {
        in.notes.push_back("dropped " + std::to_string(dropped) + " of " + std::to_string(n) +
                           " rows whose pose repeats the previous row exactly, in runs of at most " +
                           std::to_string(kMaxStairRun) + " (stair steps: the recorder sampled faster than the "
                           "robot's state updated; differences across them would be wrong)");
      }
    }
  }
  if (!options.wrench_log.empty()) {
    const LogData wrench = wrenchLogFromTable(readTable(options.wrench_log, TableSeparator::kAuto, wrenchLogUsesColumn), options.read);
    if (in.log.has_wrench) {
      in.notes.push_back("the wrench columns of " + path + " are replaced by those of " + options.wrench_log +
                         " (--wrench-log)");
    }
    in.log = alignWrench(in.log, wrench, options.wrench_time_offset_s, in.notes);
    in.wrench_in_base = false;
    in.format += " + wrench log";
  }
  if (!in.log.has_wrench) {
    throw DataError(path + ": the recording has no wrench (no actual_TCP_force_0..5 columns): give the sensor's own "
                           "recording with --wrench-log FILE (docs/log-format.md)");
  }
  return in;
}

}  // namespace ftid::logio
