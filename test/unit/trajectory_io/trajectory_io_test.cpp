// Trajectory YAML round trip, reader errors naming file and key, CSV read back by the log reader.
#include "ftid/trajectory/trajectory_io.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <sys/stat.h>

#include <filesystem>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include "ftid/common/error.hpp"
#include "ftid/logio/log.hpp"

namespace ftid::trajectory {
namespace {

std::string tempPrefix() { return "ftid_trajio_" + std::to_string(::getpid()) + "_"; }

std::string tempPath(const std::string& name) {
  return std::string(::testing::TempDir()) + "/" + tempPrefix() + name;
}

/// Removes every file this process created under the temp dir (tempPath names, and the CSV and
/// temporary files derived from them) when the test program ends.
class RemoveTempFiles : public ::testing::Environment {
 public:
  void TearDown() override {
    std::error_code ec;
    const std::string prefix = tempPrefix();
    for (const auto& e : std::filesystem::directory_iterator(::testing::TempDir(), ec)) {
      if (e.path().filename().string().rfind(prefix, 0) == 0) std::filesystem::remove(e.path(), ec);
    }
  }
};
[[maybe_unused]] ::testing::Environment* const g_remove_temp_files =
    ::testing::AddGlobalTestEnvironment(new RemoveTempFiles);

std::string readText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void writeText(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
}

/// A rest-to-rest file with awkward (non-terminating binary) numbers everywhere.
TrajectoryFile sampleFile() {
  TrajectoryFile f;
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  f.q0 << 0.1, -1.5707963267948966, 1.5707963267948966, -1.2345678901234567, -1.5707963267948966,
      1e-17;
  f.base_frequency_hz = 1.0 / 7.0;
  f.harmonics = 4;
  f.duration_s = 7.0;
  f.joints = {4, 5, 6};
  for (int j = 3; j < 6; ++j) {
    double sa = 0.0, slb = 0.0;
    for (int l = 1; l < f.harmonics; ++l) {
      f.a[j][l] = u(rng) / 3.0;
      f.b[j][l] = u(rng) / 3.0;
      sa += f.a[j][l];
      slb += (l + 1) * f.b[j][l];
    }
    f.a[j][0] = -sa;
    f.b[j][0] = -slb;
  }
  f.servo_rate_hz = 500.0;
  f.robot = "config/ur10e.urdf";
  f.constraints.velocity = JointVector::Constant(1.0 / 3.0);
  f.constraints.acceleration << 1, 2, 3, 4, 5, 6.5;
  f.constraints.floor_z_B = -0.123456789;
  f.constraints.keep_out = {{"robot base", Vec3(0.0, 0.0, 0.1), 0.25},
                            {"pillar \"A\"", Vec3(0.5, -0.3, 1.0), 0.1}};
  f.constraints.tool = {{Vec3(0.0, 0.0, 0.05), 0.08}, {Vec3(0.01, 0.0, 0.15), 0.03}};
  f.constraints.R_FS = Eigen::AngleAxisd(0.3, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  f.constraints.p_FS_F = Vec3(0.0, 0.0, 0.0375);
  f.design = {
      {"model", "paper"}, {"seed", "7"}, {"reproduce", "ftid design --seed 7: a \"quoted\" note"}};
  f.metrics = {{"condition_number", 3.3333333333333335}, {"elapsed_s", 12.5}};
  f.predicted_std = {{"mass", 1.2345e-4}, {"com_x", 2.0 / 3.0 * 1e-4}};
  return f;
}

TEST(TrajectoryIo, RobotBesideTheFileIsStoredRelativeToTheFile) {
  TrajectoryFile f = sampleFile();
  const std::string path = tempPath("rel.yaml");
  f.robot = (std::filesystem::path(path).parent_path() / "robots" / "arm.urdf").string();
  writeTrajectoryFile(path, f);
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_NE(text.str().find("robot: \"robots/arm.urdf\""), std::string::npos) << text.str();
  EXPECT_EQ(readTrajectoryFile(path).robot, std::filesystem::path(f.robot).lexically_normal().string());
  std::remove(path.c_str());
}

TEST(TrajectoryIo, YamlRoundTripIsExact) {
  const TrajectoryFile f = sampleFile();
  const std::string path = tempPath("rt.yaml");
  writeTrajectoryFile(path, f);
  const TrajectoryFile g = readTrajectoryFile(path);
  EXPECT_EQ(g.q0, f.q0);
  EXPECT_EQ(g.base_frequency_hz, f.base_frequency_hz);
  EXPECT_EQ(g.harmonics, f.harmonics);
  EXPECT_EQ(g.duration_s, f.duration_s);
  EXPECT_EQ(g.joints, f.joints);
  EXPECT_EQ(g.a, f.a);
  EXPECT_EQ(g.b, f.b);
  EXPECT_EQ(g.servo_rate_hz, f.servo_rate_hz);
  // The robot is a path relative to the working directory in memory; the file stores it
  // relative to itself or absolute (here: absolute), and reading gives the resolved path.
  EXPECT_EQ(g.robot, std::filesystem::absolute(f.robot).lexically_normal().string());
  EXPECT_EQ(g.constraints.position_lower, f.constraints.position_lower);
  EXPECT_EQ(g.constraints.position_upper, f.constraints.position_upper);
  EXPECT_EQ(g.constraints.velocity, f.constraints.velocity);
  EXPECT_EQ(g.constraints.acceleration, f.constraints.acceleration);
  EXPECT_EQ(g.constraints.floor_z_B, f.constraints.floor_z_B);
  ASSERT_EQ(g.constraints.keep_out.size(), 2u);
  EXPECT_EQ(g.constraints.keep_out[1].name, "pillar \"A\"");
  EXPECT_EQ(g.constraints.keep_out[1].center_B, f.constraints.keep_out[1].center_B);
  EXPECT_EQ(g.constraints.keep_out[1].radius, f.constraints.keep_out[1].radius);
  ASSERT_EQ(g.constraints.tool.size(), 2u);
  EXPECT_EQ(g.constraints.tool[1].center_S, f.constraints.tool[1].center_S);
  EXPECT_EQ(g.constraints.R_FS, f.constraints.R_FS);
  EXPECT_EQ(g.constraints.p_FS_F, f.constraints.p_FS_F);
  EXPECT_EQ(g.design, f.design);
  EXPECT_EQ(g.metrics, f.metrics);
  EXPECT_EQ(g.predicted_std, f.predicted_std);
  // Same trajectory, bit for bit.
  const auto ta = f.toTrajectory(), tb = g.toTrajectory();
  for (double t : {0.0, 1.234, 3.5, 7.0}) {
    EXPECT_EQ(ta.evaluate(t).q, tb.evaluate(t).q);
  }
  // Writing again gives the same text (stable format) and leaves no temporary file behind.
  const std::string path2 = tempPath("rt2.yaml");
  writeTrajectoryFile(path2, g);
  EXPECT_EQ(readText(path), readText(path2));
  EXPECT_FALSE(std::ifstream(path + ".tmp." + std::to_string(::getpid())).good());
}

void expectConfigError(const std::string& text, const std::string& needle) {
  const std::string path = tempPath("bad.yaml");
  writeText(path, text);
  try {
    (void)readTrajectoryFile(path);
    FAIL() << "expected ConfigError containing '" << needle << "'";
  } catch (const ConfigError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(path), std::string::npos) << msg;
    EXPECT_NE(msg.find(needle), std::string::npos) << msg;
  }
}

std::string replaceOnce(std::string s, const std::string& from, const std::string& to) {
  const auto p = s.find(from);
  EXPECT_NE(p, std::string::npos) << from;
  if (p != std::string::npos) s.replace(p, from.size(), to);
  return s;
}

/// 1-based line of the first line of `text` containing `what`.
int lineOf(const std::string& text, const std::string& what) {
  const auto p = text.find(what);
  EXPECT_NE(p, std::string::npos) << what;
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(p), '\n'));
}

