// Benchmark of the CAN sensor path (docs/performance.md, section "drivers_can / simsensor"):
//  1. DBC decoding + grouping: ns per frame and per 6-frame sample (SampleAssembler::feed);
//  2. CanFtImuSensor::tryReadLatest draining 8 samples (48 frames) from the SOCK_SEQPACKET
//     stand-in, as a 125 Hz daemon cycle does with a 1 kHz sensor: p50 / p99 / max;
//  3. stand-in frame latency: kernel receive timestamp minus the time just before send();
//  4. sim-sensor cost per sample: physics (CellSim::readingAt) + encoding.
// Run from anywhere (the default-file lookup finds ftsensor.dbc and ur10.urdf): build/bench/bench_can_sensor [iterations]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "ftid/common/default_files.hpp"
#include "ftid/drivers/can/ft_imu_sensor.hpp"
#include "ftid/drivers/can/seqpacket.hpp"
#include "ftid/simsensor/sim_sensor.hpp"

namespace {

using Clock = std::chrono::steady_clock;

double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(p * static_cast<double>(v.size() - 1))];
}


}  // namespace

int main(int argc, char** argv) {
  using namespace ftid;
  const int iterations = argc > 1 ? std::atoi(argv[1]) : 20000;
  const drivers::can::SensorLayout layout =
      drivers::can::SensorLayout::fromDbc(drivers::can::loadDbc(findDefaultFile("ftsensor.dbc")));

  // 1. decode + group
  {
    drivers::can::SampleAssembler a(layout);
    std::vector<drivers::can::ReceivedFrame> frames;
    std::array<can_frame, drivers::can::SensorLayout::kMaxMessages> f{};
    drivers::can::SensorValues v;
    for (int s = 0; s < 256; ++s) {
      v.wrench_S[0] = s * 0.1;
      const int n = drivers::can::encodeSample(layout, v, static_cast<std::uint32_t>(s), f);
      for (int i = 0; i < n; ++i) frames.push_back({f[static_cast<std::size_t>(i)], s * 1000});
    }
    const auto t0 = Clock::now();
    std::uint64_t completed = 0;
    for (int it = 0; it < iterations / 10 + 1; ++it)
      for (const auto& fr : frames) completed += a.feed(fr) ? 1 : 0;
    const double ns = std::chrono::duration<double, std::nano>(Clock::now() - t0).count();
    const double nframes = static_cast<double>((iterations / 10 + 1) * frames.size());
    std::printf("decode+group: %.1f ns/frame, %.1f ns/sample (%llu samples)\n", ns / nframes,
                ns / static_cast<double>(completed), static_cast<unsigned long long>(completed));
  }

  // 2. drain 8 samples per call over the stand-in
  {
    auto pair = drivers::can::makeSeqpacketPair();
    drivers::can::CanTransport& bus = *pair.a;
    drivers::can::CanFtImuSensor sensor(std::move(pair.b), layout);
    std::array<can_frame, drivers::can::SensorLayout::kMaxMessages> f{};
    drivers::can::SensorValues v;
    drivers::can::SensorSample s;
    std::vector<double> us;
    std::uint32_t counter = 0;
    const int calls = std::max(iterations / 10, 100);
    for (int c = 0; c < calls; ++c) {
      for (int k = 0; k < 8; ++k) {
        const int n = drivers::can::encodeSample(layout, v, counter++, f);
        for (int i = 0; i < n; ++i) bus.trySend(f[static_cast<std::size_t>(i)]);
      }
      const auto t0 = Clock::now();
      sensor.tryReadLatest(s);
      us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
    }
    std::printf("tryReadLatest draining 48 frames: p50 %.1f us, p99 %.1f us, max %.1f us (%d calls, %llu samples)\n",
                percentile(us, 0.5), percentile(us, 0.99), *std::max_element(us.begin(), us.end()),
                calls, static_cast<unsigned long long>(sensor.health().samples_complete));
  }

  // 3. stand-in latency (send -> kernel receive timestamp)
  {
    auto pair = drivers::can::makeSeqpacketPair();
    std::vector<double> us;
    can_frame f{};
    f.can_id = 0x1A0;
    f.len = 8;
    drivers::can::ReceivedFrame rf;
    for (int i = 0; i < iterations; ++i) {
      const std::int64_t t0 = drivers::can::realtimeNowNs();
      pair.a->trySend(f);
      pair.b->tryReceive(rf);
      us.push_back(static_cast<double>(rf.rx_time_ns - t0) * 1e-3);
    }
    std::printf("stand-in send -> kernel rx timestamp: p50 %.2f us, p99 %.2f us\n",
                percentile(us, 0.5), percentile(us, 0.99));
  }

  // 4. sim-sensor per-sample cost
  {
    simsensor::SimSensorConfig cfg = simsensor::defaultSimSensorConfig();
    simsensor::enableEffect("noise", cfg);
    simsensor::SensorFrameSource src(
        cfg, layout, model::RobotKinematics::fromUrdfFile(findDefaultFile("ur10.urdf")));
    simsensor::RobotHistory h;
    for (int k = 0; k < 200; ++k) {
      simsensor::RobotHistory::Tick t;
      t.t = 50.0 + 0.008 * k;
      t.q << 0.0, -1.5708, 1.5708, -1.5708, -1.5708, 0.0;
      t.q[4] += 0.3 * std::sin(t.t);
      t.qd[4] = 0.3 * std::cos(t.t);
      h.add(t);
    }
    std::array<can_frame, simsensor::SensorFrameSource::kMaxFrames> out{};
    const int n = std::max(iterations / 4, 100);
    const auto t0 = Clock::now();
    for (int i = 0; i < n; ++i) src.nextSample(h, 50.0 + 1.5 * i / n, 1.0, out);
    const double us = std::chrono::duration<double, std::micro>(Clock::now() - t0).count() / n;
    std::printf("sim-sensor sample (physics + noise + encode): %.1f us (max rate ~%.0f Hz on one core)\n",
                us, 1e6 / us);
  }
  return 0;
}
