#include "ftid/daemon/loop_owner.hpp"

#include "systemd_notify.hpp"

#include <pthread.h>
#include <sched.h>

#include <cstdio>
#include <exception>

#include "ftid/rt/rt_thread.hpp"

namespace ftid::daemon {

namespace {

using Clock = std::chrono::steady_clock;

std::int64_t steadyNs() noexcept {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch()).count();
}

std::string seconds(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f", s);
  return buf;
}

}  // namespace

bool watchdogMayBeFed(bool loop_heartbeat_advanced, bool link_thread_alive, double robot_silent_s,
                      double silence_limit_s) noexcept {
  const bool link_ok = silence_limit_s <= 0.0 || robot_silent_s < silence_limit_s;
  return loop_heartbeat_advanced && link_thread_alive && link_ok;
}

std::string describeSessionEnd(rt::LoopExit exit, const char* arm_error,
                               const rt::ExecutorConfig& exec) {
  const std::string why = arm_error != nullptr ? arm_error : "";
  switch (exit) {
    case rt::LoopExit::kDeviceFault:
      return "the connection failed (" + (why.empty() ? std::string("no reason given") : why) + ")";
    case rt::LoopExit::kTooManyMissed: {
      const double timeout_s = static_cast<double>(exec.period.count()) * 1e-9 * exec.timeout_periods;
      return "no state package for " + seconds(timeout_s * exec.max_consecutive_missed) +
             " s although the connection is up (robot.reconnect_after_silence_s)";
    }
    case rt::LoopExit::kCycleStopped: return "the cycle stopped";
    case rt::LoopExit::kStopRequested: return "stop requested";
  }
  return "?";
}

LoopOwner::LoopOwner(DaemonCycle* cycle, rt::LoopStats* stats, ArmConnector connect,
                     SensorLink sensor, LoopOwnerOptions options, Log log)
    : cycle_(cycle),
      stats_(stats),
      connect_(std::move(connect)),
      sensor_(std::move(sensor)),
      options_(std::move(options)),
      log_(std::move(log)),
      sensor_backoff_(options_.backoff) {
  if (!log_) log_ = [](const std::string&) {};
}

LoopOwner::~LoopOwner() { stop(); }

void LoopOwner::start(std::unique_ptr<ArmStateSource> first_arm) {
  if (started_) return;
  started_ = true;
  arm_ = std::move(first_arm);
  {
    std::lock_guard<std::mutex> l(mutex_);
    offered_ = arm_.get();
    status_.robot_up = arm_ != nullptr;
    status_.robot_ever_up = arm_ != nullptr;
    if (arm_ == nullptr) {
      down_since_ = Clock::now();
      status_.robot_last_error = "not connected yet";
    }
  }
  beat();
  launcher_ = std::thread([this] { loopThread(); });
  link_ = std::thread([this] { linkThread(); });
}

void LoopOwner::stop() {
  if (!started_) return;
  {
    std::lock_guard<std::mutex> l(mutex_);
    stop_ = true;
  }
  stop_flag_.store(true, std::memory_order_release);
  cv_.notify_all();
  if (launcher_.joinable()) launcher_.join();  // the session ends within one receive timeout
  if (link_.joinable()) link_.join();          // after a connection attempt in progress
  arm_.reset();
  if (sensor_.collect) sensor_.collect();
  started_ = false;
}

bool LoopOwner::stopping() const {
  std::lock_guard<std::mutex> l(mutex_);
  return stop_;
}

void LoopOwner::beat() noexcept { link_beat_ns_.store(steadyNs(), std::memory_order_release); }

bool LoopOwner::linkThreadAlive(Clock::duration limit) const noexcept {
  const std::int64_t age = steadyNs() - link_beat_ns_.load(std::memory_order_acquire);
  return age <= std::chrono::duration_cast<std::chrono::nanoseconds>(limit).count();
}

std::uint64_t LoopOwner::loopHeartbeat() const noexcept {
  const CycleCounters& c = cycle_->counters();
  return c.cycles.load(std::memory_order_acquire) + c.missed.load(std::memory_order_acquire) +
         parked_ticks_.load(std::memory_order_acquire);
}

