// UR simulator state-stream benchmark (docs/performance.md, "UR controller simulator").
// For each model (UR10 125 Hz, UR10e 500 Hz): an RTDE client in this process receives every state
// package at the controller rate and records |inter-arrival time - period| (the jitter a client
// of the simulator sees: the tick thread's wake-up plus the I/O path) and lost packages
// (timestamp gaps); the simulator's own tick statistics (SimRobot::tickStats(): wake-up against
// its rt::runTimerClocked deadlines, tick compute time) are printed beside it.
// As root the client runs SCHED_FIFO 80 with memory locked and the simulator SCHED_FIFO 70/69.
// usage: bench_sim_robot [seconds_per_model=10]
#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "ftid/drivers/ur/rtde_client.hpp"
#include "ftid/simrobot/sim_robot.hpp"

namespace {

void run(ftid::simrobot::RobotModel model, double seconds, bool fifo) {
  ftid::simrobot::SimRobotConfig sc;
  sc.model = model;
  sc.rtde_port = sc.dashboard_port = sc.script_port = 0;
  sc.thread_priority = fifo ? 70 : 0;
  ftid::simrobot::SimRobot sim(sc);
  sim.start();
  ftid::drivers::ur::RtdeClient c;
  c.connect("127.0.0.1", sim.rtdePort());
  c.negotiateProtocolVersion();
  const double period = sim.period();
  c.setupOutputs(1.0 / period, {"timestamp", "actual_q", "actual_qd", "target_qdd"});
  c.start();
  ftid::drivers::ur::RtdeStatePackage s;
  std::vector<double> dev_us;
  std::int64_t prev_ns = 0;
  double prev_ts = 0.0;
  std::uint64_t lost = 0;
  const int warmup = 50;
  const int n = static_cast<int>(seconds / period);
  dev_us.reserve(static_cast<std::size_t>(n));
  for (int i = 0; i < n + warmup; ++i) {
    if (c.tryReceiveState(std::chrono::milliseconds(1000), &s) != ftid::Status::kOk) {
      std::fprintf(stderr, "bench_sim_robot: no state for 1 s\n");
      std::exit(1);
    }
    if (i >= warmup) {
      const double steps = std::round((s.timestamp - prev_ts) / period);
      if (steps > 1) lost += static_cast<std::uint64_t>(steps - 1);
      dev_us.push_back(std::abs(static_cast<double>(s.host_receive_ns - prev_ns) * 1e-9 - steps * period) * 1e6);
    }
    prev_ns = s.host_receive_ns;
    prev_ts = s.timestamp;
  }
  sim.stop();
  std::sort(dev_us.begin(), dev_us.end());
  const auto q = [&](double p) { return dev_us[static_cast<std::size_t>(p * static_cast<double>(dev_us.size() - 1))]; };
  std::printf("%s %3.0f Hz %s: %zu packages, |inter-arrival - period| p50 %.0f / p99 %.0f / p99.9 %.0f / max %.0f us, "
              "%llu lost\n",
              model == ftid::simrobot::RobotModel::kUR10 ? "UR10 " : "UR10e", 1.0 / period,
              fifo ? "SCHED_FIFO " : "SCHED_OTHER", dev_us.size(), q(0.5), q(0.99), q(0.999), dev_us.back(),
              static_cast<unsigned long long>(lost));
  std::printf("%s", sim.tickStats().summary("  simulator tick").c_str());
}

}  // namespace

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::atof(argv[1]) : 10.0;
  const bool fifo = geteuid() == 0;
  if (fifo) {
    mlockall(MCL_CURRENT | MCL_FUTURE);
    sched_param sp{};
    sp.sched_priority = 80;
    pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp);
  }
  try {
    run(ftid::simrobot::RobotModel::kUR10, seconds, fifo);
    run(ftid::simrobot::RobotModel::kUR10e, seconds, fifo);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_sim_robot: %s\n", e.what());
    return 1;
  }
  return 0;
}
