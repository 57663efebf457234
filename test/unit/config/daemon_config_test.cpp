// ftidd configuration: defaults, the shipped config/ftidd.yaml, and every validation error
// naming the key and the file (and the line where the key is).
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>

#include "ftid/common/error.hpp"
#include "ftid/config/daemon_config.hpp"
#include "test_paths.hpp"

namespace ftid::config {
namespace {

// A minimal valid config: the two files that must exist point into a temp dir.
class DaemonConfigTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = ::testing::TempDir() + "ftid_cfg_" + std::to_string(::getpid());
    std::system(("mkdir -p '" + dir_ + "'").c_str());
    std::ofstream(dir_ + "/robot.urdf") << "<robot name='r'/>";
    std::ofstream(dir_ + "/sensor.dbc") << "VERSION \"\"";
  }
  void TearDown() override { std::system(("rm -rf '" + dir_ + "'").c_str()); }

  std::string base() const {
    return "robot:\n  urdf_path: robot.urdf\nsensor:\n  dbc_path: sensor.dbc\n";
  }
  DaemonConfig parse(const std::string& extra) const {
    return parseDaemonConfig(base() + extra, "test.yaml", dir_);
  }
  // Expects a ConfigError mentioning the file, the key and (if > 0) the line.
  void expectError(const std::string& yaml, const std::string& key, int line,
                   const std::string& also = "") const {
    try {
      parseDaemonConfig(yaml, "test.yaml", dir_);
      ADD_FAILURE() << "no ConfigError for key " << key;
    } catch (const ConfigError& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find("test.yaml"), std::string::npos) << msg;
      EXPECT_NE(msg.find("'" + key + "'"), std::string::npos) << msg;
      if (line > 0) {
        EXPECT_NE(msg.find("test.yaml:" + std::to_string(line) + ":"), std::string::npos) << msg;
      }
      if (!also.empty()) {
        EXPECT_NE(msg.find(also), std::string::npos) << msg;
      }
    }
  }
  std::string dir_;
};

TEST_F(DaemonConfigTest, DefaultsWithRequiredFilesAreValid) {
  const DaemonConfig c = parse("");
  EXPECT_EQ(c.robot.host, "127.0.0.1");
  EXPECT_EQ(c.robot.rtde_port, 30004);
  EXPECT_EQ(c.robot.urdf_path, dir_ + "/robot.urdf");  // relative to the config file
  EXPECT_EQ(c.sensor.dbc_path, dir_ + "/sensor.dbc");
  EXPECT_EQ(c.lcm.url, "udpm://239.255.76.67:7667?ttl=0");
  EXPECT_EQ(c.lcm.channels.wrench, "FTID_WRENCH");
  EXPECT_FALSE(c.rt.require_rt);
  EXPECT_EQ(c.robot.receiveTimeout().count(), 12000);  // 1.5 periods at 125 Hz
  EXPECT_TRUE(c.sensor.R_FS().isApprox(Mat3::Identity()));
}

