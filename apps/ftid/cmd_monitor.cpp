// `ftid monitor`: replay a log through ftidd's compensator and payload monitor, print its events.
#include <cstdio>
#include <iostream>

#include "command.hpp"
#include "ftid/compensate/monitor_log.hpp"
#include "ftid/config/daemon_config.hpp"
#include "ftid/daemon/payload_watch.hpp"
#include "ftid/fileio/json_text.hpp"

namespace {

const char* const kUsage =
    "usage: ftid monitor --log FILE --params PARAMS.yaml [--config FTIDD.yaml] [--json]\n"
    "                    [--robot URDF] [--wrench-frame sensor|base]\n"
    "\n"
    "Replays the log through the code ftidd runs: the compensator with the parameter file, then the\n"
    "payload monitor (docs/daemon.md, \"Payload monitor\"), with the monitor's default settings or\n"
    "those of ftidd's configuration.\n"
    "Prints one line per event: a payload change (an object grasped or released: the residual\n"
    "follows gravity and acceleration like a rigid body) or a contact (a residual that does not, or\n"
    "that ended before it could be told apart), with the estimated change and its standard error.\n"
    "\n"
    "  --log FILE        the log (docs/log-format.md)\n"
    "  --params FILE     the parameters the cell ran with (`ftid identify --out`)\n"
    "  --config FILE     take the settings from the `monitor` section of this ftidd configuration\n"
    "  --json            print {\"events\": [{t, kind, delta_mass, delta_mass_std, delta_com: [x, y, z],\n"
    "                    ...}], ...} instead of text (t = the decision's time in the log's t)\n"
    "  --wrench-frame F  frame of the log's wrench columns: sensor (default) or base\n"
    "  --robot URDF      robot description (default: the shipped ur10.urdf)\n"
    "\n"
    "delta_com is the centre of mass of the added (or removed) mass in S, null while the mass\n"
    "change is below 3 standard errors. Exit: 0 replayed, 1 bad log or parameter file (the message\n"
    "names the file, line or key), 2 usage error.";

ftid::Json vec3(const ftid::Vec3& v) {
  return ftid::Json::array({ftid::jsonNumber(v.x()), ftid::jsonNumber(v.y()), ftid::jsonNumber(v.z())});
}

ftid::Json eventJson(const ftid::monitor::MonitorEvent& e) {
  ftid::Json j;
  j["t"] = ftid::jsonNumber(e.t_decided);
  j["kind"] = ftid::monitor::eventName(e.kind);
  j["t_onset"] = ftid::jsonNumber(e.t_onset);
  j["confirmed"] = e.confirmed;
  j["delta_mass"] = ftid::jsonNumber(e.change.delta_mass_kg);
  j["delta_mass_std"] = ftid::jsonNumber(e.change.delta_mass_std_kg);
  // A contact's rigid-body fit has no centre of mass to speak of.
  const bool change = e.kind == ftid::monitor::EventKind::kPayloadChange;
  j["delta_com"] = change ? vec3(e.change.delta_com_m) : ftid::Json(nullptr);
  j["delta_com_std"] = change ? vec3(e.change.delta_com_std_m) : ftid::Json(nullptr);
  j["delta_mass_com"] = vec3(e.change.delta_mass_com_kg_m);
  j["log_bayes_factor"] = ftid::jsonNumber(e.log_bayes_factor);
  j["samples"] = e.samples;
  j["free_motion_samples"] = e.free_samples;
  j["duration_s"] = ftid::jsonNumber(e.duration_s);
  j["peak_force"] = ftid::jsonNumber(e.peak_force_N);
  return j;
}

int runMonitor(const std::vector<std::string>& argv) {
  ftid::compensate::MonitorRequest req;
  std::string wrench_frame;
  bool json = false;
  CLI::App app{"ftid monitor"};
  app.add_option("--log", req.log_path);
  app.add_option("--params", req.params_path);
  app.add_option("--robot", req.robot_urdf);
  app.add_option("--wrench-frame", wrench_frame)->transform(ftid::cli::oneOf({"sensor", "base"}));
  std::string config_path;
  app.add_option("--config", config_path);
  app.add_flag("--json", json);
  ftid::cli::parse(app, argv);
  req.context.wrench_in_base = ftid::samples::parseWrenchFrame(wrench_frame);
  if (req.log_path.empty() || req.params_path.empty()) throw ftid::cli::UsageError("--log and --params are required");
  if (!config_path.empty()) {
    req.settings = ftid::daemon::monitorSettings(ftid::config::loadDaemonConfig(config_path).monitor);
  }
  const ftid::compensate::MonitorReplay r = ftid::compensate::monitorLogFile(req);
  const ftid::monitor::MonitorStatus& st = r.final_status;
  if (json) {
    ftid::Json j;
    j["events"] = ftid::Json::array();
    for (const auto& e : r.events) j["events"].push_back(eventJson(e));
    j["samples"] = r.n_samples;
    j["samples_not_compensated"] = r.n_not_compensated;
    j["final_state"] = ftid::monitor::stateName(st.state);
    std::cout << ftid::jsonText(j, 2) << "\n";
    return 0;
  }
  std::printf("%d samples replayed (%d not compensated); final state: %s\n", r.n_samples, r.n_not_compensated,
              ftid::monitor::stateName(st.state));
  std::printf("events: %zu\n", r.events.size());
  for (const auto& e : r.events) {
    std::printf("  t=%.3f s  %-14s onset %.3f s  delta_mass %+.4f +- %.4f kg", e.t_decided,
                ftid::monitor::eventName(e.kind), e.t_onset, e.change.delta_mass_kg, e.change.delta_mass_std_kg);
    if (e.kind == ftid::monitor::EventKind::kPayloadChange) {
      std::printf("  delta_com [%.4f, %.4f, %.4f] +- [%.4f, %.4f, %.4f] m", e.change.delta_com_m.x(),
                  e.change.delta_com_m.y(), e.change.delta_com_m.z(), e.change.delta_com_std_m.x(),
                  e.change.delta_com_std_m.y(), e.change.delta_com_std_m.z());
    } else {
      std::printf("  peak %.1f N", e.peak_force_N);
    }
    std::printf("  log BF %.1f  (%d samples, %d in free motion%s)\n", e.log_bayes_factor, e.samples, e.free_samples,
                e.kind == ftid::monitor::EventKind::kContact && !e.confirmed ? ", ended undecided" : "");
  }
  return 0;
}

ftid::cli::Registrar reg{{"monitor", "replay a log through the payload monitor (payload changes, contacts)", kUsage,
                          &runMonitor}};

}  // namespace
