// Column aliases and the hints of the readers' refusals (include/ftid/logio/input.hpp).
#include <algorithm>
#include <array>
#include <cctype>
#include <string>

#include "ftid/common/error.hpp"
#include "ftid/logio/input.hpp"

namespace ftid::logio {

namespace {

/// The unit in a trailing [] or () of `name` ("" if none); `base` gets the name without it.
std::string unitOf(std::string_view name, std::string_view& base) {
  std::string_view v = name;
  while (!v.empty() && v.back() == ' ') v.remove_suffix(1);
  base = v;
  if (v.empty() || (v.back() != ']' && v.back() != ')')) return "";
  const std::size_t open = v.find_last_of(v.back() == ']' ? '[' : '(');
  if (open == std::string_view::npos || open == 0) return "";
  base = v.substr(0, open);
  std::string unit(v.substr(open + 1, v.size() - open - 2));
  unit.erase(std::remove(unit.begin(), unit.end(), ' '), unit.end());
  return unit;
}

/// Lower case, then only letters and digits.
std::string normalised(std::string_view v) {
  std::string out;
  for (const char c : v) {
    if (std::isalnum(static_cast<unsigned char>(c)) != 0) {
      out += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    }
  }
  return out;
}

/// Whether `unit` is the SI unit ftid reads for the native column `alias`.
bool siUnitFits(const std::string& alias, const std::string& unit) {
  if (alias == "t") return unit == "s";
  if (alias[0] == 'f') return unit == "N";
  if (alias[0] == 't' && alias.size() == 2) {
    return unit == "Nm" || unit == "N\xc2\xb7m" || unit == "N-m" || unit == "N*m" || unit == "N.m";
  }
  if (alias.rfind("qdd", 0) == 0) return unit == "rad/s^2" || unit == "rad/s2" || unit == "rad/s\xc2\xb2";
  if (alias.rfind("qd", 0) == 0) return unit == "rad/s";
  if (alias[0] == 'q') return unit == "rad";
  return false;  // other columns take no unit suffix
}

const char* siUnitName(const std::string& alias) {
  if (alias == "t") return "s";
  if (alias[0] == 'f') return "N";
  if (alias[0] == 't' && alias.size() == 2) return "Nm (also N\xc2\xb7m, N-m, N*m)";
  if (alias.rfind("qdd", 0) == 0) return "rad/s^2";
  if (alias.rfind("qd", 0) == 0) return "rad/s";
  if (alias[0] == 'q') return "rad";
  return "none";
}

const std::array<const char*, 35>& nativeNames() {
  static const std::array<const char*, 35> names = {
      "t",    "q1",   "q2",   "q3",   "q4",   "q5",   "q6",  "qd1", "qd2", "qd3", "qd4", "qd5",
      "qd6",  "qdd1", "qdd2", "qdd3", "qdd4", "qdd5", "qdd6", "fx", "fy",  "fz",  "tx",  "ty",
      "tz",   "ax",   "ay",   "az",   "wx",   "wy",   "wz",  "alx", "aly", "alz", "temp"};
  return names;
}

std::string aliasOf(const std::string& n);

}  // namespace

std::string columnAlias(std::string_view name) {
  std::string_view base;
  const std::string unit = unitOf(name, base);
  const std::string alias = aliasOf(normalised(base));
  if (!alias.empty() && !unit.empty() && !siUnitFits(alias, unit)) {
    throw DataError("column '" + std::string(name) + "': unit '" + unit + "' (ftid reads '" + alias + "' in " +
                    siUnitName(alias) + " only; convert the column or rename it)");
  }
  return alias;
}

namespace {
std::string aliasOf(const std::string& n) {
  if (n.empty()) return "";
  if (n == "t" || n == "time" || n == "timestamp" || n == "times" || n == "stamp" || n == "timesec") return "t";
  if (n == "temperature") return "temp";
  for (const char* axis : {"x", "y", "z"}) {
    const std::string a(axis);
    for (const char* f : {"f", "force", "forces"}) {
      if (n == f + a) return "f" + a;
    }
    for (const char* t : {"t", "m", "torque", "torques", "moment", "moments"}) {
      if (n == t + a) return "t" + a;
    }
  }
  // UR RTDE names (0-based joints): actual_q_0 -> q1, actual_qd_0 -> qd1, target_qdd_0 -> qdd1.
  for (const auto& [prefix, column] : {std::pair<const char*, const char*>{"actualqd", "qd"},
                                       std::pair<const char*, const char*>{"actualq", "q"},
                                       std::pair<const char*, const char*>{"targetqdd", "qdd"}}) {
    const std::string p(prefix);
    if (n.size() == p.size() + 1 && n.compare(0, p.size(), p) == 0 && n.back() >= '0' && n.back() <= '5') {
      return std::string(column) + static_cast<char>(n.back() + 1);
    }
  }
  for (const char* native : nativeNames()) {
    if (n == native) return native;
  }
  return "";
}

}  // namespace

std::string missingColumnHint(const std::vector<std::string>& missing, const std::vector<std::string>& present) {
  std::string hint;
  for (const std::string& p : present) {
    std::string_view base;
    unitOf(p, base);
    const std::string alias = aliasOf(normalised(base));
    if (alias.empty() || alias == p) continue;
    if (std::find(missing.begin(), missing.end(), alias) == missing.end()) continue;
    hint += (hint.empty() ? "" : "; ") + std::string("the header has '") + p + "': rename it to '" + alias + "'";
  }
  if (hint.empty()) return "";
  return " (" + hint +
         "; column names are case-sensitive. A sensor's own recording with these names is read as it is by "
         "--wrench-log, a UR recording by its header: docs/log-format.md)";
}

}  // namespace ftid::logio
