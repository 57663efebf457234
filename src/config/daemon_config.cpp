#include "ftid/config/daemon_config.hpp"

#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <utility>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "daemon_config_validate.hpp"
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

}  // namespace

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
// Typed setters for readSection, one per kind of value: each handler reads one value into `dst`
// and remembers where it was (key -> FILE:LINE:COLUMN), for validation messages. The handlers
// refer to this reader: it must outlive them (never copied).
class KeyReader {
 public:
  explicit KeyReader(std::string base_dir) : base_dir_(std::move(base_dir)) {}
  KeyReader(const KeyReader&) = delete;
  KeyReader& operator=(const KeyReader&) = delete;

  Handler number(double& dst) {
    return [this, &dst](const YamlValue& v) { at(v); dst = v.number(); };
  }
  Handler integer(int& dst) {
    return [this, &dst](const YamlValue& v) {
      at(v);
      dst = static_cast<int>(v.integer(-1000000000, 1000000000, "integer out of range"));
    };
  }
  Handler boolean(bool& dst) { return [this, &dst](const YamlValue& v) { at(v); dst = v.boolean(); }; }
  Handler text(std::string& dst) {
    return [this, &dst](const YamlValue& v) { at(v); dst = v.nonEmptyText(); };
  }
  /// A path, relative to the config file's directory unless absolute.
  Handler path(std::string& dst) {
    return [this, &dst](const YamlValue& v) {
      at(v);
      dst = v.nonEmptyText();
      if (dst[0] != '/' && !base_dir_.empty()) dst = base_dir_ + "/" + dst;
    };
  }
  Handler vec3(Vec3& dst) { return [this, &dst](const YamlValue& v) { at(v); dst = v.vector<3>(); }; }
  Handler vec6(Vec6& dst) { return [this, &dst](const YamlValue& v) { at(v); dst = v.vector<6>(); }; }
  /// A mapping whose keys are read by `handlers` (readSection).
  static Handler section(std::vector<std::pair<std::string, Handler>> handlers) {
    return [handlers = std::move(handlers)](const YamlValue& v) { readSection(v, handlers); };
  }
  /// A rigid part: mass [kg], com (com_F [m]) and inertia (inertia_C_F [kg m^2]).
  Handler part(RigidPartConfig& p) {
    return section({{"mass", number(p.mass)}, {"com", vec3(p.com_F)}, {"inertia", vec6(p.inertia_C_F)}});
  }

  /// Where each key read so far was given.
  const std::map<std::string, std::string>& where() const { return where_; }

 private:
  void at(const YamlValue& v) { where_[v.key()] = v.where(); }

  std::string base_dir_;
  std::map<std::string, std::string> where_;
};

// The keys of the `robot` section.
Handler robotSection(RobotConfig& r, KeyReader& k) {
  return KeyReader::section({
    {"host", k.text(r.host)},
    {"rtde_port", k.integer(r.rtde_port)},
    {"dashboard_port", k.integer(r.dashboard_port)},
    {"rtde_frequency_hz", k.number(r.rtde_frequency_hz)},
    {"rated_payload_kg", k.number(r.rated_payload_kg)},
    {"urdf_path", k.path(r.urdf_path)},
    {"base_link", k.text(r.base_link)},
    {"tip_link", k.text(r.tip_link)},
    {"receive_timeout_ms", k.number(r.receive_timeout_ms)},
    {"silent_publish_after_ms", k.number(r.silent_publish_after_ms)},
    {"watchdog_silence_s", k.number(r.watchdog_silence_s)},
    {"reconnect_after_silence_s", k.number(r.reconnect_after_silence_s)},
    {"reconnect_backoff_min_s", k.number(r.reconnect_backoff_min_s)},
    {"reconnect_backoff_max_s", k.number(r.reconnect_backoff_max_s)},
  });
}

// The keys of the `sensor` section.
Handler sensorSection(SensorConfig& s, KeyReader& k) {
  return KeyReader::section({
    {"transport", k.text(s.transport)},
    {"socket_path", k.path(s.socket_path)},
    {"can_interface", k.text(s.can_interface)},
    {"dbc_path", k.path(s.dbc_path)},
    {"stale_timeout_ms", k.number(s.stale_timeout_ms)},
    {"mount_xyz", k.vec3(s.mount_xyz)},
    {"mount_rpy", k.vec3(s.mount_rpy)},
    {"motion_source", k.text(s.motion_source)},
  });
}

// The keys of the `parameters` section.
Handler parametersSection(ParametersConfig& p, KeyReader& k) {
  return KeyReader::section({
    {"path", k.path(p.path)},
    {"required", k.boolean(p.required)},
    {"tare_window_s", k.number(p.tare_window_s)},
    {"tare_max_qd", k.number(p.tare_max_qd)},
    {"tare_max_qdd", k.number(p.tare_max_qdd)},
  });
}

// The keys of the `lcm` section and its `channels`.
Handler lcmSection(LcmConfig& l, KeyReader& k) {
  return KeyReader::section({
    {"url", k.text(l.url)},
    {"publish_cycle", k.boolean(l.publish_cycle)},
    {"stats_period_s", k.number(l.stats_period_s)},
    {"command_key_path", k.path(l.command_key_path)},
    {"accept_remote", k.boolean(l.accept_remote)},
    {"channels", KeyReader::section({
      {"cycle", k.text(l.channels.cycle)},
      {"wrench", k.text(l.channels.wrench)},
      {"stats", k.text(l.channels.stats)},
      {"command", k.text(l.channels.command)},
      {"ack", k.text(l.channels.ack)},
    })},
  });
}

