// Physics and plausibility of parameter sets (issue 26, item 4): a set that is physically
// impossible is refused whatever its standard errors, and one beyond what the robot and sensor
// can carry is refused with the limit and its source. Each verdict is checked against an
// independent formulation: the inertia against the positive semi-definiteness of the 4x4
// pseudo-inertia matrix (Wensing, Kim, Slotine 2017: a rigid body with a non-negative density
// exists iff J = [0.5 tr(I) 1 - I, h; h^T, m] >= 0, here I and h = m c about the S origin); the
// sensor range against a brute-force search over gravity directions.
#include <cmath>
#include <random>
#include <string>

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include "ftid/params/parameter_set.hpp"

namespace ftid::params {
namespace {

ParameterSet rigidSet(double m, const Eigen::Vector3d& c, const Eigen::Matrix3d& I_S, double std_dev) {
  ParameterSet s;
  s.model = "paper+rigid_body";
  const Eigen::Vector3d h = m * c;
  s.params = {{"mass", m, std_dev, "kg"}, {"mass_com_x", h(0), std_dev, "kg*m"}, {"mass_com_y", h(1), std_dev, "kg*m"},
              {"mass_com_z", h(2), std_dev, "kg*m"}};
  const char* names[6] = {"i_s_xx", "i_s_yy", "i_s_zz", "i_s_xy", "i_s_xz", "i_s_yz"};
  const double v[6] = {I_S(0, 0), I_S(1, 1), I_S(2, 2), I_S(0, 1), I_S(0, 2), I_S(1, 2)};
  for (int k = 0; k < 6; ++k) s.params.push_back({names[k], v[k], std_dev, "kg*m^2"});
  return s;
}

double& param(ParameterSet& s, const std::string& name) {
  for (auto& p : s.params) {
    if (p.name == name) return p.value;
  }
  s.params.push_back({name, 0.0, 0.0, ""});
  return s.params.back().value;
}

// The minimal eigenvalue of the pseudo-inertia matrix (the independent physical-consistency test).
double pseudoInertiaMinEig(double m, const Eigen::Vector3d& c, const Eigen::Matrix3d& I_S) {
  Eigen::Matrix4d J = Eigen::Matrix4d::Zero();
  J.topLeftCorner<3, 3>() = 0.5 * I_S.trace() * Eigen::Matrix3d::Identity() - I_S;
  J.topRightCorner<3, 1>() = m * c;
  J.bottomLeftCorner<1, 3>() = (m * c).transpose();
  J(3, 3) = m;
  return Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d>(J).eigenvalues()(0);
}

// The cases: impossible inertias with large standard errors load today.
TEST(Plausibility, ImpossibleInertiaIsRefusedWhateverItsStandardError) {
  const Eigen::Vector3d c(0.0, 0.0, 0.05);
  Eigen::Matrix3d I_S = Eigen::Vector3d(0.01, 0.01, 0.002).asDiagonal();
  ParameterSet ok = rigidSet(1.0, c, I_S, 0.0);
  EXPECT_FALSE(findParameterProblem(ok).has_value()) << findParameterProblem(ok)->message;

  ParameterSet negative = rigidSet(1.0, c, I_S, 100.0);
  param(negative, "i_s_xx") = -5.0;
  auto problem = findParameterProblem(negative);
  ASSERT_TRUE(problem.has_value());
  EXPECT_EQ(problem->key, "parameters.i_s_xx");
  EXPECT_NE(problem->message.find("negative principal moment"), std::string::npos) << problem->message;

  ParameterSet triangle = rigidSet(1.0, c, I_S, 1.0);  // std 1 kg*m^2: "within 3 standard errors" before
  param(triangle, "i_s_zz") = 0.05;
  problem = findParameterProblem(triangle);
  ASSERT_TRUE(problem.has_value());
  EXPECT_NE(problem->message.find("triangle inequality"), std::string::npos) << problem->message;

  // A point mass (zero inertia about the com) is the limit of physical bodies: accepted.
  const Eigen::Matrix3d point = 1.0 * (c.squaredNorm() * Eigen::Matrix3d::Identity() - c * c.transpose());
  ParameterSet pm = rigidSet(1.0, c, point, 0.0);
  EXPECT_FALSE(findParameterProblem(pm).has_value()) << findParameterProblem(pm)->message;
  ParameterSet zero_mass = rigidSet(1.0, c, I_S, 50.0);
  param(zero_mass, "mass") = 0.0;
  EXPECT_TRUE(findParameterProblem(zero_mass).has_value());
}

// Random bodies (seeded), some physical, some not: the verdict agrees with the pseudo-inertia
// test wherever the latter is not within rounding of its boundary.
TEST(Plausibility, InertiaVerdictAgreesWithThePseudoInertiaMatrix) {
  std::mt19937 rng(2606);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int refused = 0, accepted = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    const double m = 0.2 + 5.0 * (0.5 + 0.5 * u(rng));
    const Eigen::Vector3d c(0.05 * u(rng), 0.05 * u(rng), 0.1 * u(rng));
    // I_C from random principal moments (some negative or violating the triangle) and axes.
    const Eigen::Vector3d l(0.02 * u(rng) + 0.01, 0.02 * u(rng) + 0.01, 0.02 * u(rng) + 0.01);
    const Eigen::Matrix3d R = Eigen::Quaterniond(u(rng), u(rng), u(rng), u(rng)).normalized().toRotationMatrix();
    const Eigen::Matrix3d I_C = R * l.asDiagonal() * R.transpose();
    const Eigen::Matrix3d I_S = I_C + m * (c.squaredNorm() * Eigen::Matrix3d::Identity() - c * c.transpose());
    const double min_eig = pseudoInertiaMinEig(m, c, I_S);
    if (std::abs(min_eig) < 1e-6) continue;  // too close to the boundary for either test
    const bool physical = min_eig > 0.0;
    const bool ok = !findParameterProblem(rigidSet(m, c, I_S, 10.0)).has_value();
    EXPECT_EQ(ok, physical) << "trial " << trial << " min eig " << min_eig;
    (ok ? accepted : refused) += 1;
  }
  EXPECT_GT(refused, 500);
  EXPECT_GT(accepted, 500);
}

PlausibilityLimits ur10Limits() {
  PlausibilityLimits l;
  l.max_payload_kg = 10.0;
  l.payload_source = "cell.yaml: robot.rated_payload_kg";
  l.sensor_range << 300, 300, 500, 25, 25, 25;
  l.range_source = "signal ranges in ftsensor.dbc";
  return l;
}

ParameterSet paperSet(double m, const Eigen::Vector3d& mc, const Vec6& offsets) {
  ParameterSet s;
  s.model = "paper";
  s.params = {{"mass", m, 0.01, "kg"}, {"mass_com_x", mc(0), 0.0, ""}, {"mass_com_y", mc(1), 0.0, ""},
              {"mass_com_z", mc(2), 0.0, ""}};
  const char* names[6] = {"f0_x", "f0_y", "f0_z", "t0_x", "t0_y", "t0_z"};
  for (int a = 0; a < 6; ++a) s.params.push_back({names[a], offsets(a), 0.0, ""});
  return s;
}

TEST(Plausibility, APayloadAboveTheRatedPayloadIsRefusedNamingTheSource) {
  const PlausibilityLimits l = ur10Limits();
  EXPECT_FALSE(findParameterProblem(paperSet(9.5, {0, 0, 0.5}, Vec6::Zero()), l).has_value());
  const auto p = findParameterProblem(paperSet(1e6, {0, 0, 0}, Vec6::Zero()), l);
  ASSERT_TRUE(p.has_value());
  EXPECT_EQ(p->key, "parameters.mass");
  EXPECT_NE(p->message.find("exceeds the robot's rated payload 10 kg (cell.yaml: robot.rated_payload_kg)"),
            std::string::npos)
      << p->message;
  // Without limits only physics counts (the one-argument overload is unchanged).
  EXPECT_FALSE(findParameterProblem(paperSet(1e6, {0, 0, 0}, Vec6::Zero())).has_value());
}

// Random sets (seeded): refused for the sensor range exactly when a brute-force search over
// gravity directions finds a static reading beyond the range (away from the boundary).
TEST(Plausibility, SensorRangeVerdictAgreesWithABruteForceOverOrientations) {
  PlausibilityLimits l = ur10Limits();
  l.max_payload_kg = 1e9;  // only the range here
  std::mt19937 rng(26);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Eigen::Vector3d> dirs;
  for (int i = 0; i < 20000; ++i) {
    Eigen::Vector3d d(u(rng), u(rng), u(rng));
    if (d.norm() > 1e-3 && d.norm() <= 1.0) dirs.push_back(d.normalized());
  }
  for (int k = 0; k < 3; ++k) {  // the axes themselves (the worst cases) are reachable orientations
    dirs.push_back(Eigen::Vector3d::Unit(k));
    dirs.push_back(-Eigen::Vector3d::Unit(k));
  }
  int refused = 0, accepted = 0, compared = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const double m = 1.0 + 40.0 * (0.5 + 0.5 * u(rng));
    const Eigen::Vector3d mc = m * Eigen::Vector3d(0.2 * u(rng), 0.2 * u(rng), 0.3 * u(rng));
    Vec6 off;
    off << 50 * u(rng), 50 * u(rng), 50 * u(rng), 5 * u(rng), 5 * u(rng), 5 * u(rng);
    double worst_ratio = 0.0;
    for (const auto& d : dirs) {
      const Eigen::Vector3d g = l.gravity_mps2 * d;
      const Eigen::Vector3d f = off.head<3>() + m * g;
      const Eigen::Vector3d t = off.tail<3>() + mc.cross(g);
      for (int a = 0; a < 3; ++a) {
        worst_ratio = std::max(worst_ratio, std::abs(f(a)) / l.sensor_range(a));
        worst_ratio = std::max(worst_ratio, std::abs(t(a)) / l.sensor_range(3 + a));
      }
    }
    if (std::abs(worst_ratio - 1.0) < 0.01) continue;  // the sampled sphere is 1 % coarse at most
    ++compared;
    const bool ok = !findParameterProblem(paperSet(m, mc, off), l).has_value();
    EXPECT_EQ(ok, worst_ratio < 1.0) << "trial " << trial << " worst/range " << worst_ratio;
    (ok ? accepted : refused) += 1;
  }
  EXPECT_GT(compared, 250);
  EXPECT_GT(refused, 30);
  EXPECT_GT(accepted, 30);
}

}  // namespace
}  // namespace ftid::params