bool LoopOwner::loopFailed(std::string* why) const {
  std::lock_guard<std::mutex> l(mutex_);
  if (!loop_done_ || stop_) return false;
  if (why != nullptr) *why = loop_error_.empty() ? "the loop thread ended" : loop_error_;
  return true;
}

LinkStatus LoopOwner::status() const {
  std::lock_guard<std::mutex> l(mutex_);
  LinkStatus s = status_;
  if (!s.robot_up) {
    s.robot_down_current_s = std::chrono::duration<double>(Clock::now() - down_since_).count();
    s.robot_down_total_s += s.robot_down_current_s;
  }
  s.packets_skipped = skipped_closed_ + (arm_ != nullptr && s.robot_up ? arm_->packetsSkipped() : 0);
  s.sensor_down = sensor_.down ? sensor_.down() : false;
  s.sensor_reconnects = sensor_.reconnects ? static_cast<std::int32_t>(sensor_.reconnects()) : 0;
  return s;
}

// ----------------------------------------------------------------------------- the loop thread
void LoopOwner::loopThread() {
  try {
    rt::runInRealtimeThread(options_.rt, [this] {
      int policy = SCHED_OTHER;
      sched_param sp{};
      if (pthread_getschedparam(pthread_self(), &policy, &sp) == 0) {
        loop_fifo_.store(policy == SCHED_FIFO || policy == SCHED_RR, std::memory_order_release);
      }
      for (;;) {
        ArmStateSource* arm = nullptr;
        {
          std::unique_lock<std::mutex> l(mutex_);
          while (!stop_ && offered_ == nullptr) {
            cv_.wait_for(l, options_.tick);
            parked_ticks_.fetch_add(1, std::memory_order_release);
          }
          if (stop_) return;
          arm = offered_;
        }
        cycle_->setArm(arm);
        const rt::LoopExit exit = rt::runDeviceClocked(*cycle_, options_.exec, stats_, &stop_flag_);
        {
          std::lock_guard<std::mutex> l(mutex_);
          offered_ = nullptr;
          last_exit_ = exit;
          session_ended_ = true;
        }
        cv_.notify_all();
      }
    });
  } catch (const std::exception& e) {
    std::lock_guard<std::mutex> l(mutex_);
    loop_error_ = e.what();
  }
  {
    std::lock_guard<std::mutex> l(mutex_);
    loop_done_ = true;
  }
  cv_.notify_all();
}

// ----------------------------------------------------------------------------- the link thread
bool LoopOwner::pause(std::chrono::nanoseconds d) {
  const auto until = Clock::now() + d;
  for (;;) {
    beat();
    serviceSensor();
    const auto now = Clock::now();
    if (now >= until) return !stopping();
    std::unique_lock<std::mutex> l(mutex_);
    if (stop_) return false;
    cv_.wait_for(l, std::min<Clock::duration>(until - now, options_.tick));
    if (stop_) return false;
  }
}

void LoopOwner::serviceSensor() {
  if (sensor_.collect) sensor_.collect();
  if (!sensor_.down || !sensor_.reopen || !sensor_.down()) return;
  const auto now = Clock::now();
  if (now < next_sensor_attempt_) return;
  try {
    sensor_.reopen();
    log_("sensor " + options_.sensor_name + " reopened" +
         (sensor_backoff_.attempts() > 0
              ? " after " + std::to_string(sensor_backoff_.attempts()) + " failed attempts"
              : std::string()));
    sensor_backoff_.reset();
    sensor_last_error_.clear();
    next_sensor_attempt_ = now;
  } catch (const std::exception& e) {
    const std::string msg = e.what();
    if (msg != sensor_last_error_) {
      log_("sensor " + options_.sensor_name + " transport down, reopening with backoff: " + msg);
      sensor_last_error_ = msg;
    }
    next_sensor_attempt_ = Clock::now() + sensor_backoff_.next();
  }
}

