// sim-sensor configuration: defaults, YAML (config/sim_sensor.yaml) and --effect names.
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "ftid/fileio/yaml_reader.hpp"
#include "ftid/common/default_files.hpp"
#include "ftid/common/error.hpp"
#include "ftid/sim/effect_spec.hpp"
#include "ftid/simsensor/sim_sensor.hpp"

namespace ftid::simsensor {

namespace {

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

/// robot: the robot simulator to follow (its RTDE address and URDF, relative to the file).
void readRobot(const YamlValue& n, const std::string& path, SimSensorConfig& config) {
  n.onlyKeys({"host", "rtde_port", "rtde_frequency_hz", "urdf"});
  if (n["host"]) config.robot_host = n["host"].text();
  if (n["rtde_port"]) config.rtde_port = static_cast<std::uint16_t>(n["rtde_port"].integer(1, 65535, "must be 1..65535"));
  config.rtde_frequency_hz = n["rtde_frequency_hz"].numberOr(config.rtde_frequency_hz);
  if (n["urdf"]) config.urdf_path = resolveRelativeTo(path, n["urdf"].text());
}

/// output: where the frames go (socket, CAN interface, candump log) and at what rate.
void readOutput(const YamlValue& n, const std::string& path, SimSensorConfig& config) {
  n.onlyKeys({"socket", "can_interface", "dbc", "rate_hz", "candump_log"});
  config.socket_path = n["socket"].textOr(config.socket_path);
  config.can_interface = n["can_interface"].textOr(config.can_interface);
  if (n["dbc"]) config.dbc_path = resolveRelativeTo(path, n["dbc"].text());
  config.candump_log = n["candump_log"].textOr(config.candump_log);
  config.rate_hz = n["rate_hz"].numberOr(config.rate_hz, {0.0, 10000.0, true, false, "must be in (0, 10000]"});
}

/// payload: `paper` or its mass, centre of mass and inertia.
void readPayload(const YamlValue& n, sim::CellSimConfig& c) {
  if (n.isScalar()) {
    if (n.text() != "paper") n.fail("expected 'paper' or a mapping");
    c.payload = sim::PaperPayload::payload();
    return;
  }
  n.onlyKeys({"mass_kg", "com_m", "inertia_kgm2"});
  c.payload.mass_kg = n["mass_kg"].numberOr(c.payload.mass_kg);
  if (n["com_m"]) c.payload.p_SC_S = n["com_m"].vector<3>();
  if (n["inertia_kgm2"]) {
    // [ixx, iyy, izz, ixy, ixz, iyz] about the centre of mass, in S (docs/conventions.md).
    const Vec6 i = n["inertia_kgm2"].vector<6>();
    c.payload.I_C_S << i[0], i[3], i[4], i[3], i[1], i[5], i[4], i[5], i[2];
  }
}

/// mount: the sensor's rotation and position on the flange.
void readMount(const YamlValue& n, sim::CellSimConfig& c) {
  n.onlyKeys({"rpy_deg", "xyz_m"});
  if (n["rpy_deg"]) {
    const Vec3 rpy = n["rpy_deg"].vector<3>() * kDegToRad;
    c.R_FS = (Eigen::AngleAxisd(rpy[2], Vec3::UnitZ()) * Eigen::AngleAxisd(rpy[1], Vec3::UnitY()) *
              Eigen::AngleAxisd(rpy[0], Vec3::UnitX()))
                 .toRotationMatrix();
  }
  if (n["xyz_m"]) c.p_FS_F = n["xyz_m"].vector<3>();
}

/// noise: the standard deviations of the wrench, IMU and temperature noise.
void readNoise(const YamlValue& n, sim::CellSimConfig& c) {
  n.onlyKeys({"wrench_std", "acc_std", "gyro_std", "alpha_std", "temp_std"});
  if (n["wrench_std"]) c.noise.wrench_std = n["wrench_std"].vector<6>();
  c.noise.acc_std = n["acc_std"].numberOr(c.noise.acc_std);
  c.noise.gyro_std = n["gyro_std"].numberOr(c.noise.gyro_std);
  c.noise.alpha_std = n["alpha_std"].numberOr(c.noise.alpha_std);
  c.noise.temp_std = n["temp_std"].numberOr(c.noise.temp_std);
}

/// temperature: the sensor's temperature over time (warm-up and a slow sine).
void readTemperature(const YamlValue& n, sim::CellSimConfig& c) {
  n.onlyKeys({"start_degC", "warmup_rise_degC", "warmup_tau_s", "sine_amplitude_degC", "sine_period_s"});
  auto& t = c.temperature;
  t.start_degC = n["start_degC"].numberOr(t.start_degC);
  t.warmup_rise_degC = n["warmup_rise_degC"].numberOr(t.warmup_rise_degC);
  t.warmup_tau_s = n["warmup_tau_s"].numberOr(t.warmup_tau_s);
  t.sine_amplitude_degC = n["sine_amplitude_degC"].numberOr(t.sine_amplitude_degC);
  t.sine_period_s = n["sine_period_s"].numberOr(t.sine_period_s);
}

/// effects: the hidden effects, each off unless `enabled: true`.
void readEffects(const YamlValue& e, sim::CellSimConfig& c) {
  e.onlyKeys({"cable", "temperature_drift", "time_drift", "sensor_delay", "crosstalk", "contact"});
  if (const YamlValue n = e["cable"]) {
    n.onlyKeys({"enabled", "stiffness_N_per_m", "attach_S_m", "anchor_B_m"});
    c.cable.enabled = n["enabled"].booleanOr(false);
    c.cable.stiffness_N_per_m = n["stiffness_N_per_m"].numberOr(c.cable.stiffness_N_per_m);
    if (n["attach_S_m"]) c.cable.p_SA_S = n["attach_S_m"].vector<3>();
    if (n["anchor_B_m"]) c.cable.p_BA_B = n["anchor_B_m"].vector<3>();
  }
  if (const YamlValue n = e["temperature_drift"]) {
    auto& d = c.temperature_drift;
    n.onlyKeys({"enabled", "reference_degC", "dF0_dT_N_per_degC", "dT0_dT_Nm_per_degC"});
    d.enabled = n["enabled"].booleanOr(false);
    d.reference_degC = n["reference_degC"].numberOr(d.reference_degC);
    if (n["dF0_dT_N_per_degC"]) d.dF0_dT_N_per_degC = n["dF0_dT_N_per_degC"].vector<3>();
    if (n["dT0_dT_Nm_per_degC"]) d.dT0_dT_Nm_per_degC = n["dT0_dT_Nm_per_degC"].vector<3>();
  }
  if (const YamlValue n = e["time_drift"]) {
    n.onlyKeys({"enabled", "dF0_dt_N_per_s", "dT0_dt_Nm_per_s"});
    c.time_drift.enabled = n["enabled"].booleanOr(false);
    if (n["dF0_dt_N_per_s"]) c.time_drift.dF0_dt_N_per_s = n["dF0_dt_N_per_s"].vector<3>();
    if (n["dT0_dt_Nm_per_s"]) c.time_drift.dT0_dt_Nm_per_s = n["dT0_dt_Nm_per_s"].vector<3>();
  }
  if (const YamlValue n = e["sensor_delay"]) {
    n.onlyKeys({"enabled", "tau_s"});
    c.sensor_delay.enabled = n["enabled"].booleanOr(false);
    c.sensor_delay.tau_s = n["tau_s"].numberOr(c.sensor_delay.tau_s);
  }
  if (const YamlValue n = e["crosstalk"]) {
    n.onlyKeys({"enabled"});
    c.crosstalk.enabled = n["enabled"].booleanOr(false);
  }
  if (const YamlValue n = e["contact"]) {
    n.onlyKeys({"enabled", "t_start_s", "t_end_s", "force_B_N", "point_S_m"});
    c.contact.enabled = n["enabled"].booleanOr(false);
    c.contact.t_start_s = n["t_start_s"].numberOr(c.contact.t_start_s);
    c.contact.t_end_s = n["t_end_s"].numberOr(c.contact.t_end_s);
    if (n["force_B_N"]) c.contact.force_B = n["force_B_N"].vector<3>();
    if (n["point_S_m"]) c.contact.p_SP_S = n["point_S_m"].vector<3>();
  }
}

/// faults: the sensor faults scheduled at given times, appended to `faults`.
void readFaults(const YamlValue& n, std::vector<ScheduledSensorFault>& faults) {
  n.expectSequence("expected a list of {at_s, kind, count}");
  for (const YamlValue& item : n.elements()) {
    item.onlyKeys({"at_s", "kind", "count"});
    ScheduledSensorFault f;
    f.at_s = item.required("at_s").number();
    const YamlValue kind = item.required("kind");
    try {
      f.kind = parseSensorFault(kind.text());
    } catch (const ConfigError& e) {
      kind.fail(e.what());
    }
    if (const YamlValue count = item["count"]) {
      f.count = static_cast<int>(count.integer(1, 10000000, "must be a positive integer (at most 10000000)"));
    }
    faults.push_back(f);
  }
}

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
  } else if (name == "grasp" || name.rfind("grasp:", 0) == 0) {
    // An object grasped at t (default: never, until SIGRTMIN+2), the `ftid simulate` spec.
    const bool timed = name.find("t=") != std::string::npos;
    sim::applyEffectSpec(name, c);
    if (!timed) c.payload_change.enabled = false;  // the object is set; SIGRTMIN+2 grasps it
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
                      "rigid_body, paper_only, noise, grasp[:t=S,mass=KG,com=X/Y/Z,side=M])");
  }
}

