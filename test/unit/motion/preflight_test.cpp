// Issue 14, "Motion": before any motion the exact targets the runner will stream are checked
// against the trajectory's constraints (floor, keep-out, designed ranges, velocity and
// acceleration), whatever --yes says. The shipped excitation trajectory with q0 edited so that
// the tool passes below the floor must be refused before a single target is sent; the unedited
// one must run.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "ftid/design/trajectory_check.hpp"
#include "ftid/drivers/ur/rtde_protocol.hpp"
#include "ftid/motion/motion_runner.hpp"
#include "../../support/fake_arm.hpp"
#include "ftid/trajectory/cell_limits.hpp"
#include "ftid/trajectory/trajectory_io.hpp"
#include "test_paths.hpp"

using ftid::JointVector;
using ftid::Status;
namespace ur = ftid::drivers::ur;
namespace motion = ftid::motion;

namespace {

/// The shared fake controller (test/support/fake_arm.hpp).
using FakeArm = ftid::test::FakeArm;

ftid::trajectory::TrajectoryFile shipped() {
  return ftid::trajectory::readTrajectoryFile(ftid::test::sourcePath("/config/excitation_ur10.yaml"));
}

ftid::model::RobotKinematics ur10() {
  return ftid::model::RobotKinematics::fromUrdfFile(ftid::test::sourcePath("/config/ur10.urdf"));
}

std::string joined(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& l : v) s += l + "\n";
  return s;
}

struct Checked {
  motion::RunResult result;
  std::size_t targets = 0;
  int preflight_calls = 0;
};

Checked runWithPreflight(const ftid::trajectory::TrajectoryFile& file, const JointVector& current) {
  const auto traj = file.toTrajectory();
  const auto kin = ur10();
  FakeArm arm(0.008, current);
  motion::MotionConfig cfg;
  cfg.realtime.enable = false;
  Checked out;
  cfg.preflight = [&](const motion::PlannedMotion& p) {
    ++out.preflight_calls;
    std::string s;
    for (const auto& l : ftid::design::checkMotionSamples(p.period, p.approach, p.t_traj, p.q_traj, kin,
                                                          file.constraints)) {
      s += (s.empty() ? "" : "; ") + l;
    }
    return s;
  };
  motion::EvaluatedTrajectory<ftid::trajectory::FourierTrajectory> src(traj);
  motion::MotionRunner runner(arm, cfg, motion::MotionRunner::capacityFor(traj.duration(), 0.008));
  out.result = runner.run(src);
  out.targets = arm.targets;
  return out;
}

}  // namespace

TEST(MotionPreflight, ShippedTrajectoryRuns) {
  const auto file = shipped();
  const Checked c = runWithPreflight(file, file.q0);
  EXPECT_EQ(c.preflight_calls, 1);
  EXPECT_EQ(c.result.status, motion::RunStatus::kCompleted) << c.result.message;
  // Every period of the excitation was streamed (plus the approach).
  EXPECT_GE(c.targets, static_cast<std::size_t>(file.toTrajectory().duration() / 0.008));
}

TEST(MotionPreflight, StartPoseBelowTheFloorIsRefusedBeforeAnyTarget) {
  auto file = shipped();
  file.q0[1] = -0.6;  // shoulder edited: the excitation swings the tool ~0.26 m below the floor
  // The independent dense check (`ftid check-trajectory`) flags exactly that...
  const auto dense = ftid::design::checkTrajectory(file.toTrajectory(), ur10(), file.constraints);
  ASSERT_FALSE(dense.ok());
  // ...and so does the check of the streamed samples, naming the sample and the constraint.
  const Checked c = runWithPreflight(file, shipped().q0);
  EXPECT_EQ(c.result.status, motion::RunStatus::kRefused) << c.result.message;
  EXPECT_EQ(c.targets, 0u) << "a target was sent before the refusal";
  EXPECT_NE(c.result.message.find("tool[0] above floor"), std::string::npos) << c.result.message;
  EXPECT_NE(c.result.message.find("trajectory sample"), std::string::npos) << c.result.message;
  EXPECT_NE(c.result.message.find("approach sample"), std::string::npos) << c.result.message;
  EXPECT_NE(c.result.message.find("below the floor"), std::string::npos) << c.result.message;
}

