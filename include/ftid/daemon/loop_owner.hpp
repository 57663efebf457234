#pragma once
// LoopOwner: ftidd's real-time loop and the links that clock and feed it (docs/daemon.md,
// "Structure"; docs/operations.md, "Link loss and reconnect").
//
//   LoopOwner owner(&cycle, &stats, connectRobot, sensorLink, options, log);
//   owner.start(std::move(first_connection));   // the loop runs
//   ... owner.status(), owner.loopHeartbeat(), owner.linkThreadAlive() from the supervisor ...
//   owner.stop();                               // within one receive timeout (+ a connection
//                                               // attempt in progress)
//
// Two threads:
//  - the loop thread (SCHED_FIFO if permitted, rt::runInRealtimeThread) runs the DaemonCycle
//    under the device-clocked executor, one *session* per robot connection. A session ends when
//    the connection fails (kDeviceFault: TCP keepalive / user timeout, closed, protocol error) or
//    when no state package arrives for ExecutorConfig::max_consecutive_missed receive timeouts
//    (robot.reconnect_after_silence_s). Between sessions the loop thread parks on a condition
//    variable (waking every 0.1 s: its heartbeat advances, so a parked loop is not a wedged one);
//    it never connects, allocates in the cycle, or does set-up work.
//  - the link thread (normal priority) owns the connections: it gives the loop thread the
//    connection for a session, and when a session ends it closes that connection and reconnects
//    with exponential backoff (Backoff, robot.reconnect_backoff_*_s), each attempt validating the
//    controller as at start (ArmConnector), then hands the new connection over: the same
//    DaemonCycle resumes (parameters, tare, sensor history, cycle numbering; the output low-pass
//    restarts at the first valid wrench). It
//    also reopens the sensor transport when it closed or failed (SensorLink), with the same backoff.
//
// The supervisor publishes valid = false while no cycle runs, answers commands, and feeds the
// systemd watchdog from loopHeartbeat(), linkThreadAlive() and status().
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "ftid/daemon/backoff.hpp"
#include "ftid/daemon/daemon_cycle.hpp"
#include "ftid/rt/cyclic_executor.hpp"
#include "ftid/rt/loop_stats.hpp"
#include "ftid/rt/rt_setup.hpp"

namespace ftid::daemon {

/// Opens and validates a robot connection; throws ftid::Error (DriverError, ConfigError) with
/// the reason. Called on the link thread only.
using ArmConnector = std::function<std::unique_ptr<ArmStateSource>()>;

/// The sensor transport as the link thread sees it (all called on the link thread; empty
/// functions = no sensor link to keep).
struct SensorLink {
  std::function<bool()> down;     ///< true if the transport closed or failed (no replacement yet)
  std::function<void()> reopen;   ///< opens a new transport and offers it; throws ftid::Error
  std::function<void()> collect;  ///< frees a replaced transport
  std::function<std::uint32_t()> reconnects;  ///< replacements taken into use
};

struct LoopOwnerOptions {
  rt::RealtimeConfig rt;        ///< the loop thread's scheduling
  rt::ExecutorConfig exec;      ///< period, receive timeout, silence limit (max_consecutive_missed)
  BackoffPolicy backoff;        ///< between reconnection attempts (robot and sensor)
  std::string robot_name;       ///< "host:port", for messages
  std::string sensor_name;      ///< the sensor endpoint, for messages
  /// Slice of the link thread's waits and of the loop thread's parked wake-ups.
  std::chrono::milliseconds tick{100};
};

/// A snapshot for the supervisor (statistics, watchdog, messages).
struct LinkStatus {
  bool robot_up = false;               ///< a session runs or is about to run on a connection
  bool robot_ever_up = false;          ///< a connection was validated at least once
  std::int32_t robot_reconnects = 0;   ///< successful reconnects since start
  double robot_down_total_s = 0.0;     ///< time without a robot connection since start [s]
  double robot_down_current_s = 0.0;   ///< of the current outage [s] (0 while up)
  std::uint32_t robot_attempts = 0;    ///< failed attempts in the current outage
  std::string robot_last_error;        ///< why the link was lost / the last attempt failed
  bool sensor_down = false;
  std::int32_t sensor_reconnects = 0;
  std::uint64_t packets_skipped = 0;   ///< ArmStateSource::packetsSkipped over all connections
};

class LoopOwner {
 public:
  using Log = std::function<void(const std::string&)>;

