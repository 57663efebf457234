// Design for accuracy limits (docs/design.md "Limits"): the limits' units, and the designer's
// printed prediction, with and without the IMU, checked against a seed study of the
// identification on the designed trajectory (the simulator's own physics and noise).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <cstdio>
#include <random>

#include "ftid/common/error.hpp"
#include "ftid/design/designer.hpp"
#include "ftid/design/excitation_metric.hpp"
#include "ftid/identify/offline.hpp"
#include "ftid/model/kinematics.hpp"
#include "ftid/samples/context.hpp"
#include "ftid/sim/cell_sim.hpp"
#include "test_paths.hpp"

namespace ftid::design {
namespace {

const model::RobotKinematics& ur10() {
  static const model::RobotKinematics k =
      model::RobotKinematics::fromUrdfFile(ftid::test::sourcePath("/config/ur10.urdf"));
  return k;
}

TEST(DesignLimits, UnitsAndTheThreeStandardErrorRule) {
  const auto nominal = defaultNominalParameters();
  const auto t = parseLimits("mass=0.5%,com=1mm,tilt=0.1deg", nominal);
  EXPECT_NEAR(t.at("mass"), 0.005 * sim::PaperPayload::kMass_kg / 3.0, 1e-12);
  for (const char* c : {"com_x", "com_y", "com_z"}) EXPECT_NEAR(t.at(c), 1e-3 / 3.0, 1e-15) << c;
  EXPECT_NEAR(t.at("tilt_u"), 0.1 * 3.141592653589793 / 180.0 / 3.0, 1e-15);
  EXPECT_NEAR(parseLimits("com_z=0.2cm", nominal).at("com_z"), 2e-3 / 3.0, 1e-15);
  EXPECT_NEAR(parseLimits("mass=5g", nominal).at("mass"), 5e-3 / 3.0, 1e-15);
  for (const char* bad : {"mass=abc", "mass=-1g", "com=1furlong", "tilt"}) {
    try {
      (void)parseLimits(bad, nominal);
      ADD_FAILURE() << bad << ": expected ConfigError";
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("--limits"), std::string::npos) << e.what();
    }
  }
}

/// The printed prediction against a seed study: a designed 2 s trajectory of paper+rigid_body,
/// 30 seeds of the simulator's wrench (0.05 N, 0.01 Nm) and MEMS IMU noise (0.01 m/s^2,
/// 0.002 rad/s, with biases), identified with the IMU and without.
TEST(DesignLimits, PredictionMatchesASeedStudyWithAndWithoutTheImu) {
  DesignOptions o;
  o.model = "paper+rigid_body";
  o.duration_s = 2.0;
  o.harmonics = 5;
  o.time_budget_s = 60.0;
  o.global_max_evals = 400;  // evaluation budgets: the same design on any machine
  o.local_max_evals = 400;
  o.baseline_seeds = 0;
  o.static_baseline = false;
  o.imu_acc_std = 0.01;
  o.imu_gyro_std = 0.002;
  o.constraints = loadDesignConstraints("", ur10(), o.q0);
  const DesignResult d = designExcitation(o, ur10());
  ASSERT_FALSE(d.predicted_std_imu.empty());

  sim::CellSimConfig cfg = sim::paperCellConfig(ur10());
  cfg.trajectory = d.file.toTrajectory();
  cfg.duration_s = cfg.trajectory.duration();
  cfg.imu.enabled = true;
  const int seeds = 30;
  const char* names[] = {"mass", "com_x", "com_y", "com_z", "tilt_u", "tilt_v"};
  auto truth = [&](const std::string& n) {
    if (n == "mass") return cfg.payload.mass_kg;
    if (n == "tilt_u") return cfg.tilt_u_rad;
    if (n == "tilt_v") return cfg.tilt_v_rad;
    return cfg.payload.p_SC_S(n.back() - 'x');
  };
  for (const bool with_imu : {false, true}) {
    SCOPED_TRACE(with_imu ? "with the IMU" : "wrench alone");
    const auto& predicted = with_imu ? d.predicted_std_imu : d.predicted_std;
    std::map<std::string, std::vector<double>> err;
    for (int s = 0; s < seeds; ++s) {
      sim::CellSimConfig c = cfg;
      c.seed = 4200 + static_cast<std::uint64_t>(s);
      c.noise.wrench_std << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
      c.noise.acc_std = 0.01;
      c.noise.gyro_std = 0.002;
      const auto ctx = samples::buildContexts(sim::CellSim(c).run(), ur10());
      identify::IdentifyRequest req;
      req.model = o.model;
      req.imu = with_imu ? identify::IdentifyRequest::ImuUse::kOn : identify::IdentifyRequest::ImuUse::kOff;
      const params::ParameterSet set = identify::identifyContexts(ctx.samples, req);
      for (const char* n : names) {
        const std::string name(n);
        const double v = name == "tilt_u" ? set.tilt_u_rad : name == "tilt_v" ? set.tilt_v_rad : set.find(name)->value;
        err[name].push_back(v - truth(name));
      }
    }
    for (const char* n : names) {
      const auto& e = err[n];
      double rms = 0.0;
      int within = 0;
      for (double x : e) {
        rms += x * x / seeds;
        within += std::abs(x) <= kLimitStandardErrors * predicted.at(n) ? 1 : 0;
      }
      rms = std::sqrt(rms);
      const double ratio = rms / predicted.at(n);
      std::printf("  %-3s %-6s predicted %.3g, RMS error over %d seeds %.3g (ratio %.2f), within 3 std: %d\n",
                  with_imu ? "imu" : "w", n, predicted.at(n), seeds, rms, ratio, within);
      // 30 seeds: the RMS scatters by ~13 %; the prediction assumes white noise and nominal weights.
      EXPECT_GT(ratio, 0.6) << n;
      EXPECT_LT(ratio, 1.5) << n;
      EXPECT_GE(within, seeds - 2) << n;
    }
  }
}

/// The wrong minimum: a designed 1 s trajectory with a 2.2 kg tool, where the wrench
/// alone's tilt search (started from the paper's force stage) can end at mass -0.93 kg and
/// tilt_v 156 deg. The IMU's tilt as the start (and its fusion) finds the payload in every seed.
TEST(DesignLimits, ImuTiltStartAvoidsTheWrongMinimumOnA1sDesign) {
  DesignOptions o;
  o.model = "paper+rigid_body";
  o.duration_s = 1.0;
  o.harmonics = 5;
  o.time_budget_s = 120.0;
  o.global_max_evals = 2000;
  o.local_max_evals = 2000;
  o.baseline_seeds = 0;
  o.static_baseline = false;
  o.constraints = loadDesignConstraints(ftid::test::sourcePath("/config/design.yaml"), ur10(), o.q0);
  const DesignResult d = designExcitation(o, ur10());
  sim::CellSimConfig cfg = sim::paperCellConfig(ur10());
  cfg.trajectory = d.file.toTrajectory();
  cfg.duration_s = cfg.trajectory.duration();
  cfg.payload.mass_kg = 2.2;
  cfg.payload.p_SC_S = Vec3(0.01, 0.02, 0.08);
  cfg.payload.I_C_S = Vec3(0.01, 0.01, 0.005).asDiagonal();
  cfg.imu.enabled = true;
  cfg.noise.wrench_std << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
  cfg.noise.acc_std = 0.01;
  cfg.noise.gyro_std = 0.002;
  int wrong_wrench_alone = 0;
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    SCOPED_TRACE(seed);
    sim::CellSimConfig c = cfg;
    c.seed = seed;
    const auto ctx = samples::buildContexts(sim::CellSim(c).run(), ur10());
    identify::IdentifyRequest req;
    req.model = o.model;
    req.imu = identify::IdentifyRequest::ImuUse::kOff;
    const params::ParameterSet w = identify::identifyContexts(ctx.samples, req);
    wrong_wrench_alone += std::abs(w.find("mass")->value - 2.2) > 0.5 ? 1 : 0;
    req.imu = identify::IdentifyRequest::ImuUse::kOn;
    identify::ImuReport report;
    const params::ParameterSet f = identify::identifyContexts(ctx.samples, req, &report);
    EXPECT_TRUE(report.fused);
    EXPECT_NEAR(f.find("mass")->value, 2.2, 0.05);
    EXPECT_NEAR(f.tilt_u_rad, c.tilt_u_rad, 0.5 * 3.141592653589793 / 180.0);
    EXPECT_NEAR(f.tilt_v_rad, c.tilt_v_rad, 0.5 * 3.141592653589793 / 180.0);
  }
  std::printf("  wrench alone ended in a wrong minimum (|mass error| > 0.5 kg) in %d of 8 seeds\n", wrong_wrench_alone);
}

