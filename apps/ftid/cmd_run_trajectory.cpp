// `ftid run-trajectory`: stream an excitation trajectory to a UR controller (or `ftid sim-robot`)
// and record the robot state. Library code: ftid::motion (runOnRobot, recordingToLog).
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <iostream>
#include <string>
#include <thread>

#include "command.hpp"
#include "ftid/fileio/atomic_file.hpp"
#include "ftid/common/error.hpp"
#include "ftid/design/trajectory_check.hpp"
#include "ftid/model/kinematics.hpp"
#include "ftid/logio/log.hpp"
#include "ftid/motion/recording_log.hpp"
#include "ftid/motion/robot_session.hpp"
#include "ftid/trajectory/trajectory_io.hpp"

namespace {

const char* kUsage =
    "usage: ftid run-trajectory TRAJ --out robot_log.csv [--robot-host 127.0.0.1] [--rtde-port 30004]\n"
    "                           [--script-port 30003] [--register-offset 0|24] [--lookahead 0.1]\n"
    "                           [--gain 300] [--approach-speed 0.25] [--tracking-limit 0.05]\n"
    "                           [--robot URDF] [--constraints TRAJ.yaml] [--require-rt] [--yes]\n"
    "\n"
    "Moves the robot slowly to the trajectory's start pose, streams the trajectory with servoj at\n"
    "the controller rate (125 Hz CB3, 500 Hz e-Series) from a real-time loop clocked by the robot,\n"
    "and writes every controller tick to --out (log format: t, q1..q6, qd1..qd6, qdd1..qdd6 plus\n"
    "robot_timestamp, t_traj, phase, q_cmd*, target_q*, modes; docs/robot.md).\n"
    "\n"
    "  TRAJ               traj.yaml (ftid design) or a sampled CSV with t, q1..q6 (t from 0)\n"
    "  --robot-host H     controller address (default 127.0.0.1, e.g. `ftid sim-robot`)\n"
    "  --register-offset  RTDE registers used by the servo program: 0 (default) or 24\n"
    "  --lookahead, --gain  servoj parameters (0.03..0.2 s, 100..2000)\n"
    "  --approach-speed   peak joint speed of the move to the start pose [rad/s] (default 0.25)\n"
    "  --tracking-limit   abort when |actual_q - q(t)| exceeds this [rad] (default 0.05)\n"
    "  --robot URDF       robot model for the pre-motion check (default: the one in TRAJ.yaml)\n"
    "  --constraints F    check against the constraints of this traj.yaml (default: TRAJ's own;\n"
    "                     required for a sampled CSV, which carries none)\n"
    "  --require-rt       refuse to run without SCHED_FIFO/mlockall instead of warning\n"
    "  --yes              do not ask for confirmation before the robot moves\n"
    "\n"
    "Before any motion, every target that will be streamed (the approach from the current pose and\n"
    "the trajectory at the controller's period) is checked like `ftid check-trajectory`: tool above\n"
    "the floor and clear of the keep-out spheres, joints inside the designed ranges, velocity and\n"
    "acceleration within the designed limits. A violation refuses the run (whatever --yes says) and\n"
    "names the sample and the constraint; nothing moves.\n"
    "The robot MOVES. Keep the emergency stop at hand. Ctrl-C stops the arm and keeps the data.\n"
    "Exit status: 0 completed, 1 aborted or failed (the message says why), 2 usage error.";

std::atomic<bool> g_abort{false};
extern "C" void onSignal(int) { g_abort.store(true); }

struct Progress {
  std::atomic<int> phase{0};
  std::atomic<double> t_traj{-1.0};
  std::atomic<long> ticks{0};
  static void hook(void* ctx, const ftid::motion::RecordedTick& t) noexcept {
    auto* p = static_cast<Progress*>(ctx);
    p->phase.store(static_cast<int>(t.phase), std::memory_order_relaxed);
    p->t_traj.store(t.t_traj, std::memory_order_relaxed);
    p->ticks.fetch_add(1, std::memory_order_relaxed);
  }
};

// The command line: the session's settings and the files.
struct RunTrajectoryArgs {
  ftid::motion::RobotSessionConfig cfg;
  bool yes = false;
  std::string robot_urdf, constraints_path, out, path;
};

// Parses the command line; UsageError when the trajectory or --out is missing.
RunTrajectoryArgs parseArgs(const std::vector<std::string>& argv) {
  namespace cli = ftid::cli;
  RunTrajectoryArgs a;
  a.cfg.arm.host = "127.0.0.1";
  int rtde_port = 30004, script_port = 30003;
  CLI::App app{"ftid run-trajectory"};
  app.add_option("--robot-host", a.cfg.arm.host);
  app.add_option("--rtde-port", rtde_port)->transform(cli::integer(1, 65535));
  app.add_option("--script-port", script_port)->transform(cli::integer(1, 65535));
  app.add_option("--register-offset", a.cfg.arm.register_offset)->transform(cli::integer(0, 24));
  app.add_option("--lookahead", a.cfg.arm.lookahead_time)->transform(cli::real(cli::positive()));
  app.add_option("--gain", a.cfg.arm.gain)->transform(cli::real(cli::positive()));
  app.add_option("--approach-speed", a.cfg.motion.approach_velocity)->transform(cli::real({0.0, 1.0, true, false}));
  app.add_option("--tracking-limit", a.cfg.motion.tracking_error_limit)->transform(cli::real(cli::positive()));
  app.add_flag("--require-rt", a.cfg.motion.realtime.require);
  app.add_flag("--yes", a.yes);
  app.add_option("--robot", a.robot_urdf);
  app.add_option("--constraints", a.constraints_path);
  app.add_option("--out", a.out);
  app.add_option("TRAJECTORY", a.path);
  cli::parse(app, argv);
  a.cfg.arm.rtde_port = static_cast<std::uint16_t>(rtde_port);
  a.cfg.arm.script_port = static_cast<std::uint16_t>(script_port);
  if (a.path.empty()) throw cli::UsageError("expected exactly one trajectory file");
  if (a.out.empty()) throw cli::UsageError("--out is required");
  return a;
}

// True for a traj.yaml (ftid design), false for a sampled CSV.
bool isYamlTrajectory(const std::string& path) {
  return path.size() > 5 && (path.substr(path.size() - 5) == ".yaml" || path.substr(path.size() - 4) == ".yml");
}

// The trajectory to stream: a traj.yaml's Fourier trajectory, read into *fourier (which the source
// refers to: it must outlive it), or a sampled CSV's t, q1..q6.
std::unique_ptr<ftid::motion::JointTrajectorySource> loadTrajectory(
    const std::string& path, bool yaml, ftid::trajectory::FourierTrajectory* fourier) {
  if (yaml) {
    *fourier = ftid::trajectory::readTrajectoryFile(path).toTrajectory();
    return std::make_unique<ftid::motion::EvaluatedTrajectory<ftid::trajectory::FourierTrajectory>>(*fourier);
  }
  const auto log = ftid::logio::readLog(path, ftid::logio::LogKind::kTrajectory);
  std::vector<double> t;
  std::vector<ftid::JointVector> q;
  for (const auto& s : log.samples) {
    t.push_back(s.t);
    q.push_back(s.q);
  }
  return std::make_unique<ftid::motion::SampledTrajectory>(std::move(t), std::move(q));
}

// The constraints of the pre-motion check (MotionConfig::preflight), from --constraints or the
// traj.yaml itself; the robot model recorded there unless --robot gave one (a.robot_urdf).
ftid::trajectory::TrajectoryConstraints motionConstraints(RunTrajectoryArgs& a, bool yaml) {
  if (a.constraints_path.empty() && !yaml) {
    throw ftid::cli::UsageError(a.path + " is a sampled trajectory and carries no constraints: give --constraints "
                                "TRAJ.yaml (the design it was sampled from) so the motion can be checked");
  }
  const auto cfile = ftid::trajectory::readTrajectoryFile(a.constraints_path.empty() ? a.path : a.constraints_path);
  if (a.robot_urdf.empty()) a.robot_urdf = cfile.robot;
  return cfile.constraints;
}

// The pre-motion check: every planned target checked like `ftid check-trajectory`; "" if all pass,
// else the violations joined by "; ". Refers to kin and limits: they must outlive it.
ftid::motion::PreflightCheck preflightCheck(const ftid::model::RobotKinematics& kin,
                                            const ftid::trajectory::TrajectoryConstraints& limits) {
  return [&kin, &limits](const ftid::motion::PlannedMotion& p) {
    std::string s;
    for (const auto& line : ftid::design::checkMotionSamples(p.period, p.approach, p.t_traj, p.q_traj, kin, limits)) {
      s += (s.empty() ? "" : "; ") + line;
    }
    return s;
  };
}

// Prints the trajectory and what the robot will do; unless --yes, asks for "yes" on stdin. False
// if not confirmed (nothing moved).
bool confirmMotion(const RunTrajectoryArgs& a, const ftid::motion::JointTrajectorySource& source) {
  const ftid::JointVector start = source.startPose();
  std::printf("trajectory %s: %.2f s, start pose [%.4f %.4f %.4f %.4f %.4f %.4f] rad\n", a.path.c_str(),
              source.duration(), start[0], start[1], start[2], start[3], start[4], start[5]);
  std::printf("robot %s (RTDE %u, scripts %u): the arm will move to the start pose at <= %.2f rad/s, then "
              "run the trajectory.\n",
              a.cfg.arm.host.c_str(), a.cfg.arm.rtde_port, a.cfg.arm.script_port, a.cfg.motion.approach_velocity);
  if (a.yes) return true;
  std::printf("Type 'yes' to move the robot: ");
  std::fflush(stdout);
  std::string answer;
  if (!std::getline(std::cin, answer) || answer != "yes") {
    std::printf("not confirmed; nothing moved\n");
    return false;
  }
  return true;
}

// SIGINT and SIGTERM set g_abort: the session stops the arm and keeps the data.
void installStopHandlers() {
  struct sigaction sa {};
  sa.sa_handler = &onSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

// The progress line on stderr every 250 ms until `done` (once the first tick is recorded): phase,
// a bar of t_traj / duration, elapsed and remaining time.
void showProgress(const Progress& progress, const std::atomic<bool>& done, double duration) {
  static const char* kPhase[] = {"approach", "settle", "excite", "finish", "stopping"};
  const auto t_start = std::chrono::steady_clock::now();
  while (!done.load()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(250));
    if (progress.ticks.load() == 0) continue;
    const int ph = progress.phase.load();
    const double tt = std::max(0.0, std::min(duration, progress.t_traj.load()));
    const int width = 30;
    const int filled = duration > 0 ? static_cast<int>(width * tt / duration) : 0;
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
    std::fprintf(stderr, "\r[%-*s] %-8s elapsed %6.1f s  remaining %6.1f s ", width,
                 std::string(static_cast<std::size_t>(filled), '#').c_str(), kPhase[ph < 5 ? ph : 4], elapsed,
                 ph >= 2 ? duration - tt : duration);
  }
  std::fprintf(stderr, "\n");
}

// Runs the session (motion::runOnRobot, stopped by g_abort) with the progress line on a thread
// beside it, joined however the run ends.
ftid::motion::SessionResult runWithProgress(const ftid::motion::RobotSessionConfig& cfg,
                                            const ftid::motion::JointTrajectorySource& source) {
  Progress progress;
  std::atomic<bool> done{false};
  const double duration = source.duration();
  std::thread bar([&] { showProgress(progress, done, duration); });
  ftid::motion::SessionResult r;
  try {
    r = ftid::motion::runOnRobot(cfg, source, &g_abort, &Progress::hook, &progress);
  } catch (...) {
    done = true;
    bar.join();
    throw;
  }
  done = true;
  bar.join();
  return r;
}

// Prints the outcome, the loop statistics and the real-time report, and writes the recording to
// `out` (if any tick was recorded). Returns the exit status: 0 completed, 1 aborted or failed.
int reportResult(const ftid::motion::SessionResult& r, const std::string& out) {
  std::printf("controller %s, %.0f Hz: %s: %s\n", r.controller_version.c_str(), 1.0 / r.period,
              ftid::motion::runStatusName(r.run.status), r.run.message.c_str());
  std::printf("%s", r.run.stats.summary("loop").c_str());
  std::printf("real-time: %s\n", r.run.realtime.describe().c_str());
  if (!r.recording.empty()) {
    ftid::logio::writeLog(out, ftid::motion::recordingToLog(r.recording));
    std::printf("wrote %zu ticks to %s\n", r.recording.size(), out.c_str());
  } else {
    std::printf("nothing recorded; %s not written\n", out.c_str());
  }
  return r.run.ok() ? 0 : 1;
}

int runRunTrajectory(const std::vector<std::string>& argv) {
  RunTrajectoryArgs a = parseArgs(argv);
  ftid::checkOutputPath(a.out);  // before the robot moves
  const bool yaml = isYamlTrajectory(a.path);
  ftid::trajectory::FourierTrajectory fourier;  // evaluated by `source` for a traj.yaml
  const auto source = loadTrajectory(a.path, yaml, &fourier);
  const ftid::trajectory::TrajectoryConstraints limits = motionConstraints(a, yaml);
  if (a.robot_urdf.empty()) throw ftid::cli::UsageError("no robot model recorded in the trajectory: give --robot URDF");
  const auto kin = ftid::model::RobotKinematics::fromUrdfFile(a.robot_urdf);
  a.cfg.motion.preflight = preflightCheck(kin, limits);
  if (!confirmMotion(a, *source)) return 1;
  installStopHandlers();
  const ftid::motion::SessionResult r = runWithProgress(a.cfg, *source);
  return reportResult(r, a.out);
}

}  // namespace

static ftid::cli::Registrar reg{{"run-trajectory", "stream a trajectory to a UR robot and record its state", kUsage,
                                 &runRunTrajectory}};