TEST(TrajectoryIo, ReaderErrorsNameFileLineColumnAndKey) {
  const std::string good_path = tempPath("good_lines.yaml");
  writeTrajectoryFile(good_path, sampleFile());
  const std::string good = readText(good_path);
  const std::string bad_path = tempPath("bad.yaml");  // expectConfigError's file
  std::string bad = replaceOnce(good, "duration_s: 7.0", "duration_s: abc");
  expectConfigError(bad, bad_path + ":" + std::to_string(lineOf(bad, "duration_s: abc")) +
                             ":13: key 'duration_s': expected a number, got 'abc'");
  bad = replaceOnce(good, "harmonics: 4", "harmonics: 4\nharmonix: 5");
  expectConfigError(bad, bad_path + ":" + std::to_string(lineOf(bad, "harmonix")) + ":1: key 'harmonix': unknown key");
  bad = replaceOnce(good, "  floor_z: ", "  flor_z: 1\n  floor_z: ");
  expectConfigError(bad, bad_path + ":" + std::to_string(lineOf(bad, "flor_z")) + ":3: key 'constraints.flor_z': unknown key");
  bad = replaceOnce(good, "harmonics: 4", "harmonics: 4.5");
  expectConfigError(bad, bad_path + ":" + std::to_string(lineOf(bad, "harmonics: 4.5")) +
                             ":12: key 'harmonics': expected an integer, got '4.5'");
}

