#include <cmath>
#include <random>
#include <stdexcept>

#include <gtest/gtest.h>

#include "ftid/trajectory/fourier_trajectory.hpp"
#ifdef FTID_HAVE_ALLOC_COUNTER
#include "alloc_counter.hpp"
#endif

namespace ftid::trajectory {
namespace {

using Coeffs = std::array<std::array<double, FourierTrajectory::kMaxHarmonics>, kNumJoints>;

struct Random {
  Coeffs a{}, b{};
  JointVector q0;
};

// Random coefficients; with rest = true, harmonic 1 is chosen so that sum a = 0 and sum l b = 0.
Random randomCoefficients(unsigned seed, int harmonics, bool rest, int first_joint = 0) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> U(-0.3, 0.3);
  Random r;
  for (int j = 0; j < kNumJoints; ++j) {
    r.q0[j] = U(rng) * 5.0;
    if (j < first_joint) continue;
    auto& a = r.a[static_cast<std::size_t>(j)];
    auto& b = r.b[static_cast<std::size_t>(j)];
    for (int l = 0; l < harmonics; ++l) {
      a[static_cast<std::size_t>(l)] = U(rng);
      b[static_cast<std::size_t>(l)] = U(rng);
    }
    if (rest) {
      double sa = 0.0, sb = 0.0;
      for (int l = 1; l < harmonics; ++l) {
        sa += a[static_cast<std::size_t>(l)];
        sb += (l + 1) * b[static_cast<std::size_t>(l)];
      }
      a[0] = -sa;
      b[0] = -sb;
    }
  }
  return r;
}

TEST(FourierTrajectory, StartsAtQ0) {
  const Random r = randomCoefficients(1, 5, false);
  const FourierTrajectory traj(r.q0, 0.1, 5, 10.0, r.a, r.b);
  EXPECT_LT((traj.evaluate(0.0).q - r.q0).norm(), 1e-14);
}

TEST(FourierTrajectory, DerivativesMatchFiniteDifferences) {
  for (unsigned seed = 1; seed <= 5; ++seed) {
    const int harmonics = static_cast<int>(seed) * 3;  // 3..15
    const Random r = randomCoefficients(seed, harmonics, false);
    const FourierTrajectory traj(r.q0, 0.2, harmonics, 5.0, r.a, r.b);
    const double h = 1e-5;
    for (double t : {0.1, 0.77, 1.9, 3.3, 4.8}) {
      const TrajectoryPoint p = traj.evaluate(t), pp = traj.evaluate(t + h), pm = traj.evaluate(t - h);
      const JointVector qd_fd = (pp.q - pm.q) / (2 * h);
      const JointVector qdd_fd = (pp.qd - pm.qd) / (2 * h);
      EXPECT_LT((p.qd - qd_fd).norm(), 1e-6 * (1 + p.qd.norm())) << "seed " << seed << " t " << t;
      EXPECT_LT((p.qdd - qdd_fd).norm(), 1e-6 * (1 + p.qdd.norm())) << "seed " << seed << " t " << t;
      // Second derivative of q directly, with a larger step.
      const double H = 1e-3;
      const JointVector qdd_fd2 = (traj.evaluate(t + H).q - 2 * p.q + traj.evaluate(t - H).q) / (H * H);
      EXPECT_LT((p.qdd - qdd_fd2).norm(), 1e-4 * (1 + p.qdd.norm()));
      EXPECT_GT(p.qd.norm(), 1e-3);
    }
  }
}

TEST(FourierTrajectory, RestToRestWhenConstraintsHold) {
  const Random r = randomCoefficients(9, 5, true);
  const FourierTrajectory traj(r.q0, 0.1, 5, 20.0, r.a, r.b);  // two base periods
  for (double t : {0.0, 10.0, 20.0}) {
    const TrajectoryPoint p = traj.evaluate(t);
    EXPECT_LT(p.qd.norm(), 1e-12) << t;
    EXPECT_LT(p.qdd.norm(), 1e-12) << t;
    EXPECT_LT((p.q - r.q0).norm(), 1e-12) << t;
  }
  EXPECT_GT(traj.evaluate(3.0).qd.norm(), 1e-2);
  // Without the constraints the same check fails (the test can fail).
  const Random free = randomCoefficients(9, 5, false);
  const FourierTrajectory moving(free.q0, 0.1, 5, 20.0, free.a, free.b);
  EXPECT_GT(moving.evaluate(0.0).qd.norm() + moving.evaluate(0.0).qdd.norm(), 1e-3);
}

TEST(FourierTrajectory, HoldsQ0AtRestOutsideAndUnexcitedJointsStay) {
  const Random r = randomCoefficients(4, 4, true, /*first_joint=*/3);
  const FourierTrajectory traj(r.q0, 0.25, 4, 4.0, r.a, r.b);
  for (double t : {-1.0, -1e-9, 4.0 + 1e-9, 100.0}) {
    const TrajectoryPoint p = traj.evaluate(t);
    EXPECT_EQ(p.q, r.q0) << t;
    EXPECT_EQ(p.qd, JointVector::Zero());
    EXPECT_EQ(p.qdd, JointVector::Zero());
  }
  const TrajectoryPoint mid = traj.evaluate(1.3);
  for (int j = 0; j < 3; ++j) {
    EXPECT_EQ(mid.q[j], r.q0[j]);
    EXPECT_EQ(mid.qd[j], 0.0);
  }
  EXPECT_NE(mid.q[4], r.q0[4]);
}

TEST(FourierTrajectory, CoefficientsBeyondHarmonicsAreIgnored) {
  Random r = randomCoefficients(5, 3, false);
  const FourierTrajectory a(r.q0, 0.1, 3, 10.0, r.a, r.b);
  r.a[2][7] = 5.0;
  r.b[4][3] = -2.0;
  const FourierTrajectory b(r.q0, 0.1, 3, 10.0, r.a, r.b);
  EXPECT_EQ(a.evaluate(2.5).q, b.evaluate(2.5).q);
  EXPECT_EQ(b.a(2, 7), 0.0);
}

TEST(FourierTrajectory, InvalidArgumentsThrow) {
  const Random r = randomCoefficients(1, 2, false);
  EXPECT_THROW(FourierTrajectory(r.q0, 0.1, 0, 10.0, r.a, r.b), std::invalid_argument);
  EXPECT_THROW(FourierTrajectory(r.q0, 0.1, FourierTrajectory::kMaxHarmonics + 1, 10.0, r.a, r.b),
               std::invalid_argument);
  EXPECT_THROW(FourierTrajectory(r.q0, 0.0, 2, 10.0, r.a, r.b), std::invalid_argument);
  EXPECT_THROW(FourierTrajectory(r.q0, -0.1, 2, 10.0, r.a, r.b), std::invalid_argument);
  EXPECT_THROW(FourierTrajectory(r.q0, 0.1, 2, -1.0, r.a, r.b), std::invalid_argument);
  Random bad = r;
  bad.a[1][1] = std::nan("");
  EXPECT_THROW(FourierTrajectory(bad.q0, 0.1, 2, 10.0, bad.a, bad.b), std::invalid_argument);
}

#ifdef FTID_HAVE_ALLOC_COUNTER
TEST(FourierTrajectory, EvaluateDoesNotAllocate) {
  const Random r = randomCoefficients(2, 16, true);
  const FourierTrajectory traj(r.q0, 0.1, 16, 10.0, r.a, r.b);
  double sink = 0.0;
  ftid::test::ScopedAllocationCounter counter;
  for (int i = 0; i < 1000; ++i) sink += traj.evaluate(0.01 * i).qdd.sum();
  EXPECT_EQ(counter.count(), 0u);
  EXPECT_TRUE(std::isfinite(sink));
}
#endif

}  // namespace
}  // namespace ftid::trajectory
