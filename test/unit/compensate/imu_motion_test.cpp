// Compensation with the motion of S from the sensor's IMU (compensator.hpp, MotionSource::kImu;
// docs/effects.md "Motion from the IMU"), on the simulator's full Newton-Euler physics with its own
// IMU model (sim/cell_sim.cpp), which the compensator's effects do not share:
//  - noise-free, the IMU's motion compensates exactly as the kinematics do;
//  - an accelerometer bias the set does not know leaves exactly m b_a and (m c) x b_a in the
//    contact (the reading is m (g_S - a_S), the model reads a_S + b_a); the set's bias removes it;
//  - with a sensor_delay, the IMU is paired as the kinematics are (it is in the robot state's time);
//  - a model whose tilt is apparent (it holds a cable's pull) is refused: the IMU measures gravity;
//  - with joint accelerations differentiated from noisy joint speeds, the IMU's motion is better,
//    by the margin the two noise levels predict;
//  - a reading without its IMU is refused (Status::kInvalidInput), and the IMU mode allocates nothing.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "../identify/paper_cell.hpp"
#include "ftid/common/error.hpp"
#include "ftid/compensate/compensator.hpp"
#include "ftid/identify/fit.hpp"
#include "ftid/identify/fit_parameters.hpp"
#include "ftid/params/parameter_set.hpp"

