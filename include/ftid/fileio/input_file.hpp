#pragma once
// Reading untrusted input files (logs, parameter files, trajectories, configs, URDFs, DBCs).
// Every input is opened with O_NONBLOCK (so a FIFO cannot block the open), checked to be a
// regular file (a FIFO, directory or device gives FileError naming the path and what it is), and
// bounded in size. Set-up code only.
#include <cstddef>
#include <string>

#include "ftid/fileio/atomic_file.hpp"

namespace ftid {

/// Size limits (bytes) for the kinds of input ftid reads.
inline constexpr std::size_t kMaxLogBytes = std::size_t{2} << 30;        ///< CSV logs: 2 GiB
inline constexpr std::size_t kMaxTextConfigBytes = std::size_t{16} << 20;  ///< YAML, URDF, DBC: 16 MiB

/// Reads the whole of `path`, a regular file of at most `max_bytes`. `what` names the kind of
/// file in messages ("log file", "parameter file"). Throws FileError("PATH: ...").
std::string readInputFile(const std::string& path, const std::string& what,
                          std::size_t max_bytes = kMaxTextConfigBytes);

}  // namespace ftid
