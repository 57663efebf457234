#include "ftid/daemon/daemon.hpp"

#include <pthread.h>
#include <signal.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <deque>
#include <memory>
#include <mutex>
#include <thread>

#include "ftid/common/error.hpp"
#include "ftid/daemon/adapters.hpp"
#include "ftid/daemon/daemon_cycle.hpp"
#include "ftid/daemon/reloader.hpp"
#include "ftid/rt/cyclic_executor.hpp"
#include "ftid/rt/mailbox.hpp"
#include "ftid/rt/rt_setup.hpp"
#include "ftid/rt/rt_thread.hpp"
#include "ftid/transport/codec.hpp"
#include "ftid/transport/lcm_outbox.hpp"
#include "systemd_notify.hpp"

namespace ftid::daemon {
namespace {

using Clock = std::chrono::steady_clock;

void logLine(const std::string& line) {
  std::fprintf(stderr, "ftidd: %s\n", line.c_str());
  std::fflush(stderr);
}

double secondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Retries a set-up step that fails with DriverError (peer not up yet) until the deadline.
template <class F>
auto retryUntil(double timeout_s, const std::string& what, F&& make) -> decltype(make()) {
  const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
  bool announced = false;
  for (;;) {
    try {
      return make();
    } catch (const DriverError& e) {
      if (Clock::now() >= deadline) throw;
      if (!announced) {
        logLine("waiting for " + what + " (" + e.what() + ")");
        announced = true;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
  }
}

// Quantile of the samples added between two snapshots of a histogram [us].
double intervalQuantileUs(const rt::LatencyHistogram& now, const rt::LatencyHistogram& before,
                          double p) {
  const std::uint64_t count = now.count - before.count;
  if (count == 0) return 0.0;
  const double target = p * static_cast<double>(count);
  std::uint64_t acc = 0;
  for (int i = 0; i < rt::LatencyHistogram::kBins; ++i) {
    const auto k = static_cast<std::size_t>(i);
    acc += now.bins[k] - before.bins[k];
    if (acc > 0 && static_cast<double>(acc) >= target) return static_cast<double>(i + 1);
  }
  return static_cast<double>(now.max_ns) / 1000.0;  // in the overflow bin
}

// Number of samples above a threshold [us] (bins are 1 us wide).
std::uint64_t countAbove(const rt::LatencyHistogram& h, double threshold_us) {
  std::uint64_t n = h.overflow;
  for (int i = static_cast<int>(std::ceil(threshold_us)); i < rt::LatencyHistogram::kBins; ++i) {
    if (i >= 0) n += h.bins[static_cast<std::size_t>(i)];
  }
  return n;
}

struct CommandQueue {
  std::mutex mutex;
  std::deque<ftid_lcm::command_t> queue;
  static void push(const ftid_lcm::command_t& c, void* self) {
    auto* q = static_cast<CommandQueue*>(self);
    std::lock_guard<std::mutex> l(q->mutex);
    if (q->queue.size() < 64) q->queue.push_back(c);
  }
  bool pop(ftid_lcm::command_t* c) {
    std::lock_guard<std::mutex> l(mutex);
    if (queue.empty()) return false;
    *c = queue.front();
    queue.pop_front();
    return true;
  }
};

}  // namespace

std::string expandTimePattern(const std::string& pattern) {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  localtime_r(&t, &tm);
  char buf[4096];
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wformat-nonliteral"
  const std::size_t n = std::strftime(buf, sizeof buf, pattern.c_str(), &tm);  // user pattern
#pragma GCC diagnostic pop
  return n > 0 ? std::string(buf, n) : pattern;
}

Daemon::Daemon(config::DaemonConfig config, DaemonRunOptions options)
    : config_(std::move(config)), options_(std::move(options)) {}

int Daemon::run() {
  const config::DaemonConfig& cfg = config_;

  // Signals: blocked here, before any thread exists, and taken by the supervisor below.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGHUP);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  // Real-time set-up of the process.
  rt::RealtimeConfig rt_cfg;
  rt_cfg.enable = true;
  rt_cfg.require = cfg.rt.require_rt;
  rt_cfg.priority = cfg.rt.priority;
  rt_cfg.cpu = cfg.rt.cpu;
  rt_cfg.lock_memory = cfg.rt.lock_memory;
  rt::RealtimeReport rt_report;
  if (cfg.rt.lock_memory) rt::lockProcessMemory(rt_cfg, &rt_report);

  // Math: kinematics with the sensor mount; the compensation from the parameter file.
  model::RobotKinematics kinematics = model::RobotKinematics::fromUrdfFile(
      cfg.robot.urdf_path, cfg.robot.base_link, cfg.robot.tip_link);
  kinematics.setSensorMount(cfg.sensor.R_FS(), cfg.sensor.p_FS_F());
  KinematicsMotionModel motion(kinematics);
  const CompensationFactory factory = parameterFileFactory();
  OwnedSwapSlot<Compensation> params;
  ParameterReloader reloader(&params, factory);
  std::int32_t reloads_failed = 0;
  {
    const ReloadResult first = reloader.reload(cfg.parameters.path, std::chrono::milliseconds(0));
    if (!first.ok) {
      if (cfg.parameters.required) throw ConfigError(first.message);
      ++reloads_failed;
      logLine("no payload parameters (" + first.message +
              "): publishing the raw wrench with valid = false until a reload succeeds");
    } else {
      params.tryAcquire();  // the loop is not running yet: take it into use here
      params.collectRetired();
      logLine("payload parameters loaded from " + cfg.parameters.path);
    }
  }

  // Publishing.
  transport::OutboxOptions out_opt;
  out_opt.url = cfg.lcm.url;
  out_opt.channels.cycle = cfg.lcm.channels.cycle;
  out_opt.channels.wrench = cfg.lcm.channels.wrench;
  out_opt.channels.stats = cfg.lcm.channels.stats;
  out_opt.channels.command = cfg.lcm.channels.command;
  out_opt.channels.ack = cfg.lcm.channels.ack;
  out_opt.publish_cycle = cfg.lcm.publish_cycle;
  if (!options_.record_path.empty()) {
    out_opt.record_path = expandTimePattern(options_.record_path);
  } else if (cfg.record.enabled) {
    out_opt.record_path = expandTimePattern(cfg.record.path);
  }
  transport::LcmOutbox outbox(out_opt);
  CommandQueue commands;
  outbox.setCommandHandler(&CommandQueue::push, &commands);
  if (!out_opt.record_path.empty()) logLine("recording to " + out_opt.record_path);

  // Devices.
  can::CanSensorConfig can_cfg;
  can_cfg.endpoint = cfg.sensor.transport == "socketcan" ? "socketcan:" + cfg.sensor.can_interface
                                                          : "seqpacket:" + cfg.sensor.socket_path;
  can_cfg.dbc_path = cfg.sensor.dbc_path;
  can_cfg.health.stale_timeout_ns = static_cast<std::int64_t>(cfg.sensor.stale_timeout_ms * 1e6);
  CanSensorSource sensor(retryUntil(options_.connect_timeout_s, "the sensor at " + can_cfg.endpoint,
                                    [&] { return can::openCanSensor(can_cfg); }),
                         can_cfg.health);
  std::unique_ptr<RtdeArmSource> arm = retryUntil(
      options_.connect_timeout_s,
      "the robot at " + cfg.robot.host + ":" + std::to_string(cfg.robot.rtde_port), [&] {
        return std::make_unique<RtdeArmSource>(cfg.robot.host, cfg.robot.rtde_port,
                                               cfg.robot.rtde_frequency_hz);
      });
  logLine("connected: robot " + cfg.robot.host + ":" + std::to_string(cfg.robot.rtde_port) +
          ", sensor " + can_cfg.endpoint + ", LCM " + cfg.lcm.url);

  // The loop.
  OutboxSink sink(&outbox);
  CycleOptions cycle_opt;
  cycle_opt.stale_timeout_us = static_cast<std::int64_t>(cfg.sensor.stale_timeout_ms * 1000.0);
  DaemonCycle cycle(arm.get(), &sensor, &motion, &params, &sink, cycle_opt);
  OutputStageConfig out_cfg;
  out_cfg.frame = parseOutputFrame(cfg.output.frame);
  out_cfg.R_ST = cfg.output.R_ST();
  out_cfg.p_ST_S = cfg.output.tool_xyz;
  out_cfg.lowpass_hz = cfg.output.lowpass_hz;
  out_cfg.sample_rate_hz = cfg.robot.rtde_frequency_hz;
  OutputStage output_stage(out_cfg);
  cycle.attachOutputStage(&output_stage);
  auto loop_stats = std::make_unique<rt::LoopStats>();
  auto stats_box = std::make_unique<rt::Mailbox<rt::LoopStats>>();
  const double period_s = 1.0 / cfg.robot.rtde_frequency_hz;
  cycle.attachLoopStats(loop_stats.get(), stats_box.get(),
                        static_cast<std::uint32_t>(std::max(1.0, std::round(0.25 / period_s))));
  rt::ExecutorConfig exec;
  exec.period = std::chrono::nanoseconds(static_cast<std::int64_t>(std::llround(period_s * 1e9)));
  exec.timeout_periods = static_cast<double>(cfg.robot.receiveTimeout().count()) / (period_s * 1e6);
  exec.max_consecutive_missed = 0xFFFFFFFFu;  // an observer: keep waiting; the fault is flagged
  const double budget_us = cfg.rt.overrun_budget_ms > 0.0 ? cfg.rt.overrun_budget_ms * 1000.0
                                                          : 0.5 * period_s * 1e6;

  std::atomic<bool> stop{false};
  std::atomic<bool> loop_done{false};
  rt::LoopExit loop_exit = rt::LoopExit::kStopRequested;
  std::string loop_error;
  rt::RealtimeReport thread_report;       // complete only after the loop returns
  std::atomic<bool> loop_fifo{false};      // what the loop thread actually got
  outbox.start();
  std::thread launcher([&] {
    try {
      thread_report = rt::runInRealtimeThread(rt_cfg, [&] {
        int policy = SCHED_OTHER;
        sched_param sp{};
        if (pthread_getschedparam(pthread_self(), &policy, &sp) == 0) {
          loop_fifo.store(policy == SCHED_FIFO || policy == SCHED_RR, std::memory_order_release);
        }
        loop_exit = rt::runDeviceClocked(cycle, exec, loop_stats.get(), &stop);
      });
    } catch (const std::exception& e) {
      loop_error = e.what();
    }
    loop_done.store(true, std::memory_order_release);
  });

  // Supervisor.
  const auto t0 = Clock::now();
  const std::uint64_t watchdog_usec = systemdWatchdogUsec();
  const auto watchdog_period = std::chrono::microseconds(watchdog_usec / 2);
  auto next_watchdog = Clock::now();
  auto next_stats = Clock::now() + std::chrono::duration<double>(cfg.lcm.stats_period_s);
  auto next_status = Clock::now() + std::chrono::duration<double>(options_.status_period_s);
  std::uint64_t last_heartbeat = 0;
  rt::LoopStats prev_stats;
  rt::LoopStats snap;
  std::uint32_t faults_since_report = 0;
  std::int32_t reloads_applied = 0;
  bool ready_sent = false;
  int exit_code = 0;

  auto doReload = [&](const std::string& path) -> ReloadResult {
    notifySystemd("RELOADING=1");
    const ReloadResult r = reloader.reload(path, std::chrono::seconds(1));
    if (r.ok) {
      ++reloads_applied;
      logLine("parameters reloaded from " + path + (r.applied ? "" : " (pending)") +
              ", version " + std::to_string(r.version));
    } else {
      ++reloads_failed;
      logLine("reload failed, keeping the current parameters: " + r.message);
    }
    notifySystemd("READY=1");
    return r;
  };

  for (;;) {
    timespec wait{0, 50'000'000};
    siginfo_t info{};
    const int sig = sigtimedwait(&signals, &info, &wait);
    if (sig == SIGTERM || sig == SIGINT) {
      logLine(std::string("received ") + (sig == SIGTERM ? "SIGTERM" : "SIGINT") + ", stopping");
      break;
    }
    if (sig == SIGHUP) doReload(cfg.parameters.path);

    ftid_lcm::command_t cmd;
    while (commands.pop(&cmd)) {
      ftid_lcm::ack_t ack{};
      ack.request_id = cmd.request_id;
      ack.command = cmd.command;
      if (cmd.command == ftid_lcm::command_t::RELOAD_PARAMETERS) {
        const ReloadResult r = doReload(cmd.argument.empty() ? cfg.parameters.path : cmd.argument);
        ack.ok = r.ok && r.applied;
        ack.message = r.message;
      } else if (cmd.command == ftid_lcm::command_t::PING) {
        ack.ok = true;
      } else {
        ack.ok = false;
        ack.message = "unknown command " + std::to_string(cmd.command);
      }
      ack.param_version = static_cast<std::int32_t>(params.version());
      ack.utime = realtimeNowUs();
      outbox.publishAck(ack);
    }
    reloader.collect();

    if (loop_done.load(std::memory_order_acquire)) {
      if (!loop_error.empty()) {
        logLine("loop could not start: " + loop_error);
      } else {
        logLine(std::string("loop ended: ") + rt::loopExitName(loop_exit) +
                (loop_exit == rt::LoopExit::kDeviceFault
                     ? std::string(" (robot connection lost: ") + arm->client().lastError() + ")"
                     : ""));
      }
      exit_code = 1;
      break;
    }

    const CycleCounters& c = cycle.counters();
    const std::uint64_t heartbeat = c.cycles.load() + c.missed.load();
    if (!ready_sent && c.cycles.load() > 0) {
      ready_sent = true;
      notifySystemd("READY=1");
      const bool locked = rt_report.memory_locked || !cfg.rt.lock_memory;
      char hz[32];
      std::snprintf(hz, sizeof hz, "%g", cfg.robot.rtde_frequency_hz);
      logLine(std::string("running at ") + hz + " Hz; loop thread " +
              (loop_fifo.load() ? "SCHED_FIFO " + std::to_string(cfg.rt.priority)
                                : std::string("SCHED_OTHER (not real-time)")) +
              (locked ? "" : ", memory not locked"));
    }
    if (watchdog_usec > 0 && Clock::now() >= next_watchdog) {
      if (heartbeat != last_heartbeat) notifySystemd("WATCHDOG=1");  // only while the loop lives
      last_heartbeat = heartbeat;
      next_watchdog = Clock::now() + watchdog_period;
    }

    faults_since_report |= cycle.faults().clear();
    if (Clock::now() >= next_stats) {
      next_stats += std::chrono::duration_cast<Clock::duration>(
          std::chrono::duration<double>(cfg.lcm.stats_period_s));
      stats_box->readLatest(&snap);
      transport::LoopStatsRecord s;
      s.utime = realtimeNowUs();
      s.uptime_s = secondsSince(t0);
      s.cycles = static_cast<std::int64_t>(c.cycles.load());
      s.missed_cycles = static_cast<std::int64_t>(c.missed.load() + arm->packetsSkipped());
      s.overruns = static_cast<std::int64_t>(countAbove(snap.compute, budget_us));
      s.compute_p50_us = intervalQuantileUs(snap.compute, prev_stats.compute, 0.5);
      s.compute_p999_us = intervalQuantileUs(snap.compute, prev_stats.compute, 0.999);
      s.compute_max_us = static_cast<double>(snap.compute.max_ns) / 1000.0;
      s.valid_cycles = static_cast<std::int64_t>(c.valid.load());
      s.invalid_cycles = static_cast<std::int64_t>(c.invalid.load());
      s.stale_sensor_cycles = static_cast<std::int64_t>(c.stale_sensor.load());
      const auto oc = outbox.counters();
      s.publish_dropped = static_cast<std::int64_t>(oc.dropped);
      s.published = static_cast<std::int64_t>(oc.published);
      s.reloads_applied = reloads_applied;
      s.reloads_failed = reloads_failed;
      s.param_version = static_cast<std::int32_t>(params.version());
      s.fault_bits = faults_since_report;
      s.realtime = loop_fifo.load() && (rt_report.memory_locked || !cfg.rt.lock_memory);
      outbox.publishStats(s);
      prev_stats = snap;
      faults_since_report = 0;
      char status[256];
      std::snprintf(status, sizeof status,
                    "STATUS=cycles %lld, valid %lld, stale %lld, missed %lld, params v%d",
                    static_cast<long long>(s.cycles), static_cast<long long>(s.valid_cycles),
                    static_cast<long long>(s.stale_sensor_cycles),
                    static_cast<long long>(s.missed_cycles), s.param_version);
      notifySystemd(status);
      if (options_.status_period_s > 0.0 && Clock::now() >= next_status) {
        next_status = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                         std::chrono::duration<double>(options_.status_period_s));
        logLine(std::string(status + 7) + ", compute p99.9 " +
                std::to_string(static_cast<int>(s.compute_p999_us)) + " us");
      }
    }
  }

  notifySystemd("STOPPING=1");
  stop.store(true, std::memory_order_release);
  launcher.join();  // the loop returns within one receive timeout
  outbox.stop();
  const auto oc = outbox.counters();
  logLine("stopped after " + std::to_string(cycle.counters().cycles.load()) + " cycles, " +
          std::to_string(oc.published) + " messages published, " + std::to_string(oc.dropped) +
          " dropped");
  return exit_code;
}

}  // namespace ftid::daemon
