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
#include <type_traits>

#include "ftid/common/error.hpp"
#include "ftid/fileio/atomic_file.hpp"
#include "ftid/fileio/input_file.hpp"
#include "ftid/fileio/yaml_emit.hpp"
#include "ftid/fileio/yaml_strict.hpp"

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

// ---------------------------------------------------------------- reading

class Reader {
 public:
  explicit Reader(std::string path) : path_(std::move(path)) {}

  [[noreturn]] void fail(const std::string& key, const std::string& what) const {
    throw ConfigError(path_ + ": key '" + key + "': " + what);
  }

  YAML::Node require(const YAML::Node& parent, const std::string& key,
                     const std::string& full) const {
    if (!parent.IsMap()) fail(full, "expected a mapping containing it");
    YAML::Node n = parent[key];
    if (!n) fail(full, "missing");
    return n;
  }

  double number(const YAML::Node& n, const std::string& full) const {
    if (!n.IsScalar()) fail(full, "expected a number");
    double v = 0.0;
    try {
      v = n.as<double>();
    } catch (const YAML::Exception&) {
      fail(full, "expected a number, got '" + n.Scalar() + "'");
    }
    if (!std::isfinite(v)) fail(full, "must be finite");
    return v;
  }

  double number(const YAML::Node& parent, const std::string& key, const std::string& full) const {
    return number(require(parent, key, full), full);
  }

  int integer(const YAML::Node& n, const std::string& full) const {
    if (!n.IsScalar()) fail(full, "expected an integer");
    try {
      return n.as<int>();
    } catch (const YAML::Exception&) {
      fail(full, "expected an integer, got '" + n.Scalar() + "'");
    }
  }

  std::vector<double> numbers(const YAML::Node& n, const std::string& full,
                              std::size_t expected) const {
    if (!n.IsSequence()) fail(full, "expected a list of " + std::to_string(expected) + " numbers");
    if (n.size() != expected) {
      fail(full,
           "expected " + std::to_string(expected) + " numbers, got " + std::to_string(n.size()));
    }
    std::vector<double> out;
    for (std::size_t i = 0; i < n.size(); ++i) {
      out.push_back(number(n[i], full + "[" + std::to_string(i) + "]"));
    }
    return out;
  }

  JointVector joints(const YAML::Node& parent, const std::string& key,
                     const std::string& full) const {
    const auto v = numbers(require(parent, key, full), full, kNumJoints);
    JointVector out;
    for (int i = 0; i < kNumJoints; ++i) out[i] = v[static_cast<std::size_t>(i)];
    return out;
  }

  Vec3 vec3(const YAML::Node& parent, const std::string& key, const std::string& full) const {
    const auto v = numbers(require(parent, key, full), full, 3);
    return Vec3(v[0], v[1], v[2]);
  }

  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

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
TrajectoryFile parseTrajectoryNode(const YAML::Node& root, const std::string& path);
}  // namespace

TrajectoryFile parseTrajectoryText(const std::string& text, const std::string& path) {
  const YAML::Node root = loadYamlStrict(text, path);
  try {
    return parseTrajectoryNode(root, path);
  } catch (const YAML::Exception& e) {
    // A node of an unexpected kind (found by fuzzing: a scalar where a mapping belongs).
    throw ConfigError(path + ":" + std::to_string(e.mark.line + 1) + ": unexpected structure: " + e.msg);
  }
}

