// ftidd configuration validation: every key's range, the cross-field rules and the files a
// config names, checked section by section in the order of DaemonConfig's sections; and the LCM
// URL check (ftid/config/daemon_config.hpp).
#include "daemon_config_validate.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <climits>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <utility>

#include "ftid/common/error.hpp"

namespace ftid::config {
namespace {

/// A readable regular file (never opened here: a FIFO would block).
bool fileReadable(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode) && ::access(path.c_str(), R_OK) == 0;
}

bool parseUint(const std::string& s, unsigned long max, unsigned long& out) {
  if (s.empty() || s.size() > 10) return false;
  unsigned long v = 0;
  for (char ch : s) {
    if (ch < '0' || ch > '9') return false;
    v = v * 10 + static_cast<unsigned long>(ch - '0');
  }
  if (v > max) return false;
  out = v;
  return true;
}

bool isDirectory(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

// The monitor section: every number finite and positive (onset_margin >= 0), bounded.
template <class Fail>
void validateMonitor(const MonitorConfig& m, const Fail& fail) {
  const std::pair<const char*, double> positive[] = {
      {"monitor.publish_hz", m.publish_hz},
      {"monitor.onset_threshold", m.onset_threshold},
      {"monitor.decision_threshold", m.decision_threshold},
      {"monitor.contact_force_std_N", m.contact_force_std_N},
      {"monitor.contact_torque_std_Nm", m.contact_torque_std_Nm},
      {"monitor.contact_force_rate_N_s", m.contact_force_rate_N_s},
      {"monitor.contact_torque_rate_Nm_s", m.contact_torque_rate_Nm_s},
      {"monitor.prior_mass_std_kg", m.prior_mass_std_kg},
      {"monitor.prior_mass_com_std_kg_m", m.prior_mass_com_std_kg_m},
      {"monitor.prior_inertia_std_kg_m2", m.prior_inertia_std_kg_m2},
      {"monitor.free_motion_turn_rad_s", m.free_motion_turn_rad_s},
      {"monitor.free_motion_acc_m_s2", m.free_motion_acc_m_s2},
      {"monitor.max_gap_s", m.max_gap_s},
      {"monitor.restart_s", m.restart_s},
  };
  for (const auto& [key, value] : positive) {
    if (!(std::isfinite(value) && value > 0.0 && value <= 1e6)) fail(key, "must be a number in (0, 1e6]");
  }
  if (!(m.noise_std.allFinite() && m.noise_std.minCoeff() > 0.0 && m.noise_std.maxCoeff() <= 1e3)) {
    fail("monitor.noise_std", "must be 6 numbers in (0, 1000] (fx fy fz [N] tx ty tz [Nm])");
  }
  if (!(std::isfinite(m.onset_margin) && m.onset_margin >= 0.0 && m.onset_margin <= 1e6)) {
    fail("monitor.onset_margin", "must be a number in [0, 1e6]");
  }
  if (!(m.publish_hz >= 2.0 && m.publish_hz <= 100.0)) fail("monitor.publish_hz", "must be in 2..100 Hz");
  if (!(std::isfinite(m.min_change_s) && m.min_change_s >= 0.0 && m.min_change_s < m.restart_s)) {
    fail("monitor.min_change_s", "must be >= 0 s and below monitor.restart_s");
  }
  if (!(m.reidentify_window_s >= 0.5 && m.reidentify_window_s <= 30.0)) {
    fail("monitor.reidentify_window_s", "must be in 0.5..30 s");
  }
  if (m.channel.empty() || m.channel.size() > 63 ||
      m.channel.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_-/.") !=
          std::string::npos) {
    fail("monitor.channel", "channel names use letters, digits and _ - / . only (at most 63), got '" +
                                m.channel + "'");
  }
}

// An IPv4 or IPv6 address, or a host name by RFC 1123 (labels of 1..63 letters, digits and '-',
// not starting or ending with '-', at most 253 characters). All-numeric dotted names must be IPv4
// addresses (999.1.1.1 is neither an address nor a name).
std::string hostProblem(const std::string& host) {
  in_addr a4{};
  in6_addr a6{};
  if (::inet_pton(AF_INET, host.c_str(), &a4) == 1 || ::inet_pton(AF_INET6, host.c_str(), &a6) == 1) return {};
  if (host.size() > 253) return "is longer than 253 characters";
  bool numeric = true;
  std::size_t start = 0;
  while (start <= host.size()) {
    std::size_t dot = host.find('.', start);
    if (dot == std::string::npos) dot = host.size();
    const std::string label = host.substr(start, dot - start);
    if (label.empty() || label.size() > 63) return "is not an IPv4/IPv6 address or a valid host name (empty or over-long label)";
    if (label.front() == '-' || label.back() == '-') return "is not a valid host name (a label starts or ends with '-')";
    for (const char ch : label) {
      if (std::isalnum(static_cast<unsigned char>(ch)) == 0 && ch != '-') {
        return std::string("is not a valid host name (character '") + ch + "')";
      }
      if (std::isdigit(static_cast<unsigned char>(ch)) == 0) numeric = false;
    }
    start = dot + 1;
  }
  if (numeric) return "is not a valid IPv4 address (each of the four numbers 0..255)";
  return {};
}

// A path ftidd may create and append to: in an existing directory, not under the kernel's pseudo
// file systems, and, if it exists, a regular file (never a device, FIFO or link). Whether the
// directory is writable depends on who runs: ftidd checks it itself at start
// (recordDirWritableProblem), never whoever else loads ftidd.yaml (ftid tare, export, compensate).
std::string recordPathProblem(const std::string& path) {
  const std::string dir = internal::dirOf(path);
  char resolved[PATH_MAX];
  if (::realpath(dir.c_str(), resolved) == nullptr || !isDirectory(resolved)) {
    return "directory '" + dir + "' does not exist";
  }
  const std::string real_dir = resolved;
  for (const char* pseudo : {"/proc", "/sys", "/dev"}) {
    const std::string p = pseudo;
    if (real_dir == p || real_dir.compare(0, p.size() + 1, p + "/") == 0) {
      return "directory '" + dir + "' is under " + p + " (recordings go to a regular file system)";
    }
  }
  struct stat st {};
  if (::lstat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
    return "'" + path + "' exists and is not a regular file";
  }
  return {};
}


// The rate grid of RTDE: the controller sends on its control ticks only (500 Hz e-Series, 125 Hz
// CB3), every floor(f_loop / f)-th, so the cycle rate is 500 / n (CB3: 125 / n = 500 / 4n); another
// value is not the rate ftidd would get (docs/robot.md). "" if rtde_frequency_hz is such a rate
// (within 1e-3 Hz), else the message naming the nearest ones.
std::string rtdeRateProblem(double rtde_frequency_hz) {
  const double n = std::round(500.0 / rtde_frequency_hz);
  if (std::abs(500.0 / n - rtde_frequency_hz) > 1e-3) {
    const double lo = 500.0 / (n + 1.0);
    const double hi = 500.0 / std::max(1.0, n - 1.0);
    std::ostringstream os;
    os << "must be a rate the controller sends at, 500 / n Hz (e-Series; CB3 125 / n), e.g. " << 500.0 / n
       << " (nearby: " << lo << ", " << hi << ")";
    return os.str();
  }
  return {};
}

// The robot section's link: the controller's address and ports, and a rate it can send at.
template <class Fail>
void validateRobotLink(const RobotConfig& r, const Fail& fail) {
  if (r.host.empty()) fail("robot.host", "must not be empty");
  if (const std::string p = hostProblem(r.host); !p.empty()) fail("robot.host", "'" + r.host + "' " + p);
  if (r.rtde_port < 1 || r.rtde_port > 65535) fail("robot.rtde_port", "must be 1..65535");
  if (r.dashboard_port < 1 || r.dashboard_port > 65535) {
    fail("robot.dashboard_port", "must be 1..65535");
  }
  if (!(r.rtde_frequency_hz >= 1.0 && r.rtde_frequency_hz <= 500.0)) {
    fail("robot.rtde_frequency_hz", "must be in 1..500 Hz");
  }
  if (const std::string p = rtdeRateProblem(r.rtde_frequency_hz); !p.empty()) {
    fail("robot.rtde_frequency_hz", p);
  }
}

// The robot section's limits and timing: rated payload, receive and silence timeouts, watchdog,
// reconnect and its backoff (each against the RTDE period where it must be).
template <class Fail>
void validateRobotTiming(const RobotConfig& r, const Fail& fail) {
  if (!(r.rated_payload_kg > 0.0 && r.rated_payload_kg <= 1000.0)) {
    fail("robot.rated_payload_kg", "must be in (0, 1000] kg (the robot's rated payload: UR10 10, UR10e 12.5)");
  }
  if (!(r.receive_timeout_ms >= 0.0 && r.receive_timeout_ms <= 1000.0)) {
    fail("robot.receive_timeout_ms", "must be in 0..1000 ms (0 = 1.5 periods)");
  }
  if (!(r.silent_publish_after_ms >= 10.0 && r.silent_publish_after_ms <= 10000.0)) {
    fail("robot.silent_publish_after_ms", "must be in 10..10000 ms");
  }
  if (r.silent_publish_after_ms < 1500.0 / r.rtde_frequency_hz) {
    fail("robot.silent_publish_after_ms", "must be at least 1.5 robot periods (" +
                                              std::to_string(1500.0 / r.rtde_frequency_hz) +
                                              " ms at robot.rtde_frequency_hz): a shorter silence is every "
                                              "period (default: max(50, 3 periods))");
  }
  if (!(r.watchdog_silence_s == 0.0 || (r.watchdog_silence_s >= 0.1 && r.watchdog_silence_s <= 3600.0))) {
    fail("robot.watchdog_silence_s", "must be 0 (never) or in 0.1..3600 s");
  }
  if (!(r.reconnect_after_silence_s == 0.0 ||
        (r.reconnect_after_silence_s >= 0.1 && r.reconnect_after_silence_s <= 3600.0))) {
    fail("robot.reconnect_after_silence_s", "must be 0 (only on a TCP failure) or in 0.1..3600 s");
  }
  if (!(r.reconnect_backoff_min_s >= 0.01 && r.reconnect_backoff_min_s <= 60.0)) {
    fail("robot.reconnect_backoff_min_s", "must be in 0.01..60 s");
  }
  if (!(r.reconnect_backoff_max_s >= r.reconnect_backoff_min_s && r.reconnect_backoff_max_s <= 300.0)) {
    fail("robot.reconnect_backoff_max_s", "must be in robot.reconnect_backoff_min_s..300 s");
  }
}

// The robot model: a readable URDF and the two link names.
template <class Fail>
void validateRobotModel(const RobotConfig& r, const Fail& fail) {
  if (!fileReadable(r.urdf_path)) {
    fail("robot.urdf_path", "cannot read '" + r.urdf_path + "'");
  }
  if (r.base_link.empty()) fail("robot.base_link", "must not be empty");
  if (r.tip_link.empty()) fail("robot.tip_link", "must not be empty");
}

// The sensor section: transport and its endpoint, motion source, DBC file, staleness and mount.
template <class Fail>
void validateSensor(const SensorConfig& s, const Fail& fail) {
  if (s.transport != "seqpacket" && s.transport != "socketcan") {
    fail("sensor.transport", "must be 'seqpacket' or 'socketcan', got '" + s.transport + "'");
  }
  if (s.transport == "seqpacket") {
    if (s.socket_path.empty() || s.socket_path.size() > 107) {
      fail("sensor.socket_path", "must be 1..107 characters (Unix socket path)");
    }
  } else if (s.can_interface.empty() || s.can_interface.size() > 15) {
    fail("sensor.can_interface", "must be 1..15 characters (network interface name)");
  }
  if (s.motion_source != "kinematics" && s.motion_source != "imu") {
    fail("sensor.motion_source", "must be 'kinematics' or 'imu', got '" + s.motion_source + "'");
  }
  if (!fileReadable(s.dbc_path)) fail("sensor.dbc_path", "cannot read '" + s.dbc_path + "'");
  if (!(s.stale_timeout_ms > 0.0 && s.stale_timeout_ms <= 10000.0)) {
    fail("sensor.stale_timeout_ms", "must be in (0, 10000] ms");
  }
  if (!s.mount_xyz.allFinite() || s.mount_xyz.norm() > 2.0) {
    fail("sensor.mount_xyz", "must be finite and within 2 m of the flange");
  }
  if (!s.mount_rpy.allFinite() || s.mount_rpy.cwiseAbs().maxCoeff() > 2.0 * M_PI) {
    fail("sensor.mount_rpy", "must be finite angles in radians (|angle| <= 2 pi)");
  }
}

// The parameter file: named, and readable when parameters.required.
template <class Fail>
void validateParameterFile(const ParametersConfig& p, const Fail& fail) {
  if (p.path.empty()) fail("parameters.path", "must not be empty");
  if (p.required && !fileReadable(p.path)) {
    fail("parameters.path", "cannot read '" + p.path + "' (parameters.required is true)");
  }
}

// The five LCM channels: 1..63 characters that are safe in a subscriber's regular expression, and
// no two the same (the later one of a pair is named).
template <class Fail>
void validateLcmChannels(const LcmChannels& lc, const Fail& fail) {
  const std::pair<const char*, const std::string*> channels[] = {
      {"lcm.channels.cycle", &lc.cycle},     {"lcm.channels.wrench", &lc.wrench},
      {"lcm.channels.stats", &lc.stats},     {"lcm.channels.command", &lc.command},
      {"lcm.channels.ack", &lc.ack}};
  for (const auto& ch : channels) {
    if (ch.second->empty() || ch.second->size() > 63) fail(ch.first, "must be 1..63 characters");
    for (char ch_c : *ch.second) {
      if (!(std::isalnum(static_cast<unsigned char>(ch_c)) || ch_c == '_' || ch_c == '-' ||
            ch_c == '/' || ch_c == '.')) {
        fail(ch.first, "channel names use letters, digits and _ - / . only (a channel is also a "
                       "regular expression for subscribers), got '" + *ch.second + "'");
      }
    }
  }
  for (std::size_t i = 0; i < 5; ++i) {
    for (std::size_t j = i + 1; j < 5; ++j) {
      if (*channels[i].second == *channels[j].second) {
        fail(channels[j].first, "same channel as " + std::string(channels[i].first));
      }
    }
  }
}

// The rt section: SCHED_FIFO priority, CPU and overrun budget.
template <class Fail>
void validateRt(const RtConfig& rt, const Fail& fail) {
  if (rt.priority < 1 || rt.priority > 99) fail("rt.priority", "must be 1..99");
  if (rt.cpu < -1 || rt.cpu > 1023) fail("rt.cpu", "must be -1 (no pinning) or a CPU number");
  if (!(rt.overrun_budget_ms >= 0.0 && rt.overrun_budget_ms <= 1000.0)) {
    fail("rt.overrun_budget_ms", "must be in 0..1000 ms (0 = half a period)");
  }
}

// The output frame and the tool pose in S (p_ST_S within 2 m, R_ST's angles within 2 pi).
template <class Fail>
void validateOutputFrame(const OutputConfig& o, const Fail& fail) {
  if (o.frame != "sensor" && o.frame != "tool" && o.frame != "base") {
    fail("output.frame", "must be 'sensor', 'tool' or 'base', got '" + o.frame + "'");
  }
  if (!(o.tool_xyz.norm() <= 2.0)) fail("output.tool_xyz", "must be within 2 m of the sensor");
  if (!(o.tool_rpy.cwiseAbs().maxCoeff() <= 2.0 * M_PI)) {
    fail("output.tool_rpy", "must be angles in radians (|angle| <= 2 pi)");
  }
}

// The TARE command's averaging window [s] and its at-rest limits qd [rad/s], qdd [rad/s^2].
template <class Fail>
void validateTare(const ParametersConfig& p, const Fail& fail) {
  if (!(p.tare_window_s > 0.0 && p.tare_window_s <= 5.0)) {
    fail("parameters.tare_window_s", "must be in (0, 5] s");
  }
  if (!(p.tare_max_qd > 0.0 && p.tare_max_qd <= 1.0)) {
    fail("parameters.tare_max_qd", "must be in (0, 1] rad/s");
  }
  if (!(p.tare_max_qdd > 0.0 && p.tare_max_qdd <= 10.0)) {
    fail("parameters.tare_max_qdd", "must be in (0, 10] rad/s^2");
  }
}

// The output low-pass: off, or a cut-off below 0.45 x the sample rate (the RTDE rate).
template <class Fail>
void validateLowpass(const OutputConfig& o, double rtde_frequency_hz, const Fail& fail) {
  if (!(o.lowpass_hz == 0.0 || (o.lowpass_hz > 0.0 && o.lowpass_hz < 0.45 * rtde_frequency_hz))) {
    fail("output.lowpass_hz", "must be 0 (off) or in (0, 0.45 x robot.rtde_frequency_hz) Hz");
  }
}

// The export's rigid parts (adapter, sensor body): mass 0..100 kg, com within 1 m of the flange,
// and a physical inertia (moments >= 0 satisfying the triangle inequality; zero for mass 0).
template <class Fail>
void validateRigidParts(const ExportConfig& e, const Fail& fail) {
  for (const auto& [name, part] : {std::pair<std::string, const RigidPartConfig*>{"export.adapter", &e.adapter},
                                   {"export.sensor_body", &e.sensor_body}}) {
    if (!(part->mass >= 0.0 && part->mass <= 100.0)) fail(name + ".mass", "must be in 0..100 kg");
    if (!(part->com_F.norm() <= 1.0)) fail(name + ".com", "must be within 1 m of the flange");
    const Vec6& I = part->inertia_C_F;
    const double a = I(0), b = I(1), d = I(2);
    if (!(a >= 0.0 && b >= 0.0 && d >= 0.0) || a + b < d || a + d < b || b + d < a || I.cwiseAbs().maxCoeff() > 10.0) {
      fail(name + ".inertia", "must be a physical inertia [ixx, iyy, izz, ixy, ixz, iyz] (moments >= 0, each "
                              "at most the sum of the other two, |entries| <= 10 kg m^2)");
    }
    if (part->mass == 0.0 && I.cwiseAbs().maxCoeff() > 0.0) fail(name + ".inertia", "is non-zero for a part of mass 0");
  }
}

// The recording: when enabled, a path ftidd may create (recordPathProblem).
template <class Fail>
void validateRecord(const RecordConfig& r, const Fail& fail) {
  if (r.enabled) {
    if (r.path.empty()) fail("record.path", "must not be empty when record.enabled");
    if (const std::string p = recordPathProblem(r.path); !p.empty()) fail("record.path", p);
  }
}

}  // namespace

namespace internal {

std::string dirOf(const std::string& path) {
  const auto slash = path.find_last_of('/');
  if (slash == std::string::npos) return ".";
  if (slash == 0) return "/";
  return path.substr(0, slash);
}

void validate(const DaemonConfig& c, const std::function<std::string(const std::string&)>& where,
              std::vector<std::string>* warnings) {
  auto fail = [&](const std::string& key, const std::string& what) {
    throw ConfigError(where(key) + ": key '" + key + "': " + what);
  };
  validateRobotLink(c.robot, fail);
  validateRobotTiming(c.robot, fail);
  validateRobotModel(c.robot, fail);
  validateSensor(c.sensor, fail);
  validateParameterFile(c.parameters, fail);
  checkLcmUrl(c.lcm.url, where("lcm.url"), warnings);
  validateLcmChannels(c.lcm.channels, fail);
  if (!(c.lcm.stats_period_s >= 0.1 && c.lcm.stats_period_s <= 60.0)) {
    fail("lcm.stats_period_s", "must be in 0.1..60 s");
  }
  validateRt(c.rt, fail);
  validateMonitor(c.monitor, fail);
  validateOutputFrame(c.output, fail);
  validateTare(c.parameters, fail);
  validateLowpass(c.output, c.robot.rtde_frequency_hz, fail);
  validateRigidParts(c.exports, fail);
  validateRecord(c.record, fail);
}

}  // namespace internal

void checkLcmUrl(const std::string& url, const std::string& where, std::vector<std::string>* warnings) {
  auto fail = [&](const std::string& what) {
    throw ConfigError(where + ": key 'lcm.url': " + what + " (got '" + url + "'; default " +
                      LcmConfig().url + ")");
  };
  if (url.empty()) fail("must not be empty");
  if (url.size() > 512) fail("is too long");
  const auto sep = url.find("://");
  if (sep == std::string::npos) fail("must be an LCM provider URL (udpm://, tcpq://, memq://)");
  const std::string scheme = url.substr(0, sep);
  const std::string rest = url.substr(sep + 3);
  const auto q = rest.find('?');
  const std::string target = rest.substr(0, q);
  const std::string options = q == std::string::npos ? "" : rest.substr(q + 1);
  if (scheme == "memq") {
    if (!rest.empty()) fail("memq:// takes no address or options");
    return;
  }
  if (scheme == "file") {
    // LCM's file provider reads or writes a log file: not a network provider (file:///dev/sda).
    fail("must be a network provider (udpm://, or tcpq://; memq:// for tests), not file:// (record with record.path)");
  }
  auto hostPort = [&](bool multicast) {
    const auto colon = target.rfind(':');
    if (colon == std::string::npos) fail("needs ADDRESS:PORT");
    const std::string host = target.substr(0, colon);
    unsigned long port = 0;
    if (!parseUint(target.substr(colon + 1), 65535, port) || port == 0) fail("port must be 1..65535");
    if (multicast) {
      in_addr addr{};
      if (::inet_pton(AF_INET, host.c_str(), &addr) != 1) fail("'" + host + "' is not an IPv4 address");
      const std::uint32_t a = ntohl(addr.s_addr);
      if ((a >> 28) != 0xE) fail("'" + host + "' is not a multicast address (224.0.0.0 - 239.255.255.255)");
    } else if (host.empty()) {
      fail("needs a host");
    }
  };
  if (scheme == "tcpq") {
    hostPort(false);
    return;
  }
  if (scheme != "udpm") fail("unknown provider '" + scheme + "' (udpm://, tcpq://, memq://)");
  hostPort(true);
  std::size_t start = 0;
  while (start < options.size()) {
    auto amp = options.find('&', start);
    if (amp == std::string::npos) amp = options.size();
    const std::string opt = options.substr(start, amp - start);
    start = amp + 1;
    if (opt.empty()) continue;
    const auto eq = opt.find('=');
    const std::string name = opt.substr(0, eq);
    const std::string value = eq == std::string::npos ? "" : opt.substr(eq + 1);
    unsigned long v = 0;
    if (name == "ttl") {
      if (!parseUint(value, 255, v)) fail("ttl must be an integer 0..255");
      if (v > 1 && warnings != nullptr) {
        warnings->push_back(where + ": key 'lcm.url': ttl=" + value +
                            " lets ftidd's messages be routed beyond this host's network; use ttl=0 "
                            "(this host only) or ttl=1 (the local subnet)");
      }
    } else if (name == "recv_buf_size") {
      if (!parseUint(value, 1UL << 30, v)) fail("recv_buf_size must be a byte count");
    } else {
      fail("unknown udpm option '" + name + "' (known: ttl, recv_buf_size)");
    }
  }
}

}  // namespace ftid::config
