#pragma once
// RTDE wire format (UR Real-Time Data Exchange, TCP port 30004), protocol versions 1 and 2.
// Pure functions and tables only: no sockets. Shared by the client (RtdeClient) and the
// controller simulator (ftid::simrobot). Byte layouts: docs/robot.md (from Universal
// Robots' RTDE guide).
//
// Every package: uint16 BE total size (including the 3-byte header), uint8 type, payload.
// All integers and doubles are big-endian; doubles are IEEE-754 binary64.
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace ftid::drivers::ur::rtde {

inline constexpr std::uint16_t kDefaultPort = 30004;
inline constexpr std::uint16_t kProtocolVersion2 = 2;
inline constexpr std::size_t kHeaderSize = 3;
inline constexpr std::size_t kMaxPackageSize = 65535;
inline constexpr std::size_t kMaxNameListBytes = 2048;

enum class PackageType : std::uint8_t {
  kRequestProtocolVersion = 86,  // 'V'
  kGetUrcontrolVersion = 118,    // 'v'
  kTextMessage = 77,             // 'M'
  kDataPackage = 85,             // 'U'
  kSetupOutputs = 79,            // 'O'
  kSetupInputs = 73,             // 'I'
  kStart = 83,                   // 'S'
  kPause = 80,                   // 'P'
};

/// RTDE data types. kNotFound / kInUse only appear in setup replies.
enum class DataType : std::uint8_t {
  kBool,
  kUint8,
  kUint32,
  kUint64,
  kInt32,
  kDouble,
  kVector3d,
  kVector6d,
  kVector6Int32,
  kVector6Uint32,
  kNotFound,
  kInUse,
};

/// Wire size of a value of this type (0 for kNotFound/kInUse).
std::size_t dataTypeSize(DataType type) noexcept;
/// "DOUBLE", "VECTOR6D", "NOT_FOUND", ...
const char* dataTypeName(DataType type) noexcept;
/// Parses a type name from a setup reply; returns false if unknown.
bool parseDataType(const std::string& name, DataType* type) noexcept;

/// Enumerations.
enum RobotMode : std::int32_t {
  kRobotModeNoController = -1,
  kRobotModeDisconnected = 0,
  kRobotModeConfirmSafety = 1,
  kRobotModeBooting = 2,
  kRobotModePowerOff = 3,
  kRobotModePowerOn = 4,
  kRobotModeIdle = 5,
  kRobotModeBackdrive = 6,
  kRobotModeRunning = 7,
};
enum SafetyMode : std::int32_t {
  kSafetyModeNormal = 1,
  kSafetyModeReduced = 2,
  kSafetyModeProtectiveStop = 3,
  kSafetyModeRecovery = 4,
  kSafetyModeSafeguardStop = 5,
  kSafetyModeSystemEmergencyStop = 6,
  kSafetyModeRobotEmergencyStop = 7,
  kSafetyModeViolation = 8,
  kSafetyModeFault = 9,
};
enum RuntimeState : std::uint32_t {
  kRuntimeStopping = 0,
  kRuntimeStopped = 1,
  kRuntimePlaying = 2,
  kRuntimePausing = 3,
  kRuntimePaused = 4,
  kRuntimeResuming = 5,
};
inline constexpr std::uint32_t kRobotStatusPowerOn = 1u << 0;
inline constexpr std::uint32_t kRobotStatusProgramRunning = 1u << 1;
inline constexpr std::uint32_t kSafetyStatusNormal = 1u << 0;
inline constexpr std::uint32_t kSafetyStatusReduced = 1u << 1;
inline constexpr std::uint32_t kSafetyStatusProtectiveStopped = 1u << 2;
inline constexpr std::uint32_t kSafetyStatusRecovery = 1u << 3;
inline constexpr std::uint32_t kSafetyStatusSafeguardStopped = 1u << 4;
inline constexpr std::uint32_t kSafetyStatusSystemEmergencyStopped = 1u << 5;
inline constexpr std::uint32_t kSafetyStatusRobotEmergencyStopped = 1u << 6;
inline constexpr std::uint32_t kSafetyStatusEmergencyStopped = 1u << 7;
inline constexpr std::uint32_t kSafetyStatusViolation = 1u << 8;
inline constexpr std::uint32_t kSafetyStatusFault = 1u << 9;
inline constexpr std::uint32_t kSafetyStatusStoppedDueToSafety = 1u << 10;

const char* robotModeName(std::int32_t mode) noexcept;   ///< "RUNNING", "POWER_OFF", ...
const char* safetyModeName(std::int32_t mode) noexcept;  ///< "NORMAL", "PROTECTIVE_STOP", ...
const char* runtimeStateName(std::uint32_t state) noexcept;

/// Where a variable lives.
enum class Direction : std::uint8_t { kOutput, kInput };

/// The controller's variable table (controller outputs and inputs). Inputs are also
/// readable as outputs (read-back), as on a real controller.
/// Returns kNotFound if the name is unknown for this direction.
DataType variableType(const std::string& name, Direction direction);
/// All output names known to the table (for documentation and tests).
std::vector<std::string> knownOutputNames();

/// Splits a comma-separated name list, dropping empty tokens (ur_rtde sends a trailing comma).
std::vector<std::string> splitNames(const std::string& csv);
std::string joinNames(const std::vector<std::string>& names);

// ---------------------------------------------------------------------------------------------
// Big-endian helpers (real-time safe).
inline void putU16(std::uint8_t* p, std::uint16_t v) noexcept {
  p[0] = static_cast<std::uint8_t>(v >> 8);
  p[1] = static_cast<std::uint8_t>(v);
}
inline void putU32(std::uint8_t* p, std::uint32_t v) noexcept {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<std::uint8_t>(v >> (24 - 8 * i));
}
inline void putU64(std::uint8_t* p, std::uint64_t v) noexcept {
  for (int i = 0; i < 8; ++i) p[i] = static_cast<std::uint8_t>(v >> (56 - 8 * i));
}
inline void putI32(std::uint8_t* p, std::int32_t v) noexcept { putU32(p, static_cast<std::uint32_t>(v)); }
inline void putDouble(std::uint8_t* p, double v) noexcept {
  std::uint64_t bits;
  std::memcpy(&bits, &v, sizeof bits);
  putU64(p, bits);
}
inline std::uint16_t getU16(const std::uint8_t* p) noexcept {
  return static_cast<std::uint16_t>((p[0] << 8) | p[1]);
}
inline std::uint32_t getU32(const std::uint8_t* p) noexcept {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) |
         std::uint32_t{p[3]};
}
inline std::uint64_t getU64(const std::uint8_t* p) noexcept {
  return (std::uint64_t{getU32(p)} << 32) | getU32(p + 4);
}
inline std::int32_t getI32(const std::uint8_t* p) noexcept {
  return static_cast<std::int32_t>(getU32(p));
}
inline double getDouble(const std::uint8_t* p) noexcept {
  const std::uint64_t bits = getU64(p);
  double v;
  std::memcpy(&v, &bits, sizeof v);
  return v;
}

