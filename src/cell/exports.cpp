#include "ftid/cell/exports.hpp"

#include <cstdio>
#include <filesystem>
#include <sstream>

#include "ftid/common/default_files.hpp"
#include "ftid/common/error.hpp"
#include "ftid/fileio/atomic_file.hpp"
#include "ftid/config/daemon_config.hpp"
#include "ftid/effects/model.hpp"
#include "ftid/fileio/atomic_file.hpp"
#include "ftid/fileio/yaml_emit.hpp"
#include "ftid/model/frames.hpp"

namespace ftid::cell {

namespace {
double need(const params::ParameterSet& set, const std::string& name) {
  const params::NamedValue* v = set.find(name);
  if (!v) throw ConfigError("parameter set (model '" + set.model + "') has no '" + name + "'");
  return v->value;
}
std::string num(double x) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.9g", x);
  return buf;
}
std::string vec(const Vec3& v) { return "[" + num(v.x()) + ", " + num(v.y()) + ", " + num(v.z()) + "]"; }
std::string urOrder(const Mat3& I) {
  return "[" + num(I(0, 0)) + ", " + num(I(1, 1)) + ", " + num(I(2, 2)) + ", " + num(I(0, 1)) + ", " +
         num(I(0, 2)) + ", " + num(I(1, 2)) + "]";
}
Mat3 fromUrOrder(const Vec6& v) {
  Mat3 I;
  I << v(0), v(3), v(4), v(3), v(1), v(5), v(4), v(5), v(2);
  return I;
}

/// Notes on what a fixed-payload export cannot carry: a payload that moves with a signal, and a
/// tilt that absorbs an effect's uniform pull (Effect::foldsIntoTilt, the cable). "" when none.
std::string modelNotes(const std::string& model) {
  std::string moving, absorbers;
  try {
    const effects::Model m = effects::Model::fromName(model);
    for (const auto& e : m.effectList()) {
      if (e->name().rfind("payload(", 0) == 0) moving += (moving.empty() ? "" : ", ") + e->name();
    }
    absorbers = m.tiltAbsorbers();
  } catch (const ConfigError&) {
    return "";  // not a model this build knows: nothing to say about it
  }
  std::string out;
  if (!moving.empty()) {
    out += "# NOTE: the model's payload moves with a signal (" + moving +
           "): this export is the payload at the signal's reference value (0 unless given) only;\n"
           "#       a fixed payload cannot follow it (compensate with `ftid compensate`).\n";
  }
  if (!absorbers.empty()) {
    out += "# NOTE: the model's tilt is an APPARENT tilt (" + absorbers +
           "): the uniform horizontal pull is folded into it and part of\n"
           "#       the vertical pull may be in the mass (docs/effects.md). The gravity direction and mass below\n"
           "#       reproduce that pull only near the identification's poses, and the mass is not the tool's\n"
           "#       weight alone; compensate with ftidd, which models the pull.\n";
  }
  return out;
}

/// Inertia of a point mass m at offset d about the reference point: m (|d|^2 1 - d d^T).
Mat3 parallelAxis(double m, const Vec3& d) { return m * (d.squaredNorm() * Mat3::Identity() - d * d.transpose()); }
}  // namespace

PayloadExport makePayloadExport(const params::ParameterSet& set, const Mat3& R_FS, const Vec3& p_FS_F) {
  PayloadExport e;
  e.model = set.model;
  e.mass = need(set, "mass");
  e.com_S = Vec3(need(set, "com_x"), need(set, "com_y"), need(set, "com_z"));
  e.cog_F = p_FS_F + R_FS * e.com_S;
  if (set.find("i_c_xx")) {
    Mat3 I_C;
    const double ixx = need(set, "i_c_xx"), iyy = need(set, "i_c_yy"), izz = need(set, "i_c_zz");
    const double ixy = need(set, "i_c_xy"), ixz = need(set, "i_c_xz"), iyz = need(set, "i_c_yz");
    I_C << ixx, ixy, ixz, ixy, iyy, iyz, ixz, iyz, izz;
    e.inertia_C_F = R_FS * I_C * R_FS.transpose();
  } else if (set.find("i_s_xx")) {
    // The fit's linear parameters are the inertia about the S origin (docs/conventions.md):
    // I_C = I_S - m (|c|^2 1 - c c^T).
    Mat3 I_S;
    const double ixx = need(set, "i_s_xx"), iyy = need(set, "i_s_yy"), izz = need(set, "i_s_zz");
    const double ixy = need(set, "i_s_xy"), ixz = need(set, "i_s_xz"), iyz = need(set, "i_s_yz");
    I_S << ixx, ixy, ixz, ixy, iyy, iyz, ixz, iyz, izz;
    const Mat3 I_C = I_S - parallelAxis(e.mass, e.com_S);
    e.inertia_C_F = R_FS * I_C * R_FS.transpose();
  }
  e.gravity_B = model::gravityInBase(set.tilt_u_rad, set.tilt_v_rad);
  for (int i = 0; i < 3; ++i) {
    const char* ax = i == 0 ? "x" : (i == 1 ? "y" : "z");
    if (const auto* f = set.find(std::string("f0_") + ax)) e.f0_S(i) = f->value;
    if (const auto* t = set.find(std::string("t0_") + ax)) e.t0_S(i) = t->value;
  }
  return e;
}

