// `ftid --identify` (cell_identify.hpp): one run as a sequence of named steps over one explicit
// state, IdentifyRun. Each step either continues or ends the run with a message in the result
// (nothing moved before the motion; after it: the arm stopped, the previous parameters intact,
// the recorded data kept and named). The steps:
//   IdentifyRun's constructor  load config, trajectory, model and kinematics; the run directory
//   connectToDaemon            ftidd publishing and the sensor valid, recorded from now on
//   checkBeforeMotion          the trajectory inside the cell's limits; the operator's yes
//   runMotion                  the motion on the robot clock, watched (identify_watch.cpp)
//   keepData                   the recorded stream checked, run.csv written, the data named
//   judgeRun                   refused, aborted, foreign stream or too few samples: no fit
//   identifyAndAnalyse         the robust fit, physical validity, fit check, the laboratory
//   writeParameters            plausibility, the atomic parameter write, the exports
//   reloadDaemon               ftidd's RELOAD, acknowledged
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
#include <memory>
#include <sstream>
#include <thread>
#include <vector>

#include "ftid/cell/cycle_recorder.hpp"
#include "ftid/cell/exports.hpp"
#include "ftid/cell/run_stream.hpp"
#include "run_report.hpp"
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
#include "identify_watch.hpp"

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

/// Writes text through the one atomic writer (ftid/fileio/atomic_file.hpp).
void writeTextAtomic(const std::string& path, const std::string& text) { writeFileAtomically(path, text); }

/// True if both paths name the same file (or, if it does not exist yet, the same normalised path).
bool sameFile(const std::string& a, const std::string& b) {
  std::error_code ec;
  if (fs::exists(a, ec) && fs::exists(b, ec)) return fs::equivalent(a, b, ec);
  return fs::weakly_canonical(a, ec) == fs::weakly_canonical(b, ec);
}

/// The violations of a motion check as one line.
std::string joinViolations(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& line : v) s += (s.empty() ? "" : "; ") + line;
  return s;
}

using internal::HookContext;
using internal::axesAboveFloor;
using internal::axisTable;
using internal::expectedAccuracy;
using internal::fmt;

/// Model::fromName's model with the kinematics of the config's robot and sensor mount.
model::RobotKinematics cellKinematics(const config::DaemonConfig& cfg) {
  model::RobotKinematics kin = model::RobotKinematics::fromUrdfFile(cfg.robot.urdf_path, cfg.robot.base_link,
                                                                     cfg.robot.tip_link);
  kin.setSensorMount(cfg.sensor.R_FS(), cfg.sensor.p_FS_F());
  return kin;
}

/// The state of one run, from step to step. Constructed by the set-up, which may throw
/// ConfigError before anything moves (members are initialised in the order they are declared).
struct IdentifyRun {
  explicit IdentifyRun(const CellIdentifyOptions& options);
  void print(const std::string& s) const {
    if (o.print) o.print(s);
  }

  const CellIdentifyOptions& o;
  CellIdentifyResult result;
  // set-up
  const config::DaemonConfig cfg;
  const std::string traj_path;
  const trajectory::TrajectoryFile traj_file;
  const trajectory::FourierTrajectory traj;
  const effects::Model model;
  const model::RobotKinematics kin;
  const std::string params_path;
  fs::path run_dir;
  double rate = 125.0;  ///< controller rate [Hz] (configured)
  // connection and limits
  std::unique_ptr<CycleRecorder> recorder;
  trajectory::TrajectoryConstraints limits;
  // the motion and its record
  HookContext hook;
  motion::RunResult run;
  std::vector<CycleRecord> records;
  CycleStreamReport stream;
  RecordsToLogReport conv;
  logio::LogData log;
  std::string data_note;
  // the identification
  params::ParameterSet set;
};