namespace ftid::params {
namespace {

// An identified inertia just outside the possible set (the case seen in 1 of 12 simulated 3 s
// identifications: principal moments 0.00037, 0.00102, 0.00140 kg*m^2 about the com) is written
// as its Euclidean projection onto the possible set; one beyond 3 standard errors is not.
TEST(Plausibility, AnInertiaJustOutsideIsProjectedOneFarOutsideIsNot) {
  const Eigen::Vector3d c(0.004, 0.002, 0.051);
  const double m = 0.9;
  const Eigen::Matrix3d R = Eigen::Quaterniond(0.9, 0.1, -0.2, 0.3).normalized().toRotationMatrix();
  const Eigen::Vector3d l(0.00037, 0.00102, 0.00150);  // 0.00150 > 0.00037 + 0.00102: impossible
  const Eigen::Matrix3d I_C = R * l.asDiagonal() * R.transpose();
  const Eigen::Matrix3d I_S = I_C + m * (c.squaredNorm() * Eigen::Matrix3d::Identity() - c * c.transpose());
  ParameterSet near = rigidSet(m, c, I_S, 2e-4);  // the designed trajectory's standard errors
  ASSERT_TRUE(findParameterProblem(near).has_value());
  const std::string note = projectInertiaWithinUncertainty(&near);
  ASSERT_FALSE(note.empty());
  EXPECT_FALSE(findParameterProblem(near).has_value()) << findParameterProblem(near)->message;
  EXPECT_NE(near.provenance.method.find("inertia projected"), std::string::npos);
  // Independently: the projection moves (l0, l1, l2) by e/3 (1, 1, -1), e = l2 - l0 - l1, in the
  // same principal axes, and leaves mass and centre of mass alone.
  const double e = l(2) - l(0) - l(1);
  const Eigen::Vector3d l_expected = l + e / 3.0 * Eigen::Vector3d(1, 1, -1);
  const Eigen::Matrix3d I_S_expected =
      R * l_expected.asDiagonal() * R.transpose() + m * (c.squaredNorm() * Eigen::Matrix3d::Identity() - c * c.transpose());
  EXPECT_NEAR(param(near, "i_s_xx"), I_S_expected(0, 0), 1e-12);
  EXPECT_NEAR(param(near, "i_s_yy"), I_S_expected(1, 1), 1e-12);
  EXPECT_NEAR(param(near, "i_s_zz"), I_S_expected(2, 2), 1e-12);
  EXPECT_NEAR(param(near, "i_s_xy"), I_S_expected(0, 1), 1e-12);
  EXPECT_NEAR(param(near, "i_s_xz"), I_S_expected(0, 2), 1e-12);
  EXPECT_NEAR(param(near, "i_s_yz"), I_S_expected(1, 2), 1e-12);
  EXPECT_EQ(param(near, "mass"), m);
  EXPECT_GE(pseudoInertiaMinEig(m, c, I_S_expected), -1e-12);
  // Standard errors 100x smaller: 3 standard errors do not reach a possible tensor.
  ParameterSet far = rigidSet(m, c, I_S, 2e-6);
  EXPECT_TRUE(projectInertiaWithinUncertainty(&far).empty());
  EXPECT_TRUE(findParameterProblem(far).has_value());
  // The case: i_s_xx = -5 with standard error 100 is within 3 standard errors of a
  // possible tensor, but the estimate is noise, not a measurement: not projected, with the reason.
  ParameterSet noise = rigidSet(m, c, I_S_expected, 2e-4);
  param(noise, "i_s_xx") = -5.0;
  for (auto& q : noise.params) {
    if (q.name == "i_s_xx") q.std = 100.0;
  }
  ASSERT_TRUE(findParameterProblem(noise).has_value());
  std::string why;
  EXPECT_TRUE(projectInertiaWithinUncertainty(&noise, &why).empty());
  EXPECT_EQ(param(noise, "i_s_xx"), -5.0);
  EXPECT_TRUE(findParameterProblem(noise).has_value());
  EXPECT_NE(why.find("not small against the tensor's own scale"), std::string::npos) << why;
  // The same estimate with standard errors at 50 % of the tensor's scale (over a third): not
  // projected; at 5 % (the case above) it is.
  ParameterSet loose = rigidSet(m, c, I_S, 0.5 * I_S.eigenvalues().cwiseAbs().maxCoeff());
  EXPECT_TRUE(projectInertiaWithinUncertainty(&loose).empty());
  // A possible set is never changed.
  ParameterSet fine = rigidSet(m, c, I_S_expected + 1e-5 * Eigen::Matrix3d::Identity(), 2e-4);
  const ParameterSet before = fine;
  EXPECT_TRUE(projectInertiaWithinUncertainty(&fine).empty());
  EXPECT_EQ(param(fine, "i_s_xx"), param(const_cast<ParameterSet&>(before), "i_s_xx"));
}

}  // namespace
}  // namespace ftid::params
