// DaemonClient (ftid/daemon/client.hpp), the one sender of ftidd's commands: the options follow
// an ftidd configuration, and every way of not getting an answer ends in a named reason, never an
// exception (no key, unreadable key, no ftidd), "not sent" is told from "sent, no answer", a TARE
// is published once and never resent (a resend would be a second tare) while PING/RELOAD resend,
// and the ack's offsets reach the caller (against a fake ftidd on a private udpm port). The
// exchange with a running ftidd is covered by the cell test (ftid --identify's reload) and the
// commands integration test (`ftid tare`).
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "ftid/config/daemon_config.hpp"
#include "ftid/daemon/client.hpp"
#include <ftid_lcm/ack_t.hpp>
#include <ftid_lcm/command_t.hpp>

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
  EXPECT_FALSE(a.sent);
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
  EXPECT_TRUE(a.sent);
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

std::string writeKey(const std::string& name) {
  const std::string key = tempPath(name);
  std::ofstream(key) << std::string(64, 'c') << "\n";
  ::chmod(key.c_str(), 0600);
  return key;
}

TEST(DaemonClient, AnLcmThatCannotBeOpenedMeansNothingSent) {
  const std::string key = writeKey("lcm.key");
  DaemonClientOptions o;
  o.lcm_url = "nosuchprovider://";
  o.key_path = key;
  DaemonClient client(o);
  const CommandAck a = client.sendCommand(DaemonCommand::kTare, 0.2);
  EXPECT_FALSE(a.sent);
  EXPECT_FALSE(a.answered);
  EXPECT_NE(a.describe().find("LCM: cannot open 'nosuchprovider://'"), std::string::npos) << a.describe();
  ::unlink(key.c_str());
}

// DaemonClientOverLcm.*: the client against a fake ftidd over real LCM udpm in this process.
// They run in the AddressSanitizer + UBSan build too. This file and src/daemon/client.cpp use LCM's
// member-function subscription, whose handler call `(subs->handler->*subs->handlerMethod)(...)`
// (lcm-cpp-impl.hpp, cb_func) GCC 12 instruments wrongly under -fsanitize=vptr: the check reads an
// uninitialised register and reports "member access within address ... which does not point to
// an object of type 'LCMMHUntypedSubscription' ... invalid vptr" (or crashes) although the object
// is valid. Reproducer: 12 lines of LCM's C++ API (one lcm::LCM, subscribe(&H::on, &h), publish,
// handleTimeout) fail under g++ -fsanitize=vptr and pass under g++ -fsanitize=address,undefined
// -fno-sanitize=vptr and clang++-14 -fsanitize=undefined; test/unit/transport/gcc_vptr_pmf_repro.cpp
// shows it without LCM. So these files are built with -fno-sanitize=vptr only (cmake/FtidDefaults.cmake,
// FTID_GCC_VPTR_PMF_SOURCES) and keep ASan and every other UBSan check (docs/testing.md "Sanitizers").
// A fake ftidd on a private udpm port (this process's id: no other test hears it): counts the
// commands it receives per kind and, if `answer`, acks each with fixed offsets.
class FakeDaemon {
 public:
  // poison: before the real ack, send the issue-26 ack with the same request id whose message
  // length field is 0 (82 bytes; lcm-gen's decoder throws std::length_error on it).
  FakeDaemon(const std::string& url, bool answer, bool poison = false)
      : lc_(url), answer_(answer), poison_(poison) {
    lc_.subscribe("T_COMMAND", &FakeDaemon::handle, this);
    (void)lc_.getFileno();  // the receive socket exists before the client sends
    thread_ = std::thread([this] {
      while (!stop_) lc_.handleTimeout(20);
    });
  }
  ~FakeDaemon() {
    stop_ = true;
    thread_.join();
  }
  bool good() { return lc_.good(); }
  int count(DaemonCommand c) {
    std::lock_guard<std::mutex> lock(mutex_);
    return counts_[static_cast<int>(c)];
  }

 private:
  void handle(const lcm::ReceiveBuffer* rbuf, const std::string&) {
    ftid_lcm::command_t cmd;
    if (cmd.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) < 0) return;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (cmd.command >= 0 && cmd.command < 4) ++counts_[cmd.command];
    }
    if (!answer_) return;
    if (poison_) {
      std::vector<std::uint8_t> bad;
      auto put = [&bad](std::uint64_t v, int n) {
        for (int i = n - 1; i >= 0; --i) bad.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
      };
      put(static_cast<std::uint64_t>(ftid_lcm::ack_t::getHash()), 8);
      put(0, 8);                                             // utime
      put(static_cast<std::uint64_t>(cmd.request_id), 8);    // the request id the client waits for
      put(static_cast<std::uint64_t>(cmd.command), 1);
      put(1, 1);   // ok
      put(99, 4);  // param_version
      put(0, 4);   // message length 0
      bad.insert(bad.end(), 48, 0);
      lc_.publish("T_ACK", bad.data(), static_cast<unsigned>(bad.size()));
    }
    ftid_lcm::ack_t ack{};
    ack.request_id = cmd.request_id;
    ack.command = cmd.command;
    ack.ok = true;
    ack.param_version = 7;
    ack.message = "tared";
    for (int i = 0; i < 6; ++i) ack.offsets[i] = 0.5 * (i + 1);
    lc_.publish("T_ACK", &ack);
  }
  lcm::LCM lc_;
  bool answer_;
  bool poison_;
  std::atomic<bool> stop_{false};
  std::mutex mutex_;
  int counts_[4] = {0, 0, 0, 0};
  std::thread thread_;
};