namespace ftid::compensate {
namespace {

const effects::Model& rigidModel() {
  static const effects::Model m = effects::Model::fromName("paper+rigid_body");
  return m;
}

/// The paper's cell with full rigid-body physics; `imu_bias`: the sim's IMU biases (zero: none).
sim::CellSimConfig cellConfig(std::uint64_t seed) {
  sim::CellSimConfig cfg = test::paperConfig(false, seed);
  cfg.full_rigid_body = true;
  return cfg;
}

/// Parameters fitted with the kinematics to the noise-free run of `cfg` (the exact values).
params::ParameterSet exactParameters(sim::CellSimConfig cfg) {
  cfg.noise = sim::NoiseConfig{};
  cfg.imu.enabled = false;
  const samples::ContextSet clean = test::contextsOf(cfg);
  return identify::toParameterSet(identify::fitModel(rigidModel(), clean.samples));
}

Compensator compensatorFor(const params::ParameterSet& set, const CompensatorOptions& options) {
  return Compensator(rigidModel(), params::thetaFor(rigidModel(), set), params::nonlinearFor(rigidModel(), set),
                     options);
}

/// Per axis: the mean and RMS of the contact wrench over the samples (all must compensate).
struct ContactStats {
  Vec6 mean = Vec6::Zero();
  Vec6 rms = Vec6::Zero();
  double worst = 0.0;
};
ContactStats contactStats(Compensator& comp, const std::vector<effects::SampleContext>& samples) {
  ContactStats s;
  for (const auto& ctx : samples) {
    Wrench contact;
    EXPECT_EQ(comp.compute(ctx, &contact, nullptr), Status::kOk);
    s.mean += contact;
    s.rms += contact.cwiseAbs2();
    s.worst = std::max(s.worst, contact.cwiseAbs().maxCoeff());
  }
  const double n = static_cast<double>(samples.size());
  s.mean /= n;
  s.rms = (s.rms / n).cwiseSqrt();
  return s;
}

CompensatorOptions imuMotion(const Vec3& acc_bias = Vec3::Zero(), const Vec3& gyro_bias = Vec3::Zero()) {
  CompensatorOptions o;
  o.motion = MotionSource::kImu;
  o.imu_bias.acc_mps2 = acc_bias;
  o.imu_bias.gyro_radps = gyro_bias;
  return o;
}

TEST(ImuMotion, CompensatesNoiseFreeDataAsTheKinematicsDo) {
  const sim::CellSimConfig cfg = cellConfig(3);
  const params::ParameterSet set = exactParameters(cfg);
  const samples::ContextSet run = test::contextsOf(cfg);
  ASSERT_TRUE(run.samples.front().has_imu);
  Compensator kin = compensatorFor(set, CompensatorOptions{});
  Compensator imu = compensatorFor(set, imuMotion());
  const ContactStats k = contactStats(kin, run.samples);
  const ContactStats i = contactStats(imu, run.samples);
  EXPECT_LT(k.worst, 1e-8);
  EXPECT_LT(i.worst, 1e-8);
  // The IMU's motion was used: with the kinematics' a_S zeroed the IMU path does not change.
  std::vector<effects::SampleContext> no_kinematic_motion = run.samples;
  for (auto& c : no_kinematic_motion) {
    c.a_S.setZero();
    c.w_S.setZero();
    c.alpha_S.setZero();
  }
  Compensator imu2 = compensatorFor(set, imuMotion());
  EXPECT_LT(contactStats(imu2, no_kinematic_motion).worst, 1e-8);
  Compensator kin2 = compensatorFor(set, CompensatorOptions{});
  EXPECT_GT(contactStats(kin2, no_kinematic_motion).worst, 0.05);  // the motion matters on this run
}

TEST(ImuMotion, AnUnknownAccelerometerBiasLeavesMassTimesBias) {
  sim::CellSimConfig cfg = cellConfig(4);
  cfg.imu.enabled = true;
  cfg.imu.gyro_bias_radps.setZero();  // the accelerometer's alone: the identity below is exact
  const Vec3 b_a = cfg.imu.acc_bias_mps2;
  const params::ParameterSet set = exactParameters(cfg);
  const samples::ContextSet run = test::contextsOf(cfg);
  const double m = set.find("mass")->value;
  const Vec3 mc(set.find("mass_com_x")->value, set.find("mass_com_y")->value, set.find("mass_com_z")->value);
  Compensator unaware = compensatorFor(set, imuMotion());
  for (const auto& ctx : run.samples) {
    Wrench contact;
    ASSERT_EQ(unaware.compute(ctx, &contact, nullptr), Status::kOk);
    // The model is m (g_S - a_S - b_a) = reading - m b_a: the contact is m b_a and (m c) x b_a.
    EXPECT_LT((contact.head<3>() - m * b_a).norm(), 1e-8);
    EXPECT_LT((contact.tail<3>() - mc.cross(b_a)).norm(), 1e-8);
  }
  Compensator aware = compensatorFor(set, imuMotion(b_a));
  EXPECT_LT(contactStats(aware, run.samples).worst, 1e-8);
}

TEST(ImuMotion, TheGyroBiasIsSubtracted) {
  sim::CellSimConfig cfg = cellConfig(5);
  cfg.imu.enabled = true;
  const params::ParameterSet set = exactParameters(cfg);
  const samples::ContextSet run = test::contextsOf(cfg);
  Compensator aware = compensatorFor(set, imuMotion(cfg.imu.acc_bias_mps2, cfg.imu.gyro_bias_radps));
  EXPECT_LT(contactStats(aware, run.samples).worst, 1e-8);
  Compensator acc_only = compensatorFor(set, imuMotion(cfg.imu.acc_bias_mps2));
  EXPECT_GT(contactStats(acc_only, run.samples).worst, 1e-7);  // the gyro's bias is seen in w x (w x c)
}

TEST(ImuMotion, WithASensorDelayTheImuIsPairedAsTheKinematicsAre) {
  sim::CellSimConfig cfg = cellConfig(8);
  cfg.sensor_delay.enabled = true;  // the wrench lags the robot state and the IMU by 12 ms
  const effects::Model model = effects::Model::fromName("paper+rigid_body+sensor_delay");
  const samples::ContextSet run = test::contextsOf(cfg);
  const params::ParameterSet set = identify::toParameterSet(identify::fitModel(model, run.samples));
  auto make = [&](const CompensatorOptions& o) {
    return Compensator(model, params::thetaFor(model, set), params::nonlinearFor(model, set), o);
  };
  Compensator kin = make(CompensatorOptions{});
  Compensator imu = make(imuMotion());
  double worst_kin = 0.0, worst_imu = 0.0;
  for (const auto& ctx : run.samples) {
    Wrench a, b;
    const Status sa = kin.compute(ctx, &a, nullptr);
    ASSERT_EQ(imu.compute(ctx, &b, nullptr), sa);
    if (sa != Status::kOk) continue;
    worst_kin = std::max(worst_kin, a.cwiseAbs().maxCoeff());
    worst_imu = std::max(worst_imu, b.cwiseAbs().maxCoeff());
  }
  // Both interpolate the delayed motion between samples alike; the reading's own IMU sample (12 ms
  // late against the wrench) would leave m |da/dt| tau, tenths of a newton on this motion.
  EXPECT_LT(worst_kin, 0.02);
  EXPECT_LT(worst_imu, 1.5 * worst_kin + 1e-9);
}

TEST(ImuMotion, AModelWithAnApparentTiltIsRefused) {
  const effects::Model model = effects::Model::fromName("paper+cable");
  ASSERT_FALSE(model.tiltAbsorbers().empty());
  const Eigen::VectorXd theta = Eigen::VectorXd::Constant(model.numParams(), 0.1);
  EXPECT_THROW(Compensator(model, theta, effects::NonlinearParams{}, imuMotion()), ConfigError);
  EXPECT_NO_THROW(Compensator(model, theta, effects::NonlinearParams{}, CompensatorOptions{}));
}

/// Replaces qdd by the central difference of joint speeds read with white noise of qd_std (what an
/// arm without acceleration signals gives), and rebuilds the kinematics from it.
std::vector<effects::SampleContext> differentiatedQdd(const sim::CellSimConfig& cfg, double qd_std,
                                                      std::uint64_t seed) {
  logio::LogData log = sim::CellSim(cfg).run();
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  std::vector<JointVector> qd(log.samples.size());
  for (std::size_t k = 0; k < qd.size(); ++k) {
    qd[k] = log.samples[k].qd;
    for (int j = 0; j < 6; ++j) qd[k](j) += qd_std * n01(rng);
  }
  for (std::size_t k = 1; k + 1 < qd.size(); ++k) {
    const double dt = log.samples[k + 1].t - log.samples[k - 1].t;
    log.samples[k].qdd = (qd[k + 1] - qd[k - 1]) / dt;
  }
  return samples::buildContexts(log, *cfg.robot).samples;
}

TEST(ImuMotion, BeatsDifferentiatedJointSpeedsByWhatTheNoisePredicts) {
  sim::CellSimConfig cfg = cellConfig(6);
  const params::ParameterSet set = exactParameters(cfg);
  // A MEMS IMU (docs/simulator.md) and a noise-free wrench: the contact error is the motion's alone.
  const double acc_std = 0.01;
  cfg.noise.acc_std = acc_std;
  cfg.noise.gyro_std = 0.002;
  cfg.noise.alpha_std = 0.02;
  const std::vector<effects::SampleContext> poor = differentiatedQdd(cfg, 1e-3, 11);
  Compensator kin = compensatorFor(set, CompensatorOptions{});
  Compensator imu = compensatorFor(set, imuMotion());
  const ContactStats k = contactStats(kin, poor);
  const ContactStats i = contactStats(imu, poor);
  const double m = set.find("mass")->value;
  for (int a = 0; a < 3; ++a) {
    // The IMU's force error is m times the accelerometer's noise (the rotational terms add 1 %).
    EXPECT_NEAR(i.rms(a), m * acc_std, 0.1 * m * acc_std) << "axis " << a;
    EXPECT_GT(k.rms(a), 3.0 * i.rms(a)) << "axis " << a;
  }
  std::printf("contact force RMS with differentiated qdd (qd noise 1e-3 rad/s): kinematics %.4f %.4f %.4f N, "
              "IMU %.4f %.4f %.4f N (m sigma_acc %.4f N)\n",
              k.rms(0), k.rms(1), k.rms(2), i.rms(0), i.rms(1), i.rms(2), m * acc_std);
}

TEST(ImuMotion, AReadingWithoutItsImuIsRefused) {
  const sim::CellSimConfig cfg = cellConfig(7);
  const params::ParameterSet set = exactParameters(cfg);
  effects::SampleContext ctx = test::contextsOf(cfg).samples[100];
  ctx.has_imu = false;
  Compensator imu = compensatorFor(set, imuMotion());
  Wrench contact = Wrench::Constant(7.0);
  EXPECT_EQ(imu.compute(ctx, &contact, nullptr), Status::kInvalidInput);
  EXPECT_EQ(contact, Wrench::Constant(7.0));
  Compensator kin = compensatorFor(set, CompensatorOptions{});
  EXPECT_EQ(kin.compute(ctx, &contact, nullptr), Status::kOk);
}

TEST(ImuMotion, NonFiniteBiasesAreRefusedAtConstruction) {
  const auto& model = rigidModel();
  const Eigen::VectorXd theta = Eigen::VectorXd::Ones(model.numParams());
  CompensatorOptions o = imuMotion(Vec3(0.0, std::nan(""), 0.0));
  EXPECT_THROW(Compensator(model, theta, effects::NonlinearParams{}, o), ConfigError);
}

}  // namespace
}  // namespace ftid::compensate
