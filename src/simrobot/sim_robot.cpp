// SimRobot: composes the controller model with the RTDE, dashboard and script servers, one tick
// thread (rt::runTimerClocked) and one I/O thread (poll). Every access to the controller and the
// servers holds one mutex.
#include "ftid/simrobot/sim_robot.hpp"

#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <mutex>
#include <thread>
#include <vector>

#include "dashboard_server.hpp"
#include "ftid/rt/cyclic_executor.hpp"
#include "ftid/simrobot/controller.hpp"
#include "net.hpp"
#include "rtde_server.hpp"
#include "script_server.hpp"

namespace ftid::simrobot {

namespace {
/// A host stall of up to this many periods is caught up tick by tick (the controller clock keeps
/// pace with the host clock); a longer one re-anchors the schedule (docs/robot.md, "Clock").
constexpr std::uint32_t kCatchUpPeriods = 5;
constexpr int kIoPollTimeoutMs = 5;
}  // namespace

struct SimRobot::Impl {
  explicit Impl(SimRobotConfig c) : cfg(std::move(c)), controller(cfg) {}

  SimRobotConfig cfg;
  std::uint16_t rtde_port = 0, dashboard_port = 0, script_port = 0;
  int wake_fd = -1;
  std::thread tick_thread, io_thread;
  std::atomic<bool> running{false};

  mutable std::mutex m;  // guards everything below
  Controller controller;
  std::unique_ptr<RtdeServer> rtde;
  std::unique_ptr<DashboardServer> dashboard;
  std::unique_ptr<ScriptServer> script;
  rt::LoopStats published_stats;
  std::uint64_t packages_sent_before = 0, packages_dropped_before = 0;  // of servers already stopped

  void raisePriority(int prio) const {
    if (prio <= 0) return;
    sched_param sp{};
    sp.sched_priority = prio;
    const int rc = pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp);
    if (rc != 0) {
      std::lock_guard<std::mutex> lock(m);
      controller.log(std::string("SCHED_FIFO for the simulator refused: ") + std::strerror(rc));
    }
  }

  // The tick thread's cycle: one controller tick and its output packages per period.
  struct TickCycle {
    Impl& im;
    const rt::LoopStats& stats;
    std::uint64_t cycles = 0;
    std::uint64_t publish_every = 1;
    rt::CycleAction onTimer(std::int64_t /*deadline_ns*/) noexcept {
      std::lock_guard<std::mutex> lock(im.m);
      const Controller::TickResult r = im.controller.tick();
      im.rtde->publish(r);
      if (++cycles % publish_every == 0) im.published_stats = stats;
      return rt::CycleAction::kContinue;
    }
  };

  void tickLoop() {
    raisePriority(cfg.thread_priority);
    rt::ExecutorConfig ec;
    const double dt = controller.period();
    ec.period = cfg.realtime ? std::chrono::nanoseconds(std::llround(dt * 1e9)) : std::chrono::nanoseconds(0);
    ec.catch_up_periods = kCatchUpPeriods;
    rt::LoopStats stats;
    TickCycle cycle{*this, stats};
    cycle.publish_every = static_cast<std::uint64_t>(std::llround(1.0 / dt));  // about once a second
    rt::runTimerClocked(cycle, ec, &stats, &stop_ticking);
    std::lock_guard<std::mutex> lock(m);
    published_stats = stats;
  }
  std::atomic<bool> stop_ticking{false};

  void ioLoop() {
    raisePriority(cfg.thread_priority > 1 ? cfg.thread_priority - 1 : 0);
    std::vector<pollfd> fds;
    std::size_t n_rtde = 0, n_dash = 0, n_script = 0;
    while (running.load()) {
      fds.clear();
      {
        std::lock_guard<std::mutex> lock(m);
        if (controller.takeDisconnectRequest()) {
          rtde->disconnectAll();
          dashboard->disconnectAll();
        }
        rtde->closeMarked();
        dashboard->closeMarked();
        script->closeMarked();
        fds.push_back({wake_fd, POLLIN, 0});
        n_rtde = rtde->addPollFds(&fds);
        n_dash = dashboard->addPollFds(&fds);
        n_script = script->addPollFds(&fds);
      }
      const int rc = ::poll(fds.data(), fds.size(), kIoPollTimeoutMs);
      if (rc < 0 && errno != EINTR) break;
      if (rc <= 0) continue;
      std::lock_guard<std::mutex> lock(m);
      if (fds[0].revents) {
        std::uint64_t v;
        [[maybe_unused]] const ssize_t r = ::read(wake_fd, &v, sizeof v);
      }
      const pollfd* p = fds.data() + 1;
      rtde->onPoll(p, n_rtde);
      dashboard->onPoll(p + n_rtde, n_dash);
      script->onPoll(p + n_rtde + n_dash, n_script);
    }
  }
};

