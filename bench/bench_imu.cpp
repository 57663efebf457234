// The IMU as a measurement (docs/performance.md, "IMU-aided identification"): a trajectory ftid
// designs for 1.5 s (model paper+rigid_body, for the limits mass=0.5%,com=1mm,tilt=0.1deg with the
// IMU's information, fixed evaluation budgets so the same design on any machine), the simulator
// with full rigid-body physics, the paper's payload and tilt, wrench noise 0.05 N / 0.01 Nm and a
// MEMS IMU (accelerometer noise 0.01 m/s^2, bias (0.03, -0.02, 0.04) m/s^2; gyro noise 0.002 rad/s,
// bias (0.002, -0.003, 0.001) rad/s), 50 seeds at 125 Hz; identified with the IMU (`--imu on`) and
// with the wrench alone (`--imu off`). Counts the runs meeting mass < 0.5 %, |CoM error| < 1 mm and
// |tilt error| < 0.1 deg (Euclidean norms), the worst errors, and the runs whose every error
// (mass, com_x/y/z, tilt_u/v) is within 3.5 reported standard errors.
// Usage: bench_imu [DURATION_S=1.5] [SEEDS=50] [JOINTS=23456] [OBJECTIVE=limits|cond] [EVALS=20000]
//   JOINTS: the excited joints (digits, 1-based); EVALS: the global and the local evaluation budget.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "ftid/common/default_files.hpp"
#include "ftid/design/designer.hpp"
#include "ftid/identify/offline.hpp"
#include "ftid/model/kinematics.hpp"
#include "ftid/samples/context.hpp"
#include "ftid/sim/cell_sim.hpp"

