// Real-time loop benchmark (docs/performance.md, "Real-time loop").
//  1. Full stack: MotionRunner streams a Fourier trajectory to the in-process UR simulator over
//     loopback RTDE at 125 Hz (UR10) and 500 Hz (UR10e), loop thread SCHED_OTHER and SCHED_FIFO.
//     compute = state package decoded -> checks, trajectory, last-hop check, servo package sent;
//     wake-up = arrival of the package minus (previous arrival + period) (includes the
//     simulator's own tick jitter: it runs in the same process, SCHED_FIFO 70/69 in the FIFO runs).
//  2. Timer only: absolute-deadline clock_nanosleep loop (cyclictest-like) at both rates, both
//     scheduling classes: wake-up latency of this host.
// usage: bench_rt_loop [seconds_per_run=5]
#include <cstdio>
#include <cstdlib>
#include <string>

#include "ftid/motion/robot_session.hpp"
#include "ftid/rt/cyclic_executor.hpp"
#include "ftid/rt/rt_thread.hpp"
#include "ftid/simrobot/sim_robot.hpp"
#include "ftid/trajectory/fourier_trajectory.hpp"

namespace {

ftid::trajectory::FourierTrajectory makeTrajectory(double duration) {
  std::array<std::array<double, 16>, 6> a{}, b{};
  for (int j = 0; j < 6; ++j) {
    const double s = (j % 2 ? -1.0 : 1.0) * 0.15;
    a[j][0] = s;
    a[j][1] = -2 * s;
    a[j][2] = s;
    b[j][0] = -0.05;
    b[j][1] = 0.0;
    b[j][2] = 0.05 / 3.0;
  }
  ftid::JointVector q0;
  q0 << 0.0, -1.5708, 1.5708, -1.5708, -1.5708, 0.0;
  return ftid::trajectory::FourierTrajectory(q0, 1.0 / duration, 3, duration, a, b);
}

void fullStack(ftid::simrobot::RobotModel model, bool fifo, double seconds) {
  ftid::simrobot::SimRobotConfig sc;
  sc.model = model;
  sc.rtde_port = sc.dashboard_port = sc.script_port = 0;
  sc.thread_priority = fifo ? 70 : 0;  // the controller is real-time when the loop is
  ftid::simrobot::SimRobot sim(sc);
  sim.start();
  ftid::motion::RobotSessionConfig cfg;
  cfg.arm.rtde_port = sim.rtdePort();
  cfg.arm.script_port = sim.scriptPort();
  cfg.motion.realtime.enable = fifo;
  cfg.motion.settle_time = 0.05;
  const auto traj = makeTrajectory(seconds);
  ftid::motion::EvaluatedTrajectory<ftid::trajectory::FourierTrajectory> src(traj);
  const auto r = ftid::motion::runOnRobot(cfg, src);
  const auto& s = r.run.stats;
  std::printf("full stack %-6s %s: %s; %s\n", model == ftid::simrobot::RobotModel::kUR10 ? "125 Hz" : "500 Hz",
              fifo ? "SCHED_FIFO " : "SCHED_OTHER", r.run.message.c_str(), r.run.realtime.describe().c_str());
  std::printf("%s", s.summary("  loop").c_str());
}

struct TimerCycle {
  std::uint64_t n = 0, limit = 0;
  ftid::rt::CycleAction onTimer(std::int64_t) noexcept {
    return ++n >= limit ? ftid::rt::CycleAction::kStop : ftid::rt::CycleAction::kContinue;
  }
};

void timerOnly(double rate, bool fifo, double seconds) {
  ftid::rt::RealtimeConfig rc;
  rc.enable = fifo;
  ftid::rt::ExecutorConfig ec;
  ec.period = std::chrono::nanoseconds(static_cast<std::int64_t>(1e9 / rate));
  TimerCycle c;
  c.limit = static_cast<std::uint64_t>(seconds * rate);
  ftid::rt::LoopStats stats;
  const auto report = ftid::rt::runInRealtimeThread(rc, [&] { ftid::rt::runTimerClocked(c, ec, &stats); });
  std::printf("timer only %4.0f Hz %s: %s\n", rate, fifo ? "SCHED_FIFO " : "SCHED_OTHER", report.describe().c_str());
  std::printf("%s", stats.summary("  loop").c_str());
}

}  // namespace

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::atof(argv[1]) : 5.0;
  try {
    for (bool fifo : {false, true}) {
      fullStack(ftid::simrobot::RobotModel::kUR10, fifo, seconds);
      fullStack(ftid::simrobot::RobotModel::kUR10e, fifo, seconds);
    }
    for (bool fifo : {false, true}) {
      timerOnly(125.0, fifo, seconds);
      timerOnly(500.0, fifo, seconds);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_rt_loop: %s\n", e.what());
    return 1;
  }
  return 0;
}
