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
  std::vector<char> keep(n);
  for (std::size_t i = 0; i < n; ++i) keep[i] = drop[i] ? 0 : 1;
  log.keepRows(keep);
  return n - log.samples.size();
}

namespace {

std::string ordinal(std::size_t n) {
  const std::size_t tens = n % 100;
  const char* suffix = (tens >= 11 && tens <= 13) ? "th" : n % 10 == 1 ? "st" : n % 10 == 2 ? "nd" : n % 10 == 3 ? "rd" : "th";
  return std::to_string(n) + suffix;
}

/// "every row of the motion" / "every 8th block of 256 rows of the motion".
std::string keptOf(std::size_t stride, std::size_t block, const char* what) {
  if (stride == 1) return std::string("every row of ") + what;
  return "every " + ordinal(stride) + " block of " + std::to_string(block) + " rows of " + what;
}

/// The note of dropRepeatedPoses, or "" if it dropped none.
std::string repeatedPosesNote(std::size_t dropped, std::size_t rows) {
  if (dropped == 0) return "";
  return "dropped " + std::to_string(dropped) + " of " + std::to_string(rows) +
         " rows whose pose repeats the previous row exactly, in runs of at most " + std::to_string(kMaxStairRun) +
         " (stair steps: the recorder sampled faster than the robot's state updated; differences across them would "
         "be wrong)";
}

/// The note for a log readLogThinned thinned: how many rows, of which class, which blocks of each
/// class were kept, and why.
std::string describeThinnedLog(const std::string& path, const ThinnedLog& log, std::size_t max_rows) {
  const std::size_t extras = log.log.extra_names.size();
  return path + ": " + std::to_string(log.rows) + " data rows (" + std::to_string(log.moving_rows) + " moving, " +
         std::to_string(log.still_rows) + " holding still); " + keptOf(log.moving_stride, log.block_rows, "the motion") +
         " and " + keptOf(log.still_stride, log.block_rows, "the rest") + " are used (" +
         std::to_string(log.log.samples.size()) + " rows) to stay within --max-rows " + std::to_string(max_rows) +
         (extras > 0 ? " (" + std::to_string(log.budget_rows) + " rows with its " + std::to_string(extras) +
                           " extra column" + (extras == 1 ? "" : "s") + ")"
                     : std::string()) +
         " (memory; docs/log-format.md \"Limits\"). Every row was checked; the statistics are those of the rows "
         "used";
}

/// An ftid log: read whole, or with options.max_rows in one pass within that budget.
InputLog readFtidLog(const std::string& path, const InputOptions& options, const std::string* text) {
  InputLog in;
  in.format = "ftid log";
  const LogKind kind = options.wrench_log.empty() ? LogKind::kMeasurement : LogKind::kTrajectory;
  if (text != nullptr) {
    in.log = parseLogText(*text, path, kind, options.read);
  } else {
    ThinnedLog thinned = readLogThinned(path, kind, options.read, options.max_rows);
    if (thinned.thinned()) {
      in.thinned_note = describeThinnedLog(path, thinned, options.max_rows);
      in.notes.push_back(in.thinned_note);
    }
    in.log = std::move(thinned.log);
  }
  const std::size_t n = in.log.samples.size();
  const std::string note = repeatedPosesNote(dropRepeatedPoses(in.log), n);
  if (!note.empty()) in.notes.push_back(note);
  return in;
}

}  // namespace

InputLog readInput(const std::string& path, const InputOptions& options) {
  InputLog in;
  if (isDirectory(path)) {
    in = readRosbag2(path, options);
    if (options.wrench_log.empty()) return in;  // aligned with the bag's wrench topic
  } else if (options.max_rows > 0 && options.wrench_log.empty() && !isUrRecordFile(path)) {
    in = readFtidLog(path, options, nullptr);
  } else {
    const std::string text = readLogText(path);
    if (isUrRecordHeader(headerRow(text))) {
      const Table table = parseTable(text, path);
      in = urRecordToLog(table, options);
    } else {
      in = readFtidLog(path, options, &text);
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
