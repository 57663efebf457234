#include "daemon_setup.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <thread>

#include "ftid/common/error.hpp"
#include "ftid/daemon/backoff.hpp"
#include "ftid/drivers/can/dbc.hpp"
#include "ftid/drivers/can/sensor_layout.hpp"
#include "ftid/effects/model.hpp"
#include "ftid/transport/source_filter.hpp"

namespace ftid::daemon {

namespace {

using Clock = std::chrono::steady_clock;

// Retries a set-up step that fails with DriverError (peer not up yet) until the deadline, with
// the configured backoff (robot.reconnect_backoff_*_s) so that a restart loop does not hammer a
// controller that is still booting.
template <class F>
auto retryUntil(double timeout_s, const BackoffPolicy& policy, const std::string& what, F&& make)
    -> decltype(make()) {
  const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
  bool announced = false;
  Backoff backoff(policy);
  for (;;) {
    try {
      return make();
    } catch (const DriverError& e) {
      if (Clock::now() >= deadline) throw;
      if (!announced) {
        logLine("waiting for " + what + " (" + e.what() + ")");
        announced = true;
      }
      const auto left = std::chrono::duration_cast<std::chrono::nanoseconds>(deadline - Clock::now());
      std::this_thread::sleep_for(std::min(backoff.next(), std::max(left, std::chrono::nanoseconds(1'000'000))));
    }
  }
}

}  // namespace

void logLine(const std::string& line) {
  std::fprintf(stderr, "ftidd: %s\n", line.c_str());
  std::fflush(stderr);
}

void CommandQueue::push(const ftid_lcm::command_t& c, void* self) {
  auto* q = static_cast<CommandQueue*>(self);
  std::lock_guard<std::mutex> l(q->mutex);
  if (q->queue.size() < 64) q->queue.push_back(c);
}

bool CommandQueue::pop(ftid_lcm::command_t* c) {
  std::lock_guard<std::mutex> l(mutex);
  if (queue.empty()) return false;
  *c = queue.front();
  queue.pop_front();
  return true;
}

DaemonSetup::DaemonSetup(const config::DaemonConfig& config, const DaemonRunOptions& options)
    : cfg(config) {
  setUpRealtime();
  setUpCompensation();
  loadFirstParameters();
  setUpOutbox(options);
  setUpCommands();
  if (!out_opt.record_path.empty()) logLine("recording to " + out_opt.record_path);
  openSensor(options.connect_timeout_s);
  setUpCycle();
  setUpMonitor();
  setUpLoopTiming();
}

void DaemonSetup::setUpRealtime() {
  rt_cfg.enable = true;
  rt_cfg.require = cfg.rt.require_rt;
  rt_cfg.priority = cfg.rt.priority;
  rt_cfg.cpu = cfg.rt.cpu;
  rt_cfg.lock_memory = cfg.rt.lock_memory;
  if (cfg.rt.lock_memory) rt::lockProcessMemory(rt_cfg, &rt_report);
}

void DaemonSetup::setUpCompensation() {
  model::RobotKinematics kinematics = model::RobotKinematics::fromUrdfFile(
      cfg.robot.urdf_path, cfg.robot.base_link, cfg.robot.tip_link);
  kinematics.setSensorMount(cfg.sensor.R_FS(), cfg.sensor.p_FS_F());
  motion = std::make_unique<KinematicsMotionModel>(std::move(kinematics));
  limits = plausibilityLimits(cfg);
  const CompensationFactory factory = [this](const std::string& path) { return buildCompensation(path); };
  reloader = std::make_unique<ParameterReloader>(&params, factory);
  checkSensorDescription(cfg);  // a sensor without the IMU that motion_source needs: a set-up error
  if (motionSource(cfg) == compensate::MotionSource::kImu) {
    logLine("compensating with the motion of the sensor from its IMU (sensor.motion_source: imu): a cycle "
            "without an IMU sample is invalid");
  }
}

std::unique_ptr<Compensation> DaemonSetup::buildCompensation(const std::string& path) {
  LoadedParameters lp = loadParameters(path, apply_tare);
  requirePlausible(lp.set, limits, path);
  auto comp = std::make_unique<ParameterFileCompensation>(lp.set, path, motionSource(cfg));
  if ((effects::Model::fromName(lp.set.model).signals() & effects::kSignalTime) != 0 &&
      !std::isfinite(lp.set.time_origin_unix_s)) {
    logLine(path + ": model '" + lp.set.model + "' reads time but the file has no time_origin (written "
            "before time origins, or identified from a log without host_time): its time runs from ftidd's "
            "first valid cycle (docs/conventions.md, \"Time and logs\")");
  }
  built = std::move(lp);
  return comp;
}

void DaemonSetup::loadFirstParameters() {
  const ReloadResult first = reloader->reload(cfg.parameters.path, std::chrono::milliseconds(0));
  if (!first.ok) {
    if (cfg.parameters.required) throw ConfigError(first.message);
    ++reloads_failed;
    logLine("no payload parameters (" + first.message +
            "): publishing the raw wrench with valid = false until a reload succeeds");
    return;
  }
  params.tryAcquire();  // the loop is not running yet: take it into use here
  params.collectRetired();
  active = built;
  have_active = true;
  logLine("payload parameters loaded from " + cfg.parameters.path +
          (active.tared ? " with the tared offsets of " + tareStatePath(cfg.parameters.path) : ""));
  if (!active.note.empty()) logLine(active.note);
}

void DaemonSetup::setUpOutbox(const DaemonRunOptions& options) {
  out_opt.url = cfg.lcm.url;
  out_opt.channels.cycle = cfg.lcm.channels.cycle;
  out_opt.channels.wrench = cfg.lcm.channels.wrench;
  out_opt.channels.stats = cfg.lcm.channels.stats;
  out_opt.channels.command = cfg.lcm.channels.command;
  out_opt.channels.ack = cfg.lcm.channels.ack;
  out_opt.publish_cycle = cfg.lcm.publish_cycle;
  if (!cfg.lcm.accept_remote) out_opt.allowed_sources = transport::localSources();
  if (!options.record_path.empty()) {
    out_opt.record_path = expandTimePattern(options.record_path);
  } else if (cfg.record.enabled) {
    out_opt.record_path = expandTimePattern(cfg.record.path);
  }
  // Writability is checked here, as the user ftidd runs as (User=ftid), not in the config's
  // validation, which also runs for ftid tare/export/compensate as whoever calls them.
  if (!out_opt.record_path.empty()) {
    if (const std::string p = config::recordDirWritableProblem(out_opt.record_path); !p.empty()) {
      throw ConfigError(options.record_path.empty() ? cfg.source + ": key 'record.path': " + p : "--record: " + p);
    }
  }
  outbox = std::make_unique<transport::LcmOutbox>(out_opt);
}

// Commands: authenticated with the shared key (docs/operations.md, "Network and commands").
void DaemonSetup::setUpCommands() {
  transport::CommandKey command_key;
  try {
    command_key = transport::loadCommandKey(cfg.lcm.command_key_path);
  } catch (const ConfigError& e) {
    logLine(std::string("commands disabled, every command will be refused: ") + e.what() +
            " (SIGHUP still reloads the parameters)");
  }
  verifier = std::make_unique<transport::CommandVerifier>(std::move(command_key), transport::realtimeUs());
  outbox->setCommandHandler(&CommandQueue::push, &commands);
}

// The sensor (a local device or socket) is retried for --connect-timeout with the reconnect
// backoff and is required at start. The robot is not: the loop owner's link thread connects to it
// (the same checks and backoff as for a reconnect), so a cell PC that boots before the controller
// runs ftidd, publishing valid = false until the robot answers.
void DaemonSetup::openSensor(double connect_timeout_s) {
  const BackoffPolicy backoff{cfg.robot.reconnect_backoff_min_s, cfg.robot.reconnect_backoff_max_s, 2.0};
  can_cfg.endpoint = cfg.sensor.transport == "socketcan" ? "socketcan:" + cfg.sensor.can_interface
                                                          : "seqpacket:" + cfg.sensor.socket_path;
  can_cfg.dbc_path = cfg.sensor.dbc_path;
  can_cfg.health.stale_timeout_ns = static_cast<std::int64_t>(cfg.sensor.stale_timeout_ms * 1e6);
  sensor = std::make_unique<CanSensorSource>(
      retryUntil(connect_timeout_s, backoff, "the sensor at " + can_cfg.endpoint,
                 [&] { return drivers::can::openCanSensor(can_cfg); }),
      can_cfg.health);
  logLine("sensor " + can_cfg.endpoint + " open, LCM " + cfg.lcm.url + "; the robot " + cfg.robot.host +
          ":" + std::to_string(cfg.robot.rtde_port) + " is connected by the link thread");
}

void DaemonSetup::setUpCycle() {
  sink = std::make_unique<OutboxSink>(outbox.get());
  CycleOptions cycle_opt;
  cycle_opt.stale_timeout_us = static_cast<std::int64_t>(cfg.sensor.stale_timeout_ms * 1000.0);
  cycle = std::make_unique<DaemonCycle>(nullptr, sensor.get(), motion.get(), &params,
                                        sink.get(), cycle_opt);
  OutputStageConfig out_cfg;
  out_cfg.frame = parseOutputFrame(cfg.output.frame);
  out_cfg.R_ST = cfg.output.R_ST();
  out_cfg.p_ST_S = cfg.output.tool_xyz;
  out_cfg.lowpass_hz = cfg.output.lowpass_hz;
  out_cfg.sample_rate_hz = cfg.robot.rtde_frequency_hz;
  output_stage = std::make_unique<OutputStage>(out_cfg);
  cycle->attachOutputStage(output_stage.get());
  tare_requests = std::make_unique<rt::Mailbox<TareRequest>>();
  tare_results = std::make_unique<rt::Mailbox<TareResult>>();
  cycle->attachTare(tare_requests.get(), tare_results.get());
}

void DaemonSetup::setUpMonitor() {
  if (!cfg.monitor.enabled) return;
  monitor_link = std::make_unique<MonitorLink>();
  cycle->attachMonitor(monitor_link.get());
  transport::LcmOutbox* box = outbox.get();
  const std::string channel = cfg.monitor.channel;
  payload_watch = std::make_unique<PayloadWatch>(
      monitorSettings(cfg.monitor), cfg.monitor.publish_hz, monitor_link.get(),
      [box, channel](const MonitorReport& report) { publishMonitorReport(box, channel, report); },
      static_cast<std::size_t>(cfg.monitor.reidentify_window_s * cfg.robot.rtde_frequency_hz * 1.25) + 16);
}

void DaemonSetup::setUpLoopTiming() {
  loop_stats = std::make_unique<rt::LoopStats>();
  stats_box = std::make_unique<rt::Mailbox<rt::LoopStats>>();
  period_s = 1.0 / cfg.robot.rtde_frequency_hz;
  cycle->attachLoopStats(loop_stats.get(), stats_box.get(),
                         static_cast<std::uint32_t>(std::max(1.0, std::round(0.25 / period_s))));
  exec.period = std::chrono::nanoseconds(static_cast<std::int64_t>(std::llround(period_s * 1e9)));
  exec.timeout_periods = static_cast<double>(cfg.robot.receiveTimeout().count()) / (period_s * 1e6);
  // Missed cycles are flagged (onMissed) and the loop keeps waiting; after
  // robot.reconnect_after_silence_s of them in a row the session ends and the link is renewed.
  exec.max_consecutive_missed = 0xFFFFFFFFu;
  if (cfg.robot.reconnect_after_silence_s > 0.0) {
    const double timeout_s = static_cast<double>(cfg.robot.receiveTimeout().count()) * 1e-6;
    exec.max_consecutive_missed =
        static_cast<std::uint32_t>(std::max(1.0, std::ceil(cfg.robot.reconnect_after_silence_s / timeout_s)));
  }
  budget_us = cfg.rt.overrun_budget_ms > 0.0 ? cfg.rt.overrun_budget_ms * 1000.0 : 0.5 * period_s * 1e6;
}

ArmConnector DaemonSetup::armConnector() const {
  const std::string host = cfg.robot.host;
  const int port = cfg.robot.rtde_port;
  const double hz = cfg.robot.rtde_frequency_hz;
  return [host, port, hz]() -> std::unique_ptr<ArmStateSource> {
    auto arm = std::make_unique<RtdeArmSource>(host, port, hz);
    logLine("connected: robot " + host + ":" + std::to_string(port) + " (controller " +
            arm->controllerVersion().toString() + ")");
    return arm;
  };
}

SensorLink DaemonSetup::sensorLink() {
  SensorLink link;
  CanSensorSource* s = sensor.get();
  const std::string endpoint = can_cfg.endpoint;
  const int rcvbuf = can_cfg.receive_buffer_bytes;
  link.down = [s] { return s->transportDown(); };
  link.reopen = [s, endpoint, rcvbuf] { s->offerTransport(drivers::can::openCanTransport(endpoint, rcvbuf)); };
  link.collect = [s] { s->collectRetired(); };
  link.reconnects = [s] { return s->reconnects(); };
  return link;
}

LoopOwnerOptions DaemonSetup::loopOwnerOptions() const {
  LoopOwnerOptions o;
  o.rt = rt_cfg;
  o.exec = exec;
  o.backoff = BackoffPolicy{cfg.robot.reconnect_backoff_min_s, cfg.robot.reconnect_backoff_max_s, 2.0};
  o.robot_name = cfg.robot.host + ":" + std::to_string(cfg.robot.rtde_port);
  o.sensor_name = can_cfg.endpoint;
  return o;
}

}  // namespace ftid::daemon