  /// cycle and stats must outlive the owner; stats is written by the loop thread.
  LoopOwner(DaemonCycle* cycle, rt::LoopStats* stats, ArmConnector connect, SensorLink sensor,
            LoopOwnerOptions options, Log log);
  ~LoopOwner();  ///< stop()
  LoopOwner(const LoopOwner&) = delete;
  LoopOwner& operator=(const LoopOwner&) = delete;

  /// Starts both threads; the loop begins a session on first_arm (already connected). With
  /// first_arm == nullptr (ftidd started before the controller) the loop thread parks and the
  /// link thread connects with the same backoff and checks as for a reconnect; the first
  /// connection is not counted in robot_reconnects.
  void start(std::unique_ptr<ArmStateSource> first_arm);
  /// Ends the session, both threads, and closes the connection. Idempotent.
  void stop();

  LinkStatus status() const;
  /// True (with the reason) if the loop thread ended by itself: its real-time set-up failed
  /// (rt.require_rt) or it threw. ftidd then exits 1.
  bool loopFailed(std::string* why) const;
  /// Advances while the loop thread is alive and not wedged: every cycle, every missed wait
  /// (one receive timeout) and every parked wake-up (LoopOwnerOptions::tick).
  std::uint64_t loopHeartbeat() const noexcept;
  /// True if the link thread showed progress within `limit` (it beats every tick and around
  /// every connection attempt; an attempt is bounded by the RTDE connect and reply timeouts).
  bool linkThreadAlive(std::chrono::steady_clock::duration limit) const noexcept;
  /// True once the loop thread runs with SCHED_FIFO/SCHED_RR.
  bool loopIsRealtime() const noexcept { return loop_fifo_.load(std::memory_order_acquire); }

 private:
  void loopThread();
  void linkThread();
  /// Link thread: waits up to `d` in ticks (beating, servicing the sensor); false if stopping.
  bool pause(std::chrono::nanoseconds d);
  /// Link thread: connects (ArmConnector) with backoff and offers the connection to the loop;
  /// false if stopping.
  bool connectWithBackoff();
  void serviceSensor();
  void beat() noexcept;
  bool stopping() const;

  DaemonCycle* cycle_;
  rt::LoopStats* stats_;
  ArmConnector connect_;
  SensorLink sensor_;
  LoopOwnerOptions options_;
  Log log_;

  std::unique_ptr<ArmStateSource> arm_;  // link thread (and start/stop)
  std::thread launcher_;                 // runs the loop thread (rt::runInRealtimeThread)
  std::thread link_;

  mutable std::mutex mutex_;
  std::condition_variable cv_;
  bool stop_ = false;                    // under mutex_
  ArmStateSource* offered_ = nullptr;    // under mutex_: the connection for the next session
  bool session_ended_ = false;           // under mutex_
  rt::LoopExit last_exit_ = rt::LoopExit::kStopRequested;  // under mutex_
  std::string loop_error_;               // under mutex_
  bool loop_done_ = false;               // under mutex_
  LinkStatus status_;                    // under mutex_ (robot_down_* computed in status())
  std::chrono::steady_clock::time_point down_since_{};  // under mutex_
  std::uint64_t skipped_closed_ = 0;     // under mutex_: packetsSkipped of closed connections

  std::atomic<bool> stop_flag_{false};   // ends runDeviceClocked
  std::atomic<bool> loop_fifo_{false};
  std::atomic<std::uint64_t> parked_ticks_{0};
  std::atomic<std::int64_t> link_beat_ns_{0};
  bool started_ = false;
  Backoff sensor_backoff_;
  std::chrono::steady_clock::time_point next_sensor_attempt_{};
  std::string sensor_last_error_;
};

/// The watchdog decision (docs/operations.md, "Link loss and reconnect"): feed systemd's watchdog
/// only if the loop thread's heartbeat advanced since the last feeding, the link thread is alive,
/// and - if silence_limit_s > 0 (robot.watchdog_silence_s) - the robot has been silent for less
/// than that. silence_limit_s = 0: a healthy process renewing its robot link stays fed.
bool watchdogMayBeFed(bool loop_heartbeat_advanced, bool link_thread_alive, double robot_silent_s,
                      double silence_limit_s) noexcept;

/// "the connection failed: <why>" / "no state package for N receive timeouts ..." for a session
/// end (messages).
std::string describeSessionEnd(rt::LoopExit exit, const char* arm_error,
                               const rt::ExecutorConfig& exec);

}  // namespace ftid::daemon
