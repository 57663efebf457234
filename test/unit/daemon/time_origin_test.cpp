// The model's time (docs/conventions.md, "Time and logs"): a `time_drift` model identified in one
// run is applied by ftidd with the same time origin as by `ftid compensate` on the recording, also
// across a link reconnect (a gap on the host clock, the controller clock running on) and a
// controller reboot (the controller clock restarts). The readings are built independently of the
// compensator: at rest, reading = [m g_S + F0 + dF0/dt (host - origin); c x m g_S + T0 + dT0/dt
// (host - origin)] with g_S from the tilt formula of docs/conventions.md, so the online contact
// must be zero and the offline path must give the online numbers.
#include <gtest/gtest.h>

#include <cmath>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <iterator>
#include <limits>
#include <memory>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "fakes.hpp"
#include "ftid/common/clock.hpp"
#include "ftid/common/error.hpp"
#include "ftid/compensate/compensate_log.hpp"
#include "ftid/daemon/adapters.hpp"
#include "ftid/daemon/daemon_cycle.hpp"
#include "ftid/identify/offline.hpp"
#include "ftid/logio/log.hpp"
#include "ftid/model/kinematics.hpp"
#include "ftid/params/parameter_set.hpp"
#include "ftid/transport/codec.hpp"
#include "ftid/transport/lcm_to_csv.hpp"
#include "test_paths.hpp"

