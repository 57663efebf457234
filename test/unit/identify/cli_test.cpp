// `ftid identify` / `ftid compensate` end to end on simulated logs: JSON output, parameter file,
// compensated CSV, and the one-line errors with non-zero exit codes for bad input.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "ftid/logio/log.hpp"
#include "cli_run.hpp"
#include "paper_cell.hpp"

namespace {

using ftid::test::CliRun;
using ftid::test::dir;
using ftid::test::ftidRun;
using ftid::test::jsonValue;

TEST(IdentifyCli, JsonParamsAndCompensation) {
  const std::string log_path = dir() + "run.csv";
  ftid::logio::writeLog(log_path, ftid::sim::CellSim(ftid::test::paperConfig(true, 9)).run());
  const std::string params = dir() + "params.yaml";
  // The paper's cell with the paper's physics: the paper's method (the default model,
  // paper+rigid_body, would find the rotational inertia this physics lacks impossible).
  const CliRun r = ftidRun("identify --log " + log_path + " --method dynamic --json --out " + params);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NEAR(jsonValue(r.out, "weight"), 8.862, 0.05) << r.out;
  EXPECT_NEAR(jsonValue(r.out, "com_z"), 0.051, 0.002) << r.out;
  EXPECT_NE(r.out.find("\"residual_rms\":{\"fx\":"), std::string::npos);

  const CliRun t = ftidRun("identify --log " + log_path + " --method static");
  ASSERT_EQ(t.code, 0) << t.err;
  EXPECT_NE(t.out.find("residual RMS"), std::string::npos) << t.out;
  EXPECT_NE(t.out.find("condition number"), std::string::npos) << t.out;

  const std::string out_csv = dir() + "contact.csv";
  const CliRun c = ftidRun("compensate --log " + log_path + " --params " + params + " --out " + out_csv);
  ASSERT_EQ(c.code, 0) << c.err;
  const ftid::logio::LogData log = ftid::logio::readLog(log_path);
  std::ifstream in(out_csv);
  std::string header, line;
  std::getline(in, header);
  EXPECT_EQ(header.rfind("t,fx,fy,fz,tx,ty,tz,model_fx", 0), 0u) << header;
  std::size_t rows = 0;
  double worst = 0.0;
  while (std::getline(in, line)) {
    ++rows;
    std::stringstream ss(line);
    std::string cell;
    std::getline(ss, cell, ',');
    std::getline(ss, cell, ',');  // fx of the contact wrench
    worst = std::max(worst, std::abs(std::stod(cell)));
  }
  EXPECT_EQ(rows, log.samples.size());
  EXPECT_LT(worst, 0.3);  // noise 0.05 N: nothing but noise left
}

TEST(IdentifyCli, BadInputGivesOneLineAndNonZeroExit) {
  const std::string bad = dir() + "bad.csv";
  {
    ftid::logio::LogData log = ftid::sim::CellSim(ftid::test::paperConfig(false, 9)).run();
    log.samples.resize(50);
    ftid::logio::writeLog(bad, log);
  }
  // Corrupt one value on line 5.
  std::ifstream in(bad);
  std::stringstream all;
  std::string line;
  int k = 0;
  while (std::getline(in, line)) {
    if (++k == 5) line = "nan" + line.substr(line.find(','));
    all << line << "\n";
  }
  in.close();
  std::ofstream(bad) << all.str();
  const CliRun r = ftidRun("identify --log " + bad);
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find(bad), std::string::npos) << r.err;
  // Progress lines may precede it; the error itself is exactly one line, the last one.
  const auto error_at = r.err.find("ftid identify: error: ");
  ASSERT_NE(error_at, std::string::npos) << r.err;
  EXPECT_EQ(r.err.find('\n', error_at), r.err.size() - 1) << r.err;

  const CliRun missing = ftidRun("identify --log " + dir() + "nope.csv --json");
  EXPECT_EQ(missing.code, 1);
  const CliRun usage = ftidRun("identify");
  EXPECT_EQ(usage.code, 2);
  const CliRun method = ftidRun("identify --log " + bad + " --method fast");
  EXPECT_EQ(method.code, 2);