UrPayload combineBeyondFlange(const PayloadExport& payload, const std::vector<RigidPart>& parts) {
  struct Body {
    double m;
    Vec3 c;
    Mat3 I;
  };
  std::vector<Body> bodies{{payload.mass, payload.cog_F, payload.inertia_C_F.value_or(Mat3::Zero())}};
  for (const auto& p : parts) {
    if (p.mass > 0.0) bodies.push_back({p.mass, p.com_F, p.inertia_C_F});
  }
  UrPayload u;
  Vec3 first_moment = Vec3::Zero();
  for (const auto& b : bodies) {
    u.mass += b.m;
    first_moment += b.m * b.c;
  }
  if (!(u.mass > 0.0)) throw ConfigError("UR payload export: the total mass beyond the flange is not positive");
  u.cog_F = first_moment / u.mass;
  u.payload_point_mass = !payload.inertia_C_F.has_value();
  if (payload.inertia_C_F || bodies.size() > 1) {
    Mat3 I = Mat3::Zero();
    for (const auto& b : bodies) I += b.I + parallelAxis(b.m, b.c - u.cog_F);
    u.inertia_F = I;
  }
  return u;
}

std::string urScriptPayload(const UrPayload& p) {
  std::ostringstream o;
  o << "set_target_payload(" << num(p.mass) << ", " << vec(p.cog_F);
  if (p.inertia_F) o << ", " << urOrder(*p.inertia_F);
  o << ")";
  return o.str();
}

std::string urScriptFile(const PayloadExport& e, const std::vector<RigidPart>& parts) {
  const UrPayload u = combineBeyondFlange(e, parts);
  std::ostringstream o;
  o << "# UR payload for everything beyond the tool flange, exported by ftid (docs/operations.md \"Exports\").\n"
    << "# set_target_payload(mass [kg], centre of gravity in the flange frame tool0 [m],\n"
    << "#                    inertia about it, axes of tool0, [Ixx, Iyy, Izz, Ixy, Ixz, Iyz] [kg m^2])\n"
    << "# Set the TCP payload to this (teach pendant Installation > Payload, or run the line).\n"
    << "#   identified payload (model " << e.model << "): " << num(e.mass) << " kg at " << vec(e.cog_F) << " m"
    << (e.inertia_C_F ? ", inertia " + urOrder(*e.inertia_C_F) : std::string(", inertia not identified"))
    << "\n" << modelNotes(e.model);
  for (const auto& p : parts) {
    if (p.mass > 0.0) {
      o << "#   " << p.name << " (ftidd.yaml export." << p.name << "): " << num(p.mass) << " kg at " << vec(p.com_F)
        << " m, inertia " << urOrder(p.inertia_C_F) << "\n";
    }
  }
  if (!u.inertia_F) {
    o << "# No inertia is known (model without rigid_body, no parts configured): the controller estimates it.\n";
  } else if (u.payload_point_mass) {
    o << "# The payload's own inertia was not identified (fit paper+rigid_body for it): taken as a point mass.\n";
  }
  o << urScriptPayload(u) << "\n";
  return o.str();
}

