// UR RTDE recordings (record.py, ur_rtde's startFileRecording) as native logs
// (include/ftid/logio/input.hpp, docs/log-format.md "UR recordings").
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <initializer_list>

#include <Eigen/Geometry>

#include "ftid/common/error.hpp"
#include "ftid/logio/input.hpp"
#include "ftid/logio/table.hpp"

namespace ftid::logio {

namespace {

/// The six (or three) columns prefix_0..prefix_{n-1}: all indices, or all -1; partial is an error.
template <std::size_t N>
std::array<int, N> group(const Table& table, const std::string& prefix) {
  std::array<int, N> idx{};
  std::size_t present = 0;
  std::string missing;
  for (std::size_t j = 0; j < N; ++j) {
    const std::string name = prefix + "_" + std::to_string(j);
    idx[j] = table.find(name);
    if (idx[j] >= 0) {
      ++present;
    } else {
      missing += (missing.empty() ? "" : ", ") + name;
    }
  }
  if (present != 0 && present != N) {
    throw DataError(table.source + ":" + std::to_string(table.header_line) + ":1: incomplete UR columns " + prefix +
                    "_0.." + prefix + "_" + std::to_string(N - 1) + ", missing: " + missing);
  }
  if (present == 0) idx.fill(-1);
  return idx;
}

template <std::size_t N>
bool has(const std::array<int, N>& g) {
  return g[0] >= 0;
}

double at(const Table& table, int column, std::size_t row) {
  return table.columns[static_cast<std::size_t>(column)][row];
}

/// DataError for a value beyond its plausible range, naming line and column.
void checkRange(const Table& table, int column, std::size_t row, double limit, const char* unit) {
  const double v = at(table, column, row);
  if (std::abs(v) <= limit) return;
  char buf[240];
  std::snprintf(buf, sizeof buf, "%s:%zu: column '%s': value %.6g is outside the plausible range +-%.6g %s",
                table.source.c_str(), table.row_line[row], table.names[static_cast<std::size_t>(column)].c_str(), v,
                limit, unit);
  throw DataError(buf);
}

Mat3 rotationFromVector(const Vec3& r) {
  const double angle = r.norm();
  return angle > 0 ? Mat3(Eigen::AngleAxisd(angle, r / angle).toRotationMatrix()) : Mat3(Mat3::Identity());
}

/// The rows to keep: stair steps (the state columns repeat the previous row's while `qd`, if
/// recorded, is non-zero; logio::stairSteps) and exact duplicate rows dropped (noted); the time
/// must increase over the rest.
std::vector<std::size_t> selectRows(const Table& table, int t_col, std::initializer_list<const std::array<int, 6>*> state,
                                    const std::array<int, 6>* qd, const LogReadOptions& lim,
                                    std::vector<std::string>& notes) {
  // Rows: drop stair steps (repeats of the previous state while moving) and exact duplicate rows,
  // then check that time increases.
  std::vector<int> state_cols;
  for (const auto* g : state) {
    if (has(*g)) state_cols.insert(state_cols.end(), g->begin(), g->end());
  }
  const std::size_t rows = table.rows();
  std::vector<bool> same(rows, false);
  std::vector<int> moving(rows, -1);
  for (std::size_t r = 0; r < rows; ++r) {
    if (r > 0) {
      same[r] = std::all_of(state_cols.begin(), state_cols.end(),
                            [&](int c) { return at(table, c, r) == at(table, c, r - 1); });
    }
    if (qd != nullptr) {
      moving[r] = std::any_of(qd->begin(), qd->end(), [&](int c) { return at(table, c, r) != 0.0; }) ? 1 : 0;
    }
  }
  const std::vector<bool> stair = stairSteps(same, moving);
  std::vector<std::size_t> keep;
  std::size_t stairs = 0, duplicates = 0, same_time = 0;
  for (std::size_t r = 0; r < rows; ++r) {
    if (stair[r]) {
      ++stairs;
      continue;
    }
    if (!keep.empty()) {
      const std::size_t p = keep.back();
      if (same[r] && at(table, t_col, r) == at(table, t_col, p)) {
        ++duplicates;  // the same row twice
        continue;
      }
      if (at(table, t_col, r) == at(table, t_col, p)) {
        ++same_time;  // a torn or repeated row: the later one is the recorder's last word
        keep.back() = r;
        continue;
      }
      if (!(at(table, t_col, r) > at(table, t_col, p))) {
        char buf[240];
        std::snprintf(buf, sizeof buf,
                      "%s:%zu: column 'timestamp': time %.17g is not greater than %.17g on line %zu (timestamps "
                      "must increase)",
                      table.source.c_str(), table.row_line[r], at(table, t_col, r), at(table, t_col, p),
                      table.row_line[p]);
        throw DataError(buf);
      }
    }
    checkRange(table, t_col, r, lim.max_abs_t_s, "s");
    keep.push_back(r);
  }
  if (stairs > 0) {
    notes.push_back("dropped " + std::to_string(stairs) + " of " + std::to_string(rows) +
                        " rows whose robot state repeats the previous row exactly while the arm moves (stair steps: "
                        "the recorder sampled faster than the controller updated its state; differences across "
                        "them would be wrong)");
  }
  if (duplicates > 0) notes.push_back("dropped " + std::to_string(duplicates) + " duplicate rows");
  if (same_time > 0) {
    notes.push_back("dropped " + std::to_string(same_time) + " rows whose timestamp equals the next row's (kept the "
                    "last row of each timestamp: the recorder wrote a torn or repeated row)");
  }
  return keep;
}

/// Adds back the configured payload's gravity wrench that the controller subtracted from
/// actual_TCP_force: f_B += m g_B, t_B += (R_BT c) x (m g_B), R_BT from actual_TCP_pose.
void addConfiguredPayload(const Table& table, const std::array<int, 6>& pose, const std::vector<std::size_t>& keep,
                          const InputOptions& options, LogData& log, std::vector<std::string>& notes) {
  const Vec3 f_B = options.ur_payload_mass_kg * options.ur_gravity_B;
  for (std::size_t i = 0; i < keep.size(); ++i) {
    Vec3 r;
    for (int j = 0; j < 3; ++j) r[j] = at(table, pose[static_cast<std::size_t>(3 + j)], keep[i]);
    const Vec3 c_B = rotationFromVector(r) * options.ur_payload_com_tcp_m;
    log.samples[i].wrench_S.head<3>() += f_B;
    log.samples[i].wrench_S.tail<3>() += c_B.cross(f_B);
  }
  char buf[160];
  std::snprintf(buf, sizeof buf, "added back the controller's configured payload (%.6g kg) to actual_TCP_force",
                options.ur_payload_mass_kg);
  notes.emplace_back(buf);
}

}  // namespace

bool isUrRecordHeader(std::string_view header) {
  bool timestamp = false, joints = false, pose = false;
  std::size_t i = 0;
  while (i < header.size()) {
    while (i < header.size() && (header[i] == ',' || header[i] == ' ' || header[i] == '\t' || header[i] == '\r')) ++i;
    const std::size_t start = i;
    while (i < header.size() && header[i] != ',' && header[i] != ' ' && header[i] != '\t' && header[i] != '\r') ++i;
    const std::string_view name = header.substr(start, i - start);
    timestamp = timestamp || name == "timestamp";
    joints = joints || name == "actual_q_0";
    pose = pose || name == "actual_TCP_pose_0";
  }
  return timestamp && (joints || pose);
}

QddSource parseQddSource(const std::string& text) {
  if (text.empty() || text == "diff") return QddSource::kDifferences;
  if (text == "target") return QddSource::kTarget;
  throw ConfigError("--qdd-source must be 'diff' or 'target', not '" + text + "'");
}

namespace {

/// Refuses a differenced velocity or acceleration outside the plausible range, naming the line.
void checkDifferenced(const Table& table, const std::vector<std::size_t>& keep, const std::vector<JointVector>& v,
                      double limit, const char* what) {
  for (std::size_t i = 0; i < v.size(); ++i) {
    for (int j = 0; j < 6; ++j) {
      if (std::abs(v[i][j]) <= limit) continue;
      char buf[300];
      std::snprintf(buf, sizeof buf,
                    "%s:%zu: joint %d: the %s from smoothed differences is %.6g, outside the plausible range "
                    "(|value| <= %.6g): the recording jumps there",
                    table.source.c_str(), table.row_line[keep[i]], j + 1, what, v[i][j], limit);
      throw DataError(buf);
    }
  }
}

}  // namespace

InputLog urRecordToLog(const Table& table, const InputOptions& options) {
  InputLog out;
  LogData& log = out.log;
  log.source = table.source;
  const int t_col = table.find("timestamp");
  const auto q = group<6>(table, "actual_q");
  const auto qd = group<6>(table, "actual_qd");
  const auto qdd = group<6>(table, "target_qdd");
  const auto pose = group<6>(table, "actual_TCP_pose");
  const auto force = group<6>(table, "actual_TCP_force");
  const std::string where = table.source + ":" + std::to_string(table.header_line) + ":1: ";
  if (t_col < 0 || (!has(q) && !has(pose))) {
    throw DataError(where + "a UR recording needs 'timestamp' and actual_q_0..5 (or actual_TCP_pose_0..5)");
  }
  if (options.qdd_source == QddSource::kTarget && !has(qdd)) {
    throw DataError(where + "--qdd-source target needs the columns target_qdd_0..5, which this recording lacks "
                            "(record them, or use the default: smoothed differences of actual_qd)");
  }
  if (options.ur_payload_mass_kg != 0.0 && (!has(force) || !has(pose))) {
    throw DataError(where + "--ur-payload needs actual_TCP_force_0..5 and actual_TCP_pose_0..5 in the recording");
  }
  log.has_joints = has(q);
  log.has_wrench = has(force);
  const LogReadOptions& lim = options.read;

  const std::vector<std::size_t> keep = selectRows(table, t_col, {&q, &qd, &pose}, has(qd) ? &qd : nullptr, lim, out.notes);
  const std::size_t n = keep.size();
  std::vector<double> t(n);
  std::vector<JointVector> qv(n), qdv(n);
  log.samples.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t r = keep[i];
    t[i] = at(table, t_col, r);
    log.samples[i].t = t[i];
    for (int j = 0; j < 6; ++j) {
      const auto js = static_cast<std::size_t>(j);
      if (has(q)) {
        checkRange(table, q[js], r, lim.max_abs_q_rad, "rad (joint angles within +-4 pi)");
        qv[i][j] = at(table, q[js], r);
      }
      if (has(qd)) {
        checkRange(table, qd[js], r, lim.max_abs_qd_rad_s, "rad/s");
        qdv[i][j] = at(table, qd[js], r);
      }
      if (has(force)) {
        checkRange(table, force[js], r, lim.max_abs_wrench_S[js], j < 3 ? "N" : "Nm");
        log.samples[i].wrench_S[j] = at(table, force[js], r);
      }
    }
  }
  const int h = std::max(1, options.derivative_half_window);
  if (log.has_joints) {
    if (!has(qd)) {
      qdv = smoothedDerivative(t, qv, h);
      checkDifferenced(table, keep, qdv, lim.max_abs_qd_rad_s, "velocity [rad/s]");
      out.notes.push_back("joint velocities from smoothed differences of actual_q (no actual_qd columns)");
    }
    std::vector<JointVector> qddv;
    if (options.qdd_source == QddSource::kTarget) {
      qddv.resize(n);
      for (std::size_t i = 0; i < n; ++i) {
        for (int j = 0; j < 6; ++j) {
          checkRange(table, qdd[static_cast<std::size_t>(j)], keep[i], lim.max_abs_qdd_rad_s2, "rad/s^2");
          qddv[i][j] = at(table, qdd[static_cast<std::size_t>(j)], keep[i]);
        }
      }
      out.notes.push_back("joint accelerations: the controller's target_qdd (--qdd-source target)");
    } else {
      qddv = smoothedDerivative(t, qdv, h);
      checkDifferenced(table, keep, qddv, lim.max_abs_qdd_rad_s2, "acceleration [rad/s^2]");
      out.notes.push_back("joint accelerations from smoothed differences of actual_qd (centred least-squares slope "
                          "over +-" + std::to_string(h) + " samples; no lag)");
    }
    for (std::size_t i = 0; i < n; ++i) {
      log.samples[i].q = qv[i];
      log.samples[i].qd = qdv[i];
      log.samples[i].qdd = qddv[i];
    }
  }
  // Pose columns (a pose log's R_BS and p_BS_B when there are no joints; kept as extra otherwise).
  std::vector<int> used = {t_col};
  for (const auto* g : {&q, &qd, &force}) {
    if (has(*g)) used.insert(used.end(), g->begin(), g->end());
  }
  if (options.qdd_source == QddSource::kTarget) used.insert(used.end(), qdd.begin(), qdd.end());
  if (has(pose)) {
    static const std::array<const char*, 6> kPoseNames = {"px", "py", "pz", "rx", "ry", "rz"};
    for (std::size_t j = 0; j < 6; ++j) {
      log.extra_names.emplace_back(log.has_joints ? table.names[static_cast<std::size_t>(pose[j])] : kPoseNames[j]);
      log.extra_columns.emplace_back(n);
      for (std::size_t i = 0; i < n; ++i) log.extra_columns.back()[i] = at(table, pose[j], keep[i]);
    }
    used.insert(used.end(), pose.begin(), pose.end());
  }
  for (std::size_t c = 0; c < table.names.size(); ++c) {
    if (std::find(used.begin(), used.end(), static_cast<int>(c)) != used.end()) continue;
    log.extra_names.push_back(table.names[c]);
    log.extra_columns.emplace_back(n);
    for (std::size_t i = 0; i < n; ++i) log.extra_columns.back()[i] = table.columns[c][keep[i]];
  }
  if (log.has_wrench) {
    out.wrench_in_base = true;
    out.notes.push_back("wrench from actual_TCP_force (the controller's estimate: base axes, moments about the TCP)");
    if (options.ur_payload_mass_kg != 0.0) addConfiguredPayload(table, pose, keep, options, log, out.notes);
  }
  out.format = std::string("UR RTDE recording (") + (log.has_joints ? "joint" : "TCP pose") + " state)";
  return out;
}

std::vector<JointVector> smoothedDerivative(const std::vector<double>& t, const std::vector<JointVector>& y, int h) {
  const std::size_t n = t.size();
  std::vector<JointVector> d(n, JointVector::Zero());
  const auto hs = static_cast<std::size_t>(std::max(1, h));
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t lo = i >= hs ? i - hs : 0;
    const std::size_t hi = std::min(n - 1, i + hs);
    double sx = 0.0, sxx = 0.0, cnt = 0.0;
    JointVector sy = JointVector::Zero(), sxy = JointVector::Zero();
    for (std::size_t j = lo; j <= hi; ++j) {
      const double x = t[j] - t[i];
      sx += x;
      sxx += x * x;
      sy += y[j];
      sxy += x * y[j];
      cnt += 1.0;
    }
    const double den = cnt * sxx - sx * sx;
    if (den > 0) d[i] = (cnt * sxy - sx * sy) / den;
  }
  return d;
}

}  // namespace ftid::logio