namespace {

/// The benchmark's design: paper+rigid_body, 5 harmonics, the excited joints (digits), the limits
/// objective with the IMU's information or the condition number, EVALS + EVALS evaluations.
ftid::design::DesignResult designFor(const ftid::model::RobotKinematics& kin, double duration, const std::string& joints,
                                     const std::string& objective, long evals) {
  using namespace ftid;
  design::DesignOptions o;
  o.model = "paper+rigid_body";
  o.duration_s = duration;
  o.harmonics = 5;
  o.time_budget_s = 600.0;
  o.global_max_evals = evals;
  o.local_max_evals = evals;
  o.joints.clear();
  for (const char ch : joints) o.joints.push_back(ch - '0');
  o.baseline_seeds = 0;
  o.static_baseline = false;
  o.imu_acc_std = 0.01;
  o.imu_gyro_std = 0.002;
  if (objective == "limits") {
    o.objective = design::Objective::kLimits;
    o.limit_targets = design::parseLimits("mass=0.5%,com=1mm,tilt=0.1deg", {});
    o.targets_with_imu = true;
  }
  o.constraints = design::loadDesignConstraints(findDefaultFile("design.yaml"), kin, o.q0);
  const design::DesignResult d = design::designExcitation(o, kin);
  const double deg = 180.0 / 3.141592653589793;
  std::printf("designed %.2f s trajectory (paper+rigid_body, joints %s, objective %s, cond %.3g, %ld + %ld "
              "evaluations)\n",
              d.file.duration_s, joints.c_str(), objective.c_str(), d.condition_number, d.global_evals, d.local_evals);
  std::printf("predicted std: mass %.3g kg, com %.3g/%.3g/%.3g mm, tilt %.3g/%.3g deg; with IMU: mass %.3g, "
              "com %.3g/%.3g/%.3g mm, tilt %.3g/%.3g deg\n",
              d.predicted_std.at("mass"), 1e3 * d.predicted_std.at("com_x"), 1e3 * d.predicted_std.at("com_y"),
              1e3 * d.predicted_std.at("com_z"), d.predicted_std.at("tilt_u") * deg, d.predicted_std.at("tilt_v") * deg,
              d.predicted_std_imu.at("mass"), 1e3 * d.predicted_std_imu.at("com_x"),
              1e3 * d.predicted_std_imu.at("com_y"), 1e3 * d.predicted_std_imu.at("com_z"),
              d.predicted_std_imu.at("tilt_u") * deg, d.predicted_std_imu.at("tilt_v") * deg);
  return d;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace ftid;
  const double duration = argc > 1 ? std::atof(argv[1]) : 1.5;
  const int seeds = argc > 2 ? std::atoi(argv[2]) : 50;
  const std::string joints = argc > 3 ? argv[3] : "23456";
  const std::string objective = argc > 4 ? argv[4] : "limits";
  const long evals = argc > 5 ? std::atol(argv[5]) : 20000;
  const auto kin = model::RobotKinematics::fromUrdfFile(findDefaultFile("ur10.urdf"));
  const design::DesignResult d = designFor(kin, duration, joints, objective, evals);
  sim::CellSimConfig cfg = sim::paperCellConfig(kin);
  cfg.trajectory = d.file.toTrajectory();
  cfg.duration_s = cfg.trajectory.duration();
  cfg.full_rigid_body = true;
  cfg.imu.enabled = true;  // default biases: (0.03, -0.02, 0.04) m/s^2, (0.002, -0.003, 0.001) rad/s
  cfg.noise.wrench_std << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
  cfg.noise.acc_std = 0.01;
  cfg.noise.gyro_std = 0.002;
  const double kDeg = 180.0 / 3.141592653589793;
  for (const bool with_imu : {true, false}) {
    int meet = 0;
    int within = 0;
    int fused = 0;
    int failed = 0;
    double worst_mass = 0.0, worst_com = 0.0, worst_tilt = 0.0, worst_z = 0.0;
    double seconds = 0.0;
    double sum_z2[6] = {0, 0, 0, 0, 0, 0};  // (error / reported std)^2: mass, com_x/y/z, tilt_u/v
    for (int s = 0; s < seeds; ++s) {
      sim::CellSimConfig c = cfg;
      c.seed = 1000 + static_cast<std::uint64_t>(s);
      const auto ctx = samples::buildContexts(sim::CellSim(c).run(), kin);
      identify::IdentifyRequest req;
      req.model = "paper+rigid_body";
      req.imu = with_imu ? identify::IdentifyRequest::ImuUse::kOn : identify::IdentifyRequest::ImuUse::kOff;
      identify::ImuReport report;
      params::ParameterSet set;
      const auto t0 = std::chrono::steady_clock::now();
      try {
        set = identify::identifyContexts(ctx.samples, req, &report);
      } catch (const std::exception& e) {
        ++failed;
        std::printf("  seed %d: %s\n", s, e.what());
        continue;
      }
      seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      fused += report.fused ? 1 : 0;
      const double m = set.find("mass")->value;
      const double e_mass = std::abs(m - c.payload.mass_kg) / c.payload.mass_kg;
      Vec3 com(set.find("com_x")->value, set.find("com_y")->value, set.find("com_z")->value);
      const double e_com = (com - c.payload.p_SC_S).norm();
      const double du = set.tilt_u_rad - c.tilt_u_rad;
      const double dv = set.tilt_v_rad - c.tilt_v_rad;
      const double e_tilt = std::hypot(du, dv);
      worst_mass = std::max(worst_mass, e_mass);
      worst_com = std::max(worst_com, e_com);
      worst_tilt = std::max(worst_tilt, e_tilt);
      meet += (e_mass < 0.005 && e_com < 1e-3 && e_tilt < 0.1 / kDeg) ? 1 : 0;
      const char* axes[3] = {"com_x", "com_y", "com_z"};
      const double zs[6] = {(m - c.payload.mass_kg) / set.find("mass")->std,
                            (com(0) - c.payload.p_SC_S(0)) / set.find(axes[0])->std,
                            (com(1) - c.payload.p_SC_S(1)) / set.find(axes[1])->std,
                            (com(2) - c.payload.p_SC_S(2)) / set.find(axes[2])->std, du / set.tilt_u_std,
                            dv / set.tilt_v_std};
      double z = 0.0;
      for (int i = 0; i < 6; ++i) {
        z = std::max(z, std::abs(zs[i]));
        sum_z2[i] += zs[i] * zs[i];
      }
      worst_z = std::max(worst_z, z);
      if (z > 3.5) {
        std::printf("  seed %d: an error beyond 3.5 reported std (%.2f): mass %.5f (std %.5f), com error %.3f/%.3f/%.3f mm "
                    "(std %.3f/%.3f/%.3f), tilt error %.4f/%.4f deg (std %.4f/%.4f)\n",
                    s, z, m - c.payload.mass_kg, set.find("mass")->std, 1e3 * (com(0) - c.payload.p_SC_S(0)),
                    1e3 * (com(1) - c.payload.p_SC_S(1)), 1e3 * (com(2) - c.payload.p_SC_S(2)), 1e3 * set.find("com_x")->std,
                    1e3 * set.find("com_y")->std, 1e3 * set.find("com_z")->std, du * kDeg, dv * kDeg,
                    set.tilt_u_std * kDeg, set.tilt_v_std * kDeg);
      }
      within += z <= 3.5 ? 1 : 0;
    }
    std::printf("%-13s meets mass<0.5%%, CoM<1mm, tilt<0.1deg: %d of %d; worst mass %.3f %%, CoM %.3f mm, tilt "
                "%.4f deg; every error within 3.5 reported std: %d of %d (worst %.2f std); fused %d; failed %d; "
                "%.1f ms per identification\n",
                with_imu ? "with IMU:" : "wrench alone:", meet, seeds, 100.0 * worst_mass, 1e3 * worst_com,
                worst_tilt * kDeg, within, seeds, worst_z, fused, failed, 1e3 * seconds / std::max(1, seeds - failed));
    const int n = std::max(1, seeds - failed);
    std::printf("  RMS of error / reported std (1 when the std is right): mass %.2f, com %.2f/%.2f/%.2f, tilt %.2f/%.2f\n",
                std::sqrt(sum_z2[0] / n), std::sqrt(sum_z2[1] / n), std::sqrt(sum_z2[2] / n), std::sqrt(sum_z2[3] / n),
                std::sqrt(sum_z2[4] / n), std::sqrt(sum_z2[5] / n));
  }
  return 0;
}
