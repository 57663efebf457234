// Design constraints: URDF limits merged with config/design.yaml (tighter wins).
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <string>

#include "ftid/fileio/yaml_strict.hpp"
#include "ftid/common/error.hpp"
#include "ftid/design/designer.hpp"

namespace ftid::design {

namespace {

class Cfg {
 public:
  explicit Cfg(std::string path) : path_(std::move(path)) {}
  [[noreturn]] void fail(const std::string& key, const std::string& what) const {
    throw ConfigError(path_ + ": key '" + key + "': " + what);
  }
  double number(const YAML::Node& n, const std::string& key) const {
    if (!n.IsScalar()) fail(key, "expected a number");
    double v = 0.0;
    try {
      v = n.as<double>();
    } catch (const YAML::Exception&) {
      fail(key, "expected a number, got '" + n.Scalar() + "'");
    }
    if (!std::isfinite(v)) fail(key, "must be finite");
    return v;
  }
  std::vector<double> list(const YAML::Node& n, const std::string& key, std::size_t size) const {
    if (!n.IsSequence() || n.size() != size)
      fail(key, "expected a list of " + std::to_string(size) + " numbers");
    std::vector<double> v;
    for (std::size_t i = 0; i < size; ++i)
      v.push_back(number(n[i], key + "[" + std::to_string(i) + "]"));
    return v;
  }
  JointVector joints(const YAML::Node& n, const std::string& key) const {
    const auto v = list(n, key, kNumJoints);
    JointVector out;
    for (int i = 0; i < kNumJoints; ++i) out[i] = v[static_cast<std::size_t>(i)];
    return out;
  }
  Vec3 vec3(const YAML::Node& n, const std::string& key) const {
    const auto v = list(n, key, 3);
    return Vec3(v[0], v[1], v[2]);
  }
  void checkKeys(const YAML::Node& n, const std::string& prefix,
                 std::initializer_list<const char*> known) const {
    if (!n.IsMap()) fail(prefix.empty() ? "(top level)" : prefix, "expected a mapping");
    for (const auto& kv : n) {
      const std::string k = kv.first.as<std::string>();
      bool ok = false;
      for (const char* kn : known) ok = ok || k == kn;
      if (!ok) fail(prefix.empty() ? k : prefix + "." + k, "unknown key");
    }
  }

 private:
  std::string path_;
};

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
    const YAML::Node root = loadYamlFileStrict(config_path, "design configuration");
    Cfg cfg(config_path);
    if (!root.IsNull()) {
      cfg.checkKeys(root, "", {"limits", "workspace", "sensor_mount"});
      if (const auto l = root["limits"]) {
        cfg.checkKeys(
            l, "limits",
            {"position_lower", "position_upper", "max_excursion", "velocity", "acceleration"});
        if (l["position_lower"])
          c.position_lower =
              c.position_lower.cwiseMax(cfg.joints(l["position_lower"], "limits.position_lower"));
        if (l["position_upper"])
          c.position_upper =
              c.position_upper.cwiseMin(cfg.joints(l["position_upper"], "limits.position_upper"));
        if (l["max_excursion"]) excursion = cfg.joints(l["max_excursion"], "limits.max_excursion");
        if (l["velocity"])
          c.velocity = urdf.velocity.cwiseMin(cfg.joints(l["velocity"], "limits.velocity"));
        if (l["acceleration"])
          c.acceleration =
              urdf.acceleration.cwiseMin(cfg.joints(l["acceleration"], "limits.acceleration"));
        for (int i = 0; i < kNumJoints; ++i) {
          if (!(c.velocity[i] > 0.0)) cfg.fail("limits.velocity", "must be positive");
          if (!(c.acceleration[i] > 0.0)) cfg.fail("limits.acceleration", "must be positive");
          if (!(excursion[i] >= 0.0)) cfg.fail("limits.max_excursion", "must not be negative");
        }
      }
      if (const auto w = root["workspace"]) {
        cfg.checkKeys(w, "workspace", {"floor_z", "keep_out", "tool"});
        if (w["floor_z"]) c.floor_z_B = cfg.number(w["floor_z"], "workspace.floor_z");
        if (const auto ko = w["keep_out"]) {
          if (!ko.IsSequence() && !ko.IsNull()) cfg.fail("workspace.keep_out", "expected a list");
          c.keep_out.clear();
          for (std::size_t i = 0; ko.IsSequence() && i < ko.size(); ++i) {
            const std::string key = "workspace.keep_out[" + std::to_string(i) + "]";
            cfg.checkKeys(ko[i], key, {"name", "center", "radius"});
            trajectory::KeepOutSphere s;
            s.name = ko[i]["name"] ? ko[i]["name"].as<std::string>()
                                   : "keep_out[" + std::to_string(i) + "]";
            if (!ko[i]["center"]) cfg.fail(key + ".center", "missing");
            if (!ko[i]["radius"]) cfg.fail(key + ".radius", "missing");
            s.center_B = cfg.vec3(ko[i]["center"], key + ".center");
            s.radius = cfg.number(ko[i]["radius"], key + ".radius");
            if (s.radius < 0.0) cfg.fail(key + ".radius", "must not be negative");
            c.keep_out.push_back(s);
          }
        }
        if (const auto t = w["tool"]) {
          if (!t.IsSequence() && !t.IsNull()) cfg.fail("workspace.tool", "expected a list");
          c.tool.clear();
          for (std::size_t i = 0; t.IsSequence() && i < t.size(); ++i) {
            const std::string key = "workspace.tool[" + std::to_string(i) + "]";
            cfg.checkKeys(t[i], key, {"center", "radius"});
            if (!t[i]["center"]) cfg.fail(key + ".center", "missing");
            if (!t[i]["radius"]) cfg.fail(key + ".radius", "missing");
            trajectory::ToolSphere s;
            s.center_S = cfg.vec3(t[i]["center"], key + ".center");
            s.radius = cfg.number(t[i]["radius"], key + ".radius");
            if (s.radius < 0.0) cfg.fail(key + ".radius", "must not be negative");
            c.tool.push_back(s);
          }
        }
      }
      if (const auto m = root["sensor_mount"]) {
        cfg.checkKeys(m, "sensor_mount", {"xyz", "rpy"});
        if (m["xyz"]) c.p_FS_F = cfg.vec3(m["xyz"], "sensor_mount.xyz");
        if (m["rpy"]) {
          const Vec3 rpy = cfg.vec3(m["rpy"], "sensor_mount.rpy");
          c.R_FS = (Eigen::AngleAxisd(rpy.z(), Vec3::UnitZ()) *
                    Eigen::AngleAxisd(rpy.y(), Vec3::UnitY()) *
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
