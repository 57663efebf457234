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

Args::Args(std::vector<std::string> args, std::string command_usage)
    : args_(std::move(args)), used_(args_.size(), false), usage_(std::move(command_usage)) {
  for (std::size_t i = 0; i < args_.size(); ++i) {
    if (args_[i] == "--help" || args_[i] == "-h") {
      help_ = true;
      used_[i] = true;
    }
  }
}

bool Args::has(const std::string& name) const {
  for (std::size_t i = 0; i < args_.size(); ++i) {
    if (used_[i]) continue;
    if (args_[i] == name || args_[i].rfind(name + "=", 0) == 0) return true;
  }
  return false;
}

bool Args::flag(const std::string& name) {
  bool found = false;
  for (std::size_t i = 0; i < args_.size(); ++i) {
    if (!used_[i] && args_[i] == name) {
      used_[i] = true;
      found = true;
    }
  }
  return found;
}

std::string Args::value(const std::string& name, const std::string& default_value) {
  for (std::size_t i = 0; i < args_.size(); ++i) {
    if (used_[i]) continue;
    if (args_[i] == name) {
      if (i + 1 >= args_.size()) throw UsageError(name + " needs a value");
      used_[i] = used_[i + 1] = true;
      return args_[i + 1];
    }
    if (args_[i].rfind(name + "=", 0) == 0) {
      used_[i] = true;
      return args_[i].substr(name.size() + 1);
    }
  }
  return default_value;
}

std::vector<std::string> Args::positionals() {
  std::vector<std::string> out;
  for (std::size_t i = 0; i < args_.size(); ++i) {
    if (!used_[i] && (args_[i].empty() || args_[i][0] != '-' || args_[i] == "-")) {
      used_[i] = true;
      out.push_back(args_[i]);
    }
  }
  return out;
}

void Args::finish() const {
  for (std::size_t i = 0; i < args_.size(); ++i) {
    if (!used_[i]) throw UsageError("unknown argument '" + args_[i] + "'");
  }
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
