// Multi-process LCM over udpm inside a private network namespace (never in the default one):
// the LcmOutbox publishes from one process, `lcm-logger` (LCM's own tool, an independent
// subscriber) records in another, and the recorded log is decoded here.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <string>

#include "ftid/transport/codec.hpp"
#include "ftid/transport/lcm_log.hpp"
#include "test_paths.hpp"

namespace ftid::transport {
namespace {

bool commandWorks(const std::string& cmd) { return std::system((cmd + " >/dev/null 2>&1").c_str()) == 0; }

TEST(UdpmNetns, OutboxToLcmLoggerInAnotherProcess) {
  if (!commandWorks("command -v lcm-logger")) GTEST_SKIP() << "lcm-logger (liblcm-bin) not installed";
  if (!commandWorks("command -v ip")) GTEST_SKIP() << "ip (iproute2) not installed";
  if (!commandWorks("unshare -rn true")) {
    GTEST_SKIP() << "unshare -rn is not permitted here (user namespaces disabled?): the udpm test "
                    "only runs inside a private network namespace";
  }
  const std::string log = ::testing::TempDir() + "ftid_udpm_" + std::to_string(::getpid()) + ".lcm";
  std::remove(log.c_str());
  const std::string url = "udpm://239.255.76.67:7667?ttl=0";
  const std::string script =
      "ip link set lo up && ip route add 224.0.0.0/4 dev lo && "
      "{ lcm-logger --quiet --force --lcm-url='" + url + "' --channel='FTID_.*' '" + log + "' & LOGGER=\\$!; "
      "sleep 3; '" + ftid::test::binaryPath(FTID_UDPM_PUBLISHER) + "' '" + url + "' 100; RC=\\$?; sleep 0.5; "
      "kill -INT \\$LOGGER; wait \\$LOGGER; exit \\$RC; }";
  const std::string cmd = "unshare -rn sh -c \"" + script + "\"";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;

  LcmLogReader reader(log);
  LcmLogEvent ev;
  int cycles = 0, wrenches = 0;
  std::int64_t next_cycle = 0;
  while (reader.next(&ev)) {
    if (ev.channel == "FTID_CYCLE") {
      ftid_lcm::cycle_sample_t m{};
      ASSERT_TRUE(decodeFrom(ev.data.data(), ev.data.size(), &m));
      EXPECT_EQ(m.cycle, next_cycle++);
      ++cycles;
    } else if (ev.channel == "FTID_WRENCH") {
      ftid_lcm::compensated_wrench_t m{};
      ASSERT_TRUE(decodeFrom(ev.data.data(), ev.data.size(), &m));
      ++wrenches;
    }
  }
  EXPECT_EQ(cycles, 100);
  EXPECT_EQ(wrenches, 100);
  std::remove(log.c_str());
}

}  // namespace
}  // namespace ftid::transport
