#pragma once
// Decoders of the two ROS 2 messages ftid reads from a rosbag2 (docs/log-format.md "ROS 2
// bags"), from their serialized form: OMG CDR (XCDR1, plain), as rmw_fastrtps/cyclonedds write it
// into a bag: a 4-byte encapsulation header (0x00 0x01 little-endian or 0x00 0x00 big-endian,
// two option bytes), then the fields, each primitive aligned to its size counted from the end of
// the header; strings are a uint32 length (with the terminating NUL) and the bytes; sequences a
// uint32 count and the elements. Bytes from a bag are untrusted: every length is checked against
// what is left and against the limits below, and any violation is a DataError saying which
// field and at which byte.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "ftid/common/types.hpp"

namespace ftid::logio {

inline constexpr std::size_t kMaxCdrMessageBytes = 1 << 20;  ///< one message
inline constexpr std::size_t kMaxJointNames = 64;            ///< JointState entries
inline constexpr std::size_t kMaxCdrStringBytes = 1024;      ///< one string (name, frame_id)

/// sensor_msgs/msg/JointState.
struct JointStateMsg {
  std::int32_t stamp_sec = 0;
  std::uint32_t stamp_nanosec = 0;
  std::string frame_id;
  std::vector<std::string> name;
  std::vector<double> position;  ///< [rad]
  std::vector<double> velocity;  ///< [rad/s] (may be empty)
  std::vector<double> effort;    ///< (may be empty)
};

/// geometry_msgs/msg/WrenchStamped.
struct WrenchStampedMsg {
  std::int32_t stamp_sec = 0;
  std::uint32_t stamp_nanosec = 0;
  std::string frame_id;
  Wrench wrench = Wrench::Zero();  ///< force [N], torque [Nm]
};

/// Decode one message; throws DataError("CDR TYPE: FIELD at byte N: problem"). Trailing bytes
/// beyond the message (CDR pads to 4) are allowed up to 8.
JointStateMsg decodeJointState(const std::uint8_t* data, std::size_t size);
WrenchStampedMsg decodeWrenchStamped(const std::uint8_t* data, std::size_t size);

}  // namespace ftid::logio
