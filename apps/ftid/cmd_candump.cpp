// `ftid decode-candump`: decode a candump log with the sensor DBC into CSV samples.
#include <cinttypes>
#include <cstdio>
#include <cstdlib>

#include "command.hpp"
#include "ftid/fileio/atomic_file.hpp"
#include "ftid/common/default_files.hpp"
#include "ftid/common/error.hpp"
#include "ftid/drivers/can/candump.hpp"
#include "ftid/drivers/can/sensor_layout.hpp"

namespace {

const char* kUsage =
    "usage: ftid decode-candump FILE [--dbc config/ftsensor.dbc] [--interface can0]\n"
    "                           [--stale-ms 20] [--output FILE.csv]\n"
    "\n"
    "Decodes a candump -l log (e.g. from `candump -l can0` or `ftid sim-sensor --candump-log`)\n"
    "with the sensor's DBC, groups frames into samples by rolling counter and prints one CSV row\n"
    "per complete sample:\n"
    "  t,counter,fx,fy,fz,tx,ty,tz,ax,ay,az,wx,wy,wz,alx,aly,alz,temp,status,valid,flags\n"
    "t is the receive time of the frame completing the sample [s]; valid/flags apply the health\n"
    "rules of docs/sensor.md; flags are the sensor health bits in hex, the same bits ftidd\n"
    "publishes (docs/daemon.md). A health summary goes to stderr.\n"
    "\n"
    "options:\n"
    "  --dbc FILE        CAN layout (default: the shipped ftsensor.dbc)\n"
    "  --interface IF    only frames of this interface (default: all)\n"
    "  --stale-ms MS     stale timeout for the health rules (default 20)\n"
    "  --output FILE     write the CSV to FILE instead of stdout\n"
    "\n"
    "Exit status: 0 decoded (incomplete samples, gaps and faults are counted in the summary, not\n"
    "errors), 1 a bad DBC or candump log (the message names the file and line) or an --output that\n"
    "cannot be written, 2 usage error (no log FILE, unknown option, bad number).";

int runDecodeCandump(const std::vector<std::string>& argv) {
  using namespace ftid::drivers::can;
  std::string dbc, iface, output, log;
  double stale_ms = 20.0;
  CLI::App app{"ftid decode-candump"};
  app.add_option("--dbc", dbc);
  app.add_option("--interface", iface);
  app.add_option("--stale-ms", stale_ms)->transform(ftid::cli::real(ftid::cli::positive()));
  app.add_option("--output", output);
  app.add_option("LOG", log);
  ftid::cli::parse(app, argv);
  if (log.empty()) throw ftid::cli::UsageError("expected exactly one candump log FILE");
  if (dbc.empty()) dbc = ftid::findDefaultFile("ftsensor.dbc");
  const std::vector<std::string> pos{log};
  SensorHealthOptions health;
  health.stale_timeout_ns = static_cast<std::int64_t>(stale_ms * 1e6);
  const SensorLayout layout = SensorLayout::fromDbc(loadDbc(dbc));
  SampleAssembler assembler(layout, health);
  // Rows go to stdout, or with --output through the atomic writer (never over a symlink/device).
  if (!output.empty()) ftid::checkOutputPath(output);
  char* text_buf = nullptr;
  std::size_t text_size = 0;
  std::FILE* out = output.empty() ? stdout : ::open_memstream(&text_buf, &text_size);
  if (out == nullptr) throw ftid::DataError(output + ": cannot allocate the output buffer");
  std::fprintf(out, "t,counter,fx,fy,fz,tx,ty,tz,ax,ay,az,wx,wy,wz,alx,aly,alz,temp,status,valid,flags\n");
  std::uint64_t rows = 0;
  SensorSample s;
  for (const CandumpRecord& r : loadCandump(pos[0])) {
    if (!iface.empty() && r.interface != iface) continue;
    if (!assembler.feed(r.frame)) continue;
    assembler.readLatest(s, r.frame.rx_time_ns);
    std::fprintf(out, "%.6f,%u", static_cast<double>(s.rx_time_ns) * 1e-9, s.counter);
    for (int i = 0; i < 6; ++i) std::fprintf(out, ",%.6g", s.wrench_S[i]);
    for (const auto* v : {&s.acc_S, &s.w_S, &s.alpha_S})
      for (int i = 0; i < 3; ++i) std::fprintf(out, ",%.6g", (*v)[i]);
    std::fprintf(out, ",%.4g,%u,%d,0x%x\n", s.temp_degC, s.status_word, s.valid ? 1 : 0, s.health_flags);
    ++rows;
  }
  if (out != stdout) {
    std::fclose(out);
    const std::string text(text_buf, text_size);
    std::free(text_buf);
    ftid::writeFileAtomically(output, text);
  }
  const SensorHealthCounters& h = assembler.health();
  std::fprintf(stderr,
               "decode-candump: %" PRIu64 " samples from %" PRIu64 " frames; incomplete %" PRIu64
               ", counter gaps %" PRIu64 " (%" PRIu64 " samples lost), repeats %" PRIu64
               ", out of range %" PRIu64 ", status faults %" PRIu64 ", error frames %" PRIu64
               ", ignored frames %" PRIu64 "\n",
               rows, h.frames_received, h.samples_incomplete, h.counter_gaps, h.samples_lost,
               h.counter_repeats, h.out_of_range, h.status_faults, h.error_frames, h.frames_ignored);
  return 0;
}

}  // namespace

static ftid::cli::Registrar reg{{"decode-candump", "decode a candump log of the F/T sensor to CSV",
                                 kUsage, &runDecodeCandump}};
