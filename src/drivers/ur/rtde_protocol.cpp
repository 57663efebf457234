#include "ftid/drivers/ur/rtde_protocol.hpp"

#include <algorithm>
#include <map>
#include <sstream>

#include "ftid/common/error.hpp"

namespace ftid::drivers::ur::rtde {

std::size_t dataTypeSize(DataType type) noexcept {
  switch (type) {
    case DataType::kBool:
    case DataType::kUint8: return 1;
    case DataType::kUint32:
    case DataType::kInt32: return 4;
    case DataType::kUint64:
    case DataType::kDouble: return 8;
    case DataType::kVector3d: return 24;
    case DataType::kVector6d: return 48;
    case DataType::kVector6Int32:
    case DataType::kVector6Uint32: return 24;
    case DataType::kNotFound:
    case DataType::kInUse: return 0;
  }
  return 0;
}

const char* dataTypeName(DataType type) noexcept {
  switch (type) {
    case DataType::kBool: return "BOOL";
    case DataType::kUint8: return "UINT8";
    case DataType::kUint32: return "UINT32";
    case DataType::kUint64: return "UINT64";
    case DataType::kInt32: return "INT32";
    case DataType::kDouble: return "DOUBLE";
    case DataType::kVector3d: return "VECTOR3D";
    case DataType::kVector6d: return "VECTOR6D";
    case DataType::kVector6Int32: return "VECTOR6INT32";
    case DataType::kVector6Uint32: return "VECTOR6UINT32";
    case DataType::kNotFound: return "NOT_FOUND";
    case DataType::kInUse: return "IN_USE";
  }
  return "NOT_FOUND";
}

bool parseDataType(const std::string& name, DataType* type) noexcept {
  for (int i = 0; i <= static_cast<int>(DataType::kInUse); ++i) {
    const auto t = static_cast<DataType>(i);
    if (name == dataTypeName(t)) {
      *type = t;
      return true;
    }
  }
  return false;
}

const char* robotModeName(std::int32_t mode) noexcept {
  switch (mode) {
    case -1: return "NO_CONTROLLER";
    case 0: return "DISCONNECTED";
    case 1: return "CONFIRM_SAFETY";
    case 2: return "BOOTING";
    case 3: return "POWER_OFF";
    case 4: return "POWER_ON";
    case 5: return "IDLE";
    case 6: return "BACKDRIVE";
    case 7: return "RUNNING";
    case 8: return "UPDATING_FIRMWARE";
    default: return "UNKNOWN";
  }
}

const char* safetyModeName(std::int32_t mode) noexcept {
  switch (mode) {
    case 1: return "NORMAL";
    case 2: return "REDUCED";
    case 3: return "PROTECTIVE_STOP";
    case 4: return "RECOVERY";
    case 5: return "SAFEGUARD_STOP";
    case 6: return "SYSTEM_EMERGENCY_STOP";
    case 7: return "ROBOT_EMERGENCY_STOP";
    case 8: return "VIOLATION";
    case 9: return "FAULT";
    case 10: return "VALIDATE_JOINT_ID";
    case 11: return "UNDEFINED_SAFETY_MODE";
    case 12: return "AUTOMATIC_MODE_SAFEGUARD_STOP";
    case 13: return "SYSTEM_THREE_POSITION_ENABLING_STOP";
    default: return "UNKNOWN";
  }
}

const char* runtimeStateName(std::uint32_t state) noexcept {
  switch (state) {
    case 0: return "STOPPING";
    case 1: return "STOPPED";
    case 2: return "PLAYING";
    case 3: return "PAUSING";
    case 4: return "PAUSED";
    case 5: return "RESUMING";
    default: return "UNKNOWN";
  }
}

namespace {

using Table = std::map<std::string, DataType>;

const Table& outputTable() {
  static const Table table = [] {
    Table t;
    const DataType D = DataType::kDouble, V6 = DataType::kVector6d, V3 = DataType::kVector3d,
                   I = DataType::kInt32, U32 = DataType::kUint32, U64 = DataType::kUint64,
                   U8 = DataType::kUint8, B = DataType::kBool, V6I = DataType::kVector6Int32;
    for (const char* n : {"timestamp", "actual_execution_time", "speed_scaling", "target_speed_fraction",
                          "actual_momentum", "actual_main_voltage", "actual_robot_voltage",
                          "actual_robot_current", "standard_analog_input0", "standard_analog_input1",
                          "standard_analog_output0", "standard_analog_output1", "io_current",
                          "tool_analog_input0", "tool_analog_input1", "tool_output_current",
                          "tool_temperature", "tcp_force_scalar", "payload",
                          "joint_position_deviation_ratio", "collision_detection_ratio",
                          "target_execution_time", "actual_robot_energy_consumed",
                          "actual_robot_braking_energy_dissipated", "euromap67_24V_voltage",
                          "euromap67_24V_current"}) {
      t[n] = D;
    }
    for (const char* n : {"target_q", "target_qd", "target_qdd", "target_current", "target_moment", "actual_q",
                          "actual_qd", "actual_current", "joint_control_output", "actual_TCP_pose",
                          "actual_TCP_speed", "actual_TCP_force", "target_TCP_pose", "target_TCP_speed",
                          "joint_temperatures", "actual_joint_voltage", "actual_current_window",
                          "actual_current_as_torque", "tcp_offset", "payload_inertia", "ft_raw_wrench",
                          "actual_TCP_acceleration", "target_TCP_acceleration", "target_base_wrench",
                          "wrench_calc_from_currents"}) {
      t[n] = V6;
    }
    for (const char* n : {"actual_tool_accelerometer", "elbow_position", "elbow_velocity", "payload_cog",
                          "target_gravity", "target_base_acceleration"}) {
      t[n] = V3;
    }
    for (const char* n : {"robot_mode", "safety_mode", "safety_status", "tool_output_voltage",
                          "time_scale_source"}) {
      t[n] = I;
    }
    t["joint_mode"] = V6I;
    for (const char* n : {"runtime_state", "robot_status_bits", "safety_status_bits", "analog_io_types",
                          "tool_mode", "tool_analog_input_types", "output_bit_registers0_to_31",
                          "output_bit_registers32_to_63", "input_bit_registers0_to_31",
                          "input_bit_registers32_to_63", "script_control_line", "euromap67_input_bits",
                          "euromap67_output_bits"}) {
      t[n] = U32;
    }
    for (const char* n : {"actual_digital_input_bits", "actual_digital_output_bits", "control_step",
                          "actual_configurable_digital_input_bits",
                          "actual_configurable_digital_output_bits"}) {
      t[n] = U64;
    }
    for (const char* n : {"tool_output_mode", "tool_digital_output0_mode", "tool_digital_output1_mode"}) {
      t[n] = U8;
    }
    for (int i = 0; i < 48; ++i) {
      t["output_int_register_" + std::to_string(i)] = I;
      t["output_double_register_" + std::to_string(i)] = D;
      t["input_int_register_" + std::to_string(i)] = I;
      t["input_double_register_" + std::to_string(i)] = D;
    }
    for (int i = 64; i < 128; ++i) {
      t["output_bit_register_" + std::to_string(i)] = B;
      t["input_bit_register_" + std::to_string(i)] = B;
    }
    return t;
  }();
  return table;
}

const Table& inputTable() {
  static const Table table = [] {
    Table t;
    t["speed_slider_mask"] = DataType::kUint32;
    t["speed_slider_fraction"] = DataType::kDouble;
    for (const char* n : {"standard_digital_output_mask", "standard_digital_output",
                          "configurable_digital_output_mask", "configurable_digital_output",
                          "standard_analog_output_mask", "standard_analog_output_type",
                          "tool_digital_output_mask", "tool_digital_output"}) {
      t[n] = DataType::kUint8;
    }
    t["standard_analog_output_0"] = DataType::kDouble;
    t["standard_analog_output_1"] = DataType::kDouble;
    t["input_bit_registers0_to_31"] = DataType::kUint32;
    t["input_bit_registers32_to_63"] = DataType::kUint32;
    t["external_force_torque"] = DataType::kVector6d;
    for (int i = 0; i < 48; ++i) {
      t["input_int_register_" + std::to_string(i)] = DataType::kInt32;
      t["input_double_register_" + std::to_string(i)] = DataType::kDouble;
    }
    for (int i = 64; i < 128; ++i) t["input_bit_register_" + std::to_string(i)] = DataType::kBool;
    return t;
  }();
  return table;
}

}  // namespace

DataType variableType(const std::string& name, Direction direction) {
  const Table& t = direction == Direction::kOutput ? outputTable() : inputTable();
  const auto it = t.find(name);
  return it == t.end() ? DataType::kNotFound : it->second;
}

std::vector<std::string> knownOutputNames() {
  std::vector<std::string> out;
  for (const auto& kv : outputTable()) out.push_back(kv.first);
  return out;
}

std::vector<std::string> splitNames(const std::string& csv) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : csv) {
    if (c == ',') {
      if (!cur.empty()) out.push_back(cur);
      cur.clear();
    } else if (c != ' ' && c != '\n' && c != '\r' && c != '\t') {
      cur.push_back(c);
    }
  }
  if (!cur.empty()) out.push_back(cur);
  return out;
}

