// `ftid design` for accuracy limits at one duration (docs/design.md "Limits"): the limits objective
// is the default with --limits, --fixed-duration designs at --duration only and says whether the
// limits are met, the design record names the objective and a reproduce command that gives the
// same trajectory, a design moving joints 1-3 warns that the keep-out spheres stay in the base
// frame, and the option combinations that make no sense are usage errors.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include "ftid/trajectory/trajectory_io.hpp"
#include "test_paths.hpp"

namespace {

struct CommandResult {
  int status = -1;
  std::string out;
};

CommandResult run(const std::string& command) {
  CommandResult r;
  std::FILE* p = ::popen((command + " 2>&1").c_str(), "r");
  char buf[512];
  while (std::fgets(buf, sizeof buf, p) != nullptr) r.out += buf;
  const int status = ::pclose(p);
  r.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

std::string ftidPath() { return ftid::test::binaryPath("/apps/ftid/ftid"); }

bool haveFtid() {
  std::ifstream f(ftidPath());
  return f.good();
}

std::string stem() {
  return ::testing::TempDir() + "ftid_design_cli_" + ::testing::UnitTest::GetInstance()->current_test_info()->name() +
         "_" + std::to_string(::getpid());
}

TEST(DesignCli, LimitsAtAFixedDurationAreTheObjectiveAndTheReproduceCommandGivesTheSameTrajectory) {
  if (!haveFtid()) GTEST_SKIP() << "ftid executable not built: " << ftidPath();
  const std::string out = stem() + ".yaml";
  const std::string args =
      " design --model paper+rigid_body --joints 2,3,4,5,6 --duration 1.5 --limits mass=0.5%,com=1mm,tilt=0.1deg"
      " --imu-noise acc=0.01,gyro=0.002 --fixed-duration --global-evals 300 --local-evals 300 --baseline-seeds 0"
      " --quiet --out ";
  const CommandResult first = run(ftidPath() + args + out);
  ASSERT_EQ(first.status, 0) << first.out;
  EXPECT_TRUE(first.out.find("1.50 s meets the limits with the IMU") != std::string::npos ||
              first.out.find("1.50 s misses the limits with the IMU") != std::string::npos)
      << first.out;
  EXPECT_NE(first.out.find("warning: the design moves joint 2 by up to"), std::string::npos) << first.out;
  EXPECT_NE(first.out.find("predicted worst case over noise"), std::string::npos) << first.out;
  const ftid::trajectory::TrajectoryFile file = ftid::trajectory::readTrajectoryFile(out);
  EXPECT_EQ(file.design.at("objective"), "limits");
  const std::string reproduce = file.design.at("reproduce");
  EXPECT_NE(reproduce.find("--objective limits"), std::string::npos) << reproduce;
  EXPECT_NE(reproduce.find("--limits mass=0.5%,com=1mm,tilt=0.1deg --imu-noise acc=0.01,gyro=0.002 --fixed-duration"),
            std::string::npos)
      << reproduce;
  // The reproduce command, run as written (up to its note), designs the same trajectory.
  const std::string again = stem() + "_again.yaml";
  const std::string command = reproduce.substr(0, reproduce.find(" (same robot"));
  ASSERT_EQ(command.compare(0, 12, "ftid design "), 0) << command;
  const CommandResult second = run(ftidPath() + command.substr(4) + " --baseline-seeds 0 --quiet --out " + again);
  ASSERT_EQ(second.status, 0) << second.out;
  const ftid::trajectory::TrajectoryFile file2 = ftid::trajectory::readTrajectoryFile(again);
  EXPECT_EQ(file2.a, file.a);
  EXPECT_EQ(file2.b, file.b);
  for (const std::string& f : {out, again}) {
    std::remove(f.c_str());
    std::remove(ftid::trajectory::csvPathFor(f).c_str());
  }
}

TEST(DesignCli, MeaninglessCombinationsAreUsageErrors) {
  if (!haveFtid()) GTEST_SKIP() << "ftid executable not built: " << ftidPath();
  const std::string out = " --quiet --out " + stem() + ".yaml";
  const CommandResult no_limits = run(ftidPath() + " design --objective limits --duration 2" + out);
  EXPECT_EQ(no_limits.status, 2) << no_limits.out;
  EXPECT_NE(no_limits.out.find("--objective limits needs --limits or --target-std"), std::string::npos)
      << no_limits.out;
  const CommandResult fixed = run(ftidPath() + " design --fixed-duration --duration 2" + out);
  EXPECT_EQ(fixed.status, 2) << fixed.out;
  EXPECT_NE(fixed.out.find("--fixed-duration needs --limits or --target-std"), std::string::npos) << fixed.out;
}

}  // namespace
