// Design constraints: URDF limits merged with config/design.yaml (tighter wins).
#include <cmath>
#include <string>

#include "ftid/fileio/yaml_reader.hpp"
#include "ftid/common/error.hpp"
#include "ftid/design/designer.hpp"

namespace ftid::design {

namespace {

// Built-in defaults, identical to config/design.yaml (which documents them).
const JointVector kVelocity = (JointVector() << 1.0, 1.0, 1.5, 2.0, 2.0, 2.0).finished();
const JointVector kAcceleration = (JointVector() << 2.0, 2.0, 4.0, 6.0, 6.0, 6.0).finished();
const JointVector kExcursion = (JointVector() << 1.0, 1.0, 1.0, 3.1416, 3.1416, 3.1416).finished();

}  // namespace

trajectory::TrajectoryConstraints loadDesignConstraints(const std::string& config_path,
                                                        const model::RobotKinematics& kinematics,
                                                        const JointVector& q0) {
  trajectory::TrajectoryConstraints c;
  const auto& urdf = kinematics.limits();
  c.position_lower = urdf.lower;
  c.position_upper = urdf.upper;
  c.velocity = urdf.velocity.cwiseMin(kVelocity);
  c.acceleration = urdf.acceleration.cwiseMin(kAcceleration);
  JointVector excursion = kExcursion;
  c.floor_z_B = 0.0;
  c.keep_out = {{"robot_base", Vec3(0.0, 0.0, 0.1), 0.25},
                {"elbow", Vec3(0.0, 0.0, 0.7393), 0.10},
                {"forearm", Vec3(-0.30, 0.0, 0.7393), 0.08}};
  c.tool = {{Vec3(0.0, 0.0, 0.05), 0.08}};

  if (!config_path.empty()) {
    const YamlFile file = YamlFile::load(config_path, "design configuration");
    const YamlValue root = file.root();
    if (!root.isNull()) {
      root.onlyKeys({"limits", "workspace", "sensor_mount"});
      if (const YamlValue l = root["limits"]) {
        l.onlyKeys({"position_lower", "position_upper", "max_excursion", "velocity", "acceleration"});
        if (l["position_lower"]) c.position_lower = c.position_lower.cwiseMax(l["position_lower"].vector<kNumJoints>());
        if (l["position_upper"]) c.position_upper = c.position_upper.cwiseMin(l["position_upper"].vector<kNumJoints>());
        if (l["max_excursion"]) excursion = l["max_excursion"].vector<kNumJoints>();
        if (l["velocity"]) c.velocity = urdf.velocity.cwiseMin(l["velocity"].vector<kNumJoints>());
        if (l["acceleration"]) c.acceleration = urdf.acceleration.cwiseMin(l["acceleration"].vector<kNumJoints>());
        // After merging with the URDF (a limit the URDF makes non-positive is named with the key).
        for (int i = 0; i < kNumJoints; ++i) {
          if (!(c.velocity[i] > 0.0)) l["velocity"].fail("must be positive");
          if (!(c.acceleration[i] > 0.0)) l["acceleration"].fail("must be positive");
          if (!(excursion[i] >= 0.0)) l["max_excursion"].fail("must not be negative");
        }
      }
      if (const YamlValue w = root["workspace"]) {
        w.onlyKeys({"floor_z", "keep_out", "tool"});
        c.floor_z_B = w["floor_z"].numberOr(c.floor_z_B);
        if (const YamlValue ko = w["keep_out"]) {  // an empty `keep_out:` clears the defaults
          if (!ko.isNull()) ko.expectSequence();
          c.keep_out.clear();
          for (std::size_t i = 0; i < ko.size(); ++i) {
            const YamlValue item = ko.at(i);
            item.onlyKeys({"name", "center", "radius"});
            trajectory::KeepOutSphere s;
            s.name = item["name"].textOr("keep_out[" + std::to_string(i) + "]");
            s.center_B = item.required("center").vector<3>();
            s.radius = item.required("radius").number(NumberRange::nonNegative("must not be negative"));
            c.keep_out.push_back(s);
          }
        }
        if (const YamlValue t = w["tool"]) {  // an empty `tool:` clears the defaults
          if (!t.isNull()) t.expectSequence();
          c.tool.clear();
          for (std::size_t i = 0; i < t.size(); ++i) {
            const YamlValue item = t.at(i);
            item.onlyKeys({"center", "radius"});
            trajectory::ToolSphere s;
            s.center_S = item.required("center").vector<3>();
            s.radius = item.required("radius").number(NumberRange::nonNegative("must not be negative"));
            c.tool.push_back(s);
          }
        }
      }
      if (const YamlValue m = root["sensor_mount"]) {
        m.onlyKeys({"xyz", "rpy"});
        if (m["xyz"]) c.p_FS_F = m["xyz"].vector<3>();
        if (m["rpy"]) {
          const Vec3 rpy = m["rpy"].vector<3>();
          c.R_FS = (Eigen::AngleAxisd(rpy.z(), Vec3::UnitZ()) * Eigen::AngleAxisd(rpy.y(), Vec3::UnitY()) *
                    Eigen::AngleAxisd(rpy.x(), Vec3::UnitX()))
                       .toRotationMatrix();
        }
      }
    }
  }
  // Excursion about q0 tightens the absolute limits.
  c.position_lower = c.position_lower.cwiseMax(q0 - excursion);
  c.position_upper = c.position_upper.cwiseMin(q0 + excursion);
  return c;
}

}  // namespace ftid::design
