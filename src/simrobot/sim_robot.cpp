#include "ftid/common/clock.hpp"
#include "ftid/simrobot/sim_robot.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>

#include "ftid/common/error.hpp"
#include "ftid/drivers/ur/rtde_protocol.hpp"

namespace ftid::simrobot {

namespace rtde = ftid::drivers::ur::rtde;

RobotModel parseRobotModel(const std::string& name) {
  std::string n;
  for (char c : name) n.push_back(static_cast<char>(std::tolower(static_cast<unsigned char>(c))));
  if (n == "ur10") return RobotModel::kUR10;
  if (n == "ur10e") return RobotModel::kUR10e;
  throw ConfigError("unknown robot model '" + name + "' (expected ur10 or ur10e)");
}

FaultKind parseFaultKind(const std::string& name) {
  static const std::map<std::string, FaultKind> m = {
      {"protective_stop", FaultKind::kProtectiveStop}, {"estop", FaultKind::kEmergencyStop},
      {"program_stop", FaultKind::kProgramStop},       {"drop", FaultKind::kDropPackets},
      {"late", FaultKind::kLatePackets},               {"disconnect", FaultKind::kDisconnect},
      {"stall", FaultKind::kStallTicks}};
  const auto it = m.find(name);
  if (it == m.end()) {
    throw ConfigError("unknown fault '" + name +
                      "' (expected protective_stop, estop, program_stop, drop, late, disconnect or stall)");
  }
  return it->second;
}

const char* faultKindName(FaultKind kind) noexcept {
  switch (kind) {
    case FaultKind::kProtectiveStop: return "protective_stop";
    case FaultKind::kEmergencyStop: return "estop";
    case FaultKind::kProgramStop: return "program_stop";
    case FaultKind::kDropPackets: return "drop";
    case FaultKind::kLatePackets: return "late";
    case FaultKind::kDisconnect: return "disconnect";
    case FaultKind::kStallTicks: return "stall";
  }
  return "unknown";
}

// ------------------------------------------------------------------------------------------------
Vec6 forwardKinematicsTcpPose(RobotModel model, const JointVector& q) {
  static constexpr double kHalfPi = 1.5707963267948966;
  const double alpha[6] = {kHalfPi, 0, 0, kHalfPi, -kHalfPi, 0};
  double d[6], a[6];
  if (model == RobotModel::kUR10) {
    const double dd[6] = {0.1273, 0, 0, 0.163941, 0.1157, 0.0922};
    const double aa[6] = {0, -0.612, -0.5723, 0, 0, 0};
    std::copy(dd, dd + 6, d);
    std::copy(aa, aa + 6, a);
  } else {
    const double dd[6] = {0.1807, 0, 0, 0.17415, 0.11985, 0.11655};
    const double aa[6] = {0, -0.6127, -0.57155, 0, 0, 0};
    std::copy(dd, dd + 6, d);
    std::copy(aa, aa + 6, a);
  }
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int i = 0; i < 6; ++i) {
    Eigen::Isometry3d Ti = Eigen::Isometry3d::Identity();
    Ti.rotate(Eigen::AngleAxisd(q[i], Vec3::UnitZ()));
    Ti.translate(Vec3(0, 0, d[i]));
    Ti.translate(Vec3(a[i], 0, 0));
    Ti.rotate(Eigen::AngleAxisd(alpha[i], Vec3::UnitX()));
    T = T * Ti;
  }
  const Eigen::AngleAxisd aa(T.rotation());
  Vec6 pose;
  pose.head<3>() = T.translation();
  pose.tail<3>() = aa.axis() * aa.angle();
  return pose;
}

// ------------------------------------------------------------------------------------------------
namespace {

enum class OutKind : std::uint8_t {
  kZero, kTimestamp, kTargetQ, kTargetQd, kTargetQdd, kActualQ, kActualQd, kTcpPose, kTargetTcpPose,
  kRobotMode, kSafetyMode, kSafetyStatus, kRuntimeState, kRobotStatusBits, kSafetyStatusBits, kSpeedScaling,
  kTargetSpeedFraction, kJointMode, kJointTemperatures, kMainVoltage, kRobotVoltage, kRobotCurrent,
  kJointVoltage, kOutInt, kOutDouble, kInInt, kInDouble, kInBit, kOutBit, kExecutionTime, kToolMode,
  kPayload,
};

struct OutField {
  OutKind kind = OutKind::kZero;
  rtde::DataType type = rtde::DataType::kDouble;
  int index = 0;
};

OutField classifyOutput(const std::string& name, rtde::DataType type) {
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
  OutField f;
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

struct InField {
  std::string name;
  rtde::DataType type;
};

struct RtdeConn {
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

struct LineConn {
  int fd = -1;
  std::string rx;
  std::string tx;
  bool close = false;
};

enum class ProgramKind : std::uint8_t { kNone, kFtid, kUrRtde, kOther };

int listenOn(const std::string& host, std::uint16_t port, std::uint16_t* actual, const char* what) {
  const int fd = socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) throw DriverError(std::string("sim-robot: socket(): ") + std::strerror(errno));
  int one = 1;
  setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port);
  if (inet_pton(AF_INET, host.c_str(), &addr.sin_addr) != 1) {
    ::close(fd);
    throw ConfigError("sim-robot: host must be an IPv4 address (got '" + host + "')");
  }
  if (bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    const int e = errno;
    ::close(fd);
    throw DriverError(std::string("sim-robot: cannot listen for ") + what + " on " + host + ":" +
                      std::to_string(port) + ": " + std::strerror(e));
  }
  listen(fd, 16);
  socklen_t len = sizeof addr;
  getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  *actual = ntohs(addr.sin_port);
  return fd;
}

}  // namespace

// ------------------------------------------------------------------------------------------------
struct SimRobot::Impl {
  SimRobotConfig cfg;
  double dt = 0.008;
  rtde::ControllerVersion version;
  std::uint16_t rtde_port = 0, dashboard_port = 0, script_port = 0;
  int rtde_listen = -1, dash_listen = -1, script_listen = -1;
  int wake_fd = -1;
  std::thread tick_thread, io_thread;
  std::atomic<bool> running{false};

