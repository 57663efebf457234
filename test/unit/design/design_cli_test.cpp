// `ftid design` for accuracy limits at one duration (docs/design.md "Limits"): the limits objective
// is the default with --limits, --fixed-duration designs at --duration only and says whether the
// limits are met, the design record names the objective and a reproduce command that gives the
// same trajectory (also after a duration search, and with the IMU noise alone), a design moving
// joints 1-3 warns that the keep-out spheres stay in the base frame, and the option combinations
// that make no sense, or limits the model does not predict, are usage errors.
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

/// Runs the reproduce command of the trajectory file `out` as written (up to its note) and expects
/// the same coefficients; removes both designs' files.
void expectReproduceGivesTheSameTrajectory(const std::string& out, const std::string& again) {
  const ftid::trajectory::TrajectoryFile file = ftid::trajectory::readTrajectoryFile(out);
  const std::string reproduce = file.design.at("reproduce");
  const std::string command = reproduce.substr(0, reproduce.find(" (same robot"));
  ASSERT_EQ(command.compare(0, 12, "ftid design "), 0) << command;
  const CommandResult second = run(ftidPath() + command.substr(4) + " --baseline-seeds 0 --quiet --out " + again);
  ASSERT_EQ(second.status, 0) << command << "\n" << second.out;
  const ftid::trajectory::TrajectoryFile file2 = ftid::trajectory::readTrajectoryFile(again);
  EXPECT_EQ(file2.a, file.a) << command;
  EXPECT_EQ(file2.b, file.b) << command;
  for (const std::string& f : {out, again}) {
    std::remove(f.c_str());
    std::remove(ftid::trajectory::csvPathFor(f).c_str());
  }
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
  expectReproduceGivesTheSameTrajectory(out, stem() + "_again.yaml");
}

/// The reproduce command carries what the design depends on: after a duration search (which designs
/// one base period whatever --periods says) it names the design's periods, and it carries a
/// non-default noise and nominal payload (the metric and the relative limits depend on them);
/// with --imu-noise but no limits it is not a --fixed-duration command (that would be refused).
TEST(DesignCli, TheReproduceCommandOfASearchOrOfTheImuNoiseAloneGivesTheSameTrajectory) {
  if (!haveFtid()) GTEST_SKIP() << "ftid executable not built: " << ftidPath();
  const std::string budgets = " --global-evals 200 --local-evals 200 --baseline-seeds 0 --quiet --out ";
  const std::string searched = stem() + "_search.yaml";
  const CommandResult search =
      run(ftidPath() + " design --limits mass=1%,com=3mm --periods 2 --duration 2 --nominal mass=2"
                       " --noise fx=0.2,fy=0.05,fz=0.05,tx=0.01,ty=0.01,tz=0.01" + budgets + searched);
  ASSERT_EQ(search.status, 0) << search.out;
  const std::string reproduce = ftid::trajectory::readTrajectoryFile(searched).design.at("reproduce");
  EXPECT_NE(reproduce.find("--periods 1 "), std::string::npos) << reproduce;
  EXPECT_NE(reproduce.find("--noise fx=0.2,fy=0.05,fz=0.05,tx=0.01,ty=0.01,tz=0.01"), std::string::npos) << reproduce;
  EXPECT_NE(reproduce.find("--nominal mass=2"), std::string::npos) << reproduce;
  expectReproduceGivesTheSameTrajectory(searched, stem() + "_search_again.yaml");

  const std::string imu = stem() + "_imu.yaml";
  const CommandResult first = run(ftidPath() + " design --imu-noise acc=0.01,gyro=0.002 --duration 2" + budgets + imu);
  ASSERT_EQ(first.status, 0) << first.out;
  const std::string imu_reproduce = ftid::trajectory::readTrajectoryFile(imu).design.at("reproduce");
  EXPECT_EQ(imu_reproduce.find("--fixed-duration"), std::string::npos) << imu_reproduce;
  expectReproduceGivesTheSameTrajectory(imu, stem() + "_imu_again.yaml");
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
  // A limit the model does not predict (a typo) is refused before any design, naming it.
  const CommandResult typo = run(ftidPath() + " design --limits mas=5g --fixed-duration --duration 2" + out);
  EXPECT_EQ(typo.status, 2) << typo.out;
  EXPECT_NE(typo.out.find("--limits: model 'paper' has no predicted standard error for mas ("), std::string::npos)
      << typo.out;
  const CommandResult other = run(ftidPath() + " design --target-std i_s_xx=1e-4 --model paper --duration 2" + out);
  EXPECT_EQ(other.status, 2) << other.out;
  EXPECT_NE(other.out.find("no predicted standard error for i_s_xx"), std::string::npos) << other.out;
}

}  // namespace
