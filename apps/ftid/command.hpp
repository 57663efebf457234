#pragma once
// Sub-command registry of the `ftid` CLI. Each sub-command lives in apps/ftid/cmd_<name>.cpp,
// parses its own arguments and calls library code; it registers itself with a static Registrar:
//
//   static ftid::cli::Registrar reg{{"identify", "identify payload parameters from a log",
//                                    "ftid identify --log FILE [...]", &runIdentify}};
//
// Exit codes: 0 success, 1 runtime failure (bad data, device fault), 2 usage error.
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

namespace ftid::cli {

struct Command {
  std::string name;     ///< the word after `ftid`
  std::string summary;  ///< one line for `ftid --help`
  std::string usage;    ///< full help text for `ftid <name> --help`
  std::function<int(const std::vector<std::string>& args)> run;  ///< args exclude the name
};

/// Registers a command at static-initialisation time.
struct Registrar {
  explicit Registrar(Command command);
};

const std::vector<Command>& commands();

/// Small argument helper shared by commands: --key value, --key=value and bare flags.
class Args {
 public:
  Args(std::vector<std::string> args, std::string command_usage);
  /// True if the flag (e.g. "--json") is present; consumes it.
  bool flag(const std::string& name);
  /// The value of --name, or the default; consumes it. Throws UsageError if the value is missing.
  std::string value(const std::string& name, const std::string& default_value = "");
  /// True if --name (or --name=value) is present and not yet consumed.
  bool has(const std::string& name) const;
  /// Remaining positional arguments; consumes them.
  std::vector<std::string> positionals();
  /// Throws UsageError naming the first argument nobody consumed.
  void finish() const;
  bool helpRequested() const { return help_; }

 private:
  std::vector<std::string> args_;
  std::vector<bool> used_;
  std::string usage_;
  bool help_ = false;
};

/// Thrown for command-line mistakes; main() prints the message and the usage, exit code 2.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace ftid::cli
