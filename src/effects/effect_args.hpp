#pragma once
// Argument parsing for effects written as name(arg, ...) (private to src/effects).
#include <cstdlib>
#include <string>
#include <vector>

#include "ftid/common/error.hpp"

namespace ftid::effects::detail {

inline std::vector<std::string> splitArgs(const std::string& args) {
  std::vector<std::string> out;
  if (args.find_first_not_of(" \t") == std::string::npos) return out;
  std::string cur;
  for (char c : args + ",") {
    if (c == ',') {
      const auto b = cur.find_first_not_of(" \t");
      const auto e = cur.find_last_not_of(" \t");
      out.push_back(b == std::string::npos ? std::string() : cur.substr(b, e - b + 1));
      cur.clear();
    } else {
      cur += c;
    }
  }
  return out;
}

inline double parseNumber(const std::string& effect, const std::string& text) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end == nullptr || *end != '\0') {
    throw ConfigError("effect '" + effect + "': '" + text + "' is not a number");
  }
  return v;
}

inline int parseOrder(const std::string& effect, const std::string& text, int max_order) {
  const double v = parseNumber(effect, text);
  const int n = static_cast<int>(v);
  if (static_cast<double>(n) != v || n < 1 || n > max_order) {
    throw ConfigError("effect '" + effect + "': order '" + text + "' must be an integer 1.." +
                      std::to_string(max_order));
  }
  return n;
}

/// Shortest decimal text of a number, for canonical effect names ("25", "0.5").
inline std::string numberText(double v) {
  std::string s = std::to_string(v);
  if (s.find('.') != std::string::npos) {
    while (!s.empty() && s.back() == '0') s.pop_back();
    if (!s.empty() && s.back() == '.') s.pop_back();
  }
  return s;
}

}  // namespace ftid::effects::detail
