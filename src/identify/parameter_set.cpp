// Parameter sets: conversion from fits, YAML parameter files, the --json object.
#include "ftid/identify/parameter_set.hpp"

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
#include "ftid/effects/model.hpp"
#include "ftid/effects/nonlinear.hpp"
#include "ftid/identify/fit.hpp"

namespace ftid::identify {

namespace {

std::string number(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[40];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (char ch : s) {
    switch (ch) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\t': out += "\\t"; break;
      case '\r': out += "\\r"; break;
      default:
        if (static_cast<unsigned char>(ch) < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof(buf), "\\u%04x", static_cast<unsigned>(static_cast<unsigned char>(ch)));
          out += buf;
        } else {
          out += ch;
        }
    }
  }
  return out + "\"";
}

std::string nowUtc() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

[[noreturn]] void fail(const std::string& path, const std::string& key, const std::string& what,
                       const YAML::Node* node = nullptr) {
  std::string where = path;
  if (node != nullptr && node->Mark().line >= 0) where += ":" + std::to_string(node->Mark().line + 1);
  throw ConfigError(where + ": key '" + key + "': " + what);
}

double readNumber(const YAML::Node& node, const std::string& path, const std::string& key) {
  if (!node || !node.IsScalar()) fail(path, key, "missing or not a number", &node);
  double v = 0.0;
  try {
    v = node.as<double>();
  } catch (const YAML::Exception&) {
    fail(path, key, "'" + node.Scalar() + "' is not a number", &node);
  }
  if (!std::isfinite(v)) fail(path, key, "value is not finite", &node);
  return v;
}

NamedValue readEntry(const YAML::Node& node, const std::string& name, const std::string& path,
                     const std::string& prefix) {
  const std::string key = prefix + "." + name;
  if (!node.IsMap()) fail(path, key, "expected {value, std, unit}", &node);
  NamedValue nv;
  nv.name = name;
  nv.value = readNumber(node["value"], path, key + ".value");
  if (node["std"]) nv.std = readNumber(node["std"], path, key + ".std");
  if (node["unit"]) nv.unit = node["unit"].as<std::string>();
  return nv;
}

