#include <gtest/gtest.h>

#include <limits>

#include "ftid/drivers/ur/servo_safety.hpp"

using namespace ftid::drivers::ur;
using ftid::JointVector;

TEST(ServoSafety, AcceptsSmoothSteps) {
  ServoSafetyCheck c;
  c.reset(JointVector::Zero());
  JointVector q = JointVector::Zero();
  for (int k = 1; k <= 100; ++k) {
    q.setConstant(0.5 * (k * 0.008) * (k * 0.008));  // a = 1 rad/s^2
    ASSERT_EQ(c.check(q, 0.008), ServoReject::kNone) << k;
  }
}

TEST(ServoSafety, RejectsNonFiniteAndLimits) {
  ServoLimits lim;
  lim.upper[2] = 1.0;
  ServoSafetyCheck c(lim);
  c.reset(JointVector::Zero());
  JointVector q = JointVector::Zero();
  q[3] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(c.check(q, 0.008), ServoReject::kNonFinite);
  EXPECT_EQ(c.failedJoint(), 3);
  q.setZero();
  q[2] = 1.01;
  EXPECT_EQ(c.check(q, 0.008), ServoReject::kPositionLimit);
  EXPECT_EQ(c.failedJoint(), 2);
  q.setZero();
  q[0] = 2.2 * 0.008;  // 2.2 rad/s > 2.0944
  EXPECT_EQ(c.check(q, 0.008), ServoReject::kVelocityLimit);
  EXPECT_EQ(c.failedJoint(), 0);
  q.setZero();
  q[4] = 1.0 * 0.008;  // 1 rad/s reached in one 8 ms step = 125 rad/s^2 > 40
  EXPECT_EQ(c.check(q, 0.008), ServoReject::kAccelerationLimit);
  // The reference did not move: a held target (zero step) is still fine.
  EXPECT_EQ(c.check(JointVector::Zero(), 0.008), ServoReject::kNone);
}

TEST(ServoSafety, UninitialisedRejects) {
  ServoSafetyCheck c;
  EXPECT_NE(c.check(JointVector::Zero(), 0.008), ServoReject::kNone);
}
