// Exports of an identified payload: UR set_target_payload (everything beyond the flange) and the
// ros2_control force_torque_sensor_broadcaster + GravityCompensationWrench parameter file.
#include <gtest/gtest.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <Eigen/Eigenvalues>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "ftid/cell/exports.hpp"
#include "ftid/config/daemon_config.hpp"
#include "ftid/params/parameter_set.hpp"
#include "test_paths.hpp"

namespace {

ftid::params::ParameterSet makeSet() {
  ftid::params::ParameterSet set;
  set.model = "paper";
  set.params = {{"mass", 0.9, 0.001, "kg"},   {"f0_x", -0.5, 0.01, "N"},   {"f0_y", 0.25, 0.01, "N"},
                {"f0_z", 1.5, 0.01, "N"},     {"t0_x", 0.03, 0.001, "Nm"}, {"t0_y", -0.04, 0.001, "Nm"},
                {"t0_z", 0.02, 0.001, "Nm"}};
  set.derived = {{"com_x", 0.01, 1e-4, "m"}, {"com_y", 0.0, 1e-4, "m"}, {"com_z", 0.02, 1e-4, "m"}};
  set.tilt_estimated = true;
  set.tilt_u_rad = 0.1;
  set.tilt_v_rad = -0.05;
  return set;
}

void addInertia(ftid::params::ParameterSet& set, double ixx, double iyy, double izz, double ixy, double ixz,
                double iyz) {
  set.derived.push_back({"i_c_xx", ixx, 0, ""});
  set.derived.push_back({"i_c_yy", iyy, 0, ""});
  set.derived.push_back({"i_c_zz", izz, 0, ""});
  set.derived.push_back({"i_c_xy", ixy, 0, ""});
  set.derived.push_back({"i_c_xz", ixz, 0, ""});
  set.derived.push_back({"i_c_yz", iyz, 0, ""});
}

ftid::Mat3 rotZ90() {
  ftid::Mat3 R;
  R << 0, -1, 0, 1, 0, 0, 0, 0, 1;  // +90 deg about z: x_S -> y_F, y_S -> -x_F
  return R;
}

TEST(PayloadExport, CentreOfGravityIsExpressedInTheFlangeFrame) {
  // Sensor rotated +90 deg about the flange z axis and 5 cm out along it.
  const auto e = ftid::cell::makePayloadExport(makeSet(), rotZ90(), ftid::Vec3(0, 0, 0.05));
  // x_S = (1,0,0) is y_F, so com_S = (0.01, 0, 0.02) is (0, 0.01, 0.02) in F, plus the mount offset.
  EXPECT_NEAR(e.cog_F.x(), 0.0, 1e-15);
  EXPECT_NEAR(e.cog_F.y(), 0.01, 1e-15);
  EXPECT_NEAR(e.cog_F.z(), 0.07, 1e-15);
  EXPECT_DOUBLE_EQ(e.mass, 0.9);
  EXPECT_FALSE(e.inertia_C_F.has_value());
  EXPECT_DOUBLE_EQ(e.f0_S.x(), -0.5);
}

TEST(PayloadExport, GravityFieldCarriesTheTilt) {
  const auto e = ftid::cell::makePayloadExport(makeSet(), ftid::Mat3::Identity(), ftid::Vec3::Zero());
  // Paper Eq. 13 written out: g_B = g (cos U sin V, -sin U, -cos U cos V).
  const double g = 9.80665, u = 0.1, v = -0.05;
  EXPECT_NEAR(e.gravity_B.x(), g * std::cos(u) * std::sin(v), 1e-12);
  EXPECT_NEAR(e.gravity_B.y(), -g * std::sin(u), 1e-12);
  EXPECT_NEAR(e.gravity_B.z(), -g * std::cos(u) * std::cos(v), 1e-12);
}

TEST(PayloadExport, InertiaIsRotatedIntoTheFlangeFrameInUrOrder) {
  auto set = makeSet();
  addInertia(set, 1e-3, 2e-3, 3e-3, 0.5e-3, 0.0, 0.0);  // I_C in S
  const auto e = ftid::cell::makePayloadExport(set, rotZ90(), ftid::Vec3::Zero());
  ASSERT_TRUE(e.inertia_C_F.has_value());
  const ftid::Mat3& I = *e.inertia_C_F;
  // Moments swap between x and y, the product changes sign.
  EXPECT_NEAR(I(0, 0), 2e-3, 1e-15);
  EXPECT_NEAR(I(1, 1), 1e-3, 1e-15);
  EXPECT_NEAR(I(2, 2), 3e-3, 1e-15);
  EXPECT_NEAR(I(0, 1), -0.5e-3, 1e-15);
  // Payload alone (no parts): the line is the payload itself.
  const std::string line = ftid::cell::urScriptPayload(ftid::cell::combineBeyondFlange(e, {}));
  EXPECT_EQ(line, "set_target_payload(0.9, [0, 0.01, 0.02], [0.002, 0.001, 0.003, -0.0005, 0, 0])");
}

TEST(PayloadExport, InertiaAboutTheSensorOriginIsMovedToTheCentreOfMass) {
  // A fit gives I_S (about the S origin). Payload 0.9 kg at c = (0.01, 0, 0.02) with
  // I_C = diag(1, 2, 3) e-3: I_S = I_C + m (|c|^2 1 - c c^T), by hand
  //   |c|^2 = 5e-4: xx = 1e-3 + 0.9 (5e-4 - 1e-4) = 1.36e-3, yy = 2e-3 + 0.9 * 5e-4 = 2.45e-3,
  //   zz = 3e-3 + 0.9 (5e-4 - 4e-4) = 3.09e-3, xz = -0.9 * 0.01 * 0.02 = -1.8e-4.
  auto set = makeSet();
  set.params.push_back({"i_s_xx", 1.36e-3, 0, ""});
  set.params.push_back({"i_s_yy", 2.45e-3, 0, ""});
  set.params.push_back({"i_s_zz", 3.09e-3, 0, ""});
  set.params.push_back({"i_s_xy", 0.0, 0, ""});
  set.params.push_back({"i_s_xz", -1.8e-4, 0, ""});
  set.params.push_back({"i_s_yz", 0.0, 0, ""});
  const auto e = ftid::cell::makePayloadExport(set, ftid::Mat3::Identity(), ftid::Vec3::Zero());
  ASSERT_TRUE(e.inertia_C_F.has_value());
  ftid::Mat3 expected = ftid::Mat3::Zero();
  expected.diagonal() << 1e-3, 2e-3, 3e-3;
  EXPECT_LT((*e.inertia_C_F - expected).cwiseAbs().maxCoeff(), 1e-15) << *e.inertia_C_F;
}

TEST(PayloadExport, MissingMassIsAClearError) {
  ftid::params::ParameterSet set;
  set.model = "offsets";
  try {
    ftid::cell::makePayloadExport(set, ftid::Mat3::Identity(), ftid::Vec3::Zero());
    FAIL() << "expected ConfigError";
  } catch (const std::exception& ex) {
    EXPECT_NE(std::string(ex.what()).find("'mass'"), std::string::npos) << ex.what();
  }
}

// ---- UR: everything beyond the flange -------------------------------------------------------

TEST(UrPayload, CombinedMassAndCentreOfGravityMatchAHandCalculation) {
  // Payload 0.9 kg at (0, 0.01, 0.07) in F (sensor turned 90 deg, 5 cm out), adapter 0.2 kg at
  // (0, 0, 0.005), sensor body 0.3 kg at (0, 0, 0.02).
  //   m = 0.9 + 0.2 + 0.3 = 1.4 kg
  //   c_x = 0
  //   c_y = 0.9 * 0.01 / 1.4 = 0.009 / 1.4 = 0.006428571428...
  //   c_z = (0.9 * 0.07 + 0.2 * 0.005 + 0.3 * 0.02) / 1.4 = (0.063 + 0.001 + 0.006) / 1.4 = 0.05
  const auto e = ftid::cell::makePayloadExport(makeSet(), rotZ90(), ftid::Vec3(0, 0, 0.05));
  const std::vector<ftid::cell::RigidPart> parts{
      {"adapter", 0.2, ftid::Vec3(0, 0, 0.005), ftid::Mat3::Zero()},
      {"sensor_body", 0.3, ftid::Vec3(0, 0, 0.02), ftid::Mat3::Zero()}};
  const auto u = ftid::cell::combineBeyondFlange(e, parts);
  EXPECT_NEAR(u.mass, 1.4, 1e-15);
  EXPECT_NEAR(u.cog_F.x(), 0.0, 1e-15);
  EXPECT_NEAR(u.cog_F.y(), 0.0064285714285714, 1e-15);
  EXPECT_NEAR(u.cog_F.z(), 0.05, 1e-15);
  // Point masses: the payload inertia was not identified, so the result must say so.
  EXPECT_TRUE(u.payload_point_mass);
  ASSERT_TRUE(u.inertia_F.has_value());
  // Three point masses on the z axis plus the payload 1 cm off it. By hand, about the combined
  // centre (0, 0.0064286, 0.05): Ixx = sum m (dy^2 + dz^2), with
  //   payload  dy = 0.0035714, dz = 0.02   -> 0.9 (1.2755e-5 + 4e-4)    = 3.714796e-4
  //   adapter  dy = -0.0064286, dz = -0.045 -> 0.2 (4.1327e-5 + 2.025e-3) = 4.132653e-4
  //   body     dy = -0.0064286, dz = -0.03  -> 0.3 (4.1327e-5 + 9e-4)    = 2.823980e-4
  //   Ixx = 1.0671429e-3
  EXPECT_NEAR((*u.inertia_F)(0, 0), 1.0671429e-3, 1e-9);
  const std::string line = ftid::cell::urScriptPayload(u);
  EXPECT_EQ(line.rfind("set_target_payload(1.4, [0, 0.00642857143, 0.05], [", 0), 0u) << line;
}

/// n point masses that have the mass, centre and inertia (about the centre, in F) of a rigid
/// body: six points at +-s_k along the principal axes, rotated into F.
struct PointCloud {
  std::vector<double> m;
  std::vector<ftid::Vec3> p;
};
void addBody(PointCloud& cloud, double mass, const ftid::Vec3& centre, const ftid::Mat3& I) {
  Eigen::SelfAdjointEigenSolver<ftid::Mat3> es(I);
  const ftid::Vec3 a = es.eigenvalues();  // principal moments A, B, C
  const ftid::Mat3 R = es.eigenvectors();
  // Points +-s_x e_x, +-s_y e_y, +-s_z e_z with mass m/6 give A = (m/3)(s_y^2 + s_z^2), ...
  // so s_x^2 = 3 (B + C - A) / (2 m), and cyclically.
  const double sx = std::sqrt(3.0 * (a(1) + a(2) - a(0)) / (2.0 * mass));
  const double sy = std::sqrt(3.0 * (a(0) + a(2) - a(1)) / (2.0 * mass));
  const double sz = std::sqrt(3.0 * (a(0) + a(1) - a(2)) / (2.0 * mass));
  for (int sign : {-1, 1}) {
    for (const ftid::Vec3& d : {ftid::Vec3(sx, 0, 0), ftid::Vec3(0, sy, 0), ftid::Vec3(0, 0, sz)}) {
      cloud.m.push_back(mass / 6.0);
      cloud.p.push_back(centre + R * (sign * d));
    }
  }
}

TEST(UrPayload, InertiaMatchesADirectSumOverPointMasses) {
  // Independent formulation: replace every body by point masses with its inertia and sum
  // I = sum m_k (|r_k|^2 1 - r_k r_k^T) about the combined centre, with no parallel-axis formula.
  auto set = makeSet();
  addInertia(set, 4e-3, 5e-3, 6e-3, 0.7e-3, -0.3e-3, 0.2e-3);
  const ftid::Mat3 R_FS = Eigen::AngleAxisd(0.4, ftid::Vec3(1, 2, 3).normalized()).toRotationMatrix();
  const auto e = ftid::cell::makePayloadExport(set, R_FS, ftid::Vec3(0.001, -0.002, 0.04));
  ftid::Mat3 I_adapter, I_body;
  I_adapter << 2e-4, 1e-5, 0, 1e-5, 2.5e-4, 0, 0, 0, 3e-4;
  I_body << 6e-4, 0, 2e-5, 0, 6e-4, 0, 2e-5, 0, 4e-4;
  const std::vector<ftid::cell::RigidPart> parts{{"adapter", 0.15, ftid::Vec3(0.002, 0, 0.006), I_adapter},
                                                 {"sensor_body", 0.35, ftid::Vec3(0, 0.001, 0.025), I_body}};
  const auto u = ftid::cell::combineBeyondFlange(e, parts);
  ASSERT_FALSE(u.payload_point_mass);
  ASSERT_TRUE(u.inertia_F.has_value());

  PointCloud cloud;
  addBody(cloud, e.mass, e.cog_F, *e.inertia_C_F);
  for (const auto& p : parts) addBody(cloud, p.mass, p.com_F, p.inertia_C_F);
  double m = 0.0;
  ftid::Vec3 mc = ftid::Vec3::Zero();
  for (std::size_t k = 0; k < cloud.m.size(); ++k) {
    m += cloud.m[k];
    mc += cloud.m[k] * cloud.p[k];
  }
  const ftid::Vec3 c = mc / m;
  ftid::Mat3 I = ftid::Mat3::Zero();
  for (std::size_t k = 0; k < cloud.m.size(); ++k) {
    const ftid::Vec3 r = cloud.p[k] - c;
    I += cloud.m[k] * (r.squaredNorm() * ftid::Mat3::Identity() - r * r.transpose());
  }
  EXPECT_NEAR(u.mass, m, 1e-14);
  EXPECT_LT((u.cog_F - c).norm(), 1e-15);
  EXPECT_LT((*u.inertia_F - I).cwiseAbs().maxCoeff(), 1e-15) << *u.inertia_F << "\n\n" << I;
}

// ---- ROS 2 ----------------------------------------------------------------------------------

// Facts: the parameter definitions of the two ros2_control components the file configures.
// control_toolbox, control_filters/gravity_compensation_filter_parameters.yaml (2024-2025):
//   world_frame          string, read_only, validation not_empty
//   sensor_frame         string, read_only, validation not_empty
//   tool.CoG             double_array, validation fixed_size 3   (no default: required)
//   tool.gravity_field   double_array, default [0, 0, -9.81], validation fixed_size 3
//   tool.mass            double (no default: required)
// ros2_controllers, force_torque_sensor_broadcaster_parameters.yaml:
//   frame_id             string, validation not_empty
//   sensor_name          string, default ""
//   interface_names.{force,torque}.{x,y,z}   string, default ""
//   offset.{force,torque}.{x,y,z}            double, default 0.0; the broadcaster publishes
//                                            reading + offset
//   sensor_filter_chain.<filterN>.{type,name,params}: filters::FilterChain entries; the type of
//                                            the gravity filter is
//                                            control_filters/GravityCompensationWrench.
enum class Kind { kString, kNonEmptyString, kDouble, kDoubleArray3 };
const std::map<std::string, Kind>& filterParams() {
  static const std::map<std::string, Kind> m{{"world_frame", Kind::kNonEmptyString},
                                             {"sensor_frame", Kind::kNonEmptyString},
                                             {"tool.CoG", Kind::kDoubleArray3},
                                             {"tool.gravity_field", Kind::kDoubleArray3},
                                             {"tool.mass", Kind::kDouble}};
  return m;
}
const std::set<std::string>& filterRequired() {
  static const std::set<std::string> s{"world_frame", "sensor_frame", "tool.CoG", "tool.mass"};
  return s;
}
const std::map<std::string, Kind>& broadcasterParams() {
  static const std::map<std::string, Kind> m{
      {"frame_id", Kind::kNonEmptyString},       {"sensor_name", Kind::kString},
      {"interface_names.force.x", Kind::kString}, {"interface_names.force.y", Kind::kString},
      {"interface_names.force.z", Kind::kString}, {"interface_names.torque.x", Kind::kString},
      {"interface_names.torque.y", Kind::kString}, {"interface_names.torque.z", Kind::kString},
      {"offset.force.x", Kind::kDouble},          {"offset.force.y", Kind::kDouble},
      {"offset.force.z", Kind::kDouble},          {"offset.torque.x", Kind::kDouble},
      {"offset.torque.y", Kind::kDouble},         {"offset.torque.z", Kind::kDouble}};
  return m;
}

/// Flattens a YAML map into dotted keys -> leaf nodes (sequences are leaves).
void flatten(const YAML::Node& n, const std::string& prefix, std::map<std::string, YAML::Node>& out) {
  if (n.IsMap()) {
    for (const auto& kv : n) flatten(kv.second, prefix.empty() ? kv.first.Scalar() : prefix + "." + kv.first.Scalar(), out);
  } else {
    out[prefix] = n;
  }
}

bool isDouble(const YAML::Node& n) {
  if (!n.IsScalar()) return false;
  try {
    n.as<double>();
    return true;
  } catch (const YAML::Exception&) {
    return false;
  }
}

void checkKind(const std::string& key, const YAML::Node& n, Kind kind) {
  switch (kind) {
    case Kind::kString:
      EXPECT_TRUE(n.IsScalar()) << key;
      break;
    case Kind::kNonEmptyString:
      EXPECT_TRUE(n.IsScalar() && !n.Scalar().empty()) << key;
      break;
    case Kind::kDouble:
      EXPECT_TRUE(isDouble(n)) << key;
      break;
    case Kind::kDoubleArray3:
      ASSERT_TRUE(n.IsSequence()) << key;
      EXPECT_EQ(n.size(), 3u) << key;
      for (std::size_t i = 0; i < n.size(); ++i) EXPECT_TRUE(isDouble(n[i])) << key << "[" << i << "]";
      break;
  }
}

TEST(Ros2Export, EveryKeyIsAParameterOfTheBroadcasterOrTheGravityFilter) {
  const auto e = ftid::cell::makePayloadExport(makeSet(), ftid::Mat3::Identity(), ftid::Vec3::Zero());
  ftid::cell::Ros2Names names;
  names.world_frame = "ur_base";
  names.sensor_frame = "my_sensor";
  names.sensor_name = "tcp_fts";
  const YAML::Node root = YAML::Load(ftid::cell::ros2BroadcasterYaml(e, names));
  ASSERT_TRUE(root.IsMap());
  ASSERT_EQ(root.size(), 1u);
  const YAML::Node params = root["force_torque_sensor_broadcaster"]["ros__parameters"];
  ASSERT_TRUE(params.IsMap());

  std::map<std::string, YAML::Node> flat;
  flatten(params, "", flat);
  std::set<std::string> filter_keys;
  for (const auto& [key, node] : flat) {
    const std::string chain = "sensor_filter_chain.filter1.";
    if (key.rfind(chain, 0) == 0) {
      const std::string sub = key.substr(chain.size());
      if (sub == "type") {
        EXPECT_EQ(node.Scalar(), "control_filters/GravityCompensationWrench");
      } else if (sub == "name") {
        EXPECT_FALSE(node.Scalar().empty());
      } else {
        ASSERT_EQ(sub.rfind("params.", 0), 0u) << "not a filter-chain key: " << key;
        const std::string p = sub.substr(7);
        const auto it = filterParams().find(p);
        ASSERT_NE(it, filterParams().end()) << "the GravityCompensation filter defines no parameter '" << p << "'";
        checkKind(key, node, it->second);
        filter_keys.insert(p);
      }
      continue;
    }
    const auto it = broadcasterParams().find(key);
    ASSERT_NE(it, broadcasterParams().end()) << "force_torque_sensor_broadcaster defines no parameter '" << key << "'";
    checkKind(key, node, it->second);
  }
  for (const auto& req : filterRequired()) EXPECT_TRUE(filter_keys.count(req)) << "required filter parameter missing: " << req;
  // The broadcaster needs sensor_name (or interface names) and frame_id.
  EXPECT_EQ(flat.at("sensor_name").Scalar(), "tcp_fts");
  EXPECT_EQ(flat.at("frame_id").Scalar(), "my_sensor");

  // Values: frames as configured, the payload, gravity in B, and the offsets negated (the
  // broadcaster adds them: reading + offset = reading - F0).
  const YAML::Node f = params["sensor_filter_chain"]["filter1"]["params"];
  EXPECT_EQ(f["world_frame"].Scalar(), "ur_base");
  EXPECT_EQ(f["sensor_frame"].Scalar(), "my_sensor");
  // Full precision (ftid/fileio/yaml_emit.hpp): every number reads back as the same double.
  EXPECT_EQ(f["tool"]["mass"].as<double>(), e.mass);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(f["tool"]["CoG"][i].as<double>(), e.com_S(i));
    EXPECT_EQ(f["tool"]["gravity_field"][i].as<double>(), e.gravity_B(i));
  }
  const char* ax[] = {"x", "y", "z"};
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(params["offset"]["force"][ax[i]].as<double>(), -e.f0_S(i)) << ax[i];
    EXPECT_EQ(params["offset"]["torque"][ax[i]].as<double>(), -e.t0_S(i)) << ax[i];
  }
  // With the offsets as the broadcaster applies them, a reading equal to the offsets is zero.
  EXPECT_DOUBLE_EQ(e.f0_S.x() + params["offset"]["force"]["x"].as<double>(), 0.0);
}

