// YAML output policy (ftid/fileio/yaml_emit.hpp).
#include "ftid/fileio/yaml_emit.hpp"

#include <charconv>
#include <cmath>

#include "ftid/common/error.hpp"

namespace ftid {

std::string yamlNumberText(double v) {
  if (std::isnan(v)) return ".nan";
  if (std::isinf(v)) return v > 0 ? ".inf" : "-.inf";
  char buf[64];
  // The shortest representation that round-trips (C++17 <charconv>, GCC 11+).
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, v);
  if (ec != std::errc()) throw Error("yaml: cannot format a number");  // cannot happen with 64 bytes
  std::string s(buf, end);
  // Keep a real number a float for YAML 1.1 readers too (PyYAML): "2" -> "2.0", "8e-04" -> "8.0e-04".
  if (s.find('.') == std::string::npos) {
    const auto e = s.find('e');
    s.insert(e == std::string::npos ? s.size() : e, ".0");
  }
  return s;
}

YAML::Emitter& operator<<(YAML::Emitter& out, YamlNumber number) {
  // A plain scalar: the text above is a valid YAML float and needs no quotes.
  return out << yamlNumberText(number.value);
}

std::string yamlDocument(const std::string& comment, const YAML::Emitter& out) {
  if (!out.good()) throw ConfigError("yaml: cannot emit the document: " + out.GetLastError());
  return comment + out.c_str() + "\n";
}

}  // namespace ftid