std::string joinNames(const std::vector<std::string>& names) {
  std::string out;
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (i) out.push_back(',');
    out += names[i];
  }
  return out;
}

std::vector<std::uint8_t> encodePackage(PackageType type, const std::vector<std::uint8_t>& payload) {
  const std::size_t total = kHeaderSize + payload.size();
  if (total > kMaxPackageSize) throw DriverError("RTDE package too large (" + std::to_string(total) + " bytes)");
  std::vector<std::uint8_t> out(total);
  putU16(out.data(), static_cast<std::uint16_t>(total));
  out[2] = static_cast<std::uint8_t>(type);
  std::copy(payload.begin(), payload.end(), out.begin() + kHeaderSize);
  return out;
}

std::vector<std::uint8_t> encodeRequestProtocolVersion(std::uint16_t version) {
  std::vector<std::uint8_t> p(2);
  putU16(p.data(), version);
  return encodePackage(PackageType::kRequestProtocolVersion, p);
}

std::vector<std::uint8_t> encodeGetUrcontrolVersion() { return encodePackage(PackageType::kGetUrcontrolVersion, {}); }

std::vector<std::uint8_t> encodeSetupOutputs(double frequency_hz, const std::vector<std::string>& names,
                                             int protocol_version) {
  const std::string list = joinNames(names);
  if (list.size() > kMaxNameListBytes) {
    throw DriverError("RTDE output name list is " + std::to_string(list.size()) + " bytes (limit 2048)");
  }
  std::vector<std::uint8_t> p;
  if (protocol_version >= 2) {
    p.resize(8);
    putDouble(p.data(), frequency_hz);
  }
  p.insert(p.end(), list.begin(), list.end());
  return encodePackage(PackageType::kSetupOutputs, p);
}