  mutable std::mutex m;
  // --- robot model
  std::uint64_t ticks = 0;
  JointVector q, qd, qdd, actual_q, actual_qd;
  std::int32_t robot_mode = rtde::kRobotModeRunning;
  std::int32_t safety_mode = rtde::kSafetyModeNormal;
  std::uint32_t runtime_state = rtde::kRuntimeStopped;
  int stopping_ticks = 0;
  // --- program
  ProgramKind program = ProgramKind::kNone;
  std::string program_name;
  std::string program_text;
  int offset = 0;
  bool executing = false;
  bool servo_active = false;
  JointVector servo_target, servo_prev_target;
  std::uint64_t servo_change_tick = 0;  // tick at which servo_target last changed
  double servo_t = 0.008, servo_lookahead = 0.1, servo_gain = 300.0;
  bool stopping = false;
  double stop_decel = 10.0;
  bool movej_active = false;
  JointVector movej_start, movej_delta;
  double movej_distance = 0.0, movej_v = 1.05, movej_a = 1.4, movej_t = 0.0;
  std::uint64_t servo_commands = 0;
  // watchdog
  bool watchdog_armed = false, watchdog_fired = false;
  std::string watchdog_var;
  double watchdog_min_hz = 0.0;
  std::map<std::string, std::uint64_t> input_update_tick;
  // --- registers
  std::int32_t in_int[48] = {};
  double in_double[48] = {};
  bool in_bit[128] = {};
  std::int32_t out_int[48] = {};
  double out_double[48] = {};
  bool out_bit[128] = {};
  std::map<std::string, int> input_owner;  // variable -> connection id
  // --- connections
  std::vector<std::unique_ptr<RtdeConn>> rtde_conns;
  std::vector<std::unique_ptr<LineConn>> dash_conns;
  std::vector<std::unique_ptr<LineConn>> script_conns;
  int next_conn_id = 1;
  // --- faults
  int drop_remaining = 0, late_remaining = 0, stall_remaining = 0;
  bool disconnect_requested = false;
  std::vector<ScheduledFault> scheduled;
  double program_first_start = -1.0;
  std::uint64_t packages_sent = 0, packages_dropped = 0;
  std::string last_event;

  explicit Impl(SimRobotConfig c) : cfg(std::move(c)) {
    if (cfg.model == RobotModel::kUR10) {
      dt = 0.008;
      version = {3, 15, 8, 106339};
    } else {
      dt = 0.002;
      version = {5, 11, 1, 108318};
    }
    q = cfg.q0;
    qd.setZero();
    qdd.setZero();
    actual_q = q;
    actual_qd.setZero();
    servo_target = servo_prev_target = q;
    servo_t = dt;
    scheduled = cfg.scheduled_faults;
    stop_decel = cfg.stop_deceleration;
  }

  double timestamp() const { return cfg.t0 + static_cast<double>(ticks) * dt; }

  void log(const std::string& s) const {
    if (cfg.verbose) std::fprintf(stderr, "sim-robot [%.3f]: %s\n", timestamp(), s.c_str());
  }

  void event(const std::string& s) {
    last_event = s;
    log(s);
  }

  // ---------------------------------------------------------------- program control
  void startProgram(const std::string& text) {
    std::istringstream is(text);
    std::string line, name;
    while (std::getline(is, line)) {
      const auto p = line.find_first_not_of(" \t");
      if (p == std::string::npos) continue;
      if (line.compare(p, 4, "def ") == 0) {
        const auto open = line.find('(', p);
        name = line.substr(p + 4, open == std::string::npos ? std::string::npos : open - p - 4);
        break;
      }
    }
    if (name.empty()) {
      log("script port: text without a 'def name():' program ignored");
      return;
    }
    if (robot_mode != rtde::kRobotModeRunning || safety_mode != rtde::kSafetyModeNormal) {
      event("program '" + name + "' not started: robot_mode " + rtde::robotModeName(robot_mode) + ", safety_mode " +
            rtde::safetyModeName(safety_mode));
      return;
    }
    program_text = text;
    program_name = name;
    program = name == "ftid_servo" ? ProgramKind::kFtid : name == "rtde_control" ? ProgramKind::kUrRtde
                                                                                  : ProgramKind::kOther;
    offset = 0;
    if (program == ProgramKind::kUrRtde) {
      // ur_rtde substitutes "global reg_offset_int = # int register offset\n<0|24>".
      const auto k = text.find("reg_offset_int =");
      if (k != std::string::npos) {
        std::size_t p = k + std::strlen("reg_offset_int =");
        while (p < text.size() && text[p] == ' ') ++p;
        if (p < text.size() && text[p] == '#') p = text.find('\n', p) + 1;
        if (p > 0 && p < text.size()) offset = std::atoi(text.c_str() + p) == 24 ? 24 : 0;
      }
    } else if (text.find("read_input_integer_register(24)") != std::string::npos) {
      offset = 24;
    }
    runtime_state = rtde::kRuntimePlaying;
    executing = false;
    servo_active = false;
    movej_active = false;
    watchdog_armed = false;
    watchdog_fired = false;
    if (program != ProgramKind::kOther) out_int[offset] = 1;
    if (program_first_start < 0) program_first_start = timestamp();
    event("program '" + name + "' started (register offset " + std::to_string(offset) + ")");
  }

  void stopProgram(const std::string& why) {
    if (runtime_state == rtde::kRuntimePlaying || runtime_state == rtde::kRuntimePaused) {
      runtime_state = rtde::kRuntimeStopping;
      stopping_ticks = 1;
      event("program stopped: " + why);
    }
    servo_active = false;
    movej_active = false;
    watchdog_armed = false;
    beginStop(cfg.stop_deceleration);
  }

  void beginStop(double decel) {
    stopping = true;
    stop_decel = decel > 0 ? decel : cfg.stop_deceleration;
  }

  void protectiveStop(const std::string& why) {
    safety_mode = rtde::kSafetyModeProtectiveStop;
    stopProgram("protective stop");
    event("protective stop: " + why);
  }

