#include "ftid/common/default_files.hpp"
#include "ftid/cell/demo.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <sched.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <iostream>
#include <lcm/lcm-cpp.hpp>
#include <sstream>
#include <thread>
#include <vector>

#include "ftid/cell/cell_identify.hpp"
#include "ftid/common/error.hpp"
#include "ftid/fileio/atomic_file.hpp"
#include "ftid/transport/codec.hpp"

extern char** environ;

namespace fs = std::filesystem;

namespace ftid::cell {

namespace {

void say(const std::string& s) { std::cout << s << "\n" << std::flush; }

/// A child process with its output in a log file; terminated (SIGTERM, then SIGKILL) on scope exit.
class Child {
 public:
  Child(const std::string& name, const std::vector<std::string>& argv, const fs::path& log)
      : name_(name), log_(log) {
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&fa, STDOUT_FILENO, STDERR_FILENO);
    posix_spawn_file_actions_addopen(&fa, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    const int rc = posix_spawn(&pid_, args[0], &fa, nullptr, args.data(), environ);
    posix_spawn_file_actions_destroy(&fa);
    if (rc != 0) throw Error("cannot start " + name + " (" + argv[0] + "): " + std::strerror(rc));
  }
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
};

bool tcpPortOpen(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return false;
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const bool ok = ::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)) == 0;
  ::close(fd);
  return ok;
}

template <class Pred>
bool waitFor(Pred pred, double seconds) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < deadline) {
    if (pred()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return false;
}

std::string tail(const fs::path& p, int lines) {
  std::ifstream in(p);
  std::vector<std::string> all;
  for (std::string l; std::getline(in, l);) all.push_back(l);
  std::string out;
  for (std::size_t i = all.size() > static_cast<std::size_t>(lines) ? all.size() - lines : 0; i < all.size(); ++i)
    out += "    | " + all[i] + "\n";
  return out;
}

/// Enters a new network namespace with loopback up and a multicast route on it, so LCM's udpm
/// traffic never leaves this process tree. As root only CLONE_NEWNET is needed; otherwise a user
/// namespace maps the caller to root inside.
void enterPrivateNetwork() {
  const uid_t uid = ::geteuid();
  const gid_t gid = ::getegid();
  int flags = CLONE_NEWNET;
  if (uid != 0) flags |= CLONE_NEWUSER;
  if (::unshare(flags) != 0) {
    throw Error(std::string("cannot create a private network namespace (unshare: ") + std::strerror(errno) +
                "); run with --no-netns to use the host network");
  }
  if (uid != 0) {
    std::ofstream("/proc/self/setgroups") << "deny";
    std::ofstream("/proc/self/uid_map") << "0 " << uid << " 1";
    std::ofstream("/proc/self/gid_map") << "0 " << gid << " 1";
  }
  if (std::system("ip link set lo up && ip route add 224.0.0.0/4 dev lo") != 0) {
    throw Error("cannot bring up lo with a multicast route in the private namespace (is iproute2 installed?)");
  }
}

fs::path selfDir() { return fs::read_symlink("/proc/self/exe").parent_path(); }

/// ftidd next to ftid (installed: ../sbin/ftidd; build tree: ../ftidd/ftidd).
fs::path findFtidd() {
  for (const fs::path& p : {selfDir() / "ftidd", selfDir().parent_path() / "ftidd" / "ftidd",
                            selfDir().parent_path() / "sbin" / "ftidd"}) {
    if (fs::exists(p)) return p;
  }
  throw Error("cannot find the ftidd executable next to " + selfDir().string());
}

/// The directory of the shipped default files (the one lookup, ftid/common/default_files.hpp).
fs::path findConfigDir() { return fs::path(findDefaultFile("sim_sensor.yaml")).parent_path(); }

void writeFile(const fs::path& p, const std::string& text) { writeFileAtomically(p.string(), text); }

std::string f3(double v) {
  char b[32];
  std::snprintf(b, sizeof(b), "%.3f", v);
  return b;
}

struct LiveStats {
  int samples = 0;
  int valid = 0;
  double rms_quiet_force = 0.0;   ///< contact force RMS outside the push
  double rms_quiet_torque = 0.0;
  double peak_push_force = 0.0;   ///< |contact force| peak during the push
  double raw_force_range = 0.0;   ///< max - min of |raw force| (what the tool alone does)
};

}  // namespace

