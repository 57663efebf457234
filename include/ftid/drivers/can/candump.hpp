#pragma once
// candump log files (`candump -l`, can-utils "compact" format), one frame per line:
//   (1700000000.000123) can0 1A1#DEADBEEF01020304        3 hex digits: 11-bit id
//   (1700000000.000456) can0 12345678#00                 8 hex digits: 29-bit id (EFF)
//   (1700000000.000789) can0 20000004#0000080000000000   error frame (CAN_ERR_FLAG in the id)
//   (1700000000.001000) can0 1A1#R   /  1A1#R4            remote frame (with dlc)
// A trailing " R"/" T" (candump -x direction) is accepted. CAN FD lines (`ID##f...`) are rejected
// with a clear error (the sensor is classic CAN). Empty lines and lines starting with '#' skipped.
#include <cstddef>
#include <string>
#include <vector>

#include "ftid/drivers/can/transport.hpp"

namespace ftid::drivers::can {

struct CandumpRecord {
  ReceivedFrame frame;     ///< rx_time_ns from the "(seconds.micros)" field
  std::string interface;   ///< e.g. "can0"
};

/// Parses one line. Throws ftid::DataError "<source>:<line>: ..." on malformed input.
CandumpRecord parseCandumpLine(const std::string& text, const std::string& source, int line);

/// Formats a frame as a candump -l line (no newline), e.g. "(1700000000.000123) can0 1A1#DEAD".
std::string formatCandumpLine(const ReceivedFrame& frame, const std::string& interface);

/// Reads a whole log (throws DataError naming file and line).
std::vector<CandumpRecord> loadCandump(const std::string& path);

/// Replays a candump log as a transport. Frames become available when the replay clock reaches
/// their timestamp (advanceTo), or all at once with `paced = false`. trySend is accepted and
/// discarded. Returns kClosed after the last frame.
class CandumpReplayTransport final : public CanTransport {
 public:
  /// `interface_filter`: only frames from this interface ("" = all).
  explicit CandumpReplayTransport(const std::string& path, bool paced = false,
                                  const std::string& interface_filter = "");
  explicit CandumpReplayTransport(std::vector<CandumpRecord> records, bool paced = false);

  /// Paced mode: frames with rx_time_ns <= t_ns become available.
  void advanceTo(std::int64_t t_ns) noexcept { clock_ns_ = t_ns; }
  /// Timestamp of the next frame, or -1 at the end.
  std::int64_t nextFrameTimeNs() const noexcept;
  std::size_t size() const noexcept { return frames_.size(); }
  std::size_t position() const noexcept { return next_; }

  IoResult tryReceive(ReceivedFrame& out) noexcept override;
  IoResult trySend(const can_frame& frame) noexcept override;
  bool waitReadable(std::chrono::milliseconds timeout) override;
  int fd() const noexcept override { return -1; }
  int lastErrno() const noexcept override { return 0; }
  const char* describe() const noexcept override { return description_.c_str(); }

 private:
  std::vector<ReceivedFrame> frames_;
  std::size_t next_ = 0;
  bool paced_ = false;
  std::int64_t clock_ns_ = 0;
  std::string description_;
};

}  // namespace ftid::drivers::can