IdentifyRun::IdentifyRun(const CellIdentifyOptions& options)
    : o(options),
      cfg(config::loadDaemonConfig(o.config_path)),
      traj_path(o.trajectory_path.empty() ? findDefaultFile(defaultTrajectoryName(cfg.robot.urdf_path, o.paper))
                                          : o.trajectory_path),
      traj_file(trajectory::readTrajectoryFile(traj_path)),
      traj(traj_file.toTrajectory()),
      model(effects::Model::fromName(o.model)),
      kin(cellKinematics(cfg)),
      params_path(o.params_path.empty() ? cfg.parameters.path : o.params_path) {
  if (o.reload_daemon && !sameFile(params_path, cfg.parameters.path)) {
    // ftidd reloads only its configured file (a RELOAD command carries no path), and a restart
    // would go back to it anyway: writing elsewhere and "reloading" would be a silent lie.
    throw ConfigError("--params " + params_path + " is not ftidd's parameter file (parameters.path in " +
                      cfg.source + " is " + cfg.parameters.path +
                      "); ftidd loads only that file. Change parameters.path in the config, or add "
                      "--no-reload to write " + params_path + " without touching ftidd; nothing moved");
  }
  const fs::path runs_dir = o.runs_dir.empty() ? fs::path(params_path).parent_path() / "runs" : fs::path(o.runs_dir);
  run_dir = runs_dir / utcStamp(false);
  fs::create_directories(run_dir);

  print("ftid --identify: model " + model.name() + ", trajectory " + traj_path + " (" +
        fmt(1, traj.duration()) + " s)");
  print("  robot " + cfg.robot.host + ":" + std::to_string(cfg.robot.rtde_port) + ", ftidd data on " +
        cfg.lcm.channels.cycle + " (" + cfg.lcm.url + ")");
  print(expectedAccuracy(traj_file, model.name()));
  rate = cfg.robot.rtde_frequency_hz > 0 ? cfg.robot.rtde_frequency_hz : 125.0;
}

