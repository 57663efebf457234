#pragma once
// `ftid sim-sensor`: a simulated F/T+IMU sensor on CAN (docs/sensor.md, "Sensor simulator").
// It learns the robot's motion from a UR controller (or `ftid sim-robot`) over RTDE (read-only
// output recipe: timestamp, actual_q, actual_qd, target_qdd), computes the reading with the cell
// simulator's physics (ftid::sim::CellSim, same payload/effect/noise switches) at its own rate,
// encodes the frames per the DBC and serves them on the SOCK_SEQPACKET stand-in socket (and
// optionally a real SocketCAN interface). Robot state between RTDE ticks: cubic Hermite
// interpolation from (q, qd) at both ends; past the newest tick, constant-acceleration
// extrapolation for up to three robot periods, then the robot is held still.
#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "ftid/common/types.hpp"
#include "ftid/drivers/can/sensor_layout.hpp"
#include "ftid/sim/cell_sim.hpp"

namespace ftid::simsensor {

/// Faults the simulated sensor can be told to produce.
enum class SensorFault : std::uint8_t {
  kSilent,        ///< send nothing for `count` samples (the counter keeps running: a gap follows)
  kCounterGap,    ///< skip `count` counter values once
  kOutOfRange,    ///< Fx beyond its DBC range (1.2 x max) for `count` samples
  kErrorFrame,    ///< `count` error frames (controller problem, RX warning)
  kBusOff,        ///< one bus-off error frame
  kStuckCounter,  ///< repeat the same counter for `count` samples
  kStatusFault,   ///< status word bit 1 (IMU fault) for `count` samples
};
/// "silent", "counter_gap", "out_of_range", "error_frame", "bus_off", "stuck_counter",
/// "status_fault". Throws ConfigError listing the names otherwise.
SensorFault parseSensorFault(const std::string& name);
const char* sensorFaultName(SensorFault fault) noexcept;

struct ScheduledSensorFault {
  double at_s = 1.0;  ///< physics time (seconds since the first robot state) at which to inject
  SensorFault kind = SensorFault::kSilent;
  int count = 1;
};

struct SimSensorConfig {
  std::string robot_host = "127.0.0.1";
  std::uint16_t rtde_port = 30004;
  double rtde_frequency_hz = 0.0;  ///< 0: the controller's rate (125 Hz CB3, 500 Hz e-Series)
  std::string urdf_path = "config/ur10.urdf";
  std::string socket_path = "/run/ftid/ftsensor.sock";
  std::string can_interface;       ///< also send on this SocketCAN interface ("" = no)
  std::string dbc_path = "config/ftsensor.dbc";
  std::string candump_log;         ///< also write every frame sent to this candump log ("" = no)
  double rate_hz = 1000.0;         ///< sensor sample rate
  double duration_s = 0.0;         ///< stop after this much physics time (0 = until stopped)
  /// Physics: payload, offsets, tilt, noise, seed, mount and effect switches. robot/trajectory
  /// are not used (the motion comes from RTDE). Default: the paper's Table 2 payload, no noise.
  sim::CellSimConfig cell;
  std::vector<ScheduledSensorFault> faults;
  bool verbose = false;
};

/// The default configuration: paper payload (sim::PaperPayload), everything else off.
SimSensorConfig defaultSimSensorConfig();
/// Reads a YAML file over `config` (keys in config/sim_sensor.yaml). Errors name the file and key.
void loadSimSensorYaml(const std::string& path, SimSensorConfig& config);
/// Switches one effect on by name: cable, temperature_drift, time_drift, sensor_delay, crosstalk,
/// contact, rigid_body (= full_rigid_body), paper_only (= !full_rigid_body), noise (typical sensor
/// noise). Throws ConfigError listing the names otherwise.
void enableEffect(const std::string& name, SimSensorConfig& config);

/// Robot states received over RTDE, in controller time, with interpolation (thread-safe).
class RobotHistory {
 public:
  static constexpr std::size_t kCapacity = 2048;
  struct Tick {
    double t = 0.0;  ///< controller timestamp [s]
    JointVector q = JointVector::Zero();
    JointVector qd = JointVector::Zero();
    JointVector qdd = JointVector::Zero();
  };
  /// Appends a tick. A tick older than the newest is ignored, unless it is more than a second
  /// older: then the controller was restarted and the history starts afresh (generation() + 1).
  void add(const Tick& tick);
  /// Incremented whenever the history was restarted.
  std::uint64_t generation() const;
  /// State at controller time t (see the file comment). False if there is no tick yet.
  bool stateAt(double t, Tick& out) const;
  bool empty() const;
  double newestTime() const;
  double oldestTime() const;
  std::size_t size() const;
  /// Nominal controller period [s] (median spacing of the last ticks; 0.008 before two ticks).
  double period() const;

