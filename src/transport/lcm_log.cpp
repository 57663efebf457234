#include "ftid/transport/lcm_log.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "ftid/common/error.hpp"
#include "ftid/fileio/atomic_file.hpp"

namespace ftid::transport {
namespace {

constexpr std::uint32_t kSync = 0xEDA1DA01u;
constexpr std::int32_t kMaxChannelLength = 4096;
constexpr std::int32_t kMaxDataLength = 256 * 1024 * 1024;

void putU32(std::uint8_t* p, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<std::uint8_t>(v >> (24 - 8 * i));
}
void putU64(std::uint8_t* p, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) p[i] = static_cast<std::uint8_t>(v >> (56 - 8 * i));
}
std::uint32_t getU32(const std::uint8_t* p) {
  std::uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v = (v << 8) | p[i];
  return v;
}
std::uint64_t getU64(const std::uint8_t* p) {
  std::uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v = (v << 8) | p[i];
  return v;
}

/// Opens `path` with `flags` (plus O_NONBLOCK, O_CLOEXEC; for writing O_NOFOLLOW: a symlink is
/// refused) and
/// returns a stdio stream on it only if it is a regular file; else throws naming the path.
std::FILE* openRegular(const std::string& path, int flags, const char* mode, const std::string& what) {
  const int nofollow = (flags & O_ACCMODE) == O_RDONLY ? 0 : O_NOFOLLOW;
  const int fd = ::open(path.c_str(), flags | O_NONBLOCK | O_CLOEXEC | nofollow, 0644);
  if (fd < 0) {
    const int err = errno;
    if (err == ELOOP) throw FileError(path + ": refusing to " + what + " through a symbolic link");
    throw FileError(path + ": cannot " + what + ": " + std::strerror(err));
  }
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    throw FileError(path + ": cannot " + what + ": it is a " + fileKindName(st.st_mode) + ", not a regular file");
  }
  // Regular files never block; clear O_NONBLOCK anyway for stdio.
  ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
  std::FILE* f = ::fdopen(fd, mode);
  if (f == nullptr) {
    ::close(fd);
    throw FileError(path + ": cannot " + what + ": " + std::strerror(errno));
  }
  return f;
}

}  // namespace

LcmLogWriter::LcmLogWriter(const std::string& path) : path_(path) {
  checkOutputPath(path);  // a device node, FIFO or directory is refused before it is opened
  file_ = openRegular(path, O_WRONLY | O_CREAT | O_TRUNC, "wb", "create the LCM log");
}

LcmLogWriter::~LcmLogWriter() {
  if (file_ != nullptr) std::fclose(file_);
}

void LcmLogWriter::write(std::int64_t timestamp_us, const std::string& channel, const void* data,
                         std::size_t size) {
  std::uint8_t header[28];
  putU32(header, kSync);
  putU64(header + 4, events_);
  putU64(header + 12, static_cast<std::uint64_t>(timestamp_us));
  putU32(header + 20, static_cast<std::uint32_t>(channel.size()));
  putU32(header + 24, static_cast<std::uint32_t>(size));
  if (std::fwrite(header, 1, sizeof header, file_) != sizeof header ||
      std::fwrite(channel.data(), 1, channel.size(), file_) != channel.size() ||
      (size > 0 && std::fwrite(data, 1, size, file_) != size)) {
    throw Error(path_ + ": cannot write LCM log event " + std::to_string(events_) + ": " +
                std::strerror(errno));
  }
  ++events_;
}

void LcmLogWriter::flush() {
  if (std::fflush(file_) != 0) {
    throw Error(path_ + ": cannot flush LCM log: " + std::strerror(errno));
  }
}

LcmLogReader::LcmLogReader(const std::string& path) : path_(path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {  // never open a device or FIFO
    throw DataError(path + ": cannot open the LCM log: it is a " + fileKindName(st.st_mode) +
                    ", not a regular file");
  }
  try {
    file_ = openRegular(path, O_RDONLY, "rb", "open the LCM log");
  } catch (const FileError& e) {
    throw DataError(e.what());
  }
}

LcmLogReader::~LcmLogReader() {
  if (file_ != nullptr) std::fclose(file_);
}

bool LcmLogReader::next(LcmLogEvent* event) {
  const long offset = std::ftell(file_);
  std::uint8_t header[28];
  const std::size_t got = std::fread(header, 1, sizeof header, file_);
  if (got == 0) return false;
  if (got < sizeof header) return false;  // truncated last event
  if (getU32(header) != kSync) {
    throw DataError(path_ + ": byte offset " + std::to_string(offset) +
                    ": not an LCM log event (bad sync word)");
  }
  const auto channel_length = static_cast<std::int32_t>(getU32(header + 20));
  const auto data_length = static_cast<std::int32_t>(getU32(header + 24));
  if (channel_length <= 0 || channel_length > kMaxChannelLength || data_length < 0 ||
      data_length > kMaxDataLength) {
    throw DataError(path_ + ": byte offset " + std::to_string(offset) +
                    ": implausible LCM event header (channel length " +
                    std::to_string(channel_length) + ", data length " +
                    std::to_string(data_length) + ")");
  }
  event->eventnum = static_cast<std::int64_t>(getU64(header + 4));
  event->timestamp_us = static_cast<std::int64_t>(getU64(header + 12));
  event->channel.resize(static_cast<std::size_t>(channel_length));
  event->data.resize(static_cast<std::size_t>(data_length));
  if (std::fread(&event->channel[0], 1, event->channel.size(), file_) != event->channel.size()) {
    return false;  // truncated
  }
  if (data_length > 0 &&
      std::fread(event->data.data(), 1, event->data.size(), file_) != event->data.size()) {
    return false;  // truncated
  }
  return true;
}

}  // namespace ftid::transport
