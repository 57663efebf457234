// A sensor's own recording and its alignment with the robot's (include/ftid/logio/input.hpp,
// docs/log-format.md "Two files, one log").
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>

#include "ftid/common/error.hpp"
#include "ftid/logio/input.hpp"
#include "ftid/logio/table.hpp"

namespace ftid::logio {

namespace {

constexpr std::array<const char*, 7> kWrenchLogColumns = {"t", "fx", "fy", "fz", "tx", "ty", "tz"};

std::string joined(const std::vector<std::string>& names, std::size_t max_names = 40) {
  std::string out;
  for (std::size_t i = 0; i < names.size() && i < max_names; ++i) out += (i ? ", " : "") + names[i];
  if (names.size() > max_names) out += ", ...";
  return out;
}

double medianStep(const std::vector<LogSample>& s) {
  std::vector<double> d;
  d.reserve(s.size());
  for (std::size_t i = 1; i < s.size(); ++i) d.push_back(s[i].t - s[i - 1].t);
  if (d.empty()) return 0.0;
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
  return d[d.size() / 2];
}

/// Linear interpolation of every numeric field of a sample (time set by the caller).
LogSample lerp(const LogSample& a, const LogSample& b, double s) {
  LogSample o;
  o.q = a.q + s * (b.q - a.q);
  o.qd = a.qd + s * (b.qd - a.qd);
  o.qdd = a.qdd + s * (b.qdd - a.qdd);
  o.wrench_S = a.wrench_S + s * (b.wrench_S - a.wrench_S);
  o.acc_S = a.acc_S + s * (b.acc_S - a.acc_S);
  o.w_S = a.w_S + s * (b.w_S - a.w_S);
  o.alpha_S = a.alpha_S + s * (b.alpha_S - a.alpha_S);
  o.temp_degC = a.temp_degC + s * (b.temp_degC - a.temp_degC);
  return o;
}

/// Walks a time-sorted stream: the bracket [k, k+1] of each (non-decreasing) query time.
struct Bracket {
  const std::vector<double>& t;
  std::size_t k = 0;
  /// False if `x` is outside the stream or its bracket is longer than max_gap.
  bool find(double x, double max_gap, std::size_t& lo, double& s) {
    if (t.size() < 2 || x < t.front() || x > t.back()) return false;
    while (k + 2 < t.size() && t[k + 1] <= x) ++k;
    lo = k;
    const double dt = t[k + 1] - t[k];
    if (!(dt <= max_gap)) return false;
    s = (x - t[k]) / dt;
    return true;
  }
};

std::string hz(double step) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g Hz", step > 0 ? 1.0 / step : 0.0);
  return buf;
}

}  // namespace

bool wrenchLogUsesColumn(const std::string& name) {
  try {
    const std::string alias = columnAlias(name);
    return std::find(kWrenchLogColumns.begin(), kWrenchLogColumns.end(), alias) != kWrenchLogColumns.end();
  } catch (const DataError&) {
    return true;  // a refused unit: the reader reports it
  }
}

LogData wrenchLogFromTable(const Table& table, const LogReadOptions& read) {
  std::array<int, 7> col{};
  col.fill(-1);
  const std::string where = table.source + ":" + std::to_string(table.header_line) + ":";
  for (std::size_t c = 0; c < table.names.size(); ++c) {
    std::string alias;
    try {
      alias = columnAlias(table.names[c]);
    } catch (const DataError& e) {
      throw DataError(where + std::to_string(table.name_position[c]) + ": " + e.what());
    }
    for (std::size_t k = 0; k < kWrenchLogColumns.size(); ++k) {
      if (alias != kWrenchLogColumns[k]) continue;
      if (col[k] >= 0) {
        throw DataError(where + std::to_string(table.name_position[c]) + ": columns '" +
                        table.names[static_cast<std::size_t>(col[k])] + "' and '" + table.names[c] + "' both mean '" +
                        kWrenchLogColumns[k] + "'; keep one");
      }
      col[k] = static_cast<int>(c);
    }
  }
  std::vector<std::string> missing;
  for (std::size_t k = 0; k < col.size(); ++k) {
    if (col[k] < 0) missing.emplace_back(kWrenchLogColumns[k]);
  }
  if (!missing.empty()) {
    throw DataError(where + "1: a wrench log needs a time column (t, time or timestamp, in seconds) and the six "
                            "wrench columns fx..tz (also Fx..Tz, Mx..Mz, force_x.., torque_x..); missing: " +
                    joined(missing) + " (the header has: " + joined(table.names) + ")");
  }
  LogData log;
  log.source = table.source;
  log.has_joints = false;
  log.has_wrench = true;
  const std::size_t n = table.rows();
  log.samples.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    LogSample& s = log.samples[i];
    s.t = table.columns[static_cast<std::size_t>(col[0])][i];
    if (!(std::abs(s.t) <= read.max_abs_t_s) || (i > 0 && !(s.t > log.samples[i - 1].t))) {
      char buf[240];
      std::snprintf(buf, sizeof buf, "%s:%zu: column '%s': time %.17g %s", table.source.c_str(), table.row_line[i],
                    table.names[static_cast<std::size_t>(col[0])].c_str(), s.t,
                    i > 0 && !(s.t > log.samples[i - 1].t) ? "is not greater than the previous row's (times must increase)"
                                                          : "is outside the plausible range");
      throw DataError(buf);
    }
    for (std::size_t a = 0; a < 6; ++a) {
      const double v = table.columns[static_cast<std::size_t>(col[a + 1])][i];
      if (!(std::abs(v) <= read.max_abs_wrench_S[a])) {
        char buf[240];
        std::snprintf(buf, sizeof buf,
                      "%s:%zu: column '%s': value %.6g is outside the plausible range +-%.6g %s (100x the sensor's "
                      "rated range)",
                      table.source.c_str(), table.row_line[i], table.names[static_cast<std::size_t>(col[a + 1])].c_str(),
                      v, read.max_abs_wrench_S[a], a < 3 ? "N" : "Nm");
        throw DataError(buf);
      }
      s.wrench_S[static_cast<Eigen::Index>(a)] = v;
    }
  }
  return log;
}

