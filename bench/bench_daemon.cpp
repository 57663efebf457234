// bench_daemon: latency and rate of ftidd's published compensated wrench, measured by an
// independent LCM subscriber process. Run by bench/bench_daemon.sh inside a private network
// namespace together with `ftid sim-robot`, `ftid sim-sensor` and ftidd.
//
//   bench_daemon URL SECONDS [CHANNEL]
//   bench_daemon --write-params FILE      (the simulator's default payload as a parameter file)
//
// For every compensated_wrench_t received it takes
//   receipt -> delivery = LCM receive time (subscriber) - sensor_recv_utime (kernel timestamp of
//                         the CAN frame that completed the sensor sample used)
//   cycle   -> delivery = LCM receive time - utime (robot packet received, cycle start)
//   sensor age          = utime - sensor_recv_utime (how old the newest sample was at cycle start)
// and prints p50 / p99 / p99.9 / max of each, the message rate and gaps in the cycle numbers.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "ftid/effects/model.hpp"
#include "ftid/params/parameter_set.hpp"
#include "ftid/transport/codec.hpp"

namespace {

struct Collector {
  std::vector<double> total_us, cycle_us, age_us;
  std::int64_t first_cycle = -1, last_cycle = -1, gaps = 0, invalid = 0;
  double first_robot_time = 0.0, last_robot_time = 0.0;
  void onWrench(const lcm::ReceiveBuffer* rbuf, const std::string&,
                const ftid_lcm::compensated_wrench_t* m) {
    if (first_cycle < 0) {
      first_cycle = m->cycle;
      first_robot_time = m->robot_time;
    } else if (m->cycle != last_cycle + 1) {
      gaps += m->cycle - last_cycle - 1;
    }
    last_cycle = m->cycle;
    last_robot_time = m->robot_time;
    if (!m->valid) {
      ++invalid;
      return;
    }
    total_us.push_back(static_cast<double>(rbuf->recv_utime - m->sensor_recv_utime));
    cycle_us.push_back(static_cast<double>(rbuf->recv_utime - m->utime));
    age_us.push_back(static_cast<double>(m->sensor_age_us));
  }
};

double quantile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const auto i = static_cast<std::size_t>(p * static_cast<double>(v.size() - 1) + 0.5);
  return v[std::min(i, v.size() - 1)];
}

void printRow(const char* name, const std::vector<double>& v) {
  std::printf("%-26s p50 %8.1f  p99 %8.1f  p99.9 %8.1f  max %8.1f us\n", name, quantile(v, 0.5),
              quantile(v, 0.99), quantile(v, 0.999), quantile(v, 1.0));
}

}  // namespace

int writeParams(const std::string& path) {
  // Paper Table 2 payload, the simulator's default (docs/sensor.md).
  const double g = 9.80665, m = 8.862 / g, deg = 3.141592653589793 / 180.0;
  const ftid::effects::Model model = ftid::effects::Model::fromName("paper");
  ftid::params::ParameterSet set;
  set.model = model.name();
  for (const auto& name : model.paramIndex().names()) {
    double v = 0.0;
    if (name == "mass") v = m;
    if (name == "mass_com_x") v = m * 0.005;
    if (name == "mass_com_y") v = m * 0.002;
    if (name == "mass_com_z") v = m * 0.051;
    if (name == "f0_x") v = -0.6672;
    if (name == "f0_y") v = 0.8565;
    if (name == "f0_z") v = 0.3538;
    if (name == "t0_x") v = 0.0228;
    if (name == "t0_y") v = 0.0084;
    if (name == "t0_z") v = 0.0080;
    set.params.push_back({name, v, 0.0, ""});
  }
  set.tilt_estimated = true;
  set.tilt_u_rad = -9.8716 * deg;
  set.tilt_v_rad = -5.3709 * deg;
  ftid::params::writeParameterFile(path, set);
  return 0;
}

int main(int argc, char** argv) {
  if (argc == 3 && std::string(argv[1]) == "--write-params") return writeParams(argv[2]);
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s URL SECONDS [CHANNEL]\n", argv[0]);
    return 2;
  }
  const std::string url = argv[1];
  const double seconds = std::atof(argv[2]);
  const std::string channel = argc > 3 ? argv[3] : "FTID_WRENCH";
  lcm::LCM lc(url);
  if (!lc.good()) {
    std::fprintf(stderr, "bench_daemon: cannot open LCM %s\n", url.c_str());
    return 1;
  }
  Collector c;
  lc.subscribe(channel, &Collector::onWrench, &c)->setQueueCapacity(10000);
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < end) lc.handleTimeout(100);
  const std::int64_t received = c.last_cycle >= 0 ? c.last_cycle - c.first_cycle + 1 - c.gaps : 0;
  const double span = c.last_robot_time - c.first_robot_time;
  std::printf("messages %lld, valid %zu, invalid %lld, lost (cycle gaps) %lld\n",
              static_cast<long long>(received), c.total_us.size(), static_cast<long long>(c.invalid),
              static_cast<long long>(c.gaps));
  std::printf("published rate %.2f Hz over %.1f s of robot time\n",
              span > 0 ? static_cast<double>(received - 1) / span : 0.0, span);
  printRow("CAN receipt -> delivered", c.total_us);
  printRow("cycle start -> delivered", c.cycle_us);
  printRow("sensor age at cycle start", c.age_us);
  return received > 0 ? 0 : 1;
}
