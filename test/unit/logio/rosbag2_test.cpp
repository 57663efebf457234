// ROS 2 bags (docs/log-format.md "ROS 2 bags"): the checked-in fixtures of
// test/unit/logio/rosbag2/make_bags.py (an independent Python writer) and the CDR decoders on
// hand-made and damaged messages.
#include <sqlite3.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstdint>
#include <chrono>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "ftid/common/error.hpp"
#include "ftid/logio/cdr.hpp"
#include "ftid/logio/input.hpp"
#include "test_paths.hpp"

namespace ftid::logio {
namespace {

constexpr double kPi = 3.14159265358979323846;
const std::string kBags = ftid::test::sourcePath("/test/unit/logio/rosbag2/");

template <typename F>
std::string errorOf(F f) {
  try {
    f();
  } catch (const DataError& e) {
    return e.what();
  }
  return "";
}

// The fixtures' motion (make_bags.py): q_j(t) = 0.3 (j+1) sin(2 pi 0.7 t + j).
double qOf(int j, double t) { return 0.3 * (j + 1) * std::sin(2.0 * kPi * 0.7 * t + j); }
double qdOf(int j, double t) { return 0.3 * (j + 1) * 2.0 * kPi * 0.7 * std::cos(2.0 * kPi * 0.7 * t + j); }
double qddOf(int j, double t) { return -0.3 * (j + 1) * std::pow(2.0 * kPi * 0.7, 2) * std::sin(2.0 * kPi * 0.7 * t + j); }
double wrenchAt(int a, double t) { return (a + 1) * 0.5 + (a - 2.5) * t; }

/// The centred least-squares slope's gain on a sinusoid (docs/log-format.md "UR recordings").
double gain(double w, double dt, int h) {
  double num = 0.0, den = 0.0;
  for (int k = -h; k <= h; ++k) {
    num += k * std::sin(w * k * dt);
    den += k * k;
  }
  return num / (w * dt * den);
}

bool hasNote(const InputLog& in, const std::string& text) {
  for (const auto& n : in.notes) {
    if (n.find(text) != std::string::npos) return true;
  }
  return false;
}

TEST(Rosbag2, JointStatesByNameAndTheWrenchAlignedAtTheirInstants) {
  const InputLog in = readInput(kBags + "ur_ft");
  EXPECT_EQ(in.format, "rosbag2 (sqlite3)");
  EXPECT_TRUE(hasNote(in, "120 JointState messages on '/joint_states' (header stamps)"));
  EXPECT_TRUE(hasNote(in, "dropped 20 of 120 JointState messages whose joint state repeats"));
  EXPECT_TRUE(hasNote(in, "241 WrenchStamped messages on '/ft/wrench' in frame 'ft_frame'"));
  EXPECT_TRUE(hasNote(in, "100 samples used"));
  ASSERT_EQ(in.log.samples.size(), 100u);
  const double g = gain(2.0 * kPi * 0.7, 0.01, 3);
  for (std::size_t i = 0; i < in.log.samples.size(); ++i) {
    const LogSample& s = in.log.samples[i];
    const double t = static_cast<double>(i) / 100.0;  // t counts from the first state's whole second
    ASSERT_NEAR(s.t, t, 1e-9);
    for (int j = 0; j < 6; ++j) {
      ASSERT_NEAR(s.q[j], qOf(j, t), 1e-12) << "joint " << j;  // mapped by name, not by position
      ASSERT_NEAR(s.qd[j], qdOf(j, t), 1e-12);
      if (i >= 3 && i + 3 < in.log.samples.size()) {
        ASSERT_NEAR(s.qdd[j], g * qddOf(j, t), 1e-6) << i;
      }
    }
    for (int a = 0; a < 6; ++a) ASSERT_NEAR(s.wrench_S[a], wrenchAt(a, t), 1e-9);
  }
}

TEST(Rosbag2, ReceiveTimesWithoutStampsVelocitiesDifferencedAndTheWrenchTopicChosen) {
  InputOptions o;
  EXPECT_EQ(errorOf([&] { readInput(kBags + "no_velocity", o); }),
            kBags + "no_velocity: 2 topics of type geometry_msgs/msg/WrenchStamped: name one with --wrench-topic; the "
                    "bag has: /joint_states (sensor_msgs/msg/JointState), /ft/wrench (geometry_msgs/msg/WrenchStamped), "
                    "/ft/raw (geometry_msgs/msg/WrenchStamped)");
  for (const char* topic : {"/ft/wrench", "/ft/raw"}) {
    o.wrench_topic = topic;
    const InputLog in = readInput(kBags + "no_velocity", o);
    EXPECT_TRUE(hasNote(in, "the bag's receive times: the header stamps are zero"));
    EXPECT_TRUE(hasNote(in, "joint velocities from smoothed differences of the positions"));
    const double shift = std::string(topic) == "/ft/raw" ? 1.0 : 0.0;  // /ft/raw carries the wrench at t + 1
    ASSERT_EQ(in.log.samples.size(), 49u);  // 0.02 .. 0.98 s: inside the wrench's 0.003 .. 1.003 s
    const double g = gain(2.0 * kPi * 0.7, 0.02, 3);
    for (std::size_t i = 0; i < in.log.samples.size(); ++i) {
      const LogSample& s = in.log.samples[i];
      const double t = static_cast<double>(i + 1) / 50.0;
      ASSERT_NEAR(s.t, t, 1e-9);
      if (i >= 3 && i + 4 < in.log.samples.size()) {
        for (int j = 0; j < 6; ++j) ASSERT_NEAR(s.qd[j], g * qdOf(j, t), 1e-6) << i;
      }
      ASSERT_NEAR(s.wrench_S[2], wrenchAt(2, t + shift), 1e-6) << topic;  // receive times are whole ns
    }
  }
}

TEST(Rosbag2, RefusalsNameTheBagTopicAndFix) {
  InputOptions o;
  o.joint_topic = "/nope";
  EXPECT_EQ(errorOf([&] { readInput(kBags + "ur_ft", o); }),
            kBags + "ur_ft: no topic '/nope' (--joint-topic); the bag has: /joint_states (sensor_msgs/msg/JointState), "
                    "/ft/wrench (geometry_msgs/msg/WrenchStamped), /tf (tf2_msgs/msg/TFMessage)");
  o.joint_topic = "/ft/wrench";
  EXPECT_NE(errorOf([&] { readInput(kBags + "ur_ft", o); }).find("topic '/ft/wrench' is geometry_msgs/msg/WrenchStamped, not sensor_msgs/msg/JointState"),
            std::string::npos);
  EXPECT_NE(errorOf([&] { readInput(kBags + "mcap"); }).find("MCAP storage: ftid reads rosbag2 with sqlite3 storage"),
            std::string::npos);
  // A directory that is not a bag.
  EXPECT_NE(errorOf([&] { readInput(kBags); }).find("it is a directory, and not a rosbag2 bag"), std::string::npos);
  // A damaged storage file.
  const std::string dir = ftid::test::binaryPath("/rosbag2_damaged_") + std::to_string(::getpid());
  ASSERT_EQ(::system(("rm -rf " + dir + " && cp -r " + kBags + "ur_ft " + dir).c_str()), 0);
  std::ofstream(dir + "/ur_ft_0.db3", std::ios::trunc) << "this is not a database, just text that is long enough";
  EXPECT_NE(errorOf([&] { readInput(dir); }).find(dir + "/ur_ft_0.db3: not a rosbag2 sqlite3 file"), std::string::npos);
  // metadata.yaml pointing outside the bag.
  std::ofstream(dir + "/metadata.yaml", std::ios::trunc)
      << "rosbag2_bagfile_information:\n  storage_identifier: sqlite3\n  relative_file_paths:\n    - ../../etc/passwd\n";
  EXPECT_NE(errorOf([&] { readInput(dir); }).find("is not a file name inside the bag directory"), std::string::npos);
  ASSERT_EQ(::system(("rm -rf " + dir).c_str()), 0);
}

/// Runs `sql` on the storage file `db3` (read-write): the tests' way of crafting hostile bags.
void execSql(const std::string& db3, const char* sql) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(db3.c_str(), &db), SQLITE_OK);
  char* err = nullptr;
  const int rc = sqlite3_exec(db, sql, nullptr, nullptr, &err);
  EXPECT_EQ(rc, SQLITE_OK) << (err ? err : "");
  sqlite3_free(err);
  sqlite3_close(db);
}