void loadSimSensorYaml(const std::string& path, SimSensorConfig& config) {
  const YamlFile file = YamlFile::load(path, "sensor simulator config");
  const YamlValue root = file.root();
  if (root.isNull()) return;
  root.onlyKeys({"robot", "output", "payload", "offsets", "tilt_deg", "mount", "noise", "seed", "full_rigid_body",
                 "temperature", "effects", "faults", "duration_s"});
  sim::CellSimConfig& c = config.cell;
  if (const YamlValue n = root["robot"]) readRobot(n, path, config);
  if (const YamlValue n = root["output"]) readOutput(n, path, config);
  config.duration_s = root["duration_s"].numberOr(config.duration_s);
  if (const YamlValue n = root["payload"]) readPayload(n, c);
  if (const YamlValue n = root["offsets"]) {
    n.onlyKeys({"f0_N", "t0_Nm"});
    if (n["f0_N"]) c.F0_N = n["f0_N"].vector<3>();
    if (n["t0_Nm"]) c.T0_Nm = n["t0_Nm"].vector<3>();
  }
  if (const YamlValue n = root["tilt_deg"]) {
    const Eigen::Vector2d t = n.vector<2>();
    c.tilt_u_rad = t[0] * kDegToRad;
    c.tilt_v_rad = t[1] * kDegToRad;
  }
  if (const YamlValue n = root["mount"]) readMount(n, c);
  if (const YamlValue n = root["noise"]) readNoise(n, c);
  if (const YamlValue n = root["seed"]) {
    c.seed = static_cast<std::uint64_t>(n.integer(0, std::numeric_limits<std::int64_t>::max(), "must be a non-negative integer"));
  }
  c.full_rigid_body = root["full_rigid_body"].booleanOr(c.full_rigid_body);
  if (const YamlValue n = root["temperature"]) readTemperature(n, c);
  if (const YamlValue e = root["effects"]) readEffects(e, c);
  if (const YamlValue n = root["faults"]) readFaults(n, config.faults);
}

}  // namespace ftid::simsensor
