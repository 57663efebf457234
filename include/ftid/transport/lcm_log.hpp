#pragma once
// LCM log files in the lcm-logger format (readable by lcm-logplayer, lcm-spy and LCM's
// lcm::LogFile): big-endian events of sync word 0xEDA1DA01, event number, timestamp [us],
// channel length, data length, channel, data.
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

namespace ftid::transport {

struct LcmLogEvent {
  std::int64_t eventnum = 0;
  std::int64_t timestamp_us = 0;  ///< when the event was received/recorded [us since epoch]
  std::string channel;
  std::vector<std::uint8_t> data;
};

/// Appends events to a new LCM log file. Not thread-safe; not for the real-time loop.
class LcmLogWriter {
 public:
  /// Creates (truncates) the file. Throws ftid::Error naming the path if it cannot be opened.
  explicit LcmLogWriter(const std::string& path);
  ~LcmLogWriter();
  LcmLogWriter(const LcmLogWriter&) = delete;
  LcmLogWriter& operator=(const LcmLogWriter&) = delete;

  /// Appends one event (event numbers are assigned consecutively). Throws ftid::Error on a
  /// write failure (e.g. disk full), naming the path.
  void write(std::int64_t timestamp_us, const std::string& channel, const void* data,
             std::size_t size);
  void flush();
  std::uint64_t eventsWritten() const noexcept { return events_; }
  const std::string& path() const noexcept { return path_; }

 private:
  std::string path_;
  std::FILE* file_ = nullptr;
  std::uint64_t events_ = 0;
};

/// Reads events from an LCM log file in order.
class LcmLogReader {
 public:
  /// Throws ftid::DataError naming the path if it cannot be opened.
  explicit LcmLogReader(const std::string& path);
  ~LcmLogReader();
  LcmLogReader(const LcmLogReader&) = delete;
  LcmLogReader& operator=(const LcmLogReader&) = delete;

  /// Reads the next event; false at the end of the file. A truncated last event (a log cut
  /// short by a crash) ends the file; other corruption throws DataError naming path and offset.
  bool next(LcmLogEvent* event);
  const std::string& path() const noexcept { return path_; }

 private:
  std::string path_;
  std::FILE* file_ = nullptr;
};

}  // namespace ftid::transport
