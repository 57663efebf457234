// Excitation trajectory files: traj.yaml (coefficients + provenance) and traj.csv (sampled).
// Format documented in docs/design.md; conventions in docs/conventions.md.
#include "ftid/common/default_files.hpp"
#include "ftid/trajectory/trajectory_io.hpp"

#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <sstream>
#include <stdexcept>
#include <string>

#include "ftid/common/error.hpp"
#include "ftid/fileio/atomic_file.hpp"
#include "ftid/fileio/input_file.hpp"
#include "ftid/fileio/yaml_emit.hpp"
#include "ftid/fileio/yaml_reader.hpp"

namespace ftid::trajectory {

namespace {

constexpr const char* kFormatTag = "ftid-excitation-trajectory/1";

// ---------------------------------------------------------------- writing

template <typename Vec>
void seq(YAML::Emitter& o, const Vec& v, int n) {
  o << YAML::Flow << YAML::BeginSeq;
  for (int i = 0; i < n; ++i) o << YamlNumber{v[i]};
  o << YAML::EndSeq;
}

/// Writes `text` to `path` through the one atomic writer (ftid/fileio/atomic_file.hpp).
void writeAtomically(const std::string& path, const std::string& text) {
  try {
    writeFileAtomically(path, text);
  } catch (const FileError& e) {
    throw ConfigError(e.what());
  }
}

}  // namespace

FourierTrajectory TrajectoryFile::toTrajectory() const {
  return FourierTrajectory(q0, base_frequency_hz, harmonics, duration_s, a, b);
}

std::string csvPathFor(const std::string& yaml_path) {
  const auto slash = yaml_path.find_last_of('/');
  const auto dot = yaml_path.find_last_of('.');
  if (dot != std::string::npos && (slash == std::string::npos || dot > slash)) {
    return yaml_path.substr(0, dot) + ".csv";
  }
  return yaml_path + ".csv";
}

void writeTrajectoryFile(const std::string& path, const TrajectoryFile& file) {
  const int n = file.harmonics;
  if (n < 1 || n > FourierTrajectory::kMaxHarmonics) {
    throw ConfigError(path + ": cannot write a trajectory with " + std::to_string(n) +
                      " harmonics");
  }
  const std::string header =
      "# ftid excitation trajectory (docs/design.md). Joint i follows the finite Fourier series\n"
      "#   q_i(t)   = q0_i + sum_l [ a_il/(w l) sin(w l t) + b_il/(w l) (1 - cos(w l t)) ]\n"
      "#   qd_i(t)  = sum_l [ a_il cos(w l t) + b_il sin(w l t) ]          w = 2 pi base_frequency_hz\n"
      "# (paper Eq. 47-49 with the offset q0). Rest-to-rest: sum_l a_il = 0, sum_l l b_il = 0 and a\n"
      "# whole number of base periods. Units SI (docs/conventions.md). Re-check with\n"
      "#   ftid check-trajectory THIS_FILE\n";
  YAML::Emitter o;
  o << YAML::BeginMap;
  o << YAML::Key << "format" << YAML::Value << kFormatTag;
  o << YAML::Key << "robot" << YAML::Value << YAML::DoubleQuoted << relativeTo(path, file.robot)
    << YAML::Comment("a relative path is relative to this file");
  o << YAML::Key << "joints" << YAML::Value << YAML::Flow << file.joints
    << YAML::Comment("excited joints, 1-based UR order; the others stay at q0");
  o << YAML::Key << "q0" << YAML::Value;
  seq(o, file.q0, kNumJoints);
  o << YAML::Comment("start/end pose [rad]");
  o << YAML::Key << "base_frequency_hz" << YAML::Value << YamlNumber{file.base_frequency_hz};
  o << YAML::Key << "harmonics" << YAML::Value << n;
  o << YAML::Key << "duration_s" << YAML::Value << YamlNumber{file.duration_s};
  o << YAML::Key << "servo_rate_hz" << YAML::Value << YamlNumber{file.servo_rate_hz}
    << YAML::Comment("rate of the CSV beside this file");
  o << YAML::Key << "coefficients" << YAML::Value
    << YAML::Comment("[rad/s], one row per joint 1..6, one column per harmonic 1..N") << YAML::BeginMap;
  for (const auto* name : {"a", "b"}) {
    const auto& rows = name[0] == 'a' ? file.a : file.b;
    o << YAML::Key << name << YAML::Value << YAML::BeginSeq;
    for (int j = 0; j < kNumJoints; ++j) seq(o, rows[static_cast<std::size_t>(j)], n);
    o << YAML::EndSeq;
  }
  o << YAML::EndMap;

  const auto& c = file.constraints;
  o << YAML::Key << "constraints" << YAML::Value << YAML::Comment("what the trajectory was designed and checked against")
    << YAML::BeginMap;
  o << YAML::Key << "position_lower" << YAML::Value;
  seq(o, c.position_lower, kNumJoints);
  o << YAML::Comment("[rad]");
  o << YAML::Key << "position_upper" << YAML::Value;
  seq(o, c.position_upper, kNumJoints);
  o << YAML::Comment("[rad]");
  o << YAML::Key << "velocity" << YAML::Value;
  seq(o, c.velocity, kNumJoints);
  o << YAML::Comment("[rad/s]");
  o << YAML::Key << "acceleration" << YAML::Value;
  seq(o, c.acceleration, kNumJoints);
  o << YAML::Comment("[rad/s^2]");
  o << YAML::Key << "floor_z" << YAML::Value << YamlNumber{c.floor_z_B} << YAML::Comment("[m] in the base frame B");
  o << YAML::Key << "tool" << YAML::Value << YAML::Comment("spheres fixed in the sensor frame S") << YAML::BeginSeq;
  for (const auto& t : c.tool) {
    o << YAML::Flow << YAML::BeginMap << YAML::Key << "center" << YAML::Value;
    seq(o, t.center_S, 3);
    o << YAML::Key << "radius" << YAML::Value << YamlNumber{t.radius} << YAML::EndMap;
  }
  o << YAML::EndSeq;
  o << YAML::Key << "keep_out" << YAML::Value << YAML::Comment("spheres fixed in the base frame B") << YAML::BeginSeq;
  for (const auto& k : c.keep_out) {
    o << YAML::Flow << YAML::BeginMap << YAML::Key << "name" << YAML::Value << YAML::DoubleQuoted << k.name
      << YAML::Key << "center" << YAML::Value;
    seq(o, k.center_B, 3);
    o << YAML::Key << "radius" << YAML::Value << YamlNumber{k.radius} << YAML::EndMap;
  }
  o << YAML::EndSeq;
  o << YAML::Key << "sensor_mount" << YAML::Value << YAML::Comment("X_FS: rotation row-major, translation [m]")
    << YAML::BeginMap;
  {
    double r[9];
    for (int i = 0; i < 9; ++i) r[i] = c.R_FS(i / 3, i % 3);
    o << YAML::Key << "rotation" << YAML::Value;
    seq(o, r, 9);
    o << YAML::Key << "translation" << YAML::Value;
    seq(o, c.p_FS_F, 3);
  }
  o << YAML::EndMap;  // sensor_mount
  o << YAML::EndMap;  // constraints
  o << YAML::Key << "design" << YAML::Value << YAML::Comment("how it was produced (enough to reproduce it)")
    << YAML::BeginMap;
  for (const auto& [k, v] : file.design) o << YAML::Key << k << YAML::Value << YAML::DoubleQuoted << v;
  o << YAML::EndMap;
  o << YAML::Key << "metrics" << YAML::Value << YAML::BeginMap;
  for (const auto& [k, v] : file.metrics) o << YAML::Key << k << YAML::Value << YamlNumber{v};
  o << YAML::EndMap;
  o << YAML::Key << "predicted_std" << YAML::Value
    << YAML::Comment("predicted standard errors [SI] for the design noise") << YAML::BeginMap;
  for (const auto& [k, v] : file.predicted_std) o << YAML::Key << k << YAML::Value << YamlNumber{v};
  o << YAML::EndMap;
  o << YAML::EndMap;
  const std::string text = yamlDocument(header, o);
  writeAtomically(path, text);
}

TrajectoryFile readTrajectoryFile(const std::string& path) {
  std::string text;
  try {
    text = readInputFile(path, "trajectory file", kMaxTextConfigBytes);
  } catch (const FileError& e) {
    throw ConfigError(e.what());
  }
  return parseTrajectoryText(text, path);
}

namespace {
TrajectoryFile parseTrajectoryNode(const YamlValue& root, const std::string& path);
}  // namespace

TrajectoryFile parseTrajectoryText(const std::string& text, const std::string& path) {
  const YamlFile file = YamlFile::parse(text, path);
  try {
    return parseTrajectoryNode(file.root(), path);
  } catch (const YAML::Exception& e) {
    // A node of an unexpected kind (found by fuzzing: a scalar where a mapping belongs).
    throw ConfigError(path + ":" + std::to_string(e.mark.line + 1) + ": unexpected structure: " + e.msg);
  }
}

namespace {
TrajectoryFile parseTrajectoryNode(const YamlValue& root, const std::string& path) {
  root.expectMap("not a trajectory file (expected a YAML mapping)");
  const YamlValue fmt = root.required("format");
  if (!fmt.isScalar() || fmt.text() != kFormatTag) fmt.fail(std::string("expected '") + kFormatTag + "'");
  TrajectoryFile f;
  if (const YamlValue robot = root["robot"]) f.robot = resolveRelativeTo(path, robot.text());

  const YamlValue joints = root.required("joints");
  if (!joints.isSequence() || joints.size() == 0) joints.fail("expected a non-empty list of joint numbers 1..6");
  for (const YamlValue& j : joints.elements()) {
    f.joints.push_back(static_cast<int>(j.integer(1, kNumJoints, "joint numbers are 1..6")));
  }
  f.q0 = root.required("q0").vector<kNumJoints>();
  const NumberRange positive = NumberRange::positive("must be positive");
  f.base_frequency_hz = root.required("base_frequency_hz").number(positive);
  f.harmonics = static_cast<int>(root.required("harmonics").integer(
      1, FourierTrajectory::kMaxHarmonics, "must be 1.." + std::to_string(FourierTrajectory::kMaxHarmonics)));
  f.duration_s = root.required("duration_s").number(positive);
  f.servo_rate_hz = root.required("servo_rate_hz").number(positive);

  const YamlValue coeff = root.required("coefficients");
  for (const char* which : {"a", "b"}) {
    const YamlValue rows = coeff.required(which);
    if (!rows.isSequence() || rows.size() != static_cast<std::size_t>(kNumJoints)) {
      rows.fail("expected 6 rows (one per joint)");
    }
    auto& dst = (which[0] == 'a') ? f.a : f.b;
    for (int j = 0; j < kNumJoints; ++j) {
      const auto ju = static_cast<std::size_t>(j);
      const auto row = rows.at(ju).numbers(static_cast<std::size_t>(f.harmonics));
      for (int l = 0; l < f.harmonics; ++l) dst[ju][static_cast<std::size_t>(l)] = row[static_cast<std::size_t>(l)];
    }
  }
  coeff.onlyKeys({"a", "b"});

  if (const YamlValue c = root["constraints"]) {
    auto& k = f.constraints;
    k.position_lower = c.required("position_lower").vector<kNumJoints>();
    k.position_upper = c.required("position_upper").vector<kNumJoints>();
    k.velocity = c.required("velocity").vector<kNumJoints>();
    k.acceleration = c.required("acceleration").vector<kNumJoints>();
    k.floor_z_B = c.required("floor_z").number();
    const NumberRange radius = NumberRange::nonNegative("must not be negative");
    if (const YamlValue tool = c["tool"]) {
      tool.expectSequence("expected a list of {center, radius}");
      for (const YamlValue& t : tool.elements()) {
        t.expectMap("expected {center, radius}");
        ToolSphere s;
        s.center_S = t.required("center").vector<3>();
        s.radius = t.required("radius").number(radius);
        t.onlyKeys({"center", "radius"});
        k.tool.push_back(s);
      }
    }
    if (const YamlValue ko = c["keep_out"]) {
      ko.expectSequence("expected a list of {name, center, radius}");
      for (const YamlValue& o : ko.elements()) {
        o.expectMap("expected {name, center, radius}");
        KeepOutSphere s;
        s.name = o["name"].textOr("");
        s.center_B = o.required("center").vector<3>();
        s.radius = o.required("radius").number(radius);
        o.onlyKeys({"name", "center", "radius"});
        k.keep_out.push_back(s);
      }
    }
    if (const YamlValue m = c["sensor_mount"]) {
      const YamlValue rotation = m.required("rotation");
      const auto rot = rotation.numbers(9);
      for (int i = 0; i < 9; ++i) k.R_FS(i / 3, i % 3) = rot[static_cast<std::size_t>(i)];
      if ((k.R_FS.transpose() * k.R_FS - Mat3::Identity()).norm() > 1e-6 || k.R_FS.determinant() < 0.0) {
        rotation.fail("is not a rotation matrix");
      }
      k.p_FS_F = m.required("translation").vector<3>();
      m.onlyKeys({"rotation", "translation"});
    }
    c.onlyKeys({"position_lower", "position_upper", "velocity", "acceleration", "floor_z", "tool", "keep_out",
                "sensor_mount"});
  }
  // Provenance: free keys (what the designer recorded); `key:` without entries is allowed.
  const auto present = [&](const char* key) { return root[key].present() && !root[key].isNull(); };
  if (present("design")) {
    for (const auto& [name, v] : root["design"].entries()) f.design[name] = v.text();
  }
  for (const char* key : {"metrics", "predicted_std"}) {
    if (!present(key)) continue;
    auto& dst = key[0] == 'm' ? f.metrics : f.predicted_std;
    for (const auto& [name, v] : root[key].entries()) dst[name] = v.number();
  }
  // Unknown keys last, so that a misspelt required key is reported as missing.
  root.onlyKeys({"format", "robot", "joints", "q0", "base_frequency_hz", "harmonics", "duration_s", "servo_rate_hz",
                 "coefficients", "constraints", "design", "metrics", "predicted_std"});

  // Rest-to-rest needs a whole number of base periods; reject files that cannot be rest-to-rest.
  const double periods = f.periods();
  if (std::abs(periods - std::round(periods)) > 1e-9 || std::round(periods) < 1.0) {
    root["duration_s"].fail("duration * base_frequency_hz = " + yamlNumberText(periods) +
                            " is not a whole number of base periods (rest-to-rest needs one)");
  }
  try {
    (void)f.toTrajectory();
  } catch (const std::invalid_argument& e) {
    coeff.fail(e.what());
  }
  return f;
}
}  // namespace

void writeTrajectoryCsv(const std::string& path, const FourierTrajectory& trajectory,
                        double rate_hz) {
  if (!(rate_hz > 0.0) || !std::isfinite(rate_hz)) {
    throw ConfigError(path + ": sample rate must be positive (got " + yamlNumberText(rate_hz) + ")");
  }
  const double T = trajectory.duration();
  const long n = std::lround(std::floor(T * rate_hz + 1e-9));
  std::string text = "t";
  for (const char* g : {"q", "qd", "qdd"}) {
    for (int j = 1; j <= kNumJoints; ++j) text += "," + std::string(g) + std::to_string(j);
  }
  text += "\n";
  char buf[64];
  for (long k = 0; k <= n; ++k) {
    const double t = static_cast<double>(k) / rate_hz;
    const TrajectoryPoint p = trajectory.evaluate(t);
    std::snprintf(buf, sizeof buf, "%.6f", t);
    text += buf;
    for (const JointVector* v : {&p.q, &p.qd, &p.qdd}) {
      for (int j = 0; j < kNumJoints; ++j) {
        std::snprintf(buf, sizeof buf, ",%.12g", (*v)[j]);
        text += buf;
      }
    }
    text += "\n";
  }
  writeAtomically(path, text);
}

}  // namespace ftid::trajectory
