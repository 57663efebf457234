// Accuracy limits for the duration search (include/ftid/design/designer.hpp, docs/design.md "Limits").
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "ftid/common/error.hpp"
#include "ftid/design/designer.hpp"
#include "ftid/fileio/yaml_emit.hpp"

namespace ftid::design {

std::map<std::string, double> parseLimits(const std::string& text, const std::map<std::string, double>& nominal) {
  // Each value to SI (keeping '%'), then parseTargets; the targets are the limits / 3.
  std::string normalised;
  std::size_t start = 0;
  while (start <= text.size()) {
    std::size_t end = text.find(',', start);
    if (end == std::string::npos) end = text.size();
    const std::string item = text.substr(start, end - start);
    const std::size_t eq = item.find('=');
    if (eq == std::string::npos) throw ConfigError("--limits: '" + item + "' is not key=value");
    const std::string key = item.substr(0, eq);
    std::string value = item.substr(eq + 1);
    static const std::pair<const char*, double> kUnits[] = {
        {"mm", 1e-3}, {"cm", 1e-2}, {"deg", 3.141592653589793 / 180.0}, {"rad", 1.0}, {"Nm", 1.0},
        {"kg", 1.0},  {"g", 1e-3},  {"m", 1.0},                          {"N", 1.0}};
    double scale = 1.0;
    if (value.empty() || value.back() != '%') {
      for (const auto& [unit, factor] : kUnits) {
        const std::string u(unit);
        if (value.size() > u.size() && value.compare(value.size() - u.size(), u.size(), u) == 0) {
          value.resize(value.size() - u.size());
          scale = factor;
          break;
        }
      }
      std::size_t used = 0;
      double x = 0.0;
      try {
        x = std::stod(value, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != value.size() || !std::isfinite(x) || !(x > 0.0)) {
        throw ConfigError("--limits: '" + item + "': expected a positive number with an optional unit (%, mm, cm, m, "
                          "deg, rad, g, kg, N, Nm)");
      }
      value = yamlNumberText(x * scale);
    }
    normalised += (normalised.empty() ? "" : ",") + key + "=" + value;
    if (end == text.size()) break;
    start = end + 1;
  }
  std::map<std::string, double> out;
  try {
    out = parseTargets(normalised, nominal);
  } catch (const ConfigError& e) {
    std::string what = e.what();
    const std::string from = "--target-std";
    if (what.compare(0, from.size(), from) == 0) what = "--limits" + what.substr(from.size());
    throw ConfigError(what);
  }
  for (auto& [k, v] : out) v /= kLimitStandardErrors;
  return out;
}

}  // namespace ftid::design