TEST_F(DaemonConfigTest, ReadsEveryKey) {
  const DaemonConfig c = parse(
      "  transport: socketcan\n  can_interface: can1\n  stale_timeout_ms: 5\n"
      "  mount_xyz: [0, 0, 0.05]\n  mount_rpy: [0, 0, 1.5707963267948966]\n  motion_source: imu\n"
      "parameters:\n  path: p.yaml\n  required: false\n"
      "lcm:\n  url: memq://\n  publish_cycle: false\n  stats_period_s: 2\n"
      "  channels:\n    wrench: MY_WRENCH\n    cycle: MY_CYCLE\n"
      "rt:\n  require_rt: true\n  priority: 70\n  cpu: 1\n  lock_memory: false\n  overrun_budget_ms: 3\n"
      "record:\n  enabled: true\n  path: rec-%Y.lcm\n");
  EXPECT_EQ(c.sensor.transport, "socketcan");
  EXPECT_EQ(c.sensor.can_interface, "can1");
  EXPECT_EQ(c.sensor.stale_timeout_ms, 5.0);
  EXPECT_EQ(c.sensor.motion_source, "imu");
  EXPECT_EQ(c.sensor.p_FS_F(), Vec3(0, 0, 0.05));
  EXPECT_TRUE((c.sensor.R_FS() * Vec3::UnitX()).isApprox(Vec3::UnitY(), 1e-12));  // yaw 90 deg
  EXPECT_EQ(c.parameters.path, dir_ + "/p.yaml");
  EXPECT_EQ(c.lcm.url, "memq://");
  EXPECT_FALSE(c.lcm.publish_cycle);
  EXPECT_EQ(c.lcm.channels.wrench, "MY_WRENCH");
  EXPECT_EQ(c.lcm.channels.cycle, "MY_CYCLE");
  EXPECT_EQ(c.lcm.channels.stats, "FTID_STATS");
  EXPECT_TRUE(c.rt.require_rt);
  EXPECT_EQ(c.rt.priority, 70);
  EXPECT_EQ(c.rt.cpu, 1);
  EXPECT_FALSE(c.rt.lock_memory);
  EXPECT_TRUE(c.record.enabled);
  EXPECT_EQ(c.record.path, dir_ + "/rec-%Y.lcm");
}

TEST_F(DaemonConfigTest, UnknownKeysNameKeyFileAndLine) {
  expectError(base() + "robto:\n  host: x\n", "robto", 5, "unknown key");
  expectError(base() + "  stale_timeout: 3\n", "sensor.stale_timeout", 5, "stale_timeout_ms");
  expectError(base() + "lcm:\n  channels:\n    wrenches: X\n", "lcm.channels.wrenches", 7);
}

TEST_F(DaemonConfigTest, WrongTypesNameTheKey) {
  expectError(base() + "rt:\n  priority: high\n", "rt.priority", 6, "integer");
  expectError(base() + "rt:\n  require_rt: maybe\n", "rt.require_rt", 6, "true or false");
  expectError(base() + "  stale_timeout_ms: nan\n", "sensor.stale_timeout_ms", 5, "finite");
  expectError(base() + "  mount_xyz: [1, 2]\n", "sensor.mount_xyz", 5, "3 numbers");
  expectError(base() + "lcm:\n  url:\n", "lcm.url", 6, "no value");
  expectError(base() + "robot: 3\n", "robot", 5);
}

TEST_F(DaemonConfigTest, BadValuesNameKeyFileAndLine) {
  expectError("robot:\n  urdf_path: robot.urdf\n  rtde_port: 70000\nsensor:\n  dbc_path: sensor.dbc\n",
              "robot.rtde_port", 3, "1..65535");
  expectError("robot:\n  urdf_path: robot.urdf\n  rtde_frequency_hz: 1000\nsensor:\n  dbc_path: sensor.dbc\n",
              "robot.rtde_frequency_hz", 3, "1..500");
  expectError(base() + "  transport: usb\n", "sensor.transport", 5, "seqpacket");
  expectError(base() + "  stale_timeout_ms: 0\n", "sensor.stale_timeout_ms", 5);
  expectError(base() + "  motion_source: gyro\n", "sensor.motion_source", 5, "'kinematics' or 'imu'");
  expectError(base() + "  can_interface: a_very_long_interface_name\n  transport: socketcan\n",
              "sensor.can_interface", 5);
  expectError(base() + "rt:\n  priority: 100\n", "rt.priority", 6, "1..99");
  expectError(base() + "rt:\n  cpu: -2\n", "rt.cpu", 6);
  expectError(base() + "lcm:\n  url: http://x\n", "lcm.url", 6);
  expectError(base() + "lcm:\n  channels:\n    wrench: 'BAD CHANNEL'\n", "lcm.channels.wrench", 7);
  expectError(base() + "lcm:\n  channels:\n    stats: FTID_WRENCH\n", "lcm.channels.stats", 0,
              "same channel");
  expectError(base() + "lcm:\n  stats_period_s: 0\n", "lcm.stats_period_s", 6);
  expectError(base() + "parameters:\n  path: missing.yaml\n  required: true\n", "parameters.path", 6,
              "missing.yaml");
  expectError(base() + "record:\n  enabled: true\n  path: /no/such/dir/x.lcm\n", "record.path", 7,
              "/no/such/dir");
}

