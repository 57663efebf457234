#include "supervisor.hpp"

#include <cmath>
#include <cstdio>
#include <thread>

#include "ftid/common/error.hpp"
#include "ftid/monitor/change_fit.hpp"
#include "ftid/params/parameter_set.hpp"
#include "systemd_notify.hpp"

namespace ftid::daemon {

namespace {

using Clock = std::chrono::steady_clock;

/// The supervisor's tick: signals, commands and the valid = false messages run on it (20 Hz).
constexpr auto kTick = std::chrono::milliseconds(50);
/// The link thread is stuck if it has not shown progress for this long (a connection attempt is
/// bounded by the RTDE connect and reply timeouts, a few seconds each).
constexpr auto kLinkThreadStall = std::chrono::seconds(30);

double secondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

template <class D>
Clock::duration toClock(D d) {
  return std::chrono::duration_cast<Clock::duration>(d);
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
// fault bit robot timeout, no sensor sample. utime is the host's CLOCK_REALTIME (the robot's
// clock is gone); the rate is the supervisor's tick on CLOCK_MONOTONIC.
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

}  // namespace

Supervisor::Supervisor(DaemonSetup* setup, LoopOwner* owner, const sigset_t& signals,
                       const DaemonRunOptions& options)
    : s_(*setup), owner_(*owner), signals_(signals), options_(options) {
  t0_ = Clock::now();
  watchdog_usec_ = systemdWatchdogUsec();
  watchdog_period_ = toClock(std::chrono::microseconds(watchdog_usec_ / 2));
  next_watchdog_ = Clock::now();
  next_stats_ = Clock::now() + toClock(std::chrono::duration<double>(s_.cfg.lcm.stats_period_s));
  next_status_ = Clock::now() + toClock(std::chrono::duration<double>(options_.status_period_s));
  next_refusal_log_ = Clock::now();
  last_cycle_time_ = Clock::now();
}

ReloadResult Supervisor::doReload() {
  const std::string& path = s_.cfg.parameters.path;
  notifySystemd("RELOADING=1");
  s_.apply_tare = false;  // a reload returns to the parameter file's own offsets
  const ReloadResult r = s_.reloader->reload(path, std::chrono::seconds(1));
  s_.apply_tare = true;
  if (r.ok) {
    s_.active = s_.built;
    s_.have_active = true;
    try {
      removeTareState(tareStatePath(path));
    } catch (const Error& e) {
      logLine(e.what());
    }
    ++reloads_applied_;
    logLine("parameters reloaded from " + path + (r.applied ? "" : " (pending)") + ", version " +
            std::to_string(r.version));
  } else {
    ++s_.reloads_failed;
    logLine("reload failed, keeping the current parameters: " + r.message);
  }
  notifySystemd("READY=1");
  return r;
}

// TARE (docs/daemon.md, "Tare"): the loop averages the contact wrench over the window and
// refuses if the robot moves or a cycle is invalid; here, off the loop, the offsets are
// adjusted, the state saved atomically and the new compensation offered like a reload.
Supervisor::TareAnswer Supervisor::doTare() {
  const config::DaemonConfig& cfg = s_.cfg;
  if (!s_.have_active) return {false, "tare refused: no payload parameters loaded"};
  if (robot_silent_ || !owner_.status().robot_up) {
    return {false, "tare refused: no robot state packages (robot link lost or silent)"};
  }
  TareRequest req;
  req.id = ++tare_id_;
  req.cycles = static_cast<std::uint32_t>(
      std::max(1.0, std::round(cfg.parameters.tare_window_s * cfg.robot.rtde_frequency_hz)));
  req.max_qd_rad_s = cfg.parameters.tare_max_qd;
  req.max_qdd_rad_s2 = cfg.parameters.tare_max_qdd;
  TareResult res;
  bool answered = false;
  while (s_.tare_results->tryPop(&res)) {}  // nothing stale from an abandoned request
  s_.tare_requests->tryPush(req);
  const auto deadline = Clock::now() + toClock(std::chrono::duration<double>(cfg.parameters.tare_window_s + 1.0));
  while (Clock::now() < deadline && !owner_.loopFailed(nullptr)) {
    if (s_.tare_results->tryPop(&res) && res.id == req.id) {
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
  if (res.outcome == TareOutcome::kParametersChanged || res.param_version != s_.params.version()) {
    return {false, "tare refused: the parameters changed during the window; send TARE again"};
  }
  Wrench new_offsets = res.mean_contact_S;
  LoadedParameters next = s_.active;
  std::unique_ptr<Compensation> comp;
  TareState state;
  const std::string state_path = tareStatePath(cfg.parameters.path);
  try {
    new_offsets += offsetsOf(s_.active.set, cfg.parameters.path);
    setOffsets(&next.set, new_offsets);
    state.parameter_sha256 = s_.active.sha256;
    state.offsets = new_offsets;
    state.utime = realtimeNowUs();
    state.cycles = res.cycles;
    requirePlausible(next.set, s_.limits, cfg.parameters.path + " with the new offsets");
    comp = std::make_unique<ParameterFileCompensation>(next.set, cfg.parameters.path, motionSource(cfg));
    writeTareState(state_path, state);
  } catch (const std::exception& e) {
    return {false, std::string("tare refused: ") + e.what()};
  }
  const ReloadResult r = s_.reloader->offer(std::move(comp), std::chrono::seconds(1));
  next.tared = true;
  s_.active = next;
  std::snprintf(buf, sizeof buf,
                "tared over %u cycles: f0 = (%.5g, %.5g, %.5g) N, t0 = (%.5g, %.5g, %.5g) Nm "
                "(change %+.4g %+.4g %+.4g N, %+.4g %+.4g %+.4g Nm); saved to ",
                res.cycles, new_offsets(0), new_offsets(1), new_offsets(2), new_offsets(3),
                new_offsets(4), new_offsets(5), res.mean_contact_S(0), res.mean_contact_S(1),
                res.mean_contact_S(2), res.mean_contact_S(3), res.mean_contact_S(4),
                res.mean_contact_S(5));
  const std::string msg = buf + state_path + (r.applied ? "" : " (" + r.message + ")");
  logLine(msg);
  return {r.applied, msg, r.applied ? new_offsets : Wrench::Zero()};
}

std::pair<bool, std::string> Supervisor::doReidentify(bool apply) {
  const config::DaemonConfig& cfg = s_.cfg;
  if (!s_.payload_watch) return {false, "reidentify refused: the payload monitor is off (monitor.enabled)"};
  if (!s_.have_active) return {false, "reidentify refused: no payload parameters loaded"};
  const std::vector<monitor::MonitorSample> samples = s_.payload_watch->recent(cfg.monitor.reidentify_window_s);
  monitor::ChangeFit fit;
  try {
    fit = monitor::fitChange(samples, payloadOf(s_.active.set), s_.payload_watch->settings());
  } catch (const std::exception& e) {
    return {false, std::string("reidentify refused: ") + e.what()};
  }
  const monitor::ChangeEstimate& c = fit.change;
  char buf[640];
  std::snprintf(buf, sizeof buf,
                "%d samples over the last %.3g s (%d in free motion): delta mass %+.4f +- %.4f kg, mass %.4f kg, "
                "centre of mass of the change (%.4f, %.4f, %.4f) m; residual RMS fx..fz before (%.3g, %.3g, %.3g) "
                "N, after (%.3g, %.3g, %.3g) N",
                fit.samples, cfg.monitor.reidentify_window_s, fit.free_samples, c.delta_mass_kg, c.delta_mass_std_kg,
                fit.payload_after[0], c.delta_com_m.x(), c.delta_com_m.y(), c.delta_com_m.z(),
                fit.residual_rms_before[0], fit.residual_rms_before[1], fit.residual_rms_before[2],
                fit.residual_rms_after[0], fit.residual_rms_after[1], fit.residual_rms_after[2]);
  if (!fit.ok) return {false, "reidentify refused: " + fit.reason + " (" + buf + ")"};
  if (!apply) return {true, std::string("reidentified (not loaded; send with apply to load it): ") + buf};
  try {
    params::writeParameterFile(cfg.parameters.path, reidentifiedSet(s_.active.set, fit));  // atomic
  } catch (const std::exception& e) {
    return {false, std::string("reidentify: the parameter file cannot be written: ") + e.what()};
  }
  const ReloadResult r = doReload();
  const std::string msg = std::string("reidentified and written to ") + cfg.parameters.path +
                          (r.ok && r.applied ? ", loaded: " : ", NOT loaded (" + r.message + "): ") + buf;
  logLine(msg);
  return {r.ok && r.applied, msg};
}

void Supervisor::handleCommands() {
  ftid_lcm::command_t cmd;
  while (s_.commands.pop(&cmd)) {
    ftid_lcm::ack_t ack{};
    ack.request_id = cmd.request_id;
    ack.command = cmd.command;
    const std::string refusal = checkCommand(cmd, s_.verifier.get(), &refused_);
    if (!refusal.empty()) {
      ack.ok = false;
      ack.message = refusal;
      if (cmd.command == ftid_lcm::command_t::TARE) ++tares_refused_;
      // At most one line per second: a flood of bad commands must not flood the journal.
      if (Clock::now() >= next_refusal_log_) {
        logLine(refusal + (refusals_unlogged_ > 0 ? " (" + std::to_string(refusals_unlogged_) +
                                                        " more refused since the last line)"
                                                  : std::string()));
        refusals_unlogged_ = 0;
        next_refusal_log_ = Clock::now() + std::chrono::seconds(1);
      } else {
        ++refusals_unlogged_;
      }
    } else if (have_last_ack_ && cmd.request_id == last_ack_.request_id &&
               cmd.command == last_ack_.command) {
      ack = last_ack_;  // a resend of the request just answered
    } else if (cmd.command == ftid_lcm::command_t::RELOAD_PARAMETERS) {
      const ReloadResult r = doReload();  // never a path from the network
      ack.ok = r.ok && r.applied;
      ack.message = r.message;
    } else if (cmd.command == ftid_lcm::command_t::TARE) {
      const TareAnswer a = doTare();
      ack.ok = a.ok;
      ack.message = a.message;
      for (int i = 0; i < 6; ++i) ack.offsets[i] = a.offsets(i);
      ++(a.ok ? tares_done_ : tares_refused_);
    } else if (cmd.command == ftid_lcm::command_t::REIDENTIFY) {
      const auto [ok, message] = doReidentify(cmd.argument == "apply");
      ack.ok = ok;
      ack.message = message;
    } else if (cmd.command == ftid_lcm::command_t::PING) {
      ack.ok = true;
    } else {
      ack.ok = false;
      ack.message = "unknown command " + std::to_string(cmd.command);
    }
    ack.param_version = static_cast<std::int32_t>(s_.params.version());
    ack.utime = realtimeNowUs();
    if (refusal.empty()) {
      last_ack_ = ack;
      have_last_ack_ = true;
    }
    s_.outbox->publishAck(ack);
  }
}

// Robot link: a cycle runs per state package. While none arrives (robot silent, or the loop owner
// renewing the connection) the supervisor publishes valid = false for the loop.
void Supervisor::trackRobotLink(std::uint64_t cycles_now) {
  if (cycles_now != last_cycles_) {
    if (robot_silent_) {
      logLine("robot state packages arrive again after " + std::to_string(secondsSince(last_cycle_time_)) + " s");
    }
    last_cycles_ = cycles_now;
    last_cycle_time_ = Clock::now();
    robot_silent_ = false;
  }
  const double silent_s = secondsSince(last_cycle_time_);
  if (ready_sent_ && silent_s * 1000.0 >= s_.cfg.robot.silent_publish_after_ms) {
    if (!robot_silent_) {
      robot_silent_ = true;
      logLine("no robot state package for " + std::to_string(static_cast<int>(silent_s * 1000.0)) +
              " ms (controller stalled, link down or controller off); publishing valid = false");
    }
    publishSilence(s_.outbox.get(), static_cast<std::int32_t>(s_.params.version()));
  }
}

// The watchdog (docs/operations.md, "Link loss and reconnect"): fed only while the loop thread's
// heartbeat advances (cycles, missed waits, or its parked wake-ups between connections), the link
// thread is not stuck, and - if robot.watchdog_silence_s is set - the robot has not been silent
// for that long. A wedged thread therefore still ends in a restart by systemd; a process that is
// healthily renewing its robot link keeps the watchdog fed unless configured otherwise.
void Supervisor::feedWatchdog() {
  if (watchdog_usec_ == 0 || Clock::now() < next_watchdog_) return;
  const std::uint64_t heartbeat = owner_.loopHeartbeat();
  if (watchdogMayBeFed(heartbeat != last_heartbeat_, owner_.linkThreadAlive(kLinkThreadStall),
                       secondsSince(last_cycle_time_), s_.cfg.robot.watchdog_silence_s)) {
    notifySystemd("WATCHDOG=1");
  }
  last_heartbeat_ = heartbeat;
  next_watchdog_ = Clock::now() + watchdog_period_;
}

void Supervisor::publishStats() {
  const config::DaemonConfig& cfg = s_.cfg;
  const CycleCounters& c = s_.cycle->counters();
  next_stats_ += toClock(std::chrono::duration<double>(cfg.lcm.stats_period_s));
  s_.stats_box->readLatest(&snap_);
  const LinkStatus link = owner_.status();
  LoopStatsRecord s;
  s.utime = realtimeNowUs();
  s.uptime_s = secondsSince(t0_);
  s.cycles = static_cast<std::int64_t>(c.cycles.load());
  s.missed_cycles = static_cast<std::int64_t>(c.missed.load() + link.packets_skipped);
  s.overruns = static_cast<std::int64_t>(countAbove(snap_.compute, s_.budget_us));
  s.compute_p50_us = intervalQuantileUs(snap_.compute, prev_stats_.compute, 0.5);
  s.compute_p999_us = intervalQuantileUs(snap_.compute, prev_stats_.compute, 0.999);
  s.compute_max_us = static_cast<double>(snap_.compute.max_ns) / 1000.0;
  s.valid_cycles = static_cast<std::int64_t>(c.valid.load());
  s.invalid_cycles = static_cast<std::int64_t>(c.invalid.load());
  s.stale_sensor_cycles = static_cast<std::int64_t>(c.stale_sensor.load());
  s.robot_clock_faults = static_cast<std::int64_t>(c.robot_clock_faults.load());
  s.robot_clock_invalid_cycles = static_cast<std::int64_t>(c.robot_clock_invalid.load());
  const auto oc = s_.outbox->counters();
  s.publish_dropped = static_cast<std::int64_t>(oc.dropped);
  s.published = static_cast<std::int64_t>(oc.published);
  s.reloads_applied = reloads_applied_;
  s.reloads_failed = s_.reloads_failed;
  s.param_version = static_cast<std::int32_t>(s_.params.version());
  s.commands_refused_auth = refused_.auth;
  s.commands_refused_stale = refused_.stale;
  s.commands_refused_replay = refused_.replay;
  // Malformed = refused by the command checks, or not even a command_t (dropped by the outbox).
  s.commands_refused_malformed = refused_.malformed + static_cast<std::int32_t>(oc.malformed);
  s.tares_done = tares_done_;
  s.tares_refused = tares_refused_;
  s.fault_bits = faults_since_report_;
  s.realtime = owner_.loopIsRealtime() && (s_.rt_report.memory_locked || !cfg.rt.lock_memory);
  s.robot_link_up = link.robot_up;
  s.robot_reconnects = link.robot_reconnects;
  s.robot_link_down_s = link.robot_down_total_s;
  s.sensor_reconnects = link.sensor_reconnects;
  s_.outbox->publishStats(s);
  prev_stats_ = snap_;
  faults_since_report_ = 0;
  char status[320];
  std::snprintf(status, sizeof status,
                "cycles %lld, valid %lld, stale %lld, missed %lld, params v%d, robot link %s "
                "(%d reconnects, %.1f s down)",
                static_cast<long long>(s.cycles), static_cast<long long>(s.valid_cycles),
                static_cast<long long>(s.stale_sensor_cycles), static_cast<long long>(s.missed_cycles),
                s.param_version, link.robot_up ? "up" : "DOWN", link.robot_reconnects,
                link.robot_down_total_s);
  std::string status_line = status;
  if (!link.robot_up && !link.robot_last_error.empty()) {
    status_line += ": " + link.robot_last_error;
  }
  notifySystemdStatus(status_line);
  if (options_.status_period_s > 0.0 && Clock::now() >= next_status_) {
    next_status_ = Clock::now() + toClock(std::chrono::duration<double>(options_.status_period_s));
    logLine(status_line.substr(7) + ", compute p99.9 " +
            std::to_string(static_cast<int>(s.compute_p999_us)) + " us");
  }
}

int Supervisor::run() {
  const config::DaemonConfig& cfg = s_.cfg;
  auto next_tick = Clock::now() + kTick;
  for (;;) {
    const auto now = Clock::now();
    const auto wait_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(
        next_tick > now ? next_tick - now : Clock::duration::zero());
    timespec wait{static_cast<time_t>(wait_ns.count() / 1'000'000'000),
                  static_cast<long>(wait_ns.count() % 1'000'000'000)};
    siginfo_t info{};
    const int sig = sigtimedwait(&signals_, &info, &wait);
    if (sig == SIGTERM || sig == SIGINT) {
      logLine(std::string("received ") + (sig == SIGTERM ? "SIGTERM" : "SIGINT") + ", stopping");
      return 0;
    }
    if (sig == SIGHUP) doReload();
    if (sig > 0) continue;  // a signal before the tick: the tick's work waits for the tick
    // A steady tick: the next one a tick after this one's deadline, re-anchored after a stall
    // (a long command) instead of bursting.
    next_tick += kTick;
    if (Clock::now() > next_tick) next_tick = Clock::now() + kTick;

    handleCommands();
    s_.reloader->collect();

    std::string why;
    if (owner_.loopFailed(&why)) {
      logLine("loop could not start: " + why);
      return 1;
    }

    const CycleCounters& c = s_.cycle->counters();
    trackRobotLink(c.cycles.load());
    // READY=1 (docs/daemon.md, "systemd"): set-up done (parameters, LCM, commands, sensor) and
    // the loop thread running (its real-time set-up passed; it cycles or waits parked for the
    // robot link). The robot need not be connected: ftidd is then serving valid = false.
    if (!ready_sent_ && owner_.loopHeartbeat() > 0) {
      ready_sent_ = true;
      notifySystemd("READY=1");
      notifySystemdStatus(std::string(owner_.status().robot_up ? "running" : "waiting for the robot at ") +
                    (owner_.status().robot_up ? "" : cfg.robot.host + ":" + std::to_string(cfg.robot.rtde_port)));
    }
    if (!running_logged_ && c.cycles.load() > 0) {
      running_logged_ = true;
      const bool locked = s_.rt_report.memory_locked || !cfg.rt.lock_memory;
      char hz[32];
      std::snprintf(hz, sizeof hz, "%g", cfg.robot.rtde_frequency_hz);
      logLine(std::string("running at ") + hz + " Hz; loop thread " +
              (owner_.loopIsRealtime() ? "SCHED_FIFO " + std::to_string(cfg.rt.priority)
                                       : std::string("SCHED_OTHER (not real-time)")) +
              (locked ? "" : ", memory not locked"));
    }
    feedWatchdog();
    faults_since_report_ |= s_.cycle->faults().clear();
    if (Clock::now() >= next_stats_) publishStats();
  }
}

}  // namespace ftid::daemon
