// Parameter files (YAML): reading, validation, atomic writing (the --json object: json.cpp). Needs no fit
// or effect machinery (only the inertia math), so the parameter_yaml fuzz target links just this.
#include "ftid/params/parameter_set.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <sstream>

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "ftid/common/error.hpp"
#include "ftid/effects/rigid_body.hpp"
#include "ftid/fileio/atomic_file.hpp"
#include "ftid/fileio/input_file.hpp"
#include "ftid/fileio/yaml_emit.hpp"
#include "ftid/fileio/yaml_reader.hpp"

namespace ftid::params {

namespace {

std::string number(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[40];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

std::string nowUtc() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

/// ISO 8601 UTC with milliseconds (informational beside the number).
std::string utcText(double unix_s) {
  const auto secs = static_cast<std::time_t>(std::floor(unix_s));
  std::tm tm{};
  gmtime_r(&secs, &tm);
  char buf[48];
  std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%S", &tm);
  char out[64];
  std::snprintf(out, sizeof(out), "%s.%03dZ", buf,
                std::min(999, static_cast<int>((unix_s - std::floor(unix_s)) * 1000.0)));
  return out;
}

/// One `{value, std, unit}` entry.
NamedValue readEntry(const YamlValue& entry, const std::string& name) {
  entry.expectMap("expected {value, std, unit}");
  entry.onlyKeys({"value", "std", "unit"});
  NamedValue nv;
  nv.name = name;
  nv.value = entry.required("value").number();
  if (const YamlValue std_dev = entry["std"]) nv.std = std_dev.number();
  nv.unit = entry["unit"].textOr(nv.unit);
  return nv;
}

void yamlEntry(YAML::Emitter& out, const NamedValue& p) {
  out << YAML::Key << p.name << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "value" << YAML::Value
      << YamlNumber{p.value} << YAML::Key << "std" << YAML::Value << YamlNumber{p.std} << YAML::Key << "unit"
      << YAML::Value << YAML::DoubleQuoted << p.unit << YAML::EndMap;
}

}  // namespace

const NamedValue* ParameterSet::find(const std::string& name) const {
  for (const auto& p : params) {
    if (p.name == name) return &p;
  }
  for (const auto& p : derived) {
    if (p.name == name) return &p;
  }
  return nullptr;
}

std::optional<ParameterProblem> findParameterProblem(const ParameterSet& set) {
  auto bad = [](const std::string& key, const std::string& msg) {
    return std::optional<ParameterProblem>(ParameterProblem{key, msg});
  };
  for (const auto* group : {&set.params, &set.derived, &set.imu}) {
    const std::string prefix = group == &set.params ? "parameters." : (group == &set.imu ? "imu." : "derived.");
    for (const auto& p : *group) {
      if (!std::isfinite(p.value)) return bad(prefix + p.name, "value is not finite");
      if (!std::isfinite(p.std)) return bad(prefix + p.name, "standard error is not finite");
      if (p.std < 0.0) return bad(prefix + p.name, "standard error is negative");
    }
  }
  for (const auto& b : set.imu) {
    // A working MEMS IMU's bias is a few 0.01 m/s^2 and 0.001 rad/s; far beyond: a broken IMU or
    // a hand-edited file, whose subtraction would corrupt the compensation with the IMU's motion.
    const bool acc = b.name.rfind("acc_", 0) == 0;
    const double limit = acc ? kMaxImuAccBias_mps2 : kMaxImuGyroBias_radps;
    if (std::abs(b.value) > limit) {
      char text[96];
      std::snprintf(text, sizeof(text), "bias %.6g %s is beyond %g", b.value, acc ? "m/s^2" : "rad/s", limit);
      return bad("imu." + b.name, std::string(text) + " (no working IMU has it: a broken IMU or a wrong unit)");
    }
  }
  if (!std::isfinite(set.tilt_u_rad) || !std::isfinite(set.tilt_u_std)) return bad("tilt.u", "not finite");
  if (!std::isfinite(set.tilt_v_rad) || !std::isfinite(set.tilt_v_std)) return bad("tilt.v", "not finite");
  for (int a = 0; a < 6; ++a) {
    if (!std::isfinite(set.residual_rms(a))) {
      return bad(std::string("provenance.residual_rms.") + kWrenchAxisNames[a], "not finite");
    }
  }
  if (!std::isfinite(set.condition_number)) return bad("provenance.condition_number", "not finite");
  if (std::isinf(set.time_origin_unix_s) || set.time_origin_unix_s < 0.0) {
    return bad("time_origin.unix_s", "not a finite, non-negative Unix time");
  }
  const auto findParam = [&](const char* name) -> const NamedValue* {
    for (const auto& p : set.params) {
      if (p.name == name) return &p;
    }
    return nullptr;
  };
  const NamedValue* mass = findParam("mass");
  if (mass != nullptr && !(mass->value > 0.0)) {
    return bad("parameters.mass", "mass " + number(mass->value) + " kg is not positive (a payload has a positive mass)");
  }
  const NamedValue* is[6];
  int n_is = 0;
  for (int k = 0; k < 6; ++k) {
    is[k] = findParam(effects::kInertiaParamNames[k]);
    if (is[k] != nullptr) ++n_is;
  }
  if (n_is > 0 && mass != nullptr) {
    Eigen::Matrix<double, 10, 1> p = Eigen::Matrix<double, 10, 1>::Zero();
    Eigen::Matrix<double, 10, 10> cov = Eigen::Matrix<double, 10, 10>::Zero();
    p(0) = mass->value;
    cov(0, 0) = mass->std * mass->std;
    const char* mc[3] = {"mass_com_x", "mass_com_y", "mass_com_z"};
    for (int k = 0; k < 3; ++k) {
      if (const NamedValue* v = findParam(mc[k])) {
        p(1 + k) = v->value;
        cov(1 + k, 1 + k) = v->std * v->std;
      }
    }
    for (int k = 0; k < 6; ++k) {
      if (is[k] != nullptr) {
        p(4 + k) = is[k]->value;
        cov(4 + k, 4 + k) = is[k]->std * is[k]->std;
      }
    }
    if (n_is != 6) return bad("parameters.i_s_xx", "the inertia needs all six i_s_* parameters");
    const effects::InertiaAboutCom ic = effects::inertiaAboutCom(p, cov);
    // Physically impossible whatever the standard errors (issue 26): no body has a negative
    // principal moment about its centre of mass or one larger than the sum of the other two. A
    // standard error says how well the fit knows the tensor, not that an impossible one may be
    // used. The tolerance only absorbs rounding (I_C = I_S - m [c]x^T [c]x cancels digits).
    const Vec3& l = ic.principal;
    const double scale = std::max(l.cwiseAbs().maxCoeff(), p.tail<3>().cwiseAbs().maxCoeff() +
                                                               p.segment<3>(4).cwiseAbs().maxCoeff());
    const double tol = kInertiaRelativeTolerance * scale + 1e-12;
    if (l(0) < -tol) {
      return bad("parameters.i_s_xx", "invalid inertia: physically impossible (a negative principal moment about the "
                                      "centre of mass, whatever its standard error): " + ic.explanation);
    }
    if (l(2) > l(0) + l(1) + tol) {
      return bad("parameters.i_s_xx", "invalid inertia: physically impossible (triangle inequality violated, whatever "
                                      "its standard error): " + ic.explanation);
    }
  }
  return std::nullopt;
}

ParameterSet readParameterFile(const std::string& path) {
  std::string text;
  try {
    text = readInputFile(path, "parameter file", kMaxTextConfigBytes);
  } catch (const FileError& e) {
    throw ConfigError(e.what());
  }
  return parseParameterText(text, path);
}

ParameterSet parseParameterText(const std::string& text, const std::string& path) {
  const YamlFile file = YamlFile::parse(text, path);
  const YamlValue root = file.root();
  root.expectMap("not a parameter file (expected a YAML mapping)");
  root.onlyKeys({"model", "parameters", "derived", "tilt", "time_origin", "imu", "provenance"});
  ParameterSet set;
  const YamlValue model = root["model"];
  if (!model.isScalar()) model.fail("missing (e.g. 'model: paper')");
  set.model = model.text();
  // Parameter names are checked against the model where the set is used (thetaFor).
  for (const auto& [name, entry] : root.required("parameters").expectMap().entries()) {
    set.params.push_back(readEntry(entry, name));
  }
  if (const YamlValue derived = root["derived"]) {
    for (const auto& [name, entry] : derived.entries()) set.derived.push_back(readEntry(entry, name));
  }
  if (const YamlValue tilt = root["tilt"]) {
    tilt.expectMap().onlyKeys({"estimated", "u", "v"});
    set.tilt_estimated = tilt["estimated"].booleanOr(set.tilt_estimated);
    const NamedValue u = readEntry(tilt.required("u"), "u");
    const NamedValue v = readEntry(tilt.required("v"), "v");
    set.tilt_u_rad = u.value;
    set.tilt_u_std = u.std;
    set.tilt_v_rad = v.value;
    set.tilt_v_std = v.std;
  }
  if (const YamlValue origin = root["time_origin"]) {  // optional: older files have none
    origin.expectMap("expected {unix_s, utc}");
    origin.onlyKeys({"unix_s", "utc"});
    set.time_origin_unix_s = origin.required("unix_s").number(NumberRange::nonNegative("must be a non-negative Unix time [s]"));
  }
  if (const YamlValue imu = root["imu"]) {  // optional: written when identify used the IMU
    imu.expectMap("expected the IMU's biases, e.g. 'gyro_bias_x: {value: 0.001, std: 0.0001, unit: \"rad/s\"}'");
    imu.onlyKeys(std::vector<std::string>(std::begin(kImuBiasNames), std::end(kImuBiasNames)));
    for (const auto& [name, entry] : imu.entries()) set.imu.push_back(readEntry(entry, name));
  }
  if (const YamlValue prov = root["provenance"]) {
    prov.onlyKeys({"date", "data_file", "model", "method", "trajectory", "n_samples", "residual_rms",
                   "condition_number"});
    auto& p = set.provenance;
    p.date_utc = prov["date"].textOr(p.date_utc);
    p.data_file = prov["data_file"].textOr(p.data_file);
    p.method = prov["method"].textOr(p.method);
    p.trajectory = prov["trajectory"].textOr(p.trajectory);
    if (const YamlValue n = prov["n_samples"]) p.n_samples = static_cast<int>(n.integer(0, 2147483647));
    if (const YamlValue rms = prov["residual_rms"]) {
      rms.onlyKeys({"fx", "fy", "fz", "tx", "ty", "tz"});
      for (int a = 0; a < 6; ++a) set.residual_rms(a) = rms[kWrenchAxisNames[a]].numberOr(set.residual_rms(a));
    }
    set.condition_number = prov["condition_number"].numberOr(set.condition_number);
  }
  if (const auto problem = findParameterProblem(set)) {
    // Name the offending key's position when it is in the file ("parameters.mass", "tilt.u").
    YamlValue at = root;
    std::size_t begin = 0;
    while (at.isMap() && begin <= problem->key.size()) {
      const std::size_t dot = problem->key.find('.', begin);
      const std::string part = problem->key.substr(begin, dot == std::string::npos ? std::string::npos : dot - begin);
      at = at[part];
      if (dot == std::string::npos) break;
      begin = dot + 1;
    }
    if (at.present() && at.key() == problem->key) at.fail(problem->message);
    throw ConfigError(path + ": key '" + problem->key + "': " + problem->message);
  }
  return set;
}

void writeParameterFile(const std::string& path, const ParameterSet& set) {
  if (const auto problem = findParameterProblem(set)) {
    throw IdentificationError(path + ": not written (the previous file is untouched): '" + problem->key + "': " +
                              problem->message);
  }
  const std::string header =
      "# ftid payload parameters, written by `ftid identify` (docs/identification.md).\n"
      "# Frames, units and signs: docs/conventions.md. Each entry: {value, std (standard error), unit}.\n"
      "# `parameters` are the linear parameters of the model (what compensation uses);\n"
      "# `derived` (centre of mass, weight) and `provenance` are for information.\n";
  YAML::Emitter out;
  out << YAML::BeginMap;
  out << YAML::Key << "model" << YAML::Value << YAML::DoubleQuoted << set.model;
  out << YAML::Key << "parameters" << YAML::Value << YAML::BeginMap;
  for (const auto& p : set.params) yamlEntry(out, p);
  out << YAML::EndMap;
  if (!set.derived.empty()) {
    out << YAML::Key << "derived" << YAML::Value << YAML::BeginMap;
    for (const auto& p : set.derived) yamlEntry(out, p);
    out << YAML::EndMap;
  }
  out << YAML::Key << "tilt" << YAML::Value << YAML::Comment("base mounting tilt R_WB = Rx(u) Ry(v)") << YAML::BeginMap;
  out << YAML::Key << "estimated" << YAML::Value << set.tilt_estimated;
  yamlEntry(out, {"u", set.tilt_u_rad, set.tilt_u_std, "rad"});
  yamlEntry(out, {"v", set.tilt_v_rad, set.tilt_v_std, "rad"});
  out << YAML::EndMap;
  if (std::isfinite(set.time_origin_unix_s)) {
    out << YAML::Key << "time_origin" << YAML::Value
        << YAML::Comment("time_drift and the t signal: seconds since this instant (docs/conventions.md)")
        << YAML::Flow << YAML::BeginMap << YAML::Key << "unix_s" << YAML::Value
        << YamlNumber{set.time_origin_unix_s} << YAML::Key << "utc" << YAML::Value << YAML::DoubleQuoted
        << utcText(set.time_origin_unix_s) << YAML::EndMap;
  }
  if (!set.imu.empty()) {
    out << YAML::Key << "imu" << YAML::Value
        << YAML::Comment("the IMU's biases in its frame (compensation with the motion from the IMU)")
        << YAML::BeginMap;
    for (const auto& p : set.imu) yamlEntry(out, p);
    out << YAML::EndMap;
  }
  out << YAML::Key << "provenance" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "date" << YAML::Value << YAML::DoubleQuoted
      << (set.provenance.date_utc.empty() ? nowUtc() : set.provenance.date_utc);
  out << YAML::Key << "data_file" << YAML::Value << YAML::DoubleQuoted << set.provenance.data_file;
  out << YAML::Key << "model" << YAML::Value << YAML::DoubleQuoted << set.model;
  out << YAML::Key << "method" << YAML::Value << YAML::DoubleQuoted << set.provenance.method;
  out << YAML::Key << "trajectory" << YAML::Value << YAML::DoubleQuoted << set.provenance.trajectory;
  out << YAML::Key << "n_samples" << YAML::Value << set.provenance.n_samples;
  out << YAML::Key << "residual_rms" << YAML::Value << YAML::Flow << YAML::BeginMap;
  for (int a = 0; a < 6; ++a) out << YAML::Key << kWrenchAxisNames[a] << YAML::Value << YamlNumber{set.residual_rms(a)};
  out << YAML::EndMap;
  out << YAML::Key << "condition_number" << YAML::Value << YamlNumber{set.condition_number};
  out << YAML::EndMap;  // provenance
  out << YAML::EndMap;
  const std::string text = yamlDocument(header, out);

  // Atomic replacement (ftid/fileio/atomic_file.hpp); the previous file is kept as PATH.bak.
  AtomicWriteOptions options;
  options.keep_backup = true;
  try {
    writeFileAtomically(path, text, options);
  } catch (const FileError& e) {
    throw ConfigError(e.what());
  }
}

}  // namespace ftid::params
