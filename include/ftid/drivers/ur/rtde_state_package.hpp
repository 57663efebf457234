#pragma once
// The decoded RTDE state package: the wire format's data, every field an RTDE output recipe can
// carry, as the controller sends it (doubles, registers by number, which fields were present).
// Only the RTDE client and the code right above it read it; loops see their own view of a tick
// (drivers::ur::ArmState, ftid::RobotStateRecord; docs/architecture.md, "Robot state types").
// A fixed-size, trivially copyable struct (safe to hand to other threads through
// ftid::rt::Mailbox / SpscQueue). Fields not in the output recipe keep their default value;
// `present` says which groups were received.
#include <array>
#include <cstdint>

namespace ftid::drivers::ur {

inline constexpr int kNumRegisters = 48;  ///< output/input int and double registers 0..47

using Joint6 = std::array<double, 6>;

/// Bits of RtdeStatePackage::present.
enum RtdeStateField : std::uint32_t {
  kFieldTimestamp = 1u << 0,
  kFieldActualQ = 1u << 1,
  kFieldActualQd = 1u << 2,
  kFieldTargetQ = 1u << 3,
  kFieldTargetQd = 1u << 4,
  kFieldTargetQdd = 1u << 5,
  kFieldActualTcpPose = 1u << 6,
  kFieldRobotMode = 1u << 7,
  kFieldSafetyMode = 1u << 8,
  kFieldRuntimeState = 1u << 9,
  kFieldRobotStatusBits = 1u << 10,
  kFieldSafetyStatusBits = 1u << 11,
  kFieldSpeedScaling = 1u << 12,
  kFieldActualCurrent = 1u << 13,
  kFieldTargetMoment = 1u << 14,
  kFieldJointTemperatures = 1u << 15,
  kFieldOutputIntRegisters = 1u << 16,
  kFieldOutputDoubleRegisters = 1u << 17,
  kFieldActualTcpForce = 1u << 18,
  kFieldTargetSpeedFraction = 1u << 19,
};

struct RtdeStatePackage {
  double timestamp = 0.0;        ///< controller time since boot [s] (advances one period per tick)
  Joint6 actual_q{};             ///< [rad]
  Joint6 actual_qd{};            ///< [rad/s]
  Joint6 target_q{};             ///< [rad]
  Joint6 target_qd{};            ///< [rad/s]
  Joint6 target_qdd{};           ///< [rad/s^2]
  Joint6 actual_TCP_pose{};      ///< x, y, z [m], rotation vector [rad], controller base frame
  Joint6 actual_TCP_force{};     ///< [N, Nm] (controller estimate)
  Joint6 actual_current{};       ///< [A]
  Joint6 target_moment{};        ///< [Nm]
  Joint6 joint_temperatures{};   ///< [degC]
  std::int32_t robot_mode = -1;  ///< rtde::RobotMode
  std::int32_t safety_mode = 0;  ///< rtde::SafetyMode
  std::uint32_t runtime_state = 0;       ///< rtde::RuntimeState
  std::uint32_t robot_status_bits = 0;   ///< bit0 power on, bit1 program running
  std::uint32_t safety_status_bits = 0;  ///< bit2 protective stopped, bit5..7 e-stop, ...
  double speed_scaling = 1.0;
  double target_speed_fraction = 1.0;
  std::array<std::int32_t, kNumRegisters> output_int_register{};   ///< by register number
  std::array<double, kNumRegisters> output_double_register{};      ///< by register number
  std::uint64_t output_int_present = 0;     ///< bit n: output_int_register_n was in the recipe
  std::uint64_t output_double_present = 0;  ///< bit n: output_double_register_n was in the recipe
  std::uint32_t present = 0;                ///< RtdeStateField bits that were in the recipe
  std::int64_t host_receive_ns = 0;  ///< CLOCK_MONOTONIC time the package was read [ns]
  std::uint32_t packages_skipped = 0;  ///< older buffered packages dropped for this one (drain-to-latest)
};

}  // namespace ftid::drivers::ur
