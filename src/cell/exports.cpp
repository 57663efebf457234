#include "ftid/cell/exports.hpp"

#include <cstdio>
#include <sstream>

#include "ftid/common/error.hpp"
#include "ftid/model/frames.hpp"

namespace ftid::cell {

namespace {
double need(const identify::ParameterSet& set, const std::string& name) {
  const identify::NamedValue* v = set.find(name);
  if (!v) throw ConfigError("parameter set (model '" + set.model + "') has no '" + name + "'");
  return v->value;
}
std::string num(double x) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.9g", x);
  return buf;
}
}  // namespace

PayloadExport makePayloadExport(const identify::ParameterSet& set, const Mat3& R_FS, const Vec3& p_FS_F) {
  PayloadExport e;
  e.mass = need(set, "mass");
  e.com_S = Vec3(need(set, "com_x"), need(set, "com_y"), need(set, "com_z"));
  e.cog_F = p_FS_F + R_FS * e.com_S;
  if (set.find("i_c_xx")) {
    Mat3 I_C;
    const double ixx = need(set, "i_c_xx"), iyy = need(set, "i_c_yy"), izz = need(set, "i_c_zz");
    const double ixy = need(set, "i_c_xy"), ixz = need(set, "i_c_xz"), iyz = need(set, "i_c_yz");
    I_C << ixx, ixy, ixz, ixy, iyy, iyz, ixz, iyz, izz;
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

std::string urScriptPayload(const PayloadExport& e) {
  std::ostringstream o;
  o << "set_target_payload(" << num(e.mass) << ", [" << num(e.cog_F.x()) << ", " << num(e.cog_F.y()) << ", "
    << num(e.cog_F.z()) << "]";
  if (e.inertia_C_F) {
    const Mat3& I = *e.inertia_C_F;
    o << ", [" << num(I(0, 0)) << ", " << num(I(1, 1)) << ", " << num(I(2, 2)) << ", " << num(I(0, 1)) << ", "
      << num(I(0, 2)) << ", " << num(I(1, 2)) << "]";
  }
  o << ")";
  return o.str();
}

std::string ros2GravityCompensationYaml(const PayloadExport& e, const std::string& node_name,
                                        const std::string& world_frame, const std::string& sensor_frame) {
  std::ostringstream o;
  o << "# Exported by ftid --identify for the ros2_control control_toolbox GravityCompensation filter.\n"
    << "# tool.pos is the centre of mass in the sensor frame [m]; tool.gravity_field is gravity in the\n"
    << "# robot base frame [m/s^2], including the identified base tilt. The filter has no slot for the\n"
    << "# sensor offsets; subtract them in force_torque_sensor_broadcaster (offsets) if needed:\n"
    << "#   force offsets [N]: [" << num(e.f0_S.x()) << ", " << num(e.f0_S.y()) << ", " << num(e.f0_S.z()) << "]\n"
    << "#   torque offsets [Nm]: [" << num(e.t0_S.x()) << ", " << num(e.t0_S.y()) << ", " << num(e.t0_S.z())
    << "]\n"
    << node_name << ":\n"
    << "  ros__parameters:\n"
    << "    world_frame: " << world_frame << "\n"
    << "    sensor_frame: " << sensor_frame << "\n"
    << "    tool:\n"
    << "      mass: " << num(e.mass) << "\n"
    << "      pos: [" << num(e.com_S.x()) << ", " << num(e.com_S.y()) << ", " << num(e.com_S.z()) << "]\n"
    << "      gravity_field: [" << num(e.gravity_B.x()) << ", " << num(e.gravity_B.y()) << ", "
    << num(e.gravity_B.z()) << "]\n";
  return o.str();
}

}  // namespace ftid::cell
