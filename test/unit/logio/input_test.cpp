// Recordings other than ftid's own log (docs/log-format.md): UR RTDE recordings, a sensor's own
// wrench log and its alignment with the robot's, column aliases and the refusals that name the fix.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "ftid/common/error.hpp"
#include "ftid/logio/input.hpp"
#include "ftid/logio/log.hpp"
#include "ftid/logio/table.hpp"
#include "test_paths.hpp"

namespace ftid::logio {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::string tempPath(const std::string& name) {
  return ftid::test::binaryPath("/logio_input_") + std::to_string(::getpid()) + "_" + name;
}

std::string writeText(const std::string& name, const std::string& text) {
  const std::string path = tempPath(name);
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

/// The message of the DataError `f` throws ("" if it throws none).
template <typename F>
std::string errorOf(F f) {
  try {
    f();
  } catch (const DataError& e) {
    return e.what();
  }
  return "";
}

/// Joint j's motion: q = A_j sin(w t + j), qd its exact derivative.
double qOf(int j, double t) { return 0.3 * (j + 1) * std::sin(2.0 * kPi * 0.7 * t + j); }
double qdOf(int j, double t) { return 0.3 * (j + 1) * 2.0 * kPi * 0.7 * std::cos(2.0 * kPi * 0.7 * t + j); }
double qddOf(int j, double t) { return -0.3 * (j + 1) * std::pow(2.0 * kPi * 0.7, 2) * std::sin(2.0 * kPi * 0.7 * t + j); }

/// A record.py-style recording (space-separated) of the motion above at `rate` Hz, each state
/// written `repeat` times (a recorder faster than the controller: later copies advance the time).
std::string urRecord(double rate, int rows, int repeat = 1, char sep = ' ', bool target_qdd = true, bool force = true) {
  std::ostringstream s;
  s.precision(17);
  s << "timestamp";
  auto names = [&](const char* prefix, int n) {
    for (int j = 0; j < n; ++j) s << sep << prefix << "_" << j;
  };
  names("actual_q", 6);
  names("actual_qd", 6);
  if (target_qdd) names("target_qdd", 6);
  names("actual_TCP_pose", 6);
  if (force) names("actual_TCP_force", 6);
  names("actual_tool_accelerometer", 3);
  s << "\n";
  for (int i = 0; i < rows; ++i) {
    const double t_state = 100.0 + i / rate;
    for (int r = 0; r < repeat; ++r) {
      s << t_state + r / (rate * repeat);
      for (int j = 0; j < 6; ++j) s << sep << qOf(j, t_state);
      for (int j = 0; j < 6; ++j) s << sep << qdOf(j, t_state);
      if (target_qdd) {
        for (int j = 0; j < 6; ++j) s << sep << 1000.0 + j;  // marker values
      }
      for (int j = 0; j < 6; ++j) s << sep << 0.1 * j + 0.001 * i;
      if (force) {
        for (int j = 0; j < 6; ++j) s << sep << 2.0 * j - 5.0 + 0.01 * i;
      }
      s << sep << 0.1 << sep << 0.2 << sep << 9.8;
      s << "\n";
    }
  }
  return s.str();
}

/// The exact output of smoothedDerivative for y = sin(w t + phase) on a uniform grid, at an
/// interior sample: the least-squares slope of a sine over +-h samples is w cos(w t + phase) times
/// the real gain G = sum_k k sin(w k dt) / (w dt sum_k k^2) (the cosine part cancels by symmetry).
double gain(double w, double dt, int h) {
  double num = 0.0, den = 0.0;
  for (int k = -h; k <= h; ++k) {
    num += k * std::sin(w * k * dt);
    den += k * k;
  }
  return num / (w * dt * den);
}

TEST(Table, ReadsSpaceAndCommaSeparatedAndNamesBadFields) {
  const Table a = parseTable("# comment\na b  c\n1 2 3\n\n4\t5 6\n", "a.txt");
  ASSERT_EQ(a.names.size(), 3u);
  EXPECT_EQ(a.rows(), 2u);
  EXPECT_EQ(a.columns[2][1], 6.0);
  EXPECT_EQ(a.row_line[1], 5u);
  const Table b = parseTable("x, y\n1, -2e-3\n", "b.csv");
  EXPECT_EQ(b.find("y"), 1);
  EXPECT_EQ(b.columns[1][0], -2e-3);
  EXPECT_EQ(errorOf([] { parseTable("a b\n1 nan\n", "c.txt"); }),
            "c.txt:2:3: column 'b': non-finite value 'nan' (NaN and infinity are not allowed)");
  EXPECT_EQ(errorOf([] { parseTable("a,b\n1,x1\n", "c.txt"); }), "c.txt:2:3: column 'b': not a number: 'x1'");
  EXPECT_EQ(errorOf([] { parseTable("a b\n1\n", "c.txt"); }),
            "c.txt:2:2: too few fields: expected 2 (as in the header on line 1), found 1");
  EXPECT_EQ(errorOf([] { parseTable("a b\n1 2 3\n", "c.txt"); }),
            "c.txt:2:5: too many fields: expected 2 (as in the header on line 1), found 3");
  EXPECT_EQ(errorOf([] { parseTable("a a\n1 2\n", "c.txt"); }), "c.txt:1:3: duplicate column 'a' (first at column 1)");
  EXPECT_EQ(errorOf([] { parseTable("a b\n", "c.txt"); }), "c.txt:1:1: the file has a header but no data rows");
  EXPECT_EQ(errorOf([] { parseTable("a,,b\n1,2,3\n", "c.txt"); }), "c.txt:1:3: empty column name in header");
  // A csv writer's quoted fields and a comma at the end of every line read as the plain table.
  const Table q = parseTable("\"x\",\"y\",\n\"1\",\"-2e-3\",\n3,4\n", "q.csv");
  ASSERT_EQ(q.names, (std::vector<std::string>{"x", "y"}));
  EXPECT_EQ(q.columns[1], (std::vector<double>{-2e-3, 4.0}));
  EXPECT_EQ(errorOf([] { parseTable("a,b\n1,++2\n", "c.txt"); }), "c.txt:2:3: column 'b': not a number: '++2'");
}

TEST(UrRecord, RecognisedFromItsHeader) {
  EXPECT_TRUE(isUrRecordHeader("timestamp actual_q_0 actual_q_1"));
  EXPECT_TRUE(isUrRecordHeader("timestamp,actual_TCP_pose_0,actual_TCP_pose_1"));
  EXPECT_FALSE(isUrRecordHeader("t,q1,q2"));
  EXPECT_FALSE(isUrRecordHeader("actual_q_0 actual_q_1"));  // no timestamp
}

TEST(UrRecord, AccelerationsFromSmoothedDifferencesMatchTheExactValues) {
  const double rate = 125.0;
  const std::string text = urRecord(rate, 250);
  const InputLog in = urRecordToLog(parseTable(text, "rec.txt"), {});
  ASSERT_EQ(in.log.samples.size(), 250u);
  EXPECT_TRUE(in.log.has_joints);
  EXPECT_TRUE(in.log.has_wrench);
  EXPECT_TRUE(in.wrench_in_base);
  const double w = 2.0 * kPi * 0.7;
  const double g = gain(w, 1.0 / rate, 3);
  EXPECT_LT(std::abs(g - 1.0), 0.01);  // 0.7 Hz at 125 Hz: the smoothing costs well under 1 %
  for (std::size_t i = 3; i + 3 < in.log.samples.size(); ++i) {
    const LogSample& s = in.log.samples[i];
    const double t = 100.0 + static_cast<double>(i) / rate;
    for (int j = 0; j < 6; ++j) {
      EXPECT_NEAR(s.q[j], qOf(j, t), 1e-12);
      EXPECT_NEAR(s.qd[j], qdOf(j, t), 1e-12);
      // Exact: the gain is real, so no lag; the value is G times the true acceleration.
      ASSERT_NEAR(s.qdd[j], g * qddOf(j, t), 1e-7 * std::abs(qddOf(j, 0.0) + 1.0)) << "sample " << i << " joint " << j;
    }
  }
  // The wrench is actual_TCP_force as recorded; the other columns are kept by name.
  EXPECT_DOUBLE_EQ(in.log.samples[10].wrench_S[5], 5.0 + 0.1);
  EXPECT_GE(in.log.extraIndex("actual_tool_accelerometer_2"), 0);
  EXPECT_GE(in.log.extraIndex("actual_TCP_pose_0"), 0);
}

TEST(UrRecord, TargetAccelerationsOnRequestAndCommaSeparated) {
  InputOptions o;
  o.qdd_source = QddSource::kTarget;
  const InputLog in = urRecordToLog(parseTable(urRecord(125.0, 20, 1, ','), "rec.csv"), o);
  for (const LogSample& s : in.log.samples) {
    for (int j = 0; j < 6; ++j) EXPECT_EQ(s.qdd[j], 1000.0 + j);
  }
  EXPECT_EQ(errorOf([&] { urRecordToLog(parseTable(urRecord(125.0, 20, 1, ' ', false), "rec.txt"), o); }),
            "rec.txt:1:1: --qdd-source target needs the columns target_qdd_0..5, which this recording lacks (record "
            "them, or use the default: smoothed differences of actual_qd)");
}

TEST(UrRecord, StairSteppedStatesAreDroppedBeforeDifferencing) {
  const double rate = 125.0;
  // The recorder wrote every controller state 4 times (500 Hz against 125 Hz updates).
  const InputLog in = urRecordToLog(parseTable(urRecord(rate, 100, 4), "stairs.txt"), {});
  ASSERT_EQ(in.log.samples.size(), 100u);
  ASSERT_FALSE(in.notes.empty());
  EXPECT_NE(in.notes.front().find("dropped 300 of 400 rows"), std::string::npos) << in.notes.front();
  const double g = gain(2.0 * kPi * 0.7, 1.0 / rate, 3);
  for (std::size_t i = 3; i + 3 < in.log.samples.size(); ++i) {
    const double t = 100.0 + static_cast<double>(i) / rate;
    EXPECT_DOUBLE_EQ(in.log.samples[i].t, t);
    for (int j = 0; j < 6; ++j) ASSERT_NEAR(in.log.samples[i].qdd[j], g * qddOf(j, t), 1e-6);
  }
}

TEST(UrRecord, RepeatsAtRestAreRealReadingsAndKept) {
  // A static pose held for 20 rows: q repeats exactly, qd is zero: every row is a real reading
  // (the repeated readings of a static pose set); an exact duplicate row (same time) is dropped.
  std::string text = "timestamp actual_q_0 actual_q_1 actual_q_2 actual_q_3 actual_q_4 actual_q_5 actual_qd_0 "
                     "actual_qd_1 actual_qd_2 actual_qd_3 actual_qd_4 actual_qd_5 actual_TCP_force_0 "
                     "actual_TCP_force_1 actual_TCP_force_2 actual_TCP_force_3 actual_TCP_force_4 actual_TCP_force_5\n";
  for (int i = 0; i < 20; ++i) {
    text += std::to_string(0.008 * i) + " 0.1 -1.5 1.5 -1.5 -1.5 0.2 0 0 0 0 0 0 1 2 " + std::to_string(3.0 + 0.01 * i) +
            " 0 0 0\n";
  }
  text += "0.152 0.1 -1.5 1.5 -1.5 -1.5 0.2 0 0 0 0 0 0 1 2 3.19 0 0 0\n";  // row 20 again
  const InputLog in = urRecordToLog(parseTable(text, "rest.txt"), {});
  EXPECT_EQ(in.log.samples.size(), 20u);
  ASSERT_EQ(in.notes.size(), 3u);  // accelerations, duplicates, wrench source
  EXPECT_EQ(in.notes[0], "dropped 1 duplicate rows");
}

TEST(StairSteps, ByVelocityOrByRunLength) {
  // Runs of repeats: rows 2-3 (moving: dropped), rows 6-7 (at rest: kept).
  const std::vector<bool> same = {false, false, true, true, false, false, true, true};
  EXPECT_EQ(stairSteps(same, {1, 1, 1, 1, 1, 0, 0, 0}),
            (std::vector<bool>{false, false, true, true, false, false, false, false}));
  // Unknown velocity: a run of kMaxStairRun repeats is stair steps, one more is rest.
  std::vector<bool> short_run(1 + kMaxStairRun, true), long_run(2 + kMaxStairRun, true);
  short_run[0] = long_run[0] = false;
  const auto a = stairSteps(short_run, std::vector<int>(short_run.size(), -1));
  const auto b = stairSteps(long_run, std::vector<int>(long_run.size(), -1));
  EXPECT_EQ(std::count(a.begin(), a.end(), true), static_cast<long>(kMaxStairRun));
  EXPECT_EQ(std::count(b.begin(), b.end(), true), 0);
}

TEST(UrRecord, ConfiguredPayloadIsAddedBackInBaseAxes) {
  // One row, TCP rotated 90 deg about z: the payload's centre of mass (0.1, 0, 0) in the TCP
  // frame is (0, 0.1, 0) in B; weight m g_B = (0, 0, -2 * 9.80665); moment c_B x f_B by hand.
  std::string text =
      "timestamp actual_TCP_pose_0 actual_TCP_pose_1 actual_TCP_pose_2 actual_TCP_pose_3 actual_TCP_pose_4 "
      "actual_TCP_pose_5 actual_TCP_force_0 actual_TCP_force_1 actual_TCP_force_2 actual_TCP_force_3 "
      "actual_TCP_force_4 actual_TCP_force_5\n";
  char row[200];
  std::snprintf(row, sizeof row, "1 0.5 0.1 0.3 0 0 %.17g 1 2 3 0.1 0.2 0.3\n2 0.5 0.1 0.31 0 0 %.17g 1 2 3 0.1 0.2 0.3\n",
                kPi / 2, kPi / 2);
  text += row;
  InputOptions o;
  o.ur_payload_mass_kg = 2.0;
  o.ur_payload_com_tcp_m = Vec3(0.1, 0.0, 0.0);
  const InputLog in = urRecordToLog(parseTable(text, "pose.txt"), o);
  EXPECT_FALSE(in.log.has_joints);
  EXPECT_GE(in.log.extraIndex("rz"), 0);  // a pose log: TCP = S
  const double mg = 2.0 * 9.80665;
  const Wrench& w = in.log.samples[0].wrench_S;
  EXPECT_NEAR(w[0], 1.0, 1e-12);
  EXPECT_NEAR(w[1], 2.0, 1e-12);
  EXPECT_NEAR(w[2], 3.0 - mg, 1e-12);
  EXPECT_NEAR(w[3], 0.1 + 0.1 * -mg, 1e-12);  // (c x f)_x = c_y f_z - c_z f_y
  EXPECT_NEAR(w[4], 0.2, 1e-12);
  EXPECT_NEAR(w[5], 0.3, 1e-12);
  // Without actual_TCP_force there is nothing to add it to: refused, naming what is needed.
  EXPECT_EQ(errorOf([&] { urRecordToLog(parseTable(urRecord(125.0, 5, 1, ' ', true, false), "j.txt"), o); }),
            "j.txt:1:1: --ur-payload needs actual_TCP_force_0..5 and actual_TCP_pose_0..5 in the recording");
}

TEST(UrRecord, Refusals) {
  EXPECT_EQ(errorOf([] { urRecordToLog(parseTable("timestamp actual_q_0 actual_q_1\n1 2 3\n", "p.txt"), {}); }),
            "p.txt:1:1: incomplete UR columns actual_q_0..actual_q_5, missing: actual_q_2, actual_q_3, actual_q_4, "
            "actual_q_5");
  std::string bad = "timestamp actual_q_0 actual_q_1 actual_q_2 actual_q_3 actual_q_4 actual_q_5\n"
                    "1 0 0 0 0 0 0\n0.5 1 0 0 0 0 0\n";
  EXPECT_EQ(errorOf([&] { urRecordToLog(parseTable(bad, "r.txt"), {}); }),
            "r.txt:3: column 'timestamp': time 0.5 is not greater than 1 on line 2 (timestamps must increase)");
  // Equal timestamps (ur_rtde's recorder can write a torn or repeated row): the last row of each
  // timestamp is kept and the drop reported; a decrease is still refused.
  const std::string torn = "timestamp actual_q_0 actual_q_1 actual_q_2 actual_q_3 actual_q_4 actual_q_5\n"
                           "1 0 0 0 0 0 0\n2 0.1 0 0 0 0 0\n2 0.2 0 0 0 0 0\n3 0.3 0 0 0 0 0\n4 0.4 0 0 0 0 0\n"
                           "4 0.5 0 0 0 0 0\n5 0.6 0 0 0 0 0\n";
  const InputLog in = urRecordToLog(parseTable(torn, "torn.txt"), {});
  ASSERT_EQ(in.log.samples.size(), 5U);
  EXPECT_EQ(in.log.samples[1].t, 2.0);
  EXPECT_EQ(in.log.samples[1].q[0], 0.2);
  EXPECT_EQ(in.log.samples[2].q[0], 0.3);
  EXPECT_EQ(in.log.samples[3].q[0], 0.5);
  EXPECT_NE(std::find_if(in.notes.begin(), in.notes.end(),
                         [](const std::string& n) { return n.find("dropped 2 rows whose timestamp equals") == 0; }),
            in.notes.end());
  EXPECT_EQ(errorOf([&] { urRecordToLog(parseTable(torn + "4.5 0 0 0 0 0 0\n", "d.txt"), {}); }),
            "d.txt:9: column 'timestamp': time 4.5 is not greater than 5 on line 8 (timestamps must increase)");
  // A jump in the positions: the differenced velocity and acceleration are refused, naming the line.
  std::string jump = "timestamp actual_q_0 actual_q_1 actual_q_2 actual_q_3 actual_q_4 actual_q_5\n";
  for (int i = 0; i < 20; ++i) jump += std::to_string(i * 0.00001) + (i == 10 ? " 12 0 0 0 0 0\n" : " 0 0 0 0 0 0\n");
  const std::string e = errorOf([&] { urRecordToLog(parseTable(jump, "jump.txt"), {}); });
  EXPECT_NE(e.find("from smoothed differences is"), std::string::npos) << e;
  EXPECT_EQ(e.rfind("jump.txt:", 0), 0U) << e;
  EXPECT_NE(e.find("outside the plausible range"), std::string::npos) << e;
  std::string huge = "timestamp actual_q_0 actual_q_1 actual_q_2 actual_q_3 actual_q_4 actual_q_5\n"
                     "1 0 0 0 0 0 0\n2 0 0 1e9 0 0 0\n";
  EXPECT_NE(errorOf([&] { urRecordToLog(parseTable(huge, "h.txt"), {}); }).find("h.txt:3: column 'actual_q_2': value 1e+09 is outside the plausible range"),
            std::string::npos);
}

TEST(ColumnNames, AliasesAndCase) {
  EXPECT_EQ(columnAlias("Fx"), "fx");
  EXPECT_EQ(columnAlias("force_y"), "fy");
  EXPECT_EQ(columnAlias("Torque Z [Nm]"), "tz");
  EXPECT_EQ(columnAlias("Tz (N-m)"), "tz");
  EXPECT_EQ(columnAlias("Tz (N\xc2\xb7m)"), "tz");
  EXPECT_EQ(columnAlias("Fx [N]"), "fx");
  EXPECT_EQ(columnAlias("Time [s]"), "t");
  EXPECT_EQ(columnAlias("comment [text]"), "");  // not a column ftid reads: its unit does not matter
  // Any other unit is refused, naming the column and the unit (no silent ms-as-s or lbf-as-N).
  const auto unitError = [](const char* name) {
    try {
      columnAlias(name);
    } catch (const DataError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(unitError("Time [ms]"), "column 'Time [ms]': unit 'ms' (ftid reads 't' in s only; convert the column or rename it)");
  EXPECT_NE(unitError("Fx [lbf]").find("column 'Fx [lbf]': unit 'lbf'"), std::string::npos);
  EXPECT_NE(unitError("Tz (N-mm)").find("column 'Tz (N-mm)': unit 'N-mm'"), std::string::npos);
  EXPECT_NE(unitError("Fz [kN]").find("unit 'kN'"), std::string::npos);
  EXPECT_EQ(columnAlias("Mx"), "tx");
  EXPECT_EQ(columnAlias("Tx"), "tx");
  EXPECT_EQ(columnAlias("TIME"), "t");
  EXPECT_EQ(columnAlias("timestamp"), "t");
  EXPECT_EQ(columnAlias("Q3"), "q3");
  EXPECT_EQ(columnAlias("actual_q_0"), "q1");
  EXPECT_EQ(columnAlias("actual_qd_5"), "qd6");
  EXPECT_EQ(columnAlias("target_qdd_2"), "qdd3");
  EXPECT_EQ(columnAlias("actual_q_6"), "");
  EXPECT_EQ(columnAlias("robot_current"), "");
}

TEST(ColumnNames, TheNativeReaderNamesTheFix) {
  const std::string header =
      "t,q1,q2,q3,q4,q5,q6,qd1,qd2,qd3,qd4,qd5,qd6,qdd1,qdd2,qdd3,qdd4,qdd5,qdd6,Fx,Fy,Fz,Tx,Ty,Tz\n";
  std::string row = "0";
  for (int i = 0; i < 24; ++i) row += ",0";
  const std::string msg = errorOf([&] { parseLogText(header + row + "\n", "caps.csv"); });
  EXPECT_EQ(msg.rfind("caps.csv:1:1: missing required wrench column(s): fx, fy, fz, tx, ty, tz (the header has 'Fx': "
                      "rename it to 'fx'; the header has 'Fy': rename it to 'fy';", 0),
            0u)
      << msg;
  const std::string force_x = "t,q1,q2,q3,q4,q5,q6,qd1,qd2,qd3,qd4,qd5,qd6,qdd1,qdd2,qdd3,qdd4,qdd5,qdd6,fx,fy,fz,tx,ty,"
                              "torque_z\n" + row + "\n";
  EXPECT_NE(errorOf([&] { parseLogText(force_x, "z.csv"); }).find("missing required wrench column(s): tz (the header has 'torque_z': rename it to 'tz'"),
            std::string::npos);
  // A UR recording given to the native reader says what it is and who reads it.
  EXPECT_NE(errorOf([] { parseLogText("timestamp actual_q_0\n1 2\n", "ur.txt"); }).find("this is a UR RTDE recording"),
            std::string::npos);
}

/// A sensor's recording: time `t0 + i / rate`, the wrench linear in time (interpolation is exact).
std::string wrenchCsv(double t0, double rate, int rows, const std::string& header = "time,Fx,Fy,Fz,Tx,Ty,Tz") {
  std::ostringstream s;
  s.precision(17);
  s << header << "\n";
  for (int i = 0; i < rows; ++i) {
    const double t = t0 + i / rate;
    s << t;
    for (int a = 0; a < 6; ++a) s << "," << (a + 1) * 0.5 + (a - 2.5) * t;
    s << "\n";
  }
  return s.str();
}

double wrenchAt(int a, double t) { return (a + 1) * 0.5 + (a - 2.5) * t; }

TEST(WrenchLog, ReadsCommonSpellingsAndRefusesWithTheHeaderShown) {
  const LogData w = wrenchLogFromTable(parseTable(wrenchCsv(0.0, 500.0, 10), "ft.csv"));
  EXPECT_EQ(w.samples.size(), 10u);
  EXPECT_DOUBLE_EQ(w.samples[3].wrench_S[4], wrenchAt(4, 3.0 / 500.0));
  const LogData w2 = wrenchLogFromTable(parseTable(wrenchCsv(0.0, 500.0, 3, "t,force_x,force_y,force_z,torque_x,torque_y,torque_z"), "ft.txt"));
  EXPECT_EQ(w2.samples.size(), 3u);
  EXPECT_EQ(errorOf([] { wrenchLogFromTable(parseTable("stamp_ms,Fx,Fy,Fz,Tx,Ty\n1,2,3,4,5,6\n", "ati.csv")); }),
            "ati.csv:1:1: a wrench log needs a time column (t, time or timestamp, in seconds) and the six wrench columns "
            "fx..tz (also Fx..Tz, Mx..Mz, force_x.., torque_x..); missing: t, tz (the header has: stamp_ms, Fx, Fy, Fz, "
            "Tx, Ty)");
  // Other columns may hold anything (a hex status, a date): only the used columns are parsed.
  const std::string extra = "time,status,Fx,Fy,Fz,Tx,Ty,Tz,date\n0.0,0x1F,1,2,3,4,5,6,2026-12-03\n"
                            "0.5,0xA0,2,3,4,5,6,7,2026-12-03\n";
  const LogData w3 = wrenchLogFromTable(parseTable(extra, "x.csv", TableSeparator::kAuto, wrenchLogUsesColumn));
  ASSERT_EQ(w3.samples.size(), 2U);
  EXPECT_EQ(w3.samples[1].t, 0.5);
  EXPECT_EQ(w3.samples[1].wrench_S[5], 7.0);
  // A used column still must be numeric, named with its line.
  EXPECT_NE(errorOf([&] { parseTable(extra + "1.0,0x00,oops,3,4,5,6,7,x\n", "x.csv", TableSeparator::kAuto, wrenchLogUsesColumn); })
                .find("x.csv:4:"),
            std::string::npos);
  EXPECT_EQ(errorOf([] { wrenchLogFromTable(parseTable("t,Fx,fx,Fy,Fz,Tx,Ty,Tz\n1,2,3,4,5,6,7,8\n", "d.csv")); }),
            "d.csv:1:6: columns 'Fx' and 'fx' both mean 'fx'; keep one");
  EXPECT_EQ(errorOf([] { wrenchLogFromTable(parseTable("t,Fx,Fy,Fz,Tx,Ty,Tz\n1,0,0,0,0,0,0\n1,0,0,0,0,0,0\n", "m.csv")); }),
            "m.csv:3: column 't': time 1 is not greater than the previous row's (times must increase)");
}

LogData jointLog(double t0, double rate, int rows) {
  LogData log;
  log.source = "robot.csv";
  log.has_wrench = false;
  for (int i = 0; i < rows; ++i) {
    LogSample s;
    s.t = t0 + i / rate;
    for (int j = 0; j < 6; ++j) {
      s.q[j] = 0.1 * j + 0.2 * s.t;  // linear: interpolation is exact
      s.qd[j] = 0.2;
    }
    log.samples.push_back(s);
  }
  return log;
}

TEST(WrenchLog, AlignedAtTheSlowerStreamsInstantsOverTheCommonSpan) {
  const LogData robot = jointLog(1.0, 125.0, 1001);                                          // 1 .. 9 s
  const LogData wrench = wrenchLogFromTable(parseTable(wrenchCsv(0.0011, 500.0, 6000), "ft.csv"));  // 0 .. 12 s
  std::vector<std::string> notes;
  const LogData a = alignWrench(robot, wrench, 0.0, notes);
  ASSERT_EQ(a.samples.size(), 1001u);  // every robot instant lies in the sensor's span
  for (std::size_t i = 0; i < a.samples.size(); ++i) {
    const double t = a.samples[i].t;
    EXPECT_EQ(t, robot.samples[i].t);
    for (int k = 0; k < 6; ++k) ASSERT_NEAR(a.samples[i].wrench_S[k], wrenchAt(k, t), 1e-9);
  }
  ASSERT_FALSE(notes.empty());
  EXPECT_NE(notes[0].find("1001 samples used"), std::string::npos) << notes[0];
  EXPECT_NE(notes[0].find("at the robot's instants"), std::string::npos) << notes[0];

  // A clock offset: the sensor's times shifted by +0.5 s first; still exact, span shrinks at the end.
  notes.clear();
  const LogData b = alignWrench(jointLog(1.0, 125.0, 1501), wrench, 0.5, notes);  // robot 1 .. 13 s
  EXPECT_NEAR(b.samples.back().t, 12.5011 - 1.0 / 500.0, 1.0 / 125.0);
  for (const LogSample& s : b.samples) ASSERT_NEAR(s.wrench_S[2], wrenchAt(2, s.t - 0.5), 1e-9);

  // The robot faster than the sensor: its joint state interpolated at the sensor's instants.
  notes.clear();
  const LogData fast_wrench = wrenchLogFromTable(parseTable(wrenchCsv(2.0031, 50.0, 100), "slow_ft.csv"));
  const LogData c = alignWrench(jointLog(1.0, 1000.0, 8001), fast_wrench, 0.0, notes);
  ASSERT_EQ(c.samples.size(), 100u);
  for (std::size_t i = 0; i < c.samples.size(); ++i) {
    EXPECT_EQ(c.samples[i].wrench_S, fast_wrench.samples[i].wrench_S);
    ASSERT_NEAR(c.samples[i].q[3], 0.3 + 0.2 * c.samples[i].t, 1e-12);
  }
  EXPECT_NE(notes[0].find("joint state interpolated linearly at the sensor's instants"), std::string::npos);

  // No common span: refused, naming both spans and the option for a known offset.
  EXPECT_NE(errorOf([&] { alignWrench(jointLog(100.0, 125.0, 10), wrench, 0.0, notes); }).find("no span in common"),
            std::string::npos);
}

TEST(WrenchLog, DropOutsOfTheFasterStreamAreLeftOut) {
  LogData wrench = wrenchLogFromTable(parseTable(wrenchCsv(0.0, 500.0, 6000), "ft.csv"));
  // A 0.1 s hole in the sensor's recording around t = 5 s.
  wrench.samples.erase(wrench.samples.begin() + 2475, wrench.samples.begin() + 2525);
  std::vector<std::string> notes;
  const LogData a = alignWrench(jointLog(1.0, 125.0, 1001), wrench, 0.0, notes);
  // The hole is 4.948 .. 5.050 s: robot instants 4.952, 4.960, .., 5.048 (13) fall inside it.
  EXPECT_EQ(a.samples.size(), 1001u - 13u);
  ASSERT_EQ(notes.size(), 2u);
  EXPECT_NE(notes[1].find("left out 13 samples"), std::string::npos) << notes[1];
}

TEST(ReadInput, UrRecordWithTheSensorsOwnFile) {
  const std::string rec = writeText("rec.txt", urRecord(125.0, 500, 1, ' ', true, false));  // 100 .. 104 s
  const std::string ft = writeText("ft.csv", wrenchCsv(99.0, 500.0, 4000));                 // 99 .. 107 s
  InputOptions o;
  EXPECT_NE(errorOf([&] { readInput(rec, o); }).find("give the sensor's own recording with --wrench-log FILE"),
            std::string::npos);
  o.wrench_log = ft;
  const InputLog in = readInput(rec, o);
  EXPECT_FALSE(in.wrench_in_base);
  EXPECT_EQ(in.log.samples.size(), 500u);
  EXPECT_NEAR(in.log.samples[7].wrench_S[1], wrenchAt(1, in.log.samples[7].t), 1e-9);
  // convert's round trip: what was read, written as a native log, reads back identically.
  const std::string out = tempPath("converted.csv");
  writeLog(out, in.log);
  const LogData back = readLog(out);
  ASSERT_EQ(back.samples.size(), in.log.samples.size());
  EXPECT_EQ(back.samples[100].qdd, in.log.samples[100].qdd);
  EXPECT_EQ(back.samples[100].wrench_S, in.log.samples[100].wrench_S);
  std::remove(rec.c_str());
  std::remove(ft.c_str());
  std::remove(out.c_str());
}

TEST(ReadInput, RepeatedPosesOfAPoseLogAreDropped) {
  std::string text = "t,px,py,pz,rx,ry,rz,fx,fy,fz,tx,ty,tz\n";
  for (int i = 0; i < 40; ++i) {
    const int state = i / 2;  // each pose recorded twice
    text += std::to_string(0.001 * i) + ",0.5,0,0.4,0,0," + std::to_string(0.01 * state) + ",0,0,1,0,0,0\n";
  }
  const std::string path = writeText("poses.csv", text);
  const InputLog in = readInput(path);
  EXPECT_EQ(in.log.samples.size(), 20u);
  ASSERT_EQ(in.notes.size(), 1u);
  EXPECT_NE(in.notes[0].find("dropped 20 of 40 rows whose pose repeats"), std::string::npos);
  std::remove(path.c_str());
  // A pose held for 30 rows is the robot at rest, not stair steps: kept.
  std::string rest = "t,px,py,pz,rx,ry,rz,fx,fy,fz,tx,ty,tz\n";
  for (int i = 0; i < 30; ++i) rest += std::to_string(0.001 * i) + ",0.5,0,0.4,0,0,0.3,0,0,1,0,0,0\n";
  const std::string rest_path = writeText("rest_poses.csv", rest);
  EXPECT_EQ(readInput(rest_path).log.samples.size(), 30u);
  std::remove(rest_path.c_str());
}

}  // namespace
}  // namespace ftid::logio