std::string ros2BroadcasterYaml(const PayloadExport& e, const Ros2Names& n) {
  std::ostringstream header;
  header << "# ros2_control parameters exported by ftid (docs/operations.md \"Exports\"), model " << e.model << ".\n"
         << "# force_torque_sensor_broadcaster publishes reading + offset, then runs the sensor_filter_chain.\n"
         << "#  - offset.force / offset.torque are ADDED to the reading, so they are the negated identified\n"
         << "#    sensor offsets: offset = -F0 [N], -T0 [Nm] (F0 = " << vec(e.f0_S) << ", T0 = " << vec(e.t0_S)
         << ").\n"
         << "#  - control_filters/GravityCompensationWrench (control_toolbox) subtracts the tool's weight:\n"
         << "#    tool.mass [kg]; tool.CoG = centre of mass in sensor_frame (frame S) [m];\n"
         << "#    tool.gravity_field = gravity in world_frame [m/s^2], here the robot base B with the\n"
         << "#    identified base tilt (g_B = R_WB^T g_W). world_frame must be the TF frame of B (UR: 'base'),\n"
         << "#    sensor_frame the TF frame of S (the sensor mount in your URDF must match ftidd.yaml's).\n"
         << "#  The filter compensates gravity only; ftidd also removes the inertial wrench in motion.\n"
         << modelNotes(e.model);
  auto xyz = [](YAML::Emitter& o, const Vec3& v) {
    o << YAML::BeginMap;
    for (int i = 0; i < 3; ++i) o << YAML::Key << std::string(1, "xyz"[i]) << YAML::Value << YamlNumber{v(i)};
    o << YAML::EndMap;
  };
  auto list = [](YAML::Emitter& o, const Vec3& v) {
    o << YAML::Flow << YAML::BeginSeq << YamlNumber{v.x()} << YamlNumber{v.y()} << YamlNumber{v.z()} << YAML::EndSeq;
  };
  // Names are always quoted: a frame called `true` or `1` must stay a string for ROS 2's parser.
  YAML::Emitter o;
  o << YAML::BeginMap << YAML::Key << n.controller << YAML::Value << YAML::BeginMap;
  o << YAML::Key << "ros__parameters" << YAML::Value << YAML::BeginMap;
  o << YAML::Key << "sensor_name" << YAML::Value << YAML::DoubleQuoted << n.sensor_name;
  o << YAML::Key << "frame_id" << YAML::Value << YAML::DoubleQuoted << n.sensor_frame;
  o << YAML::Key << "offset" << YAML::Value << YAML::BeginMap;
  o << YAML::Key << "force" << YAML::Value;
  xyz(o, -e.f0_S);
  o << YAML::Key << "torque" << YAML::Value;
  xyz(o, -e.t0_S);
  o << YAML::EndMap;  // offset
  o << YAML::Key << "sensor_filter_chain" << YAML::Value << YAML::BeginMap;
  o << YAML::Key << "filter1" << YAML::Value << YAML::BeginMap;
  o << YAML::Key << "type" << YAML::Value << "control_filters/GravityCompensationWrench";
  o << YAML::Key << "name" << YAML::Value << "gravity_compensation";
  o << YAML::Key << "params" << YAML::Value << YAML::BeginMap;
  o << YAML::Key << "world_frame" << YAML::Value << YAML::DoubleQuoted << n.world_frame;
  o << YAML::Key << "sensor_frame" << YAML::Value << YAML::DoubleQuoted << n.sensor_frame;
  o << YAML::Key << "tool" << YAML::Value << YAML::BeginMap;
  o << YAML::Key << "CoG" << YAML::Value;
  list(o, e.com_S);
  o << YAML::Key << "mass" << YAML::Value << YamlNumber{e.mass};
  o << YAML::Key << "gravity_field" << YAML::Value;
  list(o, e.gravity_B);
  o << YAML::EndMap << YAML::EndMap << YAML::EndMap << YAML::EndMap;  // tool, params, filter1, chain
  o << YAML::EndMap << YAML::EndMap << YAML::EndMap;  // ros__parameters, controller, document
  return yamlDocument(header.str(), o);
}

std::vector<RigidPart> partsFromConfig(const config::DaemonConfig& cfg) {
  auto part = [](const std::string& name, const config::RigidPartConfig& p) {
    return RigidPart{name, p.mass, p.com_F, fromUrOrder(p.inertia_C_F)};
  };
  return {part("adapter", cfg.exports.adapter), part("sensor_body", cfg.exports.sensor_body)};
}

Ros2Names ros2NamesFromConfig(const config::DaemonConfig& cfg) {
  Ros2Names n;
  n.world_frame = cfg.exports.world_frame;
  n.sensor_frame = cfg.exports.sensor_frame;
  n.sensor_name = cfg.exports.sensor_name;
  return n;
}

std::string writeExports(const params::ParameterSet& set, const config::DaemonConfig& cfg,
                         const std::string& ros2_path, const std::string& urscript_path) {
  const PayloadExport e = makePayloadExport(set, cfg.sensor.R_FS(), cfg.sensor.p_FS_F());
  // Build both texts first so that a bad parameter set writes nothing.
  const std::string ros2 = ros2BroadcasterYaml(e, ros2NamesFromConfig(cfg));
  const std::string ur = urScriptFile(e, partsFromConfig(cfg));
  std::string written;
  if (!ros2_path.empty()) {
    writeFileAtomically(ros2_path, ros2);
    written += ros2_path + " (ros2_control force_torque_sensor_broadcaster + GravityCompensationWrench)";
  }
  if (!urscript_path.empty()) {
    writeFileAtomically(urscript_path, ur);
    written += (written.empty() ? "" : ", ") + urscript_path + " (UR set_target_payload)";
  }
  return written;
}

std::string defaultExportConfigPath() {
  std::error_code ec;
  if (std::filesystem::is_regular_file("/etc/ftid/ftidd.yaml", ec)) return "/etc/ftid/ftidd.yaml";
  return findDefaultFile("ftidd.yaml");
}

}  // namespace ftid::cell
