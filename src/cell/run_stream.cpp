#include "ftid/cell/run_stream.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>

#include "ftid/common/clock.hpp"
#include "ftid/common/error.hpp"

namespace ftid::cell {
namespace {

void number(std::string& out, double v) {
  char buf[32];
  const auto res = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, res.ptr);
}

}  // namespace

RunStreamWriter::RunStreamWriter(std::string path, double fsync_period_s)
    : path_(std::move(path)), fsync_period_s_(fsync_period_s) {
  fd_ = ::open(path_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_APPEND | O_CLOEXEC | O_NOFOLLOW, 0644);
  if (fd_ < 0) throw Error(path_ + ": cannot create the run file (" + std::strerror(errno) + ")");
  pending_.reserve(1 << 16);
  syncer_ = std::thread([this] {
    std::unique_lock<std::mutex> lock(sync_mutex_);
    while (!sync_stop_) {
      sync_cv_.wait_for(lock, std::chrono::duration<double>(fsync_period_s_));
      if (sync_stop_) break;
      lock.unlock();
      if (::fdatasync(fd_) != 0 && errno != EINVAL && sync_errno_.load() == 0) sync_errno_.store(errno);
      lock.lock();
    }
  });
}

RunStreamWriter::~RunStreamWriter() {
  finish();
  if (fd_ >= 0) ::close(fd_);
}

void RunStreamWriter::fail(int err) noexcept {
  try {
    const std::string dir = std::filesystem::path(path_).parent_path().string();
    error_ = err == ENOSPC ? "no space left on the file system of " + dir
                           : std::string("writing ") + path_ + " failed (" + std::strerror(err) + ")";
    error_ += "; " + path_ + " keeps the " + std::to_string(rows_) + " rows written before";
  } catch (...) {
    error_ = "write failed";
  }
  pending_.clear();
}

void RunStreamWriter::writePending() noexcept {
  std::size_t done = 0;
  while (done < pending_.size() && error_.empty()) {
    const ssize_t n = ::write(fd_, pending_.data() + done, pending_.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      // Cut the file back to the last complete row so that it stays a valid log.
      if (::ftruncate(fd_, static_cast<off_t>(size_)) != 0) {
        // Nothing more to do: the message below still names the file.
      }
      if (rows_ > 0) --rows_;  // the row being written did not make it
      fail(err);
      return;
    }
    done += static_cast<std::size_t>(n);
  }
  size_ += pending_.size();
  pending_.clear();
}

void RunStreamWriter::append(const CycleRecord& r) noexcept {
  if (fd_ < 0 || !error_.empty()) return;
  try {
    const bool usable = r.robot.valid && r.sensor.valid && r.sensor.health_flags == kHealthOk &&
                        std::isfinite(r.robot.robot_time) && r.robot.q.allFinite() && r.robot.qd.allFinite() &&
                        r.robot.qdd.allFinite() && r.sensor.wrench_S.allFinite() && r.robot.robot_time > last_t_;
    if (!usable) {
      ++skipped_;
      return;
    }
    if (!header_written_) {
      imu_ = r.sensor.has_imu;
      pending_ += "# ftid --identify: cycle samples as received from ftidd (raw capture, streamed)\n";
      pending_ += "t,q1,q2,q3,q4,q5,q6,qd1,qd2,qd3,qd4,qd5,qd6,qdd1,qdd2,qdd3,qdd4,qdd5,qdd6,fx,fy,fz,tx,ty,tz";
      if (imu_) pending_ += ",ax,ay,az,wx,wy,wz,alx,aly,alz";
      pending_ += ",cycle,sensor_age_ms,host_time\n";  // host_time: docs/conventions.md, "Time and logs"
      header_written_ = true;
    }
    if (imu_ && (!r.sensor.has_imu || !r.sensor.imu_acc_S.allFinite() || !r.sensor.imu_w_S.allFinite() ||
                 !r.sensor.imu_alpha_S.allFinite())) {
      ++skipped_;
      return;
    }
    number(pending_, r.robot.robot_time);
    for (const JointVector* v : {&r.robot.q, &r.robot.qd, &r.robot.qdd}) {
      for (int i = 0; i < kNumJoints; ++i) {
        pending_ += ',';
        number(pending_, (*v)[i]);
      }
    }
    for (int i = 0; i < 6; ++i) {
      pending_ += ',';
      number(pending_, r.sensor.wrench_S[i]);
    }
    if (imu_) {
      for (const Vec3* v : {&r.sensor.imu_acc_S, &r.sensor.imu_w_S, &r.sensor.imu_alpha_S}) {
        for (int i = 0; i < 3; ++i) {
          pending_ += ',';
          number(pending_, (*v)[i]);
        }
      }
    }
    pending_ += ',';
    number(pending_, static_cast<double>(r.cycle));
    pending_ += ',';
    number(pending_, static_cast<double>(r.sensor_age_us) / 1000.0);
    pending_ += ',';
    number(pending_, hostTimeSeconds(r.robot.recv_utime));
    pending_ += '\n';
    last_t_ = r.robot.robot_time;
    ++rows_;
    writePending();  // one write per record: a SIGKILL loses nothing already received
    if (error_.empty() && sync_errno_.load(std::memory_order_relaxed) != 0) fail(sync_errno_.load());
  } catch (...) {
    fail(ENOMEM);
  }
}

void RunStreamWriter::finish() noexcept {
  if (fd_ < 0) return;
  if (syncer_.joinable()) {
    {
      std::lock_guard<std::mutex> lock(sync_mutex_);
      sync_stop_ = true;
    }
    sync_cv_.notify_all();
    syncer_.join();
  }
  if (error_.empty()) writePending();
  if (error_.empty() && ::fsync(fd_) != 0 && errno != EINVAL) fail(errno);
}

}  // namespace ftid::cell
