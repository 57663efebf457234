#pragma once
// Argument parsing shared by both executables (apps/ftid, apps/ftidd): CLI11 (Debian's
// libcli11-dev) parses, with strict number checks. Help texts stay each command's own text (they
// are the documentation the man pages and README quote); CLI11's generated help is switched off.
// Every command-line mistake becomes a UsageError whose message names the option (exit code 2).
#include <CLI/CLI.hpp>

#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace ftid::cli {

/// A command-line mistake; the executable prints the message (and the usage) and exits with 2.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// An interval of real numbers; each end open or closed. Default: every finite number.
struct Interval {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false;
  bool hi_open = false;
  bool contains(double v) const;
  /// "a number", "a number > 0", "a number in (0, 10]" ...
  std::string describe() const;
};
Interval positive();     ///< (0, inf)
Interval nonNegative();  ///< [0, inf)

/// The strict number parsers: the whole text must be the number (no trailing characters, no
/// leading blanks), reals must be finite and inside `range`, integers are decimal. They throw
/// UsageError("WHAT: 'TEXT' is not ..."). Use them for numbers inside a larger argument
/// (e.g. SECONDS:KIND:COUNT); options use the validators below.
double parseReal(const std::string& text, const std::string& what, const Interval& range = {});
long long parseInteger(const std::string& text, const std::string& what, long long lo, long long hi);
std::uint64_t parseCount(const std::string& text, const std::string& what);  ///< 0 .. 2^64-1
/// Comma- (or `sep`-) separated reals; `n` > 0 requires exactly n of them.
std::vector<double> parseReals(const std::string& text, const std::string& what, std::size_t n = 0,
                               const Interval& range = {}, char sep = ',');

/// CLI11 validators with the checks above. They rewrite the text into a canonical form so that
/// CLI11's own conversion yields exactly the checked value (by itself CLI11 2.1 reads "010" as octal
/// and "-1" as 2^64-1 for an unsigned target), so give them with CLI::Option::transform(), not
/// check() (CLI11 runs a check on a copy of the text):
///   app.add_option("--script-port", port)->transform(ftid::cli::integer(1, 65535));
CLI::Validator real(const Interval& range = {});
CLI::Validator integer(long long lo, long long hi);
CLI::Validator count();  ///< a non-negative whole number (seeds)
/// One of the listed words ("'fast' is not one of: static, dynamic").
CLI::Validator oneOf(std::vector<std::string> words);

/// --NAME X,Y,Z: exactly `n` comma-separated reals in `range` into `out` (one occurrence).
CLI::Option* addReals(CLI::App& app, const std::string& name, std::vector<double>& out, std::size_t n,
                      const Interval& range = {});
/// A repeatable option (--effect A --effect B): each occurrence takes exactly one value.
CLI::Option* addRepeatable(CLI::App& app, const std::string& name, std::vector<std::string>& out);

/// A CLI11 app for `name` with CLI11's help flag switched off (the caller prints its own text).
void prepare(CLI::App& app);
/// Parses `args` (without the program or command name) into `app`. Throws UsageError with CLI11's
/// message, which names the option ("--script-port: 'abc' is not a whole number in 1..65535",
/// "The following argument was not expected: --bogus").
void parse(CLI::App& app, const std::vector<std::string>& args);

}  // namespace ftid::cli