TEST(MotionPreflight, NamesTheFirstOffendingSampleOfEachConstraint) {
  const auto file = shipped();
  const auto traj = file.toTrajectory();
  std::vector<double> t;
  std::vector<JointVector> q;
  for (int k = 0; k <= 10; ++k) {
    t.push_back(0.008 * k);
    q.push_back(traj.evaluate(t.back()).q);
  }
  q[7][2] = file.constraints.position_upper[2] + 0.1;  // designed range (and a velocity jump)
  const auto v = ftid::design::checkMotionSamples(0.008, {}, t, q, ur10(), file.constraints);
  const std::string s = joined(v);
  EXPECT_NE(s.find("trajectory sample 7 (t = 0.056 s): joint 3 designed range"), std::string::npos) << s;
  EXPECT_NE(s.find("joint 3 velocity"), std::string::npos) << s;
  EXPECT_NE(s.find("joint 3 acceleration"), std::string::npos) << s;
  // A jump of joint 3 to its designed limit + 0.1 rad also dips the tool: one line per constraint.
  EXPECT_NE(s.find("trajectory sample 7 (t = 0.056 s): tool[0] above floor"), std::string::npos) << s;
  EXPECT_EQ(v.size(), 5u) << s;
  // Finite differences of the unedited samples stay within the designed limits.
  q[7] = traj.evaluate(t[7]).q;
  EXPECT_TRUE(ftid::design::checkMotionSamples(0.008, {}, t, q, ur10(), file.constraints).empty());
}

TEST(MotionPreflight, ApproachThroughTheFloorIsRefused) {
  // The robot starts with the tool under the floor plane (e.g. a wrong floor in the design):
  // the approach's first samples are refused, whatever the trajectory.
  const auto file = shipped();
  JointVector current = file.q0;
  current[1] = -0.3;
  current[3] = 0.0;
  const auto kin = ur10();
  ASSERT_LT((kin.computeFlangePose(current).translation().z()), 0.1);
  const Checked c = runWithPreflight(file, current);
  EXPECT_EQ(c.result.status, motion::RunStatus::kRefused) << c.result.message;
  EXPECT_EQ(c.targets, 0u);
  EXPECT_NE(c.result.message.find("approach sample 1 "), std::string::npos) << c.result.message;
}

// Issue 14, "Links": a start-up burst of lost packages on a loaded host is tolerated up to
// startup_lost_time_limit; the same burst later in the run still aborts it.
motion::RunResult runWithLostBurst(int from_call, int count, double startup_limit) {
  const auto file = shipped();
  const auto traj = file.toTrajectory();
  FakeArm arm(0.008, file.q0);
  arm.timeout_from = from_call;
  arm.timeout_count = count;
  motion::MotionConfig cfg;
  cfg.realtime.enable = false;
  cfg.startup_lost_time_limit = startup_limit;
  motion::EvaluatedTrajectory<ftid::trajectory::FourierTrajectory> src(traj);
  motion::MotionRunner runner(arm, cfg, motion::MotionRunner::capacityFor(traj.duration(), 0.008));
  return runner.run(src);
}

TEST(MotionStartup, BurstOfLostPackagesAtStartIsTolerated) {
  // Call 1 is the readiness check; the loop starts at call 2. Six lost packages = 48 ms.
  const auto tolerated = runWithLostBurst(2, 6, 0.064);
  EXPECT_EQ(tolerated.status, motion::RunStatus::kCompleted) << tolerated.message;
  const auto without = runWithLostBurst(2, 6, 0.0);  // the old behaviour: 3 ticks anywhere
  EXPECT_EQ(without.status, motion::RunStatus::kLostPackets) << without.message;
  const auto too_long = runWithLostBurst(2, 9, 0.064);  // 72 ms: beyond the bound
  EXPECT_EQ(too_long.status, motion::RunStatus::kLostPackets) << too_long.message;
  EXPECT_NE(too_long.message.find("limit 8"), std::string::npos) << too_long.message;
}

TEST(MotionStartup, TheSameBurstLaterAborts) {
  const auto later = runWithLostBurst(400, 6, 0.064);  // ~3 s into the run
  EXPECT_EQ(later.status, motion::RunStatus::kLostPackets) << later.message;
  EXPECT_NE(later.message.find("limit 3"), std::string::npos) << later.message;
}

