#pragma once
// The one set of sensor health flags (bit set = problem). The CAN driver sets them on each sample
// (drivers::can::SensorSample::health_flags), the daemon's loop adds the ones only it can judge
// (stale at the robot state's time, non-finite values) and the same bits are published unchanged
// as sensor_sample_t.health_flags and compensated_wrench_t.sensor_health_flags (lcmtypes/,
// docs/daemon.md). Bits 0-6 are the published set subscribers have always seen, with the same
// numbers and meanings; bits 7-9 refine one of them and are never set without it, so a subscriber
// that tests only bits 0-6 sees exactly what it saw before they existed.
#include <cstdint>

namespace ftid {

enum SensorHealth : std::uint32_t {
  kHealthOk = 0,
  /// No complete sample within the stale timeout, or none yet (then kHealthNoData too).
  kHealthStale = 1u << 0,
  /// The rolling counter skipped values (samples lost), or repeated the previous one (then
  /// kHealthCounterRepeat too).
  kHealthCounterGap = 1u << 1,
  /// CAN error frame(s) seen, or the controller reported bus-off (then kHealthBusOff too).
  kHealthErrorFrame = 1u << 2,
  kHealthOutOfRange = 1u << 3,     ///< a value outside its DBC [min|max]
  kHealthNonFinite = 1u << 4,      ///< NaN or inf in a value (set by the daemon's loop)
  kHealthStatusError = 1u << 5,    ///< the sensor's status word has a bit of status_fault_mask
  kHealthTransportDown = 1u << 6,  ///< the CAN transport failed or closed
  kHealthNoData = 1u << 7,         ///< refines kHealthStale: no complete sample received yet
  kHealthCounterRepeat = 1u << 8,  ///< refines kHealthCounterGap: same counter as the previous
                                   ///< sample (a stuck sensor)
  kHealthBusOff = 1u << 9,         ///< refines kHealthErrorFrame: bus-off, no sample since
};

}  // namespace ftid
