// Column aliases and the hints of the readers' refusals (include/ftid/logio/input.hpp).
#include <algorithm>
#include <array>
#include <cctype>
#include <string>

#include "ftid/logio/input.hpp"

namespace ftid::logio {

namespace {

/// Lower case, a trailing unit in [] or () removed, then only letters and digits.
std::string normalised(std::string_view name) {
  std::string_view v = name;
  while (!v.empty() && v.back() == ' ') v.remove_suffix(1);
  if (!v.empty() && (v.back() == ']' || v.back() == ')')) {
    const std::size_t open = v.find_last_of(v.back() == ']' ? '[' : '(');
    if (open != std::string_view::npos && open > 0) v = v.substr(0, open);
  }
  std::string out;
  for (const char c : v) {
    if (std::isalnum(static_cast<unsigned char>(c)) != 0) {
      out += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    }
  }
  return out;
}

const std::array<const char*, 35>& nativeNames() {
  static const std::array<const char*, 35> names = {
      "t",    "q1",   "q2",   "q3",   "q4",   "q5",   "q6",  "qd1", "qd2", "qd3", "qd4", "qd5",
      "qd6",  "qdd1", "qdd2", "qdd3", "qdd4", "qdd5", "qdd6", "fx", "fy",  "fz",  "tx",  "ty",
      "tz",   "ax",   "ay",   "az",   "wx",   "wy",   "wz",  "alx", "aly", "alz", "temp"};
  return names;
}

}  // namespace

std::string columnAlias(std::string_view name) {
  const std::string n = normalised(name);
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

std::string missingColumnHint(const std::vector<std::string>& missing, const std::vector<std::string>& present) {
  std::string hint;
  for (const std::string& p : present) {
    const std::string alias = columnAlias(p);
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
