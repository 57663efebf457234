#pragma once
// Exports of an identified payload for tools users already have (docs/operations.md "Exports"):
//  - UR `set_target_payload(mass, cog, inertia)` for everything beyond the flange: the identified
//    payload plus the parts between the flange and the sensor's measuring side that the sensor
//    cannot weigh (adapter, sensor body; from ftidd.yaml `export:`). Centre of gravity in the tool
//    flange frame F (tool0, zero TCP offset) [m]; inertia about the combined centre of gravity,
//    axes of F, UR's order [Ixx, Iyy, Izz, Ixy, Ixz, Iyz] [kg m^2].
//  - ros2_control: a force_torque_sensor_broadcaster parameter file whose sensor_filter_chain has
//    one control_filters/GravityCompensationWrench filter (control_toolbox keys world_frame,
//    sensor_frame, tool.CoG, tool.mass, tool.gravity_field) and whose offset.force / offset.torque
//    keys remove the sensor offsets. The broadcaster ADDS its offsets to the reading, so they are
//    the negated identified offsets: offset = -F0, -T0.
#include <optional>
#include <string>
#include <vector>

#include "ftid/common/types.hpp"
#include "ftid/params/parameter_set.hpp"

namespace ftid::config {
struct DaemonConfig;
}

namespace ftid::cell {

struct PayloadExport {
  double mass = 0.0;                ///< [kg]
  Vec3 com_S = Vec3::Zero();        ///< p_SC_S [m]
  Vec3 cog_F = Vec3::Zero();        ///< p_FC_F = p_FS_F + R_FS p_SC_S [m]
  std::optional<Mat3> inertia_C_F;  ///< I_C expressed in F (if the model identified it)
  Vec3 gravity_B = Vec3::Zero();    ///< [m/s^2]
  Vec3 f0_S = Vec3::Zero();         ///< identified offsets (docs/conventions.md)
  Vec3 t0_S = Vec3::Zero();
  std::string model;                ///< the parameter set's model name (for the file comments)
};

/// Builds the export from a parameter set and the sensor mount X_FS. Throws ConfigError naming
/// the missing parameter if the set has no mass / centre of mass.
PayloadExport makePayloadExport(const params::ParameterSet& set, const Mat3& R_FS, const Vec3& p_FS_F);

/// A rigid body beyond the flange (adapter plate, sensor body), all in F.
struct RigidPart {
  std::string name;
  double mass = 0.0;                  ///< [kg]
  Vec3 com_F = Vec3::Zero();          ///< centre of mass in F [m]
  Mat3 inertia_C_F = Mat3::Zero();    ///< about its own centre of mass, axes of F [kg m^2]
};

/// Everything beyond the flange as one rigid body (what UR's set_target_payload wants).
struct UrPayload {
  double mass = 0.0;                ///< [kg]
  Vec3 cog_F = Vec3::Zero();        ///< combined centre of gravity in F [m]
  std::optional<Mat3> inertia_F;    ///< about cog_F, axes of F; none = let the controller estimate
  bool payload_point_mass = false;  ///< the identified payload's inertia was unknown (taken as 0)
};

/// Combines the payload with the parts: m = sum m_i, c = sum m_i c_i / m,
/// I = sum (I_i + m_i (|d_i|^2 1 - d_i d_i^T)), d_i = c_i - c (parallel-axis theorem). Parts of
/// mass 0 are ignored. The inertia is omitted only if the payload's is unknown and there are no
/// parts. Throws ConfigError if the total mass is not positive.
UrPayload combineBeyondFlange(const PayloadExport& payload, const std::vector<RigidPart>& parts);

/// A URScript line: `set_target_payload(m, [cx, cy, cz], [Ixx, Iyy, Izz, Ixy, Ixz, Iyz])`.
std::string urScriptPayload(const UrPayload& p);
/// The whole URScript export file (comments with what went into it, and the line).
std::string urScriptFile(const PayloadExport& e, const std::vector<RigidPart>& parts);

/// Names used in the ROS 2 file.
struct Ros2Names {
  std::string controller = "force_torque_sensor_broadcaster";  ///< top-level node name
  std::string world_frame = "base";        ///< TF frame of the robot base B
  std::string sensor_frame = "ft_sensor";  ///< TF frame of the sensor frame S
  std::string sensor_name = "ft_sensor";   ///< broadcaster sensor_name
};

/// YAML for force_torque_sensor_broadcaster (ros__parameters) with the GravityCompensationWrench
/// filter and the offsets, with comments stating frames and signs.
std::string ros2BroadcasterYaml(const PayloadExport& e, const Ros2Names& names = {});

/// The parts and names from an ftidd configuration (`export:` section).
std::vector<RigidPart> partsFromConfig(const config::DaemonConfig& cfg);
Ros2Names ros2NamesFromConfig(const config::DaemonConfig& cfg);

/// Writes the exports atomically: the ROS 2 file to `ros2_path` and the URScript file to
/// `urscript_path` (either may be empty = not written), using the config's sensor mount, parts
/// and names. Returns one line naming what was written. Throws on bad parameters or I/O errors.
std::string writeExports(const params::ParameterSet& set, const config::DaemonConfig& cfg,
                         const std::string& ros2_path, const std::string& urscript_path);

/// The configuration the exports use when none is given: /etc/ftid/ftidd.yaml (the live ftidd
/// config) if it exists, else the shipped ftidd.yaml (the one default-file lookup).
std::string defaultExportConfigPath();


}  // namespace ftid::cell
