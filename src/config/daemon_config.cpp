#include "ftid/config/daemon_config.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <climits>
#include <cstdint>
#include <cmath>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "ftid/common/error.hpp"
#include "ftid/fileio/input_file.hpp"
#include "ftid/fileio/yaml_reader.hpp"

namespace ftid::config {
namespace {

// ---------------------------------------------------------------------------------------------
// Reading: fileio's YamlValue ("FILE:LINE:COLUMN: key 'a.b': problem"), one handler per key.

using Handler = std::function<void(const YamlValue&)>;

// Applies handlers to the keys of a mapping; unknown keys are errors listing the known ones, and a
// key without a value is an error (never silently the default).
void readSection(const YamlValue& map, const std::vector<std::pair<std::string, Handler>>& handlers) {
  std::vector<std::string> known;
  known.reserve(handlers.size());
  for (const auto& h : handlers) known.push_back(h.first);
  map.onlyKeys(known);
  for (const auto& [name, value] : map.entries()) {
    if (value.isNull()) value.fail("has no value");
    for (const auto& h : handlers) {
      if (h.first == name) h.second(value);
    }
  }
}

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

std::string dirOf(const std::string& path) {
  const auto slash = path.find_last_of('/');
  if (slash == std::string::npos) return ".";
  if (slash == 0) return "/";
  return path.substr(0, slash);
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
  const std::string dir = dirOf(path);
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

// Cross-field and file checks. `where(key)` gives the location prefix for a key.
void validate(const DaemonConfig& c, const std::function<std::string(const std::string&)>& where,
              std::vector<std::string>* warnings) {
  auto fail = [&](const std::string& key, const std::string& what) {
    throw ConfigError(where(key) + ": key '" + key + "': " + what);
  };
  if (c.robot.host.empty()) fail("robot.host", "must not be empty");
  if (const std::string p = hostProblem(c.robot.host); !p.empty()) fail("robot.host", "'" + c.robot.host + "' " + p);
  if (c.robot.rtde_port < 1 || c.robot.rtde_port > 65535) fail("robot.rtde_port", "must be 1..65535");
  if (c.robot.dashboard_port < 1 || c.robot.dashboard_port > 65535) {
    fail("robot.dashboard_port", "must be 1..65535");
  }
  if (!(c.robot.rtde_frequency_hz >= 1.0 && c.robot.rtde_frequency_hz <= 500.0)) {
    fail("robot.rtde_frequency_hz", "must be in 1..500 Hz");
  }
  {
    // The controller sends on its control ticks only (500 Hz e-Series, 125 Hz CB3), every
    // floor(f_loop / f)-th: the cycle rate is 500 / n (CB3: 125 / n = 500 / 4n). Another value is
    // not the rate ftidd would get (docs/robot.md).
    const double n = std::round(500.0 / c.robot.rtde_frequency_hz);
    if (std::abs(500.0 / n - c.robot.rtde_frequency_hz) > 1e-3) {
      const double lo = 500.0 / (n + 1.0);
      const double hi = 500.0 / std::max(1.0, n - 1.0);
      std::ostringstream os;
      os << "must be a rate the controller sends at, 500 / n Hz (e-Series; CB3 125 / n), e.g. " << 500.0 / n
         << " (nearby: " << lo << ", " << hi << ")";
      fail("robot.rtde_frequency_hz", os.str());
    }
  }
  if (!(c.robot.rated_payload_kg > 0.0 && c.robot.rated_payload_kg <= 1000.0)) {
    fail("robot.rated_payload_kg", "must be in (0, 1000] kg (the robot's rated payload: UR10 10, UR10e 12.5)");
  }
  if (!(c.robot.receive_timeout_ms >= 0.0 && c.robot.receive_timeout_ms <= 1000.0)) {
    fail("robot.receive_timeout_ms", "must be in 0..1000 ms (0 = 1.5 periods)");
  }
  if (!(c.robot.silent_publish_after_ms >= 10.0 && c.robot.silent_publish_after_ms <= 10000.0)) {
    fail("robot.silent_publish_after_ms", "must be in 10..10000 ms");
  }
  if (c.robot.silent_publish_after_ms < 1500.0 / c.robot.rtde_frequency_hz) {
    fail("robot.silent_publish_after_ms", "must be at least 1.5 robot periods (" +
                                              std::to_string(1500.0 / c.robot.rtde_frequency_hz) +
                                              " ms at robot.rtde_frequency_hz): a shorter silence is every "
                                              "period (default: max(50, 3 periods))");
  }
  if (!(c.robot.watchdog_silence_s == 0.0 ||
        (c.robot.watchdog_silence_s >= 0.1 && c.robot.watchdog_silence_s <= 3600.0))) {
    fail("robot.watchdog_silence_s", "must be 0 (never) or in 0.1..3600 s");
  }
  if (!(c.robot.reconnect_after_silence_s == 0.0 ||
        (c.robot.reconnect_after_silence_s >= 0.1 && c.robot.reconnect_after_silence_s <= 3600.0))) {
    fail("robot.reconnect_after_silence_s", "must be 0 (only on a TCP failure) or in 0.1..3600 s");
  }
  if (!(c.robot.reconnect_backoff_min_s >= 0.01 && c.robot.reconnect_backoff_min_s <= 60.0)) {
    fail("robot.reconnect_backoff_min_s", "must be in 0.01..60 s");
  }
  if (!(c.robot.reconnect_backoff_max_s >= c.robot.reconnect_backoff_min_s &&
        c.robot.reconnect_backoff_max_s <= 300.0)) {
    fail("robot.reconnect_backoff_max_s", "must be in robot.reconnect_backoff_min_s..300 s");
  }
  if (!fileReadable(c.robot.urdf_path)) {
    fail("robot.urdf_path", "cannot read '" + c.robot.urdf_path + "'");
  }
  if (c.robot.base_link.empty()) fail("robot.base_link", "must not be empty");
  if (c.robot.tip_link.empty()) fail("robot.tip_link", "must not be empty");
  if (c.sensor.transport != "seqpacket" && c.sensor.transport != "socketcan") {
    fail("sensor.transport", "must be 'seqpacket' or 'socketcan', got '" + c.sensor.transport + "'");
  }
  if (c.sensor.transport == "seqpacket") {
    if (c.sensor.socket_path.empty() || c.sensor.socket_path.size() > 107) {
      fail("sensor.socket_path", "must be 1..107 characters (Unix socket path)");
    }
  } else if (c.sensor.can_interface.empty() || c.sensor.can_interface.size() > 15) {
    fail("sensor.can_interface", "must be 1..15 characters (network interface name)");
  }
  if (c.sensor.motion_source != "kinematics" && c.sensor.motion_source != "imu") {
    fail("sensor.motion_source", "must be 'kinematics' or 'imu', got '" + c.sensor.motion_source + "'");
  }
  if (!fileReadable(c.sensor.dbc_path)) fail("sensor.dbc_path", "cannot read '" + c.sensor.dbc_path + "'");
  if (!(c.sensor.stale_timeout_ms > 0.0 && c.sensor.stale_timeout_ms <= 10000.0)) {
    fail("sensor.stale_timeout_ms", "must be in (0, 10000] ms");
  }
  if (!c.sensor.mount_xyz.allFinite() || c.sensor.mount_xyz.norm() > 2.0) {
    fail("sensor.mount_xyz", "must be finite and within 2 m of the flange");
  }
  if (!c.sensor.mount_rpy.allFinite() || c.sensor.mount_rpy.cwiseAbs().maxCoeff() > 2.0 * M_PI) {
    fail("sensor.mount_rpy", "must be finite angles in radians (|angle| <= 2 pi)");
  }
  if (c.parameters.path.empty()) fail("parameters.path", "must not be empty");
  if (c.parameters.required && !fileReadable(c.parameters.path)) {
    fail("parameters.path", "cannot read '" + c.parameters.path + "' (parameters.required is true)");
  }
  checkLcmUrl(c.lcm.url, where("lcm.url"), warnings);
  const std::pair<const char*, const std::string*> channels[] = {
      {"lcm.channels.cycle", &c.lcm.channels.cycle},   {"lcm.channels.wrench", &c.lcm.channels.wrench},
      {"lcm.channels.stats", &c.lcm.channels.stats},   {"lcm.channels.command", &c.lcm.channels.command},
      {"lcm.channels.ack", &c.lcm.channels.ack}};
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
  if (!(c.lcm.stats_period_s >= 0.1 && c.lcm.stats_period_s <= 60.0)) {
    fail("lcm.stats_period_s", "must be in 0.1..60 s");
  }
  if (c.rt.priority < 1 || c.rt.priority > 99) fail("rt.priority", "must be 1..99");
  if (c.rt.cpu < -1 || c.rt.cpu > 1023) fail("rt.cpu", "must be -1 (no pinning) or a CPU number");
  if (!(c.rt.overrun_budget_ms >= 0.0 && c.rt.overrun_budget_ms <= 1000.0)) {
    fail("rt.overrun_budget_ms", "must be in 0..1000 ms (0 = half a period)");
  }
  validateMonitor(c.monitor, fail);
  if (c.output.frame != "sensor" && c.output.frame != "tool" && c.output.frame != "base") {
    fail("output.frame", "must be 'sensor', 'tool' or 'base', got '" + c.output.frame + "'");
  }
  if (!(c.output.tool_xyz.norm() <= 2.0)) fail("output.tool_xyz", "must be within 2 m of the sensor");
  if (!(c.output.tool_rpy.cwiseAbs().maxCoeff() <= 2.0 * M_PI)) {
    fail("output.tool_rpy", "must be angles in radians (|angle| <= 2 pi)");
  }
  if (!(c.parameters.tare_window_s > 0.0 && c.parameters.tare_window_s <= 5.0)) {
    fail("parameters.tare_window_s", "must be in (0, 5] s");
  }
  if (!(c.parameters.tare_max_qd > 0.0 && c.parameters.tare_max_qd <= 1.0)) {
    fail("parameters.tare_max_qd", "must be in (0, 1] rad/s");
  }
  if (!(c.parameters.tare_max_qdd > 0.0 && c.parameters.tare_max_qdd <= 10.0)) {
    fail("parameters.tare_max_qdd", "must be in (0, 10] rad/s^2");
  }
  if (!(c.output.lowpass_hz == 0.0 ||
        (c.output.lowpass_hz > 0.0 && c.output.lowpass_hz < 0.45 * c.robot.rtde_frequency_hz))) {
    fail("output.lowpass_hz", "must be 0 (off) or in (0, 0.45 x robot.rtde_frequency_hz) Hz");
  }
  for (const auto& [name, part] : {std::pair<std::string, const RigidPartConfig*>{"export.adapter", &c.exports.adapter},
                                   {"export.sensor_body", &c.exports.sensor_body}}) {
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
  if (c.record.enabled) {
    if (c.record.path.empty()) fail("record.path", "must not be empty when record.enabled");
    if (const std::string p = recordPathProblem(c.record.path); !p.empty()) fail("record.path", p);
  }
}

}  // namespace

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

Mat3 OutputConfig::R_ST() const {
  const Eigen::AngleAxisd rx(tool_rpy.x(), Vec3::UnitX());
  const Eigen::AngleAxisd ry(tool_rpy.y(), Vec3::UnitY());
  const Eigen::AngleAxisd rz(tool_rpy.z(), Vec3::UnitZ());
  return (rz * ry * rx).toRotationMatrix();
}

Mat3 SensorConfig::R_FS() const {
  const Eigen::AngleAxisd rx(mount_rpy.x(), Vec3::UnitX());
  const Eigen::AngleAxisd ry(mount_rpy.y(), Vec3::UnitY());
  const Eigen::AngleAxisd rz(mount_rpy.z(), Vec3::UnitZ());
  return (rz * ry * rx).toRotationMatrix();
}

namespace {
DaemonConfig parseDaemonConfigUnguarded(const std::string& yaml_text, const std::string& source_name,
                                        const std::string& base_dir);
}  // namespace

DaemonConfig parseDaemonConfig(const std::string& yaml_text, const std::string& source_name,
                               const std::string& base_dir) {
  try {
    return parseDaemonConfigUnguarded(yaml_text, source_name, base_dir);
  } catch (const YAML::Exception& e) {  // a node of an unexpected kind: never escapes as a crash
    throw ConfigError(source_name + ":" + std::to_string(e.mark.line + 1) + ": unexpected structure: " + e.msg);
  }
}

namespace {
DaemonConfig parseDaemonConfigUnguarded(const std::string& yaml_text, const std::string& source_name,
                                        const std::string& base_dir) {
  const YamlFile file = YamlFile::parse(yaml_text, source_name);  // duplicate keys are errors
  DaemonConfig c;
  c.source = source_name;
  std::map<std::string, std::string> where;  // key -> FILE:LINE:COLUMN, for validation messages

  // Setters: each reads one typed value and remembers where it was.
  const auto at = [&](const YamlValue& v) { where[v.key()] = v.where(); };
  const auto number = [&](double& dst) -> Handler {
    return [&at, &dst](const YamlValue& v) { at(v); dst = v.number(); };
  };
  const auto integer = [&](int& dst) -> Handler {
    return [&at, &dst](const YamlValue& v) {
      at(v);
      dst = static_cast<int>(v.integer(-1000000000, 1000000000, "integer out of range"));
    };
  };
  const auto boolean = [&](bool& dst) -> Handler { return [&at, &dst](const YamlValue& v) { at(v); dst = v.boolean(); }; };
  const auto text = [&](std::string& dst) -> Handler {
    return [&at, &dst](const YamlValue& v) { at(v); dst = v.nonEmptyText(); };
  };
  const auto path = [&](std::string& dst) -> Handler {  // relative to the config file's directory
    return [&at, &dst, &base_dir](const YamlValue& v) {
      at(v);
      dst = v.nonEmptyText();
      if (dst[0] != '/' && !base_dir.empty()) dst = base_dir + "/" + dst;
    };
  };
  const auto vec3 = [&](Vec3& dst) -> Handler { return [&at, &dst](const YamlValue& v) { at(v); dst = v.vector<3>(); }; };
  const auto vec6 = [&](Vec6& dst) -> Handler { return [&at, &dst](const YamlValue& v) { at(v); dst = v.vector<6>(); }; };
  const auto section = [](std::vector<std::pair<std::string, Handler>> handlers) -> Handler {
    return [handlers = std::move(handlers)](const YamlValue& v) { readSection(v, handlers); };
  };
  const auto part = [&](RigidPartConfig& p) -> Handler {
    return section({{"mass", number(p.mass)}, {"com", vec3(p.com_F)}, {"inertia", vec6(p.inertia_C_F)}});
  };

  const YamlValue root = file.root();
  if (!root.isNull()) {  // an empty file: all defaults
    readSection(root, {
      {"robot", section({
        {"host", text(c.robot.host)},
        {"rtde_port", integer(c.robot.rtde_port)},
        {"dashboard_port", integer(c.robot.dashboard_port)},
        {"rtde_frequency_hz", number(c.robot.rtde_frequency_hz)},
        {"rated_payload_kg", number(c.robot.rated_payload_kg)},
        {"urdf_path", path(c.robot.urdf_path)},
        {"base_link", text(c.robot.base_link)},
        {"tip_link", text(c.robot.tip_link)},
        {"receive_timeout_ms", number(c.robot.receive_timeout_ms)},
        {"silent_publish_after_ms", number(c.robot.silent_publish_after_ms)},
        {"watchdog_silence_s", number(c.robot.watchdog_silence_s)},
        {"reconnect_after_silence_s", number(c.robot.reconnect_after_silence_s)},
        {"reconnect_backoff_min_s", number(c.robot.reconnect_backoff_min_s)},
        {"reconnect_backoff_max_s", number(c.robot.reconnect_backoff_max_s)},
      })},
      {"sensor", section({
        {"transport", text(c.sensor.transport)},
        {"socket_path", path(c.sensor.socket_path)},
        {"can_interface", text(c.sensor.can_interface)},
        {"dbc_path", path(c.sensor.dbc_path)},
        {"stale_timeout_ms", number(c.sensor.stale_timeout_ms)},
        {"mount_xyz", vec3(c.sensor.mount_xyz)},
        {"mount_rpy", vec3(c.sensor.mount_rpy)},
        {"motion_source", text(c.sensor.motion_source)},
      })},
      {"parameters", section({
        {"path", path(c.parameters.path)},
        {"required", boolean(c.parameters.required)},
        {"tare_window_s", number(c.parameters.tare_window_s)},
        {"tare_max_qd", number(c.parameters.tare_max_qd)},
        {"tare_max_qdd", number(c.parameters.tare_max_qdd)},
      })},
      {"lcm", section({
        {"url", text(c.lcm.url)},
        {"publish_cycle", boolean(c.lcm.publish_cycle)},
        {"stats_period_s", number(c.lcm.stats_period_s)},
        {"command_key_path", path(c.lcm.command_key_path)},
        {"accept_remote", boolean(c.lcm.accept_remote)},
        {"channels", section({
          {"cycle", text(c.lcm.channels.cycle)},
          {"wrench", text(c.lcm.channels.wrench)},
          {"stats", text(c.lcm.channels.stats)},
          {"command", text(c.lcm.channels.command)},
          {"ack", text(c.lcm.channels.ack)},
        })},
      })},
      {"rt", section({
        {"require_rt", boolean(c.rt.require_rt)},
        {"lock_memory", boolean(c.rt.lock_memory)},
        {"priority", integer(c.rt.priority)},
        {"cpu", integer(c.rt.cpu)},
        {"overrun_budget_ms", number(c.rt.overrun_budget_ms)},
      })},
      {"output", section({
        {"frame", text(c.output.frame)},
        {"tool_xyz", vec3(c.output.tool_xyz)},
        {"tool_rpy", vec3(c.output.tool_rpy)},
        {"lowpass_hz", number(c.output.lowpass_hz)},
      })},
      {"monitor", section({
        {"enabled", boolean(c.monitor.enabled)},
        {"channel", text(c.monitor.channel)},
        {"publish_hz", number(c.monitor.publish_hz)},
        {"noise_std", vec6(c.monitor.noise_std)},
        {"onset_margin", number(c.monitor.onset_margin)},
        {"onset_threshold", number(c.monitor.onset_threshold)},
        {"decision_threshold", number(c.monitor.decision_threshold)},
        {"contact_force_std_N", number(c.monitor.contact_force_std_N)},
        {"contact_torque_std_Nm", number(c.monitor.contact_torque_std_Nm)},
        {"contact_force_rate_N_s", number(c.monitor.contact_force_rate_N_s)},
        {"contact_torque_rate_Nm_s", number(c.monitor.contact_torque_rate_Nm_s)},
        {"prior_mass_std_kg", number(c.monitor.prior_mass_std_kg)},
        {"prior_mass_com_std_kg_m", number(c.monitor.prior_mass_com_std_kg_m)},
        {"prior_inertia_std_kg_m2", number(c.monitor.prior_inertia_std_kg_m2)},
        {"free_motion_turn_rad_s", number(c.monitor.free_motion_turn_rad_s)},
        {"free_motion_acc_m_s2", number(c.monitor.free_motion_acc_m_s2)},
        {"max_gap_s", number(c.monitor.max_gap_s)},
        {"restart_s", number(c.monitor.restart_s)},
        {"min_change_s", number(c.monitor.min_change_s)},
        {"reidentify_window_s", number(c.monitor.reidentify_window_s)},
      })},
      {"export", section({
        {"world_frame", text(c.exports.world_frame)},
        {"sensor_frame", text(c.exports.sensor_frame)},
        {"sensor_name", text(c.exports.sensor_name)},
        {"adapter", part(c.exports.adapter)},
        {"sensor_body", part(c.exports.sensor_body)},
      })},
      {"record", section({
        {"enabled", boolean(c.record.enabled)},
        {"path", path(c.record.path)},
      })},
    });
  }
  // The silence limit follows the rate unless given (at 1 Hz a fixed 50 ms is every period).
  if (where.find("robot.silent_publish_after_ms") == where.end() && c.robot.rtde_frequency_hz > 0.0) {
    c.robot.silent_publish_after_ms = std::max(c.robot.silent_publish_after_ms, 3000.0 / c.robot.rtde_frequency_hz);
  }
  validate(c, [&](const std::string& key) {
    const auto it = where.find(key);
    return it == where.end() ? source_name + " (default value)" : it->second;
  }, &c.warnings);
  return c;
}
}  // namespace

DaemonConfig loadDaemonConfig(const std::string& path) {
  std::string text;
  try {
    text = readInputFile(path, "config file", kMaxTextConfigBytes);
  } catch (const FileError& e) {
    throw ConfigError(e.what());
  }
  return parseDaemonConfig(text, path, dirOf(path));
}

std::string recordDirWritableProblem(const std::string& path) {
  const std::string dir = dirOf(path);
  if (::access(dir.c_str(), W_OK | X_OK) != 0) {
    return "directory '" + dir + "' is not writable by this process (uid " + std::to_string(::geteuid()) + ")";
  }
  return {};
}

void validateDaemonConfig(const DaemonConfig& config) {
  const std::string src = config.source.empty() ? std::string("<config>") : config.source;
  validate(config, [&](const std::string&) { return src; }, nullptr);
}

std::string describeDaemonConfig(const DaemonConfig& c) {
  std::ostringstream os;
  auto b = [](bool v) { return v ? "true" : "false"; };
  os << "config: " << (c.source.empty() ? "<defaults>" : c.source) << "\n"
     << "robot.host: " << c.robot.host << "\n"
     << "robot.rtde_port: " << c.robot.rtde_port << "\n"
     << "robot.dashboard_port: " << c.robot.dashboard_port << "\n"
     << "robot.rtde_frequency_hz: " << c.robot.rtde_frequency_hz << "\n"
     << "robot.rated_payload_kg: " << c.robot.rated_payload_kg << "\n"
     << "robot.urdf_path: " << c.robot.urdf_path << "\n"
     << "robot.base_link: " << c.robot.base_link << "\n"
     << "robot.tip_link: " << c.robot.tip_link << "\n"
     << "robot.receive_timeout_ms: " << c.robot.receive_timeout_ms << " (effective "
     << static_cast<double>(c.robot.receiveTimeout().count()) / 1000.0 << " ms)\n"
     << "robot.silent_publish_after_ms: " << c.robot.silent_publish_after_ms << "\n"
     << "robot.watchdog_silence_s: " << c.robot.watchdog_silence_s << "\n"
     << "robot.reconnect_after_silence_s: " << c.robot.reconnect_after_silence_s << "\n"
     << "robot.reconnect_backoff_min_s: " << c.robot.reconnect_backoff_min_s << "\n"
     << "robot.reconnect_backoff_max_s: " << c.robot.reconnect_backoff_max_s << "\n"
     << "sensor.transport: " << c.sensor.transport << "\n"
     << "sensor.socket_path: " << c.sensor.socket_path << "\n"
     << "sensor.can_interface: " << c.sensor.can_interface << "\n"
     << "sensor.dbc_path: " << c.sensor.dbc_path << "\n"
     << "sensor.stale_timeout_ms: " << c.sensor.stale_timeout_ms << "\n"
     << "sensor.mount_xyz: [" << c.sensor.mount_xyz.transpose() << "]\n"
     << "sensor.mount_rpy: [" << c.sensor.mount_rpy.transpose() << "]\n"
     << "sensor.motion_source: " << c.sensor.motion_source << "\n"
     << "parameters.path: " << c.parameters.path << "\n"
     << "parameters.required: " << b(c.parameters.required) << "\n"
     << "parameters.tare: window " << c.parameters.tare_window_s << " s, max qd " << c.parameters.tare_max_qd
     << " rad/s, max qdd " << c.parameters.tare_max_qdd << " rad/s^2\n"
     << "lcm.url: " << c.lcm.url << "\n"
     << "lcm.channels: cycle=" << c.lcm.channels.cycle << " wrench=" << c.lcm.channels.wrench
     << " stats=" << c.lcm.channels.stats << " command=" << c.lcm.channels.command
     << " ack=" << c.lcm.channels.ack << "\n"
     << "lcm.publish_cycle: " << b(c.lcm.publish_cycle) << "\n"
     << "lcm.stats_period_s: " << c.lcm.stats_period_s << "\n"
     << "lcm.command_key_path: " << c.lcm.command_key_path << "\n"
     << "lcm.accept_remote: " << b(c.lcm.accept_remote) << "\n"
     << "rt.require_rt: " << b(c.rt.require_rt) << "\n"
     << "rt.lock_memory: " << b(c.rt.lock_memory) << "\n"
     << "rt.priority: " << c.rt.priority << "\n"
     << "rt.cpu: " << c.rt.cpu << "\n"
     << "rt.overrun_budget_ms: " << c.rt.overrun_budget_ms << "\n"
     << "record.enabled: " << b(c.record.enabled) << "\n"
     << "record.path: " << c.record.path << "\n"
     << "output: frame=" << c.output.frame << " tool_xyz=[" << c.output.tool_xyz.transpose() << "] tool_rpy=["
     << c.output.tool_rpy.transpose() << "] lowpass_hz=" << c.output.lowpass_hz << "\n"
     << "monitor: enabled=" << b(c.monitor.enabled) << " channel=" << c.monitor.channel
     << " publish_hz=" << c.monitor.publish_hz << " noise_std=[" << c.monitor.noise_std.transpose()
     << "] decision_threshold=" << c.monitor.decision_threshold << "\n"
     << "export: world_frame=" << c.exports.world_frame << " sensor_frame=" << c.exports.sensor_frame
     << " sensor_name=" << c.exports.sensor_name << "\n"
     << "export.adapter: mass " << c.exports.adapter.mass << " kg, com [" << c.exports.adapter.com_F.transpose()
     << "] m, inertia [" << c.exports.adapter.inertia_C_F.transpose() << "]\n"
     << "export.sensor_body: mass " << c.exports.sensor_body.mass << " kg, com ["
     << c.exports.sensor_body.com_F.transpose() << "] m, inertia [" << c.exports.sensor_body.inertia_C_F.transpose()
     << "]\n";
  return os.str();
}

}  // namespace ftid::config
