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

bool exists(const std::string& path) { return std::ifstream(path).good(); }

// Issue 26: nothing is written for a log with a wrong scale; a bad config does not stop offline
// work (only the plausibility inputs are read, defaults otherwise, and the limits are named).
TEST(IdentifyCli, OutRefusesAnImplausibleSetAndABadConfigMeansDefaults) {
  ftid::logio::LogData log = ftid::sim::CellSim(ftid::test::paperConfig(true, 9)).run();
  const std::string good_log = dir() + "good.csv";
  ftid::logio::writeLog(good_log, log);
  for (auto& sample : log.samples) sample.wrench_S(2) *= 4000.0;
  const std::string scaled = dir() + "scaled.csv";
  ftid::logio::writeLog(scaled, log);
  const std::string out = dir() + "scaled_params.yaml";
  std::remove(out.c_str());
  // The paper's method (no inertia to fail first): the mass itself is what the plausibility refuses.
  const CliRun r = ftidRun("identify --log " + scaled + " --method dynamic --out " + out);
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_FALSE(exists(out));
  EXPECT_NE(r.err.find("not written"), std::string::npos) << r.err;

  // (The simulated tool here has no rotational inertia: the paper's method, as for every log of
  // ftid::test::paperConfig.)
  const std::string bad_config = dir() + "bad_ftidd.yaml";
  std::ofstream(bad_config) << "robot:\n  rated_payload_kg: 12.5\n  no_such_key: 1\n";  // invalid as a whole
  const std::string good_out = dir() + "good_params.yaml";
  const CliRun g = ftidRun("identify --log " + good_log + " --method dynamic --out " + good_out + " --config " + bad_config);
  EXPECT_EQ(g.code, 0) << g.err;
  EXPECT_TRUE(exists(good_out));
  EXPECT_NE(g.err.find("rated payload 12.5 kg (" + bad_config + ": robot.rated_payload_kg)"), std::string::npos) << g.err;
  const CliRun none = ftidRun("identify --log " + good_log + " --method dynamic --out " + good_out + " --config " + dir() + "absent.yaml");
  EXPECT_EQ(none.code, 0) << none.err;
  EXPECT_NE(none.err.find("rated payload 10 kg (the built-in default"), std::string::npos) << none.err;

  // ftid compensate: same config handling; refuses an impossible or implausible parameter file.
  const std::string csv = dir() + "contact.csv";
  const CliRun c = ftidRun("compensate --log " + good_log + " --params " + good_out + " --out " + csv + " --config " +
                           bad_config);
  EXPECT_EQ(c.code, 0) << c.err;
  // Hand edits of the written file: the mass set to 10^6 kg (physically possible, beyond the
  // robot); and a rigid-body set with i_s_xx = -5, standard error 100 (the case).
  std::stringstream written;
  written << std::ifstream(good_out).rdbuf();
  std::string heavy_text = written.str();
  const std::string mass_key = "\n  mass: {value: ";
  const auto at = heavy_text.find(mass_key);
  ASSERT_NE(at, std::string::npos) << heavy_text;
  const auto value_at = at + mass_key.size();
  heavy_text.replace(value_at, heavy_text.find_first_of(",}", value_at) - value_at, "1e6");
  const std::string heavy = dir() + "heavy.yaml";
  std::ofstream(heavy) << heavy_text;
  const std::string negative = dir() + "negative_inertia.yaml";
  std::ofstream(negative) << "model: paper+rigid_body\nparameters:\n  mass: {value: 0.9, std: 0.01}\n"
                             "  mass_com_z: {value: 0.045, std: 0.001}\n  i_s_xx: {value: -5, std: 100}\n"
                             "  i_s_yy: {value: 0.01, std: 0.001}\n  i_s_zz: {value: 0.002, std: 0.001}\n"
                             "  i_s_xy: {value: 0}\n  i_s_xz: {value: 0}\n  i_s_yz: {value: 0}\n";
  for (const auto& [file, key] : {std::pair<std::string, std::string>{negative, "parameters.i_s_xx': invalid inertia"}, {heavy, "mass"}}) {
    std::remove(csv.c_str());
    const CliRun x = ftidRun("compensate --log " + good_log + " --params " + file + " --out " + csv);
    EXPECT_EQ(x.code, 1) << key << ": " << x.err;
    EXPECT_NE(x.err.find(key), std::string::npos) << x.err;
    EXPECT_FALSE(exists(csv)) << key;
  }
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

/// The `imu:` entries of a parameter file: name -> value ("name: {value: V, ...").
double imuEntry(const std::string& text, const std::string& name) {
  const std::size_t at = text.find(name + ": {value: ");
  if (at == std::string::npos) return std::nan("");
  return std::stod(text.substr(at + name.size() + 10));
}

/// The contact RMS of axis `axis` that `ftid compensate` prints ("fx  <raw>  <contact>").
double contactRms(const std::string& out, const std::string& axis) {
  std::istringstream in(out);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream l(line);
    std::string name;
    double raw = 0.0, contact = 0.0;
    if (l >> name >> raw >> contact && name == axis) return contact;
  }
  return std::nan("");
}