TEST(Rosbag2, HostileStorageFilesAreRefusedQuickly) {
  const std::string dir = ftid::test::binaryPath("/rosbag2_hostile_") + std::to_string(::getpid());
  const std::string db3 = dir + "/ur_ft_0.db3";
  // `messages` as a recursive view: endless rows from a few bytes.
  ASSERT_EQ(::system(("rm -rf " + dir + " && cp -r " + kBags + "ur_ft " + dir).c_str()), 0);
  execSql(db3, "ALTER TABLE messages RENAME TO m0; CREATE VIEW messages AS WITH RECURSIVE r(i) AS "
               "(SELECT 1 UNION ALL SELECT i + 1 FROM r) SELECT i AS id, 1 AS topic_id, i AS timestamp, "
               "x'00' AS data FROM r;");
  auto t0 = std::chrono::steady_clock::now();
  std::string e = errorOf([&] { readInput(dir); });
  EXPECT_NE(e.find(db3 + ": 'messages' is a view (CREATE VIEW messages...), not a plain table"), std::string::npos) << e;
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 5.0);
  // `topics` as a view too.
  ASSERT_EQ(::system(("rm -rf " + dir + " && cp -r " + kBags + "ur_ft " + dir).c_str()), 0);
  execSql(db3, "ALTER TABLE topics RENAME TO t0; CREATE VIEW topics AS SELECT * FROM t0;");
  e = errorOf([&] { readInput(dir); });
  EXPECT_NE(e.find(db3 + ": 'topics' is a view"), std::string::npos) << e;
  // A stored value larger than 1 MiB: refused by the connection's length limit.
  ASSERT_EQ(::system(("rm -rf " + dir + " && cp -r " + kBags + "ur_ft " + dir).c_str()), 0);
  execSql(db3, "UPDATE messages SET data = zeroblob(2000000) WHERE id = (SELECT min(id) FROM messages);");
  e = errorOf([&] { readInput(dir); });
  EXPECT_NE(e.find(db3 + ": reading the messages table: string or blob too big"), std::string::npos) << e;
  // A compressed bag is refused, saying how to decompress it.
  std::ofstream(dir + "/metadata.yaml", std::ios::trunc)
      << "rosbag2_bagfile_information:\n  storage_identifier: sqlite3\n  compression_format: zstd\n"
         "  compression_mode: FILE\n  relative_file_paths:\n    - ur_ft_0.db3.zstd\n";
  e = errorOf([&] { readInput(dir); });
  EXPECT_NE(e.find("metadata.yaml: a compressed bag (compression_format 'zstd', compression_mode 'FILE')"),
            std::string::npos) << e;
  ASSERT_EQ(::system(("rm -rf " + dir).c_str()), 0);
}

