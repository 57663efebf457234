#pragma once
// Seeded random records for transport tests.
#include <random>

#include "ftid/common/records.hpp"

namespace ftid::transport::test {

inline CycleRecord randomCycleRecord(std::mt19937_64& rng, std::int64_t cycle) {
  std::uniform_real_distribution<double> u(-10.0, 10.0);
  std::uniform_int_distribution<std::int32_t> i32(-1000000, 1000000);
  CycleRecord r;
  r.utime = 1'700'000'000'000'000 + cycle * 8000;
  r.cycle = cycle;
  r.robot.recv_utime = r.utime - 50;
  r.robot.robot_time = 1000.0 + 0.008 * static_cast<double>(cycle);
  for (int j = 0; j < 6; ++j) {
    r.robot.q(j) = u(rng);
    r.robot.qd(j) = u(rng);
    r.robot.qdd(j) = u(rng);
    r.sensor.wrench_S(j) = u(rng);
    r.modelled_S(j) = u(rng);
    r.contact_S(j) = u(rng);
  }
  r.robot.valid = true;
  r.sensor.recv_utime = r.utime - 700;
  r.sensor.counter = i32(rng);
  for (int k = 0; k < 3; ++k) {
    r.sensor.imu_acc_S(k) = u(rng);
    r.sensor.imu_w_S(k) = u(rng);
    r.sensor.imu_alpha_S(k) = u(rng);
  }
  r.sensor.temp_degC = 20.0 + u(rng);
  r.sensor.has_imu = true;
  r.sensor.has_temp = true;
  r.sensor.status_word = i32(rng);
  r.sensor.health_flags = kHealthCounterGap;
  r.sensor.valid = true;
  r.sensor_age_us = 700;
  r.fault_bits = 0x21;
  r.wrench_valid = true;
  r.param_version = 3;
  return r;
}

}  // namespace ftid::transport::test