/// Designing for the limits (Objective::kLimits) against the condition number, same 1.5 s, wrist
/// joints, budgets and seed, judged by the simulator's full rigid-body physics over 100 noise seeds
/// identified with the IMU: the worst over the limited numbers of RMS error / (limit / 3) is smaller
/// for the limits design, more of its runs meet every limit, and its RMS errors are those its own
/// prediction gives.
TEST(DesignLimits, DesigningForTheLimitsBeatsTheConditionNumberInASeedStudy) {
  const auto targets = parseLimits("mass=0.5%,com=1mm,tilt=0.1deg", defaultNominalParameters());
  auto design = [&](Objective objective) {
    DesignOptions o;
    o.model = "paper+rigid_body";
    o.duration_s = 1.5;
    o.time_budget_s = 120.0;
    o.global_max_evals = 3000;  // evaluation budgets: the same designs on any machine
    o.local_max_evals = 3000;
    o.baseline_seeds = 0;
    o.static_baseline = false;
    o.imu_acc_std = 0.01;
    o.imu_gyro_std = 0.002;
    o.objective = objective;
    o.limit_targets = targets;
    o.targets_with_imu = true;
    o.constraints = loadDesignConstraints("", ur10(), o.q0);
    return designExcitation(o, ur10());
  };
  struct Study {
    double worst_ratio = 0.0;  // max over the limited numbers of RMS error / target
    int met = 0;               // runs meeting every limit
  };
  auto study = [&](const DesignResult& d, const char* label) {
    sim::CellSimConfig cfg = sim::paperCellConfig(ur10());
    cfg.trajectory = d.file.toTrajectory();
    cfg.duration_s = cfg.trajectory.duration();
    cfg.full_rigid_body = true;
    cfg.imu.enabled = true;
    cfg.noise.wrench_std << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
    cfg.noise.acc_std = 0.01;
    cfg.noise.gyro_std = 0.002;
    const int seeds = 100;
    std::map<std::string, double> sum_sq;
    Study out;
    for (int s = 0; s < seeds; ++s) {
      sim::CellSimConfig c = cfg;
      c.seed = 7100 + static_cast<std::uint64_t>(s);
      const auto ctx = samples::buildContexts(sim::CellSim(c).run(), ur10());
      identify::IdentifyRequest req;
      req.model = "paper+rigid_body";
      req.imu = identify::IdentifyRequest::ImuUse::kOn;
      const params::ParameterSet set = identify::identifyContexts(ctx.samples, req);
      std::map<std::string, double> err{{"mass", set.find("mass")->value - c.payload.mass_kg},
                                        {"tilt_u", set.tilt_u_rad - c.tilt_u_rad},
                                        {"tilt_v", set.tilt_v_rad - c.tilt_v_rad}};
      for (int a = 0; a < 3; ++a) {
        const std::string n = std::string("com_") + static_cast<char>('x' + a);
        err[n] = set.find(n)->value - c.payload.p_SC_S(a);
      }
      bool meets = true;
      for (const auto& [n, e] : err) {
        sum_sq[n] += e * e;
        meets = meets && std::abs(e) <= kLimitStandardErrors * targets.at(n);
      }
      out.met += meets ? 1 : 0;
    }
    for (const auto& [n, target] : targets) {
      const double rms = std::sqrt(sum_sq[n] / seeds);
      const double ratio = rms / d.predicted_std_imu.at(n);
      std::printf("  %-6s %-8s predicted %.3g, RMS error %.3g (ratio %.2f), RMS / target %.2f\n", label, n.c_str(),
                  d.predicted_std_imu.at(n), rms, ratio, rms / target);
      out.worst_ratio = std::max(out.worst_ratio, rms / target);
      // 100 seeds scatter the RMS by ~7 %; the prediction assumes white noise and nominal weights.
      EXPECT_GT(ratio, 0.7) << label << " " << n;
      EXPECT_LT(ratio, 1.3) << label << " " << n;
    }
    std::printf("  %-6s worst RMS / target %.2f, every limit met in %d of %d runs\n", label, out.worst_ratio, out.met,
                seeds);
    return out;
  };
  const Study cond = study(design(Objective::kCondition), "cond");
  const Study limits = study(design(Objective::kLimits), "limits");
  EXPECT_LT(limits.worst_ratio, cond.worst_ratio);
  EXPECT_GT(limits.met, cond.met);
}

}  // namespace
}  // namespace ftid::design