TEST(TrajectoryIo, ReaderErrorsNameFileAndKey) {
  const std::string good_path = tempPath("good.yaml");
  writeTrajectoryFile(good_path, sampleFile());
  const std::string good = readText(good_path);
  expectConfigError(replaceOnce(good, "harmonics: 4", "harmonic: 4"), "key 'harmonics': missing");
  expectConfigError(replaceOnce(good, "duration_s: 7.0", "duration_s: 6.5"), "key 'duration_s'");
  expectConfigError(replaceOnce(good, "duration_s: 7.0", "duration_s: abc"),
                    "key 'duration_s': expected a number");
  expectConfigError(replaceOnce(good, "joints: [4, 5, 6]", "joints: [4, 9]"), "key 'joints[1]'");
  expectConfigError(replaceOnce(good, "format: ftid-excitation-trajectory/1", "format: other"),
                    "key 'format'");
  expectConfigError(replaceOnce(good, "floor_z: ", "floor_z: .nan #"), "key 'constraints.floor_z'");
  expectConfigError("joints: [4\n", "YAML syntax error");
  try {
    (void)readTrajectoryFile(tempPath("does_not_exist.yaml"));
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("does_not_exist.yaml"), std::string::npos);
  }
}

// Issue 14: duplicate keys, wrong node kinds (a libFuzzer finding: a keep-out entry that is a
// scalar threw YAML::BadSubscript, which escaped as a crash) and FIFOs give clear errors.
TEST(TrajectoryIo, HostileFilesGiveClearErrors) {
  const std::string good_path = tempPath("good2.yaml");
  writeTrajectoryFile(good_path, sampleFile());
  const std::string good = readText(good_path);
  expectConfigError(replaceOnce(good, "harmonics: 4", "harmonics: 4\nharmonics: 5"), "duplicate key 'harmonics'");
  expectConfigError(replaceOnce(good, "  keep_out:", "  keep_out:\n    - NULL[0.0, 1.0]"),
                    "key 'constraints.keep_out[0]': expected {name, center, radius}");
  expectConfigError(replaceOnce(good, "constraints:", "constraints: 3\nconstraints_was:"), "");
  const std::string fifo = tempPath("fifo.yaml");
  std::remove(fifo.c_str());
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  try {
    (void)readTrajectoryFile(fifo);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(fifo + ": cannot read the trajectory file: it is a FIFO"), std::string::npos)
        << e.what();
  }
  std::remove(fifo.c_str());
}

TEST(TrajectoryIo, CsvHasLogColumnsAndMatchesTheTrajectory) {
  const TrajectoryFile f = sampleFile();
  const std::string yaml = tempPath("traj.yaml");
  const std::string csv = csvPathFor(yaml);
  EXPECT_EQ(csv, tempPath("traj.csv"));
  const FourierTrajectory traj = f.toTrajectory();
  writeTrajectoryCsv(csv, traj, 125.0);
  const std::string text = readText(csv);
  const std::string header = text.substr(0, text.find('\n'));
  EXPECT_EQ(header, "t,q1,q2,q3,q4,q5,q6,qd1,qd2,qd3,qd4,qd5,qd6,qdd1,qdd2,qdd3,qdd4,qdd5,qdd6");
  // Read back with the log reader (trajectory kind: no wrench columns required).
  const logio::LogData log = logio::readLog(csv, logio::LogKind::kTrajectory);
  ASSERT_EQ(log.samples.size(), 7u * 125u + 1u);  // both ends included
  for (std::size_t k = 0; k < log.samples.size(); k += 37) {
    const auto& s = log.samples[k];
    EXPECT_NEAR(s.t, static_cast<double>(k) / 125.0, 1e-9);
    const TrajectoryPoint p = traj.evaluate(s.t);
    EXPECT_LT((s.q - p.q).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_LT((s.qd - p.qd).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_LT((s.qdd - p.qdd).cwiseAbs().maxCoeff(), 1e-9);
  }
  // Rest-to-rest visible in the file: last row back at q0 and at rest.
  const auto& last = log.samples.back();
  EXPECT_NEAR(last.t, 7.0, 1e-9);
  EXPECT_LT((last.q - f.q0).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT(last.qd.cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT(last.qdd.cwiseAbs().maxCoeff(), 1e-9);
}

}  // namespace
}  // namespace ftid::trajectory
