#include "ftid/common/default_files.hpp"
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
#include <sstream>
#include <thread>

#include "ftid/cell/cycle_recorder.hpp"
#include "ftid/cell/exports.hpp"
#include "ftid/cell/run_stream.hpp"
#include "ftid/common/error.hpp"
#include "ftid/fileio/atomic_file.hpp"
#include "ftid/config/daemon_config.hpp"
#include "ftid/daemon/client.hpp"
#include "ftid/design/trajectory_check.hpp"
#include "ftid/effects/model.hpp"
#include "ftid/samples/context.hpp"
#include "ftid/identify/fit.hpp"
#include "ftid/identify/fit_check.hpp"
#include "ftid/identify/offline.hpp"
#include "ftid/identify/physical_check.hpp"
#include "ftid/identify/robust_data.hpp"
#include "ftid/identify/tilt_start.hpp"
#include "ftid/params/parameter_set.hpp"
#include "ftid/lab/analyze.hpp"
#include "ftid/logio/log.hpp"
#include "ftid/model/kinematics.hpp"
#include "ftid/motion/robot_session.hpp"
#include "ftid/daemon/plausibility.hpp"
#include "ftid/trajectory/cell_limits.hpp"
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

/// Writes text through the one atomic writer (ftid/fileio/atomic_file.hpp).
void writeTextAtomic(const std::string& path, const std::string& text) { writeFileAtomically(path, text); }

/// True if both paths name the same file (or, if it does not exist yet, the same normalised path).
bool sameFile(const std::string& a, const std::string& b) {
  std::error_code ec;
  if (fs::exists(a, ec) && fs::exists(b, ec)) return fs::equivalent(a, b, ec);
  return fs::weakly_canonical(a, ec) == fs::weakly_canonical(b, ec);
}


/// What the trajectory's design predicts for the accuracy (its predicted standard errors at the
/// design's noise), printed before the robot moves.
std::string expectedAccuracy(const trajectory::TrajectoryFile& f, const std::string& model_name) {
  const auto get = [&](const std::string& k) {
    const auto it = f.predicted_std.find(k);
    return it == f.predicted_std.end() ? -1.0 : it->second;
  };
  const auto d = f.design.find("model");
  const std::string designed_for = d == f.design.end() ? std::string("?") : d->second;
  if (f.predicted_std.empty()) {
    return "  expected accuracy: unknown (the trajectory file records no predicted standard errors)";
  }
  std::string s = "  expected accuracy (1 sigma, predicted by the design for model " + designed_for + "):";
  const double m = get("mass");
  if (m >= 0) s += " mass " + fmt(4, m) + " kg";
  double c = 0.0;
  for (const char* k : {"com_x", "com_y", "com_z"}) c = std::max(c, get(k));
  if (c > 0) s += ", centre of mass " + fmt(2, 1000.0 * c) + " mm";
  const double t = std::max(get("tilt_u"), get("tilt_v"));
  if (t > 0) s += ", tilt " + fmt(3, t * 180.0 / M_PI) + " deg";
  double f0 = 0.0;
  for (const char* k : {"f0_x", "f0_y", "f0_z"}) f0 = std::max(f0, get(k));
  if (f0 > 0) s += ", F0 " + fmt(3, f0) + " N";
  double t0 = 0.0;
  for (const char* k : {"t0_x", "t0_y", "t0_z"}) t0 = std::max(t0, get(k));
  if (t0 > 0) s += ", T0 " + fmt(4, t0) + " Nm";
  if (designed_for != model_name) s += "\n  (you fit " + model_name + ": the figures are indicative only)";
  return s;
}

/// Shared between the real-time hook and the UI thread (atomics only).
/// Abort reasons: 0 none, 1 user, 2 ftidd silent, 3 sensor invalid, 4 this process was stalled
/// (SIGSTOP, overload), 5 our receive thread was starved, 6 the controller stalled.
struct HookContext {
  const CycleRecorder* recorder = nullptr;
  const std::atomic<bool>* user_abort = nullptr;
  std::atomic<bool> abort{false};
  std::atomic<int> reason{0};
  std::atomic<std::int64_t> detail_ms{0};  ///< the gap behind reasons 4..6 [ms]
  std::int64_t timeout_ns = 250000000;
  std::int64_t max_invalid = 5;
  double period = 0.008;                   ///< controller period [s] (configured)
  std::atomic<double> elapsed{0.0};
  std::atomic<int> phase{0};
  // Loop-thread state.
  std::int64_t last_hook_ns = 0;
  double last_robot_time = -1.0;
  double last_robot_gap_at = -1e300;       ///< robot time of the last state-package gap
  std::int64_t last_robot_gap_ms = 0;
};