std::vector<std::uint8_t> encodeSetupInputs(const std::vector<std::string>& names) {
  const std::string list = joinNames(names);
  if (list.size() > kMaxNameListBytes) {
    throw DriverError("RTDE input name list is " + std::to_string(list.size()) + " bytes (limit 2048)");
  }
  return encodePackage(PackageType::kSetupInputs, std::vector<std::uint8_t>(list.begin(), list.end()));
}

std::vector<std::uint8_t> encodeStart() { return encodePackage(PackageType::kStart, {}); }
std::vector<std::uint8_t> encodePause() { return encodePackage(PackageType::kPause, {}); }

std::vector<std::uint8_t> encodeTextMessage(const std::string& message, const std::string& source,
                                            std::uint8_t level) {
  const std::string m = message.substr(0, 255), s = source.substr(0, 255);
  std::vector<std::uint8_t> p;
  p.push_back(static_cast<std::uint8_t>(m.size()));
  p.insert(p.end(), m.begin(), m.end());
  p.push_back(static_cast<std::uint8_t>(s.size()));
  p.insert(p.end(), s.begin(), s.end());
  p.push_back(level);
  return encodePackage(PackageType::kTextMessage, p);
}

std::string ControllerVersion::toString() const {
  return std::to_string(major) + "." + std::to_string(minor) + "." + std::to_string(bugfix) + "." +
         std::to_string(build);
}

long findPackage(const std::uint8_t* buf, std::size_t size, PackageView* view) noexcept {
  if (size < kHeaderSize) return 0;
  const std::uint16_t total = getU16(buf);
  if (total < kHeaderSize) return -1;
  if (size < total) return 0;
  view->type = static_cast<PackageType>(buf[2]);
  view->payload = buf + kHeaderSize;
  view->payload_size = total - kHeaderSize;
  return static_cast<long>(total);
}

SetupReply decodeSetupReply(const PackageView& view, int protocol_version) {
  SetupReply r;
  std::size_t pos = 0;
  if (protocol_version >= 2 || view.type == PackageType::kSetupInputs) {
    if (view.payload_size < 1) throw DriverError("RTDE setup reply without recipe id");
    r.recipe_id = view.payload[0];
    pos = 1;
  }
  r.types = splitNames(std::string(reinterpret_cast<const char*>(view.payload) + pos, view.payload_size - pos));
  return r;
}

TextMessage decodeTextMessage(const PackageView& view, int protocol_version) {
  TextMessage m;
  const std::uint8_t* p = view.payload;
  const std::size_t n = view.payload_size;
  if (protocol_version >= 2) {
    std::size_t pos = 0;
    auto readString = [&](std::string* out) {
      if (pos >= n) return false;
      const std::size_t len = p[pos++];
      if (pos + len > n) return false;
      out->assign(reinterpret_cast<const char*>(p + pos), len);
      pos += len;
      return true;
    };
    if (!readString(&m.message) || !readString(&m.source) || pos >= n) {
      throw DriverError("malformed RTDE text message");
    }
    m.level = p[pos];
  } else {
    if (n < 1) throw DriverError("malformed RTDE v1 text message");
    m.level = p[0];
    m.message.assign(reinterpret_cast<const char*>(p + 1), n - 1);
  }
  return m;
}

}  // namespace ftid::drivers::ur::rtde
