#pragma once
// Streams an identification run to disk while it is recorded (issue 14, "Data"): every usable
// cycle record becomes one CSV row (docs/log-format.md; readable by `ftid identify --log` and
// `ftid analyze`) appended to the file at once, so a crash or SIGKILL of `ftid --identify` loses
// nothing that reached the kernel, and the file is fsync'ed about once per second so a power loss
// loses at most the last second (on a thread of its own: an fsync can take long on a busy disk and
// must not hold up the receive thread, whose liveness `ftid --identify` watches). A write error (a full disk) stops the stream with a message
// naming the directory; what was written stays.
//
// Rows: records with a valid robot state and a healthy, valid sensor sample, finite values and a
// robot time above the previous row's. Columns: t, q, qd, qdd, the raw wrench, the IMU group if the
// first row had it (later rows without it are skipped and counted), then the extra columns cycle and
// sensor_age_ms. The stream is the raw capture; the checked, windowed run.csv is written at the end.
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>

#include "ftid/common/records.hpp"

namespace ftid::cell {

class RunStreamWriter {
 public:
  /// Creates (O_EXCL: never replaces anything) `path`. Throws Error naming the file.
  explicit RunStreamWriter(std::string path, double fsync_period_s = 1.0);
  ~RunStreamWriter();
  RunStreamWriter(const RunStreamWriter&) = delete;
  RunStreamWriter& operator=(const RunStreamWriter&) = delete;

  /// Appends the record if usable (non-RT; the LCM receive thread). Never throws.
  void append(const CycleRecord& record) noexcept;
  /// Writes what is pending and fsyncs. Never throws.
  void finish() noexcept;

  const std::string& path() const noexcept { return path_; }
  std::size_t rows() const noexcept { return rows_; }
  std::size_t skipped() const noexcept { return skipped_; }
  bool failed() const noexcept { return !error_.empty(); }
  /// Empty, or what went wrong ("no space left on the file system of DIR after N rows ...").
  const std::string& error() const noexcept { return error_; }

 private:
  void writePending() noexcept;
  void fail(int err) noexcept;
  std::string path_;
  int fd_ = -1;
  double fsync_period_s_;
  std::string pending_;
  bool header_written_ = false;
  bool imu_ = false;
  double last_t_ = -1e300;
  std::size_t rows_ = 0;
  std::size_t size_ = 0;  ///< bytes of complete rows in the file
  std::size_t skipped_ = 0;
  std::string error_;
  std::atomic<int> sync_errno_{0};  ///< set by the fsync thread
  std::mutex sync_mutex_;
  std::condition_variable sync_cv_;
  bool sync_stop_ = false;
  std::thread syncer_;
};

}  // namespace ftid::cell