namespace ftid::daemon {
namespace {

constexpr double kMass = 1.7;
const Vec3 kCom(0.004, -0.003, 0.052);
const Vec3 kF0(0.6, -0.4, 1.1);
const Vec3 kT0(0.02, 0.015, -0.01);
const Vec3 kRateF(0.02, -0.015, 0.03);      // N/s
const Vec3 kRateT(0.001, 0.0008, -0.0012);  // Nm/s
constexpr double kTiltU = 0.011;
constexpr double kTiltV = -0.019;

params::ParameterSet driftSet(double origin_unix_s) {
  params::ParameterSet set;
  set.model = "paper+time_drift";
  auto add = [&](const char* name, double v) { set.params.push_back({name, v, 0.0, ""}); };
  add("mass", kMass);
  const char* mc[3] = {"mass_com_x", "mass_com_y", "mass_com_z"};
  const char* f0[3] = {"f0_x", "f0_y", "f0_z"};
  const char* t0[3] = {"t0_x", "t0_y", "t0_z"};
  const char* df[3] = {"f0_dt_x", "f0_dt_y", "f0_dt_z"};
  const char* dt[3] = {"t0_dt_x", "t0_dt_y", "t0_dt_z"};
  for (int k = 0; k < 3; ++k) {
    add(mc[k], kMass * kCom(k));
    add(f0[k], kF0(k));
    add(t0[k], kT0(k));
    add(df[k], kRateF(k));
    add(dt[k], kRateT(k));
  }
  set.tilt_estimated = true;
  set.tilt_u_rad = kTiltU;
  set.tilt_v_rad = kTiltV;
  set.time_origin_unix_s = origin_unix_s;
  return set;
}

/// g_B from docs/conventions.md (paper Eq. 13), written out here rather than taken from model::.
Vec3 gravityInBase() {
  const double g = 9.80665;
  return Vec3(g * std::cos(kTiltU) * std::sin(kTiltV), -g * std::sin(kTiltU),
              -g * std::cos(kTiltU) * std::cos(kTiltV));
}

/// The reading at rest at host time host_s for a set with origin origin_s.
Wrench readingAtRest(const Mat3& R_BS, double host_s, double origin_s) {
  const Vec3 f_g = kMass * (R_BS.transpose() * gravityInBase());
  const double tau = host_s - origin_s;
  Wrench w;
  w.head<3>() = f_g + kF0 + kRateF * tau;
  w.tail<3>() = kCom.cross(f_g) + kT0 + kRateT * tau;
  return w;
}

struct Dir {
  std::string path;
  Dir() {
    char tmpl[] = "/tmp/ftid-time-origin-XXXXXX";
    path = mkdtemp(tmpl);
  }
  ~Dir() { std::system(("rm -rf '" + path + "'").c_str()); }
};

std::string fileText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// Rows (t, contact fx..tz) of a `ftid compensate` output.
std::vector<std::array<double, 7>> readContact(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);  // header
  std::vector<std::array<double, 7>> rows;
  while (std::getline(in, line)) {
    std::array<double, 7> r{};
    std::stringstream ss(line);
    std::string f;
    for (int k = 0; k < 7 && std::getline(ss, f, ','); ++k) r[static_cast<std::size_t>(k)] = std::stod(f);
    rows.push_back(r);
  }
  return rows;
}

/// Runs the recorded segments [records a, b) offline through compensateLogFile.
std::vector<std::array<double, 7>> offline(const test::RecordingSink& sink, int a, int b, const std::string& dir,
                                           const std::string& params_path, const std::string& name) {
  transport::CycleLogBuilder builder(name);
  for (int k = a; k < b; ++k) {
    ftid_lcm::cycle_sample_t msg{};
    transport::toLcm(sink.records[static_cast<std::size_t>(k)], &msg);  // as published and recorded
    CycleRecord rec;
    transport::fromLcm(msg, &rec);
    EXPECT_TRUE(builder.add(rec)) << "record " << k;
  }
  const std::string log_path = dir + "/" + name + ".csv";
  logio::writeLog(log_path, builder.finish());
  compensate::CompensateRequest req;
  req.log_path = log_path;
  req.params_path = params_path;
  req.out_csv = dir + "/" + name + ".contact.csv";
  req.robot_urdf = ftid::test::sourcePath("/config/ur10.urdf");
  const compensate::CompensateSummary s = compensate::compensateLogFile(req);
  const params::ParameterSet set = params::readParameterFile(params_path);
  EXPECT_EQ(s.time_note.empty(), std::isfinite(set.time_origin_unix_s)) << s.time_note;
  return readContact(req.out_csv);
}

struct DriftRun {
  test::RecordingSink sink;
  int reconnect_at = 0;  ///< first record of the second session (same controller clock)
  int reboot_at = 0;     ///< first record after the controller reboot (its clock restarted)
};

/// 3 sessions of 40 cycles at rest at random poses: start, reconnect after a 2.5 s outage,
/// controller reboot after 40 s (robot_time restarts at 0.5 s). The readings carry the drift
/// since reading_origin_s (NaN: since the first cycle's receive time). With receive-time jitter
/// the cycle's pairing may blend a reading with the previous pose's (the tests then compare with
/// the paired reading); without it each state is paired with its own reading.
void runOnline(Compensation* comp, double reading_origin_s, DriftRun* run, int jitter_us = 300) {
  const model::RobotKinematics kin = model::RobotKinematics::fromUrdfFile(ftid::test::sourcePath("/config/ur10.urdf"));
  KinematicsMotionModel motion(kin);
  rt::OwnedSwapSlot<Compensation> slot{std::unique_ptr<Compensation>(comp)};
  test::FakeArm arm1, arm2, arm3;
  arm2.state.robot_time = arm1.state.robot_time + 2.5 + 40 * 0.008;  // the clock ran on
  arm3.state.robot_time = 0.5;                                         // rebooted
  test::FakeSensor sensor;
  CycleOptions opt;
  opt.now_us = &test::fakeNowUs;
  DaemonCycle cycle(&arm1, &sensor, &motion, &slot, &run->sink, opt);
  std::mt19937 rng(2026);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  test::FakeArm* arms[3] = {&arm1, &arm2, &arm3};
  const std::int64_t gap_us[3] = {0, 2'500'000, 40'000'000};
  for (int s = 0; s < 3; ++s) {
    test::g_fake_now_us += gap_us[s];
    cycle.setArm(arms[s]);
    if (s == 1) run->reconnect_at = run->sink.count;
    if (s == 2) run->reboot_at = run->sink.count;
    for (int k = 0; k < 40; ++k) {
      test::FakeArm& arm = *arms[s];
      for (int j = 0; j < 6; ++j) arm.state.q(j) = 2.5 * u(rng);
      arm.state.qd.setZero();
      arm.state.qdd.setZero();
      test::g_fake_now_us += 8000 + static_cast<int>(jitter_us * u(rng));  // receive-time jitter
      const double host_s = hostTimeSeconds(test::g_fake_now_us);     // FakeArm: recv_utime = now
      if (std::isnan(reading_origin_s)) reading_origin_s = host_s;
      const Mat3 R_BS = kin.computeSensorMotion(arm.state.q, arm.state.qd, arm.state.qdd).R_BS;
      sensor.sample.wrench_S = readingAtRest(R_BS, host_s, reading_origin_s);
      ++sensor.sample.counter;
      ASSERT_EQ(cycle.waitForTick(std::chrono::milliseconds(12)), Status::kOk);
      cycle.onTick();
    }
  }
  ASSERT_EQ(run->sink.count, 120);
}

/// Online: every record's contact = its paired reading - the independent model at its state's
/// receive time (seconds since origin_s), to rounding.
void expectOnlineModel(const DriftRun& run, double origin_s) {
  const model::RobotKinematics kin = model::RobotKinematics::fromUrdfFile(ftid::test::sourcePath("/config/ur10.urdf"));
  for (int k = 0; k < run.sink.count; ++k) {
    const CycleRecord& r = run.sink.records[static_cast<std::size_t>(k)];
    ASSERT_TRUE(r.wrench_valid) << "record " << k;
    const Mat3 R_BS = kin.computeSensorMotion(r.robot.q, r.robot.qd, r.robot.qdd).R_BS;
    const Wrench expected = r.sensor.wrench_S - readingAtRest(R_BS, hostTimeSeconds(r.robot.recv_utime), origin_s);
    EXPECT_LT((r.contact_S - expected).cwiseAbs().maxCoeff(), 1e-9)
        << "record " << k << ": " << r.contact_S.transpose() << " vs " << expected.transpose();
  }
}

/// Offline rows [a, b) against the online records (the CSV has 9 significant digits).
void expectSame(const std::vector<std::array<double, 7>>& rows, const DriftRun& run, int a, int b) {
  ASSERT_EQ(static_cast<int>(rows.size()), b - a);
  for (int k = a; k < b; ++k) {
    const CycleRecord& r = run.sink.records[static_cast<std::size_t>(k)];
    for (int ax = 0; ax < 6; ++ax) {
      const double off = rows[static_cast<std::size_t>(k - a)][static_cast<std::size_t>(ax + 1)];
      EXPECT_NEAR(off, r.contact_S(ax), 1e-8 * (1.0 + std::abs(r.contact_S(ax)))) << "record " << k << " axis " << ax;
    }
  }
}

TEST(TimeOrigin, OnlineAndOfflineAgreeAcrossReconnectAndControllerReboot) {
  Dir dir;
  // Identified an hour before ftidd started: the drift since then is 108 N on fz.
  const double origin_s = hostTimeSeconds(test::g_fake_now_us) - 3600.0;
  const std::string params_path = dir.path + "/drift.yaml";
  params::writeParameterFile(params_path, driftSet(origin_s));
  const params::ParameterSet back = params::readParameterFile(params_path);
  ASSERT_EQ(back.time_origin_unix_s, origin_s);  // round trip, exactly

  auto run = std::make_unique<DriftRun>();
  runOnline(new ParameterFileCompensation(back, params_path), origin_s, run.get());
  ASSERT_GT(run->reconnect_at, 0);
  expectOnlineModel(*run, origin_s);
  // Offline: the recording before the reboot (one log: its controller clock increases, over the
  // reconnect) and the one after it.
  expectSame(offline(run->sink, 0, run->reboot_at, dir.path, params_path, "before_reboot"), *run, 0, run->reboot_at);
  expectSame(offline(run->sink, run->reboot_at, run->sink.count, dir.path, params_path, "after_reboot"), *run,
             run->reboot_at, run->sink.count);
}

// Files from before time origins (no time_origin key) still load; the model's time then runs from
// ftidd's first valid cycle on the host clock, continuous over the reconnect and the reboot, and
// `ftid compensate` on a recording that starts at that cycle gives the same.
TEST(TimeOrigin, WithoutOriginTheTimeRunsFromTheFirstValidCycleOnTheHostClock) {
  Dir dir;
  params::ParameterSet set = driftSet(0.0);
  set.time_origin_unix_s = std::numeric_limits<double>::quiet_NaN();
  const std::string params_path = dir.path + "/old.yaml";
  params::writeParameterFile(params_path, set);
  {
    const std::string text = fileText(params_path);
    ASSERT_EQ(text.find("time_origin"), std::string::npos);  // as an old file
  }
  const params::ParameterSet back = params::readParameterFile(params_path);
  ASSERT_TRUE(std::isnan(back.time_origin_unix_s));

  auto run = std::make_unique<DriftRun>();
  runOnline(new ParameterFileCompensation(back, params_path), std::numeric_limits<double>::quiet_NaN(), run.get());
  expectOnlineModel(*run, hostTimeSeconds(run->sink.records[0].robot.recv_utime));
  expectSame(offline(run->sink, 0, run->reboot_at, dir.path, params_path, "old_before_reboot"), *run, 0,
             run->reboot_at);
}

// Identified in one run, applied in the next: the fit of the recording stores its first host_time
// as the time origin, its offsets hold at that instant (the true offsets plus the drift since the
// true origin), and ftidd with the identified file compensates a later run to zero.
TEST(TimeOrigin, IdentificationStoresTheRecordingsFirstHostTime) {
  Dir dir;
  const double true_origin_s = hostTimeSeconds(test::g_fake_now_us) - 600.0;
  const std::string true_path = dir.path + "/true.yaml";
  params::writeParameterFile(true_path, driftSet(true_origin_s));
  auto first = std::make_unique<DriftRun>();
  runOnline(new ParameterFileCompensation(params::readParameterFile(true_path), true_path), true_origin_s,
            first.get(), 0);
  // The recording of the first two sessions (80 cycles at rest, random poses, over 3 s).
  transport::CycleLogBuilder builder("identification run");
  for (int k = 0; k < first->reboot_at; ++k) {
    ftid_lcm::cycle_sample_t msg{};
    transport::toLcm(first->sink.records[static_cast<std::size_t>(k)], &msg);
    CycleRecord rec;
    transport::fromLcm(msg, &rec);
    ASSERT_TRUE(builder.add(rec));
  }
  const std::string log_path = dir.path + "/run.csv";
  logio::writeLog(log_path, builder.finish());
  identify::IdentifyRequest req;
  req.log_path = log_path;
  req.model = "paper+time_drift";
  req.robot_urdf = ftid::test::sourcePath("/config/ur10.urdf");
  params::ParameterSet fitted = identify::identifyLogFile(req);
  const double host0_s = hostTimeSeconds(first->sink.records[0].robot.recv_utime);
  EXPECT_EQ(fitted.time_origin_unix_s, host0_s);  // exactly the recorded value
  const double since = host0_s - true_origin_s;
  const char* f0[3] = {"f0_x", "f0_y", "f0_z"};
  const char* df[3] = {"f0_dt_x", "f0_dt_y", "f0_dt_z"};
  for (int k = 0; k < 3; ++k) {
    ASSERT_NE(fitted.find(f0[k]), nullptr);
    EXPECT_NEAR(fitted.find(f0[k])->value, kF0(k) + kRateF(k) * since, 1e-6) << f0[k];
    EXPECT_NEAR(fitted.find(df[k])->value, kRateF(k), 1e-7) << df[k];
  }
  // A later run (its readings drift since the true origin) with the identified file: zero contact.
  const std::string fitted_path = dir.path + "/fitted.yaml";
  params::writeParameterFile(fitted_path, fitted);
  test::g_fake_now_us += 3'600'000'000;  // an hour later
  auto later = std::make_unique<DriftRun>();
  runOnline(new ParameterFileCompensation(params::readParameterFile(fitted_path), fitted_path), true_origin_s,
            later.get(), 0);
  for (int k = 0; k < later->sink.count; ++k) {
    const CycleRecord& r = later->sink.records[static_cast<std::size_t>(k)];
    const Mat3 R_BS = model::RobotKinematics::fromUrdfFile(ftid::test::sourcePath("/config/ur10.urdf"))
                          .computeSensorMotion(r.robot.q, r.robot.qd, r.robot.qdd)
                          .R_BS;
    const Wrench expected =
        r.sensor.wrench_S - readingAtRest(R_BS, hostTimeSeconds(r.robot.recv_utime), true_origin_s);
    EXPECT_LT((r.contact_S - expected).cwiseAbs().maxCoeff(), 1e-4) << "record " << k;
  }
}

// A negative or infinite origin is refused with the file and key.
TEST(TimeOrigin, ParameterFileRefusesABadOrigin) {
  Dir dir;
  const std::string path = dir.path + "/p.yaml";
  params::writeParameterFile(path, driftSet(1.8e9));
  std::string text = fileText(path);
  const auto at = text.find("unix_s: ");
  ASSERT_NE(at, std::string::npos) << text;
  const auto end = text.find_first_of(",}", at);
  text.replace(at, end - at, "unix_s: -5");
  try {
    params::parseParameterText(text, "p.yaml");
    FAIL() << "accepted a negative time origin";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("time_origin.unix_s"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ftid::daemon
