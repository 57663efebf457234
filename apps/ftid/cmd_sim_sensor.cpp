// `ftid sim-sensor`: a simulated F/T+IMU sensor on CAN, fed by the robot's RTDE stream.
#include <pthread.h>
#include <signal.h>

#include <atomic>
#include <cstdio>
#include <ctime>
#include <mutex>
#include <sstream>
#include <thread>

#include "command.hpp"
#include "ftid/common/default_files.hpp"
#include "ftid/common/error.hpp"
#include "ftid/simsensor/sim_sensor.hpp"

namespace {

const char* kUsage =
    "usage: ftid sim-sensor [--robot-host 127.0.0.1] [--rtde-port 30004] [--socket PATH]\n"
    "                       [--config config/sim_sensor.yaml] [--rate 1000] [--effect NAME ...]\n"
    "                       [--fault T:KIND[:COUNT] ...] [--seed N] [--duration S]\n"
    "                       [--can-interface can0] [--candump-log FILE] [--dbc FILE] [--urdf FILE]\n"
    "\n"
    "Simulates the wrist F/T sensor with IMU: reads the robot's joint motion over RTDE from a UR\n"
    "controller or `ftid sim-robot`, computes the sensor reading with the cell simulator's physics\n"
    "(payload, tilt, offsets, effects, noise) and sends it as CAN frames laid out by the DBC, on a\n"
    "Unix SOCK_SEQPACKET socket carrying struct can_frame (the SocketCAN stand-in that ftidd reads\n"
    "with sensor endpoint seqpacket:PATH). Runs until SIGINT/SIGTERM or --duration.\n"
    "\n"
    "options (command line overrides --config, which overrides the defaults):\n"
    "  --robot-host H      RTDE host (default 127.0.0.1)\n"
    "  --rtde-port P       RTDE port (default 30004)\n"
    "  --rtde-frequency F  RTDE output rate [Hz] (default: 125 on CB3, 500 on e-Series)\n"
    "  --urdf FILE         robot model for the physics (default: the shipped ur10.urdf, docs/operations.md)\n"
    "  --socket PATH       stand-in socket to serve (default /run/ftid/ftsensor.sock)\n"
    "  --config FILE       YAML configuration (see config/sim_sensor.yaml for every key)\n"
    "  --rate HZ           sample rate (default 1000; 6 frames per sample)\n"
    "  --duration S        stop after S seconds of robot time (default: run until stopped)\n"
    "  --effect NAME       switch on a hidden effect; repeatable: cable, temperature_drift,\n"
    "                      time_drift, sensor_delay, crosstalk, contact, rigid_body, paper_only,\n"
    "                      noise (typical sensor noise)\n"
    "  --seed N            noise seed (default 1)\n"
    "  --fault T:KIND[:N]  inject a sensor fault T seconds after the first robot state; repeatable.\n"
    "                      KIND = silent | counter_gap | out_of_range | error_frame | bus_off |\n"
    "                      stuck_counter | status_fault; N = samples/frames (default 1)\n"
    "  --can-interface IF  also send on SocketCAN interface IF (needs AF_CAN)\n"
    "  --candump-log FILE  also write every frame to a candump -l style log\n"
    "  --dbc FILE          CAN layout (default: the shipped ftsensor.dbc)\n"
    "  --verbose           a status line every second instead of every 5 s\n"
    "\n"
    "At run time: SIGUSR1 injects one error frame, SIGUSR2 silences the sensor for 100 samples,\n"
    "SIGRTMIN+1 starts the configured contact push (effects.contact) now.\n"
    "Default payload: the paper's Table 2 (8.862 N, c = (0.5, 0.2, 5.1) cm, tilt -9.87/-5.37 deg).\n"
    "Layout, health rules and the simulator: docs/sensor.md.";

double parseNumber(const std::string& key, const std::string& v) {
  try {
    std::size_t used = 0;
    const double d = std::stod(v, &used);
    if (used != v.size()) throw std::invalid_argument(v);
    return d;
  } catch (const std::exception&) {
    throw ftid::cli::UsageError(key + ": not a number: '" + v + "'");
  }
}

int runSimSensor(const std::vector<std::string>& argv) {
  using namespace ftid::simsensor;
  ftid::cli::Args args(argv, kUsage);
  SimSensorConfig cfg = defaultSimSensorConfig();
  cfg.urdf_path.clear();  // defaults from the one lookup below, unless --config/--urdf set them
  cfg.dbc_path.clear();
  const std::string config_path = args.value("--config");
  if (!config_path.empty()) loadSimSensorYaml(config_path, cfg);
  if (args.has("--robot-host")) cfg.robot_host = args.value("--robot-host");
  if (args.has("--rtde-port")) {
    const double p = parseNumber("--rtde-port", args.value("--rtde-port"));
    if (p < 1 || p > 65535) throw ftid::cli::UsageError("--rtde-port must be 1..65535");
    cfg.rtde_port = static_cast<std::uint16_t>(p);
  }
  if (args.has("--rtde-frequency"))
    cfg.rtde_frequency_hz = parseNumber("--rtde-frequency", args.value("--rtde-frequency"));
  if (args.has("--urdf")) cfg.urdf_path = args.value("--urdf");
  if (args.has("--socket")) cfg.socket_path = args.value("--socket");
  if (args.has("--rate")) cfg.rate_hz = parseNumber("--rate", args.value("--rate"));
  if (args.has("--duration")) cfg.duration_s = parseNumber("--duration", args.value("--duration"));
  if (args.has("--seed")) {
    const double s = parseNumber("--seed", args.value("--seed"));
    if (s < 0) throw ftid::cli::UsageError("--seed must be >= 0");
    cfg.cell.seed = static_cast<std::uint64_t>(s);
  }
  if (args.has("--can-interface")) cfg.can_interface = args.value("--can-interface");
  if (args.has("--candump-log")) cfg.candump_log = args.value("--candump-log");
  if (args.has("--dbc")) cfg.dbc_path = args.value("--dbc");
  if (cfg.urdf_path.empty()) cfg.urdf_path = ftid::findDefaultFile("ur10.urdf");
  if (cfg.dbc_path.empty()) cfg.dbc_path = ftid::findDefaultFile("ftsensor.dbc");
  // Repeatable options: Args::value() consumes one occurrence per call.
  for (std::string e = args.value("--effect"); !e.empty(); e = args.value("--effect"))
    enableEffect(e, cfg);
  for (std::string f = args.value("--fault"); !f.empty(); f = args.value("--fault")) {
    std::stringstream ss(f);
    std::string when, kind, count;
    std::getline(ss, when, ':');
    std::getline(ss, kind, ':');
    std::getline(ss, count, ':');
    ScheduledSensorFault sf;
    sf.at_s = parseNumber("--fault", when);
    sf.kind = parseSensorFault(kind);
    if (!count.empty()) sf.count = static_cast<int>(parseNumber("--fault", count));
    if (sf.count < 1) throw ftid::cli::UsageError("--fault: COUNT must be >= 1");
    cfg.faults.push_back(sf);
  }
  cfg.verbose = args.flag("--verbose");
  args.finish();

  // Signals go to the waiter thread only (blocked before any thread starts).
  sigset_t set;
  sigemptyset(&set);
  for (int s : {SIGINT, SIGTERM, SIGUSR1, SIGUSR2, SIGRTMIN + 1}) sigaddset(&set, s);
  pthread_sigmask(SIG_BLOCK, &set, nullptr);

  SimSensor sensor(cfg);
  std::atomic<bool> stop{false};
  std::atomic<bool> done{false};
  std::thread waiter([&] {
    const timespec poll{0, 200'000'000};
    while (!done.load()) {
      siginfo_t info;
      const int sig = sigtimedwait(&set, &info, &poll);
      if (sig == SIGINT || sig == SIGTERM) stop = true;
      if (sig == SIGUSR1) sensor.inject(SensorFault::kErrorFrame, 1);
      if (sig == SIGUSR2) sensor.inject(SensorFault::kSilent, 100);
      if (sig == SIGRTMIN + 1) sensor.startContactPush();
    }
  });
  std::mutex print_mutex;
  std::printf("sim-sensor: %.0f Hz on %s; robot %s:%u; Ctrl-C to stop\n", cfg.rate_hz,
              cfg.socket_path.c_str(), cfg.robot_host.c_str(), cfg.rtde_port);
  std::fflush(stdout);
  try {
    sensor.run(stop, [&](const std::string& line) {
      std::lock_guard<std::mutex> lock(print_mutex);
      std::printf("sim-sensor: %s\n", line.c_str());
      std::fflush(stdout);
    });
  } catch (...) {
    done = true;
    waiter.join();
    throw;
  }
  done = true;
  waiter.join();
  const SimSensorStats st = sensor.stats();
  std::printf("sim-sensor: stopped: %llu samples, %llu frames, %llu robot states, %llu frames "
              "dropped by slow clients\n",
              static_cast<unsigned long long>(st.samples),
              static_cast<unsigned long long>(st.frames_sent),
              static_cast<unsigned long long>(st.robot_ticks),
              static_cast<unsigned long long>(st.frames_dropped));
  return 0;
}

}  // namespace

static ftid::cli::Registrar reg{{"sim-sensor",
                                 "simulated F/T+IMU sensor on CAN (SOCK_SEQPACKET stand-in) fed by RTDE",
                                 kUsage, &runSimSensor}};
