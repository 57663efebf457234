// The laboratory's look at the sensor's IMU (issue 23, src/lab/imu_check.hpp, docs/analyze.md "The
// IMU"), on simulator runs whose sensor is mounted rotated 3 degrees about z: an IMU that turns with
// the sensor agrees with `mounting`; one left in the configured frame is reported as disagreeing; and
// a model without `mounting` hears from the IMU that the sensor is not where the configuration says.
#include <gtest/gtest.h>

#include <cmath>

#include <nlohmann/json.hpp>

#include "lab_sim.hpp"

namespace ftid::lab {
namespace {

constexpr double kYaw = 0.05235987755982988;  // 3 deg, the simulator's default mounting

sim::CellSimConfig rotatedSensor(std::uint64_t seed, bool imu_turns_with_it) {
  sim::CellSimConfig c = labtest::baseConfig(seed);
  c.mounting.enabled = true;
  c.mounting.rotate_imu = imu_turns_with_it;
  c.noise.acc_std = 0.01;  // a MEMS IMU (docs/simulator.md)
  c.noise.gyro_std = 0.002;
  c.noise.alpha_std = 0.02;
  return c;
}

AnalysisResult analyzeWith(const sim::CellSimConfig& c, const std::string& model) {
  AnalyzeOptions o;
  o.model = model;
  o.candidates = {"cable"};  // the IMU check does not depend on the ranking
  return analyze(labtest::contexts(c).samples, nullptr, o, "run.csv");
}

const identify::ImuComparison* comparison(const AnalysisResult& r, const std::string& quantity) {
  for (const auto& c : r.imu.comparisons) {
    if (c.quantity == quantity) return &c;
  }
  return nullptr;
}

bool warned(const AnalysisResult& r, const std::string& fragment) {
  for (const auto& w : r.warnings) {
    if (w.find(fragment) != std::string::npos) return true;
  }
  return false;
}

TEST(LabImu, AnImuThatTurnsWithTheSensorAgreesWithMounting) {
  const AnalysisResult r = analyzeWith(rotatedSensor(31, true), "paper+mounting");
  ASSERT_TRUE(r.imu.used) << r.imu.not_used_reason;
  const auto& g = r.imu.estimate.gyro;
  EXPECT_NEAR(g.rpy_rad.z(), kYaw, 3.5 * g.rotation_std_rad.z());
  ASSERT_NE(comparison(r, "mount"), nullptr);
  EXPECT_FALSE(comparison(r, "mount")->disagrees) << comparison(r, "mount")->message;
  ASSERT_NE(comparison(r, "delay"), nullptr);
  EXPECT_FALSE(comparison(r, "delay")->disagrees) << comparison(r, "delay")->message;
  EXPECT_FALSE(warned(r, "disagree"));
  const auto j = nlohmann::json::parse(formatJson(r));
  EXPECT_TRUE(j.at("imu").at("used").get<bool>());
  EXPECT_NEAR(j.at("imu").at("mount_rpy").at(2).get<double>(), g.rpy_rad.z(), 1e-12);
  EXPECT_NE(formatText(r).find("the sensor's IMU against the kinematics and paper+mounting"), std::string::npos);
}

/// The IMU's mount disagrees with the model's (or the configuration's), in the result and its warning.
void expectMountDisagreement(const AnalysisResult& r, const std::string& warning) {
  ASSERT_TRUE(r.imu.used) << r.imu.not_used_reason;
  ASSERT_NE(comparison(r, "mount"), nullptr);
  EXPECT_TRUE(comparison(r, "mount")->disagrees) << comparison(r, "mount")->message;
  EXPECT_TRUE(warned(r, warning));
  EXPECT_NE(formatText(r).find("DISAGREE"), std::string::npos);
}

TEST(LabImu, AnImuLeftInTheConfiguredFrameIsReported) {
  expectMountDisagreement(analyzeWith(rotatedSensor(32, false), "paper+mounting"),
                          "the IMU and paper+mounting disagree on the mount");
}

TEST(LabImu, AModelWithoutMountingHearsOfTheRotationFromTheImu) {
  expectMountDisagreement(analyzeWith(rotatedSensor(33, true), "paper"), "the IMU and paper disagree on the mount");
}

// `cable` folds the cable's horizontal pull into the tilt (an apparent tilt): the laboratory does
// not read its difference from the IMU's tilt as a set-up error, and says why it did not compare.
TEST(LabImu, ACableModelsApparentTiltIsNotASetUpError) {
  sim::CellSimConfig c = rotatedSensor(35, true);
  c.mounting.enabled = false;
  c.cable.enabled = true;
  const AnalysisResult r = analyzeWith(c, "paper+cable");
  ASSERT_TRUE(r.imu.used) << r.imu.not_used_reason;
  EXPECT_EQ(comparison(r, "tilt"), nullptr);
  EXPECT_FALSE(warned(r, "disagree on the tilt"));
  EXPECT_NE(r.imu.tilt_not_compared.find("pull of cable"), std::string::npos) << r.imu.tilt_not_compared;
  EXPECT_NE(formatText(r).find("tilt not compared: paper+cable folds"), std::string::npos);
  EXPECT_NE(nlohmann::json::parse(formatJson(r)).at("imu").at("tilt_not_compared").get<std::string>().find("cable"),
            std::string::npos);
  // The same run under the paper model: its tilt is the base's, and is compared.
  const AnalysisResult p = analyzeWith(c, "paper");
  EXPECT_NE(comparison(p, "tilt"), nullptr);
  EXPECT_TRUE(p.imu.tilt_not_compared.empty());
}

TEST(LabImu, ALogWithoutTheImuSaysSo) {
  std::vector<SampleContext> s = labtest::contexts(labtest::baseConfig(34)).samples;
  for (auto& c : s) c.has_imu = false;
  AnalyzeOptions o;
  o.candidates = {"cable"};
  const AnalysisResult r = analyze(s, nullptr, o, "run.csv");
  EXPECT_FALSE(r.imu.used);
  EXPECT_NE(r.imu.not_used_reason.find("no IMU columns"), std::string::npos);
  EXPECT_FALSE(nlohmann::json::parse(formatJson(r)).at("imu").at("used").get<bool>());
}

}  // namespace
}  // namespace ftid::lab
