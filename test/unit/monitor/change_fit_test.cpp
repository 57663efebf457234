// Re-identification of a payload change from monitor samples (fitChange): the fit on a simulated
// grasp (full physics: independent of the regressor) and each refusal with its reason.
#include <gtest/gtest.h>

#include "ftid/monitor/change_fit.hpp"
#include "monitor_cell.hpp"

namespace ftid::monitor {
namespace {

const test::IdentifiedCell& cellA() {
  static const test::IdentifiedCell cell(11);
  return cell;
}

std::vector<MonitorSample> window(const std::vector<MonitorSample>& all, double t0, double t1) {
  std::vector<MonitorSample> out;
  for (const auto& s : all) {
    if (s.t >= t0 && s.t <= t1) out.push_back(s);
  }
  return out;
}

sim::CellSimConfig graspRun(std::uint64_t seed, const Vec3& p_SC_S) {
  sim::CellSimConfig cfg = test::operationRun(seed, seed + 7000, 10.0);
  cfg.payload_change.enabled = true;
  cfg.payload_change.t_s = 5.0;
  cfg.payload_change.added = sim::compactObject(0.6, p_SC_S);
  return cfg;
}

TEST(ChangeFit, RecoversTheGraspedObjectFromTheLastSeconds) {
  for (std::uint64_t seed = 4101; seed <= 4103; ++seed) {
    SCOPED_TRACE(seed);
    const Vec3 p_SC_S(0.02, -0.01, 0.11);
    const auto all = test::monitorSamples(cellA(), graspRun(seed, p_SC_S));
    const monitor::ChangeVector before = test::payloadOf(cellA());
    const ChangeFit fit = fitChange(window(all, 6.0, 10.0), before, MonitorSettings{});
    ASSERT_TRUE(fit.ok) << fit.reason;
    EXPECT_NEAR(fit.change.delta_mass_kg, 0.6, 0.012);  // 2 %
    EXPECT_LT((fit.change.delta_com_m - p_SC_S).norm(), 0.005);
    EXPECT_NEAR(fit.payload_after[0], sim::PaperPayload::kMass_kg + 0.6, 0.02);
    EXPECT_TRUE(fit.inertia_checked);
    // The compensation error is gone: the residual after the fit is the sensor noise.
    EXPECT_GT(fit.residual_rms_before[2], 1.0);
    EXPECT_LT(fit.residual_rms_after.head<3>().maxCoeff(), 0.08);
  }
}

TEST(ChangeFit, RefusesWithoutMotion) {
  sim::CellSimConfig cfg = test::monitorCell(4201);
  const JointVector q0 = sim::paperStartPose();
  cfg.motion = [q0](double) {
    trajectory::TrajectoryPoint p;
    p.q = q0;
    return p;
  };
  cfg.duration_s = 4.0;
  const auto all = test::monitorSamples(cellA(), cfg);
  const ChangeFit fit = fitChange(all, test::payloadOf(cellA()), MonitorSettings{});
  EXPECT_FALSE(fit.ok);
  EXPECT_NE(fit.reason.find("no motion"), std::string::npos) << fit.reason;
  EXPECT_NE(fitChange({}, test::payloadOf(cellA()), MonitorSettings{}).reason.find("no samples"), std::string::npos);
}

TEST(ChangeFit, RefusesAWindowWithAPush) {
  sim::CellSimConfig cfg = graspRun(4301, Vec3(0.0, 0.0, 0.1));
  sim::ContactSwitch push;
  push.t_start_s = 7.0;
  push.t_end_s = 7.6;
  push.force_B = Vec3(12.0, 0.0, 0.0);
  cfg.pushes.push_back(push);
  const auto all = test::monitorSamples(cellA(), cfg);
  const ChangeFit fit = fitChange(window(all, 6.0, 10.0), test::payloadOf(cellA()), MonitorSettings{});
  EXPECT_FALSE(fit.ok);
  EXPECT_NE(fit.reason.find("residual"), std::string::npos) << fit.reason;
}

TEST(ChangeFit, RefusesAnUnphysicalResult) {
  const auto all = test::monitorSamples(cellA(), graspRun(4401, Vec3(0.0, 0.0, 0.1)));
  monitor::ChangeVector before = test::payloadOf(cellA());
  before[0] = -1.0;  // the parameters in use claim an impossible mass: after + 0.6 kg still < 0
  const ChangeFit fit = fitChange(window(all, 6.0, 10.0), before, MonitorSettings{});
  EXPECT_FALSE(fit.ok);
  EXPECT_NE(fit.reason.find("physics"), std::string::npos) << fit.reason;
}

}  // namespace
}  // namespace ftid::monitor