LogData alignWrench(const LogData& robot, const LogData& wrench, double offset_s, std::vector<std::string>& notes) {
  if (robot.samples.size() < 2 || wrench.samples.size() < 2) {
    throw DataError((robot.samples.size() < 2 ? robot.source : wrench.source) +
                    ": at least two rows are needed to align the robot's and the sensor's recordings");
  }
  std::vector<double> tr(robot.samples.size()), tw(wrench.samples.size());
  for (std::size_t i = 0; i < tr.size(); ++i) tr[i] = robot.samples[i].t;
  for (std::size_t i = 0; i < tw.size(); ++i) tw[i] = wrench.samples[i].t + offset_s;
  const double lo = std::max(tr.front(), tw.front());
  const double hi = std::min(tr.back(), tw.back());
  if (!(lo < hi)) {
    char buf[400];
    std::snprintf(buf, sizeof buf,
                  "%s covers %.9g..%.9g s and %s covers %.9g..%.9g s (after --wrench-time-offset %.6g s): no span "
                  "in common. Are both recorded on the same clock? A known offset between the clocks: "
                  "--wrench-time-offset S",
                  robot.source.c_str(), tr.front(), tr.back(), wrench.source.c_str(), tw.front(), tw.back(), offset_s);
    throw DataError(buf);
  }
  const double step_r = medianStep(robot.samples);
  const double step_w = medianStep(wrench.samples);
  // A pose log keeps its instants (its rotation columns are not interpolated).
  const bool at_robot = step_r >= step_w || !robot.has_joints;
  LogData out;
  out.source = robot.source;
  out.has_joints = robot.has_joints;
  out.has_wrench = true;
  out.has_imu = robot.has_imu;
  out.has_temp = robot.has_temp;
  out.extra_names = robot.extra_names;
  out.extra_columns.assign(robot.extra_names.size(), {});
  // A bracket longer than 10 sample periods of the faster stream is a drop-out: no sample there.
  std::size_t gaps = 0;
  if (at_robot) {
    Bracket b{tw};
    for (std::size_t i = 0; i < tr.size(); ++i) {
      if (tr[i] < lo || tr[i] > hi) continue;
      std::size_t k = 0;
      double s = 0.0;
      if (!b.find(tr[i], 10.0 * step_w + 1e-12, k, s)) {
        ++gaps;
        continue;
      }
      LogSample smp = robot.samples[i];
      smp.wrench_S = lerp(wrench.samples[k], wrench.samples[k + 1], s).wrench_S;
      out.samples.push_back(smp);
      for (std::size_t e = 0; e < out.extra_columns.size(); ++e) out.extra_columns[e].push_back(robot.extra_columns[e][i]);
    }
  } else {
    Bracket b{tr};
    for (std::size_t i = 0; i < tw.size(); ++i) {
      if (tw[i] < lo || tw[i] > hi) continue;
      std::size_t k = 0;
      double s = 0.0;
      if (!b.find(tw[i], 10.0 * step_r + 1e-12, k, s)) {
        ++gaps;
        continue;
      }
      LogSample smp = lerp(robot.samples[k], robot.samples[k + 1], s);
      smp.t = tw[i];
      smp.wrench_S = wrench.samples[i].wrench_S;
      out.samples.push_back(smp);
      for (std::size_t e = 0; e < out.extra_columns.size(); ++e) {
        const auto& c = robot.extra_columns[e];
        out.extra_columns[e].push_back(c[k] + s * (c[k + 1] - c[k]));
      }
    }
  }
  if (out.samples.size() < 2) {
    throw DataError(robot.source + " and " + wrench.source + ": fewer than two samples in the span both cover");
  }
  char buf[600];
  std::snprintf(buf, sizeof buf,
                "aligned %s (%s, %zu rows) with %s (%s, %zu rows): %s over the span both cover, %.9g..%.9g s: "
                "%zu samples used",
                wrench.source.c_str(), hz(step_w).c_str(), wrench.samples.size(), robot.source.c_str(),
                hz(step_r).c_str(), robot.samples.size(),
                at_robot ? "the wrench interpolated linearly at the robot's instants"
                         : "the robot's joint state interpolated linearly at the sensor's instants",
                lo, hi, out.samples.size());
  notes.emplace_back(buf);
  if (offset_s != 0.0) {
    std::snprintf(buf, sizeof buf, "the sensor's times shifted by %.9g s (--wrench-time-offset)", offset_s);
    notes.emplace_back(buf);
  }
  if (gaps > 0) {
    notes.push_back("left out " + std::to_string(gaps) + " samples that fall in gaps of the faster recording " +
                    "longer than 10 of its sample periods (drop-outs)");
  }
  return out;
}

}  // namespace ftid::logio
