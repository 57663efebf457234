#pragma once
// The loop's own data: what the daemon's cycle reads (robot state, sensor sample) and produces
// (cycle record, loop statistics), handed to the publishing side. Fixed size, no heap: copying one
// into a queue slot is real-time safe. They live here, below both the daemon and transport, so
// the loop does not depend on LCM; the LCM messages mirror them field for field (lcmtypes/*.lcm,
// encoded by ftid/transport/codec.hpp). Frames, units and signs:
// docs/conventions.md.
#include <cstdint>

#include "ftid/common/sensor_health.hpp"
#include "ftid/common/types.hpp"

namespace ftid {

/// Robot joint state that clocked one cycle (robot_state_t).
struct RobotStateRecord {
  std::int64_t recv_utime = 0;          ///< host receive time [us since epoch]
  double robot_time = 0.0;              ///< controller timestamp [s]
  JointVector q = JointVector::Zero();  ///< [rad]
  JointVector qd = JointVector::Zero(); ///< [rad/s]
  JointVector qdd = JointVector::Zero();///< [rad/s^2]
  bool valid = false;
};

/// One raw sensor sample (sensor_sample_t).
struct SensorSampleRecord {
  std::int64_t recv_utime = 0;      ///< host receive time of the sample's last frame [us since epoch]
  /// The same receipt on the host's CLOCK_MONOTONIC [us]: the clock of the sample's age, which a
  /// step of the real-time clock cannot change. 0: unknown, and such a sample is never fresh.
  /// Loop-internal: not in sensor_sample_t (a subscriber's monotonic clock is not this host's).
  std::int64_t recv_mono_us = 0;
  std::int32_t counter = 0;         ///< sensor rolling counter
  Wrench wrench_S = Wrench::Zero(); ///< raw reading in S [N, Nm]
  Vec3 imu_acc_S = Vec3::Zero();    ///< specific force [m/s^2]
  Vec3 imu_w_S = Vec3::Zero();      ///< [rad/s]
  Vec3 imu_alpha_S = Vec3::Zero();  ///< [rad/s^2]
  double temp_degC = 0.0;
  bool has_imu = false;
  bool has_temp = false;
  std::int32_t status_word = 0;
  std::uint32_t health_flags = kHealthOk;  ///< SensorHealth bits (common/sensor_health.hpp)
  bool valid = false;
};

/// Everything one loop cycle produces (cycle_sample_t + compensated_wrench_t).
struct CycleRecord {
  std::int64_t utime = 0;         ///< cycle start (robot packet received) [us since epoch]
  std::int64_t cycle = 0;         ///< cycle number since start
  RobotStateRecord robot;
  SensorSampleRecord sensor;
  /// Age of the sample used at the cycle's start on the host's monotonic clock [us]
  /// (now - sensor.recv_mono_us); -1 if no sample ever (or its receipt is unknown).
  std::int64_t sensor_age_us = 0;
  std::uint32_t fault_bits = 0;   ///< ftid::FaultBit
  Wrench modelled_S = Wrench::Zero();  ///< model prediction [N, Nm]
  Wrench contact_S = Wrench::Zero();   ///< raw - modelled, zero when !wrench_valid
  /// The contact wrench in the output frame, low-pass filtered (daemon::OutputStage); zero
  /// when !wrench_valid.
  Wrench output = Wrench::Zero();
  std::int8_t output_frame = 0;        ///< 0 sensor, 1 tool, 2 base (compensated_wrench_t)
  bool wrench_valid = false;
  std::int32_t param_version = 0;
};

/// Loop statistics for one report interval (loop_stats_t).
struct LoopStatsRecord {
  std::int64_t utime = 0;
  double uptime_s = 0.0;
  std::int64_t cycles = 0;
  std::int64_t missed_cycles = 0;
  std::int64_t overruns = 0;
  double compute_p50_us = 0.0;
  double compute_p999_us = 0.0;
  double compute_max_us = 0.0;
  std::int64_t valid_cycles = 0;
  std::int64_t invalid_cycles = 0;
  std::int64_t stale_sensor_cycles = 0;
  std::int64_t robot_clock_faults = 0;          ///< controller clock states found not sane
  std::int64_t robot_clock_invalid_cycles = 0;  ///< cycles invalid because of it
  std::int64_t publish_dropped = 0;
  std::int64_t published = 0;
  std::int32_t reloads_applied = 0;
  std::int32_t reloads_failed = 0;
  std::int32_t param_version = 0;
  std::int32_t commands_refused_auth = 0;
  std::int32_t commands_refused_stale = 0;
  std::int32_t commands_refused_replay = 0;
  std::int32_t commands_refused_malformed = 0;
  std::int32_t tares_done = 0;
  std::int32_t tares_refused = 0;
  std::uint32_t fault_bits = 0;
  bool realtime = false;
  bool robot_link_up = false;
  std::int32_t robot_reconnects = 0;
  double robot_link_down_s = 0.0;
  std::int32_t sensor_reconnects = 0;
};

}  // namespace ftid
