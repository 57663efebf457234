#pragma once
// Exports of an identified payload for tools users already have (docs/operations.md):
//  - UR `set_target_payload(mass, cog, inertia)`: centre of gravity in the tool flange frame F
//    (tool0, zero TCP offset) [m]; inertia about the centre of gravity in F, in UR's order
//    [Ixx, Iyy, Izz, Ixy, Ixz, Iyz] [kg m^2].
//  - ros2_control control_toolbox GravityCompensation filter parameters: tool.mass, tool.pos
//    (centre of mass in the sensor frame S) and tool.gravity_field (gravity in the robot base B,
//    which includes the identified tilt: g_B = R_WB^T g_W, docs/conventions.md).
#include <optional>
#include <string>

#include "ftid/common/types.hpp"
#include "ftid/identify/parameter_set.hpp"

namespace ftid::cell {

struct PayloadExport {
  double mass = 0.0;                ///< [kg]
  Vec3 com_S = Vec3::Zero();        ///< p_SC_S [m]
  Vec3 cog_F = Vec3::Zero();        ///< p_FC_F = p_FS_F + R_FS p_SC_S [m]
  std::optional<Mat3> inertia_C_F;  ///< I_C expressed in F (if the model identified it)
  Vec3 gravity_B = Vec3::Zero();    ///< [m/s^2]
  Vec3 f0_S = Vec3::Zero();         ///< offsets (not representable in either target; documented)
  Vec3 t0_S = Vec3::Zero();
};

/// Builds the export from a parameter set and the sensor mount X_FS. Throws ConfigError naming
/// the missing parameter if the set has no mass / centre of mass.
PayloadExport makePayloadExport(const identify::ParameterSet& set, const Mat3& R_FS, const Vec3& p_FS_F);

/// A URScript line: `set_target_payload(m, [cx, cy, cz], [Ixx, Iyy, Izz, Ixy, Ixz, Iyz])`.
std::string urScriptPayload(const PayloadExport& e);
/// YAML for the control_toolbox GravityCompensation filter (ros__parameters), with comments.
std::string ros2GravityCompensationYaml(const PayloadExport& e, const std::string& node_name = "gravity_compensation",
                                        const std::string& world_frame = "base",
                                        const std::string& sensor_frame = "ft_sensor");

}  // namespace ftid::cell