  // ---------------------------------------------------------------- program step (docs/robot.md, simulator "Each tick")
  void programStep() {
    if (runtime_state != rtde::kRuntimePlaying || program == ProgramKind::kNone || program == ProgramKind::kOther) {
      return;
    }
    const int o = offset;
    const std::int32_t cmd = in_int[o];
    if (cmd == 0) {
      executing = false;
      out_int[o] = 1;
      return;
    }
    if (cmd == 11) {
      JointVector target;
      for (int i = 0; i < 6; ++i) target[i] = in_double[o + i];
      if (!target.allFinite()) {
        protectiveStop("non-finite servoj target");
        return;
      }
      for (int i = 0; i < 6; ++i) {
        if (target[i] < cfg.position_lower[i] || target[i] > cfg.position_upper[i]) {
          protectiveStop("servoj target outside joint limits (joint " + std::to_string(i + 1) + ")");
          return;
        }
      }
      if (!servo_active) {
        servo_prev_target = q;
        stopping = false;
        movej_active = false;
      } else {
        servo_prev_target = servo_target;
      }
      if (in_double[o + 8] > 0) servo_t = in_double[o + 8];
      if (in_double[o + 9] > 0) servo_lookahead = std::clamp(in_double[o + 9], 0.03, 0.2);
      if (in_double[o + 10] > 0) servo_gain = std::clamp(in_double[o + 10], 100.0, 2000.0);
      if (cfg.servo_step_protective_stop_factor > 0) {
        // A host that answers late (non-real-time scheduling) leaves the previous target in the
        // registers for a tick and then sends one covering two ticks: judge the step over the
        // time since the target last changed (at most 3 ticks, the runner's lost-package limit).
        const std::uint64_t held = servo_active ? std::min<std::uint64_t>(ticks - servo_change_tick, 3) : 1;
        const double t = std::max(servo_t, static_cast<double>(std::max<std::uint64_t>(held, 1)) * dt);
        for (int i = 0; i < 6; ++i) {
          if (std::abs(target[i] - servo_prev_target[i]) / t >
              cfg.velocity_limit[i] * cfg.servo_step_protective_stop_factor) {
            protectiveStop("servoj step on joint " + std::to_string(i + 1) + " needs " +
                           std::to_string(std::abs(target[i] - servo_prev_target[i]) / t) + " rad/s");
            return;
          }
        }
      }
      if (!servo_active || target != servo_target) servo_change_tick = ticks;
      servo_target = target;
      servo_active = true;
      ++servo_commands;
      out_int[o] = 1;
      if (program == ProgramKind::kFtid) out_int[o + 1] = static_cast<std::int32_t>(servo_commands % 2000000000);
      return;
    }
    static const std::set<std::int32_t> kRealtimeCommands = {6, 9, 10, 24, 25, 27, 38, 58, 66, 67, 68, 69, 70, 71};
    if (program == ProgramKind::kUrRtde && kRealtimeCommands.count(cmd)) {
      out_int[o] = 1;  // accepted, not modelled
      return;
    }
    if (executing) return;
    executing = true;
    switch (cmd) {
      case 1: {  // moveJ: q d0..5, v d6, a d7; "done" when the motion ends
        JointVector target;
        for (int i = 0; i < 6; ++i) target[i] = in_double[o + i];
        if (!target.allFinite()) {
          protectiveStop("non-finite movej target");
          return;
        }
        servo_active = false;
        stopping = false;
        movej_active = true;
        movej_start = q;
        movej_delta = target - q;
        movej_distance = movej_delta.cwiseAbs().maxCoeff();
        movej_v = in_double[o + 6] > 0 ? in_double[o + 6] : 1.05;
        movej_a = in_double[o + 7] > 0 ? in_double[o + 7] : 1.4;
        movej_t = 0.0;
        out_int[o] = 0;  // busy
        return;
      }
      case 16:
        servo_active = false;
        beginStop(in_double[o]);
        break;
      case 26:
        out_double[o] = dt;
        break;
      case 35:
        watchdog_armed = true;
        watchdog_fired = false;
        watchdog_var = "input_int_register_" + std::to_string(o);
        watchdog_min_hz = in_double[o];
        input_update_tick[watchdog_var] = ticks;
        event("watchdog armed on " + watchdog_var + " at " + std::to_string(watchdog_min_hz) + " Hz");
        break;
      case 255:
        out_int[o] = 2;
        stopProgram("stop command (255) from the client");
        return;
      default:
        break;
    }
    out_int[o] = 2;
  }

