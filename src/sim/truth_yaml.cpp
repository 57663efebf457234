// The truth of a simulated run as YAML (parameter names of docs/conventions.md).
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cstring>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "ftid/common/error.hpp"
#include "ftid/fileio/atomic_file.hpp"
#include "ftid/fileio/yaml_emit.hpp"
#include "ftid/sim/cell_sim.hpp"

namespace ftid::sim {

namespace {

using Num = YamlNumber;  // the output policy of every YAML file (ftid/fileio/yaml_emit.hpp)

void vec3(YAML::Emitter& e, const char* key, const Vec3& v) {
  e << YAML::Key << key << YAML::Value << YAML::Flow << YAML::BeginSeq << Num{v.x()} << Num{v.y()} << Num{v.z()} << YAML::EndSeq;
}

}  // namespace

std::string truthYaml(const CellSimConfig& c) {
  YAML::Emitter e;
  e << YAML::Comment("Truth of a simulated ftid run (docs/simulator.md; names: docs/conventions.md)");
  e << YAML::BeginMap;
  e << YAML::Key << "parameters" << YAML::Value << YAML::BeginMap;
  const PayloadTruth& p = c.payload;
  e << YAML::Key << "mass" << YAML::Value << Num{p.mass_kg};
  e << YAML::Key << "weight" << YAML::Value << Num{p.mass_kg * kStandardGravity};
  e << YAML::Key << "com_x" << YAML::Value << Num{p.p_SC_S.x()};
  e << YAML::Key << "com_y" << YAML::Value << Num{p.p_SC_S.y()};
  e << YAML::Key << "com_z" << YAML::Value << Num{p.p_SC_S.z()};
  e << YAML::Key << "f0_x" << YAML::Value << Num{c.F0_N.x()};
  e << YAML::Key << "f0_y" << YAML::Value << Num{c.F0_N.y()};
  e << YAML::Key << "f0_z" << YAML::Value << Num{c.F0_N.z()};
  e << YAML::Key << "t0_x" << YAML::Value << Num{c.T0_Nm.x()};
  e << YAML::Key << "t0_y" << YAML::Value << Num{c.T0_Nm.y()};
  e << YAML::Key << "t0_z" << YAML::Value << Num{c.T0_Nm.z()};
  e << YAML::Key << "tilt_u" << YAML::Value << Num{c.tilt_u_rad};
  e << YAML::Key << "tilt_v" << YAML::Value << Num{c.tilt_v_rad};
  e << YAML::Key << "inertia" << YAML::Value << YAML::Flow << YAML::BeginSeq << Num{p.I_C_S(0, 0)} << Num{p.I_C_S(1, 1)}
    << Num{p.I_C_S(2, 2)} << Num{p.I_C_S(0, 1)} << Num{p.I_C_S(0, 2)} << Num{p.I_C_S(1, 2)} << YAML::EndSeq;
  e << YAML::EndMap;
  e << YAML::Key << "full_rigid_body" << YAML::Value << c.full_rigid_body;
  e << YAML::Key << "sensor_mount" << YAML::Value << YAML::BeginMap;
  e << YAML::Key << "R_FS" << YAML::Value << YAML::Flow << YAML::BeginSeq;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) e << Num{c.R_FS(i, j)};
  e << YAML::EndSeq;
  vec3(e, "p_FS_F", c.p_FS_F);
  e << YAML::EndMap;
  e << YAML::Key << "effects" << YAML::Value << YAML::BeginMap;
  e << YAML::Key << "cable" << YAML::Value << YAML::BeginMap << YAML::Key << "enabled" << YAML::Value
    << c.cable.enabled << YAML::Key << "stiffness" << YAML::Value << Num{c.cable.stiffness_N_per_m};
  vec3(e, "attach_S", c.cable.p_SA_S);
  vec3(e, "anchor_B", c.cable.p_BA_B);
  e << YAML::EndMap;
  e << YAML::Key << "temperature_drift" << YAML::Value << YAML::BeginMap << YAML::Key << "enabled" << YAML::Value
    << c.temperature_drift.enabled << YAML::Key << "reference_temp" << YAML::Value
    << Num{c.temperature_drift.reference_degC};
  vec3(e, "df0_dtemp", c.temperature_drift.dF0_dT_N_per_degC);
  vec3(e, "dt0_dtemp", c.temperature_drift.dT0_dT_Nm_per_degC);
  e << YAML::EndMap;
  e << YAML::Key << "time_drift" << YAML::Value << YAML::BeginMap << YAML::Key << "enabled" << YAML::Value
    << c.time_drift.enabled;
  vec3(e, "df0_dt", c.time_drift.dF0_dt_N_per_s);
  vec3(e, "dt0_dt", c.time_drift.dT0_dt_Nm_per_s);
  e << YAML::EndMap;
  e << YAML::Key << "sensor_delay" << YAML::Value << YAML::BeginMap << YAML::Key << "enabled" << YAML::Value
    << c.sensor_delay.enabled << YAML::Key << "tau" << YAML::Value << Num{c.sensor_delay.tau_s} << YAML::EndMap;
  e << YAML::Key << "crosstalk" << YAML::Value << YAML::BeginMap << YAML::Key << "enabled" << YAML::Value
    << c.crosstalk.enabled << YAML::Key << "E" << YAML::Value << YAML::BeginSeq;
  for (int i = 0; i < 6; ++i) {
    e << YAML::Flow << YAML::BeginSeq;
    for (int j = 0; j < 6; ++j) e << Num{c.crosstalk.E(i, j)};
    e << YAML::EndSeq;
  }
  e << YAML::EndSeq << YAML::EndMap;
  e << YAML::Key << "contact" << YAML::Value << YAML::BeginMap << YAML::Key << "enabled" << YAML::Value
    << c.contact.enabled << YAML::Key << "t_start" << YAML::Value << Num{c.contact.t_start_s} << YAML::Key << "t_end"
    << YAML::Value << Num{c.contact.t_end_s};
  vec3(e, "force_B", c.contact.force_B);
  vec3(e, "point_S", c.contact.p_SP_S);
  e << YAML::EndMap;
  e << YAML::Key << "glitches" << YAML::Value << YAML::BeginMap << YAML::Key << "enabled" << YAML::Value
    << c.glitches.enabled << YAML::Key << "probability" << YAML::Value << Num{c.glitches.probability} << YAML::Key
    << "force" << YAML::Value << Num{c.glitches.force_N} << YAML::Key << "torque" << YAML::Value
    << Num{c.glitches.torque_Nm} << YAML::EndMap;
  e << YAML::Key << "mounting" << YAML::Value << YAML::BeginMap << YAML::Key << "enabled" << YAML::Value
    << c.mounting.enabled;
  vec3(e, "roll_pitch_yaw", c.mounting.rpy_rad);
  e << YAML::Key << "rotate_imu" << YAML::Value << c.mounting.rotate_imu << YAML::EndMap;
  e << YAML::Key << "imu" << YAML::Value << YAML::BeginMap << YAML::Key << "enabled" << YAML::Value
    << c.imu.enabled;
  vec3(e, "acc_bias", c.imu.acc_bias_mps2);
  vec3(e, "gyro_bias", c.imu.gyro_bias_radps);
  e << YAML::Key << "delay" << YAML::Value << Num{c.imu.delay_s} << YAML::EndMap;
  e << YAML::Key << "static_poses" << YAML::Value << YAML::BeginMap << YAML::Key << "enabled" << YAML::Value
    << c.static_poses.enabled << YAML::Key << "poses" << YAML::Value << c.static_poses.poses << YAML::Key << "hold"
    << YAML::Value << Num{c.static_poses.hold_s} << YAML::Key << "average" << YAML::Value << c.static_poses.average
    << YAML::EndMap;
  e << YAML::EndMap;  // effects
  e << YAML::Key << "noise" << YAML::Value << YAML::BeginMap;
  e << YAML::Key << "wrench_std" << YAML::Value << YAML::Flow << YAML::BeginSeq;
  for (int i = 0; i < 6; ++i) e << Num{c.noise.wrench_std[i]};
  e << YAML::EndSeq;
  e << YAML::Key << "acc_std" << YAML::Value << Num{c.noise.acc_std};
  e << YAML::Key << "gyro_std" << YAML::Value << Num{c.noise.gyro_std};
  e << YAML::Key << "alpha_std" << YAML::Value << Num{c.noise.alpha_std};
  e << YAML::Key << "temp_std" << YAML::Value << Num{c.noise.temp_std};
  e << YAML::Key << "wrench_lowpass_hz" << YAML::Value << Num{c.noise.wrench_lowpass_hz};
  e << YAML::Key << "wrench_oversample" << YAML::Value << c.noise.wrench_oversample;
  e << YAML::EndMap;
  e << YAML::Key << "temperature_profile" << YAML::Value << YAML::BeginMap;
  e << YAML::Key << "custom" << YAML::Value << static_cast<bool>(c.temperature.custom);
  e << YAML::Key << "start" << YAML::Value << Num{c.temperature.start_degC};
  e << YAML::Key << "warmup_rise" << YAML::Value << Num{c.temperature.warmup_rise_degC};
  e << YAML::Key << "warmup_tau" << YAML::Value << Num{c.temperature.warmup_tau_s};
  e << YAML::Key << "sine_amplitude" << YAML::Value << Num{c.temperature.sine_amplitude_degC};
  e << YAML::Key << "sine_period" << YAML::Value << Num{c.temperature.sine_period_s};
  e << YAML::EndMap;
  e << YAML::Key << "seed" << YAML::Value << c.seed;
  e << YAML::Key << "rate" << YAML::Value << Num{c.rate_hz};
  e << YAML::Key << "duration" << YAML::Value << Num{c.duration_s};
  e << YAML::EndMap;
  return std::string(e.c_str()) + "\n";
}

void writeTruthYaml(const std::string& path, const CellSimConfig& config) {
  writeFileAtomically(path, truthYaml(config));  // ftid/fileio/atomic_file.hpp
}

}  // namespace ftid::sim
