#pragma once
// ftidd's set-up (private to src/daemon): everything Daemon::run() builds before a thread starts,
// in dependency order. The constructor throws ftid::Error (named file, key or peer) on any
// set-up failure; nothing here runs on the loop.
//
//   DaemonSetup s(cfg, options);   // math, parameters, LCM, commands, sensor, robot, the cycle
//   LoopOwner owner(s.cycle.get(), s.loop_stats.get(), s.armConnector(), s.sensorLink(), ...);
//   owner.start(nullptr);  // the link thread connects the robot
//   Supervisor sup(s, owner, ...);
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>

#include "ftid/config/daemon_config.hpp"
#include "ftid/daemon/adapters.hpp"
#include "ftid/daemon/daemon.hpp"
#include "ftid/daemon/daemon_cycle.hpp"
#include "ftid/daemon/loop_owner.hpp"
#include "ftid/daemon/output_stage.hpp"
#include "ftid/daemon/payload_watch.hpp"
#include "ftid/daemon/plausibility.hpp"
#include "ftid/daemon/reloader.hpp"
#include "ftid/daemon/tare.hpp"
#include "ftid/drivers/can/ft_imu_sensor.hpp"
#include "ftid/rt/loop_stats.hpp"
#include "ftid/rt/mailbox.hpp"
#include "ftid/rt/rt_setup.hpp"
#include "ftid/transport/codec.hpp"
#include "ftid/transport/command_auth.hpp"
#include "ftid/transport/lcm_outbox.hpp"

namespace ftid::daemon {

/// One line on stderr (the journal under systemd), prefixed "ftidd: ".
void logLine(const std::string& line);

/// The compensation's motion source from `sensor.motion_source` (validated by the config reader).
inline compensate::MotionSource motionSource(const config::DaemonConfig& cfg) {
  return cfg.sensor.motion_source == "imu" ? compensate::MotionSource::kImu : compensate::MotionSource::kKinematics;
}

/// Commands received by the outbox's receive thread, taken by the supervisor (bounded: 64).
struct CommandQueue {
  std::mutex mutex;
  std::deque<ftid_lcm::command_t> queue;
  static void push(const ftid_lcm::command_t& c, void* self);
  bool pop(ftid_lcm::command_t* c);
};

struct DaemonSetup {
  DaemonSetup(const config::DaemonConfig& config, const DaemonRunOptions& options);

  /// Connects and validates the robot (RtdeArmSource), on the loop owner's link thread: the
  /// first connection and every reconnect (set-up does not wait for the robot).
  ArmConnector armConnector() const;
  /// The sensor transport for the loop owner's link thread (reopen the same endpoint).
  SensorLink sensorLink();
  LoopOwnerOptions loopOwnerOptions() const;

  const config::DaemonConfig& cfg;
  rt::RealtimeConfig rt_cfg;
  rt::RealtimeReport rt_report;

  // Math and parameters. The factory reads the parameter file with the tare state next to it
  // (applied if it belongs to this content; docs/daemon.md, "Tare") and remembers what it built.
  std::unique_ptr<KinematicsMotionModel> motion;
  bool apply_tare = true;      ///< false during a reload: a reload discards the tare
  /// What the robot and sensor can carry (robot.rated_payload_kg, the DBC's ranges): every set
  /// built (start, reload, tare) is checked against it first (issue 26).
  params::PlausibilityLimits limits;
  LoadedParameters built;      ///< the set of the last successful build
  LoadedParameters active;     ///< the set of the parameters offered to the loop
  bool have_active = false;
  rt::OwnedSwapSlot<Compensation> params;
  std::unique_ptr<ParameterReloader> reloader;
  std::int32_t reloads_failed = 0;

  // Publishing and commands.
  transport::OutboxOptions out_opt;
  std::unique_ptr<transport::LcmOutbox> outbox;
  std::unique_ptr<transport::CommandVerifier> verifier;
  CommandQueue commands;

  // Devices.
  drivers::can::CanSensorConfig can_cfg;
  std::unique_ptr<CanSensorSource> sensor;

  // The loop.
  std::unique_ptr<OutboxSink> sink;
  std::unique_ptr<DaemonCycle> cycle;
  std::unique_ptr<OutputStage> output_stage;
  std::unique_ptr<rt::Mailbox<TareRequest>> tare_requests;
  std::unique_ptr<rt::Mailbox<TareResult>> tare_results;
  std::unique_ptr<rt::LoopStats> loop_stats;
  std::unique_ptr<rt::Mailbox<rt::LoopStats>> stats_box;
  // The payload monitor (null when monitor.enabled is false): the loop hands over, the watch's
  // thread decides and publishes payload_monitor_t on monitor.channel.
  std::unique_ptr<MonitorLink> monitor_link;
  std::unique_ptr<PayloadWatch> payload_watch;
  rt::ExecutorConfig exec;
  double period_s = 0.008;
  double budget_us = 4000.0;  ///< computation time counted as an overrun [us]

 private:
  // The constructor's steps, in this order (each needs those before it).
  /// rt_cfg from the rt section; locks the process memory if rt.lock_memory.
  void setUpRealtime();
  /// The kinematics with the sensor mount, the plausibility limits and the parameter reloader.
  void setUpCompensation();
  /// The reloader's factory: the compensation from a parameter file (with its tare), remembered in
  /// `built`. Throws on a file that cannot be read or is not plausible.
  std::unique_ptr<Compensation> buildCompensation(const std::string& path);
  /// The first parameter load: active on success; a failure throws if parameters.required.
  void loadFirstParameters();
  /// out_opt (channels, source filter, recording path, checked writable) and the outbox.
  void setUpOutbox(const DaemonRunOptions& options);
  /// The command key (commands refused without one), the verifier and the command queue.
  void setUpCommands();
  /// can_cfg and the sensor, retried with the reconnect backoff for connect_timeout_s.
  void openSensor(double connect_timeout_s);
  /// The cycle with its sink, output stage and tare mailboxes.
  void setUpCycle();
  /// The payload monitor's link and watch, if monitor.enabled.
  void setUpMonitor();
  /// Loop statistics, the executor's period and miss limits, and the overrun budget.
  void setUpLoopTiming();
};

}  // namespace ftid::daemon
