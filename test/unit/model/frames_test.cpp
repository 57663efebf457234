#include <cmath>

#include <gtest/gtest.h>

#include "ftid/model/frames.hpp"

namespace ftid::model {
namespace {

TEST(Frames, TiltRotationIsRxTimesRy) {
  const double u = 0.3, v = -0.2;
  const Mat3 expected =
      (Eigen::AngleAxisd(u, Vec3::UnitX()) * Eigen::AngleAxisd(v, Vec3::UnitY())).toRotationMatrix();
  EXPECT_LT((tiltRotation(u, v) - expected).norm(), 1e-15);
}

TEST(Frames, GravityInBaseMatchesPaperEq13) {
  // g_B = 9.80665 (cos U sin V, -sin U, -cos U cos V), written out independently.
  for (double u : {-0.2, 0.0, 0.17}) {
    for (double v : {-0.09, 0.0, 0.4}) {
      const Vec3 expected = kStandardGravity * Vec3(std::cos(u) * std::sin(v), -std::sin(u), -std::cos(u) * std::cos(v));
      EXPECT_LT((gravityInBase(u, v) - expected).norm(), 1e-14) << u << " " << v;
    }
  }
  EXPECT_LT((gravityInBase(0, 0) - Vec3(0, 0, -kStandardGravity)).norm(), 1e-15);
}

TEST(Frames, GravityInSensorRotatesIntoS) {
  const Mat3 R_BS = Eigen::AngleAxisd(1.0, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  const Vec3 g_S = gravityInSensor(R_BS, 0.1, 0.2);
  EXPECT_LT((R_BS * g_S - gravityInBase(0.1, 0.2)).norm(), 1e-14);
  EXPECT_NEAR(g_S.norm(), kStandardGravity, 1e-12);
}

}  // namespace
}  // namespace ftid::model
