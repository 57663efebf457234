#include "ftid/cell/cell_identify.hpp"

#include <sys/statvfs.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <sstream>
#include <thread>

#include "ftid/cell/cycle_recorder.hpp"
#include "ftid/cell/exports.hpp"
#include "ftid/common/error.hpp"
#include "ftid/config/daemon_config.hpp"
#include "ftid/effects/model.hpp"
#include "ftid/identify/context.hpp"
#include "ftid/identify/fit.hpp"
#include "ftid/identify/fit_check.hpp"
#include "ftid/identify/offline.hpp"
#include "ftid/identify/parameter_set.hpp"
#include "ftid/lab/analyze.hpp"
#include "ftid/logio/log.hpp"
#include "ftid/model/kinematics.hpp"
#include "ftid/motion/robot_session.hpp"
#include "ftid/trajectory/trajectory_io.hpp"
#include "ftid/transport/codec.hpp"

namespace fs = std::filesystem;

namespace ftid::cell {

namespace {

/// UTC time: compact (for directory names) or ISO 8601.
std::string utcStamp(bool iso) {
  std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char buf[64];
  if (iso) {
    std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%SZ", &tm);
  } else {
    std::strftime(buf, sizeof(buf), "%Y%m%d-%H%M%S", &tm);
  }
  return buf;
}

/// Fixed-point number with `decimals` digits.
std::string fmt(int decimals, double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}

/// Writes text atomically: temporary file in the same directory, fsync, rename.
void writeTextAtomic(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  {
    std::ofstream out(tmp, std::ios::trunc);
    out << text;
    out.flush();
    if (!out) {
      std::error_code ec;
      fs::remove(tmp, ec);
      throw Error(path + ": cannot write (" + std::string(std::strerror(errno)) + ")");
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::error_code ec;
    fs::remove(tmp, ec);
    throw Error(path + ": cannot rename into place (" + std::string(std::strerror(errno)) + ")");
  }
}

/// Default excitation trajectory: next to the config, the installed defaults, the source tree.
std::string findDefaultTrajectory(const std::string& config_source) {
  std::vector<fs::path> candidates;
  if (!config_source.empty()) candidates.push_back(fs::path(config_source).parent_path() / "excitation_ur10.yaml");
  candidates.emplace_back("/etc/ftid/excitation_ur10.yaml");
  candidates.emplace_back("/usr/share/ftid/config/excitation_ur10.yaml");
  candidates.emplace_back("config/excitation_ur10.yaml");
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    for (fs::path p = exe.parent_path(); !p.empty() && p != p.root_path(); p = p.parent_path()) {
      candidates.push_back(p / "config" / "excitation_ur10.yaml");
      candidates.push_back(p / "share" / "ftid" / "config" / "excitation_ur10.yaml");
    }
  }
  for (const auto& c : candidates) {
    if (fs::exists(c, ec)) return c.string();
  }
  throw ConfigError("no excitation trajectory given (--trajectory) and no default excitation_ur10.yaml found");
}

/// Shared between the real-time hook and the UI thread (atomics only).
struct HookContext {
  const CycleRecorder* recorder = nullptr;
  const std::atomic<bool>* user_abort = nullptr;
  std::atomic<bool> abort{false};
  std::atomic<int> reason{0};  // 0 none, 1 user, 2 ftidd silent, 3 sensor invalid
  std::int64_t timeout_ns = 250000000;
  std::int64_t max_invalid = 5;
  std::atomic<double> elapsed{0.0};
  std::atomic<int> phase{0};
};

void cycleHook(void* context, const motion::RecordedTick& tick) noexcept {
  auto* c = static_cast<HookContext*>(context);
  c->phase.store(static_cast<int>(tick.phase), std::memory_order_relaxed);
  if (tick.t_traj >= 0.0) c->elapsed.store(tick.t_traj, std::memory_order_relaxed);
  if (c->abort.load(std::memory_order_relaxed)) return;
  if (c->user_abort && c->user_abort->load(std::memory_order_relaxed)) {
    c->reason.store(1);
    c->abort.store(true);
    return;
  }
  const std::int64_t age = monotonicNowNs() - c->recorder->lastReceiveNs();
  if (age > c->timeout_ns) {
    c->reason.store(2);
    c->abort.store(true);
    return;
  }
  if (c->recorder->invalidSensorStreak() > c->max_invalid) {
    c->reason.store(3);
    c->abort.store(true);
  }
}

const char* phaseName(int p) {
  switch (p) {
    case 0: return "moving to start";
    case 1: return "settling";
    case 2: return "excitation";
    case 3: return "finishing";
    default: return "stopping";
  }
}

std::string axisTable(const Vec6& heldout, const Vec6& noise, const Vec6& raw) {
  std::ostringstream o;
  o << "  axis   raw RMS   held-out residual   noise floor   ratio\n";
  for (int i = 0; i < 6; ++i) {
    const double ratio = noise(i) > 0 ? heldout(i) / noise(i) : 0.0;
    char line[160];
    std::snprintf(line, sizeof(line), "  %-4s %9.4f %12.4f %16.4f %10.2f%s\n", kWrenchAxisNames[i], raw(i),
                  heldout(i), noise(i), ratio, ratio > 1.2 ? "   <- above noise" : "");
    o << line;
  }
  return o.str();
}

}  // namespace

std::string requestDaemonReload(const std::string& lcm_url, const std::string& command_channel,
                                const std::string& ack_channel, const std::string& params_path,
                                double timeout_s) {
  lcm::LCM lc(lcm_url);
  if (!lc.good()) return "LCM: cannot open '" + lcm_url + "'";
  struct AckWaiter {
    std::int64_t request_id = 0;
    bool got = false;
    ftid_lcm::ack_t ack;
    void handle(const lcm::ReceiveBuffer* rbuf, const std::string&) {
      ftid_lcm::ack_t a;
      if (a.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) < 0) return;
      if (a.request_id != request_id) return;
      ack = a;
      got = true;
    }
  } waiter;
  waiter.request_id = static_cast<std::int64_t>(monotonicNowNs() ^ (static_cast<std::int64_t>(::getpid()) << 40));
  lcm::Subscription* sub = lc.subscribe(ack_channel, &AckWaiter::handle, &waiter);
  ftid_lcm::command_t cmd;
  cmd.utime = static_cast<std::int64_t>(std::chrono::duration_cast<std::chrono::microseconds>(
                                            std::chrono::system_clock::now().time_since_epoch())
                                            .count());
  cmd.request_id = waiter.request_id;
  cmd.command = ftid_lcm::command_t::RELOAD_PARAMETERS;
  cmd.argument = params_path;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  auto next_send = std::chrono::steady_clock::now();
  while (!waiter.got && std::chrono::steady_clock::now() < deadline) {
    if (std::chrono::steady_clock::now() >= next_send) {  // resend: the first may race the subscription
      lc.publish(command_channel, &cmd);
      next_send += std::chrono::milliseconds(500);
    }
    lc.handleTimeout(50);
  }
  lc.unsubscribe(sub);
  if (!waiter.got) return "ftidd did not acknowledge the reload within " + fmt(1, timeout_s) + " s (is it running?)";
  if (!waiter.ack.ok) return "ftidd refused the reload: " + waiter.ack.message;
  return "";
}