/// A hand-made CDR message (little- or big-endian).
struct Writer {
  std::vector<std::uint8_t> b;
  bool little;
  explicit Writer(bool le) : b{0x00, static_cast<std::uint8_t>(le ? 0x01 : 0x00), 0, 0}, little(le) {}
  void align(std::size_t n) {
    while ((b.size() - 4) % n != 0) b.push_back(0);
  }
  void bytes(const void* p, std::size_t n) {
    std::uint8_t t[8];
    std::memcpy(t, p, n);
    if (!little) std::reverse(t, t + n);
    b.insert(b.end(), t, t + n);
  }
  void u32(std::uint32_t v) {
    align(4);
    bytes(&v, 4);
  }
  void f64(double v) {
    align(8);
    bytes(&v, 8);
  }
  void str(const std::string& s) {
    u32(static_cast<std::uint32_t>(s.size() + 1));
    b.insert(b.end(), s.begin(), s.end());
    b.push_back(0);
  }
};

std::vector<std::uint8_t> jointState(bool little) {
  Writer w(little);
  w.u32(12);
  w.u32(345);
  w.str("base");
  w.u32(2);
  w.str("a");
  w.str("wrist_3_joint");
  w.u32(2);
  w.f64(0.5);
  w.f64(-1.25);
  w.u32(0);  // no velocities
  w.u32(2);
  w.f64(1.0);
  w.f64(2.0);
  return w.b;
}