DaemonClientOptions privateOptions(const std::string& key) {
  DaemonClientOptions o;
  o.lcm_url = "udpm://239.255.76.67:" + std::to_string(20000 + ::getpid() % 30000) + "?ttl=0";
  o.command_channel = "T_COMMAND";
  o.ack_channel = "T_ACK";
  o.key_path = key;
  o.resend_period_s = 0.05;
  return o;
}

TEST(DaemonClientOverLcm, ATareIsPublishedOnceWhilePingIsResent) {
  const std::string key = writeKey("once.key");
  const DaemonClientOptions o = privateOptions(key);
  FakeDaemon daemon(o.lcm_url, /*answer=*/false);
  if (!daemon.good()) GTEST_SKIP() << "no udpm multicast here (" << o.lcm_url << ")";
  DaemonClient client(o);
  EXPECT_FALSE(resendsUnanswered(DaemonCommand::kTare));
  EXPECT_TRUE(resendsUnanswered(DaemonCommand::kPing));
  EXPECT_TRUE(resendsUnanswered(DaemonCommand::kReloadParameters));
  const CommandAck tare = client.sendCommand(DaemonCommand::kTare, 0.4);
  EXPECT_TRUE(tare.sent);
  EXPECT_FALSE(tare.answered);
  const CommandAck ping = client.sendCommand(DaemonCommand::kPing, 0.4);
  EXPECT_TRUE(ping.sent);
  EXPECT_FALSE(ping.answered);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // the fake drains its socket
  // Resent every 0.05 s for 0.4 s: the PING arrives several times (so the fake hears resends),
  // the unanswered TARE exactly once.
  EXPECT_GE(daemon.count(DaemonCommand::kPing), 3);
  EXPECT_EQ(daemon.count(DaemonCommand::kTare), 1);
  ::unlink(key.c_str());
}

TEST(DaemonClientOverLcm, TheAckOffsetsReachTheCaller) {
  const std::string key = writeKey("offsets.key");
  const DaemonClientOptions o = privateOptions(key);
  FakeDaemon daemon(o.lcm_url, /*answer=*/true);
  if (!daemon.good()) GTEST_SKIP() << "no udpm multicast here (" << o.lcm_url << ")";
  DaemonClient client(o);
  const CommandAck a = client.sendCommand(DaemonCommand::kTare, 2.0);
  ASSERT_TRUE(a.answered) << a.describe();
  EXPECT_TRUE(a.sent);
  EXPECT_TRUE(a.ok);
  EXPECT_EQ(a.describe(), "");
  EXPECT_EQ(a.message, "tared");
  EXPECT_EQ(a.param_version, 7);
  for (int i = 0; i < 6; ++i) EXPECT_DOUBLE_EQ(a.offsets[static_cast<std::size_t>(i)], 0.5 * (i + 1));
  EXPECT_EQ(daemon.count(DaemonCommand::kTare), 1);
  ::unlink(key.c_str());
}

// Issue 26: an ack whose message length is 0 (sent before the real one, with the request id
// the client waits for) is dropped; `ftid tare` and --identify's reload then get the real
// answer. Before the fix the decoder's std::length_error escaped sendCommand (ftid tare exit 1,
// --identify reporting failure after it had loaded the new parameters).
TEST(DaemonClientOverLcm, AMalformedAckIsDroppedAndTheRealOneCounts) {
  const std::string key = writeKey("poison.key");
  const DaemonClientOptions o = privateOptions(key);
  FakeDaemon daemon(o.lcm_url, /*answer=*/true, /*poison=*/true);
  if (!daemon.good()) GTEST_SKIP() << "no udpm multicast here (" << o.lcm_url << ")";
  DaemonClient client(o);
  for (const DaemonCommand c : {DaemonCommand::kTare, DaemonCommand::kReloadParameters}) {
    CommandAck a;
    EXPECT_NO_THROW(a = client.sendCommand(c, 2.0));
    ASSERT_TRUE(a.answered) << a.describe();
    EXPECT_TRUE(a.ok);
    EXPECT_EQ(a.message, "tared");
    EXPECT_EQ(a.param_version, 7);  // the real ack's, not the malformed one's 99
  }
  ::unlink(key.c_str());
}

}  // namespace
}  // namespace ftid::daemon