  // ---------------------------------------------------------------- motion model (documented)
  void motionStep() {
    JointVector acc = JointVector::Zero();
    if (movej_active) {
      // Trapezoidal profile of the largest joint displacement; all joints scaled to it.
      movej_t += dt;
      const double D = movej_distance, v = movej_v, a = movej_a;
      double s;
      const double t_acc = v / a;
      if (D <= 1e-12) {
        s = 1.0;
      } else if (D < v * t_acc) {  // triangular
        const double tp = std::sqrt(D / a);
        const double t = std::min(movej_t, 2 * tp);
        s = (t <= tp ? 0.5 * a * t * t : D - 0.5 * a * (2 * tp - t) * (2 * tp - t)) / D;
      } else {
        const double T = D / v + t_acc;
        const double t = std::min(movej_t, T);
        if (t < t_acc) {
          s = 0.5 * a * t * t;
        } else if (t < T - t_acc) {
          s = 0.5 * a * t_acc * t_acc + v * (t - t_acc);
        } else {
          s = D - 0.5 * a * (T - t) * (T - t);
        }
        s /= D;
      }
      const JointVector q_new = movej_start + movej_delta * s;
      const JointVector qd_new = (q_new - q) / dt;
      acc = (qd_new - qd) / dt;
      qdd = acc;
      qd = qd_new;
      q = q_new;
      if (s >= 1.0) {
        movej_active = false;
        qd.setZero();
        if (runtime_state == rtde::kRuntimePlaying) out_int[offset] = 2;
      }
      return;
    }
    if (servo_active) {
      const double omega = std::min(2.0 / servo_lookahead * std::sqrt(servo_gain / 300.0),
                                    cfg.omega_max_fraction / dt);
      const double t = std::max(servo_t, dt);
      const JointVector v_ff = (servo_target - servo_prev_target) / t;
      acc = omega * omega * (servo_target - q) + 2.0 * omega * (v_ff - qd);
      servo_prev_target = servo_target;  // a repeated target means "hold": v_ff = 0
    } else if (stopping) {
      for (int i = 0; i < 6; ++i) {
        const double need = -qd[i] / dt;
        acc[i] = std::clamp(need, -stop_decel, stop_decel);
      }
      if (qd.cwiseAbs().maxCoeff() < 1e-9) stopping = false;
    } else {
      acc = -qd / dt;  // idle: at rest
    }
    for (int i = 0; i < 6; ++i) acc[i] = std::clamp(acc[i], -cfg.acceleration_limit, cfg.acceleration_limit);
    JointVector qd_new = qd + acc * dt;
    for (int i = 0; i < 6; ++i) qd_new[i] = std::clamp(qd_new[i], -cfg.velocity_limit[i], cfg.velocity_limit[i]);
    qdd = (qd_new - qd) / dt;
    q += 0.5 * (qd + qd_new) * dt;
    qd = qd_new;
    for (int i = 0; i < 6; ++i) {
      if (q[i] < cfg.position_lower[i] || q[i] > cfg.position_upper[i]) {
        q[i] = std::clamp(q[i], cfg.position_lower[i], cfg.position_upper[i]);
        qd[i] = 0.0;
        if (safety_mode == rtde::kSafetyModeNormal) protectiveStop("joint " + std::to_string(i + 1) + " position limit");
      }
    }
  }

  void applyScheduledFaults() {
    if (program_first_start < 0) return;
    for (auto it = scheduled.begin(); it != scheduled.end();) {
      if (timestamp() - program_first_start >= it->after_s) {
        injectLocked(it->kind, it->count);
        it = scheduled.erase(it);
      } else {
        ++it;
      }
    }
  }

  void injectLocked(FaultKind kind, int count) {
    switch (kind) {
      case FaultKind::kProtectiveStop: protectiveStop("injected"); break;
      case FaultKind::kEmergencyStop:
        safety_mode = rtde::kSafetyModeRobotEmergencyStop;
        stopProgram("emergency stop");
        robot_mode = rtde::kRobotModePowerOff;
        event("emergency stop (injected)");
        break;
      case FaultKind::kProgramStop: stopProgram("injected program stop"); break;
      case FaultKind::kDropPackets: drop_remaining += std::max(count, 1); event("dropping packages (injected)"); break;
      case FaultKind::kLatePackets: late_remaining += std::max(count, 1); event("delaying packages (injected)"); break;
      case FaultKind::kDisconnect: disconnect_requested = true; event("disconnecting clients (injected)"); break;
      case FaultKind::kStallTicks: stall_remaining += std::max(count, 1); event("stalling the clock (injected)"); break;
    }
  }

  void tick() {
    if (stall_remaining > 0) {
      --stall_remaining;
      return;  // the controller clock does not advance: no packages
    }
    ++ticks;
    if (runtime_state == rtde::kRuntimeStopping && --stopping_ticks < 0) runtime_state = rtde::kRuntimeStopped;
    applyScheduledFaults();
    // Watchdog: the watched input must have been written at least min_hz times per second.
    if (watchdog_armed && runtime_state == rtde::kRuntimePlaying && watchdog_min_hz > 0) {
      const double since = static_cast<double>(ticks - input_update_tick[watchdog_var]) * dt;
      if (since > 1.0 / watchdog_min_hz) {
        watchdog_fired = true;
        stopProgram("RTDE watchdog: " + watchdog_var + " not updated for " + std::to_string(since) + " s");
      }
    }
    const JointVector prev_q = q, prev_qd = qd;
    programStep();
    motionStep();
    actual_q = prev_q;  // actual lags target by one tick
    actual_qd = prev_qd;
    buildOutputs();
  }

  // ---------------------------------------------------------------- RTDE output
  std::uint32_t robotStatusBits() const {
    std::uint32_t b = 0;
    if (robot_mode >= rtde::kRobotModePowerOn) b |= rtde::kRobotStatusPowerOn;
    if (runtime_state == rtde::kRuntimePlaying) b |= rtde::kRobotStatusProgramRunning;
    return b;
  }
  std::uint32_t safetyStatusBits() const {
    switch (safety_mode) {
      case rtde::kSafetyModeNormal: return rtde::kSafetyStatusNormal;
      case rtde::kSafetyModeProtectiveStop:
        return rtde::kSafetyStatusProtectiveStopped | rtde::kSafetyStatusStoppedDueToSafety;
      case rtde::kSafetyModeRobotEmergencyStop:
        return rtde::kSafetyStatusRobotEmergencyStopped | rtde::kSafetyStatusEmergencyStopped |
               rtde::kSafetyStatusStoppedDueToSafety;
      case rtde::kSafetyModeSystemEmergencyStop:
        return rtde::kSafetyStatusSystemEmergencyStopped | rtde::kSafetyStatusEmergencyStopped |
               rtde::kSafetyStatusStoppedDueToSafety;
      default: return 0;
    }
  }

  static void putVec(std::vector<std::uint8_t>* out, const JointVector& v) {
    for (int i = 0; i < 6; ++i) {
      std::uint8_t b[8];
      rtde::putDouble(b, v[i]);
      out->insert(out->end(), b, b + 8);
    }
  }