TEST(Ros2Export, NamesWithYamlSyntaxStayStrings) {
  // The emitter quotes what YAML would otherwise read as syntax or as another type.
  const auto e = ftid::cell::makePayloadExport(makeSet(), ftid::Mat3::Identity(), ftid::Vec3::Zero());
  ftid::cell::Ros2Names names;
  names.world_frame = "base: link # 1";
  names.sensor_frame = "true";
  names.sensor_name = "- [fts]";
  const YAML::Node root = YAML::Load(ftid::cell::ros2BroadcasterYaml(e, names));
  const YAML::Node params = root["force_torque_sensor_broadcaster"]["ros__parameters"];
  EXPECT_EQ(params["sensor_name"].as<std::string>(), "- [fts]");
  EXPECT_EQ(params["frame_id"].as<std::string>(), "true");
  EXPECT_EQ(params["frame_id"].Tag(), "!");  // a quoted scalar: a string for every YAML reader, not a bool
  EXPECT_EQ(params["sensor_filter_chain"]["filter1"]["params"]["world_frame"].as<std::string>(), "base: link # 1");
}

TEST(Ros2Export, AnApparentTiltIsFlaggedInBothExports) {
  // A model with `cable` fits an apparent tilt (the cable's horizontal pull folded in, docs/effects.md):
  // both exports say so; a model without such an effect gets no such note.
  const auto plain = ftid::cell::makePayloadExport(makeSet(), ftid::Mat3::Identity(), ftid::Vec3::Zero());
  EXPECT_EQ(ftid::cell::ros2BroadcasterYaml(plain).find("APPARENT tilt"), std::string::npos);
  EXPECT_EQ(ftid::cell::urScriptFile(plain, {}).find("APPARENT tilt"), std::string::npos);
  ftid::params::ParameterSet set = makeSet();
  set.model = "paper+cable";
  const auto e = ftid::cell::makePayloadExport(set, ftid::Mat3::Identity(), ftid::Vec3::Zero());
  const std::string ros2 = ftid::cell::ros2BroadcasterYaml(e);
  EXPECT_NE(ros2.find("# NOTE: the model's tilt is an APPARENT tilt (cable)"), std::string::npos) << ros2;
  EXPECT_NO_THROW(YAML::Load(ros2));  // the note is a comment: the parameters are unchanged
  EXPECT_NE(ftid::cell::urScriptFile(e, {}).find("APPARENT tilt (cable)"), std::string::npos);
}

