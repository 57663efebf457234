#pragma once
// DaemonCycle: one cycle of ftidd (docs/daemon.md), written against the seams of
// ftid/daemon/seams.hpp so that it runs in unit tests without threads or hardware.
//
//   waitForTick(timeout)  arm->waitForState()                    (the robot is the clock)
//                         then, if the sample after the robot state's time has not arrived
//                         yet, sensor->waitForSample() for it, bounded (max_sensor_wait_us,
//                         half a robot period; not while the sensor is silent)
//   onTick()              step(): swap in new parameters if a reload posted them
//                               -> drain the sensor: every new sample into the history
//                               -> the sensor sample at the robot state's time: robot_time
//                                  mapped to the host clock (RobotClockMap), interpolated
//                                  between the two bracketing samples (SensorHistory)
//                               -> flag stale/invalid data (ages on the monotonic clock;
//                                  never compensated as valid)
//                               -> sensor motion from the joint state (kinematics)
//                               -> compensation with the current parameters
//                               -> hand the CycleRecord to the sink (LcmOutbox queue)
//   onMissed(n)           count, raise kFaultRobotTimeout
//
// onTick(), onMissed() and step() are noexcept and allocation-free (test/rt_safety proves it).
// Counters are atomics read by the supervisor thread.
#include <atomic>
#include <chrono>
#include <cstdint>

#include "ftid/common/status.hpp"
#include "ftid/daemon/output_stage.hpp"
#include "ftid/daemon/payload_watch.hpp"
#include "ftid/daemon/seams.hpp"
#include "ftid/rt/swap_slot.hpp"
#include "ftid/daemon/time_pairing.hpp"
#include "ftid/rt/cyclic_executor.hpp"
#include "ftid/rt/loop_stats.hpp"
#include "ftid/rt/mailbox.hpp"
#include "ftid/common/records.hpp"

namespace ftid::daemon {

using rt::CycleAction;

/// CLOCK_REALTIME in microseconds (the clock of LCM utime fields and sensor receive times).
std::int64_t realtimeNowUs() noexcept;
/// CLOCK_MONOTONIC in microseconds.
std::int64_t monotonicNowUs() noexcept;

struct CycleOptions {
  /// A sensor sample older than this at the start of a cycle, on the host's monotonic clock
  /// (now - recv_mono_us), is stale [us]. The same bound
  /// applies to the pairing: a sample used for the robot state's time that lies farther than
  /// this from it (or two bracketing samples farther apart) is stale as well.
  std::int64_t stale_timeout_us = 20'000;
  /// Window of the robot clock offset estimate (RobotClockMap) in controller seconds.
  double clock_window_s = 1.0;
  /// waitForTick() waits at most this long [us] (and at most half a robot period) for the
  /// sensor sample that follows the robot state's time, so that the two samples bracketing it
  /// exist (docs/daemon.md, "Time base"). 0: never wait (the newest sample is used whenever the
  /// following one has not arrived yet).
  std::int64_t max_sensor_wait_us = 1500;
  /// Clock of utime and of the pairing's host times (recv_utime; tests inject a fake). Must be
  /// noexcept and RT-safe.
  std::int64_t (*now_us)() noexcept = &realtimeNowUs;
  /// The host's monotonic clock [us]: the clock of sensor ages and staleness (recv_mono_us) and
  /// the one against which the controller's clock is checked (ControllerClockCheck). nullptr:
  /// CLOCK_MONOTONIC, or, when a test injected now_us, that fake clock (one fake serves both).
  /// Must be noexcept and RT-safe.
  std::int64_t (*mono_now_us)() noexcept = nullptr;
  ControllerClockCheck::Options clock_check;
};

/// Counters of the loop, written by the loop thread, read by anyone.
struct CycleCounters {
  std::atomic<std::uint64_t> cycles{0};          ///< onTick() calls (the heartbeat)
  std::atomic<std::uint64_t> missed{0};          ///< onMissed() calls
  std::atomic<std::uint64_t> valid{0};           ///< cycles with a valid compensated wrench
  std::atomic<std::uint64_t> invalid{0};         ///< cycles without
  std::atomic<std::uint64_t> stale_sensor{0};    ///< cycles with a stale sensor sample (the
                                                 ///< newest or the one used older than the timeout)
  std::atomic<std::uint64_t> robot_clock_invalid{0};  ///< cycles invalid: controller clock not sane
  std::atomic<std::uint64_t> robot_clock_faults{0};   ///< controller clock faults detected
  std::atomic<std::uint64_t> invalid_sensor{0};  ///< cycles with an invalid (not stale) sample
  std::atomic<std::uint64_t> invalid_robot{0};   ///< cycles with an unusable robot state
  std::atomic<std::uint64_t> no_parameters{0};   ///< cycles without parameters loaded
  std::atomic<std::uint64_t> model_failures{0};  ///< compensation returned non-finite values
  std::atomic<std::uint64_t> sink_dropped{0};    ///< records the sink refused (queue full)
  std::atomic<std::uint64_t> param_swaps{0};     ///< parameter objects taken into use
  /// How the sensor sample of a cycle was paired with the robot state (SensorPairing):
  std::atomic<std::uint64_t> sensor_interpolated{0};  ///< at the robot state's time
  std::atomic<std::uint64_t> sensor_one_sided{0};     ///< nearest sample (kNewest / kOldest)
  std::atomic<std::uint64_t> sensor_unpaired{0};      ///< newest sample (no history/robot time)
  std::atomic<std::uint64_t> sensor_waits{0};         ///< waitForTick() waited for a sample
  std::atomic<std::uint64_t> sensor_wait_timeouts{0}; ///< ... and it did not come in time
  std::atomic<std::int64_t> last_utime{0};       ///< utime of the last cycle
};

/// A tare request from the command thread to the loop (docs/daemon.md, "Tare").
struct TareRequest {
  std::uint64_t id = 0;            ///< non-zero, increasing; echoed in the result
  std::uint32_t cycles = 125;      ///< valid cycles to average (the window)
  double max_qd_rad_s = 0.01;      ///< |qd_j| above this in the window: refused (robot moves)
  double max_qdd_rad_s2 = 0.05;    ///< |qdd_j| above this in the window: refused
};

enum class TareOutcome : std::int8_t {
  kOk = 0,
  kMoving = 1,             ///< qd or qdd beyond the threshold during the window
  kInvalid = 2,            ///< a cycle without a valid compensated wrench during the window
  kParametersChanged = 3,  ///< the parameters in use changed during the window
};

/// The loop's answer: mean contact wrench over the window (in S), to be added to the offsets.
struct TareResult {
  std::uint64_t id = 0;
  TareOutcome outcome = TareOutcome::kOk;
  std::uint32_t cycles = 0;         ///< cycles accumulated before the end / the refusal
  std::uint32_t param_version = 0;  ///< parameters the contact was computed with
  double max_qd = 0.0;              ///< largest |qd_j| seen [rad/s]
  double max_qdd = 0.0;             ///< largest |qdd_j| seen [rad/s^2]
  Wrench mean_contact_S = Wrench::Zero();
};

/// Loop-side accumulation of a tare window: fixed size, noexcept, allocation-free.
class TareAccumulator {
 public:
  /// Starts a window (replaces one in progress).
  void start(const TareRequest& request) noexcept;
  bool active() const noexcept { return active_; }
  /// Adds one cycle. Returns true when the window ended (done or refused); then *result is set.
  bool add(const CycleRecord& rec, TareResult* result) noexcept;