namespace {
TrajectoryFile parseTrajectoryNode(const YAML::Node& root, const std::string& path) {
  Reader r(path);
  if (!root.IsMap()) r.fail("format", "file is not a YAML mapping");
  const YAML::Node fmt = r.require(root, "format", "format");
  if (!fmt.IsScalar() || fmt.Scalar() != kFormatTag) {
    r.fail("format", std::string("expected '") + kFormatTag + "'");
  }
  TrajectoryFile f;
  if (root["robot"]) f.robot = resolveRelativeTo(path, root["robot"].as<std::string>());

  const YAML::Node joints = r.require(root, "joints", "joints");
  if (!joints.IsSequence() || joints.size() == 0)
    r.fail("joints", "expected a non-empty list of joint numbers 1..6");
  for (std::size_t i = 0; i < joints.size(); ++i) {
    const int j = r.integer(joints[i], "joints[" + std::to_string(i) + "]");
    if (j < 1 || j > kNumJoints)
      r.fail("joints[" + std::to_string(i) + "]", "joint numbers are 1..6");
    f.joints.push_back(j);
  }
  f.q0 = r.joints(root, "q0", "q0");
  f.base_frequency_hz = r.number(root, "base_frequency_hz", "base_frequency_hz");
  if (f.base_frequency_hz <= 0.0) r.fail("base_frequency_hz", "must be positive");
  f.harmonics = r.integer(r.require(root, "harmonics", "harmonics"), "harmonics");
  if (f.harmonics < 1 || f.harmonics > FourierTrajectory::kMaxHarmonics) {
    r.fail("harmonics", "must be 1.." + std::to_string(FourierTrajectory::kMaxHarmonics));
  }
  f.duration_s = r.number(root, "duration_s", "duration_s");
  if (f.duration_s <= 0.0) r.fail("duration_s", "must be positive");
  f.servo_rate_hz = r.number(root, "servo_rate_hz", "servo_rate_hz");
  if (f.servo_rate_hz <= 0.0) r.fail("servo_rate_hz", "must be positive");

  const YAML::Node coeff = r.require(root, "coefficients", "coefficients");
  for (const char* which : {"a", "b"}) {
    const std::string key = std::string("coefficients.") + which;
    const YAML::Node rows = r.require(coeff, which, key);
    if (!rows.IsSequence() || rows.size() != static_cast<std::size_t>(kNumJoints)) {
      r.fail(key, "expected 6 rows (one per joint)");
    }
    auto& dst = (which[0] == 'a') ? f.a : f.b;
    for (int j = 0; j < kNumJoints; ++j) {
      const auto ju = static_cast<std::size_t>(j);
      const auto row = r.numbers(rows[ju], key + "[" + std::to_string(j) + "]",
                                 static_cast<std::size_t>(f.harmonics));
      for (int l = 0; l < f.harmonics; ++l)
        dst[ju][static_cast<std::size_t>(l)] = row[static_cast<std::size_t>(l)];
    }
  }

  if (const YAML::Node c = root["constraints"]) {
    auto& k = f.constraints;
    k.position_lower = r.joints(c, "position_lower", "constraints.position_lower");
    k.position_upper = r.joints(c, "position_upper", "constraints.position_upper");
    k.velocity = r.joints(c, "velocity", "constraints.velocity");
    k.acceleration = r.joints(c, "acceleration", "constraints.acceleration");
    k.floor_z_B = r.number(c, "floor_z", "constraints.floor_z");
    if (const YAML::Node tool = c["tool"]) {
      if (!tool.IsSequence()) r.fail("constraints.tool", "expected a list of {center, radius}");
      for (std::size_t i = 0; i < tool.size(); ++i) {
        const std::string key = "constraints.tool[" + std::to_string(i) + "]";
        ToolSphere s;
        s.center_S = r.vec3(tool[i], "center", key + ".center");
        s.radius = r.number(tool[i], "radius", key + ".radius");
        if (s.radius < 0.0) r.fail(key + ".radius", "must not be negative");
        k.tool.push_back(s);
      }
    }
    if (const YAML::Node ko = c["keep_out"]) {
      if (!ko.IsSequence())
        r.fail("constraints.keep_out", "expected a list of {name, center, radius}");
      for (std::size_t i = 0; i < ko.size(); ++i) {
        const std::string key = "constraints.keep_out[" + std::to_string(i) + "]";
        KeepOutSphere s;
        if (!ko[i].IsMap()) r.fail(key, "expected {name, center, radius}");
        if (ko[i]["name"]) s.name = ko[i]["name"].as<std::string>();
        s.center_B = r.vec3(ko[i], "center", key + ".center");
        s.radius = r.number(ko[i], "radius", key + ".radius");
        if (s.radius < 0.0) r.fail(key + ".radius", "must not be negative");
        k.keep_out.push_back(s);
      }
    }
    if (const YAML::Node m = c["sensor_mount"]) {
      const auto rot = r.numbers(r.require(m, "rotation", "constraints.sensor_mount.rotation"),
                                 "constraints.sensor_mount.rotation", 9);
      for (int i = 0; i < 9; ++i) k.R_FS(i / 3, i % 3) = rot[static_cast<std::size_t>(i)];
      if ((k.R_FS.transpose() * k.R_FS - Mat3::Identity()).norm() > 1e-6 ||
          k.R_FS.determinant() < 0.0) {
        r.fail("constraints.sensor_mount.rotation", "is not a rotation matrix");
      }
      k.p_FS_F = r.vec3(m, "translation", "constraints.sensor_mount.translation");
    }
  }
  auto readMap = [&](const char* key, auto& dst, bool numeric) {
    const YAML::Node m = root[key];
    if (!m || m.IsNull()) return;
    if (!m.IsMap()) r.fail(key, "expected a mapping");
    for (const auto& kv : m) {
      const std::string name = kv.first.as<std::string>();
      if constexpr (std::is_same_v<std::decay_t<decltype(dst)>, std::map<std::string, double>>) {
        (void)numeric;
        dst[name] = r.number(kv.second, std::string(key) + "." + name);
      } else {
        if (!kv.second.IsScalar()) r.fail(std::string(key) + "." + name, "expected a scalar");
        dst[name] = kv.second.Scalar();
      }
    }
  };
  readMap("design", f.design, false);
  readMap("metrics", f.metrics, true);
  readMap("predicted_std", f.predicted_std, true);

  // Rest-to-rest needs a whole number of base periods; reject files that cannot be rest-to-rest.
  const double periods = f.periods();
  if (std::abs(periods - std::round(periods)) > 1e-9 || std::round(periods) < 1.0) {
    r.fail("duration_s", "duration * base_frequency_hz = " + yamlNumberText(periods) +
                             " is not a whole number of base periods (rest-to-rest needs one)");
  }
  try {
    (void)f.toTrajectory();
  } catch (const std::invalid_argument& e) {
    r.fail("coefficients", e.what());
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