// Link loss and reconnect (docs/operations.md): defaults, every key read, the bounds named.
TEST_F(DaemonConfigTest, ReconnectKeys) {
  const DaemonConfig d = parse("");
  EXPECT_EQ(d.robot.watchdog_silence_s, 0.0);  // never: the watchdog watches the threads
  EXPECT_EQ(d.robot.reconnect_after_silence_s, 5.0);
  EXPECT_EQ(d.robot.reconnect_backoff_min_s, 0.2);
  EXPECT_EQ(d.robot.reconnect_backoff_max_s, 5.0);
  const std::string robot = "robot:\n  urdf_path: robot.urdf\n";
  const std::string sensor = "sensor:\n  dbc_path: sensor.dbc\n";
  const DaemonConfig c = parseDaemonConfig(
      robot + "  watchdog_silence_s: 30\n  reconnect_after_silence_s: 0\n"
              "  reconnect_backoff_min_s: 0.5\n  reconnect_backoff_max_s: 8\n" + sensor,
      "test.yaml", dir_);
  EXPECT_EQ(c.robot.watchdog_silence_s, 30.0);
  EXPECT_EQ(c.robot.reconnect_after_silence_s, 0.0);
  EXPECT_EQ(c.robot.reconnect_backoff_min_s, 0.5);
  EXPECT_EQ(c.robot.reconnect_backoff_max_s, 8.0);
  expectError(robot + "  watchdog_silence_s: 0.05\n" + sensor, "robot.watchdog_silence_s", 3, "0 (never)");
  expectError(robot + "  reconnect_after_silence_s: -1\n" + sensor, "robot.reconnect_after_silence_s", 3);
  expectError(robot + "  reconnect_backoff_min_s: 0\n" + sensor, "robot.reconnect_backoff_min_s", 3, "0.01..60");
  expectError(robot + "  reconnect_backoff_min_s: 2\n  reconnect_backoff_max_s: 1\n" + sensor,
              "robot.reconnect_backoff_max_s", 4, "reconnect_backoff_min_s..300");
}

// The exact position: FILE:LINE:COLUMN of the value, then the full key path.
TEST_F(DaemonConfigTest, ErrorsNameLineColumnAndFullKey) {
  const std::string robot = "robot:\n  urdf_path: robot.urdf\n";
  const std::string sensor = "sensor:\n  dbc_path: sensor.dbc\n";
  expectError(robot + "  reconnect_backoff_min_s: 2\n  reconnect_backoff_max_s: 1\n" + sensor,
              "robot.reconnect_backoff_max_s", 4,
              "test.yaml:4:28: key 'robot.reconnect_backoff_max_s': must be in robot.reconnect_backoff_min_s..300 s");
  expectError(robot + "  rtde_port: 3e4\n" + sensor, "robot.rtde_port", 3,
              "test.yaml:3:14: key 'robot.rtde_port': expected an integer, got '3e4'");
  expectError(base() + "export:\n  adapter:\n    com: [0, 0, x]\n", "export.adapter.com[2]", 7,
              "test.yaml:7:17: key 'export.adapter.com[2]': expected a number, got 'x'");
  expectError(base() + "  mount_rpy: [0, 0, 7]\n", "sensor.mount_rpy", 5, "test.yaml:5:14: key 'sensor.mount_rpy': must be");
}

TEST_F(DaemonConfigTest, MissingFilesNameTheKey) {
  expectError("robot:\n  urdf_path: nope.urdf\nsensor:\n  dbc_path: sensor.dbc\n", "robot.urdf_path", 2,
              "nope.urdf");
  expectError("robot:\n  urdf_path: robot.urdf\nsensor:\n  dbc_path: nope.dbc\n", "sensor.dbc_path", 4,
              "nope.dbc");
}

