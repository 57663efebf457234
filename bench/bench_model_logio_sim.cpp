// Benchmarks of the foundation modules: kinematics (computeSensorMotion), log reading/writing,
// Fourier evaluation and the cell simulator. Figures go to docs/performance.md
// ("Kinematics, log IO, trajectory, simulator").
//   usage: bench_model_logio_sim [SOURCE_DIR]   (default: current directory, needs config/ur10.urdf)
#include <chrono>
#include <cstdio>
#include <string>

#include "ftid/logio/log.hpp"
#include "ftid/model/kinematics.hpp"
#include "ftid/sim/cell_sim.hpp"

namespace {

template <typename F>
double bestOfMs(int repeats, F&& f) {
  double best = 1e300;
  for (int r = 0; r < repeats; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    if (ms < best) best = ms;
  }
  return best;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace ftid;
  const std::string root = argc > 1 ? argv[1] : ".";
  const model::RobotKinematics kin = model::RobotKinematics::fromUrdfFile(root + "/config/ur10.urdf");

  // Kinematics.
  {
    JointVector q, qd, qdd;
    q << 0.1, -1.2, 1.3, -1.7, -1.57, 0.4;
    qd.setConstant(0.3);
    qdd.setConstant(-0.5);
    const int n = 200000;
    double sink = 0.0;
    const double ms = bestOfMs(3, [&] {
      for (int i = 0; i < n; ++i) {
        q[5] += 1e-6;
        sink += kin.computeSensorMotion(q, qd, qdd).a_S.x();
      }
    });
    std::printf("computeSensorMotion: %.3f us/call (%d calls)  [sink %g]\n", ms * 1e3 / n, n, sink);
  }
  // Fourier trajectory.
  {
    const trajectory::FourierTrajectory traj = sim::paperExcitationTrajectory();
    const int n = 200000;
    double sink = 0.0;
    const double ms = bestOfMs(3, [&] {
      for (int i = 0; i < n; ++i) sink += traj.evaluate(i * 5e-5).qdd[4];
    });
    std::printf("FourierTrajectory::evaluate (5 harmonics): %.3f us/call  [sink %g]\n", ms * 1e3 / n, sink);
  }
  // Simulator.
  sim::CellSimConfig cfg = sim::paperCellConfig(kin);
  cfg.noise.wrench_std << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
  logio::LogData log;
  {
    const double ms = bestOfMs(3, [&] { log = sim::CellSim(cfg).run(); });
    std::printf("CellSim::run 10 s at 125 Hz (%zu samples): %.2f ms\n", log.samples.size(), ms);
  }
  {
    cfg.rate_hz = 1000.0;
    cfg.sensor_delay.enabled = true;
    cfg.cable.enabled = true;
    const double ms = bestOfMs(3, [&] { log = sim::CellSim(cfg).run(); });
    std::printf("CellSim::run 10 s at 1 kHz, delay+cable (%zu samples): %.2f ms\n", log.samples.size(), ms);
  }
  // Log IO on the 10,001-sample log (all 35 columns).
  const std::string path = "/tmp/ftid_bench_log.csv";
  {
    const double ms = bestOfMs(3, [&] { logio::writeLog(path, log); });
    std::printf("writeLog %zu rows x 35 columns (atomic, fsync): %.2f ms\n", log.samples.size(), ms);
  }
  {
    logio::LogData back;
    const double ms = bestOfMs(5, [&] { back = logio::readLog(path); });
    std::printf("readLog %zu rows x 35 columns: %.2f ms\n", back.samples.size(), ms);
  }
  std::remove(path.c_str());
  return 0;
}
