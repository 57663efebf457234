// Real recordings in (docs/log-format.md "UR recordings", "Two files, one log"): a cell recorded
// as a UR controller and a separate sensor logger record it gives the native log's payload.
// The simulator (independent rigid-body physics) runs at 1000 Hz; the robot's recording takes
// 125 Hz of it without accelerations, the sensor's 500 Hz at instants between the robot's.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include "ftid/common/error.hpp"
#include "ftid/identify/offline.hpp"
#include "ftid/logio/log.hpp"
#include "ftid/samples/context.hpp"
#include "paper_cell.hpp"
#include "test_paths.hpp"

namespace ftid::identify {
namespace {

constexpr double kGravity = 9.80665;

std::string scratch(const std::string& name) {
  return ::testing::TempDir() + "ftid_rec_" + std::to_string(::getpid()) + "_" + name;
}

/// 12 s of the paper cell at 1000 Hz, full rigid-body physics, white sensor noise.
const logio::LogData& run1kHz() {
  static const logio::LogData log = [] {
    sim::CellSimConfig cfg = test::paperConfig(true, 5);
    cfg.full_rigid_body = true;
    cfg.rate_hz = 1000.0;
    cfg.duration_s = 12.0;
    return sim::CellSim(cfg).run();
  }();
  return log;
}

bool robotRow(std::size_t i, double t) { return i % 8 == 2 && t >= 1.0 && t <= 10.0; }

/// The native 125 Hz log (exact qdd) of the robot's instants.
logio::LogData nativeLog() {
  const logio::LogData& full = run1kHz();
  logio::LogData log;
  log.source = "native.csv";
  for (std::size_t i = 0; i < full.samples.size(); ++i) {
    if (robotRow(i, full.samples[i].t)) log.samples.push_back(full.samples[i]);
  }
  return log;
}

struct UrRecordOptions {
  bool tcp_force = false;          ///< actual_TCP_force_0..5 (and actual_TCP_pose) from the run
  double payload_kg = 0.0;         ///< the controller's configured payload, subtracted
  Vec3 payload_com_m = Vec3::Zero();
};

/// The robot's record.py file: timestamp actual_q_0..5 actual_qd_0..5 (space-separated, no qdd).
std::string writeUrRecord(const std::string& name, const UrRecordOptions& o = {}) {
  const logio::LogData& full = run1kHz();
  const samples::ContextSet ctx = samples::buildContexts(full, test::ur10());
  std::ostringstream s;
  s.precision(17);
  s << "timestamp";
  for (const char* p : {"actual_q", "actual_qd"}) {
    for (int j = 0; j < 6; ++j) s << " " << p << "_" << j;
  }
  if (o.tcp_force) {
    for (const char* p : {"actual_TCP_pose", "actual_TCP_force"}) {
      for (int j = 0; j < 6; ++j) s << " " << p << "_" << j;
    }
  }
  s << "\n";
  const Vec3 g_B(0.0, 0.0, -kGravity);
  for (std::size_t i = 0; i < full.samples.size(); ++i) {
    const logio::LogSample& x = full.samples[i];
    if (!robotRow(i, x.t)) continue;
    s << x.t;
    for (int j = 0; j < 6; ++j) s << " " << x.q[j];
    for (int j = 0; j < 6; ++j) s << " " << x.qd[j];
    if (o.tcp_force) {
      const Mat3& R = ctx.samples[i].R_BS;
      const Eigen::AngleAxisd aa(R);
      const Vec3 r = aa.angle() * aa.axis();
      const Vec3 p = ctx.samples[i].p_BS_B;
      // The controller's estimate: base axes, moments about the TCP (= S), minus its payload.
      const Vec3 f = R * x.wrench_S.head<3>() - o.payload_kg * g_B;
      const Vec3 t = R * x.wrench_S.tail<3>() - (R * o.payload_com_m).cross(o.payload_kg * g_B);
      s << " " << p.x() << " " << p.y() << " " << p.z() << " " << r.x() << " " << r.y() << " " << r.z();
      s << " " << f.x() << " " << f.y() << " " << f.z() << " " << t.x() << " " << t.y() << " " << t.z();
    }
    s << "\n";
  }
  const std::string path = scratch(name);
  std::ofstream(path) << s.str();
  return path;
}

/// The sensor's own file at 500 Hz (odd 1 kHz samples: never at a robot instant) over all 12 s,
/// its clock `clock_offset_s` ahead of the robot's.
std::string writeSensorFile(const std::string& name, double clock_offset_s = 0.0) {
  const logio::LogData& full = run1kHz();
  std::ostringstream s;
  s.precision(17);
  s << "time,Fx,Fy,Fz,Tx,Ty,Tz\n";
  for (std::size_t i = 1; i < full.samples.size(); i += 2) {
    const logio::LogSample& x = full.samples[i];
    s << x.t + clock_offset_s;
    for (int a = 0; a < 6; ++a) s << "," << x.wrench_S[a];
    s << "\n";
  }
  const std::string path = scratch(name);
  std::ofstream(path) << s.str();
  return path;
}

IdentifyRequest request(const std::string& log, const std::string& model) {
  IdentifyRequest r;
  r.log_path = log;
  r.model = model;
  r.robot_urdf = ftid::test::sourcePath("/config/ur10.urdf");
  return r;
}

double value(const ParameterSet& s, const char* name) {
  const NamedValue* v = s.find(name);
  EXPECT_NE(v, nullptr) << name;
  return v != nullptr ? v->value : 0.0;
}

/// The acceptance: 0.5 % mass, 1 mm centre of mass, 0.1 deg tilt.
void expectSamePayload(const ParameterSet& a, const ParameterSet& b, double mass_rel, double com_m, double tilt_rad) {
  EXPECT_NEAR(value(a, "mass"), value(b, "mass"), mass_rel * value(a, "mass"));
  for (const char* c : {"com_x", "com_y", "com_z"}) EXPECT_NEAR(value(a, c), value(b, c), com_m) << c;
  EXPECT_NEAR(a.tilt_u_rad, b.tilt_u_rad, tilt_rad);
  EXPECT_NEAR(a.tilt_v_rad, b.tilt_v_rad, tilt_rad);
}

constexpr double kTenthDegree = 0.1 * 3.14159265358979323846 / 180.0;

TEST(Recordings, UrRecordPlusSensorFileGivesTheNativeLogsPayload) {
  const std::string native = scratch("native.csv");
  logio::writeLog(native, nativeLog());
  const std::string rec = writeUrRecord("ur_record.txt");
  const std::string ft = writeSensorFile("ft.csv");
  const ParameterSet a = identifyLogFile(request(native, "paper+rigid_body"));
  IdentifyRequest r = request(rec, "paper+rigid_body");
  r.context.input.wrench_log = ft;
  const ParameterSet b = identifyLogFile(r);
  expectSamePayload(a, b, 0.005, 1e-3, kTenthDegree);
  // Both near the truth as well (the data differ by the interpolated noise only).
  EXPECT_NEAR(value(b, "mass"), test::Table2::mass(), 0.005 * test::Table2::mass());
  for (const char* f : {native.c_str(), rec.c_str(), ft.c_str()}) std::remove(f);
}

TEST(Recordings, AClockOffsetBetweenTheFilesIsFoundBySensorDelay) {
  const std::string rec = writeUrRecord("ur_record_off.txt");
  const std::string ft = writeSensorFile("ft_off.csv", 0.020);  // the sensor's clock 20 ms ahead
  IdentifyRequest r = request(rec, "paper+rigid_body+sensor_delay");
  r.max_delay_s = 0.1;
  r.context.input.wrench_log = ft;
  const ParameterSet with_offset = identifyLogFile(r);
  EXPECT_NEAR(value(with_offset, "delay"), 0.020, 0.001);
  // The reported offset, given back as --wrench-time-offset, aligns the files: delay ~ 0.
  r.context.input.wrench_time_offset_s = -value(with_offset, "delay");
  const ParameterSet aligned = identifyLogFile(r);
  EXPECT_NEAR(value(aligned, "delay"), 0.0, 0.001);
  const std::string native = scratch("native_off.csv");
  logio::writeLog(native, nativeLog());
  expectSamePayload(identifyLogFile(request(native, "paper+rigid_body")), aligned, 0.005, 1e-3, kTenthDegree);
  for (const char* f : {native.c_str(), rec.c_str(), ft.c_str()}) std::remove(f);
}

TEST(Recordings, UrBuiltInSensorAsTheWrenchSource) {
  // actual_TCP_force as the e-Series controller reports it: base axes, moments about the TCP.
  const std::string native = scratch("native_tcp.csv");
  logio::writeLog(native, nativeLog());
  const ParameterSet a = identifyLogFile(request(native, "paper+rigid_body"));
  UrRecordOptions o;
  o.tcp_force = true;
  const std::string rec = writeUrRecord("ur_tcp.txt", o);
  const ParameterSet b = identifyLogFile(request(rec, "paper+rigid_body"));  // base frame implied
  // Not bit-identical: the recording's qdd are smoothed differences, the native log's exact.
  expectSamePayload(a, b, 1e-4, 1e-5, 1e-5);
  // A payload configured on the controller (subtracted there) is added back with --ur-payload.
  o.payload_kg = 0.7;
  o.payload_com_m = Vec3(0.01, -0.02, 0.04);
  const std::string rec_cfg = writeUrRecord("ur_tcp_cfg.txt", o);
  IdentifyRequest r = request(rec_cfg, "paper+rigid_body");
  const ParameterSet without = identifyLogFile(r);
  // ftid sees what is left (not exactly mass - 0.7: the controller subtracted it along an
  // untilted vertical, the simulated base is tilted by 10 deg).
  EXPECT_LT(value(without, "mass"), value(a, "mass") - 0.5);
  r.context.input.ur_payload_mass_kg = o.payload_kg;
  r.context.input.ur_payload_com_tcp_m = o.payload_com_m;
  expectSamePayload(b, identifyLogFile(r), 1e-9, 1e-9, 1e-9);
  for (const char* f : {native.c_str(), rec.c_str(), rec_cfg.c_str()}) std::remove(f);
}

}  // namespace
}  // namespace ftid::identify
