// Readings the sensor did not renew (include/ftid/samples/held_readings.hpp).
#include "ftid/samples/held_readings.hpp"

#include <algorithm>
#include <cstdio>

#include "ftid/logio/log.hpp"

namespace ftid::samples {

namespace {

// The pose columns of a pose log (docs/log-format.md "Pose logs"), by index; empty for joint logs.
std::vector<int> poseColumns(const logio::LogData& log) {
  std::vector<int> cols;
  if (log.has_joints) return cols;
  for (const char* name : {"qx", "qy", "qz", "qw", "rx", "ry", "rz", "px", "py", "pz"}) {
    const int k = log.extraIndex(name);
    if (k >= 0) cols.push_back(k);
  }
  return cols;
}

// Whether the robot's state differs between rows i-1 and i: joints and joint velocities, or the
// pose columns of a pose log.
bool robotMoved(const logio::LogData& log, const std::vector<int>& pose_cols, std::size_t i) {
  const auto& a = log.samples[i - 1];
  const auto& b = log.samples[i];
  if (log.has_joints) return a.q != b.q || a.qd != b.qd;
  for (const int k : pose_cols) {
    const auto& col = log.extra_columns[static_cast<std::size_t>(k)];
    if (col[i - 1] != col[i]) return true;
  }
  return false;
}

}  // namespace

HeldReadings findHeldReadings(const logio::LogData& log) {
  HeldReadings h;
  const std::size_t n = log.samples.size();
  h.held.assign(n, 0);
  if (!log.has_wrench || n < 2) return h;
  const std::vector<int> pose_cols = poseColumns(log);
  std::vector<int> spans;  // rows spanned by each held reading
  std::size_t start = 0;   // row the current reading arrived with
  auto closeRun = [&](std::size_t end) {  // rows [start, end) show one reading
    if (end - start < 2) return;
    spans.push_back(static_cast<int>(end - start));
    const double span_s = (end < n ? log.samples[end].t : log.samples[end - 1].t) - log.samples[start].t;
    if (span_s > h.longest_s) {
      h.longest_s = span_s;
      h.longest_from_s = log.samples[start].t;
    }
  };
  for (std::size_t i = 1; i < n; ++i) {
    const bool same = log.samples[i].wrench_S == log.samples[i - 1].wrench_S;
    if (same && robotMoved(log, pose_cols, i)) {
      h.held[i] = 1;
      ++h.count;
      continue;
    }
    if (same) continue;  // at rest: a repeated value is a reading (kept), and extends no hold
    closeRun(i);
    start = i;
  }
  closeRun(n);
  h.runs = static_cast<int>(spans.size());
  if (!spans.empty()) {
    std::nth_element(spans.begin(), spans.begin() + static_cast<std::ptrdiff_t>(spans.size() / 2), spans.end());
    h.typical_rows = spans[spans.size() / 2];
  }
  return h;
}

std::string describeHeldReadings(const HeldReadings& h, const std::string& log_path) {
  if (h.count == 0) return "";
  char line[400];
  std::snprintf(line, sizeof(line),
                "%d rows repeat the previous row's wrench bit for bit while the robot moved: %d "
                "readings held over several rows (median %d rows each, as a sensor at 1/%d of the log's "
                "rate gives; the longest %.3g s from t = %.6g s, a stalled stream if far longer); only "
                "the row each reading arrived with is used",
                h.count, h.runs, h.typical_rows, h.typical_rows, h.longest_s, h.longest_from_s);
  return log_path + ": " + line;
}

}  // namespace ftid::samples