// Compensation with the motion from the IMU (docs/effects.md "Motion from the IMU"): identify writes
// the IMU's biases; `ftid compensate --motion imu` subtracts them and compensates to the noise; a
// log without the IMU columns is a one-line error.
TEST(IdentifyCli, TheImuBiasesAreWrittenAndCompensateWithTheImuUsesThem) {
  ftid::sim::CellSimConfig cfg = ftid::test::paperConfig(true, 24);
  cfg.noise.acc_std = 0.01;
  cfg.noise.gyro_std = 0.002;
  cfg.imu.enabled = true;  // biases (0.03, -0.02, 0.04) m/s^2, (0.002, -0.003, 0.001) rad/s
  ftid::logio::LogData log = ftid::sim::CellSim(cfg).run();
  const std::string with_imu = dir() + "imu_motion.csv";
  ftid::logio::writeLog(with_imu, log);
  log.has_imu = false;
  const std::string without_imu = dir() + "imu_motion_none.csv";
  ftid::logio::writeLog(without_imu, log);
  const std::string params = dir() + "imu_motion.yaml";
  std::remove(params.c_str());
  const CliRun id = ftidRun("identify --log " + with_imu + " --model paper --out " + params);
  ASSERT_EQ(id.code, 0) << id.err;
  std::stringstream read;
  read << std::ifstream(params).rdbuf();
  const std::string text = read.str();
  ASSERT_NE(text.find("imu:"), std::string::npos) << text;
  EXPECT_NEAR(imuEntry(text, "gyro_bias_x"), 0.002, 2e-4) << text;
  EXPECT_NEAR(imuEntry(text, "gyro_bias_y"), -0.003, 2e-4) << text;
  EXPECT_NEAR(imuEntry(text, "acc_bias_z"), 0.04, 0.01) << text;

  const std::string out = dir() + "imu_motion_contact.csv";
  const CliRun imu = ftidRun("compensate --log " + with_imu + " --params " + params + " --out " + out + " --motion imu");
  ASSERT_EQ(imu.code, 0) << imu.err;
  const CliRun kin = ftidRun("compensate --log " + with_imu + " --params " + params + " --out " + out);
  ASSERT_EQ(kin.code, 0) << kin.err;
  for (const char* axis : {"fx", "fy", "fz"}) {
    // The wrench noise (0.05 N) and m sigma_acc (0.009 N) add in quadrature: 0.051 N.
    EXPECT_LT(contactRms(imu.out, axis), 0.06) << imu.out;
    EXPECT_LT(contactRms(kin.out, axis), 0.06) << kin.out;
  }
  // The file's biases are what the IMU's motion subtracts: 1 m/s^2 more on x leaves -m x 1 m/s^2
  // on fx (0.90 N) with the IMU's motion, and nothing with the kinematics'.
  const std::string key = "acc_bias_x: {value: ";
  const std::size_t at = text.find(key) + key.size();
  const std::string shifted = text.substr(0, at) + std::to_string(imuEntry(text, "acc_bias_x") + 1.0) +
                              text.substr(text.find(',', at));
  std::ofstream(params) << shifted;
  const double m = 8.862 / 9.80665;
  const CliRun imu1 = ftidRun("compensate --log " + with_imu + " --params " + params + " --out " + out + " --motion imu");
  ASSERT_EQ(imu1.code, 0) << imu1.err;
  EXPECT_NEAR(contactRms(imu1.out, "fx"), m, 0.05) << imu1.out;
  EXPECT_LT(contactRms(imu1.out, "fy"), 0.06) << imu1.out;
  const CliRun kin1 = ftidRun("compensate --log " + with_imu + " --params " + params + " --out " + out);
  ASSERT_EQ(kin1.code, 0) << kin1.err;
  EXPECT_EQ(contactRms(kin1.out, "fx"), contactRms(kin.out, "fx"));
  const CliRun none = ftidRun("compensate --log " + without_imu + " --params " + params + " --out " + out +
                              " --motion imu");
  EXPECT_EQ(none.code, 1);
  EXPECT_NE(none.err.find("has no IMU columns"), std::string::npos) << none.err;
  EXPECT_EQ(ftidRun("compensate --log " + with_imu + " --params " + params + " --out " + out + " --motion gps").code, 2);
  for (const auto& f : {with_imu, without_imu, params, out, params + ".bak"}) std::remove(f.c_str());
}

}  // namespace
namespace recordings {

/// A record.py file (no accelerations, no wrench) and the sensor's file of one simulated run; the
/// sensor's clock `offset_s` ahead.
void writeRecordAndSensor(const std::string& rec, const std::string& ft, double offset_s) {
  ftid::sim::CellSimConfig cfg = ftid::test::paperConfig(true, 4);
  cfg.full_rigid_body = true;
  cfg.rate_hz = 500.0;
  const ftid::logio::LogData log = ftid::sim::CellSim(cfg).run();
  std::ofstream r(rec), f(ft);
  r.precision(17);
  f.precision(17);
  r << "timestamp actual_q_0 actual_q_1 actual_q_2 actual_q_3 actual_q_4 actual_q_5 actual_qd_0 actual_qd_1 "
       "actual_qd_2 actual_qd_3 actual_qd_4 actual_qd_5\n";
  f << "time,Fx,Fy,Fz,Tx,Ty,Tz\n";
  for (std::size_t i = 0; i < log.samples.size(); ++i) {
    const auto& s = log.samples[i];
    if (i % 4 == 1) {
      r << s.t;
      for (int j = 0; j < 6; ++j) r << " " << s.q[j];
      for (int j = 0; j < 6; ++j) r << " " << s.qd[j];
      r << "\n";
    }
    f << s.t + offset_s;
    for (int a = 0; a < 6; ++a) f << "," << s.wrench_S[a];
    f << "\n";
  }
}

TEST(RecordingsCli, ConvertIdentifyWithClockOffsetAndCompensate) {
  const std::string rec = dir() + "ur_record.txt";
  const std::string ft = dir() + "ft.csv";
  writeRecordAndSensor(rec, ft, 0.016);
  const CliRun c = ftidRun("convert " + rec + " " + dir() + "native.csv --wrench-log " + ft);
  ASSERT_EQ(c.code, 0) << c.err;
  EXPECT_NE(c.err.find("joint accelerations from smoothed differences of actual_qd"), std::string::npos) << c.err;
  EXPECT_NE(c.err.find("samples used"), std::string::npos) << c.err;
  const ftid::logio::LogData native = ftid::logio::readLog(dir() + "native.csv");
  EXPECT_GT(native.samples.size(), 1000u);
  // Without --wrench-log the recording has no wrench: the refusal names the option.
  const CliRun no_wrench = ftidRun("identify --log " + rec);
  EXPECT_EQ(no_wrench.code, 1);
  EXPECT_NE(no_wrench.err.find("--wrench-log FILE"), std::string::npos) << no_wrench.err;
  // The clock offset is found by sensor_delay and reported with the option that removes it.
  const CliRun id = ftidRun("identify --log " + rec + " --wrench-log " + ft +
                            " --model paper+rigid_body+sensor_delay --max-delay 0.1 --out " + dir() + "p.yaml");
  ASSERT_EQ(id.code, 0) << id.err;
  const auto at = id.out.find("clock offset: " + ft + " lags the robot's recording by ");
  ASSERT_NE(at, std::string::npos) << id.out;
  const std::string by = "recording by ";
  const double ms = std::stod(id.out.substr(id.out.find(by, at) + by.size()));
  EXPECT_NEAR(ms, 16.0, 1.0) << id.out;
  const CliRun comp = ftidRun("compensate --log " + rec + " --wrench-log " + ft + " --params " + dir() +
                              "p.yaml --out " + dir() + "contact.csv");
  EXPECT_EQ(comp.code, 0) << comp.err;
  const CliRun bad_source = ftidRun("identify --log " + rec + " --wrench-log " + ft + " --qdd-source target");
  EXPECT_EQ(bad_source.code, 1);
  EXPECT_NE(bad_source.err.find("--qdd-source target needs the columns target_qdd_0..5"), std::string::npos)
      << bad_source.err;
}

TEST(RecordingsCli, ATooSmallStaticSetSaysWhatWouldDo) {
  ftid::sim::CellSimConfig cfg = ftid::test::paperConfig(true, 3);
  ftid::test::useRestPoses(cfg, 17, 1);
  const std::string poses = dir() + "poses.csv";
  ftid::logio::writeLog(poses, ftid::sim::CellSim(cfg).run());
  const CliRun r = ftidRun("analyze " + poses);
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("17 samples are too few for the analysis (need 100: 20 per held-out block x 5 blocks). "
                       "What would do: repeated readings at each pose (e.g. 6 at each of the 17 poses"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("--folds 2"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("ftid identify --log " + poses + " --method static"), std::string::npos) << r.err;
}

}  // namespace recordings

namespace {

TEST(IdentifyCli, ALogBeyondMaxRowsIsThinnedKeepingTheMotionAndSaysSo) {
  // 20 s holding still, then the paper's 10 s excitation (125 Hz: 2500 + 1251 rows). With
  // --max-rows 2000 (blocks of 125 rows) the still rows are the larger class: every 2nd of their
  // 20 blocks would leave 1250 + 1251 > 2000 rows, every 4th leaves 625 + 1251.
  ftid::sim::CellSimConfig cfg = ftid::test::paperConfig(true, 11);
  const ftid::trajectory::FourierTrajectory excitation = cfg.trajectory;
  const double still_s = 20.0;
  cfg.motion = [excitation, still_s](double t) {
    if (t >= still_s) return excitation.evaluate(t - still_s);
    ftid::trajectory::TrajectoryPoint p;
    p.q = excitation.evaluate(0.0).q;
    return p;
  };
  cfg.duration_s = still_s + 10.0;
  const std::string log_path = dir() + "long_still.csv";
  ftid::logio::writeLog(log_path, ftid::sim::CellSim(cfg).run());
  const CliRun whole = ftidRun("identify --log " + log_path + " --method dynamic --json --max-rows 0");
  ASSERT_EQ(whole.code, 0) << whole.err;
  EXPECT_EQ(whole.out.find("--max-rows"), std::string::npos) << whole.out;
  const CliRun r = ftidRun("identify --log " + log_path + " --method dynamic --json --max-rows 2000");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("every row of the motion and every 4th block of 125 rows of the rest are used"),
            std::string::npos)
      << r.out;
  EXPECT_NEAR(jsonValue(r.out, "weight"), 8.862, 0.05) << r.out;
  EXPECT_NEAR(jsonValue(r.out, "com_z"), 0.051, 0.002) << r.out;
  // A negative budget is a usage error (exit 2).
  const CliRun bad = ftidRun("identify --log " + log_path + " --max-rows -3");
  EXPECT_EQ(bad.code, 2) << bad.err;
}

}  // namespace
