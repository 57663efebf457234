// Strict number checks and the CLI11 glue shared by apps/ftid and apps/ftidd (cli_args.hpp).
#include "cli_args.hpp"

#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <system_error>

namespace ftid::cli {

namespace {

std::string numberText(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

/// The real number that is the whole of `text`, or false.
bool readReal(const std::string& text, double& out) {
  if (text.empty() || std::isspace(static_cast<unsigned char>(text.front())) != 0) return false;
  char* end = nullptr;
  out = std::strtod(text.c_str(), &end);
  return end == text.c_str() + text.size() && std::isfinite(out);
}

template <typename T>
bool readWhole(const std::string& text, T& out) {
  const char* first = text.c_str();
  const char* last = first + text.size();
  if (first != last && *first == '+') {  // "+5" as strtol reads it; "+-5" stays an error
    ++first;
    if (first == last || *first == '-' || *first == '+') return false;
  }
  if (first == last) return false;
  const auto [ptr, ec] = std::from_chars(first, last, out, 10);
  return ec == std::errc() && ptr == last;
}

std::string wholeRange(long long lo, long long hi) {
  if (hi == std::numeric_limits<long long>::max()) return ">= " + std::to_string(lo);
  return "in " + std::to_string(lo) + ".." + std::to_string(hi);
}

}  // namespace

bool Interval::contains(double v) const {
  if (lo_open ? !(v > lo) : !(v >= lo)) return false;
  if (hi_open ? !(v < hi) : !(v <= hi)) return false;
  return true;
}

std::string Interval::describe() const {
  const bool has_lo = std::isfinite(lo);
  const bool has_hi = std::isfinite(hi);
  if (!has_lo && !has_hi) return "a finite number";
  if (has_lo && !has_hi) return std::string("a number ") + (lo_open ? "> " : ">= ") + numberText(lo);
  if (!has_lo) return std::string("a number ") + (hi_open ? "< " : "<= ") + numberText(hi);
  return std::string("a number in ") + (lo_open ? "(" : "[") + numberText(lo) + ", " + numberText(hi) +
         (hi_open ? ")" : "]");
}

Interval positive() { return Interval{0.0, std::numeric_limits<double>::infinity(), true, false}; }
Interval nonNegative() { return Interval{0.0, std::numeric_limits<double>::infinity(), false, false}; }

double parseReal(const std::string& text, const std::string& what, const Interval& range) {
  double v = 0.0;
  if (!readReal(text, v) || !range.contains(v)) {
    throw UsageError(what + ": '" + text + "' is not " + range.describe());
  }
  return v;
}

long long parseInteger(const std::string& text, const std::string& what, long long lo, long long hi) {
  long long v = 0;
  if (!readWhole(text, v) || v < lo || v > hi) {
    throw UsageError(what + ": '" + text + "' is not a whole number " + wholeRange(lo, hi));
  }
  return v;
}

std::uint64_t parseCount(const std::string& text, const std::string& what) {
  std::uint64_t v = 0;
  if (!readWhole(text, v)) throw UsageError(what + ": '" + text + "' is not a non-negative whole number");
  return v;
}

std::vector<double> parseReals(const std::string& text, const std::string& what, std::size_t n,
                               const Interval& range, char sep) {
  std::vector<double> out;
  std::size_t start = 0;
  while (true) {
    const std::size_t end = text.find(sep, start);
    out.push_back(parseReal(text.substr(start, end == std::string::npos ? std::string::npos : end - start), what,
                            range));
    if (end == std::string::npos) break;
    start = end + 1;
  }
  if (n > 0 && out.size() != n) {
    throw UsageError(what + ": expected " + std::to_string(n) + " values separated by '" + std::string(1, sep) +
                     "', got '" + text + "'");
  }
  return out;
}

// A validator's function returns the error message (empty: accepted) and may rewrite the text;
// CLI11 prefixes the message with the option's name. Options take them with ->transform(), not
// ->check(): CLI11 runs a check() on a copy of the text, so the canonical text would be lost.
CLI::Validator real(const Interval& range) {
  return CLI::Validator(
      [range](std::string& text) -> std::string {
        double v = 0.0;
        if (!readReal(text, v) || !range.contains(v)) return "'" + text + "' is not " + range.describe();
        text = numberText(v);
        return {};
      },
      "NUMBER");
}

CLI::Validator integer(long long lo, long long hi) {
  return CLI::Validator(
      [lo, hi](std::string& text) -> std::string {
        long long v = 0;
        if (!readWhole(text, v) || v < lo || v > hi) return "'" + text + "' is not a whole number " + wholeRange(lo, hi);
        text = std::to_string(v);
        return {};
      },
      "INT");
}

CLI::Validator count() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        std::uint64_t v = 0;
        if (!readWhole(text, v)) return "'" + text + "' is not a non-negative whole number";
        text = std::to_string(v);
        return {};
      },
      "N");
}

CLI::Validator oneOf(std::vector<std::string> words) {
  return CLI::Validator(
      [words](std::string& text) -> std::string {
        std::string list;
        for (const auto& w : words) {
          if (w == text) return {};
          list += (list.empty() ? "" : ", ") + w;
        }
        return "'" + text + "' is not one of: " + list;
      },
      "WORD");
}

CLI::Option* addReals(CLI::App& app, const std::string& name, std::vector<double>& out, std::size_t n,
                      const Interval& range) {
  return app.add_option(name, out)
      ->delimiter(',')
      ->expected(static_cast<int>(n))
      ->allow_extra_args(false)
      ->transform(real(range));
}

CLI::Option* addRepeatable(CLI::App& app, const std::string& name, std::vector<std::string>& out) {
  return app.add_option(name, out)->allow_extra_args(false);
}

void prepare(CLI::App& app) { app.set_help_flag(); }

void parse(CLI::App& app, const std::vector<std::string>& args) {
  prepare(app);
  std::vector<std::string> reversed(args.rbegin(), args.rend());  // CLI11 consumes from the back
  try {
    app.parse(reversed);
  } catch (const CLI::ParseError& e) {
    throw UsageError(e.what());
  }
}

}  // namespace ftid::cli