TEST(Cdr, DecodesBothByteOrders) {
  for (const bool little : {true, false}) {
    const auto bytes = jointState(little);
    const JointStateMsg m = decodeJointState(bytes.data(), bytes.size());
    EXPECT_EQ(m.stamp_sec, 12);
    EXPECT_EQ(m.stamp_nanosec, 345u);
    EXPECT_EQ(m.frame_id, "base");
    ASSERT_EQ(m.name.size(), 2u);
    EXPECT_EQ(m.name[1], "wrist_3_joint");
    EXPECT_EQ(m.position, (std::vector<double>{0.5, -1.25}));
    EXPECT_TRUE(m.velocity.empty());
    EXPECT_EQ(m.effort, (std::vector<double>{1.0, 2.0}));
  }
  Writer w(true);
  w.u32(1);
  w.u32(2);
  w.str("ft");
  for (int a = 0; a < 6; ++a) w.f64(a - 2.5);
  const WrenchStampedMsg m = decodeWrenchStamped(w.b.data(), w.b.size());
  EXPECT_EQ(m.frame_id, "ft");
  EXPECT_EQ(m.wrench[5], 2.5);
}

TEST(Cdr, EveryTruncationAndDamageIsADataError) {
  const auto bytes = jointState(true);
  for (std::size_t n = 0; n < bytes.size(); ++n) {
    const std::string e = errorOf([&] { decodeJointState(bytes.data(), n); });
    // A cut inside the last padding-free field is always detected: nothing decodes short.
    EXPECT_NE(e, "") << "truncated to " << n << " bytes";
  }
  auto bad = bytes;
  bad[1] = 0x03;  // not plain CDR
  EXPECT_EQ(errorOf([&] { decodeJointState(bad.data(), bad.size()); }),
            "CDR sensor_msgs/msg/JointState: encapsulation header at byte 0: not plain CDR (expected 00 00 or 00 01, "
            "found 00 03)");
  bad = bytes;
  bad[12] = 0xff;  // frame_id length 255 + ...: longer than the message
  bad[13] = 0xff;
  EXPECT_NE(errorOf([&] { decodeJointState(bad.data(), bad.size()); }).find("header.frame_id at byte 12: string of"),
            std::string::npos);
  bad = bytes;
  bad[24] = 0xff;  // name count (bytes 24..27, after "base\0" at 16..20 and padding) 255: more than 64
  EXPECT_EQ(errorOf([&] { decodeJointState(bad.data(), bad.size()); }),
            "CDR sensor_msgs/msg/JointState: name at byte 24: 255 elements (at most 64)");
  bad = bytes;
  bad[20] = 'X';  // the frame_id's NUL
  EXPECT_NE(errorOf([&] { decodeJointState(bad.data(), bad.size()); }).find("not terminated by NUL"), std::string::npos);
  auto longer = bytes;
  longer.resize(bytes.size() + 16, 0);
  EXPECT_NE(errorOf([&] { decodeJointState(longer.data(), longer.size()); }).find("bytes left after the message"),
            std::string::npos);
}

}  // namespace
}  // namespace ftid::logio
