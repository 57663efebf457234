// sim-sensor configuration: defaults, YAML (config/sim_sensor.yaml) and --effect names.
#include <yaml-cpp/yaml.h>

#include <cmath>

#include "ftid/fileio/yaml_strict.hpp"
#include "ftid/common/default_files.hpp"
#include "ftid/common/error.hpp"
#include "ftid/simsensor/sim_sensor.hpp"

namespace ftid::simsensor {

namespace {

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

class YamlReader {
 public:
  explicit YamlReader(std::string file) : file_(std::move(file)) {}

  [[noreturn]] void fail(const std::string& key, const YAML::Node& node,
                         const std::string& what) const {
    std::string where = file_;
    if (node.IsDefined() && node.Mark().line >= 0) where += ":" + std::to_string(node.Mark().line + 1);
    throw ConfigError(where + ": key '" + key + "': " + what);
  }
  double number(const YAML::Node& n, const std::string& key) const {
    try {
      const double v = n.as<double>();
      if (!std::isfinite(v)) fail(key, n, "must be a finite number");
      return v;
    } catch (const YAML::Exception&) {
      fail(key, n, "expected a number");
    }
  }
  bool boolean(const YAML::Node& n, const std::string& key) const {
    try {
      return n.as<bool>();
    } catch (const YAML::Exception&) {
      fail(key, n, "expected true or false");
    }
  }
  std::string text(const YAML::Node& n, const std::string& key) const {
    if (!n.IsScalar()) fail(key, n, "expected a string");
    return n.as<std::string>();
  }
  template <int N>
  Eigen::Matrix<double, N, 1> vec(const YAML::Node& n, const std::string& key) const {
    if (!n.IsSequence() || static_cast<int>(n.size()) != N)
      fail(key, n, "expected a list of " + std::to_string(N) + " numbers");
    Eigen::Matrix<double, N, 1> v;
    for (int i = 0; i < N; ++i)
      v[i] = number(n[static_cast<std::size_t>(i)], key + "[" + std::to_string(i) + "]");
    return v;
  }
  /// Throws for keys of `map` not in `allowed` (catches typos).
  void onlyKeys(const YAML::Node& map, const std::string& prefix,
                std::initializer_list<const char*> allowed) const {
    if (!map.IsMap()) fail(prefix, map, "expected a mapping");
    for (const auto& kv : map) {
      const std::string k = kv.first.as<std::string>();
      bool ok = false;
      for (const char* a : allowed) ok = ok || k == a;
      if (!ok) {
        std::string list;
        for (const char* a : allowed) list += std::string(list.empty() ? "" : ", ") + a;
        fail(prefix.empty() ? k : prefix + "." + k, kv.first, "unknown key (expected one of: " + list + ")");
      }
    }
  }