SimRobot::SimRobot(SimRobotConfig config) : impl_(std::make_unique<Impl>(std::move(config))) {}

SimRobot::~SimRobot() { stop(); }

void SimRobot::start() {
  Impl& im = *impl_;
  if (im.running.load()) return;
  int rtde_fd = -1, dash_fd = -1;
  rtde_fd = net::listenOn(im.cfg.host, im.cfg.rtde_port, &im.rtde_port, "RTDE");
  int script_fd = -1;
  try {
    dash_fd = net::listenOn(im.cfg.host, im.cfg.dashboard_port, &im.dashboard_port, "dashboard");
    script_fd = net::listenOn(im.cfg.host, im.cfg.script_port, &im.script_port, "scripts");
  } catch (...) {
    if (rtde_fd >= 0) ::close(rtde_fd);
    if (dash_fd >= 0) ::close(dash_fd);
    throw;
  }
  {
    std::lock_guard<std::mutex> lock(im.m);
    im.rtde = std::make_unique<RtdeServer>(im.controller, rtde_fd);
    im.dashboard = std::make_unique<DashboardServer>(im.controller, dash_fd);
    im.script = std::make_unique<ScriptServer>(im.controller, script_fd);
  }
  im.wake_fd = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  im.stop_ticking = false;
  im.running = true;
  im.tick_thread = std::thread([&im] { im.tickLoop(); });
  im.io_thread = std::thread([&im] { im.ioLoop(); });
}

void SimRobot::stop() {
  Impl& im = *impl_;
  if (!im.running.exchange(false)) return;
  im.stop_ticking = true;
  if (im.wake_fd >= 0) {
    const std::uint64_t one = 1;
    [[maybe_unused]] const ssize_t r = ::write(im.wake_fd, &one, sizeof one);
  }
  if (im.tick_thread.joinable()) im.tick_thread.join();
  if (im.io_thread.joinable()) im.io_thread.join();
  std::lock_guard<std::mutex> lock(im.m);
  im.packages_sent_before += im.rtde->packagesSent();
  im.packages_dropped_before += im.rtde->packagesDropped();
  im.rtde.reset();  // closes every connection and the listening socket
  im.dashboard.reset();
  im.script.reset();
  if (im.wake_fd >= 0) ::close(im.wake_fd);
  im.wake_fd = -1;
}

std::uint16_t SimRobot::rtdePort() const noexcept { return impl_->rtde_port; }
std::uint16_t SimRobot::dashboardPort() const noexcept { return impl_->dashboard_port; }
std::uint16_t SimRobot::scriptPort() const noexcept { return impl_->script_port; }
double SimRobot::period() const noexcept { return impl_->controller.period(); }
std::string SimRobot::versionString() const { return impl_->controller.version().toString(); }

void SimRobot::inject(FaultKind kind, int count) {
  std::lock_guard<std::mutex> lock(impl_->m);
  impl_->controller.inject(kind, count);
}

void SimRobot::runProgramText(const std::string& text) {
  std::lock_guard<std::mutex> lock(impl_->m);
  impl_->controller.loadProgram(text);
}

SimSnapshot SimRobot::snapshot() const {
  const Impl& im = *impl_;
  std::lock_guard<std::mutex> lock(im.m);
  const Controller& k = im.controller;
  SimSnapshot s;
  s.timestamp = k.timestamp();
  s.ticks = k.ticks();
  s.q = k.motion().q();
  s.qd = k.motion().qd();
  s.actual_q = k.actualQ();
  s.robot_mode = k.robotMode();
  s.safety_mode = k.safetyMode();
  s.runtime_state = k.runtimeState();
  s.program_name = k.programName();
  s.servo_active = k.motion().servoActive();
  s.moving = k.motion().qd().cwiseAbs().maxCoeff() > 1e-6;
  s.rtde_connections = im.rtde ? im.rtde->connectionCount() : 0;
  s.servo_commands = k.servoCommands();
  s.packages_sent = im.packages_sent_before + (im.rtde ? im.rtde->packagesSent() : 0);
  s.packages_dropped = im.packages_dropped_before + (im.rtde ? im.rtde->packagesDropped() : 0);
  s.watchdog_armed = k.watchdogArmed();
  s.watchdog_fired = k.watchdogFired();
  s.last_event = k.lastEvent();
  return s;
}

rt::LoopStats SimRobot::tickStats() const {
  std::lock_guard<std::mutex> lock(impl_->m);
  return impl_->published_stats;
}

}  // namespace ftid::simrobot
