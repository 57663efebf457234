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
/// ftid logs read in pieces (InputFileReader; docs/log-format.md "Limits"): 16 GiB.
inline constexpr std::size_t kMaxStreamedLogBytes = std::size_t{16} << 30;

/// Reads the whole of `path`, a regular file of at most `max_bytes`. `what` names the kind of
/// file in messages ("log file", "parameter file"). Throws FileError("PATH: ...").
std::string readInputFile(const std::string& path, const std::string& what,
                          std::size_t max_bytes = kMaxTextConfigBytes);

/// The same file checks as readInputFile (regular file, opened without blocking, at most
/// `max_bytes`), read in pieces: the bytes read(buf, n) returns, concatenated, are the file's
/// bytes, exactly what readInputFile(path, what, max_bytes) would return. Throws FileError.
class InputFileReader {
 public:
  InputFileReader(const std::string& path, const std::string& what, std::size_t max_bytes);
  ~InputFileReader();
  InputFileReader(const InputFileReader&) = delete;
  InputFileReader& operator=(const InputFileReader&) = delete;

  /// Up to `n` next bytes into `buf`; 0 at the end of the file. Throws FileError on a read
  /// error or when the file (growing while read) passes `max_bytes`.
  std::size_t read(char* buf, std::size_t n);
  /// The file's size when it was opened [bytes].
  std::size_t size() const { return size_; }

 private:
  std::string path_;
  std::string what_;
  std::size_t max_bytes_;
  std::size_t size_ = 0;
  std::size_t done_ = 0;
  int fd_ = -1;
};

}  // namespace ftid