TEST_F(DaemonConfigTest, SyntaxErrorsAndUnreadableFilesNameTheFile) {
  try {
    parseDaemonConfig("robot: [unclosed\n", "test.yaml", dir_);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("test.yaml:"), std::string::npos) << e.what();
  }
  try {
    loadDaemonConfig(dir_ + "/none.yaml");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("none.yaml"), std::string::npos) << e.what();
  }
}

// Issue 14: duplicate keys used to take the last value silently.
TEST_F(DaemonConfigTest, DuplicateKeysAreErrors) {
  try {
    parseDaemonConfig(base() + "rt:\n  priority: 10\n  priority: 90\n", "test.yaml", dir_);
    FAIL();
  } catch (const ConfigError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("test.yaml:7: duplicate key 'priority' (first on line 6)"), std::string::npos) << msg;
  }
  EXPECT_THROW(parseDaemonConfig(base() + "robot:\n  host: 10.0.0.2\n", "test.yaml", dir_), ConfigError);
}

// Issue 14: a garbage LCM URL passed --check-config, ttl=255 passed without a warning.
TEST_F(DaemonConfigTest, LcmUrlIsValidated) {
  expectError(base() + "lcm:\n  url: udpm://garbage\n", "lcm.url", 6, "ADDRESS:PORT");
  expectError(base() + "lcm:\n  url: udpm://10.1.2.3:7667\n", "lcm.url", 6, "not a multicast address");
  expectError(base() + "lcm:\n  url: udpm://239.255.76.67:0\n", "lcm.url", 6, "1..65535");
  expectError(base() + "lcm:\n  url: udpm://239.255.76.67:99999\n", "lcm.url", 6, "1..65535");
  expectError(base() + "lcm:\n  url: udpm://239.255.76.67:7667?ttl=256\n", "lcm.url", 6, "0..255");
  expectError(base() + "lcm:\n  url: udpm://239.255.76.67:7667?ttl=-1\n", "lcm.url", 6, "0..255");
  expectError(base() + "lcm:\n  url: udpm://239.255.76.67:7667?tll=0\n", "lcm.url", 6, "unknown udpm option 'tll'");
  expectError(base() + "lcm:\n  url: udpm://300.1.1.1:7667\n", "lcm.url", 6, "not an IPv4 address");
  expectError(base() + "lcm:\n  url: memq://x\n", "lcm.url", 6);
  EXPECT_TRUE(parse("lcm:\n  url: udpm://239.255.76.67:7667?ttl=1&recv_buf_size=2097152\n").warnings.empty());
  const DaemonConfig c = parse("lcm:\n  url: udpm://239.255.76.67:7667?ttl=255\n");
  ASSERT_EQ(c.warnings.size(), 1u);
  EXPECT_NE(c.warnings[0].find("test.yaml:6"), std::string::npos) << c.warnings[0];
  EXPECT_NE(c.warnings[0].find("ttl=255"), std::string::npos) << c.warnings[0];
  EXPECT_TRUE(parse("").warnings.empty()) << "the default URL (ttl=0) gives no warning";
}

// Issue 14: a FIFO or a directory as config or parameter file hung or gave no file name.
TEST_F(DaemonConfigTest, FifoAndDirectoryAreRefusedWithoutBlocking) {
  const std::string fifo = dir_ + "/cfg.fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  try {
    loadDaemonConfig(fifo);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(fifo + ": cannot read the config file: it is a FIFO"), std::string::npos)
        << e.what();
  }
  try {
    loadDaemonConfig(dir_);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("it is a directory"), std::string::npos) << e.what();
  }
  expectError(base() + "parameters:\n  path: cfg.fifo\n  required: true\n", "parameters.path", 6, "cfg.fifo");
}

TEST(DaemonConfigFile, ShippedConfigIsValid) {
  const DaemonConfig c = loadDaemonConfig(ftid::test::sourcePath("/config/ftidd.yaml"));
  EXPECT_EQ(c.lcm.url, "udpm://239.255.76.67:7667?ttl=0");
  EXPECT_NE(describeDaemonConfig(c).find("lcm.url"), std::string::npos);
  EXPECT_TRUE(c.warnings.empty());
}

}  // namespace
}  // namespace ftid::config

