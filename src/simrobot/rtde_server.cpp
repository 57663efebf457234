#include "rtde_server.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>

#include "net.hpp"

namespace ftid::simrobot {

namespace rtde = ftid::drivers::ur::rtde;

enum class OutKind : std::uint8_t {
  kZero, kTimestamp, kTargetQ, kTargetQd, kTargetQdd, kActualQ, kActualQd, kTcpPose, kTargetTcpPose,
  kRobotMode, kSafetyMode, kSafetyStatus, kRuntimeState, kRobotStatusBits, kSafetyStatusBits, kSpeedScaling,
  kTargetSpeedFraction, kJointMode, kJointTemperatures, kMainVoltage, kRobotVoltage, kRobotCurrent,
  kJointVoltage, kOutInt, kOutDouble, kInInt, kInDouble, kInBit, kOutBit, kExecutionTime, kToolMode,
  kPayload,
};

struct RtdeServer::OutField {
  OutKind kind = OutKind::kZero;
  rtde::DataType type = rtde::DataType::kDouble;
  int index = 0;
};

struct RtdeServer::InField {
  std::string name;
  rtde::DataType type;
};

struct RtdeServer::Connection {
  int fd = -1;
  int id = 0;
  std::vector<std::uint8_t> rx;
  std::vector<std::uint8_t> tx;
  int protocol = 1;
  std::vector<OutField> outputs;
  bool outputs_valid = false;
  std::uint8_t output_id = 1;
  int decimation = 1;
  int decimation_counter = 0;
  std::map<std::uint8_t, std::vector<InField>> inputs;
  std::uint8_t next_input_id = 1;
  bool started = false;
  bool close = false;
};

namespace {

constexpr std::size_t kMaxQueuedBytes = 4 * 1024 * 1024;  // a client that stops reading is closed
// UR joint_mode values (RTDE guide): every joint RUNNING, or POWER_OFF.
constexpr std::int32_t kJointModeRunning = 253;
constexpr std::int32_t kJointModePowerOff = 239;

RtdeServer::OutField classifyOutput(const std::string& name, rtde::DataType type) {
  static const std::map<std::string, OutKind> fixed = {
      {"timestamp", OutKind::kTimestamp}, {"target_q", OutKind::kTargetQ}, {"target_qd", OutKind::kTargetQd},
      {"target_qdd", OutKind::kTargetQdd}, {"actual_q", OutKind::kActualQ}, {"actual_qd", OutKind::kActualQd},
      {"actual_TCP_pose", OutKind::kTcpPose}, {"target_TCP_pose", OutKind::kTargetTcpPose},
      {"robot_mode", OutKind::kRobotMode}, {"safety_mode", OutKind::kSafetyMode},
      {"safety_status", OutKind::kSafetyStatus}, {"runtime_state", OutKind::kRuntimeState},
      {"robot_status_bits", OutKind::kRobotStatusBits}, {"safety_status_bits", OutKind::kSafetyStatusBits},
      {"speed_scaling", OutKind::kSpeedScaling}, {"target_speed_fraction", OutKind::kTargetSpeedFraction},
      {"joint_mode", OutKind::kJointMode}, {"joint_temperatures", OutKind::kJointTemperatures},
      {"actual_main_voltage", OutKind::kMainVoltage}, {"actual_robot_voltage", OutKind::kRobotVoltage},
      {"actual_robot_current", OutKind::kRobotCurrent}, {"actual_joint_voltage", OutKind::kJointVoltage},
      {"actual_execution_time", OutKind::kExecutionTime}, {"tool_mode", OutKind::kToolMode},
      {"payload", OutKind::kPayload}};
  RtdeServer::OutField f;
  f.type = type;
  const auto it = fixed.find(name);
  if (it != fixed.end()) {
    f.kind = it->second;
    return f;
  }
  auto reg = [&](const char* prefix, OutKind kind) {
    const std::string p(prefix);
    if (name.rfind(p, 0) != 0) return false;
    f.kind = kind;
    f.index = std::atoi(name.c_str() + p.size());
    return true;
  };
  if (reg("output_int_register_", OutKind::kOutInt) || reg("output_double_register_", OutKind::kOutDouble) ||
      reg("input_int_register_", OutKind::kInInt) || reg("input_double_register_", OutKind::kInDouble) ||
      reg("input_bit_register_", OutKind::kInBit) || reg("output_bit_register_", OutKind::kOutBit)) {
    return f;
  }
  return f;  // known name without a model: zeros of the right size
}

void putVec(std::vector<std::uint8_t>* out, const JointVector& v) {
  for (int i = 0; i < 6; ++i) {
    std::uint8_t b[8];
    rtde::putDouble(b, v[i]);
    out->insert(out->end(), b, b + 8);
  }
}

template <class T, std::size_t N>
T at(const std::array<T, N>& a, int i, T fallback) {
  return i >= 0 && i < static_cast<int>(N) ? a[static_cast<std::size_t>(i)] : fallback;
}

}  // namespace

RtdeServer::RtdeServer(Controller& controller, int listen_fd) : controller_(controller), listen_fd_(listen_fd) {}

RtdeServer::~RtdeServer() { closeAll(); }

std::size_t RtdeServer::addPollFds(std::vector<pollfd>* fds) const {
  fds->push_back({listen_fd_, POLLIN, 0});
  for (const auto& c : conns_) {
    fds->push_back({c->fd, static_cast<short>(POLLIN | (c->tx.empty() ? 0 : POLLOUT)), 0});
  }
  return conns_.size() + 1;
}

void RtdeServer::onPoll(const pollfd* fds, std::size_t n) {
  if (n == 0) return;
  const std::size_t existing = conns_.size();
  if (fds[0].revents & POLLIN) accept();
  for (std::size_t i = 0; i < existing && i + 1 < n; ++i) {
    const pollfd& p = fds[i + 1];
    Connection* c = conns_[i].get();
    if (p.fd != c->fd) continue;
    if (p.revents & (POLLIN | POLLHUP | POLLERR)) read(c);
    if (p.revents & POLLOUT) flush(c);
  }
}

void RtdeServer::accept() {
  const int fd = net::acceptConnection(listen_fd_);
  if (fd < 0) return;
  auto c = std::make_unique<Connection>();
  c->fd = fd;
  c->id = next_conn_id_++;
  controller_.log("RTDE client " + std::to_string(c->id) + " connected");
  conns_.push_back(std::move(c));
}

void RtdeServer::flush(Connection* c) {
  if (!c->close) net::flushBytes(c->fd, &c->tx, &c->close);
}

void RtdeServer::read(Connection* c) {
  if (!net::readAvailable(c->fd, &c->rx)) c->close = true;
  std::size_t pos = 0;
  for (;;) {
    rtde::PackageView v;
    const long n = rtde::findPackage(c->rx.data() + pos, c->rx.size() - pos, &v);
    if (n < 0) {
      c->close = true;
      break;
    }
    if (n == 0) break;
    handlePackage(c, v);
    pos += static_cast<std::size_t>(n);
  }
  c->rx.erase(c->rx.begin(), c->rx.begin() + static_cast<long>(pos));
  flush(c);
}

// Before a marked connection's socket is closed (net::closeMarked): its input registers are free
// again, and the log says who left.
void RtdeServer::forget(const Connection* c) {
  for (auto it = input_owner_.begin(); it != input_owner_.end();) {
    it = it->second == c->id ? input_owner_.erase(it) : std::next(it);
  }
  controller_.log("RTDE client " + std::to_string(c->id) + " disconnected");
}

void RtdeServer::closeMarked() {
  net::closeMarked(&conns_, [this](const Connection* c) { forget(c); });
}

void RtdeServer::disconnectAll() {
  for (auto& c : conns_) c->close = true;
}

void RtdeServer::closeAll() {
  net::closeAll(&conns_, &listen_fd_);
  input_owner_.clear();
}

// ---------------------------------------------------------------------------------- outputs
void RtdeServer::appendValue(std::vector<std::uint8_t>* out, const OutField& f) const {
  const Controller& k = controller_;
  const RegisterFile& reg = k.registers();
  std::uint8_t b[8];
  auto dbl = [&](double v) {
    rtde::putDouble(b, v);
    out->insert(out->end(), b, b + 8);
  };
  auto i32 = [&](std::int32_t v) {
    rtde::putI32(b, v);
    out->insert(out->end(), b, b + 4);
  };
  auto u32 = [&](std::uint32_t v) {
    rtde::putU32(b, v);
    out->insert(out->end(), b, b + 4);
  };
  const bool running = k.robotMode() == rtde::kRobotModeRunning;
  switch (f.kind) {
    case OutKind::kTimestamp: dbl(k.timestamp()); return;
    case OutKind::kTargetQ: putVec(out, k.motion().q()); return;
    case OutKind::kTargetQd: putVec(out, k.motion().qd()); return;
    case OutKind::kTargetQdd: putVec(out, k.motion().qdd()); return;
    case OutKind::kActualQ: putVec(out, k.actualQ()); return;
    case OutKind::kActualQd: putVec(out, k.actualQd()); return;
    case OutKind::kTcpPose: putVec(out, forwardKinematicsTcpPose(k.config().model, k.actualQ())); return;
    case OutKind::kTargetTcpPose: putVec(out, forwardKinematicsTcpPose(k.config().model, k.motion().q())); return;
    case OutKind::kRobotMode: i32(k.robotMode()); return;
    case OutKind::kSafetyMode:
    case OutKind::kSafetyStatus: i32(k.safetyMode()); return;
    case OutKind::kRuntimeState: u32(k.runtimeState()); return;
    case OutKind::kRobotStatusBits: u32(k.robotStatusBits()); return;
    case OutKind::kSafetyStatusBits: u32(k.safetyStatusBits()); return;
    case OutKind::kSpeedScaling:
    case OutKind::kTargetSpeedFraction: dbl(1.0); return;
    case OutKind::kJointMode:
      for (int i = 0; i < 6; ++i) i32(running ? kJointModeRunning : kJointModePowerOff);
      return;
    case OutKind::kJointTemperatures: putVec(out, JointVector::Constant(35.0)); return;
    case OutKind::kMainVoltage:
    case OutKind::kRobotVoltage: dbl(48.0); return;
    case OutKind::kRobotCurrent: dbl(running ? 0.6 : 0.0); return;
    case OutKind::kJointVoltage: putVec(out, JointVector::Constant(48.0)); return;
    case OutKind::kExecutionTime: dbl(k.period() * 0.1); return;
    case OutKind::kOutInt: i32(at(reg.out_int, f.index, 0)); return;
    case OutKind::kOutDouble: dbl(at(reg.out_double, f.index, 0.0)); return;
    case OutKind::kInInt: i32(at(reg.in_int, f.index, 0)); return;
    case OutKind::kInDouble: dbl(at(reg.in_double, f.index, 0.0)); return;
    case OutKind::kInBit: out->push_back(at(reg.in_bit, f.index, false) ? 1 : 0); return;
    case OutKind::kOutBit: out->push_back(at(reg.out_bit, f.index, false) ? 1 : 0); return;
    case OutKind::kToolMode:
    case OutKind::kPayload:
    case OutKind::kZero: break;
  }
  out->insert(out->end(), rtde::dataTypeSize(f.type), 0);
}

void RtdeServer::publish(const Controller::TickResult& tick) {
  if (!tick.advanced) return;
  for (auto& c : conns_) {
    if (!c->started || !c->outputs_valid || c->close) continue;
    if (++c->decimation_counter < c->decimation) continue;
    c->decimation_counter = 0;
    if (tick.drop) {
      ++packages_dropped_;
      continue;
    }
    const std::size_t start = c->tx.size();
    const std::uint8_t head[4] = {0, 0, static_cast<std::uint8_t>(rtde::PackageType::kDataPackage), c->output_id};
    c->tx.insert(c->tx.end(), head, head + 4);
    for (const auto& f : c->outputs) appendValue(&c->tx, f);
    rtde::putU16(c->tx.data() + start, static_cast<std::uint16_t>(c->tx.size() - start));
    ++packages_sent_;
    if (c->tx.size() > kMaxQueuedBytes) {
      controller_.log("RTDE client " + std::to_string(c->id) + " does not read: closing");
      c->close = true;
    }
  }
  if (!tick.late) {
    for (auto& c : conns_) flush(c.get());
  }
}

// ---------------------------------------------------------------------------------- requests
void RtdeServer::reply(Connection* c, rtde::PackageType type, const std::vector<std::uint8_t>& payload) {
  const auto pkg = rtde::encodePackage(type, payload);
  c->tx.insert(c->tx.end(), pkg.begin(), pkg.end());
}

void RtdeServer::handlePackage(Connection* c, const rtde::PackageView& v) {
  const std::string text(reinterpret_cast<const char*>(v.payload), v.payload_size);
  switch (v.type) {
    case rtde::PackageType::kRequestProtocolVersion: {
      const bool ok = v.payload_size == 2 && (rtde::getU16(v.payload) == 1 || rtde::getU16(v.payload) == 2);
      if (ok) c->protocol = rtde::getU16(v.payload);
      reply(c, v.type, {static_cast<std::uint8_t>(ok ? 1 : 0)});
      return;
    }
    case rtde::PackageType::kGetUrcontrolVersion: {
      const rtde::ControllerVersion& version = controller_.version();
      std::vector<std::uint8_t> p(16);
      rtde::putU32(p.data(), version.major);
      rtde::putU32(p.data() + 4, version.minor);
      rtde::putU32(p.data() + 8, version.bugfix);
      rtde::putU32(p.data() + 12, version.build);
      reply(c, v.type, p);
      return;
    }
    case rtde::PackageType::kSetupOutputs: {
      const double f_max = 1.0 / controller_.period();
      double freq = f_max;
      std::string names_csv = text;
      if (c->protocol >= 2) {
        if (v.payload_size < 8) {
          c->close = true;
          return;
        }
        freq = rtde::getDouble(v.payload);
        names_csv = text.substr(8);
      }
      const auto names = rtde::splitNames(names_csv);
      std::vector<std::string> types;
      std::vector<OutField> fields;
      bool valid = !names.empty();
      for (const auto& n : names) {
        const rtde::DataType t = rtde::variableType(n, rtde::Direction::kOutput);
        types.push_back(rtde::dataTypeName(t));
        if (t == rtde::DataType::kNotFound) valid = false;
        fields.push_back(classifyOutput(n, t));
      }
      if (!(freq > 0)) freq = f_max;
      freq = std::min(freq, f_max);  // documented: out-of-range frequencies are clamped
      c->decimation = std::max(1, static_cast<int>(std::floor(f_max / freq + 1e-9)));
      c->decimation_counter = c->decimation - 1;  // first package on the next tick
      c->outputs = std::move(fields);
      c->outputs_valid = valid;
      std::vector<std::uint8_t> p;
      if (c->protocol >= 2) p.push_back(c->output_id);
      const std::string joined = rtde::joinNames(types);
      p.insert(p.end(), joined.begin(), joined.end());
      reply(c, v.type, p);
      return;
    }
    case rtde::PackageType::kSetupInputs: {
      const auto names = rtde::splitNames(text);
      std::vector<std::string> types;
      std::vector<InField> fields;
      bool ok = !names.empty();
      for (const auto& n : names) {
        const rtde::DataType t = rtde::variableType(n, rtde::Direction::kInput);
        const auto own = input_owner_.find(n);
        if (t == rtde::DataType::kNotFound) {
          types.push_back("NOT_FOUND");
          ok = false;
        } else if (own != input_owner_.end() && own->second != c->id) {
          types.push_back("IN_USE");
          ok = false;
        } else {
          types.push_back(rtde::dataTypeName(t));
        }
        fields.push_back({n, t});
      }
      std::uint8_t id = 0;
      if (ok) {
        id = c->next_input_id++;
        for (const auto& n : names) input_owner_[n] = c->id;
        c->inputs[id] = std::move(fields);
      }
      std::vector<std::uint8_t> p{id};
      const std::string joined = rtde::joinNames(types);
      p.insert(p.end(), joined.begin(), joined.end());
      reply(c, v.type, p);
      return;
    }
    case rtde::PackageType::kStart: {
      const bool ok = c->outputs_valid || !c->inputs.empty();
      if (ok) c->started = true;
      reply(c, v.type, {static_cast<std::uint8_t>(ok ? 1 : 0)});
      return;
    }
    case rtde::PackageType::kPause:
      c->started = false;
      reply(c, v.type, {1});
      return;
    case rtde::PackageType::kTextMessage:
      controller_.log("RTDE text from client " + std::to_string(c->id));
      return;
    case rtde::PackageType::kDataPackage: {
      if (v.payload_size < 1) return;
      const auto it = c->inputs.find(v.payload[0]);
      if (it == c->inputs.end()) return;
      std::size_t need = 1;
      for (const auto& f : it->second) need += rtde::dataTypeSize(f.type);
      if (need != v.payload_size) {
        controller_.log("RTDE client " + std::to_string(c->id) + ": data package of wrong size ignored");
        return;
      }
      const std::uint8_t* p = v.payload + 1;
      for (const auto& f : it->second) {
        applyInput(f, p);
        p += rtde::dataTypeSize(f.type);
      }
      return;
    }
  }
}

void RtdeServer::applyInput(const InField& f, const std::uint8_t* p) {
  auto idx = [&](const char* prefix) {
    return f.name.rfind(prefix, 0) == 0 ? std::atoi(f.name.c_str() + std::strlen(prefix)) : -1;
  };
  int i;
  if ((i = idx("input_int_register_")) >= 0) {
    controller_.writeInputInt(i, rtde::getI32(p));
  } else if ((i = idx("input_double_register_")) >= 0) {
    controller_.writeInputDouble(i, rtde::getDouble(p));
  } else if ((i = idx("input_bit_register_")) >= 0) {
    controller_.writeInputBit(i, p[0] != 0);
  }
}

}  // namespace ftid::simrobot
