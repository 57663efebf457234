// `ftid`: the one-shot command-line tool. Sub-commands register themselves (command.hpp);
// this file only dispatches and maps exceptions to exit codes and one-line messages.
#include <algorithm>
#include <cstdio>
#include <exception>
#include <iostream>
#include <string>
#include <vector>

#include "command.hpp"
#include "ftid/common/error.hpp"

namespace ftid::cli {

namespace {
std::vector<Command>& registry() {
  static std::vector<Command> r;
  return r;
}
}  // namespace

Registrar::Registrar(Command command) { registry().push_back(std::move(command)); }

const std::vector<Command>& commands() {
  auto& r = registry();
  std::sort(r.begin(), r.end(), [](const Command& a, const Command& b) { return a.name < b.name; });
  return r;
}

}  // namespace ftid::cli

namespace {

void printOverview() {
  std::cout << "ftid - payload identification and gravity/inertia compensation for wrist F/T sensors\n\n"
               "usage: ftid <command> [options]      (ftid <command> --help for details)\n\n"
               "commands:\n";
  for (const auto& c : ftid::cli::commands()) {
    std::printf("  %-18s %s\n", c.name.c_str(), c.summary.c_str());
  }
  std::cout << "\nConventions (frames, units, signs): docs/conventions.md\n";
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty() || args[0] == "--help" || args[0] == "-h" || args[0] == "help") {
    printOverview();
    return args.empty() ? 2 : 0;
  }
  if (args[0] == "--version") {
    std::cout << "ftid " FTID_VERSION "\n";
    return 0;
  }
  std::string name = args[0];
  std::vector<std::string> rest(args.begin() + 1, args.end());
  // `ftid --identify` is the one-shot cell command (move the robot, record, identify, analyse);
  // `ftid identify --log FILE` identifies offline from a recorded log.
  if (name == "--identify") name = "cell-identify";
  for (const auto& c : ftid::cli::commands()) {
    if (c.name != name) continue;
    try {
      for (const auto& a : rest) {
        if (a == "--help" || a == "-h") {
          std::cout << c.usage << "\n";
          return 0;
        }
      }
      return c.run(rest);
    } catch (const ftid::cli::UsageError& e) {
      std::cerr << "ftid " << c.name << ": " << e.what() << "\n\n" << c.usage << "\n";
      return 2;
    } catch (const std::exception& e) {
      std::cerr << "ftid " << c.name << ": error: " << e.what() << "\n";
      return 1;
    }
  }
  std::cerr << "ftid: unknown command '" << args[0] << "' (ftid --help lists the commands)\n";
  return 2;
}
