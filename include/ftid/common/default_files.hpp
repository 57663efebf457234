#pragma once
// The one lookup for ftid's shipped default files (robot descriptions, the DBC, trajectories,
// configuration templates), used by every command so that they work from any directory:
//
//   1. the build tree: `config/NAME` next to the running executable (CMake copies config/ there),
//   2. the installed data directory: `<exe>/../share/ftid/config/NAME` (any install prefix),
//      then /usr/share/ftid/config/NAME,
//   3. /etc/ftid/NAME.
//
// Paths given by the user are never looked up here: they are relative to the working directory
// (command line) or to the file that names them (trajectory `robot:`, ftidd.yaml). Set-up code
// only (file system access); header-only so that every module can use it.
#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

#include "ftid/common/error.hpp"

namespace ftid {

/// Directory of the running executable ("" if /proc/self/exe cannot be read).
inline std::string executableDir() {
  char buf[4096];
  const ssize_t n = ::readlink("/proc/self/exe", buf, sizeof(buf) - 1);
  if (n <= 0) return "";
  return std::filesystem::path(std::string(buf, static_cast<std::size_t>(n))).parent_path().string();
}

/// The places searched for NAME, in order (see the file comment). `exe_dir` "" skips 1 and 2a.
inline std::vector<std::string> defaultFileCandidates(const std::string& name,
                                                      const std::string& exe_dir = executableDir()) {
  std::vector<std::string> c;
  if (!exe_dir.empty()) {
    c.push_back(exe_dir + "/config/" + name);
    c.push_back((std::filesystem::path(exe_dir).parent_path() / "share/ftid/config" / name).string());
  }
  c.push_back("/usr/share/ftid/config/" + name);
  c.push_back("/etc/ftid/" + name);
  return c;
}

/// The first existing candidate for NAME (e.g. "ur10.urdf"); throws ConfigError listing every
/// place searched if there is none.
inline std::string findDefaultFile(const std::string& name, const std::string& exe_dir = executableDir()) {
  const auto candidates = defaultFileCandidates(name, exe_dir);
  std::error_code ec;
  for (const auto& p : candidates) {
    if (std::filesystem::is_regular_file(p, ec)) return std::filesystem::path(p).lexically_normal().string();
  }
  std::string tried;
  for (const auto& p : candidates) tried += (tried.empty() ? "" : ", ") + p;
  throw ConfigError("default file '" + name + "' not found (searched " + tried +
                    "); give the file explicitly or reinstall ftid");
}

/// The default robot description (ur10.urdf) from the lookup above.
inline std::string defaultRobotUrdf() { return findDefaultFile("ur10.urdf"); }

/// A path named inside a file (e.g. a trajectory's `robot:`): absolute paths as they are,
/// relative ones relative to the directory of `naming_file`.
inline std::string resolveRelativeTo(const std::string& naming_file, const std::string& path) {
  if (path.empty() || path[0] == '/') return path;
  const std::filesystem::path dir = std::filesystem::path(naming_file).parent_path();
  return (dir / path).lexically_normal().string();
}

/// The inverse of resolveRelativeTo, for writing `path` into `naming_file`: relative to the
/// directory of `naming_file` if it lies in that directory or below (so the two files can move
/// together), else absolute. Both are made absolute against the working directory first.
inline std::string relativeTo(const std::string& naming_file, const std::string& path) {
  if (path.empty()) return path;
  std::error_code ec;
  const auto dir = std::filesystem::absolute(std::filesystem::path(naming_file), ec).parent_path().lexically_normal();
  const auto target = std::filesystem::absolute(std::filesystem::path(path), ec).lexically_normal();
  const auto rel = target.lexically_relative(dir);
  if (rel.empty() || *rel.begin() == "..") return target.string();
  return rel.string();
}

}  // namespace ftid