int runDemo(const DemoOptions& opt) {
  const auto t_start = std::chrono::steady_clock::now();
  const fs::path work = fs::absolute(opt.workdir);
  fs::create_directories(work / "logs");
  const fs::path cfgdir = findConfigDir();
  const fs::path ftid = fs::read_symlink("/proc/self/exe");
  const fs::path ftidd = findFtidd();
  say("== ftid demo: a UR10 cell with an F/T+IMU sensor, simulated on loopback");
  say("   work directory: " + work.string());
  if (opt.private_netns) {
    enterPrivateNetwork();
    say("   network: a private network namespace (LCM multicast stays inside it)");
  }

  // ---- configuration files for this run
  const fs::path sock = work / "ftsensor.sock";
  const fs::path params = work / "parameters.yaml";
  fs::remove(params);
  fs::remove(fs::path(params.string() + ".bak"));
  // The demo's own command key (ftidd refuses unsigned commands; the installed key in /etc/ftid
  // is root's): 32 random bytes as hex, readable by this user only.
  const fs::path key = work / "command.key";
  {
    std::random_device rd;
    std::string hex = "# command key of this demo cell (docs/operations.md, \"Network and commands\")\n";
    const char* digits = "0123456789abcdef";
    for (int i = 0; i < 32; ++i) {
      const unsigned b = rd() & 0xFFu;
      hex += digits[b >> 4];
      hex += digits[b & 0xFu];
    }
    writeFile(key, hex + "\n");
    fs::permissions(key, fs::perms::owner_read | fs::perms::owner_write, fs::perm_options::replace);
  }
  writeFile(work / "ftidd.yaml",
            "# ftidd configuration written by `ftid demo` (see config/ftidd.yaml for every key)\n"
            "robot:\n  host: 127.0.0.1\n  rtde_port: 30004\n  dashboard_port: 29999\n"
            "  rtde_frequency_hz: 125\n  urdf_path: " + (cfgdir / "ur10.urdf").string() + "\n"
            "sensor:\n  transport: seqpacket\n  socket_path: " + sock.string() + "\n"
            "  dbc_path: " + (cfgdir / "ftsensor.dbc").string() + "\n  stale_timeout_ms: 20\n"
            "parameters:\n  path: " + params.string() + "\n  required: false\n"
            "lcm:\n  url: \"udpm://239.255.76.67:7667?ttl=0\"\n  command_key_path: " + key.string() + "\n"
            "rt:\n  require_rt: false\n");
  std::string sensor_yaml;
  {
    std::ifstream in(cfgdir / "sim_sensor.yaml");
    std::stringstream ss;
    ss << in.rdbuf();
    sensor_yaml = ss.str();
  }
  writeFile(work / "sim_sensor.yaml", sensor_yaml);

  // ---- processes
  say("[1/6] UR10 controller simulator (CB3, 125 Hz): RTDE 127.0.0.1:30004, dashboard 29999, script 30003");
  Child robot("sim-robot", {ftid.string(), "sim-robot", "--model", "ur10"}, work / "logs" / "sim-robot.log");
  if (!waitFor([] { return tcpPortOpen(30004) && tcpPortOpen(29999); }, 10.0)) {
    say("demo: the robot simulator did not start:\n" + tail(robot.log(), 10));
    return 1;
  }
  say("[2/6] F/T+IMU sensor simulator: the paper's payload (G = 8.862 N, c = (5, 2, 51) mm, base tilt"
      " U = -9.87 deg, V = -5.37 deg), 0.05 N / 0.01 Nm noise, and a hidden effect the paper's model"
      " lacks");
  // The paper's physics plus exactly one hidden effect (rigid_body = the full Newton-Euler physics).
  std::vector<std::string> sensor_args{ftid.string(), "sim-sensor", "--config", (work / "sim_sensor.yaml").string(),
                                       "--urdf", (cfgdir / "ur10.urdf").string(), "--dbc",
                                       (cfgdir / "ftsensor.dbc").string(), "--socket", sock.string(), "--seed",
                                       std::to_string(opt.seed), "--effect", "noise"};
  if (opt.hidden_effect == "rigid_body") {
    sensor_args.insert(sensor_args.end(), {"--effect", "rigid_body"});
  } else {
    sensor_args.insert(sensor_args.end(), {"--effect", "paper_only", "--effect", opt.hidden_effect});
  }
  say("      hidden effect: " + opt.hidden_effect + " (the analysis has to find it)");
  Child sensor("sim-sensor", sensor_args, work / "logs" / "sim-sensor.log");
  if (!waitFor([&] { return fs::exists(sock) || !sensor.alive(); }, 10.0) || !sensor.alive()) {
    say("demo: the sensor simulator did not start:\n" + tail(sensor.log(), 10));
    return 1;
  }
  say("[3/6] ftidd, the real-time compensation daemon (robot-clocked loop, LCM publishing)");
  Child daemon("ftidd", {ftidd.string(), "--config", (work / "ftidd.yaml").string()}, work / "logs" / "ftidd.log");

  // ---- identification with the paper's model
  auto identify = [&](const std::string& model, const std::string& step) {
    say("");
    say(step + " ftid --identify --model " + model + " --yes");
    CellIdentifyOptions o;
    o.config_path = (work / "ftidd.yaml").string();
    o.model = model;
    o.assume_yes = true;
    o.runs_dir = (work / "runs").string();
    o.startup_wait_s = 15.0;
    o.print = [](const std::string& s) {
      std::istringstream in(s);
      for (std::string l; std::getline(in, l);) say("    " + l);
    };
    double last = -1;
    o.progress = [&last](const std::string& phase, double el, double tot) {
      if (std::floor(el) != last) {
        last = std::floor(el);
        std::printf("    [%-16s] %4.1f / %4.1f s\n", phase.c_str(), el, tot);
        std::fflush(stdout);
      }
    };
    return runCellIdentify(o);
  };
  const CellIdentifyResult first = identify("paper", "[4/6]");
  if (first.exit_code != 0) {
    say("demo: identification failed: " + first.message);
    say("ftidd log:\n" + tail(daemon.log(), 15) + "sensor log:\n" + tail(sensor.log(), 8));
    return 1;
  }
  if (first.suggested_effect.empty()) {
    say("demo: the analysis found nothing missing, but the sensor carries a hidden '" + opt.hidden_effect + "'");
    return 1;
  }
  const std::string model2 = "paper+" + first.suggested_effect;
  const CellIdentifyResult second = identify(model2, "[5/6]");
  if (second.exit_code != 0) {
    say("demo: second identification failed: " + second.message);
    return 1;
  }
  say("");
  say("   The error falls (held-out residual RMS per axis, noise floor in brackets):");
  for (int i = 0; i < 6; ++i) {
    char line[200];
    std::snprintf(line, sizeof(line), "     %-3s  paper: %8.4f   %-22s %8.4f   [%.4f]", kWrenchAxisNames[i],
                  first.heldout_rms(i), (model2 + ":").c_str(), second.heldout_rms(i), second.noise_floor(i));
    say(line);
  }

  // ---- live compensated wrench with a push on the tool
  say("");
  say("[6/6] live compensated wrench from ftidd (LCM FTID_WRENCH) while someone pushes the tool");
  lcm::LCM lc("udpm://239.255.76.67:7667?ttl=0");
  struct Collector {
    std::vector<CycleRecord> recs;
    void handle(const lcm::ReceiveBuffer* rb, const std::string&) {
      ftid_lcm::compensated_wrench_t m;
      if (m.decode(rb->data, 0, static_cast<int>(rb->data_size)) < 0) return;
      CycleRecord r;
      transport::fromLcm(m, &r);
      recs.push_back(r);
    }
  } collector;
  lc.subscribe("FTID_WRENCH", &Collector::handle, &collector);
  auto collect = [&](double seconds) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (std::chrono::steady_clock::now() < end) lc.handleTimeout(20);
  };
  collect(1.5);
  const std::size_t quiet_end = collector.recs.size();
  sensor.signal(SIGRTMIN + 1);  // the sensor simulator starts its configured contact push now
  collect(3.0);
  LiveStats st;
  double fmin = 1e9, fmax = -1e9;
  double raw_quiet = 0.0;  // mean |raw force| before the push: the tool's weight plus the offsets
  int quiet_n = 0;
  for (std::size_t i = 0; i < collector.recs.size(); ++i) {
    const auto& r = collector.recs[i];
    ++st.samples;
    if (!r.wrench_valid) continue;
    ++st.valid;
    const double fc = r.contact_S.head<3>().norm();
    const double fr = (r.contact_S + r.modelled_S).head<3>().norm();
    fmin = std::min(fmin, fr);
    fmax = std::max(fmax, fr);
    if (i < quiet_end) {
      st.rms_quiet_force += fc * fc;
      st.rms_quiet_torque += r.contact_S.tail<3>().squaredNorm();
      raw_quiet += fr;
      ++quiet_n;
    } else {
      st.peak_push_force = std::max(st.peak_push_force, fc);
    }
  }
  if (quiet_n > 0) {
    st.rms_quiet_force = std::sqrt(st.rms_quiet_force / quiet_n);
    st.rms_quiet_torque = std::sqrt(st.rms_quiet_torque / quiet_n);
    raw_quiet /= quiet_n;
  }
  st.raw_force_range = fmax - fmin;
  say("   " + std::to_string(st.samples) + " compensated samples (" + std::to_string(st.valid) + " valid)");
  say("   before the push: |contact force| RMS " + f3(st.rms_quiet_force) + " N, |contact torque| RMS " +
      f3(st.rms_quiet_torque) + " Nm (uncompensated, |force| reads " + f3(raw_quiet) +
      " N there: the tool's weight and the sensor offsets)");
  say("   during the push: peak |contact force| " + f3(st.peak_push_force) +
      " N (the simulated push peaks at 8 N): only the contact remains");

  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  say("");
  say("== demo finished in " + std::to_string(static_cast<int>(secs)) + " s. Where things are:");
  say("   parameters:     " + second.params_path + " (previous: " + second.params_path + ".bak)");
  say("   exports:        " + second.params_path + ".urscript, " + second.params_path + ".ros2.yaml");
  say("   recorded runs:  " + first.data_csv + "\n                   " + second.data_csv);
  say("   reports:        " + fs::path(first.data_csv).parent_path().string() + "/report.html\n                   " +
      fs::path(second.data_csv).parent_path().string() + "/report.html");
  say("   process logs:   " + (work / "logs").string());
  say("   try:            ftid analyze " + first.data_csv + " --model paper --explain");
  const bool ok = st.valid > 0 && st.peak_push_force > 4.0 && st.rms_quiet_force < 0.5;
  if (!ok) say("demo: the live compensation did not behave as expected (see the figures above)");
  return ok ? 0 : 1;
}

}  // namespace ftid::cell
