#include "ftid/daemon/tare.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iterator>
#include <sstream>
#include <vector>

#include "ftid/common/error.hpp"
#include "ftid/daemon/reloader.hpp"
#include "ftid/fileio/atomic_file.hpp"
#include "ftid/fileio/input_file.hpp"
#include "ftid/fileio/yaml_emit.hpp"
#include "ftid/fileio/yaml_reader.hpp"
#include "ftid/transport/hmac_sha256.hpp"

namespace ftid::daemon {

const char* const kOffsetNames[6] = {"f0_x", "f0_y", "f0_z", "t0_x", "t0_y", "t0_z"};

namespace {

std::string hexOf(const transport::Sha256Digest& d) {
  static const char* digits = "0123456789abcdef";
  std::string s;
  for (const std::uint8_t b : d) {
    s += digits[b >> 4];
    s += digits[b & 0xF];
  }
  return s;
}

}  // namespace

Wrench offsetsOf(const params::ParameterSet& set, const std::string& source) {
  Wrench w;
  for (int i = 0; i < 6; ++i) {
    const params::NamedValue* v = nullptr;
    for (const auto& p : set.params) {
      if (p.name == kOffsetNames[i]) v = &p;
    }
    if (v == nullptr) {
      throw ConfigError(source + ": key 'parameters." + kOffsetNames[i] +
                        "': missing (a tare adjusts the offsets f0_x..t0_z)");
    }
    w(i) = v->value;
  }
  return w;
}

void setOffsets(params::ParameterSet* set, const Wrench& offsets) {
  for (int i = 0; i < 6; ++i) {
    for (auto& p : set->params) {
      if (p.name == kOffsetNames[i]) {
        p.value = offsets(i);
        p.std = 0.0;
      }
    }
  }
}

std::string tareStatePath(const std::string& parameter_path) { return parameter_path + ".tare.yaml"; }

void writeTareState(const std::string& path, const TareState& state) {
  YAML::Emitter out;
  out << YAML::BeginMap;
  out << YAML::Key << "parameter_sha256" << YAML::Value << state.parameter_sha256;
  out << YAML::Key << "utime" << YAML::Value << state.utime;
  out << YAML::Key << "cycles" << YAML::Value << state.cycles;
  out << YAML::Key << "offsets" << YAML::Value << YAML::Comment("N (f0) and Nm (t0), in the sensor frame S")
      << YAML::BeginMap;
  for (int i = 0; i < 6; ++i) out << YAML::Key << kOffsetNames[i] << YAML::Value << YamlNumber{state.offsets(i)};
  out << YAML::EndMap << YAML::EndMap;
  writeFileAtomically(path, yamlDocument("# ftidd tare state (docs/daemon.md, \"Tare\"): offsets measured by a TARE command.\n"
                                         "# Applied only to the parameter file whose SHA-256 is parameter_sha256; a reload\n"
                                         "# (SIGHUP or RELOAD_PARAMETERS) deletes this file. Written by ftidd; do not edit.\n",
                                         out));
}

std::optional<TareState> readTareState(const std::string& path) {
  struct stat st {};
  if (::lstat(path.c_str(), &st) != 0 && errno == ENOENT) return std::nullopt;
  const YamlFile file = YamlFile::load(path, "tare state file");
  const YamlValue root = file.root();
  root.expectMap("expected a mapping (tare state file)");
  root.onlyKeys({"parameter_sha256", "utime", "cycles", "offsets"});
  TareState s;
  const YamlValue sha = root.required("parameter_sha256");
  s.parameter_sha256 = sha.text();
  if (s.parameter_sha256.size() != 64) sha.fail("expected 64 hex digits");
  s.utime = root.required("utime").integer();
  s.cycles = static_cast<std::uint32_t>(root.required("cycles").integer(0, 4294967295LL));
  const YamlValue off = root.required("offsets").expectMap();
  off.onlyKeys(std::vector<std::string>(std::begin(kOffsetNames), std::end(kOffsetNames)));
  for (int i = 0; i < 6; ++i) s.offsets(i) = off.required(kOffsetNames[i]).number();
  return s;
}

void removeTareState(const std::string& path) {
  if (::unlink(path.c_str()) != 0 && errno != ENOENT) {
    throw FileError(path + ": cannot remove the tare state (" + std::strerror(errno) + ")");
  }
}

LoadedParameters loadParameters(const std::string& path, bool apply_tare) {
  // Never block on a FIFO, a device or a pipe named as the parameter file (issue 14).
  if (const std::string problem = regularFileProblem(path); !problem.empty()) throw ConfigError(problem);
  LoadedParameters out;
  const std::string text = readInputFile(path, "parameter file");
  out.sha256 = hexOf(transport::sha256(text.data(), text.size()));
  out.set = params::parseParameterText(text, path);
  if (!apply_tare) return out;
  const std::string tare_path = tareStatePath(path);
  std::optional<TareState> state;
  try {
    state = readTareState(tare_path);
  } catch (const Error& e) {
    out.note = std::string("tare state ignored: ") + e.what();
    return out;
  }
  if (!state) return out;
  if (state->parameter_sha256 != out.sha256) {
    out.note = "tare state ignored: " + tare_path + " belongs to other content of " + path;
    return out;
  }
  offsetsOf(out.set, path);  // the model must have the offsets
  setOffsets(&out.set, state->offsets);
  out.tared = true;
  return out;
}

}  // namespace ftid::daemon