/// ftidd and sensor ready? Starts recording ftidd's cycle stream (streamed to cycles.csv).
bool connectToDaemon(IdentifyRun& r) {
  const CellIdentifyOptions& o = r.o;
  const config::DaemonConfig& cfg = r.cfg;
  CellIdentifyResult& result = r.result;
  r.recorder = std::make_unique<CycleRecorder>(cfg.lcm.url, cfg.lcm.channels.cycle,
                                               static_cast<std::size_t>((r.traj.duration() + 180.0) * r.rate * 1.2));
  CycleRecorder& recorder = *r.recorder;
  if (!cfg.lcm.accept_remote) recorder.restrictSources(transport::localSources());
  const std::string stream_path = (r.run_dir / "cycles.csv").string();
  recorder.streamTo(std::make_unique<RunStreamWriter>(stream_path));
  recorder.start();
  if (!recorder.waitForRecords(10, std::chrono::milliseconds(static_cast<int>(o.startup_wait_s * 1000)))) {
    result.message = "ftidd is not publishing cycle samples on " + cfg.lcm.channels.cycle + " (" + cfg.lcm.url +
                     "): start it (systemctl start ftidd) and check `journalctl -u ftidd`; nothing moved";
    return false;
  }
  // One stale sample now and then is normal on a busy host; a sensor that stays invalid is not.
  for (int i = 0; i < 100 && recorder.invalidSensorStreak() > 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  if (recorder.invalidSensorStreak() > 0) {
    result.message = "the F/T sensor is not delivering valid data through ftidd (stale or invalid samples); "
                     "check the sensor and its CAN link; nothing moved";
    return false;
  }
  r.print("  ftidd and the sensor are up (" + std::to_string(recorder.count()) + " cycle samples received)");
  return true;
}

/// The exact targets are checked before any motion, whatever --yes says: here the excitation at
/// the configured controller rate (before asking), in the runner again (runMotion's preflight)
/// with the controller's real period and the approach from the robot's current pose. Then the
/// operator's confirmation unless --yes. False if refused or cancelled (nothing moved).
bool checkBeforeMotion(IdentifyRun& r) {
  const CellIdentifyOptions& o = r.o;
  const trajectory::FourierTrajectory& traj = r.traj;
  const std::string& traj_path = r.traj_path;
  CellIdentifyResult& result = r.result;
  // The cell's limits, tightened by the trajectory's own (issue 26: an edited trajectory cannot
  // move the floor or widen a limit); printed with the file each limit came from.
  trajectory::LimitSources limit_sources;
  r.limits = trajectory::effectiveConstraints(
      r.traj_file.constraints, traj_path,
      trajectory::applicableCellLimits(o.cell_limits_path), &limit_sources);  // --cell only tightens
  r.print("  limits (a trajectory can only tighten the cell's):");
  {
    std::istringstream lines(trajectory::describeLimits(r.limits, limit_sources));
    for (std::string line; std::getline(lines, line);) r.print("    " + line);
  }
  {
    const motion::EvaluatedTrajectory<trajectory::FourierTrajectory> source(traj);
    std::vector<double> t_traj;
    std::vector<JointVector> q_traj;
    const double period = 1.0 / r.rate;
    for (long k = 0;; ++k) {
      const double t = std::min(static_cast<double>(k) * period, traj.duration());
      JointVector q = JointVector::Zero();
      source.sample(t, &q);
      t_traj.push_back(t);
      q_traj.push_back(q);
      if (t >= traj.duration()) break;
    }
    const auto v = design::checkMotionSamples(period, {}, t_traj, q_traj, r.kin, r.limits);
    if (!v.empty()) {
      result.message = "trajectory " + traj_path + " refused before any motion (`ftid check-trajectory " +
                       traj_path + "` shows all margins): " + joinViolations(v) + "; nothing moved";
      return false;
    }
  }

  if (!o.assume_yes) {
    const bool yes = o.confirm && o.confirm("The robot will move: slowly to the start pose, then the " +
                                            fmt(1, traj.duration()) +
                                            " s excitation trajectory. Is the workspace clear? [y/N] ");
    if (!yes) {
      result.message = "cancelled by the operator; nothing moved";
      return false;
    }
  }
  return true;
}

/// The motion, on the robot clock, watched by the hook; cycle samples recorded meanwhile. False if
/// the robot could not be set up (nothing moved).
bool runMotion(IdentifyRun& r) {
  const CellIdentifyOptions& o = r.o;
  const config::DaemonConfig& cfg = r.cfg;
  const trajectory::FourierTrajectory& traj = r.traj;
  CycleRecorder& recorder = *r.recorder;
  HookContext& hook = r.hook;
  motion::RobotSessionConfig session;
  session.arm.host = cfg.robot.host;
  session.arm.rtde_port = static_cast<std::uint16_t>(cfg.robot.rtde_port);
  session.arm.script_port = static_cast<std::uint16_t>(o.script_port);
  session.arm.register_offset = o.register_offset;
  session.motion.realtime.require = o.require_realtime;
  session.motion.preflight = [&r](const motion::PlannedMotion& p) {
    return joinViolations(design::checkMotionSamples(p.period, p.approach, p.t_traj, p.q_traj, r.kin, r.limits));
  };
  hook.recorder = &recorder;
  hook.user_abort = o.abort;
  hook.timeout_ns = static_cast<std::int64_t>(o.ftidd_timeout_s * 1e9);
  hook.max_invalid = o.max_invalid_sensor_cycles;
  hook.period = 1.0 / r.rate;
  recorder.clear();

  std::atomic<bool> ui_running{true};
  std::thread ui;
  if (o.progress) {
    ui = std::thread([&o, &hook, &traj, &ui_running] {
      while (ui_running.load()) {
        o.progress(internal::phaseName(hook.phase.load()), hook.elapsed.load(), traj.duration());
        std::this_thread::sleep_for(std::chrono::milliseconds(200));
      }
    });
  }
  motion::SessionResult session_result;
  std::string setup_error;
  try {
    const motion::EvaluatedTrajectory<trajectory::FourierTrajectory> source(traj);
    session_result = motion::runOnRobot(session, source, &hook.abort, &internal::cycleHook, &hook);
  } catch (const std::exception& e) {
    setup_error = e.what();
  }
  ui_running = false;
  if (ui.joinable()) ui.join();
  // Let the last samples arrive, then stop recording.
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  recorder.stop();
  r.records = recorder.snapshot();

  if (!setup_error.empty()) {
    r.result.message = "robot set-up failed: " + setup_error + "; nothing moved, parameters unchanged";
    return false;
  }
  r.run = session_result.run;
  return true;
}

/// Keeps the data, whatever happened: the stream checked against the controller's clock, run.csv
/// written, and r.data_note saying where the data are.
void keepData(IdentifyRun& r) {
  const motion::RunResult& run = r.run;
  const fs::path& run_dir = r.run_dir;
  CellIdentifyResult& result = r.result;
  double t0 = -1e300;
  double t1 = 1e300;
  if (run.excitation_start_timestamp >= 0.0) {
    t0 = run.excitation_start_timestamp;
    t1 = t0 + r.traj.duration();
  }
  // The stream must follow the controller's clock: duplicates are dropped, a second publisher
  // (conflicting samples, off-grid times) makes the run unusable.
  std::vector<CycleRecord> clean;
  r.stream =
      checkCycleStream(r.records, r.rate, run.ok() ? t0 : -1e300, run.ok() ? t1 : 1e300, &clean);
  r.log = recordsToLog(clean, run.ok() ? t0 : -1e300, run.ok() ? t1 : 1e300, (run_dir / "run.csv").string(),
                       &r.conv);
  std::string save_error;
  if (!r.log.samples.empty()) {
    try {
      logio::writeLog((run_dir / "run.csv").string(), r.log);
      result.data_csv = (run_dir / "run.csv").string();
    } catch (const std::exception& e) {
      save_error = e.what();
      struct statvfs fs_info {};
      if (::statvfs(run_dir.c_str(), &fs_info) == 0 && fs_info.f_bavail * fs_info.f_frsize < 1024 * 1024) {
        save_error += " (no space left on the file system of " + run_dir.string() + ")";
      }
      r.print("  WARNING: could not save " + (run_dir / "run.csv").string() + ": " + save_error);
    }
  }
  // The streamed capture holds everything received, whatever happened to run.csv.
  const RunStreamWriter* streamed = r.recorder->stream();
  std::string& data_note = r.data_note;
  if (!result.data_csv.empty()) {
    data_note = "recorded data saved in " + result.data_csv;
  } else if (streamed != nullptr && streamed->rows() > 0) {
    data_note = "run.csv not written" + (save_error.empty() ? std::string() : " (" + save_error + ")") +
                "; the " + std::to_string(streamed->rows()) + " samples received are in " + streamed->path();
  } else {
    data_note = "no data recorded";
  }
  if (streamed != nullptr && streamed->failed()) data_note += "; streaming stopped: " + streamed->error();
}

/// The run's verdict before any fit: refused, aborted (the watch's reason), a stream that does not
/// match the controller, or too few samples end the run with the parameters unchanged.
bool judgeRun(IdentifyRun& r) {
  const motion::RunResult& run = r.run;
  const CycleStreamReport& stream = r.stream;
  const std::string& data_note = r.data_note;
  CellIdentifyResult& result = r.result;
  if (run.status == motion::RunStatus::kRefused) {
    result.message = "motion refused before it started: " + run.message + "; nothing moved, parameters unchanged";
    return false;
  }
  if (!run.ok()) {
    std::string why = internal::abortReason(r.hook, std::string(motion::runStatusName(run.status)) + ": " + run.message);
    if (!stream.ok()) {  // say so too: a second publisher may be behind the abort
      why += "; also, the recorded " + r.cfg.lcm.channels.cycle + " stream does not match the controller (" +
             stream.describe() + ")";
    }
    result.message = "identification run aborted: " + why + "; the arm is stopped, parameters unchanged, " + data_note;
    return false;
  }
  r.print("  cycle stream: " + stream.describe());
  if (!stream.ok()) {
    result.message = "identification refused: the recorded " + r.cfg.lcm.channels.cycle +
                     " stream does not match the controller (" + stream.describe() +
                     "); parameters unchanged, " + data_note;
    return false;
  }
  r.print("  motion complete: " + std::to_string(r.conv.converted) + " synchronised samples (" +
        std::to_string(r.conv.skipped_invalid) + " invalid dropped), max tracking error " +
        fmt(4, run.max_tracking_error) + " rad");
  if (r.log.samples.size() < 50) {
    result.message = "too few valid samples recorded during the excitation (" + std::to_string(r.log.samples.size()) +
                     "); parameters unchanged, " + data_note;
    return false;
  }
  return true;
}

/// The model laboratory on the run (o.analyze): held-out residuals per axis, the missing effect
/// it names and the command that adds it; analysis.json and report.html in the run directory.
/// Returns the change in time the laboratory found ("" when none): a run that holds more than one
/// set-up (a contact with the tool, a grasp or release while it moved) is not written.
std::string analyseRun(IdentifyRun& r, const samples::ContextSet& contexts) {
  const CellIdentifyOptions& o = r.o;
  const effects::Model& model = r.model;
  const fs::path& run_dir = r.run_dir;
  CellIdentifyResult& result = r.result;
  params::ParameterSet& set = r.set;
  const auto print = [&r](const std::string& s) { r.print(s); };
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
  std::string change;  // change in time (lab/change_point.hpp)
  for (const auto& cp : ar.change_points) change += (change.empty() ? "" : "; ") + lab::describeChangePoint(cp);
  if (!change.empty()) {
    print("WARNING: " + change + ": the run holds " + std::to_string(ar.change_points.size() + 1) +
          " set-ups; the parameters describe none of them. Repeat the run without the change (no contact, "
          "no grasp or release while it moves).");
  }
  if (!change.empty()) {
    print("The candidate effects would only imitate the change. The recorded data in segments:");
    for (const auto& c : lab::segmentCommands(ar.change_points, lab::shellQuote(result.data_csv), model.name())) {
      print("  " + c);
    }
  } else if (top) {
    result.suggested_effect = top->effect;
    print("A physical effect is missing from the model: " + top->effect + " (" + top->description + ").");
    print("  adding it would cut the held-out residual by " + fmt(0, 100.0 * top->relative_reduction) +
          " %. Add it with:  ftid --identify --model " + lab::shellQuote(model.name() + "+" + top->effect));
    print("  or analyse the recorded data:  ftid analyze " + lab::shellQuote(result.data_csv) + " --model " +
          lab::shellQuote(model.name() + "+" + top->effect) + " --explain");
  } else if (const std::string above = axesAboveFloor(ar.report.residual_rms, ar.noise_floor); !above.empty()) {
    print("No candidate effect explains what is left, yet the held-out residual is above the noise floor (" + above +
          "): the run was disturbed (a contact, a stalled host) or the model misses an effect outside the "
          "laboratory's menu; see the report, and repeat the run.");
  } else {
    print("No significant effect is missing: the model explains the data down to the sensor noise.");
  }
  print("Report: " + (run_dir / "report.html").string());
  return change;
}

/// The laboratory on the run (analyseRun); true, with the refusal in the result's message, when it
/// found a change in time.
bool refuseAChange(IdentifyRun& r, const samples::ContextSet& contexts) {
  const std::string change = analyseRun(r, contexts);
  if (change.empty()) return false;
  r.result.message = "identification refused: the run holds more than one set-up (" + change +
                     "): no parameters describe it; repeat the run without touching the tool and without a "
                     "grasp or release while it moves; parameters unchanged, " + r.data_note;
  return true;
}

/// Identify and analyse: the offline identification's treatment (several tilt starts, glitches
/// left out, robust_data.hpp), the physical-validity verdict, the held-out fit check and the
/// laboratory. False, parameters unchanged, if the fit fails or is refused.
bool identifyAndAnalyse(IdentifyRun& r) {
  const CellIdentifyOptions& o = r.o;
  const effects::Model& model = r.model;
  const std::string& data_note = r.data_note;
  CellIdentifyResult& result = r.result;
  params::ParameterSet& set = r.set;
  const auto print = [&r](const std::string& s) { r.print(s); };
  samples::ContextOptions copts;
  copts.R_FS = r.cfg.sensor.R_FS();
  copts.p_FS_F = r.cfg.sensor.p_FS_F();
  try {
    const samples::ContextSet contexts = samples::buildContexts(r.log, r.kin, copts);
    // The offline identification's treatment: several tilt starts, saturated samples and glitches left
    // out (robust_data.hpp).
    std::vector<std::string> notes;
    auto fitOn = [&](const std::vector<identify::SampleContext>& s) {
      identify::MultiStartFit m = identify::fitModelMultiStart(model, s);
      notes = std::move(m.notes);
      return identify::toParameterSet(m.fit);
    };
    const identify::RobustIdentification robust = identify::leaveOutBadSamples(contexts.samples, {}, fitOn);
    set = robust.set;
    const std::vector<identify::SampleContext>& fitted = robust.fittedOn(contexts.samples);
    for (const auto& s : robust.saturation.axes) print("  WARNING: " + identify::saturationLine(s));
    if (!robust.glitches.samples.empty()) {
      print("  " + std::to_string(robust.glitches.samples.size()) +
            " glitch(es) (isolated spikes) left out of the fit, as `ftid analyze` leaves them out");
    }
    for (const auto& n : notes) print("  WARNING: " + n);
    set.provenance.date_utc = utcStamp(true);
    set.provenance.data_file = result.data_csv;
    set.time_origin_unix_s = contexts.time_origin_unix_s;  // the recording's first host_time
    set.provenance.method = "fit";
    set.provenance.trajectory = r.traj_path;
    set.provenance.n_samples = static_cast<int>(fitted.size());
    std::string imu_note;  // the IMU's biases, for ftidd's sensor.motion_source: imu
    set.imu = identify::imuBiasEntriesOf(fitted, &imu_note);
    if (!imu_note.empty()) print("  " + imu_note);
    print("");
    print(identify::formatParameterTable(set));
    // A mass that moves with a signal (payload(t)) must be positive at every sample too.
    const identify::PhysicalValidity validity =
        identify::checkPhysicalValidity(set, identify::varyingMass(set, fitted));
    print(validity.line);
    // A run of two set-ups (a contact, a grasp) is the cause to name, even when its fit is also
    // impossible: the laboratory looks first.
    if (o.analyze && !validity.valid) {
      try {
        if (refuseAChange(r, contexts)) return false;
      } catch (const std::exception& e) {  // the laboratory could not run: the physical refusal stands
        print("  WARNING: the laboratory could not analyse the run: " + std::string(e.what()));
      }
    }
    if (!validity.valid) {
      result.message = "identification refused: " + identify::physicalRefusal(validity) + "; parameters unchanged, " + data_note;
      return false;
    }
    // Does the model fit? Held-out residual against the noise floor, warning above 1.2x.
    print(identify::formatFitCheck(identify::checkFit(
        fitted,
        [&](const std::vector<identify::SampleContext>& train) {
          return identify::toParameterSet(identify::fitModelMultiStart(model, train).fit);
        },
        "ftid analyze " + lab::shellQuote(result.data_csv) + " --model " + lab::shellQuote(model.name()) +
            " --explain")));
    if (o.analyze && refuseAChange(r, contexts)) return false;
  } catch (const std::exception& e) {
    result.message = "identification failed: " + std::string(e.what()) + "; parameters unchanged, " + data_note;
    return false;
  }
  return true;
}

/// Writes the parameters atomically (previous version kept) and the exports. An inertia estimate
/// just outside the physically possible set (within 3 standard errors) is written as the nearest
/// possible one, and said so; the cell's plausibility limits are checked before anything is
/// written (issue 26). False if refused or not written (the previous parameters intact).
bool writeParameters(IdentifyRun& r) {
  const config::DaemonConfig& cfg = r.cfg;
  const std::string& params_path = r.params_path;
  const std::string& data_note = r.data_note;
  CellIdentifyResult& result = r.result;
  params::ParameterSet& set = r.set;
  const auto print = [&r](const std::string& s) { r.print(s); };
  try {
    std::string not_projected;
    if (const std::string note = params::projectInertiaWithinUncertainty(&set, &not_projected); !note.empty()) {
      print("  note: " + note);
    }
    if (!not_projected.empty()) print("  " + not_projected);
    daemon::requirePlausible(set, daemon::plausibilityLimits(cfg), params_path + " (identified)");
  } catch (const std::exception& e) {
    result.message = "identification refused: " + std::string(e.what()) + "; parameters unchanged, " + data_note;
    return false;
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
    return false;
  }
  try {
    print("Exports: " + writeExports(set, cfg, params_path + ".ros2.yaml", params_path + ".urscript"));
  } catch (const std::exception& e) {
    print("  WARNING: exports not written: " + std::string(e.what()));
  }
  print("Parameters written to " + params_path + " (previous version: " + params_path + ".bak)");
  return true;
}

/// Asks ftidd to reload its parameter file (o.reload_daemon) and waits for its acknowledgement.
bool reloadDaemon(IdentifyRun& r) {
  const CellIdentifyOptions& o = r.o;
  const config::DaemonConfig& cfg = r.cfg;
  const std::string& params_path = r.params_path;
  const std::string& data_note = r.data_note;
  CellIdentifyResult& result = r.result;
  if (o.reload_daemon) {
    daemon::DaemonClient client(daemon::DaemonClientOptions::fromConfig(cfg));
    const std::string err = client.sendCommand(daemon::DaemonCommand::kReloadParameters, 3.0).describe();
    if (err.empty()) {
      result.reloaded = true;
      r.print("ftidd reloaded the new parameters.");
    } else {
      result.message = "parameters written to " + params_path + " but " + err + "; " + data_note;
      return false;
    }
  }
  return true;
}

}  // namespace

std::string defaultTrajectoryName(const std::string& urdf_path, bool paper) {
  const std::string robot = fs::path(urdf_path).stem().string();
  return "excitation_" + robot + (paper ? "_paper" : "") + ".yaml";
}

CellIdentifyResult runCellIdentify(const CellIdentifyOptions& o) {
  IdentifyRun r(o);  // everything here may throw ConfigError before anything moves
  if (!connectToDaemon(r) || !checkBeforeMotion(r) || !runMotion(r)) return r.result;
  keepData(r);  // whatever happened
  if (!judgeRun(r) || !identifyAndAnalyse(r) || !writeParameters(r) || !reloadDaemon(r)) return r.result;
  r.result.exit_code = 0;
  r.result.message = "identified " + r.model.name() + " from " + std::to_string(r.log.samples.size()) +
                     " samples; " + r.data_note;
  return r.result;
}

}  // namespace ftid::cell