// Issue 14, "Links": the servo program's RTDE watchdog is armed by the loop's first cycles (command
// 35 until the program reports done, then 0 until ready) and no servo target or hold (command 11)
// reaches the program before; the calling thread never arms it, so its stalls cannot fire it.
namespace {
struct ArmedRun {
  motion::RunResult result;
  std::size_t targets = 0, targets_before_watchdog = 0;
  int watchdog_requests = 0;
  std::size_t unarmed_ticks = 0;  ///< recorded ticks before the first target
};

ArmedRun runArming(bool program_ignores_watchdog, int timeout_from = -1, int timeout_count = 0, int gap_at_call = -1,
                   int gap_ticks = 0) {
  const auto file = shipped();
  const auto traj = file.toTrajectory();
  FakeArm arm(0.008, file.q0);
  arm.program.ignore_watchdog = program_ignores_watchdog;
  arm.timeout_from = timeout_from;
  arm.timeout_count = timeout_count;
  arm.gap_at_call = gap_at_call;
  arm.gap_ticks = gap_ticks;
  motion::MotionConfig cfg;
  cfg.realtime.enable = false;
  motion::EvaluatedTrajectory<ftid::trajectory::FourierTrajectory> src(traj);
  motion::MotionRunner runner(arm, cfg, motion::MotionRunner::capacityFor(traj.duration(), 0.008));
  ArmedRun out;
  out.result = runner.run(src);
  out.targets = arm.targets;
  out.targets_before_watchdog = arm.targets_before_watchdog;
  out.watchdog_requests = arm.program.watchdog_requests;
  for (const auto& t : runner.recording()) {
    if (t.q_command.allFinite() || t.phase != motion::Phase::kApproach) break;
    ++out.unarmed_ticks;
  }
  return out;
}
}  // namespace

TEST(MotionWatchdog, TheLoopArmsItBeforeTheFirstTarget) {
  const ArmedRun r = runArming(false);
  EXPECT_EQ(r.result.status, motion::RunStatus::kCompleted) << r.result.message;
  EXPECT_EQ(r.watchdog_requests, 1);
  EXPECT_EQ(r.targets_before_watchdog, 0u);
  // Request seen done one tick later, clear seen ready one tick after that: 2 ticks, no target.
  EXPECT_EQ(r.unarmed_ticks, 2u);
}

TEST(MotionWatchdog, LostTicksWhileArmingKeepArming) {
  // Calls 2 and 3 (the loop's first) time out: the loop re-sends the arming step, never a hold.
  const ArmedRun r = runArming(false, 2, 2);
  EXPECT_EQ(r.result.status, motion::RunStatus::kCompleted) << r.result.message;
  EXPECT_EQ(r.watchdog_requests, 1);
  EXPECT_EQ(r.targets_before_watchdog, 0u);
}

TEST(MotionWatchdog, AProgramThatNeverConfirmsEndsTheRunBeforeAnyMotion) {
  const ArmedRun r = runArming(true);
  EXPECT_EQ(r.result.status, motion::RunStatus::kWatchdogNotArmed) << r.result.message;
  EXPECT_EQ(r.targets, 0u);
  EXPECT_NE(r.result.message.find("did not confirm arming its RTDE watchdog within 0.50 s"), std::string::npos)
      << r.result.message;
  // Bounded by watchdog_arm_timeout (0.5 s = 63 ticks at 125 Hz), not by the lost-package limits.
  EXPECT_GE(r.unarmed_ticks, 63u);
  EXPECT_LE(r.unarmed_ticks, 65u);
}

TEST(MotionWatchdog, AStallOfTheCallingThreadBeforeTheLoopIsNotALoss) {
  // 150 ms (19 ticks) pass between the readiness state (call 1) and the loop's first state
  // (call 2): nothing was streamed then, so it is set-up time, not 19 lost packages.
  const ArmedRun r = runArming(false, -1, 0, 2, 19);
  EXPECT_EQ(r.result.status, motion::RunStatus::kCompleted) << r.result.message;
  EXPECT_EQ(r.result.stats.packets_lost, 0u);
  // The same gap later in the run is a loss.
  const ArmedRun later = runArming(false, -1, 0, 400, 19);
  EXPECT_EQ(later.result.status, motion::RunStatus::kLostPackets) << later.result.message;
}

// Issue 26, item 7: the tracking error is measured against what the arm was commanded. A host
// stall (the client reads nothing for a tick, the controller holds the last target) must not
// abort the run; an arm that stops following its commands must still stop it.
namespace {
class BlockedArm : public FakeArm {
 public:
  using FakeArm::FakeArm;
  std::size_t block_after = static_cast<std::size_t>(-1);  ///< the arm stops moving after this many targets
  Status sendServoTarget(const JointVector& q) noexcept override {
    if (targets >= block_after) {
      if (!held_) {
        held_ = true;
        held_q_ = q;
      }
      return FakeArm::sendServoTarget(held_q_);  // blocked: the commands no longer move it
    }
    return FakeArm::sendServoTarget(q);
  }

