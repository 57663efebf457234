// CSV log reader/writer (docs/log-format.md). The reader loads the file in one piece and parses
// fields in place with std::from_chars (no iostream per field); every error names
// FILE:LINE:COLUMN, where COLUMN is the 1-based character position of the offending field.
#include "ftid/logio/log.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string_view>
#include <system_error>
#include <tuple>
#include <unordered_map>

#include "ftid/common/error.hpp"
#include "ftid/fileio/atomic_file.hpp"
#include "ftid/fileio/input_file.hpp"
#include "ftid/logio/input.hpp"
#include "file_lines.hpp"
#include "line_cursor.hpp"
#include "row_thinner.hpp"

namespace ftid::logio {

int LogData::extraIndex(const std::string& name) const {
  for (std::size_t i = 0; i < extra_names.size(); ++i) {
    if (extra_names[i] == name) return static_cast<int>(i);
  }
  return -1;
}

void LogData::keepRows(const std::vector<char>& keep) {
  std::size_t n = 0;
  for (std::size_t i = 0; i < keep.size(); ++i) {
    if (keep[i] == 0) continue;
    samples[n] = samples[i];
    for (auto& c : extra_columns) c[n] = c[i];
    ++n;
  }
  samples.resize(n);
  for (auto& c : extra_columns) c.resize(n);
}

namespace {

// Slot of every known column in the sample.
enum Group { kCore, kWrench, kImu, kTemp };
struct KnownColumn {
  const char* name;
  Group group;
};

constexpr int kNumKnown = 1 + 18 + 6 + 9 + 1;
const std::array<KnownColumn, kNumKnown>& knownColumns() {
  static const std::array<KnownColumn, kNumKnown> cols = {{
      {"t", kCore},     {"q1", kCore},    {"q2", kCore},    {"q3", kCore},    {"q4", kCore},
      {"q5", kCore},    {"q6", kCore},    {"qd1", kCore},   {"qd2", kCore},   {"qd3", kCore},
      {"qd4", kCore},   {"qd5", kCore},   {"qd6", kCore},   {"qdd1", kCore},  {"qdd2", kCore},
      {"qdd3", kCore},  {"qdd4", kCore},  {"qdd5", kCore},  {"qdd6", kCore},  {"fx", kWrench},
      {"fy", kWrench},  {"fz", kWrench},  {"tx", kWrench},  {"ty", kWrench},  {"tz", kWrench},
      {"ax", kImu},     {"ay", kImu},     {"az", kImu},     {"wx", kImu},     {"wy", kImu},
      {"wz", kImu},     {"alx", kImu},    {"aly", kImu},    {"alz", kImu},    {"temp", kTemp},
  }};
  return cols;
}

double* slotOf(LogSample& s, int known) {
  if (known == 0) return &s.t;
  if (known <= 6) return &s.q[known - 1];
  if (known <= 12) return &s.qd[known - 7];
  if (known <= 18) return &s.qdd[known - 13];
  if (known <= 24) return &s.wrench_S[known - 19];
  if (known <= 27) return &s.acc_S[known - 25];
  if (known <= 30) return &s.w_S[known - 28];
  if (known <= 33) return &s.alpha_S[known - 31];
  return &s.temp_degC;
}

double valueOf(const LogSample& s, int known) { return *slotOf(const_cast<LogSample&>(s), known); }

std::string_view trim(std::string_view v) {
  while (!v.empty() && (v.front() == ' ' || v.front() == '\t')) v.remove_prefix(1);
  while (!v.empty() && (v.back() == ' ' || v.back() == '\t' || v.back() == '\r')) v.remove_suffix(1);
  return v;
}

[[noreturn]] void dataError(const std::string& file, std::size_t line, std::size_t column,
                            const std::string& message) {
  throw DataError(file + ":" + std::to_string(line) + ":" + std::to_string(column) + ": " + message);
}

// Parses one number; returns false with a reason if it is not a finite number.
/// At most 40 characters of a field, for messages.
std::string shown(std::string_view v) {
  return v.size() <= 40 ? std::string(v) : std::string(v.substr(0, 40)) + "...";
}

bool parseNumber(std::string_view field, double& out, std::string& why) {
  const std::string_view v = trim(field);
  if (v.empty()) {
    why = "empty field";
    return false;
  }
  std::string_view body = v;
  if (body.front() == '+') {
    body.remove_prefix(1);
    if (!body.empty() && (body.front() == '-' || body.front() == '+')) {
      why = "not a number: '" + shown(v) + "'";
      return false;
    }
  }
  const char* first = body.data();
  const char* last = body.data() + body.size();
  auto res = std::from_chars(first, last, out);
  if (res.ec == std::errc::result_out_of_range) {
    why = "number '" + shown(v) + "' is out of the range of a double";
    return false;
  }
  if (res.ec != std::errc() || res.ptr != last) {
    why = "not a number: '" + shown(v) + "'";
    return false;
  }
  if (!std::isfinite(out)) {
    why = "non-finite value '" + shown(v) + "' (NaN and infinity are not allowed)";
    return false;
  }
  return true;
}

std::string readWholeFile(const std::string& path) { return readLogText(path); }


/// Largest plausible |value| of every known column (LogReadOptions, docs/log-format.md).
std::array<double, kNumKnown> plausibleLimits(const LogReadOptions& o) {
  std::array<double, kNumKnown> lim{};
  for (int k = 0; k < kNumKnown; ++k) {
    double l = 0.0;
    if (k == 0) l = o.max_abs_t_s;
    else if (k <= 6) l = o.max_abs_q_rad;
    else if (k <= 12) l = o.max_abs_qd_rad_s;
    else if (k <= 18) l = o.max_abs_qdd_rad_s2;
    else if (k <= 24) l = o.max_abs_wrench_S[static_cast<std::size_t>(k - 19)];
    else if (k <= 27) l = o.max_abs_acc_m_s2;
    else if (k <= 30) l = o.max_abs_w_rad_s;
    else if (k <= 33) l = o.max_abs_alpha_rad_s2;
    else l = o.max_abs_temp_degC;
    lim[static_cast<std::size_t>(k)] = l;
  }
  return lim;
}

const char* limitReason(int k) {
  if (k >= 1 && k <= 6) return "rad (joint angles within +-4 pi)";
  if (k >= 19 && k <= 21) return "N (100x the sensor's rated range)";
  if (k >= 22 && k <= 24) return "Nm (100x the sensor's rated range)";
  return "(SI units; see docs/log-format.md)";
}

/// missingColumnHint (input.hpp) for a ", "-separated list of missing names.
std::string hintFor(const std::string& missing, const std::vector<std::string>& present) {
  std::vector<std::string> names;
  for (std::size_t start = 0; start < missing.size();) {
    const std::size_t end = missing.find(", ", start);
    names.push_back(missing.substr(start, end == std::string::npos ? std::string::npos : end - start));
    start = end == std::string::npos ? missing.size() : end + 2;
  }
  return missingColumnHint(names, present);
}

bool isBlankOrComment(std::string_view line) {
  std::string_view v = trim(line);
  return v.empty() || v.front() == '#';
}

}  // namespace

LogData readLog(const std::string& path, LogKind kind, const LogReadOptions& options) {
  return parseLogText(readWholeFile(path), path, kind, options);
}

namespace {

/// The header row's mapping of fields to columns.
struct ColumnMap {
  std::size_t header_line = 0;           ///< line of the header row (1-based)
  std::vector<int> field_known;          ///< per field: known column index or -1
  std::vector<int> field_extra;          ///< per field: extra column index or -1
  std::array<int, kNumKnown> known_field{};  ///< per known column: its field or -1
  /// The header ends with a comma (an empty last field): a row's trailing comma is dropped too.
  bool trailing_separator = false;
};

/// Advances `cur` to the header row (the first line that is neither blank nor a comment) and
/// returns it; refuses an empty log, a UR recording's header and an overlong header row.
template <class Cursor>
std::string_view readHeaderRow(Cursor& cur, const std::string& path) {
  std::string_view line;
  bool have_header = false;
  while (cur.next(line)) {
    if (!isBlankOrComment(line)) {
      have_header = true;
      break;
    }
  }
  if (!have_header) dataError(path, cur.line_no == 0 ? 1 : cur.line_no, 1, "empty log: no header row");
  if (isUrRecordHeader(line)) {
    dataError(path, cur.line_no, 1,
              "this is a UR RTDE recording (record.py or ur_rtde), not an ftid log: ftid identify, analyze, "
              "compensate and convert read it (docs/log-format.md \"UR recordings\")");
  }
  if (line.size() > kMaxHeaderBytes) {
    dataError(path, cur.line_no, 1,
              "header row is " + std::to_string(line.size()) + " characters long; at most " +
                  std::to_string(kMaxHeaderBytes) + " are accepted");
  }
  return line;
}

/// Maps each field of the header row to a known column or a new extra column of `log` (its
/// name appended to log.extra_names); refuses empty and duplicate names and too many columns.
ColumnMap mapColumns(std::string_view line, std::size_t header_line, const std::string& path, LogData& log) {
  const auto& known = knownColumns();
  ColumnMap map;
  map.header_line = header_line;
  map.known_field.fill(-1);
  // Duplicate names are found with a hash map: linear in the header length.
  std::unordered_map<std::string_view, std::size_t> seen;  // name -> its 1-based column
  if (const char* why = otherSeparator(line); *why != '\0') dataError(path, header_line, 1, why);
  std::size_t start = 0;
  int field = 0;
  while (true) {
    std::size_t comma = line.find(',', start);
    std::string_view name =
        unquoted(trim(line.substr(start, comma == std::string_view::npos ? line.npos : comma - start)));
    if (name.empty() && comma == std::string_view::npos && field > 0) {
      map.trailing_separator = true;  // "t,q1,...,tz," (a writer that ends every line with a comma)
      break;
    }
    if (name.empty()) dataError(path, header_line, start + 1, "empty column name in header");
    if (static_cast<std::size_t>(field) >= kMaxColumns) {
      dataError(path, header_line, start + 1,
                "too many columns in the header (at most " + std::to_string(kMaxColumns) + ")");
    }
    const auto [it, inserted] = seen.emplace(name, start + 1);
    if (!inserted) {
      dataError(path, header_line, start + 1,
                "duplicate column '" + shown(name) + "' (first at column " + std::to_string(it->second) + ")");
    }
    int k = -1;
    for (int i = 0; i < kNumKnown; ++i) {
      if (name == known[static_cast<std::size_t>(i)].name) k = i;
    }
    if (k >= 0) {
      map.known_field[static_cast<std::size_t>(k)] = field;
      map.field_known.push_back(k);
      map.field_extra.push_back(-1);
    } else {
      map.field_known.push_back(-1);
      map.field_extra.push_back(static_cast<int>(log.extra_names.size()));
      log.extra_names.emplace_back(name);
    }
    ++field;
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return map;
}

/// The known columns of group `g` the header lacks (", "-separated), how many it has, and of how many.
std::tuple<std::string, int, int> missingOf(const ColumnMap& map, Group g) {
  const auto& known = knownColumns();
  std::string missing;
  int present = 0, total = 0;
  for (int i = 0; i < kNumKnown; ++i) {
    if (known[static_cast<std::size_t>(i)].group != g) continue;
    ++total;
    if (map.known_field[static_cast<std::size_t>(i)] >= 0) {
      ++present;
    } else {
      missing += (missing.empty() ? "" : ", ") + std::string(known[static_cast<std::size_t>(i)].name);
    }
  }
  return std::make_tuple(missing, present, total);
}

/// Required columns and all-or-nothing groups; sets log.has_joints, has_wrench, has_imu, has_temp.
void checkColumnGroups(const ColumnMap& map, const std::string& path, LogKind kind, LogData& log) {
  const std::size_t header_line = map.header_line;
  {
    // t always; the joint columns q, qd, qdd unless the log gives the sensor pose instead
    // (qx,qy,qz,qw or rx,ry,rz: kept as extra columns, read by samples::buildContexts).
    auto [missing, present, total] = missingOf(map, kCore);
    if (map.known_field[0] < 0) {
      dataError(path, header_line, 1, "missing required column(s): " + missing + hintFor(missing, log.extra_names));
    }
    const auto hasExtra = [&](std::initializer_list<const char*> names) {
      for (const char* n : names) {
        if (log.extraIndex(n) < 0) return false;
      }
      return true;
    };
    const bool pose = hasExtra({"qx", "qy", "qz", "qw"}) || hasExtra({"rx", "ry", "rz"});
    log.has_joints = present == total;
    if (!log.has_joints && (present > 1 || !pose)) {
      dataError(path, header_line, 1,
                "missing required column(s): " + missing +
                    (present > 1 ? "" : " (or, instead of joint angles, the sensor pose: qx,qy,qz,qw or rx,ry,rz)") +
                    hintFor(missing, log.extra_names));
    }
  }
  {
    auto [missing, present, total] = missingOf(map, kWrench);
    if (kind == LogKind::kMeasurement && present != total) {
      dataError(path, header_line, 1,
                "missing required wrench column(s): " + missing + hintFor(missing, log.extra_names) +
                    (present == 0 ? " (a robot recording without the wrench: give the sensor's own recording with "
                                    "--wrench-log FILE)"
                                  : ""));
    }
    if (present != 0 && present != total) {
      dataError(path, header_line, 1, "incomplete wrench columns, missing: " + missing + hintFor(missing, log.extra_names));
    }
    log.has_wrench = present == total;
  }
  {
    auto [missing, present, total] = missingOf(map, kImu);
    if (present != 0 && present != total) {
      dataError(path, header_line, 1,
                "incomplete IMU columns (ax..alz must be all present or all absent), missing: " + missing);
    }
    log.has_imu = present == total;
  }
  log.has_temp = map.known_field[kNumKnown - 1] >= 0;
}

/// Parses the fields of the data row `line` (line `line_no`) into `sample` (known columns,
/// each within its plausible range `limits`) and `extras` (the extra columns, in order); returns the
/// 1-based character position of the t field. Refuses a field that is not a number and a row
/// with more or fewer fields than the header.
std::size_t parseRow(std::string_view line, std::size_t line_no, const ColumnMap& map,
                     const std::array<double, kNumKnown>& limits, const std::string& path, LogSample& sample,
                     const LogData& log, std::vector<double>& extras) {
  const auto& known = knownColumns();
  const std::size_t n_fields = map.field_known.size();
  std::string why;
  std::size_t t_column = 1;
  std::size_t start = 0;
  std::size_t field = 0;
  if (map.trailing_separator) {
    while (!line.empty() && (line.back() == ' ' || line.back() == '\t')) line.remove_suffix(1);
    if (!line.empty() && line.back() == ',') line.remove_suffix(1);
  }
  while (true) {
    const std::size_t comma = line.find(',', start);
    const std::string_view f =
        unquoted(trim(line.substr(start, comma == std::string_view::npos ? line.npos : comma - start)));
    if (field >= n_fields) {
      dataError(path, line_no, start + 1,
                "too many fields: expected " + std::to_string(n_fields) + " (as in the header on line " +
                    std::to_string(map.header_line) + ")");
    }
    double v = 0.0;
    const int k = map.field_known[field];
    if (!parseNumber(f, v, why)) {
      const std::string name = k >= 0 ? known[static_cast<std::size_t>(k)].name
                                      : log.extra_names[static_cast<std::size_t>(map.field_extra[field])];
      dataError(path, line_no, start + 1, "column '" + name + "': " + why);
    }
    if (k == 0) t_column = start + 1;
    if (k >= 0) {
      const double limit = limits[static_cast<std::size_t>(k)];
      if (!(std::abs(v) <= limit)) {
        char buf[200];
        std::snprintf(buf, sizeof buf, "column '%s': value %.6g is outside the plausible range +-%.6g %s",
                      known[static_cast<std::size_t>(k)].name, v, limit, limitReason(k));
        dataError(path, line_no, start + 1, buf);
      }
      *slotOf(sample, k) = v;
    } else {
      extras[static_cast<std::size_t>(map.field_extra[field])] = v;
    }
    ++field;
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  if (field != n_fields) {
    dataError(path, line_no, line.size() + 1,
              "too few fields: expected " + std::to_string(n_fields) + " (as in the header on line " +
                  std::to_string(map.header_line) + "), found " + std::to_string(field));
  }
  return t_column;
}

/// Parses and checks every data row after the header (t must increase strictly from row to
/// row) and hands each to store(sample, extras).
template <class Cursor, class Store>
void parseRows(Cursor& cur, const ColumnMap& map, const std::string& path, const LogReadOptions& options,
               const LogData& log, Store&& store) {
  const std::array<double, kNumKnown> limits = plausibleLimits(options);
  std::vector<double> extras(log.extra_names.size(), 0.0);
  double previous_t = 0.0;
  std::size_t previous_t_line = 0;
  bool first = true;
  std::string_view line;
  while (cur.next(line)) {
    if (isBlankOrComment(line)) continue;
    LogSample sample;
    const std::size_t t_column = parseRow(line, cur.line_no, map, limits, path, sample, log, extras);
    if (!first && !(sample.t > previous_t)) {
      char buf[160];
      std::snprintf(buf, sizeof buf, "column 't': time %.17g is not greater than %.17g on line %zu (t must be strictly increasing)",
                    sample.t, previous_t, previous_t_line);
      dataError(path, cur.line_no, t_column, buf);
    }
    first = false;
    previous_t = sample.t;
    previous_t_line = cur.line_no;
    store(sample, extras);
  }
}

/// Appends a row to the log.
void appendRow(LogData& log, const LogSample& sample, const std::vector<double>& extras) {
  log.samples.push_back(sample);
  for (std::size_t k = 0; k < extras.size(); ++k) log.extra_columns[k].push_back(extras[k]);
}

}  // namespace

LogData parseLogText(std::string_view text, const std::string& path, LogKind kind, const LogReadOptions& options) {
  LogData log;
  log.source = path;
  LineCursor cur{text};
  const std::string_view header = readHeaderRow(cur, path);
  const ColumnMap map = mapColumns(header, cur.line_no, path, log);
  checkColumnGroups(map, path, kind, log);
  log.extra_columns.assign(log.extra_names.size(), {});
  const std::size_t rows_estimate = text.size() / (map.field_known.size() * 8 + 1) + 1;
  log.samples.reserve(rows_estimate);
  for (auto& c : log.extra_columns) c.reserve(rows_estimate);
  parseRows(cur, map, path, options, log,
            [&log](const LogSample& sample, const std::vector<double>& extras) { appendRow(log, sample, extras); });
  if (log.samples.empty()) dataError(path, map.header_line, 1, "log has a header but no data rows");
  return log;
}

std::size_t rowBudget(std::size_t max_rows, std::size_t extra_columns) {
  const double rows = static_cast<double>(max_rows) * static_cast<double>(kWorkingBytesPerRow) /
                      static_cast<double>(kWorkingBytesPerRow + kExtraColumnBytesPerRow * extra_columns);
  // At least 2: one row of each class in its first block, which no stride leaves out.
  return std::max<std::size_t>(2, static_cast<std::size_t>(rows));
}

std::size_t thinBlockRows(std::size_t budget_rows) { return std::clamp<std::size_t>(budget_rows / 16, 1, 256); }

bool isUrRecordFile(const std::string& path) {
  FileLineCursor cur(path, kMaxStreamedLogBytes);
  std::string_view line;
  while (cur.next(line)) {
    if (!isBlankOrComment(line)) return isUrRecordHeader(line);
  }
  return false;
}

namespace {

[[noreturn]] void refusePoseLog(const std::string& path, std::size_t rows, std::size_t max_rows, std::size_t budget,
                                std::size_t extras) {
  const double bytes = static_cast<double>(rows) * static_cast<double>(kWorkingBytesPerRow + kExtraColumnBytesPerRow * extras);
  char need[32];
  std::snprintf(need, sizeof need, bytes >= 1e9 ? "%.1f GB" : "%.0f MB", bytes >= 1e9 ? bytes / 1e9 : bytes / 1e6);
  throw DataError(path + ": " + std::to_string(rows) + " data rows, more than --max-rows " + std::to_string(max_rows) +
                  " (" + std::to_string(budget) + " rows with its extra columns) allows: a pose log is used whole, "
                  "because its poses are differenced and rows left out would falsify the velocities (it would need "
                  "about " + need + " of memory). Cut it into parts by time, or raise --max-rows (0: no limit but "
                  "FTID_MAX_LOG_ROWS) if the machine has the memory (docs/log-format.md \"Limits\")");
}

}  // namespace

ThinnedLog readLogThinned(const std::string& path, LogKind kind, const LogReadOptions& options, std::size_t max_rows) {
  ThinnedLog out;
  LogData& log = out.log;
  log.source = path;
  FileLineCursor cur(path, kMaxStreamedLogBytes);
  const std::string_view header = readHeaderRow(cur, path);
  const ColumnMap map = mapColumns(header, cur.line_no, path, log);
  checkColumnGroups(map, path, kind, log);
  log.extra_columns.assign(log.extra_names.size(), {});
  out.budget_rows = rowBudget(max_rows, log.extra_names.size());
  out.block_rows = thinBlockRows(out.budget_rows);
  // The vectors grow to at most budget + 1 rows (not by doubling beyond it).
  const std::size_t cap = out.budget_rows + 1;
  const auto reserveRows = [&log](std::size_t n) {
    log.samples.reserve(n);
    for (auto& c : log.extra_columns) c.reserve(n);
  };
  reserveRows(std::min(cap, cur.fileSize() / (map.field_known.size() * 8 + 1) + 1));
  RowThinner thinner(out.budget_rows, out.block_rows);
  std::size_t rows = 0;
  bool refused = false;
  parseRows(cur, map, path, options, log, [&](const LogSample& sample, const std::vector<double>& extras) {
    ++rows;
    if (refused || !thinner.offer(sample.qd.cwiseAbs().maxCoeff() < kStillSpeedRadS)) return;
    if (log.samples.size() == log.samples.capacity()) reserveRows(std::min(cap, 2 * log.samples.size() + 1024));
    appendRow(log, sample, extras);
    if (!thinner.over()) return;
    if (!log.has_joints) {
      refused = true;  // every row is still checked, so the message gives the whole count
      log.samples = {};
      for (auto& c : log.extra_columns) c = {};
      return;
    }
    log.keepRows(thinner.thin());
  });
  if (rows == 0) dataError(path, map.header_line, 1, "log has a header but no data rows");
  if (refused) refusePoseLog(path, rows, max_rows, out.budget_rows, log.extra_names.size());
  out.rows = rows;
  out.still_rows = thinner.rows(true);
  out.moving_rows = thinner.rows(false);
  out.still_stride = thinner.stride(true);
  out.moving_stride = thinner.stride(false);
  return out;
}

namespace {

void appendNumber(std::string& out, double v) {
  char buf[32];
  auto res = std::to_chars(buf, buf + sizeof buf, v);  // shortest representation that round-trips
  out.append(buf, res.ptr);
}

}  // namespace

void writeLog(const std::string& path, const LogData& log) {
  const auto& known = knownColumns();
  std::vector<int> cols;
  for (int i = 0; i < kNumKnown; ++i) {
    const Group g = known[static_cast<std::size_t>(i)].group;
    if ((g == kCore && (i == 0 || log.has_joints)) || (g == kWrench && log.has_wrench) || (g == kImu && log.has_imu) ||
        (g == kTemp && log.has_temp)) {
      cols.push_back(i);
    }
  }
  if (log.extra_columns.size() != log.extra_names.size()) {
    throw DataError(path + ": extra_names and extra_columns differ in size");
  }
  for (std::size_t e = 0; e < log.extra_columns.size(); ++e) {
    if (log.extra_columns[e].size() != log.samples.size()) {
      throw DataError(path + ": extra column '" + log.extra_names[e] + "' has " +
                      std::to_string(log.extra_columns[e].size()) + " values for " +
                      std::to_string(log.samples.size()) + " samples");
    }
  }
  std::string out;
  out.reserve(64 + log.samples.size() * (cols.size() + log.extra_names.size()) * 20);
  for (std::size_t c = 0; c < cols.size(); ++c) {
    if (c) out += ',';
    out += known[static_cast<std::size_t>(cols[c])].name;
  }
  for (const auto& name : log.extra_names) {
    if (name.empty() || name.find_first_of(",\n\r") != std::string::npos) {
      throw DataError(path + ": invalid extra column name '" + name + "'");
    }
    out += ',';
    out += name;
  }
  out += '\n';
  for (std::size_t i = 0; i < log.samples.size(); ++i) {
    const LogSample& s = log.samples[i];
    if (i > 0 && !(s.t > log.samples[i - 1].t)) {
      throw DataError(path + ": sample " + std::to_string(i) + ": t is not strictly increasing");
    }
    for (std::size_t c = 0; c < cols.size(); ++c) {
      const double v = valueOf(s, cols[c]);
      if (!std::isfinite(v)) {
        throw DataError(path + ": sample " + std::to_string(i) + ", column '" +
                        known[static_cast<std::size_t>(cols[c])].name + "': non-finite value");
      }
      if (c) out += ',';
      appendNumber(out, v);
    }
    for (std::size_t e = 0; e < log.extra_columns.size(); ++e) {
      const double v = log.extra_columns[e][i];
      if (!std::isfinite(v)) {
        throw DataError(path + ": sample " + std::to_string(i) + ", column '" + log.extra_names[e] +
                        "': non-finite value");
      }
      out += ',';
      appendNumber(out, v);
    }
    out += '\n';
  }

  // Atomic replace (ftid/fileio/atomic_file.hpp): refuses symlinks, devices, FIFOs, directories.
  try {
    writeFileAtomically(path, out);
  } catch (const FileError& e) {
    throw DataError(e.what());
  }
}

}  // namespace ftid::logio