void yamlEntry(std::ostream& os, const std::string& indent, const NamedValue& p) {
  os << indent << p.name << ": {value: " << number(p.value) << ", std: " << number(p.std)
     << ", unit: " << quoted(p.unit) << "}\n";
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

ParameterSet toParameterSet(const FitResult& fit) {
  ParameterSet set;
  set.model = fit.model_name;
  for (std::size_t j = 0; j < fit.params.size(); ++j) {
    const auto e = static_cast<Eigen::Index>(j);
    set.params.push_back({fit.params[j].name, fit.theta(e), fit.theta_std(e), fit.params[j].unit});
  }
  for (const auto& d : fit.derived) set.derived.push_back({d.name, d.value, d.std, d.unit});
  set.tilt_estimated = fit.tilt_estimated;
  set.tilt_u_rad = fit.tilt_u_rad;
  set.tilt_v_rad = fit.tilt_v_rad;
  set.tilt_u_std = fit.tilt_u_std;
  set.tilt_v_std = fit.tilt_v_std;
  if (fit.mounting_estimated) {
    for (int k = 0; k < 3; ++k) {
      set.params.push_back({effects::kMountParamNames[k], fit.mount_rpy_rad(k), fit.mount_rpy_std(k), "rad"});
    }
  }
  if (fit.delay_estimated) set.params.push_back({effects::kDelayParamName, fit.delay_s, fit.delay_std, "s"});
  set.residual_rms = fit.residual_rms;
  set.condition_number = fit.condition_number;
  set.extras.push_back({"tilt_iterations", static_cast<double>(fit.tilt_iterations), 0.0, ""});
  set.extras.push_back({"residual_variance_weighted", fit.sigma2, 0.0, ""});
  set.provenance.method = "fit";
  set.provenance.n_samples = fit.n_samples;
  return set;
}

Eigen::VectorXd thetaFor(const effects::Model& model, const ParameterSet& set, const std::string& source) {
  const auto& names = model.paramIndex().names();
  Eigen::VectorXd theta(static_cast<Eigen::Index>(names.size()));
  for (std::size_t j = 0; j < names.size(); ++j) {
    const NamedValue* p = nullptr;
    for (const auto& q : set.params) {
      if (q.name == names[j]) p = &q;
    }
    if (p == nullptr) {
      throw ConfigError(source + ": key 'parameters." + names[j] + "' is missing (model '" +
                        model.name() + "' needs it)");
    }
    theta(static_cast<Eigen::Index>(j)) = p->value;
  }
  return theta;
}

effects::NonlinearParams nonlinearFor(const effects::Model& model, const ParameterSet& set,
                                      const std::string& source) {
  effects::NonlinearParams nl;
  nl.tilt_u_rad = set.tilt_u_rad;
  nl.tilt_v_rad = set.tilt_v_rad;
  auto need = [&](const char* name) {
    for (const auto& q : set.params) {
      if (q.name == name) {
        if (!std::isfinite(q.value)) throw ConfigError(source + ": key 'parameters." + name + "' is not finite");
        return q.value;
      }
    }
    throw ConfigError(source + ": key 'parameters." + name + "' is missing (model '" + model.name() +
                      "' needs it)");
  };
  if (model.estimatesMounting()) {
    for (int k = 0; k < 3; ++k) nl.mount_rpy_rad(k) = need(effects::kMountParamNames[k]);
  }
  if (model.estimatesDelay()) nl.delay_s = need(effects::kDelayParamName);
  return nl;
}

ParameterSet readParameterFile(const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw ConfigError(path + ": cannot open the parameter file");
  } catch (const YAML::ParserException& e) {
    throw ConfigError(path + ":" + std::to_string(e.mark.line + 1) + ": YAML syntax error: " + e.msg);
  }
  if (!root.IsMap()) throw ConfigError(path + ": not a parameter file (expected a YAML mapping)");
  ParameterSet set;
  try {
    const YAML::Node model = root["model"];
    if (!model || !model.IsScalar()) fail(path, "model", "missing (e.g. 'model: paper')");
    set.model = model.as<std::string>();
    const YAML::Node params = root["parameters"];
    if (!params || !params.IsMap()) fail(path, "parameters", "missing or not a mapping");
    for (const auto& kv : params) {
      set.params.push_back(readEntry(kv.second, kv.first.as<std::string>(), path, "parameters"));
    }
    if (const YAML::Node derived = root["derived"]) {
      if (!derived.IsMap()) fail(path, "derived", "not a mapping", &derived);
      for (const auto& kv : derived) {
        set.derived.push_back(readEntry(kv.second, kv.first.as<std::string>(), path, "derived"));
      }
    }
    if (const YAML::Node tilt = root["tilt"]) {
      if (!tilt.IsMap()) fail(path, "tilt", "not a mapping", &tilt);
      if (tilt["estimated"]) set.tilt_estimated = tilt["estimated"].as<bool>();
      const NamedValue u = readEntry(tilt["u"], "u", path, "tilt");
      const NamedValue v = readEntry(tilt["v"], "v", path, "tilt");
      set.tilt_u_rad = u.value;
      set.tilt_u_std = u.std;
      set.tilt_v_rad = v.value;
      set.tilt_v_std = v.std;
    }
    if (const YAML::Node prov = root["provenance"]) {
      if (prov["date"]) set.provenance.date_utc = prov["date"].as<std::string>();
      if (prov["data_file"]) set.provenance.data_file = prov["data_file"].as<std::string>();
      if (prov["method"]) set.provenance.method = prov["method"].as<std::string>();
      if (prov["trajectory"]) set.provenance.trajectory = prov["trajectory"].as<std::string>();
      if (prov["n_samples"]) set.provenance.n_samples = prov["n_samples"].as<int>();
      if (const YAML::Node rms = prov["residual_rms"]) {
        for (int a = 0; a < 6; ++a) {
          if (rms[kWrenchAxisNames[a]]) {
            set.residual_rms(a) = readNumber(rms[kWrenchAxisNames[a]], path,
                                             std::string("provenance.residual_rms.") + kWrenchAxisNames[a]);
          }
        }
      }
      if (prov["condition_number"]) {
        set.condition_number = prov["condition_number"].as<double>();
      }
    }
  } catch (const YAML::Exception& e) {
    throw ConfigError(path + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
  return set;
}

void writeParameterFile(const std::string& path, const ParameterSet& set) {
  std::ostringstream os;
  os << "# ftid payload parameters, written by `ftid identify` (docs/identification.md).\n"
        "# Frames, units and signs: docs/conventions.md. Each entry: {value, std (standard error), unit}.\n"
        "# `parameters` are the model's parameters (what compensation uses): the linear ones and,\n"
        "# for `mounting` / `sensor_delay`, mount_roll/pitch/yaw [rad] and delay [s];\n"
        "# `derived` (centre of mass, weight) and `provenance` are for information.\n";
  os << "model: " << quoted(set.model) << "\n";
  os << "parameters:\n";
  for (const auto& p : set.params) yamlEntry(os, "  ", p);
  if (!set.derived.empty()) {
    os << "derived:\n";
    for (const auto& p : set.derived) yamlEntry(os, "  ", p);
  }
  os << "tilt:  # base mounting tilt R_WB = Rx(u) Ry(v)\n";
  os << "  estimated: " << (set.tilt_estimated ? "true" : "false") << "\n";
  yamlEntry(os, "  ", {"u", set.tilt_u_rad, set.tilt_u_std, "rad"});
  yamlEntry(os, "  ", {"v", set.tilt_v_rad, set.tilt_v_std, "rad"});
  os << "provenance:\n";
  os << "  date: " << quoted(set.provenance.date_utc.empty() ? nowUtc() : set.provenance.date_utc) << "\n";
  os << "  data_file: " << quoted(set.provenance.data_file) << "\n";
  os << "  model: " << quoted(set.model) << "\n";
  os << "  method: " << quoted(set.provenance.method) << "\n";
  os << "  trajectory: " << quoted(set.provenance.trajectory) << "\n";
  os << "  n_samples: " << set.provenance.n_samples << "\n";
  os << "  residual_rms: {";
  for (int a = 0; a < 6; ++a) os << (a ? ", " : "") << kWrenchAxisNames[a] << ": " << number(set.residual_rms(a));
  os << "}\n";
  os << "  condition_number: " << number(set.condition_number) << "\n";

  // Atomic replacement: write a temporary file in the same directory, fsync it, keep the previous
  // file as PATH.bak, rename over PATH, fsync the directory. Any failure leaves PATH untouched.
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  const std::string text = os.str();
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw ConfigError(path + ": cannot create " + tmp + " (" + std::strerror(errno) + ")");
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = errno;
      ::close(fd);
      std::remove(tmp.c_str());
      throw ConfigError(path + ": write failed (" + std::strerror(err) + ")");
    }
    done += static_cast<std::size_t>(n);
  }
  if (::fsync(fd) != 0 || ::close(fd) != 0) {
    const int err = errno;
    std::remove(tmp.c_str());
    throw ConfigError(path + ": write failed (" + std::strerror(err) + ")");
  }
  if (std::ifstream(path).good()) {
    const std::string bak = path + ".bak";
    std::remove(bak.c_str());
    if (::link(path.c_str(), bak.c_str()) != 0) {
      // Filesystems without hard links: copy instead.
      std::ifstream src(path, std::ios::binary);
      std::ofstream dst(bak, std::ios::binary | std::ios::trunc);
      dst << src.rdbuf();
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    std::remove(tmp.c_str());
    throw ConfigError(path + ": cannot rename the temporary file into place (" + std::strerror(err) + ")");
  }
  const std::string dir = path.find('/') == std::string::npos ? "." : path.substr(0, path.rfind('/') + 1);
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
}

std::string toJson(const ParameterSet& set) {
  std::ostringstream os;
  os << "{\"model\":" << quoted(set.model) << ",\"method\":" << quoted(set.provenance.method)
     << ",\"n_samples\":" << set.provenance.n_samples << ",\"parameters\":{";
  bool first = true;
  auto entry = [&](const std::string& name, double value, double sd) {
    os << (first ? "" : ",") << quoted(name) << ":{\"value\":" << number(value) << ",\"std\":" << number(sd) << "}";
    first = false;
  };
  std::vector<std::string> done;
  for (const char* name : {"mass", "weight", "com_x", "com_y", "com_z", "f0_x", "f0_y", "f0_z", "t0_x",
                           "t0_y", "t0_z"}) {
    if (const NamedValue* p = set.find(name)) {
      entry(name, p->value, p->std);
      done.push_back(name);
    }
  }
  entry("tilt_u", set.tilt_u_rad, set.tilt_u_std);
  entry("tilt_v", set.tilt_v_rad, set.tilt_v_std);
  for (const auto& p : set.params) {
    if (std::find(done.begin(), done.end(), p.name) == done.end()) entry(p.name, p.value, p.std);
  }
  os << "},\"residual_rms\":{";
  for (int a = 0; a < 6; ++a) os << (a ? "," : "") << quoted(kWrenchAxisNames[a]) << ":" << number(set.residual_rms(a));
  os << "},\"condition_number\":" << number(set.condition_number);
  os << ",\"tilt_estimated\":" << (set.tilt_estimated ? "true" : "false");
  os << ",\"units\":{";
  first = true;
  for (const auto* group : {&set.params, &set.derived}) {
    for (const auto& p : *group) {
      os << (first ? "" : ",") << quoted(p.name) << ":" << quoted(p.unit);
      first = false;
    }
  }
  os << (first ? "" : ",") << "\"tilt_u\":\"rad\",\"tilt_v\":\"rad\"}";
  os << ",\"extras\":{";
  for (std::size_t i = 0; i < set.extras.size(); ++i) {
    os << (i ? "," : "") << quoted(set.extras[i].name) << ":" << number(set.extras[i].value);
  }
  os << "},\"data_file\":" << quoted(set.provenance.data_file) << "}";
  return os.str();
}

}  // namespace ftid::identify