 private:
  bool held_ = false;
  JointVector held_q_ = JointVector::Zero();
};

motion::RunResult runTracking(double limit, int gap_at_call, std::size_t block_after) {
  const auto file = shipped();
  const auto traj = file.toTrajectory();
  BlockedArm arm(0.008, file.q0);
  arm.gap_at_call = gap_at_call;
  arm.gap_ticks = 1;  // 16 ms between two states: within the lost-package limit (24 ms)
  arm.block_after = block_after;
  motion::MotionConfig cfg;
  cfg.realtime.enable = false;
  cfg.tracking_error_limit = limit;
  motion::EvaluatedTrajectory<ftid::trajectory::FourierTrajectory> src(traj);
  motion::MotionRunner runner(arm, cfg, motion::MotionRunner::capacityFor(traj.duration(), 0.008));
  return runner.run(src);
}
}  // namespace

TEST(MotionTracking, AHostStallIsNoTrackingErrorButABlockedJointIs) {
  // The arm follows its commands exactly (one tick late): no tracking error at all, so a limit
  // of 1 mrad is met; with one tick not read 2 s into the excitation the trajectory's time ran 8 ms ahead of the
  // last command (|qd| x 8 ms, far above 1 mrad on the shipped excitation), which used to abort.
  const motion::RunResult plain = runTracking(1e-3, -1, static_cast<std::size_t>(-1));
  ASSERT_EQ(plain.status, motion::RunStatus::kCompleted) << plain.message;
  // FakeArm's time starts at 100 s and advances one period per call: the call 2 s into the excitation.
  const int excite_call = static_cast<int>((plain.excitation_start_timestamp - 100.0) / 0.008);
  const motion::RunResult stall = runTracking(1e-3, excite_call + 250, static_cast<std::size_t>(-1));
  EXPECT_EQ(stall.status, motion::RunStatus::kCompleted) << stall.message;
  EXPECT_LT(stall.max_tracking_error, 1e-9);
  // The arm blocked after 300 targets: aborted with a tracking error at the default limit.
  const motion::RunResult blocked = runTracking(0.05, -1, 300);
  EXPECT_EQ(blocked.status, motion::RunStatus::kTrackingError) << blocked.message;
  EXPECT_GT(blocked.max_tracking_error, 0.05);
}

// Issue 26, item 3: the floor and the limits come from the cell's configuration; a trajectory
// file can only tighten them. The edit: floor_z -10 and a widened limit in the
// trajectory, whose (edited) start pose swings the tool below the floor.
TEST(CellLimits, ATrajectoryCanOnlyTightenTheCellsLimits) {
  const ftid::trajectory::CellLimits cell = ftid::trajectory::readCellLimits(ftid::test::sourcePath("/config/cell_limits.yaml"));
  auto file = shipped();
  file.q0[1] = -0.6;                      // the tool swings ~0.26 m below the floor
  file.constraints.floor_z_B = -10.0;     // the edit: move the floor away
  file.constraints.velocity[4] = 100.0;   // and widen a limit
  ASSERT_TRUE(ftid::design::checkTrajectory(file.toTrajectory(), ur10(), file.constraints).ok())
      << "the trajectory's own constraints let it pass (what check-trajectory said before)";
  ftid::trajectory::LimitSources src;
  const auto eff = ftid::trajectory::effectiveConstraints(file.constraints, "traj.yaml", cell, &src);
  EXPECT_EQ(eff.floor_z_B, 0.0);
  EXPECT_EQ(src.floor_z, cell.path);
  EXPECT_EQ(eff.velocity[4], cell.velocity[4]);
  EXPECT_EQ(src.velocity[4], cell.path);
  EXPECT_EQ(eff.velocity[0], 1.0);  // the trajectory's tighter limit stays, and says so
  EXPECT_EQ(src.velocity[0], "traj.yaml");
  ASSERT_EQ(eff.keep_out.size(), file.constraints.keep_out.size() + cell.keep_out.size());
  const auto report = ftid::design::checkTrajectory(file.toTrajectory(), ur10(), eff);
  ASSERT_FALSE(report.ok());
  EXPECT_NE(joined(report.violations()).find("above floor"), std::string::npos) << joined(report.violations());
  const std::string described = ftid::trajectory::describeLimits(eff, src);
  EXPECT_NE(described.find("floor_z 0 m (" + cell.path + ")"), std::string::npos) << described;
  EXPECT_NE(described.find("velocity [1, 1, 1.5, 2, 3.1416, 2] rad/s (j1-4 traj.yaml, j5 " + cell.path + ", j6 traj.yaml)"),
            std::string::npos)
      << described;
  // The unedited shipped trajectory holds within the shipped cell's limits.
  const auto shipped_file = shipped();
  EXPECT_TRUE(ftid::design::checkTrajectory(shipped_file.toTrajectory(), ur10(),
                                            ftid::trajectory::effectiveConstraints(shipped_file.constraints, "s",
                                                                                   cell, nullptr))
                  .ok());
}