 private:
  std::string file_;
};

std::string join(const std::string& a, const char* b) { return a.empty() ? b : a + "." + b; }

}  // namespace

SimSensorConfig defaultSimSensorConfig() {
  SimSensorConfig c;
  sim::PaperPayload::apply(c.cell);
  c.cell.full_rigid_body = true;
  return c;
}

void enableEffect(const std::string& name, SimSensorConfig& config) {
  sim::CellSimConfig& c = config.cell;
  if (name == "cable") {
    c.cable.enabled = true;
  } else if (name == "temperature_drift") {
    c.temperature_drift.enabled = true;
  } else if (name == "time_drift") {
    c.time_drift.enabled = true;
  } else if (name == "sensor_delay") {
    c.sensor_delay.enabled = true;
  } else if (name == "crosstalk") {
    c.crosstalk.enabled = true;
  } else if (name == "contact") {
    c.contact.enabled = true;
  } else if (name == "rigid_body") {
    c.full_rigid_body = true;
  } else if (name == "paper_only") {
    c.full_rigid_body = false;
  } else if (name == "noise") {
    // Typical sensor noise, about the resolution of paper Table 1.
    c.noise.wrench_std << 0.05, 0.05, 0.05, 0.005, 0.005, 0.005;
    c.noise.acc_std = 0.02;
    c.noise.gyro_std = 0.002;
    c.noise.alpha_std = 0.05;
    c.noise.temp_std = 0.02;
  } else {
    throw ConfigError("unknown effect '" + name +
                      "' (cable, temperature_drift, time_drift, sensor_delay, crosstalk, contact, "
                      "rigid_body, paper_only, noise)");
  }
}

void loadSimSensorYaml(const std::string& path, SimSensorConfig& config) {
  const YAML::Node root = loadYamlFileStrict(path, "sensor simulator config");
  if (root.IsNull()) return;
  const YamlReader r(path);
  r.onlyKeys(root, "", {"robot", "output", "payload", "offsets", "tilt_deg", "mount", "noise",
                        "seed", "full_rigid_body", "temperature", "effects", "faults", "duration_s"});
  sim::CellSimConfig& c = config.cell;
  if (const auto n = root["robot"]) {
    r.onlyKeys(n, "robot", {"host", "rtde_port", "rtde_frequency_hz", "urdf"});
    if (n["host"]) config.robot_host = r.text(n["host"], "robot.host");
    if (n["rtde_port"]) {
      const double p = r.number(n["rtde_port"], "robot.rtde_port");
      if (p < 1 || p > 65535 || p != std::floor(p)) r.fail("robot.rtde_port", n["rtde_port"], "must be 1..65535");
      config.rtde_port = static_cast<std::uint16_t>(p);
    }
    if (n["rtde_frequency_hz"]) config.rtde_frequency_hz = r.number(n["rtde_frequency_hz"], "robot.rtde_frequency_hz");
    if (n["urdf"]) config.urdf_path = resolveRelativeTo(path, r.text(n["urdf"], "robot.urdf"));
  }
  if (const auto n = root["output"]) {
    r.onlyKeys(n, "output", {"socket", "can_interface", "dbc", "rate_hz", "candump_log"});
    if (n["socket"]) config.socket_path = r.text(n["socket"], "output.socket");
    if (n["can_interface"]) config.can_interface = r.text(n["can_interface"], "output.can_interface");
    if (n["dbc"]) config.dbc_path = resolveRelativeTo(path, r.text(n["dbc"], "output.dbc"));
    if (n["candump_log"]) config.candump_log = r.text(n["candump_log"], "output.candump_log");
    if (n["rate_hz"]) {
      config.rate_hz = r.number(n["rate_hz"], "output.rate_hz");
      if (!(config.rate_hz > 0.0 && config.rate_hz <= 10000.0))
        r.fail("output.rate_hz", n["rate_hz"], "must be in (0, 10000]");
    }
  }
  if (root["duration_s"]) config.duration_s = r.number(root["duration_s"], "duration_s");
  if (const auto n = root["payload"]) {
    if (n.IsScalar()) {
      if (n.as<std::string>() != "paper") r.fail("payload", n, "expected 'paper' or a mapping");
      c.payload = sim::PaperPayload::payload();
    } else {
      r.onlyKeys(n, "payload", {"mass_kg", "com_m", "inertia_kgm2"});
      if (n["mass_kg"]) c.payload.mass_kg = r.number(n["mass_kg"], "payload.mass_kg");
      if (n["com_m"]) c.payload.p_SC_S = r.vec<3>(n["com_m"], "payload.com_m");
      if (n["inertia_kgm2"]) {
        // [ixx, iyy, izz, ixy, ixz, iyz] about the centre of mass, in S (docs/conventions.md).
        const Vec6 i = r.vec<6>(n["inertia_kgm2"], "payload.inertia_kgm2");
        c.payload.I_C_S << i[0], i[3], i[4], i[3], i[1], i[5], i[4], i[5], i[2];
      }
    }
  }
  if (const auto n = root["offsets"]) {
    r.onlyKeys(n, "offsets", {"f0_N", "t0_Nm"});
    if (n["f0_N"]) c.F0_N = r.vec<3>(n["f0_N"], "offsets.f0_N");
    if (n["t0_Nm"]) c.T0_Nm = r.vec<3>(n["t0_Nm"], "offsets.t0_Nm");
  }
  if (const auto n = root["tilt_deg"]) {
    const Eigen::Vector2d t = r.vec<2>(n, "tilt_deg");
    c.tilt_u_rad = t[0] * kDegToRad;
    c.tilt_v_rad = t[1] * kDegToRad;
  }
  if (const auto n = root["mount"]) {
    r.onlyKeys(n, "mount", {"rpy_deg", "xyz_m"});
    if (n["rpy_deg"]) {
      const Vec3 rpy = r.vec<3>(n["rpy_deg"], "mount.rpy_deg") * kDegToRad;
      c.R_FS = (Eigen::AngleAxisd(rpy[2], Vec3::UnitZ()) * Eigen::AngleAxisd(rpy[1], Vec3::UnitY()) *
                Eigen::AngleAxisd(rpy[0], Vec3::UnitX()))
                   .toRotationMatrix();
    }
    if (n["xyz_m"]) c.p_FS_F = r.vec<3>(n["xyz_m"], "mount.xyz_m");
  }
  if (const auto n = root["noise"]) {
    r.onlyKeys(n, "noise", {"wrench_std", "acc_std", "gyro_std", "alpha_std", "temp_std"});
    if (n["wrench_std"]) c.noise.wrench_std = r.vec<6>(n["wrench_std"], "noise.wrench_std");
    if (n["acc_std"]) c.noise.acc_std = r.number(n["acc_std"], "noise.acc_std");
    if (n["gyro_std"]) c.noise.gyro_std = r.number(n["gyro_std"], "noise.gyro_std");
    if (n["alpha_std"]) c.noise.alpha_std = r.number(n["alpha_std"], "noise.alpha_std");
    if (n["temp_std"]) c.noise.temp_std = r.number(n["temp_std"], "noise.temp_std");
  }
  if (root["seed"]) {
    const double s = r.number(root["seed"], "seed");
    if (s < 0 || s != std::floor(s)) r.fail("seed", root["seed"], "must be a non-negative integer");
    c.seed = static_cast<std::uint64_t>(s);
  }
  if (root["full_rigid_body"]) c.full_rigid_body = r.boolean(root["full_rigid_body"], "full_rigid_body");
  if (const auto n = root["temperature"]) {
    r.onlyKeys(n, "temperature", {"start_degC", "warmup_rise_degC", "warmup_tau_s",
                                  "sine_amplitude_degC", "sine_period_s"});
    auto& t = c.temperature;
    if (n["start_degC"]) t.start_degC = r.number(n["start_degC"], "temperature.start_degC");
    if (n["warmup_rise_degC"]) t.warmup_rise_degC = r.number(n["warmup_rise_degC"], "temperature.warmup_rise_degC");
    if (n["warmup_tau_s"]) t.warmup_tau_s = r.number(n["warmup_tau_s"], "temperature.warmup_tau_s");
    if (n["sine_amplitude_degC"]) t.sine_amplitude_degC = r.number(n["sine_amplitude_degC"], "temperature.sine_amplitude_degC");
    if (n["sine_period_s"]) t.sine_period_s = r.number(n["sine_period_s"], "temperature.sine_period_s");
  }
  if (const auto e = root["effects"]) {
    r.onlyKeys(e, "effects", {"cable", "temperature_drift", "time_drift", "sensor_delay", "crosstalk", "contact"});
    const auto enabled = [&](const YAML::Node& n, const std::string& key) {
      return n["enabled"] ? r.boolean(n["enabled"], key + ".enabled") : false;
    };
    if (const auto n = e["cable"]) {
      const std::string k = "effects.cable";
      r.onlyKeys(n, k, {"enabled", "stiffness_N_per_m", "attach_S_m", "anchor_B_m"});
      c.cable.enabled = enabled(n, k);
      if (n["stiffness_N_per_m"]) c.cable.stiffness_N_per_m = r.number(n["stiffness_N_per_m"], join(k, "stiffness_N_per_m"));
      if (n["attach_S_m"]) c.cable.p_SA_S = r.vec<3>(n["attach_S_m"], join(k, "attach_S_m"));
      if (n["anchor_B_m"]) c.cable.p_BA_B = r.vec<3>(n["anchor_B_m"], join(k, "anchor_B_m"));
    }
    if (const auto n = e["temperature_drift"]) {
      const std::string k = "effects.temperature_drift";
      r.onlyKeys(n, k, {"enabled", "reference_degC", "dF0_dT_N_per_degC", "dT0_dT_Nm_per_degC"});
      c.temperature_drift.enabled = enabled(n, k);
      if (n["reference_degC"]) c.temperature_drift.reference_degC = r.number(n["reference_degC"], join(k, "reference_degC"));
      if (n["dF0_dT_N_per_degC"]) c.temperature_drift.dF0_dT_N_per_degC = r.vec<3>(n["dF0_dT_N_per_degC"], join(k, "dF0_dT_N_per_degC"));
      if (n["dT0_dT_Nm_per_degC"]) c.temperature_drift.dT0_dT_Nm_per_degC = r.vec<3>(n["dT0_dT_Nm_per_degC"], join(k, "dT0_dT_Nm_per_degC"));
    }
    if (const auto n = e["time_drift"]) {
      const std::string k = "effects.time_drift";
      r.onlyKeys(n, k, {"enabled", "dF0_dt_N_per_s", "dT0_dt_Nm_per_s"});
      c.time_drift.enabled = enabled(n, k);
      if (n["dF0_dt_N_per_s"]) c.time_drift.dF0_dt_N_per_s = r.vec<3>(n["dF0_dt_N_per_s"], join(k, "dF0_dt_N_per_s"));
      if (n["dT0_dt_Nm_per_s"]) c.time_drift.dT0_dt_Nm_per_s = r.vec<3>(n["dT0_dt_Nm_per_s"], join(k, "dT0_dt_Nm_per_s"));
    }
    if (const auto n = e["sensor_delay"]) {
      const std::string k = "effects.sensor_delay";
      r.onlyKeys(n, k, {"enabled", "tau_s"});
      c.sensor_delay.enabled = enabled(n, k);
      if (n["tau_s"]) c.sensor_delay.tau_s = r.number(n["tau_s"], join(k, "tau_s"));
    }
    if (const auto n = e["crosstalk"]) {
      const std::string k = "effects.crosstalk";
      r.onlyKeys(n, k, {"enabled"});
      c.crosstalk.enabled = enabled(n, k);
    }
    if (const auto n = e["contact"]) {
      const std::string k = "effects.contact";
      r.onlyKeys(n, k, {"enabled", "t_start_s", "t_end_s", "force_B_N", "point_S_m"});
      c.contact.enabled = enabled(n, k);
      if (n["t_start_s"]) c.contact.t_start_s = r.number(n["t_start_s"], join(k, "t_start_s"));
      if (n["t_end_s"]) c.contact.t_end_s = r.number(n["t_end_s"], join(k, "t_end_s"));
      if (n["force_B_N"]) c.contact.force_B = r.vec<3>(n["force_B_N"], join(k, "force_B_N"));
      if (n["point_S_m"]) c.contact.p_SP_S = r.vec<3>(n["point_S_m"], join(k, "point_S_m"));
    }
  }
  if (const auto n = root["faults"]) {
    if (!n.IsSequence()) r.fail("faults", n, "expected a list of {at_s, kind, count}");
    for (std::size_t i = 0; i < n.size(); ++i) {
      const std::string k = "faults[" + std::to_string(i) + "]";
      r.onlyKeys(n[i], k, {"at_s", "kind", "count"});
      ScheduledSensorFault f;
      if (!n[i]["at_s"] || !n[i]["kind"]) r.fail(k, n[i], "needs at_s and kind");
      f.at_s = r.number(n[i]["at_s"], k + ".at_s");
      try {
        f.kind = parseSensorFault(r.text(n[i]["kind"], k + ".kind"));
      } catch (const ConfigError& e) {
        r.fail(k + ".kind", n[i]["kind"], e.what());
      }
      if (n[i]["count"]) {
        const double cnt = r.number(n[i]["count"], k + ".count");
        if (cnt < 1 || cnt > 1e7 || cnt != std::floor(cnt)) r.fail(k + ".count", n[i]["count"], "must be a positive integer");
        f.count = static_cast<int>(cnt);
      }
      config.faults.push_back(f);
    }
  }
}

}  // namespace ftid::simsensor
