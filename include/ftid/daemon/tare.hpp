#pragma once
// ftidd's tare (docs/daemon.md, "Tare"), the non-real-time half: the parameter file read with
// its content digest, the tare state file next to it (PATH.tare.yaml: the tared offsets and the
// digest of the parameter file they belong to), and the offsets f0_x..t0_z in a ParameterSet.
// The loop-side half (TareAccumulator) is in ftid/daemon/daemon_cycle.hpp. Set-up code: these
// functions allocate, do I/O and throw.
#include <cstdint>
#include <optional>
#include <string>

#include "ftid/common/types.hpp"
#include "ftid/params/parameter_set.hpp"

namespace ftid::daemon {

/// Names of the six offsets, in Wrench order (fx, fy, fz, tx, ty, tz).
extern const char* const kOffsetNames[6];

/// The offsets f0_x..t0_z of the set. Throws ConfigError naming `source` if one is missing.
Wrench offsetsOf(const params::ParameterSet& set, const std::string& source);
/// Replaces the offsets (their standard errors become 0: a tare is not a fit).
void setOffsets(params::ParameterSet* set, const Wrench& offsets);

/// PATH.tare.yaml.
std::string tareStatePath(const std::string& parameter_path);

struct TareState {
  std::string parameter_sha256;  ///< hex digest of the parameter file's content
  Wrench offsets = Wrench::Zero();
  std::int64_t utime = 0;        ///< when the tare was taken [us since the epoch]
  std::uint32_t cycles = 0;      ///< cycles averaged
};

/// Writes the state atomically (ftid::writeFileAtomically). Throws FileError naming the path.
void writeTareState(const std::string& path, const TareState& state);
/// nullopt if the file does not exist; throws ConfigError naming the file and key if it is
/// malformed or a value is missing or non-finite.
std::optional<TareState> readTareState(const std::string& path);
/// Removes the state file (no error if it does not exist). Throws FileError on other failures.
void removeTareState(const std::string& path);

/// A parameter file as ftidd uses it.
struct LoadedParameters {
  params::ParameterSet set;   ///< with the tared offsets if `tared`
  std::string sha256;           ///< hex digest of the parameter file's content
  bool tared = false;           ///< the tare state matched and was applied
  std::string note;             ///< why a tare state present was not applied (empty otherwise)
};

/// Reads and validates the parameter file (regular files only; ConfigError naming file and
/// key). If `apply_tare` and PATH.tare.yaml exists and records this content's digest, its
/// offsets replace the file's; a state for other content, or a malformed one, is ignored and
/// said in `note`.
LoadedParameters loadParameters(const std::string& path, bool apply_tare);

}  // namespace ftid::daemon
