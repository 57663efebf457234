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
#include "ftid/daemon/tare.hpp"
#include "ftid/rt/cyclic_executor.hpp"
#include "ftid/rt/mailbox.hpp"
#include "ftid/rt/rt_setup.hpp"
#include "ftid/rt/rt_thread.hpp"
#include "ftid/transport/codec.hpp"
#include "ftid/transport/command_auth.hpp"
#include "ftid/transport/lcm_outbox.hpp"
#include "ftid/transport/source_filter.hpp"
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

// Retries a set-up step that fails with DriverError (peer not up yet) until the deadline, with
// exponential backoff (0.2 s doubling to 3.2 s) so that a restart loop does not hammer a
// controller that is still booting.
template <class F>
auto retryUntil(double timeout_s, const std::string& what, F&& make) -> decltype(make()) {
  const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
  bool announced = false;
  auto backoff = std::chrono::milliseconds(200);
  for (;;) {
    try {
      return make();
    } catch (const DriverError& e) {
      if (Clock::now() >= deadline) throw;
      if (!announced) {
        logLine("waiting for " + what + " (" + e.what() + ")");
        announced = true;
      }
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
      std::this_thread::sleep_for(std::min(backoff, std::max(left, std::chrono::milliseconds(1))));
      backoff = std::min(backoff * 2, std::chrono::milliseconds(3200));
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

// The wrench message published while no robot state package arrives: valid = false, cycle = -1,
// fault bit robot timeout, no sensor sample.
void publishSilence(transport::LcmOutbox* outbox, std::int32_t param_version) {
  CycleRecord rec;
  rec.utime = realtimeNowUs();
  rec.cycle = -1;
  rec.sensor_age_us = -1;
  rec.fault_bits = kFaultRobotTimeout;
  rec.wrench_valid = false;
  rec.param_version = param_version;
  ftid_lcm::compensated_wrench_t msg{};
  transport::toLcm(rec, &msg);
  std::uint8_t buf[512];
  const int n = transport::encodeInto(msg, buf, sizeof buf);
  if (n > 0) outbox->publishRaw(outbox->options().channels.wrench, buf, static_cast<unsigned>(n));
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

std::string checkCommand(const ftid_lcm::command_t& cmd, transport::CommandVerifier* verifier,
                         CommandCounters* counters) {
  const transport::CommandVerdict v = verifier->verify(cmd, transport::realtimeUs());
  std::string why;
  switch (v) {
    case transport::CommandVerdict::kAccepted: break;
    case transport::CommandVerdict::kBadMac:
      ++counters->auth;
      why = verifier->hasKey() ? "bad authenticator (wrong key or altered message)"
                               : "no command key configured (lcm.command_key_path)";
      break;
    case transport::CommandVerdict::kStale:
      ++counters->stale;
      why = "stale: signed outside +-30 s of ftidd's clock or before ftidd started";
      break;
    case transport::CommandVerdict::kReplayed:
      ++counters->replay;
      why = "replayed: sequence not above the last accepted command";
      break;
  }
  if (why.empty() && cmd.command == ftid_lcm::command_t::RELOAD_PARAMETERS && !cmd.argument.empty()) {
    ++counters->malformed;
    why = "RELOAD_PARAMETERS takes no path: ftidd reloads only its configured parameter file";
  }
  if (why.empty() && cmd.command == ftid_lcm::command_t::TARE && !cmd.argument.empty()) {
    ++counters->malformed;
    why = "TARE takes no argument (the window and limits are in ftidd's configuration)";
  }
  if (why.empty()) return {};
  return "command " + std::to_string(static_cast<int>(cmd.command)) + " (request " +
         std::to_string(cmd.request_id) + ") refused: " + why;
}

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
  // The factory reads the parameter file with the tare state next to it (applied if it belongs
  // to this content; docs/daemon.md, "Tare") and remembers what it built for the next TARE.
  bool apply_tare = true;                 // false during a reload: a reload discards the tare
  LoadedParameters built;                 // the set of the last successful build
  LoadedParameters active;                // the set of the parameters offered to the loop
  bool have_active = false;
  const CompensationFactory factory = [&](const std::string& path) -> std::unique_ptr<Compensation> {
    LoadedParameters lp = loadParameters(path, apply_tare);
    auto comp = std::make_unique<ParameterFileCompensation>(lp.set, path);
    built = std::move(lp);
    return comp;
  };
  rt::OwnedSwapSlot<Compensation> params;
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
      active = built;
      have_active = true;
      logLine("payload parameters loaded from " + cfg.parameters.path +
              (active.tared ? " with the tared offsets of " + tareStatePath(cfg.parameters.path) : ""));
      if (!active.note.empty()) logLine(active.note);
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
  if (!cfg.lcm.accept_remote) out_opt.allowed_sources = transport::localSources();
  if (!options_.record_path.empty()) {
    out_opt.record_path = expandTimePattern(options_.record_path);
  } else if (cfg.record.enabled) {
    out_opt.record_path = expandTimePattern(cfg.record.path);
  }
  transport::LcmOutbox outbox(out_opt);
  // Commands: authenticated with the shared key (docs/operations.md, "Network and commands").
  transport::CommandKey command_key;
  try {
    command_key = transport::loadCommandKey(cfg.lcm.command_key_path);
  } catch (const ConfigError& e) {
    logLine(std::string("commands disabled, every command will be refused: ") + e.what() +
            " (SIGHUP still reloads the parameters)");
  }
  transport::CommandVerifier verifier(std::move(command_key), transport::realtimeUs());
  CommandCounters refused;
  CommandQueue commands;
  outbox.setCommandHandler(&CommandQueue::push, &commands);
  if (!out_opt.record_path.empty()) logLine("recording to " + out_opt.record_path);

  // Devices.
  drivers::can::CanSensorConfig can_cfg;
  can_cfg.endpoint = cfg.sensor.transport == "socketcan" ? "socketcan:" + cfg.sensor.can_interface
                                                          : "seqpacket:" + cfg.sensor.socket_path;
  can_cfg.dbc_path = cfg.sensor.dbc_path;
  can_cfg.health.stale_timeout_ns = static_cast<std::int64_t>(cfg.sensor.stale_timeout_ms * 1e6);
  CanSensorSource sensor(retryUntil(options_.connect_timeout_s, "the sensor at " + can_cfg.endpoint,
                                    [&] { return drivers::can::openCanSensor(can_cfg); }),
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
  auto tare_requests = std::make_unique<rt::Mailbox<TareRequest>>();
  auto tare_results = std::make_unique<rt::Mailbox<TareResult>>();
  cycle.attachTare(tare_requests.get(), tare_results.get());
  std::uint64_t tare_id = 0;
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
  auto next_refusal_log = Clock::now();
  std::uint64_t refusals_unlogged = 0;
  std::uint64_t last_cycles = 0;
  auto last_cycle_time = Clock::now();
  bool robot_silent = false;
  bool ready_sent = false;
  int exit_code = 0;

  auto doReload = [&](const std::string& path) -> ReloadResult {
    notifySystemd("RELOADING=1");
    apply_tare = false;  // a reload returns to the parameter file's own offsets
    const ReloadResult r = reloader.reload(path, std::chrono::seconds(1));
    apply_tare = true;
    if (r.ok) {
      active = built;
      have_active = true;
      try {
        removeTareState(tareStatePath(path));
      } catch (const Error& e) {
        logLine(e.what());
      }
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

  // TARE (docs/daemon.md, "Tare"): the loop averages the contact wrench over the window and
  // refuses if the robot moves or a cycle is invalid; here, off the loop, the offsets are
  // adjusted, the state saved atomically and the new compensation offered like a reload.
  struct TareAnswer {
    bool ok = false;
    std::string message;
  };
  auto doTare = [&]() -> TareAnswer {
    if (!have_active) return {false, "tare refused: no payload parameters loaded"};
    TareRequest req;
    req.id = ++tare_id;
    req.cycles = static_cast<std::uint32_t>(
        std::max(1.0, std::round(cfg.parameters.tare_window_s * cfg.robot.rtde_frequency_hz)));
    req.max_qd_rad_s = cfg.parameters.tare_max_qd;
    req.max_qdd_rad_s2 = cfg.parameters.tare_max_qdd;
    TareResult res;
    bool answered = false;
    while (tare_results->tryPop(&res)) {}  // nothing stale from an abandoned request
    tare_requests->tryPush(req);
    const auto deadline = Clock::now() + std::chrono::duration<double>(cfg.parameters.tare_window_s + 1.0);
    while (Clock::now() < deadline && !loop_done.load(std::memory_order_acquire)) {
      if (tare_results->tryPop(&res) && res.id == req.id) {
        answered = true;
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    char buf[512];
    if (!answered) {
      return {false, "tare refused: the loop did not complete the window (no robot state packages?)"};
    }
    if (res.outcome == TareOutcome::kMoving) {
      std::snprintf(buf, sizeof buf,
                    "tare refused: the robot moves (max |qd| %.4g rad/s, max |qdd| %.4g rad/s^2; "
                    "limits %.4g and %.4g, parameters.tare_max_qd/_qdd)",
                    res.max_qd, res.max_qdd, req.max_qd_rad_s, req.max_qdd_rad_s2);
      return {false, buf};
    }
    if (res.outcome == TareOutcome::kInvalid) {
      std::snprintf(buf, sizeof buf,
                    "tare refused: a cycle without a valid compensated wrench after %u of %u cycles "
                    "(sensor stale or invalid, or robot state unusable)",
                    res.cycles, req.cycles);
      return {false, buf};
    }
    if (res.outcome == TareOutcome::kParametersChanged || res.param_version != params.version()) {
      return {false, "tare refused: the parameters changed during the window; send TARE again"};
    }
    Wrench new_offsets = res.mean_contact_S;
    LoadedParameters next = active;
    std::unique_ptr<Compensation> comp;
    TareState state;
    const std::string state_path = tareStatePath(cfg.parameters.path);
    try {
      new_offsets += offsetsOf(active.set, cfg.parameters.path);
      setOffsets(&next.set, new_offsets);
      state.parameter_sha256 = active.sha256;
      state.offsets = new_offsets;
      state.utime = realtimeNowUs();
      state.cycles = res.cycles;
      comp = std::make_unique<ParameterFileCompensation>(next.set, cfg.parameters.path);
      writeTareState(state_path, state);
    } catch (const std::exception& e) {
      return {false, std::string("tare refused: ") + e.what()};
    }
    const ReloadResult r = reloader.offer(std::move(comp), std::chrono::seconds(1));
    next.tared = true;
    active = next;
    std::snprintf(buf, sizeof buf,
                  "tared over %u cycles: f0 = (%.5g, %.5g, %.5g) N, t0 = (%.5g, %.5g, %.5g) Nm "
                  "(change %+.4g %+.4g %+.4g N, %+.4g %+.4g %+.4g Nm); saved to ",
                  res.cycles, new_offsets(0), new_offsets(1), new_offsets(2), new_offsets(3),
                  new_offsets(4), new_offsets(5), res.mean_contact_S(0), res.mean_contact_S(1),
                  res.mean_contact_S(2), res.mean_contact_S(3), res.mean_contact_S(4),
                  res.mean_contact_S(5));
    const std::string msg = buf + state_path + (r.applied ? "" : " (" + r.message + ")");
    logLine(msg);
    return {r.applied, msg};
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
      const std::string refusal = checkCommand(cmd, &verifier, &refused);
      if (!refusal.empty()) {
        ack.ok = false;
        ack.message = refusal;
        // At most one line per second: a flood of bad commands must not flood the journal.
        if (Clock::now() >= next_refusal_log) {
          logLine(refusal + (refusals_unlogged > 0 ? " (" + std::to_string(refusals_unlogged) +
                                                         " more refused since the last line)"
                                                   : std::string()));
          refusals_unlogged = 0;
          next_refusal_log = Clock::now() + std::chrono::seconds(1);
        } else {
          ++refusals_unlogged;
        }
      } else if (cmd.command == ftid_lcm::command_t::RELOAD_PARAMETERS) {
        const ReloadResult r = doReload(cfg.parameters.path);  // never a path from the network
        ack.ok = r.ok && r.applied;
        ack.message = r.message;
      } else if (cmd.command == ftid_lcm::command_t::TARE) {
        const TareAnswer a = doTare();
        ack.ok = a.ok;
        ack.message = a.message;
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
    // Robot link: a cycle runs per state package. While none arrives the loop only counts missed
    // cycles, so the supervisor publishes valid = false for it and, after watchdog_silence_s,
    // stops feeding the systemd watchdog (see below).
    const std::uint64_t cycles_now = c.cycles.load();
    if (cycles_now != last_cycles) {
      if (robot_silent) {
        logLine("robot state packages arrive again after " + std::to_string(secondsSince(last_cycle_time)) +
                " s");
      }
      last_cycles = cycles_now;
      last_cycle_time = Clock::now();
      robot_silent = false;
    }
    const double silent_s = secondsSince(last_cycle_time);
    if (ready_sent && silent_s * 1000.0 >= cfg.robot.silent_publish_after_ms) {
      if (!robot_silent) {
        robot_silent = true;
        logLine("no robot state package for " + std::to_string(static_cast<int>(silent_s * 1000.0)) +
                " ms (controller stalled, link down or controller off); publishing valid = false");
      }
      publishSilence(&outbox, static_cast<std::int32_t>(params.version()));
    }
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
      // Only while the loop lives and the robot link carries packages (or went silent less than
      // watchdog_silence_s ago): a dead link ends in a restart by systemd.
      if (heartbeat != last_heartbeat && silent_s < cfg.robot.watchdog_silence_s) notifySystemd("WATCHDOG=1");
      last_heartbeat = heartbeat;
      next_watchdog = Clock::now() + watchdog_period;
    }

    faults_since_report |= cycle.faults().clear();
    if (Clock::now() >= next_stats) {
      next_stats += std::chrono::duration_cast<Clock::duration>(
          std::chrono::duration<double>(cfg.lcm.stats_period_s));
      stats_box->readLatest(&snap);
      LoopStatsRecord s;
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
      s.commands_refused_auth = refused.auth;
      s.commands_refused_stale = refused.stale;
      s.commands_refused_replay = refused.replay;
      s.commands_refused_malformed = refused.malformed;
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
