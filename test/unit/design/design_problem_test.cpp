// The designer's optimisation problem (src/design/design_problem.hpp), checked against direct
// formulations: the Kreisselmeier-Steinhauser soft maximum against the plain maximum (its
// documented bounds), and Problem::makeFeasible against the joint limits evaluated sample by
// sample on the parametrisation's own motion (no soft maximum involved), and the limits objective
// against predicted standard errors computed here from the information matrix's plain inverse.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "design_problem.hpp"
#include "ftid/common/error.hpp"
#include "ftid/design/designer.hpp"
#include "ftid/design/excitation_metric.hpp"
#include "ftid/model/kinematics.hpp"
#include "test_paths.hpp"

namespace ftid::design::internal {
namespace {

TEST(DesignSoftMax, BoundedByTheMaximumAndTheMaximumPlusLogNOverRho) {
  std::mt19937_64 rng(11);
  for (int n : {1, 2, 3, 10, 100, 1000}) {
    for (int trial = 0; trial < 20; ++trial) {
      SoftMax ks;
      double max_g = -std::numeric_limits<double>::infinity();
      for (int i = 0; i < n; ++i) {
        // Constraint values around the feasibility border, some of them tied.
        const double g = trial % 3 == 0 && i % 2 == 1 ? 0.25 : 6.0 * uniform01(rng) - 5.0;
        ks.add(g);
        max_g = std::max(max_g, g);
      }
      const double v = ks.value();
      EXPECT_GE(v, max_g) << "n " << n << " trial " << trial;
      EXPECT_LE(v, max_g + std::log(static_cast<double>(n)) / kKsRho + 1e-12) << "n " << n << " trial " << trial;
    }
  }
  // n equal values: exactly the upper bound.
  SoftMax equal;
  for (int i = 0; i < 8; ++i) equal.add(-0.5);
  EXPECT_NEAR(equal.value(), -0.5 + std::log(8.0) / kKsRho, 1e-12);
}

TEST(DesignSoftMax, EmptyIsFeasibleAndNanOrInfinityIsInfeasible) {
  SoftMax ks;
  EXPECT_LT(ks.value(), 0.0);
  ks.add(-1.0);
  ks.add(std::numeric_limits<double>::quiet_NaN());
  EXPECT_GT(ks.value(), 0.0);
  ks.clear();
  ks.add(-1.0);
  ks.add(std::numeric_limits<double>::infinity());
  EXPECT_GT(ks.value(), 0.0);
}

TEST(DesignProblem, MakeFeasibleScalesToTheLargestAmplitudeWithinTheJointLimits) {
  const model::RobotKinematics kin =
      model::RobotKinematics::fromUrdfFile(ftid::test::sourcePath("/config/ur10.urdf"));
  DesignOptions opt;
  opt.duration_s = 6.0;
  opt.harmonics = 4;
  opt.constraints = loadDesignConstraints("", kin, opt.q0);
  opt.constraints.tool.clear();  // joint limits only: the scale then has a closed form to check
  opt.constraints.keep_out.clear();
  Problem p(opt, kin);
  std::mt19937_64 rng(5);
  const double m = 1.0 - opt.constraint_margin;
  const auto& c = opt.constraints;
  for (int trial = 0; trial < 10; ++trial) {
    const std::vector<double> x = randomDirection(rng, p.n());
    const std::vector<double> y = p.makeFeasible(x);
    // y = s x with s in [0, 1].
    const double s = y[0] / x[0];
    ASSERT_GE(s, 0.0);
    ASSERT_LE(s, 1.0);
    for (std::size_t k = 0; k < x.size(); ++k) ASSERT_NEAR(y[k], s * x[k], 1e-12);
    // The worst ratio of motion to (margin-tightened) limit over the design samples, directly.
    SampledMotion mo;
    p.param().sample(y.data(), mo);
    double worst = 0.0;
    for (int j : opt.joints) {
      const int i = j - 1;
      for (Eigen::Index t = 0; t < mo.q.cols(); ++t) {
        const double dq = mo.q(i, t) - opt.q0[i];
        worst = std::max(worst, dq > 0 ? dq / ((c.position_upper[i] - opt.q0[i]) * m)
                                       : -dq / ((opt.q0[i] - c.position_lower[i]) * m));
        worst = std::max(worst, std::abs(mo.qd(i, t)) / (c.velocity[i] * m));
        worst = std::max(worst, std::abs(mo.qdd(i, t)) / (c.acceleration[i] * m));
      }
    }
    // Within the limits, and (unless x itself was) no further inside them than the soft maximum's
    // conservatism allows: makeFeasible stops where KS = 0, and KS <= max + ln(n)/rho with at
    // most n = 2K values per constraint (the two signs of the velocity and the acceleration).
    EXPECT_LE(worst, 1.0 + 1e-12) << "trial " << trial;
    if (s < 1.0) {
      const double slack = std::log(2.0 * static_cast<double>(mo.q.cols())) / kKsRho;
      EXPECT_GE(worst, 1.0 - slack - 1e-6) << "trial " << trial << ": not the largest amplitude";
    }
    EXPECT_TRUE(p.evaluateConstraintsOnly(y)) << "trial " << trial;
  }
}

/// The limits objective (Objective::kLimits) is log10 of the p-norm (p = kLimitNormP) of the ratios
/// predicted std / target, the standard errors taken here from the plain inverse of the information
/// matrix, the CoM's by the delta method written out: var(c) = (var(mc) - 2 c cov(mc, m) +
/// c^2 var(m)) / m^2 at the nominal payload. The IMU's information only adds, so with it the
/// objective is never larger.
TEST(DesignProblem, LimitObjectiveIsThePNormOfPredictedStdOverTarget) {
  const model::RobotKinematics kin =
      model::RobotKinematics::fromUrdfFile(ftid::test::sourcePath("/config/ur10.urdf"));
  DesignOptions opt;
  opt.model = "paper+rigid_body";
  opt.duration_s = 1.5;
  opt.joints = {2, 3, 4, 5, 6};
  opt.constraints = loadDesignConstraints("", kin, opt.q0);
  opt.objective = Objective::kLimits;
  const auto nominal = defaultNominalParameters();
  opt.limit_targets = parseLimits("mass=0.5%,com=1mm,tilt=0.1deg", nominal);
  Problem p(opt, kin);
  DesignOptions with_imu = opt;
  with_imu.imu_acc_std = 0.01;
  with_imu.imu_gyro_std = 0.002;
  with_imu.targets_with_imu = true;
  Problem q(with_imu, kin);
  const auto& names = p.metric().columnNames();
  auto col = [&](const std::string& n) {
    return static_cast<Eigen::Index>(std::find(names.begin(), names.end(), n) - names.begin());
  };
  std::mt19937_64 rng(11);
  for (int trial = 0; trial < 5; ++trial) {
    SCOPED_TRACE(trial);
    const std::vector<double> x = p.makeFeasible(randomDirection(rng, p.n()));
    const Eigen::MatrixXd cov = p.information(x).inverse();
    const double m = nominal.at("mass");
    std::map<std::string, double> sd;
    sd["mass"] = std::sqrt(cov(col("mass"), col("mass")));
    for (const char* a : {"x", "y", "z"}) {
      const Eigen::Index ic = col(std::string("mass_com_") + a);
      const Eigen::Index im = col("mass");
      const double c = nominal.at(std::string("com_") + a);
      sd[std::string("com_") + a] =
          std::sqrt((cov(ic, ic) - 2.0 * c * cov(ic, im) + c * c * cov(im, im)) / (m * m));
    }
    for (const char* t : {"tilt_u", "tilt_v"}) sd[t] = std::sqrt(cov(col(t), col(t)));
    double sum = 0.0;
    for (const auto& [key, target] : opt.limit_targets) sum += std::pow(sd.at(key) / target, kLimitNormP);
    const double objective = p.evaluate(x.data()).objective;
    EXPECT_NEAR(objective, std::log10(sum) / kLimitNormP, 1e-9);
    EXPECT_LE(q.evaluate(x.data()).objective, objective + 1e-12);
  }
}

/// The IMU's information of a motion scales with the samples it stands for: 150 design samples each
/// standing for 188/150 samples give about the information of the 188 samples at the servo rate.
TEST(DesignProblem, ImuInformationOfFewSamplesWeightedMatchesTheServoRate) {
  const model::RobotKinematics kin =
      model::RobotKinematics::fromUrdfFile(ftid::test::sourcePath("/config/ur10.urdf"));
  DesignOptions opt;
  opt.model = "paper+rigid_body";
  opt.duration_s = 1.5;
  opt.constraints = loadDesignConstraints("", kin, opt.q0);
  Problem p(opt, kin);
  std::mt19937_64 rng(3);
  const std::vector<double> x = p.makeFeasible(randomDirection(rng, p.n()));
  const Eigen::Index P = p.metric().numColumns();
  const Eigen::MatrixXd zero = Eigen::MatrixXd::Zero(P, P);
  auto imuInfo = [&](int samples, double weight) {
    p.param().prepareSampling(samples);
    SampledMotion mo;
    p.param().sample(x.data(), mo);
    return Eigen::Matrix2d(p.metric().informationWithImu(mo, zero, 0.01, 0.002, weight).bottomRightCorner(2, 2));
  };
  const Eigen::Matrix2d servo = imuInfo(188, 1.0);
  const Eigen::Matrix2d design = imuInfo(150, 188.0 / 150.0);
  ASSERT_GT(servo.norm(), 0.0);
  EXPECT_LT((design - servo).norm() / servo.norm(), 0.1) << "servo rate:\n" << servo << "\ndesign samples:\n" << design;
}

TEST(DesignProblem, TheLimitsObjectiveNeedsLimitsTheModelPredictsAndTheImuTargetsItsNoise) {
  const model::RobotKinematics kin =
      model::RobotKinematics::fromUrdfFile(ftid::test::sourcePath("/config/ur10.urdf"));
  DesignOptions opt;
  opt.constraints = loadDesignConstraints("", kin, opt.q0);
  opt.objective = Objective::kLimits;
  EXPECT_THROW((void)designExcitation(opt, kin), ConfigError);
  opt.limit_targets = {{"mass", 0.001}};
  opt.targets_with_imu = true;
  EXPECT_THROW((void)designExcitation(opt, kin), ConfigError);
  // A target the model does not predict (a typo) is refused before any design, by the limits
  // objective and by the duration search whatever the objective.
  opt.targets_with_imu = false;
  opt.limit_targets = {{"mass", 0.001}, {"mas", 0.001}};
  EXPECT_THROW((void)designExcitation(opt, kin), ConfigError);
  DesignOptions cond;
  cond.constraints = opt.constraints;
  EXPECT_THROW((void)findShortestDuration(cond, kin, {{"i_s_xx", 1e-4}}), ConfigError);
  EXPECT_STREQ(objectiveName(Objective::kLimits), "limits");
}

}  // namespace
}  // namespace ftid::design::internal