 private:
  TareRequest request_;
  bool active_ = false;
  std::uint32_t n_ = 0;
  std::uint32_t version_ = 0;
  double max_qd_ = 0.0;
  double max_qdd_ = 0.0;
  Wrench sum_ = Wrench::Zero();
};

class DaemonCycle {
 public:
  /// All pointers must outlive the cycle. params may hold no object yet (then every cycle is
  /// published with wrench_valid = false and kFaultNone for the parameters).
  DaemonCycle(ArmStateSource* arm, SensorSource* sensor, const MotionModel* motion,
              rt::OwnedSwapSlot<Compensation>* params, CycleSink* sink, CycleOptions options = {});

  // ftid::rt executor interface (runDeviceClocked).
  Status waitForTick(std::chrono::nanoseconds timeout) noexcept;
  CycleAction onTick() noexcept;
  CycleAction onMissed(std::uint32_t consecutive_missed) noexcept;

  /// One cycle for the given robot state (what onTick() does after waitForTick()); the result
  /// is also handed to the sink. `out` may be nullptr.
  void step(const RobotStateRecord& robot, CycleRecord* out) noexcept;

  /// Every `every_n_cycles` ticks, onTick() copies *stats (the executor's, updated by the loop
  /// thread) into *box for the supervisor. Call before the loop starts.
  void attachLoopStats(const rt::LoopStats* stats, rt::Mailbox<rt::LoopStats>* box,
                       std::uint32_t every_n_cycles) noexcept {
    loop_stats_ = stats;
    stats_box_ = box;
    stats_every_ = every_n_cycles > 0 ? every_n_cycles : 1;
  }

  /// The output stage (frame, low-pass) applied to the contact wrench of every cycle; nullptr =
  /// output = contact in S. Call before the loop starts.
  void attachOutputStage(OutputStage* stage) noexcept { output_stage_ = stage; }

  /// Tare: step() takes a request from *requests, accumulates its window over the following
  /// cycles and writes the result to *results (both wait-free mailboxes; the command thread
  /// builds the new parameters off the loop). Call before the loop starts.
  void attachTare(rt::Mailbox<TareRequest>* requests, rt::Mailbox<TareResult>* results) noexcept {
    tare_requests_ = requests;
    tare_results_ = results;
  }

  /// Payload monitor (docs/daemon.md, "Payload monitor"): every valid cycle hands its residual
  /// and motion to *link (wait-free), and every record gets the link's flags (kFlagPayload*).
  /// Call before the loop starts; nullptr = no monitor.
  void attachMonitor(MonitorLink* link) noexcept { monitor_link_ = link; }

