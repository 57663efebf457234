#pragma once
// One F/T+IMU sensor sample as delivered to the real-time loop, and the sensor's health counters.
// The health flags are the project's one set, ftid::SensorHealth (common/sensor_health.hpp).
// Frames, units and signs of the values are those of docs/conventions.md (wrench the payload
// exerts on the sensor, in S; IMU specific force, angular velocity and acceleration, in S).
#include <cstdint>
#include <limits>

#include "ftid/common/sensor_health.hpp"
#include "ftid/common/types.hpp"

namespace ftid::drivers::can {

struct SensorSample {
  Wrench wrench_S = Wrench::Zero();  ///< [N, Nm]
  Vec3 acc_S = Vec3::Zero();         ///< IMU specific force [m/s^2] (if has_imu)
  Vec3 w_S = Vec3::Zero();           ///< angular velocity [rad/s] (if has_imu)
  Vec3 alpha_S = Vec3::Zero();       ///< angular acceleration [rad/s^2] (if has_imu)
  double temp_degC = std::numeric_limits<double>::quiet_NaN();  ///< (if has_temperature)
  std::uint32_t status_word = 0;     ///< sensor status bits as sent (if has_status)
  std::uint32_t counter = 0;         ///< the sample's rolling counter
  /// Receive time of the frame that completed the sample: kernel SO_TIMESTAMP, CLOCK_REALTIME ns.
  std::int64_t rx_time_ns = 0;
  /// Number of complete samples assembled so far, this one included (0 = none yet).
  std::uint64_t sequence = 0;
  /// ftid::SensorHealth bits (common/sensor_health.hpp), the same bits ftidd publishes. Which of
  /// them make `valid` false: docs/sensor.md, "The sensor object and the health rules".
  std::uint32_t health_flags = kHealthStale | kHealthNoData;
  bool valid = false;      ///< safe to compensate: complete, fresh enough, in range, status ok
  bool fresh = false;      ///< a new complete sample arrived since the previous read
  bool has_imu = false;
  bool has_temperature = false;
  bool has_status = false;
};

/// Counters since the sensor was opened (monotonic; read from the thread that reads samples).
struct SensorHealthCounters {
  std::uint64_t frames_received = 0;    ///< every frame the transport delivered
  std::uint64_t frames_ignored = 0;     ///< ids not in the layout, remote frames
  std::uint64_t frames_malformed = 0;   ///< layout ids with a too-short payload
  std::uint64_t error_frames = 0;       ///< CAN_ERR_FLAG frames
  std::uint64_t bus_off_events = 0;     ///< error frames with CAN_ERR_BUSOFF
  std::uint64_t samples_complete = 0;   ///< samples with every frame present
  std::uint64_t samples_incomplete = 0; ///< frame groups abandoned before completion
  std::uint64_t counter_gaps = 0;       ///< gap events in the rolling counter
  std::uint64_t samples_lost = 0;       ///< samples missing in those gaps
  std::uint64_t counter_repeats = 0;    ///< samples repeating the previous counter
  std::uint64_t out_of_range = 0;       ///< samples with a value outside [min|max]
  std::uint64_t status_faults = 0;      ///< samples whose status word had a fault bit
  std::uint64_t stale_events = 0;       ///< transitions into the stale state
  std::uint64_t transport_errors = 0;   ///< kError/kClosed from the transport
  std::uint32_t last_error_class = 0;   ///< can_id & CAN_ERR_MASK of the last error frame
};

}  // namespace ftid::drivers::can
