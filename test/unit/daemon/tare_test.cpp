// ftidd's TARE (docs/daemon.md, "Tare"): the loop-side window in DaemonCycle against fakes and
// the production compensation, the offsets it yields checked against a payload at rest written
// by hand (conventions.md: f = m g_S + F0, t = c x (m g_S) + T0), refusals (moving robot, invalid
// sample, parameters swapped), and the tare state file (persisted, applied only to the
// parameter file it belongs to, removed on reload).
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <string>

#include "fakes.hpp"
#include "ftid/common/error.hpp"
#include "ftid/daemon/adapters.hpp"
#include "ftid/daemon/daemon_cycle.hpp"
#include "ftid/daemon/tare.hpp"
#include "ftid/model/frames.hpp"

namespace ftid::daemon {
namespace {

constexpr double kMass = 1.3;
const Vec3 kCom(0.012, -0.021, 0.064);

Wrench fileOffsets() {
  Wrench w;
  w << 0.5, -0.3, 0.2, 0.011, -0.021, 0.031;
  return w;
}
// What the sensor's zero really is now (it drifted since the parameters were identified).
Wrench trueOffsets() {
  Wrench bias;
  bias << 1.5, -2.0, 0.7, 0.05, -0.08, 0.02;
  return fileOffsets() + bias;
}

void writeParams(const std::string& path, double mass) {
  params::ParameterSet set;
  set.model = "paper";
  const Wrench f0 = fileOffsets();
  for (int i = 0; i < 6; ++i) set.params.push_back({kOffsetNames[i], f0(i), 0.1, ""});
  set.params.push_back({"mass", mass, 0.0, "kg"});
  set.params.push_back({"mass_com_x", mass * kCom.x(), 0.0, "kg*m"});
  set.params.push_back({"mass_com_y", mass * kCom.y(), 0.0, "kg*m"});
  set.params.push_back({"mass_com_z", mass * kCom.z(), 0.0, "kg*m"});
  params::writeParameterFile(path, set);
}

struct Files {
  std::string params;
  explicit Files(const std::string& tag)
      : params(::testing::TempDir() + "ftid_tare_" + tag + "_" + std::to_string(::getpid()) + ".yaml") {}
  ~Files() {
    std::remove(params.c_str());
    std::remove((params + ".bak").c_str());
    std::remove(tareStatePath(params).c_str());
  }
};

struct TareRig {
  test::FakeArm arm;
  test::FakeSensor sensor;
  test::FixedMotion motion;
  rt::OwnedSwapSlot<Compensation> slot;
  test::RecordingSink sink;
  rt::Mailbox<TareRequest> requests;
  rt::Mailbox<TareResult> results;
  std::unique_ptr<DaemonCycle> cycle;
  explicit TareRig(std::unique_ptr<Compensation> comp) : slot(std::move(comp)) {
    CycleOptions opt;
    opt.now_us = &test::fakeNowUs;
    cycle = std::make_unique<DaemonCycle>(&arm, &sensor, &motion, &slot, &sink, opt);
    cycle->attachTare(&requests, &results);
    // A pose with gravity along no axis of S, the robot at rest.
    motion.motion.R_BS = (Eigen::AngleAxisd(0.7, Vec3::UnitZ()) * Eigen::AngleAxisd(-1.1, Vec3::UnitY()) *
                          Eigen::AngleAxisd(0.4, Vec3::UnitX())).toRotationMatrix();
    arm.state.qd.setZero();
    arm.state.qdd.setZero();
    // The payload at rest, by hand: f = m g_S + F0, t = c x (m g_S) + T0.
    const Vec3 g_S = motion.motion.R_BS.transpose() * Vec3(0.0, 0.0, -9.80665);
    const Wrench w0 = trueOffsets();
    sensor.sample.wrench_S.head<3>() = kMass * g_S + w0.head<3>();
    sensor.sample.wrench_S.tail<3>() = kCom.cross(kMass * g_S) + w0.tail<3>();
  }
  void tick() {
    test::g_fake_now_us += 8000;
    ASSERT_EQ(cycle->waitForTick(std::chrono::milliseconds(12)), Status::kOk);
    cycle->onTick();
  }
  const CycleRecord& last() const { return cycle->lastRecord(); }
};

TEST(Tare, RemovesAConstantContactBiasAndPersistsUntilReload) {
  Files f("bias");
  writeParams(f.params, kMass);
  LoadedParameters loaded = loadParameters(f.params, true);
  ASSERT_FALSE(loaded.tared);
  TareRig rig(std::make_unique<ParameterFileCompensation>(loaded.set, f.params));
  rig.tick();
  ASSERT_TRUE(rig.last().wrench_valid);
  const Wrench bias = trueOffsets() - fileOffsets();
  EXPECT_LT((rig.last().contact_S - bias).norm(), 1e-9) << rig.last().contact_S.transpose();

  TareRequest req;
  req.id = 7;
  req.cycles = 10;
  rig.requests.tryPush(req);
  TareResult res;
  for (int i = 0; i < 10; ++i) {
    EXPECT_FALSE(rig.results.tryPop(&res)) << "result before the window ended, cycle " << i;
    rig.tick();
  }
  ASSERT_TRUE(rig.results.tryPop(&res));
  EXPECT_EQ(res.id, 7u);
  EXPECT_EQ(res.outcome, TareOutcome::kOk);
  EXPECT_EQ(res.cycles, 10u);
  EXPECT_EQ(res.param_version, 1u);
  EXPECT_LT((res.mean_contact_S - bias).norm(), 1e-9);

  // Off the loop: new offsets = old + mean contact; persisted; offered as a reload is.
  const Wrench tared = offsetsOf(loaded.set, f.params) + res.mean_contact_S;
  EXPECT_LT((tared - trueOffsets()).norm(), 1e-9);
  TareState state;
  state.parameter_sha256 = loaded.sha256;
  state.offsets = tared;
  state.cycles = res.cycles;
  state.utime = 1234;
  writeTareState(tareStatePath(f.params), state);
  setOffsets(&loaded.set, tared);
  rig.slot.post(std::make_unique<ParameterFileCompensation>(loaded.set, f.params));
  rig.tick();
  EXPECT_EQ(rig.last().param_version, 2);
  ASSERT_TRUE(rig.last().wrench_valid);
  EXPECT_LT(rig.last().contact_S.norm(), 1e-9) << rig.last().contact_S.transpose();

  // A restart applies the saved tare to the same parameter file ...
  const LoadedParameters restarted = loadParameters(f.params, true);
  EXPECT_TRUE(restarted.tared);
  EXPECT_TRUE(restarted.note.empty());
  EXPECT_LT((offsetsOf(restarted.set, f.params) - trueOffsets()).norm(), 1e-12);
  // ... a reload does not (and removes it) ...
  EXPECT_FALSE(loadParameters(f.params, false).tared);
  // ... and a new parameter file ignores a state that belongs to the old one, and says so.
  writeParams(f.params, 2.0);
  const LoadedParameters other = loadParameters(f.params, true);
  EXPECT_FALSE(other.tared);
  EXPECT_NE(other.note.find("belongs to other content"), std::string::npos) << other.note;
  EXPECT_LT((offsetsOf(other.set, f.params) - fileOffsets()).norm(), 1e-12);
  removeTareState(tareStatePath(f.params));
  EXPECT_FALSE(readTareState(tareStatePath(f.params)).has_value());
  removeTareState(tareStatePath(f.params));  // absent: no error
}

TEST(Tare, RefusesWhileTheRobotMovesOrASampleIsInvalidOrParametersChange) {
  Files f("refuse");
  writeParams(f.params, kMass);
  const LoadedParameters loaded = loadParameters(f.params, true);
  TareRig rig(std::make_unique<ParameterFileCompensation>(loaded.set, f.params));
  TareRequest req;
  req.cycles = 20;
  req.max_qd_rad_s = 0.01;
  req.max_qdd_rad_s2 = 0.2;
  TareResult res;

  // A joint slowly moving (0.03 rad/s) from the 4th cycle of the window.
  req.id = 1;
  rig.requests.tryPush(req);
  for (int i = 0; i < 3; ++i) rig.tick();
  rig.arm.state.qd(4) = -0.03;
  rig.tick();
  ASSERT_TRUE(rig.results.tryPop(&res));
  EXPECT_EQ(res.id, 1u);
  EXPECT_EQ(res.outcome, TareOutcome::kMoving);
  EXPECT_EQ(res.cycles, 3u);
  EXPECT_DOUBLE_EQ(res.max_qd, 0.03);
  rig.arm.state.qd.setZero();

  // Accelerating (qd still within the limit).
  req.id = 2;
  rig.requests.tryPush(req);
  rig.arm.state.qdd(1) = 0.5;
  rig.tick();
  ASSERT_TRUE(rig.results.tryPop(&res));
  EXPECT_EQ(res.outcome, TareOutcome::kMoving);
  EXPECT_DOUBLE_EQ(res.max_qdd, 0.5);
  rig.arm.state.qdd.setZero();

  // An invalid sensor sample in the window.
  req.id = 3;
  rig.requests.tryPush(req);
  rig.tick();
  rig.sensor.sample.valid = false;
  rig.tick();
  ASSERT_TRUE(rig.results.tryPop(&res));
  EXPECT_EQ(res.outcome, TareOutcome::kInvalid);
  EXPECT_EQ(res.cycles, 1u);
  rig.sensor.sample.valid = true;

  // The parameters swapped during the window.
  req.id = 4;
  rig.requests.tryPush(req);
  rig.tick();
  rig.slot.post(std::make_unique<ParameterFileCompensation>(loaded.set, f.params));
  rig.tick();
  ASSERT_TRUE(rig.results.tryPop(&res));
  EXPECT_EQ(res.outcome, TareOutcome::kParametersChanged);
  rig.slot.collectRetired();

  // At rest again, the full window completes.
  req.id = 5;
  rig.requests.tryPush(req);
  for (int i = 0; i < 20; ++i) rig.tick();
  ASSERT_TRUE(rig.results.tryPop(&res));
  EXPECT_EQ(res.id, 5u);
  EXPECT_EQ(res.outcome, TareOutcome::kOk);
  EXPECT_EQ(res.cycles, 20u);
}

TEST(Tare, MalformedStateFilesNameTheKey) {
  Files f("bad");
  const std::string path = tareStatePath(f.params);
  auto write = [&](const std::string& text) {
    std::ofstream(path) << text;
  };
  const std::string digest(64, 'a');
  write("parameter_sha256: " + digest + "\nutime: 1\ncycles: 3\noffsets: {f0_x: 1, f0_y: 2, f0_z: 3, t0_x: 4, t0_y: 5}\n");
  try {
    readTareState(path);
    FAIL() << "missing offset accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("offsets.t0_z"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  write("parameter_sha256: " + digest + "\nutime: 1\ncycles: 3\noffsets: {f0_x: 1, f0_y: .nan, f0_z: 3, t0_x: 4, t0_y: 5, t0_z: 6}\n");
  try {  // the file, line, column and key of the bad value
    readTareState(path);
    FAIL() << "non-finite offset accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(path + ":4:26: key 'offsets.f0_y': must be finite"), std::string::npos)
        << e.what();
  }
  write("parameter_sha256: abc\nutime: 1\ncycles: 3\n");
  EXPECT_THROW(readTareState(path), ConfigError);
  // A broken state never stops the parameters from loading; it is ignored and said.
  writeParams(f.params, kMass);
  const LoadedParameters lp = loadParameters(f.params, true);
  EXPECT_FALSE(lp.tared);
  EXPECT_NE(lp.note.find("tare state ignored"), std::string::npos) << lp.note;
  // A round trip keeps every digit.
  TareState s;
  s.parameter_sha256 = digest;
  s.offsets << 0.1, -1.0 / 3.0, 2e-7, 5.5, -0.25, 1e3;
  s.utime = 1700000000123456;
  s.cycles = 125;
  writeTareState(path, s);
  const auto back = readTareState(path);
  ASSERT_TRUE(back.has_value());
  EXPECT_EQ(back->offsets, s.offsets);
  EXPECT_EQ(back->utime, s.utime);
  EXPECT_EQ(back->cycles, 125u);
  EXPECT_EQ(back->parameter_sha256, digest);
}

}  // namespace
}  // namespace ftid::daemon