void cycleHook(void* context, const motion::RecordedTick& tick) noexcept {
  auto* c = static_cast<HookContext*>(context);
  const std::int64_t now = monotonicNs();
  const std::int64_t since_hook = c->last_hook_ns > 0 ? now - c->last_hook_ns : 0;
  c->last_hook_ns = now;
  const double rt = tick.state.timestamp;
  if (c->last_robot_time >= 0.0 && rt - c->last_robot_time > 3.0 * c->period) {
    c->last_robot_gap_at = rt;
    c->last_robot_gap_ms = static_cast<std::int64_t>((rt - c->last_robot_time) * 1000.0);
  }
  c->last_robot_time = rt;
  c->phase.store(static_cast<int>(tick.phase), std::memory_order_relaxed);
  if (tick.t_traj >= 0.0) c->elapsed.store(tick.t_traj, std::memory_order_relaxed);
  if (c->abort.load(std::memory_order_relaxed)) return;
  if (c->user_abort && c->user_abort->load(std::memory_order_relaxed)) {
    c->reason.store(1);
    c->abort.store(true);
    return;
  }
  // This loop itself was stopped or starved (SIGSTOP, overload): named first, whatever else the
  // gap caused (after SIGCONT the receive thread may already have caught up with ftidd's queued
  // data, and the robot program's watchdog may have stopped the program: this tick reports that).
  if (since_hook > c->timeout_ns) {
    c->detail_ms.store(since_hook / 1000000);
    c->reason.store(4);
    c->abort.store(true);
    return;
  }
  const std::int64_t age = now - c->recorder->lastReceiveNs();
  if (age > c->timeout_ns) {
    // Who went quiet? This loop itself (stopped or starved: the gap is between our own calls),
    // our LCM receive thread (it polls every 50 ms), or ftidd (our side is alive).
    const std::int64_t poll_age = now - c->recorder->lastPollNs();
    if (since_hook > c->timeout_ns) {
      c->detail_ms.store(since_hook / 1000000);
      c->reason.store(4);
    } else if (poll_age > c->timeout_ns) {
      c->detail_ms.store(poll_age / 1000000);
      c->reason.store(5);
    } else {
      c->reason.store(2);
    }
    c->abort.store(true);
    return;
  }
  if (c->recorder->invalidSensorStreak() > c->max_invalid) {
    // Right after a gap in the robot's own packages ftidd cannot pair samples with robot states:
    // that is a controller stall, not a silent sensor.
    if (rt - c->last_robot_gap_at < 1.0) {
      c->detail_ms.store(c->last_robot_gap_ms);
      c->reason.store(6);
    } else {
      c->reason.store(3);
    }
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

std::string defaultTrajectoryName(const std::string& urdf_path, bool paper) {
  const std::string robot = fs::path(urdf_path).stem().string();
  return "excitation_" + robot + (paper ? "_paper" : "") + ".yaml";
}

CellIdentifyResult runCellIdentify(const CellIdentifyOptions& o) {
  CellIdentifyResult result;
  auto print = [&](const std::string& s) {
    if (o.print) o.print(s);
  };

  // ---- set-up: everything here may throw ConfigError before anything moves
  const config::DaemonConfig cfg = config::loadDaemonConfig(o.config_path);
  const std::string traj_path = o.trajectory_path.empty()
                                    ? findDefaultFile(defaultTrajectoryName(cfg.robot.urdf_path, o.paper))
                                    : o.trajectory_path;
  const trajectory::TrajectoryFile traj_file = trajectory::readTrajectoryFile(traj_path);
  const trajectory::FourierTrajectory traj = traj_file.toTrajectory();
  const effects::Model model = effects::Model::fromName(o.model);
  model::RobotKinematics kin = model::RobotKinematics::fromUrdfFile(cfg.robot.urdf_path, cfg.robot.base_link,
                                                                     cfg.robot.tip_link);
  kin.setSensorMount(cfg.sensor.R_FS(), cfg.sensor.p_FS_F());
  const std::string params_path = o.params_path.empty() ? cfg.parameters.path : o.params_path;
  if (o.reload_daemon && !sameFile(params_path, cfg.parameters.path)) {
    // ftidd reloads only its configured file (a RELOAD command carries no path), and a restart
    // would go back to it anyway: writing elsewhere and "reloading" would be a silent lie.
    throw ConfigError("--params " + params_path + " is not ftidd's parameter file (parameters.path in " +
                      cfg.source + " is " + cfg.parameters.path +
                      "); ftidd loads only that file. Change parameters.path in the config, or add "
                      "--no-reload to write " + params_path + " without touching ftidd; nothing moved");
  }
  const fs::path runs_dir = o.runs_dir.empty() ? fs::path(params_path).parent_path() / "runs" : fs::path(o.runs_dir);
  const fs::path run_dir = runs_dir / utcStamp(false);
  fs::create_directories(run_dir);

  print("ftid --identify: model " + model.name() + ", trajectory " + traj_path + " (" +
        fmt(1, traj.duration()) + " s)");
  print("  robot " + cfg.robot.host + ":" + std::to_string(cfg.robot.rtde_port) + ", ftidd data on " +
        cfg.lcm.channels.cycle + " (" + cfg.lcm.url + ")");
  print(expectedAccuracy(traj_file, model.name()));

  // ---- ftidd and sensor ready?
  const double rate = cfg.robot.rtde_frequency_hz > 0 ? cfg.robot.rtde_frequency_hz : 125.0;
  CycleRecorder recorder(cfg.lcm.url, cfg.lcm.channels.cycle,
                         static_cast<std::size_t>((traj.duration() + 180.0) * rate * 1.2));
  if (!cfg.lcm.accept_remote) recorder.restrictSources(transport::localSources());
  const std::string stream_path = (run_dir / "cycles.csv").string();
  recorder.streamTo(std::make_unique<RunStreamWriter>(stream_path));
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

  // ---- the exact targets are checked before any motion, whatever --yes says: here the
  // excitation at the configured controller rate (before asking), in the runner again with the
  // controller's real period and the approach from the robot's current pose.
  // The cell's limits, tightened by the trajectory's own (issue 26: an edited trajectory cannot
  // move the floor or widen a limit); printed with the file each limit came from.
  trajectory::LimitSources limit_sources;
  const trajectory::TrajectoryConstraints limits = trajectory::effectiveConstraints(
      traj_file.constraints, traj_path,
      trajectory::applicableCellLimits(o.cell_limits_path), &limit_sources);  // --cell only tightens
  print("  limits (a trajectory can only tighten the cell's):");
  {
    std::istringstream lines(trajectory::describeLimits(limits, limit_sources));
    for (std::string line; std::getline(lines, line);) print("    " + line);
  }
  auto joinViolations = [](const std::vector<std::string>& v) {
    std::string s;
    for (const auto& line : v) s += (s.empty() ? "" : "; ") + line;
    return s;
  };
  {
    const motion::EvaluatedTrajectory<trajectory::FourierTrajectory> source(traj);
    std::vector<double> t_traj;
    std::vector<JointVector> q_traj;
    const double period = 1.0 / rate;
    for (long k = 0;; ++k) {
      const double t = std::min(static_cast<double>(k) * period, traj.duration());
      JointVector q = JointVector::Zero();
      source.sample(t, &q);
      t_traj.push_back(t);
      q_traj.push_back(q);
      if (t >= traj.duration()) break;
    }
    const auto v = design::checkMotionSamples(period, {}, t_traj, q_traj, kin, limits);
    if (!v.empty()) {
      result.message = "trajectory " + traj_path + " refused before any motion (`ftid check-trajectory " +
                       traj_path + "` shows all margins): " + joinViolations(v) + "; nothing moved";
      return result;
    }
  }

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
  session.motion.preflight = [&](const motion::PlannedMotion& p) {
    return joinViolations(design::checkMotionSamples(p.period, p.approach, p.t_traj, p.q_traj, kin, limits));
  };

  HookContext hook;
  hook.recorder = &recorder;
  hook.user_abort = o.abort;
  hook.timeout_ns = static_cast<std::int64_t>(o.ftidd_timeout_s * 1e9);
  hook.max_invalid = o.max_invalid_sensor_cycles;
  hook.period = 1.0 / rate;
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
  const std::vector<CycleRecord> records = recorder.snapshot();

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
  // The stream must follow the controller's clock: duplicates are dropped, a second publisher
  // (conflicting samples, off-grid times) makes the run unusable.
  std::vector<CycleRecord> clean;
  const CycleStreamReport stream =
      checkCycleStream(records, rate, run.ok() ? t0 : -1e300, run.ok() ? t1 : 1e300, &clean);
  RecordsToLogReport conv;
  logio::LogData log = recordsToLog(clean, run.ok() ? t0 : -1e300, run.ok() ? t1 : 1e300,
                                    (run_dir / "run.csv").string(), &conv);
  std::string save_error;
  if (!log.samples.empty()) {
    try {
      logio::writeLog((run_dir / "run.csv").string(), log);
      result.data_csv = (run_dir / "run.csv").string();
    } catch (const std::exception& e) {
      save_error = e.what();
      struct statvfs fs_info {};
      if (::statvfs(run_dir.c_str(), &fs_info) == 0 && fs_info.f_bavail * fs_info.f_frsize < 1024 * 1024) {
        save_error += " (no space left on the file system of " + run_dir.string() + ")";
      }
      print("  WARNING: could not save " + (run_dir / "run.csv").string() + ": " + save_error);
    }
  }
  // The streamed capture holds everything received, whatever happened to run.csv.
  const RunStreamWriter* streamed = recorder.stream();
  std::string data_note;
  if (!result.data_csv.empty()) {
    data_note = "recorded data saved in " + result.data_csv;
  } else if (streamed != nullptr && streamed->rows() > 0) {
    data_note = "run.csv not written" + (save_error.empty() ? std::string() : " (" + save_error + ")") +
                "; the " + std::to_string(streamed->rows()) + " samples received are in " + streamed->path();
  } else {
    data_note = "no data recorded";
  }
  if (streamed != nullptr && streamed->failed()) data_note += "; streaming stopped: " + streamed->error();

  if (run.status == motion::RunStatus::kRefused) {
    result.message = "motion refused before it started: " + run.message + "; nothing moved, parameters unchanged";
    return result;
  }
  if (!run.ok()) {
    std::string why = std::string(motion::runStatusName(run.status)) + ": " + run.message;
    switch (hook.reason.load()) {
      case 1: why = "stopped by the operator (Ctrl-C)"; break;
      case 2: why = "ftidd stopped publishing (killed or stalled) during the motion"; break;
      case 3: why = "the F/T sensor went silent or invalid during the motion"; break;
      case 4:
        why = "ftid --identify itself was stopped or stalled for " + std::to_string(hook.detail_ms.load()) +
              " ms (SIGSTOP, or an overloaded host); ftidd was not at fault";
        break;
      case 5:
        why = "ftid --identify's receive thread was starved for " + std::to_string(hook.detail_ms.load()) +
              " ms (overloaded host), so ftidd's data could not be watched";
        break;
      case 6:
        why = "the robot controller stalled (no state package for " + std::to_string(hook.detail_ms.load()) +
              " ms), so ftidd could not pair sensor samples with robot states";
        break;
      default: break;
    }
    if (!stream.ok()) {  // say so too: a second publisher may be behind the abort
      why += "; also, the recorded " + cfg.lcm.channels.cycle + " stream does not match the controller (" +
             stream.describe() + ")";
    }
    result.message = "identification run aborted: " + why + "; the arm is stopped, parameters unchanged, " + data_note;
    return result;
  }
  print("  cycle stream: " + stream.describe());
  if (!stream.ok()) {
    result.message = "identification refused: the recorded " + cfg.lcm.channels.cycle +
                     " stream does not match the controller (" + stream.describe() +
                     "); parameters unchanged, " + data_note;
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
  samples::ContextOptions copts;
  copts.R_FS = cfg.sensor.R_FS();
  copts.p_FS_F = cfg.sensor.p_FS_F();
  params::ParameterSet set;
  try {
    const samples::ContextSet contexts = samples::buildContexts(log, kin, copts);
    // The offline identification's treatment: several tilt starts, glitches left out (robust_data.hpp).
    std::vector<std::string> notes;
    auto fitOn = [&](const std::vector<identify::SampleContext>& s) {
      identify::MultiStartFit m = identify::fitModelMultiStart(model, s);
      notes = std::move(m.notes);
      return identify::toParameterSet(m.fit);
    };
    const identify::RobustIdentification robust =
        identify::leaveOutGlitches(contexts.samples, fitOn(contexts.samples), fitOn);
    set = robust.set;
    if (!robust.glitches.samples.empty()) {
      print("  " + std::to_string(robust.glitches.samples.size()) +
            " glitch(es) (isolated spikes) left out of the fit, as `ftid analyze` leaves them out");
    }
    for (const auto& n : notes) print("  WARNING: " + n);
    set.provenance.date_utc = utcStamp(true);
    set.provenance.data_file = result.data_csv;
    set.time_origin_unix_s = contexts.time_origin_unix_s;  // the recording's first host_time
    set.provenance.method = "fit";
    set.provenance.trajectory = traj_path;
    set.provenance.n_samples = static_cast<int>(robust.samples.size());
    print("");
    print(identify::formatParameterTable(set));
    const identify::PhysicalValidity validity = identify::checkPhysicalValidity(set);
    print(validity.line);
    if (!validity.valid) {
      result.message = "identification refused: " + identify::physicalRefusal(validity) + "; parameters unchanged, " + data_note;
      return result;
    }
    // Does the model fit? Held-out residual against the noise floor, warning above 1.2x.
    print(identify::formatFitCheck(identify::checkFit(
        robust.samples,
        [&](const std::vector<identify::SampleContext>& train) {
          return identify::toParameterSet(identify::fitModelMultiStart(model, train).fit);
        },
        "ftid analyze " + lab::shellQuote(result.data_csv) + " --model " + lab::shellQuote(model.name()) +
            " --explain")));
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
              " %. Add it with:  ftid --identify --model " + lab::shellQuote(model.name() + "+" + top->effect));
        print("  or analyse the recorded data:  ftid analyze " + lab::shellQuote(result.data_csv) + " --model " +
              lab::shellQuote(model.name() + "+" + top->effect) + " --explain");
      } else {
        print("No significant effect is missing: the model explains the data down to the sensor noise.");
      }
      print("Report: " + (run_dir / "report.html").string());
    }
  } catch (const std::exception& e) {
    result.message = "identification failed: " + std::string(e.what()) + "; parameters unchanged, " + data_note;
    return result;
  }

  // ---- write parameters atomically (previous version kept) and exports. An inertia estimate
  // just outside the physically possible set (within 3 standard errors) is written as the nearest
  // possible one, and said so; the cell's plausibility limits are checked before anything is
  // written (issue 26).
  try {
    std::string not_projected;
    if (const std::string note = params::projectInertiaWithinUncertainty(&set, &not_projected); !note.empty()) {
      print("  note: " + note);
    }
    if (!not_projected.empty()) print("  " + not_projected);
    daemon::requirePlausible(set, daemon::plausibilityLimits(cfg), params_path + " (identified)");
  } catch (const std::exception& e) {
    result.message = "identification refused: " + std::string(e.what()) + "; parameters unchanged, " + data_note;
    return result;
  }
  try {
    fs::create_directories(fs::path(params_path).parent_path());
    params::writeParameterFile(params_path, set);
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
    print("Exports: " + writeExports(set, cfg, params_path + ".ros2.yaml", params_path + ".urscript"));
  } catch (const std::exception& e) {
    print("  WARNING: exports not written: " + std::string(e.what()));
  }
  print("Parameters written to " + params_path + " (previous version: " + params_path + ".bak)");

  if (o.reload_daemon) {
    daemon::DaemonClient client(daemon::DaemonClientOptions::fromConfig(cfg));
    const std::string err = client.sendCommand(daemon::DaemonCommand::kReloadParameters, 3.0).describe();
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