  void appendValue(std::vector<std::uint8_t>* out, const OutField& f) {
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
    switch (f.kind) {
      case OutKind::kTimestamp: dbl(timestamp()); return;
      case OutKind::kTargetQ: putVec(out, q); return;
      case OutKind::kTargetQd: putVec(out, qd); return;
      case OutKind::kTargetQdd: putVec(out, qdd); return;
      case OutKind::kActualQ: putVec(out, actual_q); return;
      case OutKind::kActualQd: putVec(out, actual_qd); return;
      case OutKind::kTcpPose: putVec(out, forwardKinematicsTcpPose(cfg.model, actual_q)); return;
      case OutKind::kTargetTcpPose: putVec(out, forwardKinematicsTcpPose(cfg.model, q)); return;
      case OutKind::kRobotMode: i32(robot_mode); return;
      case OutKind::kSafetyMode:
      case OutKind::kSafetyStatus: i32(safety_mode); return;
      case OutKind::kRuntimeState: u32(runtime_state); return;
      case OutKind::kRobotStatusBits: u32(robotStatusBits()); return;
      case OutKind::kSafetyStatusBits: u32(safetyStatusBits()); return;
      case OutKind::kSpeedScaling:
      case OutKind::kTargetSpeedFraction: dbl(1.0); return;
      case OutKind::kJointMode:
        for (int i = 0; i < 6; ++i) i32(robot_mode == rtde::kRobotModeRunning ? 253 : 239);
        return;
      case OutKind::kJointTemperatures: putVec(out, JointVector::Constant(35.0)); return;
      case OutKind::kMainVoltage:
      case OutKind::kRobotVoltage: dbl(48.0); return;
      case OutKind::kRobotCurrent: dbl(robot_mode == rtde::kRobotModeRunning ? 0.6 : 0.0); return;
      case OutKind::kJointVoltage: putVec(out, JointVector::Constant(48.0)); return;
      case OutKind::kExecutionTime: dbl(dt * 0.1); return;
      case OutKind::kOutInt: i32(f.index >= 0 && f.index < 48 ? out_int[f.index] : 0); return;
      case OutKind::kOutDouble: dbl(f.index >= 0 && f.index < 48 ? out_double[f.index] : 0.0); return;
      case OutKind::kInInt: i32(f.index >= 0 && f.index < 48 ? in_int[f.index] : 0); return;
      case OutKind::kInDouble: dbl(f.index >= 0 && f.index < 48 ? in_double[f.index] : 0.0); return;
      case OutKind::kInBit: out->push_back(f.index >= 0 && f.index < 128 && in_bit[f.index] ? 1 : 0); return;
      case OutKind::kOutBit: out->push_back(f.index >= 0 && f.index < 128 && out_bit[f.index] ? 1 : 0); return;
      case OutKind::kToolMode:
      case OutKind::kPayload:
      case OutKind::kZero: break;
    }
    out->insert(out->end(), rtde::dataTypeSize(f.type), 0);
  }

  void buildOutputs() {
    const bool drop = drop_remaining > 0;
    if (drop) --drop_remaining;
    const bool late = late_remaining > 0;
    if (late) --late_remaining;
    for (auto& c : rtde_conns) {
      if (!c->started || !c->outputs_valid || c->close) continue;
      if (++c->decimation_counter < c->decimation) continue;
      c->decimation_counter = 0;
      if (drop) {
        ++packages_dropped;
        continue;
      }
      const std::size_t start = c->tx.size();
      const std::uint8_t head[4] = {0, 0, static_cast<std::uint8_t>(rtde::PackageType::kDataPackage), c->output_id};
      c->tx.insert(c->tx.end(), head, head + 4);
      for (const auto& f : c->outputs) appendValue(&c->tx, f);
      rtde::putU16(c->tx.data() + start, static_cast<std::uint16_t>(c->tx.size() - start));
      ++packages_sent;
      if (c->tx.size() > 4 * 1024 * 1024) {
        log("RTDE client " + std::to_string(c->id) + " does not read: closing");
        c->close = true;
      }
    }
    if (!late) {
      for (auto& c : rtde_conns) flushRtde(c.get());
    }
  }

