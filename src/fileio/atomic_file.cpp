// The one atomic writer (include/ftid/fileio/atomic_file.hpp).
#include "ftid/fileio/atomic_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <vector>

namespace ftid {

namespace {

std::string why(int err) { return std::strerror(err); }

std::string parentDir(const std::string& path) {
  const auto slash = path.rfind('/');
  if (slash == std::string::npos) return ".";
  if (slash == 0) return "/";
  return path.substr(0, slash);
}

/// lstat; returns false if the path does not exist, throws on other errors.
bool lstatPath(const std::string& path, struct stat& st) {
  if (::lstat(path.c_str(), &st) == 0) return true;
  if (errno == ENOENT) return false;
  throw FileError(path + ": cannot check the output file: " + why(errno));
}

[[noreturn]] void refuse(const std::string& path, mode_t mode) {
  throw FileError(path + ": refusing to replace a " + std::string(fileKindName(mode)) +
                  " (output files may only replace a regular file or be created; give another path)");
}

void writeAll(int fd, std::string_view data, const std::string& tmp) {
  const char* p = data.data();
  std::size_t left = data.size();
  while (left > 0) {
    const ssize_t n = ::write(fd, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw FileError(tmp + ": write failed: " + why(errno));
    }
    p += n;
    left -= static_cast<std::size_t>(n);
  }
}

void fsyncDir(const std::string& dir) {
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
}

bool renameUnsupported(int err) { return err == EINVAL || err == ENOSYS || err == EOPNOTSUPP; }

/// Keeps `old_name` (a regular file already out of the way) as `bak`, or removes it.
void disposeOld(const std::string& old_name, const std::string& bak, bool keep_backup) {
  if (keep_backup && ::rename(old_name.c_str(), bak.c_str()) == 0) return;
  ::unlink(old_name.c_str());
}

}  // namespace

const char* fileKindName(mode_t mode) {
  if (S_ISLNK(mode)) return "symbolic link";
  if (S_ISDIR(mode)) return "directory";
  if (S_ISFIFO(mode)) return "FIFO";
  if (S_ISSOCK(mode)) return "socket";
  if (S_ISCHR(mode)) return "character device";
  if (S_ISBLK(mode)) return "block device";
  if (S_ISREG(mode)) return "regular file";
  return "special file";
}

void checkOutputPath(const std::string& path) {
  if (path.empty()) throw FileError("output path is empty");
  struct stat st {};
  if (lstatPath(path, st) && !S_ISREG(st.st_mode)) refuse(path, st.st_mode);
}

void writeFileAtomically(const std::string& path, std::string_view contents, const AtomicWriteOptions& options) {
  if (path.empty()) throw FileError("output path is empty");
  if (path.back() == '/') throw FileError(path + ": output path names a directory");
  const std::string bak = path + ".bak";
  struct stat st {};
  mode_t mode = options.mode;
  if (lstatPath(path, st)) {
    if (!S_ISREG(st.st_mode)) refuse(path, st.st_mode);
    mode = st.st_mode & 07777;
  }
  if (options.keep_backup) {
    struct stat bst {};
    if (lstatPath(bak, bst) && !S_ISREG(bst.st_mode)) refuse(bak, bst.st_mode);
  }

  // Temporary file next to the target (same file system), created exclusively (never follows).
  std::string tmpl = path + ".tmp-XXXXXX";
  std::vector<char> name(tmpl.begin(), tmpl.end());
  name.push_back('\0');
  const int fd = ::mkostemp(name.data(), O_CLOEXEC);
  if (fd < 0) throw FileError(path + ": cannot create a temporary file in " + parentDir(path) + ": " + why(errno));
  const std::string tmp(name.data());
  try {
    writeAll(fd, contents, tmp);
    if (::fchmod(fd, mode) != 0) throw FileError(tmp + ": chmod failed: " + why(errno));
    if (::fsync(fd) != 0) throw FileError(tmp + ": fsync failed: " + why(errno));
  } catch (...) {
    ::close(fd);
    ::unlink(tmp.c_str());
    throw;
  }
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    throw FileError(tmp + ": close failed: " + why(err));
  }

  // Put it in place. A few attempts, in case the target appears or vanishes meanwhile.
  for (int attempt = 0; attempt < 4; ++attempt) {
    const bool exists = lstatPath(path, st);
    if (exists && !S_ISREG(st.st_mode)) {
      ::unlink(tmp.c_str());
      refuse(path, st.st_mode);
    }
    if (exists) {
      if (::renameat2(AT_FDCWD, tmp.c_str(), AT_FDCWD, path.c_str(), RENAME_EXCHANGE) == 0) {
        // `tmp` now names what was at `path`: it must have been a regular file.
        struct stat old {};
        if (::lstat(tmp.c_str(), &old) == 0 && !S_ISREG(old.st_mode)) {
          ::renameat2(AT_FDCWD, tmp.c_str(), AT_FDCWD, path.c_str(), RENAME_EXCHANGE);
          ::unlink(tmp.c_str());
          refuse(path, old.st_mode);
        }
        disposeOld(tmp, bak, options.keep_backup);
        fsyncDir(parentDir(path));
        return;
      }
      const int err = errno;
      if (err == ENOENT) continue;  // vanished meanwhile: create it
      if (!renameUnsupported(err)) {
        ::unlink(tmp.c_str());
        throw FileError(path + ": cannot move the temporary file into place: " + why(err));
      }
      // No RENAME_EXCHANGE on this file system: hard-link backup, then rename over the file that
      // was just checked to be regular.
      if (options.keep_backup) {
        ::unlink(bak.c_str());
        if (::link(path.c_str(), bak.c_str()) != 0) {
          // Without hard links the backup is skipped; the new file still replaces the old one.
        }
      }
      if (::rename(tmp.c_str(), path.c_str()) != 0) {
        const int rerr = errno;
        ::unlink(tmp.c_str());
        throw FileError(path + ": cannot move the temporary file into place: " + why(rerr));
      }
      fsyncDir(parentDir(path));
      return;
    }
    if (::renameat2(AT_FDCWD, tmp.c_str(), AT_FDCWD, path.c_str(), RENAME_NOREPLACE) == 0) {
      fsyncDir(parentDir(path));
      return;
    }
    const int err = errno;
    if (err == EEXIST) continue;  // appeared meanwhile: check what it is
    if (!renameUnsupported(err)) {
      ::unlink(tmp.c_str());
      throw FileError(path + ": cannot move the temporary file into place: " + why(err));
    }
    if (::link(tmp.c_str(), path.c_str()) == 0) {  // no-replace without renameat2
      ::unlink(tmp.c_str());
      fsyncDir(parentDir(path));
      return;
    }
    const int lerr = errno;
    if (lerr == EEXIST) continue;
    if (::rename(tmp.c_str(), path.c_str()) != 0) {
      const int rerr = errno;
      ::unlink(tmp.c_str());
      throw FileError(path + ": cannot move the temporary file into place: " + why(rerr));
    }
    fsyncDir(parentDir(path));
    return;
  }
  ::unlink(tmp.c_str());
  throw FileError(path + ": the output file kept changing while it was being replaced; nothing written");
}

}  // namespace ftid
