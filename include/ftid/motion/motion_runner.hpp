#pragma once
// Streams a joint trajectory to an Arm in a device-clocked real-time loop and records every tick.
//
// Phases (one loop, the controller is the clock):
//   0. arming:   the loop's first cycles arm the robot program's RTDE watchdog (Arm::sendArmWatchdog
//      until the program reports done, then sendClearCommand until ready; bounded by
//      MotionConfig::watchdog_arm_timeout) and send no servo target; from then on every cycle writes
//      the command register (the watchdog's kick). Arming here, not on the calling thread, means a
//      stall of the calling thread before the loop (page faults, a slow pre-motion check, load)
//      cannot fire the watchdog and end the run;
//   1. approach: a quintic rest-to-rest move from the current pose to the trajectory's start pose,
//      slow (MotionConfig::approach_velocity / approach_acceleration), streamed through servoj;
//   2. settle:   hold the start pose until |actual_q - start| < start_tolerance (bounded time);
//   3. excite:   target(k) = q(t_k + period - t_0) computed from the ROBOT timestamp t_k;
//   4. finish:   hold the final pose for settle_time, then stop.
// Every tick: the state is recorded (preallocated buffer), checked (safety/robot mode, program
// state, lost packages, tracking error, caller abort), the optional hook is called, a target is
// sent. Any abort condition sends servoStop at once; after the loop the runner keeps reading
// until the arm is at rest (bounded), so the recording shows the stop. Data recorded up to the
// abort is kept. Nothing in the loop allocates, throws or does I/O (test/rt_safety).
#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "ftid/common/types.hpp"
#include "ftid/drivers/ur/arm.hpp"
#include "ftid/rt/loop_stats.hpp"
#include "ftid/rt/rt_setup.hpp"

namespace ftid::motion {

/// A joint-space trajectory the runner can sample in the loop. sample() must be real-time safe.
class JointTrajectorySource {
 public:
  virtual ~JointTrajectorySource() = default;
  /// q at time t in [0, duration()] (outside: clamp to the ends). Returns false if unavailable.
  virtual bool sample(double t, JointVector* q) const noexcept = 0;
  virtual double duration() const noexcept = 0;
  JointVector startPose() const noexcept {
    JointVector q = JointVector::Zero();
    sample(0.0, &q);
    return q;
  }
};

/// Adapter for any type with `evaluate(double t) -> {q, qd, qdd}` (e.g. trajectory::FourierTrajectory).
template <class Trajectory>
class EvaluatedTrajectory final : public JointTrajectorySource {
 public:
  explicit EvaluatedTrajectory(const Trajectory& trajectory) : trajectory_(trajectory) {}
  bool sample(double t, JointVector* q) const noexcept override {
    const double d = trajectory_.duration();
    *q = trajectory_.evaluate(t < 0.0 ? 0.0 : (t > d ? d : t)).q;
    return true;
  }
  double duration() const noexcept override { return trajectory_.duration(); }

 private:
  const Trajectory& trajectory_;
};

/// A sampled trajectory (t strictly increasing, starting at 0) with linear interpolation.
class SampledTrajectory final : public JointTrajectorySource {
 public:
  /// Throws DataError if t is not strictly increasing, does not start at 0, or q is non-finite.
  SampledTrajectory(std::vector<double> t, std::vector<JointVector> q);
  bool sample(double t, JointVector* q) const noexcept override;
  double duration() const noexcept override { return t_.empty() ? 0.0 : t_.back(); }