 private:
  mutable std::mutex mutex_;
  std::array<Tick, kCapacity> ring_{};
  std::size_t head_ = 0;  ///< index of the next write
  std::size_t count_ = 0;
  double period_ = 0.008;
  std::uint64_t generation_ = 0;
};

/// Turns robot state + time into CAN frames (physics, noise, faults, counter). Not thread-safe
/// except inject().
class SensorFrameSource {
 public:
  static constexpr int kMaxFrames = drivers::can::SensorLayout::kMaxMessages + 4;

  SensorFrameSource(const SimSensorConfig& config, const drivers::can::SensorLayout& layout,
                    model::RobotKinematics robot);

  /// The physical reading (noise included) for controller time t_robot and physics time t_phys.
  sim::SensorReading readingAt(const RobotHistory& history, double t_robot, double t_phys);
  /// Produces one sample's frames (possibly none, while silent) into out; returns the count.
  int nextSample(const RobotHistory& history, double t_robot, double t_phys,
                 std::array<can_frame, kMaxFrames>& out);
  /// Thread-safe: takes effect at the next sample.
  void inject(SensorFault kind, int count = 1);
  /// Thread-safe: the configured contact push (effects.contact force, point and window length)
  /// starts at the next sample.
  void requestContactPush() noexcept { contact_requested_.store(true); }
  /// Thread-safe: the configured object (`grasp`, payload_change.added) is held from the next
  /// sample on.
  void requestGrasp() noexcept { grasp_requested_.store(true); }
  std::uint32_t counter() const noexcept { return counter_; }
  const sim::CellSim& cell() const noexcept { return cell_; }

 private:
  sim::CellSim cell_;
  drivers::can::SensorLayout layout_;
  std::mt19937_64 rng_;
  bool add_noise_ = false;
  std::uint32_t counter_ = 0;
  std::array<std::atomic<int>, 7> pending_{};  ///< injected faults, by SensorFault
  std::atomic<bool> contact_requested_{false};
  std::atomic<bool> grasp_requested_{false};
  int silent_left_ = 0, out_of_range_left_ = 0, stuck_left_ = 0, status_left_ = 0;
  std::array<double, 6> wrench_max_{};  ///< DBC maximum per wrench axis (overload status bit)
  double fx_fault_value_ = 360.0;
};

struct SimSensorStats {
  std::uint64_t samples = 0;          ///< samples produced (including silent ones)
  std::uint64_t frames_sent = 0;
  std::uint64_t frames_dropped = 0;   ///< a client's queue was full
  std::uint64_t robot_ticks = 0;      ///< RTDE states received
  std::uint64_t late_samples = 0;     ///< samples produced late (scheduling hiccup)
  std::uint64_t skipped_samples = 0;  ///< samples skipped after a long stall (show as gaps)
  int clients = 0;
  double t_phys = 0.0;                ///< physics time of the last sample [s]
  bool robot_connected = false;
};

/// The running simulator: RTDE reader thread + emitter loop.
class SimSensor {
 public:
  /// Loads the URDF and DBC, binds the socket (and SocketCAN). Throws ConfigError/DataError/
  /// DriverError with clear messages.
  explicit SimSensor(SimSensorConfig config);
  ~SimSensor();
  SimSensor(const SimSensor&) = delete;
  SimSensor& operator=(const SimSensor&) = delete;

  /// Runs until `stop` becomes true (or duration_s of physics time). Connects to RTDE (retrying
  /// every second), then emits samples at rate_hz. `progress` gets a status line every few
  /// seconds and on notable events (may be empty).
  void run(const std::atomic<bool>& stop,
           const std::function<void(const std::string&)>& progress = {});
  void inject(SensorFault kind, int count = 1);
  /// Starts the configured contact push now (thread-safe; used on SIGRTMIN+1 by the CLI).
  void startContactPush() noexcept;
  /// Grasps the configured object now (thread-safe; used on SIGRTMIN+2 by the CLI).
  void startGrasp() noexcept;
  SimSensorStats stats() const;
  const SimSensorConfig& config() const noexcept { return config_; }

 private:
  struct Impl;
  SimSensorConfig config_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ftid::simsensor