// The keys of the `rt` section.
Handler rtSection(RtConfig& rt, KeyReader& k) {
  return KeyReader::section({
    {"require_rt", k.boolean(rt.require_rt)},
    {"lock_memory", k.boolean(rt.lock_memory)},
    {"priority", k.integer(rt.priority)},
    {"cpu", k.integer(rt.cpu)},
    {"overrun_budget_ms", k.number(rt.overrun_budget_ms)},
  });
}

// The keys of the `output` section.
Handler outputSection(OutputConfig& o, KeyReader& k) {
  return KeyReader::section({
    {"frame", k.text(o.frame)},
    {"tool_xyz", k.vec3(o.tool_xyz)},
    {"tool_rpy", k.vec3(o.tool_rpy)},
    {"lowpass_hz", k.number(o.lowpass_hz)},
  });
}

// The keys of the `monitor` section.
Handler monitorSection(MonitorConfig& m, KeyReader& k) {
  return KeyReader::section({
    {"enabled", k.boolean(m.enabled)},
    {"channel", k.text(m.channel)},
    {"publish_hz", k.number(m.publish_hz)},
    {"noise_std", k.vec6(m.noise_std)},
    {"onset_margin", k.number(m.onset_margin)},
    {"onset_threshold", k.number(m.onset_threshold)},
    {"decision_threshold", k.number(m.decision_threshold)},
    {"contact_force_std_N", k.number(m.contact_force_std_N)},
    {"contact_torque_std_Nm", k.number(m.contact_torque_std_Nm)},
    {"contact_force_rate_N_s", k.number(m.contact_force_rate_N_s)},
    {"contact_torque_rate_Nm_s", k.number(m.contact_torque_rate_Nm_s)},
    {"prior_mass_std_kg", k.number(m.prior_mass_std_kg)},
    {"prior_mass_com_std_kg_m", k.number(m.prior_mass_com_std_kg_m)},
    {"prior_inertia_std_kg_m2", k.number(m.prior_inertia_std_kg_m2)},
    {"free_motion_turn_rad_s", k.number(m.free_motion_turn_rad_s)},
    {"free_motion_acc_m_s2", k.number(m.free_motion_acc_m_s2)},
    {"max_gap_s", k.number(m.max_gap_s)},
    {"restart_s", k.number(m.restart_s)},
    {"min_change_s", k.number(m.min_change_s)},
    {"reidentify_window_s", k.number(m.reidentify_window_s)},
  });
}

// The keys of the `export` section (DaemonConfig::exports).
Handler exportSection(ExportConfig& e, KeyReader& k) {
  return KeyReader::section({
    {"world_frame", k.text(e.world_frame)},
    {"sensor_frame", k.text(e.sensor_frame)},
    {"sensor_name", k.text(e.sensor_name)},
    {"adapter", k.part(e.adapter)},
    {"sensor_body", k.part(e.sensor_body)},
  });
}

// The keys of the `record` section.
Handler recordSection(RecordConfig& r, KeyReader& k) {
  return KeyReader::section({
    {"enabled", k.boolean(r.enabled)},
    {"path", k.path(r.path)},
  });
}

// The top-level sections of ftidd.yaml, in the order unknown-key messages list them.
std::vector<std::pair<std::string, Handler>> topLevelSections(DaemonConfig& c, KeyReader& k) {
  return {
    {"robot", robotSection(c.robot, k)},
    {"sensor", sensorSection(c.sensor, k)},
    {"parameters", parametersSection(c.parameters, k)},
    {"lcm", lcmSection(c.lcm, k)},
    {"rt", rtSection(c.rt, k)},
    {"output", outputSection(c.output, k)},
    {"monitor", monitorSection(c.monitor, k)},
    {"export", exportSection(c.exports, k)},
    {"record", recordSection(c.record, k)},
  };
}

// The silence limit follows the rate unless given (at 1 Hz a fixed 50 ms is every period):
// silent_publish_after_ms = max(default, 3 RTDE periods) when the file does not set it.
void silenceFollowsRate(const std::map<std::string, std::string>& where, RobotConfig& r) {
  if (where.find("robot.silent_publish_after_ms") == where.end() && r.rtde_frequency_hz > 0.0) {
    r.silent_publish_after_ms = std::max(r.silent_publish_after_ms, 3000.0 / r.rtde_frequency_hz);
  }
}

DaemonConfig parseDaemonConfigUnguarded(const std::string& yaml_text, const std::string& source_name,
                                        const std::string& base_dir) {
  const YamlFile file = YamlFile::parse(yaml_text, source_name);  // duplicate keys are errors
  DaemonConfig c;
  c.source = source_name;
  KeyReader keys(base_dir);  // remembers key -> FILE:LINE:COLUMN, for validation messages
  const YamlValue root = file.root();
  if (!root.isNull()) readSection(root, topLevelSections(c, keys));  // an empty file: all defaults
  silenceFollowsRate(keys.where(), c.robot);
  const std::map<std::string, std::string>& where = keys.where();
  internal::validate(c, [&](const std::string& key) {
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
  return parseDaemonConfig(text, path, internal::dirOf(path));
}

std::string recordDirWritableProblem(const std::string& path) {
  const std::string dir = internal::dirOf(path);
  if (::access(dir.c_str(), W_OK | X_OK) != 0) {
    return "directory '" + dir + "' is not writable by this process (uid " + std::to_string(::geteuid()) + ")";
  }
  return {};
}

void validateDaemonConfig(const DaemonConfig& config) {
  const std::string src = config.source.empty() ? std::string("<config>") : config.source;
  internal::validate(config, [&](const std::string&) { return src; }, nullptr);
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