// The installed cell limits always apply; --cell FILE is applied on top of them, so it can only
// tighten (a looser --cell cannot widen the installed limits or lower the installed floor).
TEST(CellLimits, ACellFileCanOnlyTightenTheInstalledLimits) {
  const std::string dir = ::testing::TempDir() + "cell_limits_" + std::to_string(::getpid());
  ASSERT_EQ(std::system(("mkdir -p '" + dir + "'").c_str()), 0);
  const std::string installed = dir + "/installed.yaml";
  const std::string loose = dir + "/loose.yaml";
  const auto limitsText = [](double v4, double floor_z) {
    std::ostringstream os;
    os << "limits:\n  position_lower: [-6, -6, -6, -6, -6, -6]\n  position_upper: [6, 6, 6, 6, 6, 6]\n"
       << "  velocity: [2, 2, 3, 3, " << v4 << ", 3]\n  acceleration: [4, 4, 8, 12, 12, 12]\n"
       << "  floor_z: " << floor_z << "\n";
    return os.str();
  };
  std::ofstream(installed) << limitsText(1.5, 0.0);
  std::ofstream(loose) << limitsText(100.0, -10.0);  // wider speed, lower floor ...
  {
    std::ofstream append(loose, std::ios::app);
    append << "  keep_out:\n    - {name: \"extra\", center: [1, 1, 1], radius: 0.1}\n";  // ... one more sphere
  }
  const auto cells = ftid::trajectory::applicableCellLimits(loose, installed);
  ASSERT_EQ(cells.size(), 2u);
  auto file = shipped();
  file.constraints.velocity[4] = 100.0;
  file.constraints.floor_z_B = -10.0;
  ftid::trajectory::LimitSources src;
  const auto eff = ftid::trajectory::effectiveConstraints(file.constraints, "traj.yaml", cells, &src);
  EXPECT_EQ(eff.velocity[4], 1.5);
  EXPECT_EQ(src.velocity[4], installed);
  EXPECT_EQ(eff.floor_z_B, 0.0);
  EXPECT_EQ(src.floor_z, installed);
  EXPECT_EQ(src.velocity[0], "traj.yaml");  // the trajectory's tighter 1.0 stays
  ASSERT_FALSE(src.keep_out.empty());
  EXPECT_EQ(src.keep_out.back(), loose);  // the tightening file's sphere is added
  // Without an installed file, --cell is the cell's limits.
  EXPECT_EQ(ftid::trajectory::applicableCellLimits(loose, dir + "/absent.yaml").front().path, loose);
  std::system(("rm -rf '" + dir + "'").c_str());
}

TEST(CellLimits, BadFilesNameTheFileLineAndKey) {
  const auto error = [](const std::string& text) {
    try {
      (void)ftid::trajectory::parseCellLimitsText(text, "cell.yaml");
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string six = "[0, 0, 0, 0, 0, 0]";
  const std::string ok_rest = "  velocity: [1, 1, 1, 1, 1, 1]\n  acceleration: [1, 1, 1, 1, 1, 1]\n  floor_z: 0\n";
  EXPECT_NE(error("limits:\n  position_lower: " + six + "\n" + ok_rest).find("cell.yaml"), std::string::npos);
  EXPECT_NE(error("limits:\n  position_lower: " + six + "\n" + ok_rest).find("position_upper"), std::string::npos);
  EXPECT_NE(error("limits:\n  position_lower: [1, 1, 1, 1, 1, 1]\n  position_upper: " + six + "\n" + ok_rest)
                .find("cell.yaml:3"),
            std::string::npos);
  const std::string unknown = error("limits:\n  position_lower: " + six + "\n  position_upper: [1, 1, 1, 1, 1, 1]\n" +
                                    ok_rest + "  floor: 0\n");
  EXPECT_NE(unknown.find("cell.yaml:7"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("'limits.floor'"), std::string::npos) << unknown;
  EXPECT_EQ(error("limits:\n  position_lower: " + six + "\n  position_upper: [1, 1, 1, 1, 1, 1]\n" + ok_rest),
            "no error");
}