// Connects with backoff until a connection is validated (or stop); false if stopping. Used for
// the first connection when ftidd started without a robot and after every lost session.
bool LoopOwner::connectWithBackoff() {
  Backoff backoff(options_.backoff);
  std::string last_msg;
  std::unique_ptr<ArmStateSource> fresh;
  while (fresh == nullptr) {
    if (stopping()) return false;
    beat();
    try {
      fresh = connect_();
    } catch (const std::exception& e) {
      // One printable line: the text can quote bytes the controller sent (RTDE type names).
      const std::string msg = printableLine(e.what(), 300);
      std::uint32_t attempts = 0;
      bool ever_up = false;
      {
        std::lock_guard<std::mutex> l(mutex_);
        attempts = ++status_.robot_attempts;
        status_.robot_last_error = msg;
        ever_up = status_.robot_ever_up;
      }
      if (msg != last_msg) {  // one line per distinct reason, not per attempt
        log_(std::string(ever_up ? "reconnect" : "robot connection") + " attempt " +
             std::to_string(attempts) + " failed: " + msg + " (retrying with backoff)");
        last_msg = msg;
      }
    }
    beat();
    if (fresh == nullptr && !pause(backoff.next())) return false;
  }
  double outage_s = 0.0;
  std::uint32_t failed = 0;
  bool first = false;
  {
    std::lock_guard<std::mutex> l(mutex_);
    first = !status_.robot_ever_up;
    arm_ = std::move(fresh);
    outage_s = std::chrono::duration<double>(Clock::now() - down_since_).count();
    status_.robot_down_total_s += outage_s;
    status_.robot_up = true;
    status_.robot_ever_up = true;
    failed = status_.robot_attempts;
    if (!first) ++status_.robot_reconnects;
    offered_ = arm_.get();
  }
  cv_.notify_all();
  if (first) {
    log_("robot link to " + options_.robot_name + " up after " + seconds(outage_s) + " s (" +
         std::to_string(failed) + " failed attempts); the loop starts");
  } else {
    log_("robot link to " + options_.robot_name + " restored after " + seconds(outage_s) + " s (" +
         std::to_string(failed) + " failed attempts); the loop resumes");
  }
  return true;
}

void LoopOwner::linkThread() {
  // Started without a robot (ftidd came up before the controller): connect first.
  bool connected = false;
  {
    std::lock_guard<std::mutex> l(mutex_);
    connected = arm_ != nullptr;
  }
  if (!connected) {
    log_("no robot link to " + options_.robot_name + " yet; connecting (backoff " +
         seconds(options_.backoff.min_s) + " s doubling to " + seconds(options_.backoff.max_s) +
         " s), publishing valid = false meanwhile");
    if (!connectWithBackoff()) return;
  }
  for (;;) {
    // While a session runs: wait for its end, keeping the sensor link.
    rt::LoopExit exit = rt::LoopExit::kStopRequested;
    bool ended = false;
    {
      std::unique_lock<std::mutex> l(mutex_);
      cv_.wait_for(l, options_.tick, [this] { return stop_ || session_ended_ || loop_done_; });
      if (stop_ || loop_done_) return;
      ended = session_ended_;
      session_ended_ = false;
      exit = last_exit_;
    }
    beat();
    serviceSensor();
    if (!ended) continue;

    // The session ended: the robot link is lost.
    const std::string why = printableLine(
        describeSessionEnd(exit, arm_ != nullptr ? arm_->lastError() : "", options_.exec), 300);
    std::unique_ptr<ArmStateSource> old;
    {
      std::lock_guard<std::mutex> l(mutex_);
      status_.robot_up = false;
      status_.robot_attempts = 0;
      status_.robot_last_error = why;
      down_since_ = Clock::now();
      if (arm_ != nullptr) skipped_closed_ += arm_->packetsSkipped();
      old = std::move(arm_);
    }
    log_("robot link to " + options_.robot_name + " lost: " + why + "; reconnecting (backoff " +
         seconds(options_.backoff.min_s) + " s doubling to " + seconds(options_.backoff.max_s) + " s)");
    old.reset();  // closes the connection (outside the lock: it may wait for the socket)
    if (!connectWithBackoff()) return;
  }
}

}  // namespace ftid::daemon