  // One pose only: the data do not determine the parameters.
  ftid::sim::CellSimConfig cfg = ftid::test::paperConfig(false, 9);
  cfg.motion = [](double) {
    ftid::trajectory::TrajectoryPoint p;
    p.q = ftid::sim::paperStartPose();
    return p;
  };
  cfg.duration_s = 2.0;
  const std::string still = dir() + "still.csv";
  ftid::logio::writeLog(still, ftid::sim::CellSim(cfg).run());
  const CliRun s = ftidRun("identify --log " + still + " --json");
  EXPECT_EQ(s.code, 1);
  EXPECT_NE(s.err.find("do not determine"), std::string::npos) << s.err;
  EXPECT_EQ(std::count(s.err.begin(), s.err.end(), '\n'), 1) << s.err;
}

}  // namespace

namespace {

/// The "parameters" object of an identify JSON (the part the IMU may change).
std::string parametersOf(const std::string& json) {
  const auto a = json.find("\"parameters\":");
  const auto b = json.find("\"residual_rms\":");
  return a == std::string::npos || b == std::string::npos ? std::string() : json.substr(a, b - a);
}

TEST(IdentifyCli, ImuOffIsTheWrenchAloneAndOnReportsTheImu) {
  ftid::sim::CellSimConfig cfg = ftid::test::paperConfig(true, 23);
  cfg.duration_s = 4.0;
  cfg.noise.acc_std = 0.01;
  cfg.noise.gyro_std = 0.002;
  cfg.imu.enabled = true;
  cfg.imu.delay_s = 0.016;
  ftid::logio::LogData log = ftid::sim::CellSim(cfg).run();
  const std::string with_imu = dir() + "imu.csv";
  ftid::logio::writeLog(with_imu, log);
  log.has_imu = false;
  const std::string without_imu = dir() + "noimu.csv";
  ftid::logio::writeLog(without_imu, log);
  const CliRun off = ftidRun("identify --log " + with_imu + " --model paper --imu off --json");
  const CliRun plain = ftidRun("identify --log " + without_imu + " --model paper --json");
  const CliRun on = ftidRun("identify --log " + with_imu + " --model paper --json");
  ASSERT_EQ(off.code, 0) << off.err;
  ASSERT_EQ(plain.code, 0) << plain.err;
  ASSERT_EQ(on.code, 0) << on.err;
  EXPECT_FALSE(parametersOf(off.out).empty());
  EXPECT_EQ(parametersOf(off.out), parametersOf(plain.out));  // bit for bit: the same text
  EXPECT_EQ(off.out.find("\"imu\""), std::string::npos);
  EXPECT_NE(parametersOf(on.out), parametersOf(off.out));
  EXPECT_NE(on.out.find("\"imu\":{\"used\":true,\"fused\":true"), std::string::npos) << on.out;
  // The IMU stream's 16 ms lag against the robot is reported (the model assumes none).
  const CliRun text = ftidRun("identify --log " + with_imu + " --model paper");
  ASSERT_EQ(text.code, 0) << text.err;
  EXPECT_TRUE(text.out.find("IMU stream delay 15.9") != std::string::npos ||
              text.out.find("IMU stream delay 16.0") != std::string::npos)
      << text.out;  // 15.96 +- 0.07 ms
  EXPECT_NE(text.out.find("WARNING: the IMU and the configuration disagree on the delay"), std::string::npos)
      << text.out;
  // --imu on without IMU columns: a one-line error, exit 1.
  const CliRun missing = ftidRun("identify --log " + without_imu + " --model paper --imu on");
  EXPECT_EQ(missing.code, 1);
  EXPECT_NE(missing.err.find("no IMU columns"), std::string::npos) << missing.err;
  const CliRun bad = ftidRun("identify --log " + with_imu + " --imu maybe");
  EXPECT_EQ(bad.code, 2) << bad.err;
  for (const auto& f : {with_imu, without_imu}) std::remove(f.c_str());
}

}  // namespace