TEST(Ros2Export, WriteExportsUsesTheConfigsMountNamesAndParts) {
  const std::string dir = ::testing::TempDir() + "ftid_exports_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  const ftid::config::DaemonConfig cfg = ftid::config::parseDaemonConfig(
      "robot: {urdf_path: " + ftid::test::sourceDir() + "/config/ur10.urdf}\n"
      "sensor: {dbc_path: " + ftid::test::sourceDir() +
          "/config/ftsensor.dbc, mount_xyz: [0, 0, 0.05], mount_rpy: [0, 0, 1.5707963267948966]}\n"
      "export:\n  world_frame: base\n  sensor_frame: fts\n  sensor_name: fts\n"
      "  adapter: {mass: 0.2, com: [0, 0, 0.005], inertia: [0, 0, 0, 0, 0, 0]}\n"
      "  sensor_body: {mass: 0.3, com: [0, 0, 0.02], inertia: [0, 0, 0, 0, 0, 0]}\n",
      "test.yaml", "");
  const std::string written =
      ftid::cell::writeExports(makeSet(), cfg, dir + "/p.ros2.yaml", dir + "/p.urscript");
  EXPECT_NE(written.find("p.ros2.yaml"), std::string::npos);
  std::ifstream ur(dir + "/p.urscript");
  std::stringstream ss;
  ss << ur.rdbuf();
  // The hand-calculated combination of the test above (same payload, mount and parts).
  // (x is 0 up to the rounding of cos(pi/2) in the mount rotation.)
  EXPECT_NE(ss.str().find("set_target_payload(1.4, ["), std::string::npos) << ss.str();
  EXPECT_NE(ss.str().find(", 0.00642857143, 0.05], ["), std::string::npos) << ss.str();
  EXPECT_NE(ss.str().find("adapter (ftidd.yaml export.adapter): 0.2 kg"), std::string::npos) << ss.str();
  const YAML::Node ros2 = YAML::LoadFile(dir + "/p.ros2.yaml");
  EXPECT_EQ(ros2["force_torque_sensor_broadcaster"]["ros__parameters"]["sensor_filter_chain"]["filter1"]["params"]
                ["sensor_frame"].Scalar(),
            "fts");
  std::filesystem::remove_all(dir);
}

TEST(Ros2Export, ConfigRejectsAnUnphysicalPartInertiaNamingTheKey) {
  try {
    ftid::config::parseDaemonConfig(
        "robot: {urdf_path: " + ftid::test::sourceDir() + "/config/ur10.urdf}\n"
        "sensor: {dbc_path: " + ftid::test::sourceDir() + "/config/ftsensor.dbc}\n"
        "export:\n  adapter: {mass: 0.2, inertia: [1e-3, 1e-3, 5e-3, 0, 0, 0]}\n",
        "bad.yaml", "");
    FAIL() << "expected ConfigError";
  } catch (const std::exception& ex) {
    EXPECT_NE(std::string(ex.what()).find("export.adapter.inertia"), std::string::npos) << ex.what();
    EXPECT_NE(std::string(ex.what()).find("bad.yaml:4"), std::string::npos) << ex.what();
  }
}

}  // namespace