CellIdentifyResult runCellIdentify(const CellIdentifyOptions& o) {
  CellIdentifyResult result;
  auto print = [&](const std::string& s) {
    if (o.print) o.print(s);
  };

  // ---- set-up: everything here may throw ConfigError before anything moves
  const config::DaemonConfig cfg = config::loadDaemonConfig(o.config_path);
  const std::string traj_path = o.trajectory_path.empty() ? findDefaultTrajectory(cfg.source) : o.trajectory_path;
  const trajectory::TrajectoryFile traj_file = trajectory::readTrajectoryFile(traj_path);
  const trajectory::FourierTrajectory traj = traj_file.toTrajectory();
  const effects::Model model = effects::Model::fromName(o.model);
  model::RobotKinematics kin = model::RobotKinematics::fromUrdfFile(cfg.robot.urdf_path, cfg.robot.base_link,
                                                                     cfg.robot.tip_link);
  kin.setSensorMount(cfg.sensor.R_FS(), cfg.sensor.p_FS_F());
  const std::string params_path = o.params_path.empty() ? cfg.parameters.path : o.params_path;
  const fs::path runs_dir = o.runs_dir.empty() ? fs::path(params_path).parent_path() / "runs" : fs::path(o.runs_dir);
  const fs::path run_dir = runs_dir / utcStamp(false);
  fs::create_directories(run_dir);

  print("ftid --identify: model " + model.name() + ", trajectory " + traj_path + " (" +
        fmt(1, traj.duration()) + " s)");
  print("  robot " + cfg.robot.host + ":" + std::to_string(cfg.robot.rtde_port) + ", ftidd data on " +
        cfg.lcm.channels.cycle + " (" + cfg.lcm.url + ")");

  // ---- ftidd and sensor ready?
  const double rate = cfg.robot.rtde_frequency_hz > 0 ? cfg.robot.rtde_frequency_hz : 125.0;
  CycleRecorder recorder(cfg.lcm.url, cfg.lcm.channels.cycle,
                         static_cast<std::size_t>((traj.duration() + 180.0) * rate * 1.2));
  recorder.start();
  if (!recorder.waitForRecords(10, std::chrono::milliseconds(static_cast<int>(o.startup_wait_s * 1000)))) {
    result.message = "ftidd is not publishing cycle samples on " + cfg.lcm.channels.cycle + " (" + cfg.lcm.url +
                     "): start it (systemctl start ftidd) and check `journalctl -u ftidd`; nothing moved";
    return result;
  }
  // One stale sample now and then is normal on a busy host; a sensor that stays invalid is not.
  for (int i = 0; i < 100 && recorder.invalidSensorStreak() > 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  if (recorder.invalidSensorStreak() > 0) {
    result.message = "the F/T sensor is not delivering valid data through ftidd (stale or invalid samples); "
                     "check the sensor and its CAN link; nothing moved";
    return result;
  }
  print("  ftidd and the sensor are up (" + std::to_string(recorder.count()) + " cycle samples received)");

  if (!o.assume_yes) {
    const bool yes = o.confirm && o.confirm("The robot will move: slowly to the start pose, then the " +
                                            fmt(1, traj.duration()) +
                                            " s excitation trajectory. Is the workspace clear? [y/N] ");
    if (!yes) {
      result.message = "cancelled by the operator; nothing moved";
      return result;
    }
  }

  // ---- motion, on the robot clock; cycle samples recorded meanwhile
  motion::RobotSessionConfig session;
  session.arm.host = cfg.robot.host;
  session.arm.rtde_port = static_cast<std::uint16_t>(cfg.robot.rtde_port);
  session.arm.script_port = static_cast<std::uint16_t>(o.script_port);
  session.arm.register_offset = o.register_offset;
  session.motion.realtime.require = o.require_realtime;

  HookContext hook;
  hook.recorder = &recorder;
  hook.user_abort = o.abort;
  hook.timeout_ns = static_cast<std::int64_t>(o.ftidd_timeout_s * 1e9);
  hook.max_invalid = o.max_invalid_sensor_cycles;
  recorder.clear();

  std::atomic<bool> ui_running{true};
  std::thread ui;
  if (o.progress) {
    ui = std::thread([&] {
      while (ui_running.load()) {
        o.progress(phaseName(hook.phase.load()), hook.elapsed.load(), traj.duration());
        std::this_thread::sleep_for(std::chrono::milliseconds(200));
      }
    });
  }
  motion::SessionResult session_result;
  std::string setup_error;
  try {
    const motion::EvaluatedTrajectory<trajectory::FourierTrajectory> source(traj);
    session_result = motion::runOnRobot(session, source, &hook.abort, &cycleHook, &hook);
  } catch (const std::exception& e) {
    setup_error = e.what();
  }
  ui_running = false;
  if (ui.joinable()) ui.join();
  // Let the last samples arrive, then stop recording.
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  recorder.stop();
  const std::vector<transport::CycleRecord> records = recorder.snapshot();

  if (!setup_error.empty()) {
    result.message = "robot set-up failed: " + setup_error + "; nothing moved, parameters unchanged";
    return result;
  }
  const motion::RunResult& run = session_result.run;

  // ---- keep the data, whatever happened
  double t0 = -1e300;
  double t1 = 1e300;
  if (run.excitation_start_timestamp >= 0.0) {
    t0 = run.excitation_start_timestamp;
    t1 = t0 + traj.duration();
  }
  RecordsToLogReport conv;
  logio::LogData log = recordsToLog(records, run.ok() ? t0 : -1e300, run.ok() ? t1 : 1e300,
                                    (run_dir / "run.csv").string(), &conv);
  if (!log.samples.empty()) {
    try {
      logio::writeLog((run_dir / "run.csv").string(), log);
      result.data_csv = (run_dir / "run.csv").string();
    } catch (const std::exception& e) {
      print("  WARNING: could not save the recorded data: " + std::string(e.what()));
    }
  }
  const std::string data_note =
      result.data_csv.empty() ? "no data recorded" : "recorded data saved in " + result.data_csv;

  if (!run.ok()) {
    std::string why = std::string(motion::runStatusName(run.status)) + ": " + run.message;
    switch (hook.reason.load()) {
      case 1: why = "stopped by the operator (Ctrl-C)"; break;
      case 2: why = "ftidd stopped publishing (killed or stalled) during the motion"; break;
      case 3: why = "the F/T sensor went silent or invalid during the motion"; break;
      default: break;
    }
    result.message = "identification run aborted: " + why + "; the arm is stopped, parameters unchanged, " + data_note;
    return result;
  }
  print("  motion complete: " + std::to_string(conv.converted) + " synchronised samples (" +
        std::to_string(conv.skipped_invalid) + " invalid dropped), max tracking error " +
        fmt(4, run.max_tracking_error) + " rad");
  if (log.samples.size() < 50) {
    result.message = "too few valid samples recorded during the excitation (" + std::to_string(log.samples.size()) +
                     "); parameters unchanged, " + data_note;
    return result;
  }

  // ---- identify and analyse
  identify::ContextOptions copts;
  copts.R_FS = cfg.sensor.R_FS();
  copts.p_FS_F = cfg.sensor.p_FS_F();
  identify::ParameterSet set;
  try {
    const identify::ContextSet contexts = identify::buildContexts(log, kin, copts);
    const identify::FitResult fit = identify::fitModel(model, contexts.samples);
    set = identify::toParameterSet(fit);
    set.provenance.date_utc = utcStamp(true);
    set.provenance.data_file = result.data_csv;
    set.provenance.method = "fit";
    set.provenance.trajectory = traj_path;
    set.provenance.n_samples = static_cast<int>(contexts.samples.size());
    print("");
    print(identify::formatParameterTable(set));
    // Does the model fit? Held-out residual against the noise floor, warning above 1.2x.
    print(identify::formatFitCheck(identify::checkFit(
        contexts.samples,
        [&](const std::vector<identify::SampleContext>& train) {
          return identify::toParameterSet(identify::fitModel(model, train));
        },
        "ftid analyze " + result.data_csv + " --model " + model.name() + " --explain")));
    if (o.analyze) {
      lab::AnalyzeOptions aopts;
      aopts.model = model.name();
      aopts.folds = o.folds;
      const lab::AnalysisResult ar = lab::analyze(contexts.samples, nullptr, aopts, result.data_csv);
      result.heldout_rms = ar.report.residual_rms;
      result.noise_floor = ar.noise_floor;
      if (ar.report.inertia) {
        const char* in[6] = {"i_c_xx", "i_c_yy", "i_c_zz", "i_c_xy", "i_c_xz", "i_c_yz"};
        for (int k = 0; k < 6; ++k)
          set.derived.push_back({in[k], ar.report.inertia->value(k), ar.report.inertia->std(k), "kg*m^2"});
      }
      result.analysis_json = lab::formatJson(ar);
      try {
        writeTextAtomic((run_dir / "analysis.json").string(), result.analysis_json + "\n");
        writeTextAtomic((run_dir / "report.html").string(), lab::renderHtml(ar));
      } catch (const std::exception& e) {
        print("  WARNING: " + std::string(e.what()));
      }
      print("Held-out residual per axis (" + std::to_string(ar.folds) + "-fold, contiguous time blocks):");
      print(axisTable(ar.report.residual_rms, ar.noise_floor, ar.report.raw_rms));
      const lab::CandidateResult* top = nullptr;
      for (const auto& c : ar.candidates) {
        if (c.significant && !c.skipped) {
          top = &c;
          break;
        }
      }
      if (top) {
        result.suggested_effect = top->effect;
        print("A physical effect is missing from the model: " + top->effect + " (" + top->description + ").");
        print("  adding it would cut the held-out residual by " + fmt(0, 100.0 * top->relative_reduction) +
              " %. Add it with:  ftid --identify --model " + model.name() + "+" + top->effect);
        print("  or analyse the recorded data:  ftid analyze " + result.data_csv + " --model " + model.name() + "+" +
              top->effect + " --explain");
      } else {
        print("No significant effect is missing: the model explains the data down to the sensor noise.");
      }
      print("Report: " + (run_dir / "report.html").string());
    }
  } catch (const std::exception& e) {
    result.message = "identification failed: " + std::string(e.what()) + "; parameters unchanged, " + data_note;
    return result;
  }

  // ---- write parameters atomically (previous version kept) and exports
  try {
    fs::create_directories(fs::path(params_path).parent_path());
    identify::writeParameterFile(params_path, set);
    result.params_path = params_path;
  } catch (const std::exception& e) {
    // The writer's exception may not say why (e.g. ENOSPC seen only at flush): name a full disk.
    std::string why = e.what();
    struct statvfs fs_info {};
    const fs::path dir = fs::path(params_path).parent_path().empty() ? fs::path(".") : fs::path(params_path).parent_path();
    if (::statvfs(dir.c_str(), &fs_info) == 0 && fs_info.f_bavail * fs_info.f_frsize < 64 * 1024) {
      why += " (no space left on the file system of " + dir.string() + ": " +
             std::to_string(fs_info.f_bavail * fs_info.f_frsize / 1024) + " kB free)";
    }
    result.message = "could not write the parameter file: " + why +
                     "; the previous parameters are intact, " + data_note;
    return result;
  }
  try {
    const PayloadExport ex = makePayloadExport(set, cfg.sensor.R_FS(), cfg.sensor.p_FS_F());
    writeTextAtomic(params_path + ".urscript", "# UR payload for the identified tool (ftid)\n" + urScriptPayload(ex) + "\n");
    writeTextAtomic(params_path + ".ros2.yaml", ros2GravityCompensationYaml(ex));
    print("Exports: " + params_path + ".urscript (UR set_target_payload), " + params_path +
          ".ros2.yaml (ros2_control GravityCompensation)");
  } catch (const std::exception& e) {
    print("  WARNING: exports not written: " + std::string(e.what()));
  }
  print("Parameters written to " + params_path + " (previous version: " + params_path + ".bak)");

  if (o.reload_daemon) {
    const std::string err = requestDaemonReload(cfg.lcm.url, cfg.lcm.channels.command, cfg.lcm.channels.ack,
                                                params_path, 3.0);
    if (err.empty()) {
      result.reloaded = true;
      print("ftidd reloaded the new parameters.");
    } else {
      result.message = "parameters written to " + params_path + " but " + err + "; " + data_note;
      return result;
    }
  }
  result.exit_code = 0;
  result.message = "identified " + model.name() + " from " + std::to_string(log.samples.size()) + " samples; " +
                   data_note;
  return result;
}

}  // namespace ftid::cell
