#pragma once
// The demo cell's state and its shared steps (private to ftid_cell): demo.cpp (the laboratory
// story) and demo_payload.cpp (`--scenario payload-change`) run their steps over one DemoCell.
#include <fcntl.h>
#include <signal.h>
#include <sched.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <lcm/lcm-cpp.hpp>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "ftid/cell/cell_identify.hpp"
#include "ftid/cell/demo.hpp"
#include "ftid/common/error.hpp"
#include "ftid/common/status.hpp"
#include "ftid/simsensor/sim_sensor.hpp"
#include "ftid/transport/codec.hpp"

extern char** environ;

namespace ftid::cell::demo {

namespace fs = std::filesystem;

void say(const std::string& s);
std::string f3(double v);
/// The last `lines` lines of a file (a child's log), for messages.
std::string tail(const fs::path& p, int lines);

/// SCHED_FIFO priority of the two simulators where the demo may use it (root): the controller and
/// the sensor they stand for keep their own time on their own hardware, whatever the cell PC's load
/// (as in scripts/soak.sh); below ftidd's loop (80) and the motion runner's.
inline constexpr int kSimulatorFifoPriority = 70;

/// A child process with its output in a log file; terminated (SIGTERM, then SIGKILL) on scope exit.
/// With fifo_priority > 0 it runs SCHED_FIFO at that priority when permitted, else as usual.
class Child {
 public:
  Child(const std::string& name, const std::vector<std::string>& argv, const fs::path& log, int fifo_priority = 0)
      : name_(name), log_(log) {
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&fa, STDOUT_FILENO, STDERR_FILENO);
    posix_spawn_file_actions_addopen(&fa, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    int rc = EPERM;
    if (fifo_priority > 0) {
      posix_spawnattr_t attr;
      posix_spawnattr_init(&attr);
      sched_param sp{};
      sp.sched_priority = fifo_priority;
      posix_spawnattr_setschedpolicy(&attr, SCHED_FIFO);
      posix_spawnattr_setschedparam(&attr, &sp);
      posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSCHEDULER | POSIX_SPAWN_SETSCHEDPARAM);
      rc = posix_spawn(&pid_, args[0], &fa, &attr, args.data(), environ);
      posix_spawnattr_destroy(&attr);
      realtime_ = rc == 0;
    }
    if (rc == EPERM) rc = posix_spawn(&pid_, args[0], &fa, nullptr, args.data(), environ);  // not permitted
    posix_spawn_file_actions_destroy(&fa);
    if (rc != 0) throw Error("cannot start " + name + " (" + argv[0] + "): " + std::strerror(rc));
  }
  /// Whether it runs SCHED_FIFO (fifo_priority given and permitted).
  bool realtime() const { return realtime_; }
  ~Child() { stop(); }
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;
  bool alive() {
    if (pid_ <= 0) return false;
    int status = 0;
    if (waitpid(pid_, &status, WNOHANG) == pid_) {
      pid_ = -1;
      return false;
    }
    return true;
  }
  void signal(int sig) const {
    if (pid_ > 0) ::kill(pid_, sig);
  }
  void stop() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGTERM);
    for (int i = 0; i < 50; ++i) {
      if (waitpid(pid_, nullptr, WNOHANG) == pid_) {
        pid_ = -1;
        return;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    ::kill(pid_, SIGKILL);
    waitpid(pid_, nullptr, 0);
    pid_ = -1;
  }
  const fs::path& log() const { return log_; }
  const std::string& name() const { return name_; }

 private:
  std::string name_;
  fs::path log_;
  pid_t pid_ = -1;
  bool realtime_ = false;
};

struct LiveStats {
  int samples = 0;
  int valid = 0;
  double rms_quiet_force = 0.0;   ///< contact force RMS outside the push
  double rms_quiet_torque = 0.0;
  double peak_push_force = 0.0;   ///< |contact force| peak during the push
  double raw_quiet_force = 0.0;   ///< mean |raw force| outside the push (tool weight and offsets)
};

/// The live receiver's store of ftidd's compensated wrench (FTID_WRENCH): only cycles that
/// started at or after since_utime, at most the reserved 10000.
struct Collector {
  std::int64_t since_utime = 0;
  std::vector<CycleRecord> recs;
  // Received bytes are untrusted: the one safe decode, and a bounded store (5 s at 125 Hz
  // is 625 records; a flood beyond 10000 is dropped, never grown without bound).
  void handle(const lcm::ReceiveBuffer* rb, const std::string&) noexcept {
    ftid_lcm::compensated_wrench_t m;
    if (!transport::decodeFrom(rb->data, rb->data_size, &m)) return;
    CycleRecord r;
    transport::fromLcm(m, &r);
    if (r.utime < since_utime || recs.size() >= recs.capacity()) return;
    recs.push_back(r);  // within the reserved capacity: no allocation, no throw
  }
};

/// The demo's state: its paths, the sensor simulator's truth, the three processes (stopped in
/// reverse order of their start when the demo ends) and the live receiver's store.
struct DemoCell {
  explicit DemoCell(const DemoOptions& options);

  const DemoOptions& opt;
  const fs::path work;
  const fs::path cfgdir;
  const fs::path ftid;
  const fs::path ftidd;
  const fs::path sock;
  const fs::path params;
  const fs::path key;
  std::vector<std::string> effects;  ///< the sensor's physics switches (set before writeCellFiles)
  std::string hidden_text;           ///< what step 2 says after "hidden effect: "
  simsensor::SimSensorConfig truth;
  std::unique_ptr<Child> robot;
  std::unique_ptr<Child> sensor;
  std::unique_ptr<Child> daemon;
  Collector collector;
  int steps = 7;  ///< the number of steps the scenario prints ("[k/steps]")
  std::string step(int k) const { return "[" + std::to_string(k) + "/" + std::to_string(steps) + "]"; }
};

/// Writes the command key, ftidd.yaml and the sensor simulator's configuration; reads the latter
/// back, with the effects c.effects (set before), as c.truth.
void writeCellFiles(DemoCell& c);
/// Steps 1-3: the robot simulator, the sensor simulator and ftidd. False (with the log) on failure.
bool startProcesses(DemoCell& c);
/// `ftid --identify --yes` on the cell with `model`, its output indented under the step's title.
CellIdentifyResult identifyOnCell(const DemoCell& c, const std::string& model, const std::string& step);
/// The identified payload beside the simulator's truth (value, 1 sigma, truth).
std::string identifiedText(const std::string& params_path, const sim::CellSimConfig& truth);
/// |contact| RMS of the simulated noise alone (three independent axes).
std::string noiseOnlyText(const sim::CellSimConfig& truth);

/// Ticks of a recording (a motion runner's `--out` CSV or a run's run.csv, columns qdd1..qdd6)
/// where the arm's acceleration exceeded kJerkRadps2 on some joint: the demo's excitations plan at
/// most 6 rad/s^2 (they peak at 5.9-6.5), the simulated arm's clamp is 40, so such a tick is a
/// servo target that reached the controller late or not at all (a host stall, with or without a
/// missed tick), which the sensor simulator, learning the motion over RTDE, cannot follow
/// (docs/sensor.md, "Between robot ticks"). 0 if the file is unreadable.
inline constexpr double kJerkRadps2 = 20.0;
std::size_t jerkTicks(const fs::path& csv);

}  // namespace ftid::cell::demo