namespace ftid::config {
namespace {

class MonitorConfigTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = ::testing::TempDir() + "ftid_monitor_cfg_" + std::to_string(::getpid());
    std::system(("mkdir -p '" + dir_ + "'").c_str());
    std::ofstream(dir_ + "/robot.urdf") << "<robot name='r'/>";
    std::ofstream(dir_ + "/sensor.dbc") << "VERSION \"\"";
  }
  void TearDown() override { std::system(("rm -rf '" + dir_ + "'").c_str()); }
  DaemonConfig parse(const std::string& extra) const {
    return parseDaemonConfig("robot:\n  urdf_path: robot.urdf\nsensor:\n  dbc_path: sensor.dbc\n" + extra,
                             "test.yaml", dir_);
  }
  std::string dir_;
};

TEST_F(MonitorConfigTest, ReadsTheSectionAndKeepsDefaults) {
  const DaemonConfig d = parse("");
  EXPECT_TRUE(d.monitor.enabled);
  EXPECT_EQ(d.monitor.channel, "FTID_MONITOR");
  const DaemonConfig c = parse(
      "monitor:\n  enabled: false\n  channel: CELL_MONITOR\n  publish_hz: 10\n"
      "  noise_std: [0.5, 0.5, 0.6, 0.05, 0.05, 0.04]\n  decision_threshold: 20\n  restart_s: 2\n"
      "  free_motion_turn_rad_s: 0.1\n");
  EXPECT_FALSE(c.monitor.enabled);
  EXPECT_EQ(c.monitor.channel, "CELL_MONITOR");
  EXPECT_EQ(c.monitor.publish_hz, 10.0);
  EXPECT_EQ(c.monitor.noise_std(2), 0.6);
  EXPECT_EQ(c.monitor.decision_threshold, 20.0);
  EXPECT_EQ(c.monitor.restart_s, 2.0);
  EXPECT_EQ(c.monitor.free_motion_turn_rad_s, 0.1);
}

TEST_F(MonitorConfigTest, BadValuesNameTheKeyAndLine) {
  const auto expectError = [&](const std::string& extra, const std::string& key) {
    try {
      parse(extra);
      ADD_FAILURE() << "accepted " << extra;
    } catch (const ConfigError& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find("test.yaml:6"), std::string::npos) << msg;
      EXPECT_NE(msg.find("'" + key + "'"), std::string::npos) << msg;
    }
  };
  expectError("monitor:\n  publish_hz: 1\n", "monitor.publish_hz");
  expectError("monitor:\n  decision_threshold: 0\n", "monitor.decision_threshold");
  expectError("monitor:\n  noise_std: [0.3, 0.3, 0, 0.03, 0.03, 0.03]\n", "monitor.noise_std");
  expectError("monitor:\n  channel: 'A B'\n", "monitor.channel");
  expectError("monitor:\n  onset_margin: -1\n", "monitor.onset_margin");
  EXPECT_THROW(parse("monitor:\n  window: 3\n"), ConfigError);  // unknown key
}

