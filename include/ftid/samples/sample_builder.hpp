#pragma once
// The one sample builder: a SampleContext (ftid/effects/effect.hpp) from one instant's joint state,
// the sensor-frame kinematics at it, one sensor reading and gravity in the base. The daemon's cycle
// (online compensation) and buildContexts (offline identification, ftid compensate, the lab) both
// build every context through it, so both see exactly the same inputs for the same sample
// (test/unit/daemon/sample_paths_test.cpp checks this bit for bit). Frames and units:
// docs/conventions.md.
#include "ftid/common/types.hpp"
#include "ftid/effects/effect.hpp"
#include "ftid/model/kinematics.hpp"

namespace ftid::samples {

using effects::SampleContext;

/// What one sensor sample contributes to a context: the reading in S and, if the sensor has them,
/// its IMU and temperature channels.
struct SensorReading {
  Wrench wrench_S = Wrench::Zero();  ///< raw reading in S [N, Nm]
  bool has_imu = false;
  Vec3 imu_acc_S = Vec3::Zero();     ///< IMU specific force [m/s^2]
  Vec3 imu_w_S = Vec3::Zero();       ///< [rad/s]
  Vec3 imu_alpha_S = Vec3::Zero();   ///< [rad/s^2]
  bool has_temp = false;
  double temp_degC = 0.0;
};

/// Fills every field of *out:
///   t, t_model, q, qd                 = the arguments (t [s] since the first sample; t_model [s]
///                                       the model's time, since the parameter set's time origin:
///                                       docs/conventions.md, "Time and logs")
///   R_BS, p_BS_B, w_S, alpha_S, a_S   = motion (RobotKinematics::computeSensorMotion(q, qd, qdd))
///   g_S                               = R_BS^T g_B
///   wrench_S, has_imu, has_temp       = reading
///   imu_*, temp_degC                  = reading if it has them, else zero
///   has_joints = true; extra, extra_names = nullptr; wrench_model_S = 0 (their owners set them).
/// Real-time safe (no allocation, no throw).
void makeSampleContext(double t, double t_model, const JointVector& q, const JointVector& qd,
                       const model::SensorMotion& motion, const SensorReading& reading,
                       const Vec3& g_B, SampleContext* out) noexcept;

}  // namespace ftid::samples