// ---------------------------------------------------------------------------------------------
// Package encoders for the set-up phase (allocate; not for the loop).
std::vector<std::uint8_t> encodePackage(PackageType type, const std::vector<std::uint8_t>& payload);
std::vector<std::uint8_t> encodeRequestProtocolVersion(std::uint16_t version);  // 00 05 56 00 02
std::vector<std::uint8_t> encodeGetUrcontrolVersion();                          // 00 03 76
std::vector<std::uint8_t> encodeSetupOutputs(double frequency_hz, const std::vector<std::string>& names,
                                             int protocol_version = 2);
std::vector<std::uint8_t> encodeSetupInputs(const std::vector<std::string>& names);
std::vector<std::uint8_t> encodeStart();  // 00 03 53
std::vector<std::uint8_t> encodePause();  // 00 03 50
/// v2 text message: uint8 len, msg, uint8 len, source, uint8 level (strings truncated to 255).
std::vector<std::uint8_t> encodeTextMessage(const std::string& message, const std::string& source,
                                            std::uint8_t level);

struct ControllerVersion {
  std::uint32_t major = 0, minor = 0, bugfix = 0, build = 0;
  std::string toString() const;  ///< "3.15.8.106339"
};

/// A complete package split into type and payload (payload points into the caller's buffer).
struct PackageView {
  PackageType type{};
  const std::uint8_t* payload = nullptr;
  std::size_t payload_size = 0;
};

/// Finds the first complete package in buf[0..size). Returns its total size, 0 if incomplete,
/// or -1 if the header is invalid (size < 3). Real-time safe.
long findPackage(const std::uint8_t* buf, std::size_t size, PackageView* view) noexcept;

/// Parsed setup reply: recipe id and the types in request order.
struct SetupReply {
  std::uint8_t recipe_id = 0;
  std::vector<std::string> types;
};
SetupReply decodeSetupReply(const PackageView& view, int protocol_version = 2);

struct TextMessage {
  std::string message;
  std::string source;
  std::uint8_t level = 3;  ///< 0 EXCEPTION, 1 ERROR, 2 WARNING, 3 INFO
};
TextMessage decodeTextMessage(const PackageView& view, int protocol_version = 2);

}  // namespace ftid::drivers::ur::rtde
