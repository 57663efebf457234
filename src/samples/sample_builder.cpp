// The one sample builder (include/ftid/samples/sample_builder.hpp).
#include "ftid/samples/sample_builder.hpp"

namespace ftid::samples {

void makeSampleContext(double t, double t_model, const JointVector& q, const JointVector& qd,
                       const model::SensorMotion& motion, const SensorReading& reading,
                       const Vec3& g_B, SampleContext* out) noexcept {
  SampleContext& c = *out;
  c.t = t;
  c.t_model = t_model;
  c.q = q;
  c.qd = qd;
  c.R_BS = motion.R_BS;
  c.p_BS_B = motion.p_BS_B;
  c.w_S = motion.w_S;
  c.alpha_S = motion.alpha_S;
  c.a_S = motion.a_S;
  c.g_S = motion.R_BS.transpose() * g_B;
  c.wrench_S = reading.wrench_S;
  c.has_imu = reading.has_imu;
  if (reading.has_imu) {
    c.imu_acc_S = reading.imu_acc_S;
    c.imu_w_S = reading.imu_w_S;
    c.imu_alpha_S = reading.imu_alpha_S;
  } else {
    c.imu_acc_S.setZero();
    c.imu_w_S.setZero();
    c.imu_alpha_S.setZero();
  }
  c.has_temp = reading.has_temp;
  c.temp_degC = reading.has_temp ? reading.temp_degC : 0.0;
  c.has_joints = true;
  c.extra = nullptr;
  c.extra_names = nullptr;
  c.wrench_model_S.setZero();
}

}  // namespace ftid::samples
