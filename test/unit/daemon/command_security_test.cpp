// Issue 14, "The command and data channels": a reload never blocks on a FIFO or a pipe given as
// the parameter file, RELOAD_PARAMETERS takes no path, and bad, stale or replayed commands are
// refused and counted.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <string>

#include "ftid/daemon/adapters.hpp"
#include "ftid/daemon/daemon.hpp"
#include "ftid/daemon/reloader.hpp"
#include "ftid/transport/command_auth.hpp"
#include "ftid_lcm/command_t.hpp"

namespace ftid::daemon {
namespace {

std::string scratch(const std::string& name) {
  return ::testing::TempDir() + "ftid_cmdsec_" + std::to_string(::getpid()) + "_" + name;
}

TEST(ReloadSafety, FifoAndPipeAreRefusedWithoutBlocking) {
  const std::string fifo = scratch("params.fifo");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  int pipe_fds[2];
  ASSERT_EQ(::pipe(pipe_fds), 0);
  const std::string proc_pipe = "/proc/self/fd/" + std::to_string(pipe_fds[0]);

  // The production factory, as ftidd uses it: reading a FIFO with no writer would block forever.
  rt::OwnedSwapSlot<Compensation> slot;
  ParameterReloader reloader(&slot, parameterFileFactory());
  for (const std::string& path : {fifo, proc_pipe, ::testing::TempDir()}) {
    const auto t0 = std::chrono::steady_clock::now();
    const ReloadResult r = reloader.reload(path, std::chrono::milliseconds(0));
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    EXPECT_FALSE(r.ok) << path;
    EXPECT_LT(s, 0.5) << path;
    EXPECT_NE(r.message.find("not a regular file"), std::string::npos) << r.message;
    EXPECT_NE(r.message.find(path), std::string::npos) << r.message;
  }
  EXPECT_EQ(reloader.failed(), 3u);
  EXPECT_NE(regularFileProblem(fifo).find("a FIFO"), std::string::npos);
  EXPECT_NE(regularFileProblem(::testing::TempDir()).find("a directory"), std::string::npos);
  EXPECT_NE(regularFileProblem(scratch("missing")).find("cannot open"), std::string::npos);
  ::close(pipe_fds[0]);
  ::close(pipe_fds[1]);
  ::unlink(fifo.c_str());
}

transport::CommandKey key() {
  transport::CommandKey k;
  k.bytes.assign(32, 0x42);
  return k;
}

ftid_lcm::command_t command(std::int8_t type, const std::string& argument = "") {
  ftid_lcm::command_t c{};
  c.utime = transport::realtimeUs();
  c.request_id = 99;
  c.command = type;
  c.argument = argument;
  return c;
}

TEST(CommandChecks, RefusesPathsBadStaleAndReplayedCommandsAndCountsThem) {
  transport::CommandVerifier verifier(key(), transport::realtimeUs() - 1000);
  CommandCounters counters;

  auto ok = command(ftid_lcm::command_t::RELOAD_PARAMETERS);
  transport::signCommand(&ok, key());
  EXPECT_EQ(checkCommand(ok, &verifier, &counters), "");

  // The attack from the issue: RELOAD naming the previous tool's file, even correctly signed.
  auto with_path = command(ftid_lcm::command_t::RELOAD_PARAMETERS, "/var/lib/ftid/parameters.yaml.bak");
  transport::signCommand(&with_path, key(), ok.sequence + 1);
  const std::string r1 = checkCommand(with_path, &verifier, &counters);
  EXPECT_NE(r1.find("takes no path"), std::string::npos) << r1;
  EXPECT_EQ(counters.malformed, 1);

  auto unsigned_cmd = command(ftid_lcm::command_t::RELOAD_PARAMETERS);
  EXPECT_NE(checkCommand(unsigned_cmd, &verifier, &counters).find("bad authenticator"), std::string::npos);
  EXPECT_EQ(counters.auth, 1);

  EXPECT_NE(checkCommand(ok, &verifier, &counters).find("replayed"), std::string::npos);  // same datagram
  EXPECT_EQ(counters.replay, 1);

  auto old = command(ftid_lcm::command_t::PING);
  transport::signCommand(&old, key(), transport::realtimeUs() - 120'000'000);
  EXPECT_NE(checkCommand(old, &verifier, &counters).find("stale"), std::string::npos);
  EXPECT_EQ(counters.stale, 1);

  transport::CommandVerifier keyless(transport::CommandKey{}, transport::realtimeUs() - 1000);
  auto signed_ping = command(ftid_lcm::command_t::PING);
  transport::signCommand(&signed_ping, key());
  EXPECT_NE(checkCommand(signed_ping, &keyless, &counters).find("no command key"), std::string::npos);
  EXPECT_EQ(counters.auth, 2);
}

TEST(CommandChecks, TareTakesNoArgument) {
  transport::CommandVerifier verifier(key(), transport::realtimeUs() - 1000);
  CommandCounters counters;
  auto with_arg = command(ftid_lcm::command_t::TARE, "0.5");
  transport::signCommand(&with_arg, key());
  const std::string r = checkCommand(with_arg, &verifier, &counters);
  EXPECT_NE(r.find("TARE takes no argument"), std::string::npos) << r;
  EXPECT_EQ(counters.malformed, 1);
  auto plain = command(ftid_lcm::command_t::TARE);
  transport::signCommand(&plain, key(), with_arg.sequence + 1);
  EXPECT_EQ(checkCommand(plain, &verifier, &counters), "");
}

TEST(CommandChecks, ReidentifyTakesNothingOrApply) {
  transport::CommandVerifier verifier(key(), transport::realtimeUs() - 1000);
  CommandCounters counters;
  auto bad = command(ftid_lcm::command_t::REIDENTIFY, "/etc/passwd");
  transport::signCommand(&bad, key());
  const std::string r = checkCommand(bad, &verifier, &counters);
  EXPECT_NE(r.find("REIDENTIFY takes no argument or \"apply\""), std::string::npos) << r;
  EXPECT_EQ(counters.malformed, 1);
  auto apply = command(ftid_lcm::command_t::REIDENTIFY, "apply");
  transport::signCommand(&apply, key(), bad.sequence + 1);
  EXPECT_EQ(checkCommand(apply, &verifier, &counters), "");
  auto plain = command(ftid_lcm::command_t::REIDENTIFY);
  transport::signCommand(&plain, key(), apply.sequence + 1);
  EXPECT_EQ(checkCommand(plain, &verifier, &counters), "");
}

}  // namespace
}  // namespace ftid::daemon
