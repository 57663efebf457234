// `ftid convert`: any supported recording written as a native ftid log (docs/log-format.md).
#include <iostream>
#include <string>

#include "command.hpp"
#include "input_flags.hpp"
#include "ftid/fileio/atomic_file.hpp"
#include "ftid/logio/input.hpp"
#include "ftid/logio/log.hpp"

namespace {

const char* const kUsage =
    "usage: ftid convert IN OUT.csv [--wrench-log FILE [--wrench-time-offset S]]\n"
    "                    [--qdd-source diff|target] [--ur-payload M,CX,CY,CZ]\n"
    "\n"
    "Reads IN as ftid identify, analyze and compensate read it (an ftid log, a UR RTDE recording\n"
    "from record.py or ur_rtde, a ROS 2 bag; either with the sensor's own recording) and writes what ftid read\n"
    "as a native ftid log (docs/log-format.md, written atomically), so you can inspect it. Prints\n"
    "what the reader did (rows dropped, the alignment, where the accelerations came from).\n"
    "\n"
    "%INPUT%"
    "\n"
    "A UR recording's actual_TCP_force is in the robot base's axes: OUT keeps it so, and says so;\n"
    "read OUT with --wrench-frame base. Exit: 0 written, 1 bad input (named), 2 usage error.";

const std::string& usage() {
  static const std::string text = ftid::cli::withInputFlagsHelp(kUsage);
  return text;
}

int runConvert(const std::vector<std::string>& argv) {
  std::string in_path, out_path;
  CLI::App app{"ftid convert"};
  app.add_option("IN", in_path);
  app.add_option("OUT", out_path);
  ftid::cli::InputFlags flags;
  ftid::cli::addInputFlags(app, flags);
  ftid::cli::parse(app, argv);
  if (in_path.empty() || out_path.empty()) throw ftid::cli::UsageError("IN and OUT are required");
  ftid::logio::InputOptions options;
  ftid::cli::applyInputFlags(flags, options);
  ftid::checkOutputPath(out_path);  // refuse a symlink/device/FIFO/directory before the work
  const ftid::logio::InputLog in = ftid::logio::readInput(in_path, options);
  for (const std::string& note : in.notes) std::cerr << "ftid convert: " << note << "\n";
  ftid::logio::writeLog(out_path, in.log);
  std::cout << in_path << " (" << in.format << "): " << in.log.samples.size() << " samples written to " << out_path
            << "\n";
  if (in.wrench_in_base) {
    std::cout << "the wrench columns are in the robot base's axes (actual_TCP_force): read " << out_path
              << " with --wrench-frame base\n";
  }
  return 0;
}

ftid::cli::Registrar reg{{"convert", "write any supported recording as a native ftid log", usage(), &runConvert}};

}  // namespace