 private:
  std::vector<double> t_;
  std::vector<JointVector> q_;
  mutable std::size_t cursor_ = 0;  // monotone search hint (single-threaded use)
};

/// The exact joint targets a run will stream, computed before any motion from the robot's current
/// pose and the controller period (assuming no lost packages; a lost package only skips a target
/// of the same path).
struct PlannedMotion {
  double period = 0.0;                  ///< controller period [s]
  JointVector current = JointVector::Zero();  ///< robot pose before the run
  std::vector<JointVector> approach;    ///< approach targets, one per tick, ending at the start pose
  std::vector<double> t_traj;           ///< trajectory time of each excitation target [s]
  std::vector<JointVector> q_traj;      ///< excitation targets (k * period, then the end pose)
};

/// Checks a planned motion; returns "" to allow it, else why it must not run (one line per
/// violation). Called by MotionRunner::run before any target is sent (non-real-time).
using PreflightCheck = std::function<std::string(const PlannedMotion& plan)>;

struct MotionConfig {
  double approach_velocity = 0.25;      ///< [rad/s] peak joint speed of the move to the start pose
  double approach_acceleration = 0.5;   ///< [rad/s^2] peak joint acceleration of that move
  double start_tolerance = 0.005;       ///< [rad] start pose reached when every joint is this close
  double settle_timeout = 2.0;          ///< [s] max time to reach start_tolerance after the approach
  double settle_time = 0.25;            ///< [s] hold at the end before stopping
  double tracking_error_limit = 0.05;   ///< [rad] |actual_q - q_traj(t)| that aborts the run
  /// Controller time without a state package that aborts the run [s]: consecutive missed ticks
  /// (wait timeouts) or one timestamp gap longer than this. 0.024 s = 3 ticks at 125 Hz, 12 at
  /// 500 Hz; well inside the program's RTDE watchdog (1 / watchdog_min_hz = 0.1 s).
  double lost_time_limit = 0.024;
  /// During the loop's first startup_grace seconds a longer burst is tolerated: a host under load
  /// often loses a few packages while the real-time thread starts (page faults, migration). 0.064 s
  /// = 8 ticks at 125 Hz, 32 at 500 Hz; below the servo program's RTDE watchdog (0.1 s at the
  /// default watchdog_min_hz = 10), which still stops the arm by itself if the host stalls longer.
  /// The arm is at rest then (first approach targets), so a held target is harmless.
  double startup_lost_time_limit = 0.064;
  double startup_grace = 0.5;  ///< [s] of controller time after the loop starts
  /// [s] of controller time the loop's first cycles may take to arm the program's RTDE watchdog
  /// (2-3 ticks with the simulator); after that the run ends with kWatchdogNotArmed and
  /// nothing has moved.
  double watchdog_arm_timeout = 0.5;
  double timeout_periods = 1.5;         ///< device wait timeout in controller periods
  bool abort_on_speed_scaling = true;   ///< speed_scaling < 0.99 means the robot time-scales: abort
  double stop_timeout = 2.0;            ///< [s] wait for rest after a stop
  rt::RealtimeConfig realtime{};        ///< loop thread set-up
  /// If set: run() refuses (RunStatus::kRefused, nothing moves) when it returns a reason.
  PreflightCheck preflight;
};

enum class RunStatus : std::uint8_t {
  kCompleted,
  kAborted,          ///< caller abort flag (e.g. SIGINT)
  kNotReady,         ///< robot not RUNNING / NORMAL / program not running before motion
  kProtectiveStop,
  kEmergencyStop,
  kSafetyFault,      ///< any other non-normal safety mode
  kModeChanged,      ///< robot_mode left RUNNING
  kProgramStopped,   ///< runtime_state left PLAYING
  kLostPackets,      ///< missed ticks / timestamp gaps beyond the limits
  kConnectionLost,
  kTrackingError,
  kTargetRejected,   ///< last-hop safety check refused a target
  kSpeedScaled,      ///< speed_scaling < 1
  kRefused,          ///< the preflight check refused the planned motion; nothing moved
  kWatchdogNotArmed, ///< the robot program did not confirm its RTDE watchdog in time; nothing moved
};
const char* runStatusName(RunStatus s) noexcept;

enum class Phase : std::uint8_t { kApproach = 0, kSettle = 1, kExcite = 2, kFinish = 3, kStopping = 4 };

/// One recorded tick.
struct RecordedTick {
  drivers::ur::ArmState state;
  JointVector q_command = JointVector::Zero();  ///< target sent after this state
  double t_traj = -1.0;                         ///< trajectory time of state.timestamp (excite phase), else -1
  Phase phase = Phase::kApproach;
};

struct RunResult {
  RunStatus status = RunStatus::kNotReady;
  std::string message;        ///< one clear sentence (what happened, when, values)
  std::size_t ticks_recorded = 0;
  double excitation_start_timestamp = -1.0;  ///< robot timestamp of trajectory t = 0
  double max_tracking_error = 0.0;           ///< [rad] during the excite phase
  rt::LoopStats stats{};
  rt::RealtimeReport realtime{};
  bool ok() const noexcept { return status == RunStatus::kCompleted; }
};

/// Per-cycle hook: called in the loop thread after each state is recorded. Must be real-time safe.
using CycleHook = void (*)(void* context, const RecordedTick& tick) noexcept;

/// Live progress for a UI thread (all atomics).
struct RunProgress {
  std::atomic<int> phase{0};           ///< Phase as int
  std::atomic<double> elapsed{0.0};    ///< [s] of trajectory time streamed
  std::atomic<double> duration{0.0};   ///< [s] trajectory duration
  std::atomic<bool> running{false};
};

class MotionRunner {
 public:
  /// capacity: ticks the recording can hold (allocated here, never in the loop). When full, later
  /// ticks are not recorded (counted in RunResult message) but the run continues.
  MotionRunner(drivers::ur::Arm& arm, MotionConfig config, std::size_t capacity);

  /// Empty if the state allows motion, else the reason ("robot_mode is POWER_OFF", ...).
  static std::string readinessProblem(const drivers::ur::ArmState& s);

  /// Runs the phases above. Blocks; the loop runs on its own (real-time) thread. Throws only for
  /// set-up errors (RealtimeSetupError when realtime.require is set).
  RunResult run(const JointTrajectorySource& trajectory, const std::atomic<bool>* abort = nullptr,
                CycleHook hook = nullptr, void* hook_context = nullptr);

  /// Ticks recorded by the last run.
  const std::vector<RecordedTick>& recording() const noexcept { return recording_; }
  const RunProgress& progress() const noexcept { return progress_; }
  /// Capacity needed for a trajectory of `duration` s at `period` plus approach and margins.
  static std::size_t capacityFor(double duration, double period, double approach_and_margin_s = 60.0);

  /// The targets run() would stream from `current` at `period` (what the preflight check sees).
  PlannedMotion plan(const JointTrajectorySource& trajectory, const JointVector& current, double period) const;

 private:
  drivers::ur::Arm& arm_;
  MotionConfig config_;
  std::vector<RecordedTick> recording_;
  std::size_t capacity_;
  RunProgress progress_;
};

}  // namespace ftid::motion
