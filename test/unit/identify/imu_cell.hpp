#pragma once
// Test helper: a paper cell with a MEMS-grade IMU in the sensor (biases, its own rotation and
// stream delay), and the simulator's own IMU noise for seed studies.
#include <memory>
#include <random>
#include <vector>

#include "paper_cell.hpp"

namespace ftid::test {

/// Paper cell, full rigid-body physics, duration `duration_s`, with the IMU's errors switched on:
/// biases (0.03, -0.02, 0.04) m/s^2 and (0.002, -0.003, 0.001) rad/s, the sensor (and its IMU)
/// mounted rotated by roll 1, pitch -2, yaw 3 deg, the IMU stream lagging by 12 ms.
inline sim::CellSimConfig imuCellConfig(double duration_s) {
  sim::CellSimConfig cfg = sim::paperCellConfig(ur10());
  cfg.duration_s = duration_s;
  cfg.imu.enabled = true;
  cfg.imu.delay_s = 0.012;
  cfg.mounting.enabled = true;
  cfg.mounting.rpy_rad = Vec3(1.0, -2.0, 3.0) * kDegToRad;
  cfg.mounting.rotate_imu = true;
  return cfg;
}

/// The simulator's own IMU noise (CellSim::addNoise with acc_std / gyro_std) added to the IMU
/// columns of contexts built from a noise-free run (the wrench is left as it is).
inline std::function<void(std::vector<effects::SampleContext>&, std::mt19937_64&)> simulatorImuNoise(
    const sim::CellSimConfig& config) {
  auto simulator = std::make_shared<sim::CellSim>(config);
  return [simulator](std::vector<effects::SampleContext>& ctx, std::mt19937_64& rng) {
    for (auto& c : ctx) {
      sim::SensorReading r;
      r.acc_S = c.imu_acc_S;
      r.w_S = c.imu_w_S;
      r.alpha_S = c.imu_alpha_S;
      simulator->addNoise(r, rng);
      c.imu_acc_S = r.acc_S;
      c.imu_w_S = r.w_S;
      c.imu_alpha_S = r.alpha_S;
    }
  };
}

}  // namespace ftid::test
