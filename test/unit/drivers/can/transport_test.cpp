// Transports: SOCK_SEQPACKET stand-in (server/client and socketpair) with kernel receive
// timestamps, the sensor object over it, and SocketCAN where the kernel has AF_CAN.
#include <gtest/gtest.h>
#include <unistd.h>

#include <array>
#include <cstdlib>
#include <cstring>
#include <net/if.h>
#include <string>
#include <thread>

#include "ftid/common/error.hpp"
#include "ftid/drivers/can/ft_imu_sensor.hpp"
#include "ftid/drivers/can/seqpacket.hpp"
#include "ftid/drivers/can/socketcan.hpp"
#include "test_paths.hpp"

namespace ftid::drivers::can {
namespace {

std::string tempSocketPath(const char* tag) {
  return "/tmp/ftid-can-test-" + std::to_string(getpid()) + "-" + tag + ".sock";
}

can_frame makeFrame(std::uint32_t id, std::uint8_t len, std::uint8_t fill) {
  can_frame f{};
  f.can_id = id;
  f.len = len;
  for (int i = 0; i < len; ++i) f.data[i] = static_cast<std::uint8_t>(fill + i);
  return f;
}

TEST(Seqpacket, ServerBroadcastsFramesWithKernelTimestamps) {
  const std::string path = tempSocketPath("bcast");
  SeqpacketCanServer server(path);
  SeqpacketCanClient c1(path);
  SeqpacketCanClient c2(path);
  EXPECT_EQ(server.acceptPending(), 2);
  ReceivedFrame rf;
  EXPECT_EQ(c1.tryReceive(rf), IoResult::kWouldBlock);  // nothing yet, does not block

  const std::int64_t before = realtimeNowNs();
  for (std::uint8_t k = 0; k < 50; ++k) {
    ASSERT_EQ(server.trySend(makeFrame(k % 2 ? (0x12345u | CAN_EFF_FLAG) : 0x1A0u, 8, k)),
              IoResult::kOk);
  }
  const std::int64_t after = realtimeNowNs();
  for (SeqpacketCanClient* c : {&c1, &c2}) {
    ASSERT_TRUE(c->waitReadable(std::chrono::milliseconds(1000)));
    std::int64_t last_ts = 0;
    for (std::uint8_t k = 0; k < 50; ++k) {
      ASSERT_EQ(c->tryReceive(rf), IoResult::kOk) << int(k);
      const can_frame expected = makeFrame(k % 2 ? (0x12345u | CAN_EFF_FLAG) : 0x1A0u, 8, k);
      EXPECT_EQ(std::memcmp(&rf.frame, &expected, sizeof expected), 0);
      // The timestamp is the kernel's (taken when the frame was queued): between the two clocks
      // read around the sends, non-decreasing.
      EXPECT_GE(rf.rx_time_ns, before - 1000);
      EXPECT_LE(rf.rx_time_ns, after + 1000);
      EXPECT_GE(rf.rx_time_ns, last_ts);
      last_ts = rf.rx_time_ns;
    }
    EXPECT_EQ(c->tryReceive(rf), IoResult::kWouldBlock);
  }
  // Client -> server direction.
  ASSERT_EQ(c1.trySend(makeFrame(0x7FF, 2, 9)), IoResult::kOk);
  bool got = false;
  for (int i = 0; i < 100 && !got; ++i) {
    got = server.tryReceive(rf) == IoResult::kOk;
    if (!got) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_TRUE(got);
  EXPECT_EQ(rf.frame.can_id, 0x7FFu);
  EXPECT_EQ(rf.frame.len, 2);
}

TEST(Seqpacket, ClientSeesServerGoAwayAndReconnects) {
  const std::string path = tempSocketPath("gone");
  auto server = std::make_unique<SeqpacketCanServer>(path);
  SeqpacketCanClient client(path);
  server->acceptPending();
  server.reset();  // closes and unlinks
  ReceivedFrame rf;
  EXPECT_EQ(client.tryReceive(rf), IoResult::kClosed);
  EXPECT_FALSE(client.reconnect());
  server = std::make_unique<SeqpacketCanServer>(path);
  EXPECT_TRUE(client.reconnect());
  server->trySend(makeFrame(0x100, 1, 1));
  ASSERT_TRUE(client.waitReadable(std::chrono::milliseconds(1000)));
  EXPECT_EQ(client.tryReceive(rf), IoResult::kOk);
}

TEST(Seqpacket, ErrorsNameThePath) {
  try {
    SeqpacketCanClient c("/tmp/ftid-no-such-socket-xyz.sock");
    FAIL();
  } catch (const DriverError& e) {
    EXPECT_NE(std::string(e.what()).find("/tmp/ftid-no-such-socket-xyz.sock"), std::string::npos);
  }
  const std::string path = tempSocketPath("busy");
  SeqpacketCanServer first(path);
  EXPECT_THROW(SeqpacketCanServer second(path), DriverError);  // someone serves it already
  EXPECT_THROW(SeqpacketCanServer longpath(std::string(200, 'x')), ConfigError);
}

TEST(Seqpacket, SocketpairKeepsFrameBoundaries) {
  auto pair = makeSeqpacketPair();
  for (std::uint8_t len = 0; len <= 8; ++len) {
    ASSERT_EQ(pair.a->trySend(makeFrame(0x100 + len, len, len)), IoResult::kOk);
  }
  ReceivedFrame rf;
  for (std::uint8_t len = 0; len <= 8; ++len) {
    ASSERT_EQ(pair.b->tryReceive(rf), IoResult::kOk);
    EXPECT_EQ(rf.frame.can_id, 0x100u + len);
    EXPECT_EQ(rf.frame.len, len);
  }
  EXPECT_EQ(pair.b->tryReceive(rf), IoResult::kWouldBlock);
  pair.a.reset();
  EXPECT_EQ(pair.b->tryReceive(rf), IoResult::kClosed);
}

TEST(Seqpacket, BatchReceiveKeepsOrderTimestampsAndSeesClose) {
  auto pair = makeSeqpacketPair();
  for (std::uint32_t k = 0; k < 100; ++k) ASSERT_EQ(pair.a->trySend(makeFrame(k, 8, 0)), IoResult::kOk);
  std::array<ReceivedFrame, 64> batch{};
  IoResult status = IoResult::kError;
  int n = pair.b->tryReceiveBatch(batch.data(), 64, status);
  ASSERT_EQ(n, 64);
  EXPECT_EQ(status, IoResult::kOk);
  for (int i = 0; i < n; ++i) {
    EXPECT_EQ(batch[static_cast<std::size_t>(i)].frame.can_id, static_cast<canid_t>(i));
    if (i > 0) {
      EXPECT_GE(batch[static_cast<std::size_t>(i)].rx_time_ns,
                batch[static_cast<std::size_t>(i - 1)].rx_time_ns);
    }
  }
  n = pair.b->tryReceiveBatch(batch.data(), 64, status);
  ASSERT_EQ(n, 36);
  EXPECT_EQ(status, IoResult::kWouldBlock);
  EXPECT_EQ(batch[35].frame.can_id, 99u);
  EXPECT_GT(batch[35].rx_time_ns, 0);
  n = pair.b->tryReceiveBatch(batch.data(), 64, status);
  EXPECT_EQ(n, 0);
  EXPECT_EQ(status, IoResult::kWouldBlock);
  pair.a->trySend(makeFrame(7, 1, 0));
  pair.a.reset();
  n = pair.b->tryReceiveBatch(batch.data(), 64, status);
  EXPECT_EQ(n, 1);  // the frame sent before the close, then end of stream
  EXPECT_EQ(status, IoResult::kClosed);
}

TEST(CanFtImuSensor, DrainsToLatestOverTheStandIn) {
  const SensorLayout layout =
      SensorLayout::fromDbc(loadDbc(ftid::test::sourcePath("/config/ftsensor.dbc")));
  auto pair = makeSeqpacketPair();
  CanTransport& bus = *pair.a;
  CanFtImuSensor sensor(std::move(pair.b), layout);
  SensorSample s;
  EXPECT_EQ(sensor.tryReadLatest(s), Status::kStale);  // nothing yet
  EXPECT_TRUE(s.health_flags & kHealthNoData);
  std::array<can_frame, SensorLayout::kMaxMessages> f{};
  SensorValues v;
  for (std::uint32_t c = 0; c < 20; ++c) {
    v.wrench_S[2] = -10.0 - c;
    const int n = encodeSample(layout, v, c, f);
    for (int i = 0; i < n; ++i) ASSERT_EQ(bus.trySend(f[static_cast<std::size_t>(i)]), IoResult::kOk);
  }
  EXPECT_EQ(sensor.tryReadLatest(s), Status::kOk);
  EXPECT_TRUE(s.fresh);
  EXPECT_EQ(s.counter, 19u);
  EXPECT_NEAR(s.wrench_S[2], -29.0, 0.03);
  EXPECT_EQ(sensor.health().samples_complete, 20u);
  EXPECT_EQ(sensor.health().frames_received, 120u);
  EXPECT_LE(std::llabs(realtimeNowNs() - s.rx_time_ns), 1'000'000'000);
  // Peer gone: transport fault, never valid.
  pair.a.reset();
  EXPECT_EQ(sensor.tryReadLatest(s), Status::kFault);
  EXPECT_FALSE(s.valid);
  EXPECT_TRUE(s.health_flags & kHealthTransportDown);
}

TEST(CanSensorConfig, EndpointErrors) {
  EXPECT_THROW(openCanTransport("bogus"), ConfigError);
  EXPECT_THROW(openCanTransport("udp:1.2.3.4"), ConfigError);
  CanSensorConfig cfg;
  cfg.dbc_path = "/nonexistent.dbc";
  EXPECT_THROW(openCanSensor(cfg), DataError);
}

// SocketCAN: needs a kernel with AF_CAN and a (v)can interface (FTID_TEST_CAN_IFACE, default
// vcan0: `modprobe vcan; ip link add vcan0 type vcan; ip link set vcan0 up`).
TEST(SocketCan, RoundTripOnVirtualInterface) {
  std::string why;
  if (!socketCanAvailable(&why)) GTEST_SKIP() << "SocketCAN unavailable: " << why;
  const char* env = std::getenv("FTID_TEST_CAN_IFACE");
  const std::string iface = env != nullptr ? env : "vcan0";
  if (if_nametoindex(iface.c_str()) == 0)
    GTEST_SKIP() << "AF_CAN exists but there is no interface '" << iface
                 << "' (set FTID_TEST_CAN_IFACE or create vcan0)";
  SocketCanOptions rx_opts;
  rx_opts.interface = iface;
  can_filter flt{};
  flt.can_id = 0x1A0;
  flt.can_mask = 0x7F8 | CAN_EFF_FLAG | CAN_RTR_FLAG;  // 0x1A0..0x1A7 standard data frames
  rx_opts.filters.push_back(flt);
  SocketCanTransport rx(rx_opts);
  SocketCanOptions tx_opts;
  tx_opts.interface = iface;
  SocketCanTransport tx(tx_opts);
  const std::int64_t before = realtimeNowNs();
  ASSERT_EQ(tx.trySend(makeFrame(0x300, 8, 1)), IoResult::kOk);  // filtered out
  ASSERT_EQ(tx.trySend(makeFrame(0x1A3, 8, 7)), IoResult::kOk);
  ASSERT_TRUE(rx.waitReadable(std::chrono::milliseconds(1000)));
  ReceivedFrame rf;
  ASSERT_EQ(rx.tryReceive(rf), IoResult::kOk);
  EXPECT_EQ(rf.frame.can_id, 0x1A3u);
  EXPECT_EQ(rf.frame.data[0], 7);
  EXPECT_GE(rf.rx_time_ns, before - 1000);
  EXPECT_EQ(rx.tryReceive(rf), IoResult::kWouldBlock);
}

TEST(SocketCan, ConstructorExplainsMissingSupport) {
  std::string why;
  if (socketCanAvailable(&why)) GTEST_SKIP() << "AF_CAN is available here";
  SocketCanOptions o;
  try {
    SocketCanTransport t(o);
    FAIL();
  } catch (const DriverError& e) {
    EXPECT_NE(std::string(e.what()).find("seqpacket"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ftid::drivers::can
