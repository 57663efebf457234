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
};

}  // namespace ftid::daemon
