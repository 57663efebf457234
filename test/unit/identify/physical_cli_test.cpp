// `ftid identify` tells the truth (issue 21): the physical-validity line, and no parameter file or
// export from a set that fails it. Logs from `ftid simulate` (the simulator's full Newton-Euler
// physics, independent of the identification's regressors).
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "cli_run.hpp"

namespace {

using ftid::test::CliRun;
using ftid::test::dir;
using ftid::test::fileExists;
using ftid::test::ftidRun;

/// A hidden cable and an 8 ms delay; `duration_s` of the built-in excitation, noise seed `seed`.
std::string simulateCableDelay(const std::string& name, int duration_s, int seed) {
  const std::string log = dir() + name;
  const CliRun s = ftidRun("simulate --out " + log + " --seed " + std::to_string(seed) + " --duration " +
                           std::to_string(duration_s) + " --effect cable --effect sensor_delay:tau=0.008");
  EXPECT_EQ(s.code, 0) << s.err;
  return log;
}

TEST(IdentifyPhysical, UndeterminedInertiaIsRefusedAndNothingWritten) {
  // The case: `identify --model paper+cable+sensor_delay+rigid_body` on a short run wrote a
  // UR script with a negative inertia. 3 s do not determine the payload: refused, exit 1.
  const std::string log = simulateCableDelay("short.csv", 3, 1);
  const std::string out = dir() + "params.yaml";
  for (const char* ext : {"", ".ros2.yaml", ".urscript", ".bak"}) std::remove((out + ext).c_str());  // an earlier run's
  const CliRun r = ftidRun("identify --log " + log + " --model paper+cable+sensor_delay+rigid_body --imu off --out " + out);
  EXPECT_EQ(r.code, 1) << r.out << r.err;
  EXPECT_NE(r.out.find("physical validity: mass"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("principal moments"), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("no parameter file or export written"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("parameters.mass"), std::string::npos) << r.err;
  EXPECT_FALSE(fileExists(out));
  EXPECT_FALSE(fileExists(out + ".ros2.yaml"));
  EXPECT_FALSE(fileExists(out + ".urscript"));
  // The JSON says the same.
  const CliRun j = ftidRun("identify --log " + log + " --model paper+cable+sensor_delay+rigid_body --imu off --json");
  EXPECT_EQ(j.code, 1);
  EXPECT_NE(j.out.find("\"physical_validity\":{\"valid\":false,\"key\":\"parameters.mass\""), std::string::npos) << j.out;
}

TEST(IdentifyPhysical, DeterminedPayloadPassesAndIsWritten) {
  const std::string log = simulateCableDelay("long.csv", 10, 3);
  const std::string out = dir() + "params.yaml";
  const CliRun r = ftidRun("identify --log " + log + " --model paper+cable+sensor_delay+rigid_body --out " + out);
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("-> physically valid within the uncertainty"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("principal moments"), std::string::npos) << r.out;
  EXPECT_TRUE(fileExists(out));
  EXPECT_TRUE(fileExists(out + ".urscript"));
}

}  // namespace

namespace {

using ftid::test::jsonValue;

TEST(IdentifyDefaults, CleanDynamicLogDoesNotWarn) {
  // The default model is the cell's (paper+rigid_body): a clean full-physics run fits to the noise.
  const std::string log = dir() + "clean.csv";
  ASSERT_EQ(ftidRun("simulate --out " + log + " --seed 8").code, 0);
  const CliRun r = ftidRun("identify --log " + log);
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("model paper+rigid_body"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("warning"), std::string::npos) << r.out;
  EXPECT_EQ(r.err.find("set-up:"), std::string::npos) << r.err;
  // The paper's method stays one flag away.
  const CliRun p = ftidRun("identify --log " + log + " --method dynamic");
  EXPECT_EQ(p.code, 0) << p.err;
  EXPECT_NE(p.out.find("method paper-dynamic"), std::string::npos) << p.out;
  EXPECT_EQ(ftidRun("identify --log " + log + " --method dynamic --model paper").code, 2);
}

TEST(IdentifyDefaults, MountRotatedNinetyDegreesIsDiagnosedAndFixedByMountRpy) {
  const std::string log = dir() + "m90.csv";
  ASSERT_EQ(ftidRun("simulate --out " + log + " --mass 0.9 --seed 2 --effect mounting:yaw=90").code, 0);
  const std::string out = dir() + "params.yaml";
  std::remove(out.c_str());
  const CliRun r = ftidRun("identify --log " + log + " --out " + out);
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.err.find("set-up: the sensor is mounted rotated"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("add --mount-rpy 0,0,1.5708"), std::string::npos) << r.err;
  EXPECT_FALSE(fileExists(out));
  const CliRun f = ftidRun("identify --log " + log + " --mount-rpy 0,0,1.5708 --json --out " + out);
  ASSERT_EQ(f.code, 0) << f.err;
  EXPECT_NEAR(jsonValue(f.out, "mass"), 0.90, 0.01) << f.out;
  EXPECT_TRUE(fileExists(out));
  // compensate and analyze take the same mount.
  const CliRun c = ftidRun("compensate --log " + log + " --params " + out + " --mount-rpy 0,0,1.5708 --out " + dir() +
                           "contact.csv");
  EXPECT_EQ(c.code, 0) << c.err;
  const CliRun a = ftidRun("analyze " + log + " --folds 2");
  EXPECT_NE(a.err.find("add --mount-rpy 0,0,1.5708"), std::string::npos) << a.err;
  const CliRun bad = ftidRun("identify --log " + log + " --mount-rpy 0,0");
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.err.find("--mount-rpy"), std::string::npos) << bad.err;
}

}  // namespace