  /// Replaces the robot state source (a new connection after a link loss). Only while no
  /// executor runs this cycle (the loop owner calls it between two sessions, on the loop thread).
  /// Parameters, tare, sensor history and cycle numbering carry over; the output low-pass
  /// restarts at the first valid wrench (the contact may have changed while no package came).
  /// The controller clock check restarts too: a new connection (or a rebooted controller) is a
  /// new clock session, not a jump of the old one.
  void setArm(ArmStateSource* arm) noexcept {
    arm_ = arm;
    if (output_stage_ != nullptr) output_stage_->reset();
    clock_check_ = ControllerClockCheck(options_.clock_check);
  }
  ArmStateSource* arm() const noexcept { return arm_; }

  const CycleCounters& counters() const noexcept { return counters_; }
  /// Fault bits raised since the supervisor last cleared them.
  FaultWord& faults() noexcept { return faults_; }
  /// Version of the parameters in use (0 = none).
  std::uint32_t paramVersion() const noexcept { return params_->version(); }
  /// The record of the most recent cycle (loop thread / tests only).
  const CycleRecord& lastRecord() const noexcept { return record_; }
  /// The newest sensor sample of the most recent cycle as the source reported it (before
  /// pairing; loop thread / tests only).
  const SensorSampleRecord& lastNewestSample() const noexcept { return latest_; }
  /// How the most recent cycle paired its sensor sample (loop thread / tests only).
  SensorPairing lastPairing() const noexcept { return last_pairing_; }
  /// Host time [us] the most recent robot state was mapped to (0 if none; loop thread / tests).
  std::int64_t lastPairTimeUs() const noexcept { return last_pair_time_us_; }
  const RobotClockMap& clockMap() const noexcept { return clock_map_; }
  const ControllerClockCheck& clockCheck() const noexcept { return clock_check_; }

 private:
  void awaitBracketingSample() noexcept;
  // The steps of step(), in order (daemon_cycle.cpp); each works on record_.
  Compensation* acquireParameters() noexcept;
  void beginRecord(const RobotStateRecord& robot, std::int64_t now) noexcept;
  bool checkRobotState(const RobotStateRecord& robot) noexcept;
  bool checkControllerClock(const RobotStateRecord& robot, bool robot_ok,
                            std::int64_t mono_now) noexcept;
  void pairSensorSample(const RobotStateRecord& robot, std::int64_t now) noexcept;
  bool checkSensorSample(std::int64_t mono_now) noexcept;
  void compensate(const RobotStateRecord& robot, Compensation* comp, bool inputs_valid) noexcept;
  double sampleTimeS(const RobotStateRecord& robot) noexcept;
  double modelTimeS(const RobotStateRecord& robot, const Compensation& comp) noexcept;
  void makeContext(const RobotStateRecord& robot, const Compensation& comp, double t_s,
                   double t_model_s) noexcept;
  void computeContact(Compensation* comp) noexcept;
  void applyOutputStage() noexcept;
  void countAndTare() noexcept;
  void publish(std::int64_t now, CycleRecord* out) noexcept;

  MonitorLink* monitor_link_ = nullptr;

  ArmStateSource* arm_;
  SensorSource* sensor_;
  const MotionModel* motion_;
  rt::OwnedSwapSlot<Compensation>* params_;
  CycleSink* sink_;
  CycleOptions options_;
  CycleCounters counters_;
  FaultWord faults_;
  RobotStateRecord robot_;  // filled by waitForTick
  CycleRecord record_;
  effects::SampleContext ctx_;
  SensorHistory history_;
  RobotClockMap clock_map_;
  ControllerClockCheck clock_check_;
  SensorSampleRecord latest_;
  SensorPairing last_pairing_ = SensorPairing::kNone;
  std::int64_t last_pair_time_us_ = 0;
  double prev_wait_robot_time_ = 0.0;  // robot_time of the previous waitForTick() state
  OutputStage* output_stage_ = nullptr;
  rt::Mailbox<TareRequest>* tare_requests_ = nullptr;
  rt::Mailbox<TareResult>* tare_results_ = nullptr;
  TareAccumulator tare_;
  TareRequest tare_request_;
  TareResult tare_result_;
  const rt::LoopStats* loop_stats_ = nullptr;
  rt::Mailbox<rt::LoopStats>* stats_box_ = nullptr;
  std::uint32_t stats_every_ = 1;
  std::uint32_t since_stats_ = 0;
  std::int64_t cycle_number_ = 0;
  double first_robot_time_ = 0.0;  ///< anchor of the sample time t (re-anchored on a clock reset)
  double last_robot_time_ = 0.0;
  bool have_first_time_ = false;
  double first_host_time_s_ = 0.0;  ///< host time of the first valid cycle [s since the epoch]
  bool have_first_host_time_ = false;
};

}  // namespace ftid::daemon
