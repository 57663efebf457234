#include "ftid/trajectory/cell_limits.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <cstdio>
#include <sstream>

#include "ftid/common/default_files.hpp"
#include "ftid/common/error.hpp"
#include "ftid/fileio/input_file.hpp"
#include "ftid/fileio/yaml_reader.hpp"

namespace ftid::trajectory {

CellLimits readCellLimits(const std::string& path) {
  std::string text;
  try {
    text = readInputFile(path, "cell limits file", kMaxTextConfigBytes);
  } catch (const FileError& e) {
    throw ConfigError(e.what());
  }
  return parseCellLimitsText(text, path);
}

CellLimits parseCellLimitsText(const std::string& text, const std::string& path) {
  const YamlFile file = YamlFile::parse(text, path);
  const YamlValue root = file.root();
  root.expectMap("not a cell limits file (expected a mapping with `limits:`)");
  root.onlyKeys({"limits"});
  const YamlValue l = root.required("limits");
  l.expectMap("expected position_lower, position_upper, velocity, acceleration, floor_z, keep_out");
  CellLimits c;
  c.path = path;
  c.position_lower = l.required("position_lower").vector<kNumJoints>();
  c.position_upper = l.required("position_upper").vector<kNumJoints>();
  c.velocity = l.required("velocity").vector<kNumJoints>();
  c.acceleration = l.required("acceleration").vector<kNumJoints>();
  c.floor_z_B = l.required("floor_z").number();
  for (int j = 0; j < kNumJoints; ++j) {
    if (!(c.position_lower(j) < c.position_upper(j))) l["position_upper"].fail("must be above position_lower for every joint");
    if (!(c.velocity(j) > 0.0)) l["velocity"].fail("must be positive for every joint");
    if (!(c.acceleration(j) > 0.0)) l["acceleration"].fail("must be positive for every joint");
  }
  if (const YamlValue ko = l["keep_out"]) {
    ko.expectSequence("expected a list of {name, center, radius}");
    for (const YamlValue& o : ko.elements()) {
      o.expectMap("expected {name, center, radius}");
      KeepOutSphere s;
      s.name = o["name"].textOr("");
      s.center_B = o.required("center").vector<3>();
      s.radius = o.required("radius").number(NumberRange::nonNegative("must not be negative"));
      o.onlyKeys({"name", "center", "radius"});
      c.keep_out.push_back(s);
    }
  }
  l.onlyKeys({"position_lower", "position_upper", "velocity", "acceleration", "floor_z", "keep_out"});
  return c;
}

std::string defaultCellLimitsPath() {
  struct stat st {};
  if (::stat(kInstalledCellLimitsPath, &st) == 0 && S_ISREG(st.st_mode)) return kInstalledCellLimitsPath;
  return findDefaultFile("cell_limits.yaml");
}

std::vector<CellLimits> applicableCellLimits(const std::string& extra_path, const std::string& installed_path) {
  std::vector<CellLimits> out;
  struct stat st {};
  if (!installed_path.empty() && ::stat(installed_path.c_str(), &st) == 0 && S_ISREG(st.st_mode)) {
    out.push_back(readCellLimits(installed_path));
  }
  if (!extra_path.empty() && (out.empty() || extra_path != installed_path)) out.push_back(readCellLimits(extra_path));
  if (out.empty()) out.push_back(readCellLimits(findDefaultFile("cell_limits.yaml")));
  return out;
}

TrajectoryConstraints effectiveConstraints(const TrajectoryConstraints& traj, const std::string& traj_source,
                                           const std::vector<CellLimits>& cells, LimitSources* sources) {
  TrajectoryConstraints e = traj;
  LimitSources s;
  bool first = true;
  const std::string prev = "\x01previous";  // a limit kept from the step before
  for (const CellLimits& cell : cells) {
    LimitSources step;
    e = effectiveConstraints(e, first ? traj_source : prev, cell, &step);
    if (!first) {
      const auto keep = [&prev](std::string* now, const std::string& before) {
        if (*now == prev) *now = before;
      };
      for (std::size_t j = 0; j < static_cast<std::size_t>(kNumJoints); ++j) {
        keep(&step.position_lower[j], s.position_lower[j]);
        keep(&step.position_upper[j], s.position_upper[j]);
        keep(&step.velocity[j], s.velocity[j]);
        keep(&step.acceleration[j], s.acceleration[j]);
      }
      keep(&step.floor_z, s.floor_z);
      for (std::size_t k = 0; k < step.keep_out.size() && k < s.keep_out.size(); ++k) keep(&step.keep_out[k], s.keep_out[k]);
    }
    s = std::move(step);
    first = false;
  }
  if (sources != nullptr) *sources = std::move(s);
  return e;
}

TrajectoryConstraints effectiveConstraints(const TrajectoryConstraints& traj, const std::string& traj_source,
                                           const CellLimits& cell, LimitSources* sources) {
  TrajectoryConstraints e = traj;
  LimitSources s;
  const auto pick = [](double traj_v, double cell_v, bool larger, const std::string& traj_src,
                       const std::string& cell_src, std::string* src) {
    const bool traj_tighter = larger ? traj_v >= cell_v : traj_v <= cell_v;
    *src = traj_tighter ? traj_src : cell_src;
    return traj_tighter ? traj_v : cell_v;
  };
  for (int j = 0; j < kNumJoints; ++j) {
    const auto u = static_cast<std::size_t>(j);
    e.position_lower(j) = pick(traj.position_lower(j), cell.position_lower(j), true, traj_source, cell.path,
                               &s.position_lower[u]);
    e.position_upper(j) = pick(traj.position_upper(j), cell.position_upper(j), false, traj_source, cell.path,
                               &s.position_upper[u]);
    e.velocity(j) = pick(traj.velocity(j), cell.velocity(j), false, traj_source, cell.path, &s.velocity[u]);
    e.acceleration(j) = pick(traj.acceleration(j), cell.acceleration(j), false, traj_source, cell.path,
                             &s.acceleration[u]);
  }
  e.floor_z_B = pick(traj.floor_z_B, cell.floor_z_B, true, traj_source, cell.path, &s.floor_z);
  s.keep_out.assign(traj.keep_out.size(), traj_source);
  for (const KeepOutSphere& k : cell.keep_out) {
    e.keep_out.push_back(k);
    s.keep_out.push_back(cell.path);
  }
  if (sources != nullptr) *sources = std::move(s);
  return e;
}

namespace {

std::string perJoint(const char* name, const JointVector& v, const std::array<std::string, kNumJoints>& src,
                     const char* unit) {
  std::ostringstream os;
  os.precision(6);
  os << name << " [";
  for (int j = 0; j < kNumJoints; ++j) os << (j > 0 ? ", " : "") << v(j);
  os << "] " << unit << " (";
  // Group consecutive joints with the same source: "j1-3 cell.yaml, j4-6 traj.yaml".
  int start = 0;
  for (int j = 1; j <= kNumJoints; ++j) {
    if (j == kNumJoints || src[static_cast<std::size_t>(j)] != src[static_cast<std::size_t>(start)]) {
      os << (start > 0 ? ", " : "") << "j" << start + 1;
      if (j - 1 > start) os << "-" << j;
      os << " " << src[static_cast<std::size_t>(start)];
      start = j;
    }
  }
  os << ")";
  return os.str();
}

}  // namespace

std::string describeLimits(const TrajectoryConstraints& c, const LimitSources& s) {
  std::ostringstream os;
  os << perJoint("position_lower", c.position_lower, s.position_lower, "rad") << "\n"
     << perJoint("position_upper", c.position_upper, s.position_upper, "rad") << "\n"
     << perJoint("velocity", c.velocity, s.velocity, "rad/s") << "\n"
     << perJoint("acceleration", c.acceleration, s.acceleration, "rad/s^2") << "\n"
     << "floor_z " << c.floor_z_B << " m (" << s.floor_z << ")\n";
  for (std::size_t k = 0; k < c.keep_out.size(); ++k) {
    os << "keep_out '" << c.keep_out[k].name << "' r = " << c.keep_out[k].radius << " m ("
       << (k < s.keep_out.size() ? s.keep_out[k] : std::string("?")) << ")\n";
  }
  return os.str();
}

}  // namespace ftid::trajectory
