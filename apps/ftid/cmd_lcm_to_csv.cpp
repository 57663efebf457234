// `ftid lcm-to-csv`: convert an LCM log recorded from ftidd (its cycle samples) to the CSV log
// format, so the run can be analysed with `ftid analyze` / identified with `ftid identify`.
#include <cstdio>

#include "command.hpp"
#include "ftid/fileio/atomic_file.hpp"
#include "ftid/logio/log.hpp"
#include "ftid/transport/lcm_to_csv.hpp"

namespace {

const char* const kUsage =
    "usage: ftid lcm-to-csv LOG.lcm --out RUN.csv [--channel FTID_CYCLE] [--keep-invalid]\n"
    "\n"
    "Reads an LCM log (lcm-logger format: `ftidd --record`, record.enabled in ftidd.yaml, or\n"
    "lcm-logger) and writes the robot state and raw sensor sample of every cycle_sample_t on the\n"
    "channel as one CSV row (docs/log-format.md): t = robot controller time [s], q, qd, qdd,\n"
    "wrench, and the IMU and temperature columns when every sample has them; extra columns\n"
    "cycle, sensor_age_ms, fault_bits, host_time (the robot state's receive time on ftidd's host,\n"
    "UTC seconds: the clock of time_drift, docs/conventions.md \"Time and logs\"). Cycles with an\n"
    "invalid robot state or a stale/invalid sensor sample are dropped (a stale reading does not\n"
    "belong to that robot state) unless --keep-invalid is given. The CSV is written atomically.\n"
    "\n"
    "  --out FILE        the CSV to write (required)\n"
    "  --channel NAME    channel with cycle_sample_t (default FTID_CYCLE)\n"
    "  --keep-invalid    keep cycles flagged invalid or stale\n"
    "\n"
    "Exit status: 0 written (skipped cycles are counted on stdout), 1 the log cannot be read or has\n"
    "no usable cycle_sample_t on the channel, or the CSV cannot be written (the message names the\n"
    "file), 2 usage error (not exactly one log, no --out, unknown option).";

int runLcmToCsv(const std::vector<std::string>& argv) {
  ftid::transport::LcmToLogOptions options;
  std::string out;
  std::vector<std::string> inputs;
  CLI::App app{"ftid lcm-to-csv"};
  app.add_option("--out", out);
  app.add_option("--channel", options.channel);
  app.add_flag("--keep-invalid", options.keep_invalid);
  app.add_option("LCMLOG", inputs);
  ftid::cli::parse(app, argv);
  if (inputs.size() != 1) throw ftid::cli::UsageError("exactly one LCM log file is required");
  if (out.empty()) throw ftid::cli::UsageError("--out is required");
  ftid::checkOutputPath(out);
  ftid::transport::LcmToLogReport report;
  const ftid::logio::LogData log = ftid::transport::lcmLogToLogData(inputs[0], options, &report);
  ftid::logio::writeLog(out, log);
  std::printf("%zu events read, %zu cycle samples on %s, %zu rows written -> %s\n", report.events,
              report.on_channel, options.channel.c_str(), report.converted, out.c_str());
  if (report.skipped_invalid + report.skipped_non_monotonic + report.skipped_non_finite +
          report.decode_errors > 0) {
    std::printf("skipped: %zu invalid/stale, %zu non-increasing time, %zu non-finite, %zu not "
                "decodable\n",
                report.skipped_invalid, report.skipped_non_monotonic, report.skipped_non_finite,
                report.decode_errors);
  }
  std::printf("columns: t, q, qd, qdd, wrench%s%s, cycle, sensor_age_ms, fault_bits, host_time\n",
              log.has_imu ? ", imu" : "", log.has_temp ? ", temp" : "");
  return 0;
}

ftid::cli::Registrar reg{{"lcm-to-csv", "convert an LCM log recorded from ftidd to a CSV log",
                          kUsage, &runLcmToCsv}};

}  // namespace