// Issue 26, item 6: the configuration gaps an unlucky operator hit, each refused naming the key
// and its line; and the silence limit follows the rate.
TEST_F(DaemonConfigTest, HostsRatesRecordPathsAndUrlsAreValidatedStrictly) {
  const std::string sensor = "sensor:\n  dbc_path: sensor.dbc\n";
  expectError("robot:\n  urdf_path: robot.urdf\n  host: 999.1.1.1\n" + sensor, "robot.host", 3, "IPv4");
  expectError("robot:\n  urdf_path: robot.urdf\n  host: -bad-.example\n" + sensor, "robot.host", 3);
  expectError("robot:\n  urdf_path: robot.urdf\n  host: 'a b'\n" + sensor, "robot.host", 3);
  for (const char* ok : {"192.168.1.10", "ur10-cell.local", "::1", "controller"}) {
    const DaemonConfig c = parseDaemonConfig(std::string("robot:\n  urdf_path: robot.urdf\n  host: '") + ok + "'\n" + sensor,
                                             "test.yaml", dir_);
    EXPECT_EQ(c.robot.host, ok);
  }
  expectError("robot:\n  urdf_path: robot.urdf\n  rtde_frequency_hz: 125.5\n" + sensor, "robot.rtde_frequency_hz", 3,
              "500 / n");
  expectError("robot:\n  urdf_path: robot.urdf\n  rtde_frequency_hz: 300\n" + sensor, "robot.rtde_frequency_hz", 3);
  for (const double ok : {500.0, 250.0, 125.0, 62.5, 100.0, 1.0}) {
    const DaemonConfig c = parseDaemonConfig(
        "robot:\n  urdf_path: robot.urdf\n  rtde_frequency_hz: " + std::to_string(ok) + "\n" + sensor, "test.yaml", dir_);
    EXPECT_EQ(c.robot.rtde_frequency_hz, ok);
  }
  expectError(base() + "record:\n  enabled: true\n  path: /proc/self/mem\n", "record.path", 7, "/proc");
  expectError(base() + "record:\n  enabled: true\n  path: /dev/null\n", "record.path", 7, "/dev");
  expectError(base() + "record:\n  enabled: true\n  path: /sys/kernel/x.lcm\n", "record.path", 7);
  expectError(base() + "record:\n  enabled: true\n  path: " + dir_ + "\n", "record.path", 7);  // a directory
  EXPECT_TRUE(parse("record:\n  enabled: true\n  path: rec.lcm\n").record.enabled);
  expectError(base() + "lcm:\n  url: file:///dev/sda\n", "lcm.url", 0, "network provider");
}

// Loading ftidd.yaml must not depend on who loads it (ftid tare, export, compensate run as an
// operator): a record directory the caller cannot write is not a config error; ftidd checks it
// at start as its own user (recordDirWritableProblem, called by the daemon set-up).
TEST_F(DaemonConfigTest, RecordDirWritabilityIsNotPartOfValidation) {
  const std::string ro = dir_ + "/ro";
  ASSERT_EQ(::mkdir(ro.c_str(), 0755), 0);
  ASSERT_EQ(::chmod(ro.c_str(), 0555), 0);
  ASSERT_EQ(::chmod(dir_.c_str(), 0755), 0);
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {  // child: as an unprivileged user (root may write anywhere)
    if (::geteuid() == 0 && (::setgid(65534) != 0 || ::setuid(65534) != 0)) ::_exit(10);
    int code = 0;
    try {
      const DaemonConfig c = parse("record:\n  enabled: true\n  path: ro/rec.lcm\n");
      if (!c.record.enabled) code = 11;
    } catch (const std::exception&) {
      code = 12;  // validation refused a directory only this caller cannot write
    }
    const std::string problem = recordDirWritableProblem(ro + "/rec.lcm");
    if (code == 0 && problem.find("not writable") == std::string::npos) code = 13;
    ::_exit(code);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "10 setuid failed, 12 validation checked writability, 13 no start check";
  EXPECT_EQ(recordDirWritableProblem(dir_ + "/rec.lcm"), "");
  ::chmod(ro.c_str(), 0755);
}

TEST_F(DaemonConfigTest, TheSilenceLimitFollowsTheRate) {
  EXPECT_EQ(parse("").robot.silent_publish_after_ms, 50.0);  // 125 Hz: 50 ms > 3 periods
  const DaemonConfig slow = parseDaemonConfig("robot:\n  urdf_path: robot.urdf\n  rtde_frequency_hz: 1\n"
                                              "sensor:\n  dbc_path: sensor.dbc\n", "test.yaml", dir_);
  EXPECT_EQ(slow.robot.silent_publish_after_ms, 3000.0);  // 3 periods at 1 Hz
  expectError("robot:\n  urdf_path: robot.urdf\n  rtde_frequency_hz: 1\n  silent_publish_after_ms: 50\n"
              "sensor:\n  dbc_path: sensor.dbc\n", "robot.silent_publish_after_ms", 4, "1.5 robot periods");
}

}  // namespace
}  // namespace ftid::config
