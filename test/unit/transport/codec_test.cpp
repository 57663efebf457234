// Codec round trips: domain record -> LCM type -> bytes -> LCM type -> domain record.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "ftid/transport/codec.hpp"
#include "test_records.hpp"

namespace ftid::transport {
namespace {

void expectSameCycleSample(const CycleRecord& a, const CycleRecord& b) {
  EXPECT_EQ(a.utime, b.utime);
  EXPECT_EQ(a.cycle, b.cycle);
  EXPECT_EQ(a.robot.recv_utime, b.robot.recv_utime);
  EXPECT_EQ(a.robot.robot_time, b.robot.robot_time);
  EXPECT_EQ(a.robot.q, b.robot.q);
  EXPECT_EQ(a.robot.qd, b.robot.qd);
  EXPECT_EQ(a.robot.qdd, b.robot.qdd);
  EXPECT_EQ(a.robot.valid, b.robot.valid);
  EXPECT_EQ(a.sensor.recv_utime, b.sensor.recv_utime);
  EXPECT_EQ(a.sensor.counter, b.sensor.counter);
  EXPECT_EQ(a.sensor.wrench_S, b.sensor.wrench_S);
  EXPECT_EQ(a.sensor.imu_acc_S, b.sensor.imu_acc_S);
  EXPECT_EQ(a.sensor.imu_w_S, b.sensor.imu_w_S);
  EXPECT_EQ(a.sensor.imu_alpha_S, b.sensor.imu_alpha_S);
  EXPECT_EQ(a.sensor.temp_degC, b.sensor.temp_degC);
  EXPECT_EQ(a.sensor.has_imu, b.sensor.has_imu);
  EXPECT_EQ(a.sensor.has_temp, b.sensor.has_temp);
  EXPECT_EQ(a.sensor.status_word, b.sensor.status_word);
  EXPECT_EQ(a.sensor.health_flags, b.sensor.health_flags);
  EXPECT_EQ(a.sensor.valid, b.sensor.valid);
  EXPECT_EQ(a.sensor_age_us, b.sensor_age_us);
  EXPECT_EQ(a.fault_bits, b.fault_bits);
}

TEST(Codec, CycleSampleRoundTripIsExact) {
  std::mt19937_64 rng(42);
  for (int i = 0; i < 50; ++i) {
    const CycleRecord in = test::randomCycleRecord(rng, i);
    ftid_lcm::cycle_sample_t msg{};
    toLcm(in, &msg);
    std::vector<std::uint8_t> buf(static_cast<std::size_t>(encodedSize(msg)));
    const int n = encodeInto(msg, buf.data(), buf.size());
    ASSERT_EQ(n, static_cast<int>(buf.size()));
    ftid_lcm::cycle_sample_t decoded{};
    ASSERT_TRUE(decodeFrom(buf.data(), buf.size(), &decoded));
    CycleRecord out;
    fromLcm(decoded, &out);
    expectSameCycleSample(in, out);
  }
}

TEST(Codec, CompensatedWrenchRoundTripIsExact) {
  std::mt19937_64 rng(7);
  const CycleRecord in = test::randomCycleRecord(rng, 12);
  ftid_lcm::compensated_wrench_t msg{};
  toLcm(in, &msg);
  std::uint8_t buf[1024];
  const int n = encodeInto(msg, buf, sizeof buf);
  ASSERT_GT(n, 0);
  ftid_lcm::compensated_wrench_t decoded{};
  ASSERT_TRUE(decodeFrom(buf, static_cast<std::size_t>(n), &decoded));
  CycleRecord out;
  fromLcm(decoded, &out);
  EXPECT_EQ(out.utime, in.utime);
  EXPECT_EQ(out.cycle, in.cycle);
  EXPECT_EQ(out.robot.robot_time, in.robot.robot_time);
  EXPECT_EQ(out.sensor.recv_utime, in.sensor.recv_utime);
  EXPECT_EQ(out.sensor_age_us, in.sensor_age_us);
  EXPECT_EQ(out.sensor.wrench_S, in.sensor.wrench_S);
  EXPECT_EQ(out.modelled_S, in.modelled_S);
  EXPECT_EQ(out.contact_S, in.contact_S);
  EXPECT_EQ(out.wrench_valid, in.wrench_valid);
  EXPECT_EQ(out.fault_bits, in.fault_bits);
  EXPECT_EQ(out.sensor.health_flags, in.sensor.health_flags);
  EXPECT_EQ(out.param_version, in.param_version);
  // Field order on the wire: raw[0] of the message is fx of the reading.
  EXPECT_EQ(msg.raw[0], in.sensor.wrench_S(0));
  EXPECT_EQ(msg.contact[5], in.contact_S(5));
}

TEST(Codec, LoopStatsRoundTripIsExact) {
  LoopStatsRecord in;
  in.utime = 123456789;
  in.uptime_s = 12.5;
  in.cycles = 1000;
  in.missed_cycles = 3;
  in.overruns = 2;
  in.compute_p50_us = 12.0;
  in.compute_p999_us = 80.5;
  in.compute_max_us = 120.25;
  in.valid_cycles = 990;
  in.invalid_cycles = 10;
  in.stale_sensor_cycles = 4;
  in.robot_clock_faults = 9;
  in.robot_clock_invalid_cycles = 11;
  in.publish_dropped = 1;
  in.published = 1999;
  in.reloads_applied = 5;
  in.reloads_failed = 1;
  in.param_version = 6;
  in.commands_refused_auth = 7;
  in.commands_refused_stale = 8;
  in.commands_refused_replay = 9;
  in.commands_refused_malformed = 10;
  in.tares_done = 11;
  in.tares_refused = 12;
  in.fault_bits = 0x48;
  in.realtime = true;
  in.robot_link_up = true;
  in.robot_reconnects = 3;
  in.robot_link_down_s = 12.5;
  in.sensor_reconnects = 2;
  ftid_lcm::loop_stats_t msg{};
  toLcm(in, &msg);
  std::uint8_t buf[512];
  const int n = encodeInto(msg, buf, sizeof buf);
  ASSERT_GT(n, 0);
  ftid_lcm::loop_stats_t decoded{};
  ASSERT_TRUE(decodeFrom(buf, static_cast<std::size_t>(n), &decoded));
  LoopStatsRecord out;
  fromLcm(decoded, &out);
  EXPECT_EQ(out.utime, in.utime);
  EXPECT_EQ(out.uptime_s, in.uptime_s);
  EXPECT_EQ(out.cycles, in.cycles);
  EXPECT_EQ(out.missed_cycles, in.missed_cycles);
  EXPECT_EQ(out.overruns, in.overruns);
  EXPECT_EQ(out.compute_p999_us, in.compute_p999_us);
  EXPECT_EQ(out.compute_max_us, in.compute_max_us);
  EXPECT_EQ(out.stale_sensor_cycles, in.stale_sensor_cycles);
  EXPECT_EQ(out.robot_clock_faults, in.robot_clock_faults);
  EXPECT_EQ(out.robot_clock_invalid_cycles, in.robot_clock_invalid_cycles);
  EXPECT_EQ(out.published, in.published);
  EXPECT_EQ(out.reloads_applied, in.reloads_applied);
  EXPECT_EQ(out.reloads_failed, in.reloads_failed);
  EXPECT_EQ(out.param_version, in.param_version);
  EXPECT_EQ(out.commands_refused_auth, in.commands_refused_auth);
  EXPECT_EQ(out.commands_refused_stale, in.commands_refused_stale);
  EXPECT_EQ(out.commands_refused_replay, in.commands_refused_replay);
  EXPECT_EQ(out.commands_refused_malformed, in.commands_refused_malformed);
  EXPECT_EQ(out.tares_done, in.tares_done);
  EXPECT_EQ(out.tares_refused, in.tares_refused);
  EXPECT_EQ(out.fault_bits, in.fault_bits);
  EXPECT_EQ(out.realtime, in.realtime);
  EXPECT_EQ(out.robot_link_up, in.robot_link_up);
  EXPECT_EQ(out.robot_reconnects, in.robot_reconnects);
  EXPECT_EQ(out.robot_link_down_s, in.robot_link_down_s);
  EXPECT_EQ(out.sensor_reconnects, in.sensor_reconnects);
}

TEST(Codec, EncodeIntoTooSmallBufferFails) {
  ftid_lcm::cycle_sample_t msg{};
  std::uint8_t buf[16];
  EXPECT_LT(encodeInto(msg, buf, sizeof buf), 0);
}

TEST(Codec, DecodeRejectsOtherTypeAndShortBuffer) {
  ftid_lcm::loop_stats_t stats{};
  std::uint8_t buf[512];
  const int n = encodeInto(stats, buf, sizeof buf);
  ASSERT_GT(n, 0);
  ftid_lcm::cycle_sample_t cycle{};
  EXPECT_FALSE(decodeFrom(buf, static_cast<std::size_t>(n), &cycle));  // fingerprint differs
  ftid_lcm::loop_stats_t again{};
  EXPECT_FALSE(decodeFrom(buf, static_cast<std::size_t>(n) - 1, &again));
}

}  // namespace
}  // namespace ftid::transport
