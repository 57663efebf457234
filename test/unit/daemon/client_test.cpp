// DaemonClient (ftid/daemon/client.hpp), the one sender of ftidd's commands: the options follow
// an ftidd configuration, and every way of not getting an answer ends in a named reason, never an
// exception (no key, unreadable key, no ftidd). The exchange with a running ftidd is covered by
// the cell test (ftid --identify's reload) and the commands integration test.
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <string>

#include "ftid/config/daemon_config.hpp"
#include "ftid/daemon/client.hpp"

namespace ftid::daemon {
namespace {

std::string tempPath(const std::string& name) {
  return ::testing::TempDir() + "ftid_client_" + std::to_string(::getpid()) + "_" + name;
}

TEST(DaemonClient, OptionsFollowTheDaemonConfiguration) {
  config::DaemonConfig cfg;
  cfg.lcm.url = "memq://";
  cfg.lcm.channels.command = "MY_COMMAND";
  cfg.lcm.channels.ack = "MY_ACK";
  cfg.lcm.command_key_path = "/etc/x.key";
  const DaemonClientOptions o = DaemonClientOptions::fromConfig(cfg);
  EXPECT_EQ(o.lcm_url, "memq://");
  EXPECT_EQ(o.command_channel, "MY_COMMAND");
  EXPECT_EQ(o.ack_channel, "MY_ACK");
  EXPECT_EQ(o.key_path, "/etc/x.key");
  EXPECT_STREQ(daemonCommandName(DaemonCommand::kReloadParameters), "RELOAD_PARAMETERS");
  EXPECT_STREQ(daemonCommandName(DaemonCommand::kPing), "PING");
  EXPECT_STREQ(daemonCommandName(DaemonCommand::kTare), "TARE");
}

TEST(DaemonClient, WithoutAReadableKeyNothingIsSentAndTheReasonNamesTheKey) {
  DaemonClientOptions o;
  o.lcm_url = "memq://";
  o.key_path = tempPath("missing.key");
  DaemonClient client(o);
  const CommandAck a = client.sendCommand(DaemonCommand::kTare, 0.2);
  EXPECT_FALSE(a.answered);
  EXPECT_FALSE(a.ok);
  EXPECT_NE(a.describe().find("cannot sign the TARE command"), std::string::npos) << a.describe();
  EXPECT_NE(a.describe().find(o.key_path), std::string::npos) << a.describe();

  // A key others may read is refused the same way (transport::loadCommandKey's rule).
  const std::string open_key = tempPath("open.key");
  std::ofstream(open_key) << std::string(64, 'a') << "\n";
  ::chmod(open_key.c_str(), 0644);
  o.key_path = open_key;
  DaemonClient client2(o);
  const CommandAck b = client2.sendCommand(DaemonCommand::kPing, 0.2);
  EXPECT_FALSE(b.answered);
  EXPECT_NE(b.describe().find("cannot sign the PING command"), std::string::npos) << b.describe();
  ::unlink(open_key.c_str());
}

TEST(DaemonClient, NoDaemonMeansNoAckWithinTheTimeout) {
  const std::string key = tempPath("good.key");
  std::ofstream(key) << std::string(64, 'b') << "\n";
  ::chmod(key.c_str(), 0600);
  DaemonClientOptions o;
  o.lcm_url = "memq://";  // nobody else on it: no ftidd
  o.key_path = key;
  o.resend_period_s = 0.05;
  DaemonClient client(o);
  const auto t0 = std::chrono::steady_clock::now();
  const CommandAck a = client.sendCommand(DaemonCommand::kReloadParameters, 0.3);
  const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_FALSE(a.answered);
  EXPECT_FALSE(a.ok);
  EXPECT_EQ(a.describe(), "ftidd did not acknowledge the RELOAD_PARAMETERS within 0.3 s (is it running?)");
  EXPECT_GE(took, 0.3);
  EXPECT_LT(took, 2.0);
  EXPECT_NE(a.request_id, 0);
  // The client is reusable: a second command gets its own request id.
  const CommandAck b = client.sendCommand(DaemonCommand::kPing, 0.1);
  EXPECT_NE(b.request_id, a.request_id);
  ::unlink(key.c_str());
}

}  // namespace
}  // namespace ftid::daemon
