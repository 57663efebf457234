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
    "                      noise (typical sensor noise), grasp[:t=S,mass=KG,com=X/Y/Z,side=M]\n"
    "                      (an object held from t on; default 0.6 kg, com 0/0/0.12 m, a 6 cm\n"
    "                      cube, at SIGRTMIN+2 unless t is given)\n"
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
    "SIGRTMIN+1 starts the configured contact push (effects.contact) now; SIGRTMIN+2 grasps the\n"
    "--effect grasp object now (`kill -s RTMIN+2 PID`).\n"
    "Default payload: the paper's Table 2 (8.862 N, c = (0.5, 0.2, 5.1) cm, tilt -9.87/-5.37 deg).\n"
    "Layout, health rules and the simulator: docs/sensor.md.\n"
    "\n"
    "Exit status: 0 stopped by SIGINT/SIGTERM or after --duration, 1 a bad configuration, URDF or\n"
    "DBC file (named), an unknown --effect or fault kind, or a socket, CAN interface or candump log\n"
    "that cannot be opened or written (the message says which), 2 usage error (unknown option, bad\n"
    "number). A robot that is not reachable is retried every second, not an exit.";

int runSimSensor(const std::vector<std::string>& argv) {
  using namespace ftid::simsensor;
  namespace cli = ftid::cli;
  SimSensorConfig cfg = defaultSimSensorConfig();
  cfg.urdf_path.clear();  // defaults from the one lookup below, unless --config/--urdf set them
  cfg.dbc_path.clear();
  std::string config_path, robot_host, urdf, socket, can_interface, candump_log, dbc;
  int rtde_port = 0;
  double rtde_frequency = 0.0, rate = 0.0, duration = 0.0;
  std::uint64_t seed = 0;
  std::vector<std::string> effects, faults;
  bool verbose = false;
  CLI::App app{"ftid sim-sensor"};
  app.add_option("--config", config_path);
  CLI::Option* o_host = app.add_option("--robot-host", robot_host);
  CLI::Option* o_port = app.add_option("--rtde-port", rtde_port)->transform(cli::integer(1, 65535));
  CLI::Option* o_freq = app.add_option("--rtde-frequency", rtde_frequency)->transform(cli::real(cli::nonNegative()));
  CLI::Option* o_urdf = app.add_option("--urdf", urdf);
  CLI::Option* o_socket = app.add_option("--socket", socket);
  CLI::Option* o_rate = app.add_option("--rate", rate)->transform(cli::real(cli::positive()));
  CLI::Option* o_duration = app.add_option("--duration", duration)->transform(cli::real(cli::nonNegative()));
  CLI::Option* o_seed = app.add_option("--seed", seed)->transform(cli::count());
  CLI::Option* o_can = app.add_option("--can-interface", can_interface);
  CLI::Option* o_candump = app.add_option("--candump-log", candump_log);
  CLI::Option* o_dbc = app.add_option("--dbc", dbc);
  cli::addRepeatable(app, "--effect", effects);
  cli::addRepeatable(app, "--fault", faults);
  app.add_flag("--verbose", verbose);
  cli::parse(app, argv);
  std::vector<ScheduledSensorFault> cli_faults;  // checked before any file is read
  for (const auto& f : faults) {  // SECONDS:KIND[:COUNT]
    std::stringstream ss(f);
    std::string when, kind, n;
    std::getline(ss, when, ':');
    std::getline(ss, kind, ':');
    std::getline(ss, n, ':');
    ScheduledSensorFault sf;
    sf.at_s = cli::parseReal(when, "--fault " + f + ": SECONDS", cli::nonNegative());
    sf.kind = parseSensorFault(kind);
    if (!n.empty()) sf.count = static_cast<int>(cli::parseInteger(n, "--fault " + f + ": COUNT", 1, 1000000000));
    cli_faults.push_back(sf);
  }
  // The configuration file first; options given on the command line override it.
  if (!config_path.empty()) loadSimSensorYaml(config_path, cfg);
  if (o_host->count() > 0) cfg.robot_host = robot_host;
  if (o_port->count() > 0) cfg.rtde_port = static_cast<std::uint16_t>(rtde_port);
  if (o_freq->count() > 0) cfg.rtde_frequency_hz = rtde_frequency;
  if (o_urdf->count() > 0) cfg.urdf_path = urdf;
  if (o_socket->count() > 0) cfg.socket_path = socket;
  if (o_rate->count() > 0) cfg.rate_hz = rate;
  if (o_duration->count() > 0) cfg.duration_s = duration;
  if (o_seed->count() > 0) cfg.cell.seed = seed;
  if (o_can->count() > 0) cfg.can_interface = can_interface;
  if (o_candump->count() > 0) cfg.candump_log = candump_log;
  if (o_dbc->count() > 0) cfg.dbc_path = dbc;
  if (cfg.urdf_path.empty()) cfg.urdf_path = ftid::findDefaultFile("ur10.urdf");
  if (cfg.dbc_path.empty()) cfg.dbc_path = ftid::findDefaultFile("ftsensor.dbc");
  for (const auto& e : effects) enableEffect(e, cfg);
  cfg.faults.insert(cfg.faults.end(), cli_faults.begin(), cli_faults.end());
  cfg.verbose = verbose;

  // Signals go to the waiter thread only (blocked before any thread starts).
  sigset_t set;
  sigemptyset(&set);
  for (int s : {SIGINT, SIGTERM, SIGUSR1, SIGUSR2, SIGRTMIN + 1, SIGRTMIN + 2}) sigaddset(&set, s);
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
      if (sig == SIGRTMIN + 2) sensor.startGrasp();
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
