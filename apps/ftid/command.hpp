#pragma once
// Sub-command table of the `ftid` CLI. Each sub-command lives in apps/ftid/cmd_<name>.cpp (picked
// up by apps/ftid/CMakeLists.txt's glob), parses its arguments with CLI11 (cli_args.hpp) and calls
// library code. It registers itself with one static Registrar line:
//
//   ftid::cli::Registrar reg{{"identify", "identify payload parameters from a recorded log",
//                             kUsage, &runIdentify}};
//
// where runIdentify(args) builds a CLI::App, binds its options and calls ftid::cli::parse(app, args).
// main.cpp prints kUsage for `ftid identify --help` (exit 0) and maps a UsageError to exit 2.
// Exit codes: 0 success, 1 runtime failure (bad data, device fault), 2 usage error.
#include <functional>
#include <string>
#include <vector>

#include "cli_args.hpp"

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

/// Every registered command, sorted by name.
const std::vector<Command>& commands();

}  // namespace ftid::cli
