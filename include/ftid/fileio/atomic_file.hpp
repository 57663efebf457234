#pragma once
// The one atomic writer for every output file ftid produces (parameter files, logs, reports,
// trajectories, exports). Set-up code only: it allocates, blocks and throws.
//
// writeFileAtomically(PATH, text):
//   1. refuses unless PATH is missing or a regular file: a symbolic link, directory, FIFO, socket or
//      device node gives FileError("PATH: refusing to replace a <kind> ...") and nothing is touched;
//   2. writes a temporary file in PATH's directory (mkstemp, O_NOFOLLOW), fsyncs it;
//   3. puts it in place without following a symlink: renameat2(RENAME_EXCHANGE) when PATH exists
//      (what was swapped out is checked to be a regular file, else swapped back and refused) or
//      renameat2(RENAME_NOREPLACE) when it did not (something appearing meanwhile is refused);
//      plain rename() only on file systems without renameat2 (after the same lstat check);
//   4. fsyncs the directory.
// Any failure leaves PATH as it was and removes the temporary file.
#include <string>
#include <string_view>

#include <sys/types.h>

#include "ftid/common/error.hpp"

namespace ftid {

/// A file could not be read or written safely; the message names the path.
class FileError : public Error {
 public:
  using Error::Error;
};

struct AtomicWriteOptions {
  /// Mode of a new file; an existing file keeps its mode.
  mode_t mode = 0644;
  /// Keep the replaced file as PATH.bak (itself only replaced if it is a regular file or missing).
  bool keep_backup = false;
};

/// Writes `contents` to `path` atomically (see above). Throws FileError naming the path.
void writeFileAtomically(const std::string& path, std::string_view contents,
                         const AtomicWriteOptions& options = {});

/// Throws FileError unless `path` is missing or a regular file (not a symlink). Commands call this
/// before long work so a bad --out is refused at once; writeFileAtomically checks again.
void checkOutputPath(const std::string& path);

/// "symbolic link", "directory", "FIFO", "socket", "character device", "block device" or
/// "regular file" for an lstat mode.
const char* fileKindName(mode_t mode);

}  // namespace ftid