  static void flushBytes(int fd, std::vector<std::uint8_t>* tx, bool* close) {
    while (!tx->empty()) {
      const ssize_t n = ::send(fd, tx->data(), tx->size(), MSG_NOSIGNAL | MSG_DONTWAIT);
      if (n > 0) {
        tx->erase(tx->begin(), tx->begin() + n);
        continue;
      }
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)) return;
      *close = true;
      return;
    }
  }
  void flushRtde(RtdeConn* c) {
    if (!c->close) flushBytes(c->fd, &c->tx, &c->close);
  }
  static void flushLine(LineConn* c) {
    while (!c->tx.empty() && !c->close) {
      const ssize_t n = ::send(c->fd, c->tx.data(), c->tx.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
      if (n > 0) {
        c->tx.erase(0, static_cast<std::size_t>(n));
        continue;
      }
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)) return;
      c->close = true;
    }
  }

  // ---------------------------------------------------------------- RTDE requests
  void reply(RtdeConn* c, rtde::PackageType type, const std::vector<std::uint8_t>& payload) {
    const auto pkg = rtde::encodePackage(type, payload);
    c->tx.insert(c->tx.end(), pkg.begin(), pkg.end());
  }

  void handleRtdePackage(RtdeConn* c, const rtde::PackageView& v) {
    const std::string text(reinterpret_cast<const char*>(v.payload), v.payload_size);
    switch (v.type) {
      case rtde::PackageType::kRequestProtocolVersion: {
        const bool ok = v.payload_size == 2 && (rtde::getU16(v.payload) == 1 || rtde::getU16(v.payload) == 2);
        if (ok) c->protocol = rtde::getU16(v.payload);
        reply(c, v.type, {static_cast<std::uint8_t>(ok ? 1 : 0)});
        return;
      }
      case rtde::PackageType::kGetUrcontrolVersion: {
        std::vector<std::uint8_t> p(16);
        rtde::putU32(p.data(), version.major);
        rtde::putU32(p.data() + 4, version.minor);
        rtde::putU32(p.data() + 8, version.bugfix);
        rtde::putU32(p.data() + 12, version.build);
        reply(c, v.type, p);
        return;
      }
      case rtde::PackageType::kSetupOutputs: {
        double freq = 1.0 / dt;
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
        const double f_max = 1.0 / dt;
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
          const auto own = input_owner.find(n);
          if (t == rtde::DataType::kNotFound) {
            types.push_back("NOT_FOUND");
            ok = false;
          } else if (own != input_owner.end() && own->second != c->id) {
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
          for (const auto& n : names) input_owner[n] = c->id;
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
        log("RTDE text from client " + std::to_string(c->id));
        return;
      case rtde::PackageType::kDataPackage: {
        if (v.payload_size < 1) return;
        const auto it = c->inputs.find(v.payload[0]);
        if (it == c->inputs.end()) return;
        std::size_t need = 1;
        for (const auto& f : it->second) need += rtde::dataTypeSize(f.type);
        if (need != v.payload_size) {
          log("RTDE client " + std::to_string(c->id) + ": data package of wrong size ignored");
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

  void applyInput(const InField& f, const std::uint8_t* p) {
    input_update_tick[f.name] = ticks;
    auto idx = [&](const char* prefix) {
      return f.name.rfind(prefix, 0) == 0 ? std::atoi(f.name.c_str() + std::strlen(prefix)) : -1;
    };
    int i;
    if ((i = idx("input_int_register_")) >= 0 && i < 48) {
      in_int[i] = rtde::getI32(p);
    } else if ((i = idx("input_double_register_")) >= 0 && i < 48) {
      in_double[i] = rtde::getDouble(p);
    } else if ((i = idx("input_bit_register_")) >= 0 && i < 128) {
      in_bit[i] = p[0] != 0;
    }
  }

  void readRtde(RtdeConn* c) {
    std::uint8_t buf[65536];
    for (;;) {
      const ssize_t n = ::recv(c->fd, buf, sizeof buf, MSG_DONTWAIT);
      if (n > 0) {
        c->rx.insert(c->rx.end(), buf, buf + n);
        continue;
      }
      if (n == 0 || (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) c->close = true;
      break;
    }
    std::size_t pos = 0;
    for (;;) {
      rtde::PackageView v;
      const long n = rtde::findPackage(c->rx.data() + pos, c->rx.size() - pos, &v);
      if (n < 0) {
        c->close = true;
        break;
      }
      if (n == 0) break;
      handleRtdePackage(c, v);
      pos += static_cast<std::size_t>(n);
    }
    c->rx.erase(c->rx.begin(), c->rx.begin() + static_cast<long>(pos));
    flushRtde(c);
  }

  void closeRtde(RtdeConn* c) {
    for (auto it = input_owner.begin(); it != input_owner.end();) {
      it = it->second == c->id ? input_owner.erase(it) : std::next(it);
    }
    ::close(c->fd);
    log("RTDE client " + std::to_string(c->id) + " disconnected");
  }

  // ---------------------------------------------------------------- dashboard
  std::string programStateText() const {
    const std::string name = program_name.empty() ? "<unnamed>" : program_name + ".urp";
    switch (runtime_state) {
      case rtde::kRuntimePlaying: return "PLAYING " + name;
      case rtde::kRuntimePaused: return "PAUSED " + name;
      default: return "STOPPED " + name;
    }
  }

  std::string dashboard(const std::string& raw, bool* close) {
    std::string cmd = raw;
    while (!cmd.empty() && (cmd.back() == '\r' || cmd.back() == ' ')) cmd.pop_back();
    while (!cmd.empty() && cmd.front() == ' ') cmd.erase(0, 1);
    if (cmd == "stop") {
      stopProgram("dashboard stop");
      return "Stopped";
    }
    if (cmd == "play") {
      if (program_text.empty()) return "Failed to execute: play";
      if (robot_mode != rtde::kRobotModeRunning || safety_mode != rtde::kSafetyModeNormal) {
        return "Failed to execute: play";
      }
      startProgram(program_text);
      return "Starting program";
    }
    if (cmd == "pause") {
      if (runtime_state == rtde::kRuntimePlaying) {
        runtime_state = rtde::kRuntimePaused;
        servo_active = false;
        beginStop(cfg.stop_deceleration);
      }
      return "Pausing program";
    }
    if (cmd == "PolyscopeVersion") {
      return std::string("URSoftware ") + version.toString() +
             (version.major >= 5 ? " (Mar 22 2021)" : " (Nov 29 2021)");
    }
    if (cmd == "get serial number") return cfg.serial_number;
    if (cmd == "is in remote control") return "true";
    if (cmd == "robotmode") return std::string("Robotmode: ") + rtde::robotModeName(robot_mode);
    if (cmd == "safetymode") return std::string("Safetymode: ") + rtde::safetyModeName(safety_mode);
    if (cmd == "safetystatus") return std::string("Safetystatus: ") + rtde::safetyModeName(safety_mode);
    if (cmd == "programState") return programStateText();
    if (cmd == "running") {
      return std::string("Program running: ") + (runtime_state == rtde::kRuntimePlaying ? "true" : "false");
    }
    if (cmd == "get loaded program") {
      return program_name.empty() ? "No program loaded" : "Loaded program: " + program_name + ".urp";
    }
    if (cmd == "power on") {
      if (robot_mode == rtde::kRobotModePowerOff) robot_mode = rtde::kRobotModeIdle;
      return "Powering on";
    }
    if (cmd == "power off") {
      stopProgram("power off");
      robot_mode = rtde::kRobotModePowerOff;
      return "Powering off";
    }
    if (cmd == "brake release") {
      if (robot_mode == rtde::kRobotModeIdle || robot_mode == rtde::kRobotModePowerOn) {
        robot_mode = rtde::kRobotModeRunning;
      }
      return "Brake releasing";
    }
    if (cmd == "unlock protective stop") {
      if (safety_mode == rtde::kSafetyModeProtectiveStop) safety_mode = rtde::kSafetyModeNormal;
      return "Protective stop releasing";
    }
    if (cmd == "close safety popup") return "closing safety popup";
    if (cmd == "close popup") return "closing popup";
    if (cmd.rfind("load ", 0) == 0) {
      const std::string f = cmd.substr(5);
      return "Loading program: " + f;
    }
    if (cmd == "quit") {
      *close = true;
      return "Disconnected";
    }
    if (cmd.rfind("sim ", 0) == 0) {  // simulator extension: fault injection
      std::istringstream is(cmd.substr(4));
      std::string kind;
      int count = 10;
      is >> kind >> count;
      try {
        injectLocked(parseFaultKind(kind), count);
        if (kind == "estop") return "Sim: injected estop";
        return "Sim: injected " + kind;
      } catch (const std::exception& e) {
        return std::string("Sim: ") + e.what();
      }
    }
    return "could not understand: '" + cmd + "'";
  }

  void readDashboard(LineConn* c) {
    char buf[4096];
    for (;;) {
      const ssize_t n = ::recv(c->fd, buf, sizeof buf, MSG_DONTWAIT);
      if (n > 0) {
        c->rx.append(buf, static_cast<std::size_t>(n));
        continue;
      }
      if (n == 0 || (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) c->close = true;
      break;
    }
    std::size_t nl;
    while ((nl = c->rx.find('\n')) != std::string::npos) {
      const std::string line = c->rx.substr(0, nl);
      c->rx.erase(0, nl + 1);
      bool close = false;
      c->tx += dashboard(line, &close) + "\n";
      flushLine(c);
      if (close) {
        c->close = true;
        break;
      }
    }
    flushLine(c);
  }

  // ---------------------------------------------------------------- script port
  void readScript(LineConn* c) {
    char buf[65536];
    bool eof = false;
    for (;;) {
      const ssize_t n = ::recv(c->fd, buf, sizeof buf, MSG_DONTWAIT);
      if (n > 0) {
        c->rx.append(buf, static_cast<std::size_t>(n));
        continue;
      }
      if (n == 0 || (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) eof = true;
      break;
    }
    if (cfg.verbose && !c->rx.empty()) log("script port: " + std::to_string(c->rx.size()) + " bytes buffered");
    // A program is complete when, after a "def name():" line, a line "end" at column 0 follows.
    for (;;) {
      const auto def = c->rx.find("def ");
      if (def == std::string::npos) break;
      std::size_t pos = def, end_at = std::string::npos;
      while ((pos = c->rx.find('\n', pos)) != std::string::npos) {
        ++pos;
        if (c->rx.compare(pos, 3, "end") == 0 &&
            (pos + 3 == c->rx.size() || c->rx[pos + 3] == '\n' || c->rx[pos + 3] == '\r')) {
          end_at = pos + 3;
          break;
        }
      }
      if (end_at == std::string::npos) break;
      const std::string prog = c->rx.substr(0, end_at);
      c->rx.erase(0, std::min(c->rx.size(), end_at + 1));
      startProgram(prog);
    }
    if (eof) {
      if (c->rx.find("def ") != std::string::npos) startProgram(c->rx);
      c->close = true;
    }
  }

  // ---------------------------------------------------------------- threads
  void raisePriority(int prio) const {
    if (prio <= 0) return;
    sched_param sp{};
    sp.sched_priority = prio;
    const int rc = pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp);
    if (rc != 0) log(std::string("SCHED_FIFO for the simulator refused: ") + std::strerror(rc));
  }

  void tickLoop() {
    raisePriority(cfg.thread_priority);
    const std::int64_t period_ns = static_cast<std::int64_t>(std::llround(dt * 1e9));
    std::int64_t next = monotonicNs() + period_ns;
    while (running.load()) {
      if (cfg.realtime) {
        timespec ts{static_cast<time_t>(next / 1'000'000'000), static_cast<long>(next % 1'000'000'000)};
        while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
        }
      }
      {
        std::lock_guard<std::mutex> lock(m);
        tick();
      }
      next += period_ns;
      const std::int64_t now = monotonicNs();
      if (now - next > 5 * period_ns) next = now;  // re-anchor after a long stall of the host
    }
  }

  void ioLoop() {
    raisePriority(cfg.thread_priority > 1 ? cfg.thread_priority - 1 : 0);
    while (running.load()) {
      std::vector<pollfd> fds;
      {
        std::lock_guard<std::mutex> lock(m);
        if (disconnect_requested) {
          disconnect_requested = false;
          for (auto& c : rtde_conns) c->close = true;
          for (auto& c : dash_conns) c->close = true;
        }
        cleanup();
        fds.push_back({wake_fd, POLLIN, 0});
        fds.push_back({rtde_listen, POLLIN, 0});
        fds.push_back({dash_listen, POLLIN, 0});
        fds.push_back({script_listen, POLLIN, 0});
        for (auto& c : rtde_conns) fds.push_back({c->fd, static_cast<short>(POLLIN | (c->tx.empty() ? 0 : POLLOUT)), 0});
        for (auto& c : dash_conns) fds.push_back({c->fd, static_cast<short>(POLLIN | (c->tx.empty() ? 0 : POLLOUT)), 0});
        for (auto& c : script_conns) fds.push_back({c->fd, POLLIN, 0});
      }
      const int rc = ::poll(fds.data(), fds.size(), 5);
      if (rc < 0 && errno != EINTR) break;
      if (rc <= 0) continue;
      std::lock_guard<std::mutex> lock(m);
      if (fds[0].revents) {
        std::uint64_t v;
        [[maybe_unused]] const ssize_t r = ::read(wake_fd, &v, sizeof v);
      }
      if (fds[1].revents & POLLIN) acceptRtde();
      if (fds[2].revents & POLLIN) acceptLine(dash_listen, &dash_conns, true);
      if (fds[3].revents & POLLIN) acceptLine(script_listen, &script_conns, false);
      std::size_t k = 4;
      const std::size_t nr = rtde_conns.size(), nd = dash_conns.size(), ns = script_conns.size();
      for (std::size_t i = 0; i < nr && k < fds.size(); ++i, ++k) {
        if (fds[k].fd != rtde_conns[i]->fd) continue;
        if (fds[k].revents & (POLLIN | POLLHUP | POLLERR)) readRtde(rtde_conns[i].get());
        if (fds[k].revents & POLLOUT) flushRtde(rtde_conns[i].get());
      }
      for (std::size_t i = 0; i < nd && k < fds.size(); ++i, ++k) {
        if (fds[k].fd != dash_conns[i]->fd) continue;
        if (fds[k].revents & (POLLIN | POLLHUP | POLLERR)) readDashboard(dash_conns[i].get());
        if (fds[k].revents & POLLOUT) flushLine(dash_conns[i].get());
      }
      for (std::size_t i = 0; i < ns && k < fds.size(); ++i, ++k) {
        if (fds[k].fd != script_conns[i]->fd) continue;
        if (fds[k].revents & (POLLIN | POLLHUP | POLLERR)) readScript(script_conns[i].get());
      }
    }
  }

  void cleanup() {
    for (auto it = rtde_conns.begin(); it != rtde_conns.end();) {
      if ((*it)->close) {
        closeRtde(it->get());
        it = rtde_conns.erase(it);
      } else {
        ++it;
      }
    }
    for (auto* list : {&dash_conns, &script_conns}) {
      for (auto it = list->begin(); it != list->end();) {
        if ((*it)->close) {
          ::close((*it)->fd);
          it = list->erase(it);
        } else {
          ++it;
        }
      }
    }
  }

  static int acceptFd(int listen_fd) {
    const int fd = ::accept4(listen_fd, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd >= 0) {
      int one = 1;
      setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    }
    return fd;
  }

  void acceptRtde() {
    const int fd = acceptFd(rtde_listen);
    if (fd < 0) return;
    auto c = std::make_unique<RtdeConn>();
    c->fd = fd;
    c->id = next_conn_id++;
    log("RTDE client " + std::to_string(c->id) + " connected");
    rtde_conns.push_back(std::move(c));
  }

  void acceptLine(int listen_fd, std::vector<std::unique_ptr<LineConn>>* list, bool greet) {
    const int fd = acceptFd(listen_fd);
    if (fd < 0) return;
    auto c = std::make_unique<LineConn>();
    c->fd = fd;
    if (greet) {
      c->tx = "Connected: Universal Robots Dashboard Server\n";
      flushLine(c.get());
    }
    list->push_back(std::move(c));
  }
};

// ------------------------------------------------------------------------------------------------
SimRobot::SimRobot(SimRobotConfig config) : impl_(std::make_unique<Impl>(std::move(config))) {}

SimRobot::~SimRobot() { stop(); }

void SimRobot::start() {
  Impl& im = *impl_;
  if (im.running.load()) return;
  im.rtde_listen = listenOn(im.cfg.host, im.cfg.rtde_port, &im.rtde_port, "RTDE");
  try {
    im.dash_listen = listenOn(im.cfg.host, im.cfg.dashboard_port, &im.dashboard_port, "dashboard");
    im.script_listen = listenOn(im.cfg.host, im.cfg.script_port, &im.script_port, "scripts");
  } catch (...) {
    if (im.rtde_listen >= 0) ::close(im.rtde_listen);
    if (im.dash_listen >= 0) ::close(im.dash_listen);
    im.rtde_listen = im.dash_listen = -1;
    throw;
  }
  im.wake_fd = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  im.running = true;
  im.tick_thread = std::thread([&im] { im.tickLoop(); });
  im.io_thread = std::thread([&im] { im.ioLoop(); });
}

void SimRobot::stop() {
  Impl& im = *impl_;
  if (!im.running.exchange(false)) return;
  if (im.wake_fd >= 0) {
    const std::uint64_t one = 1;
    [[maybe_unused]] const ssize_t r = ::write(im.wake_fd, &one, sizeof one);
  }
  if (im.tick_thread.joinable()) im.tick_thread.join();
  if (im.io_thread.joinable()) im.io_thread.join();
  std::lock_guard<std::mutex> lock(im.m);
  for (auto& c : im.rtde_conns) ::close(c->fd);
  for (auto& c : im.dash_conns) ::close(c->fd);
  for (auto& c : im.script_conns) ::close(c->fd);
  im.rtde_conns.clear();
  im.dash_conns.clear();
  im.script_conns.clear();
  im.input_owner.clear();
  for (int* fd : {&im.rtde_listen, &im.dash_listen, &im.script_listen, &im.wake_fd}) {
    if (*fd >= 0) ::close(*fd);
    *fd = -1;
  }
}

std::uint16_t SimRobot::rtdePort() const noexcept { return impl_->rtde_port; }
std::uint16_t SimRobot::dashboardPort() const noexcept { return impl_->dashboard_port; }
std::uint16_t SimRobot::scriptPort() const noexcept { return impl_->script_port; }
double SimRobot::period() const noexcept { return impl_->dt; }
std::string SimRobot::versionString() const { return impl_->version.toString(); }

void SimRobot::inject(FaultKind kind, int count) {
  std::lock_guard<std::mutex> lock(impl_->m);
  impl_->injectLocked(kind, count);
}

void SimRobot::runProgramText(const std::string& text) {
  std::lock_guard<std::mutex> lock(impl_->m);
  impl_->startProgram(text);
}

SimSnapshot SimRobot::snapshot() const {
  const Impl& im = *impl_;
  std::lock_guard<std::mutex> lock(im.m);
  SimSnapshot s;
  s.timestamp = im.timestamp();
  s.ticks = im.ticks;
  s.q = im.q;
  s.qd = im.qd;
  s.actual_q = im.actual_q;
  s.robot_mode = im.robot_mode;
  s.safety_mode = im.safety_mode;
  s.runtime_state = im.runtime_state;
  s.program_name = im.program_name;
  s.servo_active = im.servo_active;
  s.moving = im.qd.cwiseAbs().maxCoeff() > 1e-6;
  s.rtde_connections = static_cast<int>(im.rtde_conns.size());
  s.servo_commands = im.servo_commands;
  s.packages_sent = im.packages_sent;
  s.packages_dropped = im.packages_dropped;
  s.watchdog_armed = im.watchdog_armed;
  s.watchdog_fired = im.watchdog_fired;
  s.last_event = im.last_event;
  return s;
}

}  // namespace ftid::simrobot
