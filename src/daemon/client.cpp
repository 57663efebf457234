#include "ftid/daemon/client.hpp"

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <lcm/lcm-cpp.hpp>

#include "ftid/config/daemon_config.hpp"
#include "ftid/transport/codec.hpp"
#include "ftid/transport/command_auth.hpp"
#include "ftid/transport/source_filter.hpp"
#include <ftid_lcm/ack_t.hpp>
#include <ftid_lcm/command_t.hpp>

namespace ftid::daemon {

namespace {

std::string seconds(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f", s);
  return buf;
}

// Collects the ack with one request id. Anyone on the network can send on the ack channel: the
// bytes go through transport::decodeFrom (a string length of 0 made lcm-gen's decoder throw
// std::length_error through LCM's callback, ending `ftid tare` and `--identify`'s reload, issue
// 26); a malformed ack is dropped and counted, and the wait goes on for the real one.
struct AckWaiter {
  std::int64_t request_id = 0;
  bool got = false;
  int malformed = 0;
  ftid_lcm::ack_t ack;
  void handle(const lcm::ReceiveBuffer* rbuf, const std::string& /*channel*/) noexcept {
    ftid_lcm::ack_t a;
    if (!transport::decodeFrom(rbuf->data, rbuf->data_size, &a)) {
      ++malformed;
      return;
    }
    if (a.request_id != request_id) return;
    try {
      ack = a;
    } catch (...) {  // std::bad_alloc copying the message: not an answer we can use
      return;
    }
    got = true;
  }
};

}  // namespace

const char* daemonCommandName(DaemonCommand command) noexcept {
  switch (command) {
    case DaemonCommand::kReloadParameters: return "RELOAD_PARAMETERS";
    case DaemonCommand::kPing: return "PING";
    case DaemonCommand::kTare: return "TARE";
    case DaemonCommand::kReidentify: return "REIDENTIFY";
  }
  return "?";
}

bool resendsUnanswered(DaemonCommand command) noexcept {
  return command != DaemonCommand::kTare && command != DaemonCommand::kReidentify;
}

DaemonClientOptions DaemonClientOptions::fromConfig(const config::DaemonConfig& config) {
  DaemonClientOptions o;
  o.lcm_url = config.lcm.url;
  o.command_channel = config.lcm.channels.command;
  o.ack_channel = config.lcm.channels.ack;
  o.key_path = config.lcm.command_key_path;
  return o;
}

std::string CommandAck::describe() const {
  if (ok) return {};
  if (answered) return std::string("ftidd refused the ") + daemonCommandName(command) + ": " + message;
  return message;
}

struct DaemonClient::Lcm {
  explicit Lcm(const std::string& url) : lc(url) {}
  lcm::LCM lc;
};

DaemonClient::DaemonClient(DaemonClientOptions options) : options_(std::move(options)) {}
DaemonClient::~DaemonClient() = default;

CommandAck DaemonClient::sendCommand(DaemonCommand command, double timeout_s,
                                     const std::string& argument) {
  CommandAck result;
  result.command = command;
  const std::string name = daemonCommandName(command);
  transport::CommandKey key;
  try {
    key = transport::loadCommandKey(options_.key_path);
  } catch (const std::exception& e) {
    result.message = "cannot sign the " + name + " command: " + e.what() +
                     " (run as root or as a member of the ftid group)";
    return result;
  }
  if (!lcm_) lcm_ = std::make_unique<Lcm>(options_.lcm_url);
  lcm::LCM& lc = lcm_->lc;
  if (!lc.good()) {
    lcm_.reset();
    result.message = "LCM: cannot open '" + options_.lcm_url + "'";
    return result;
  }
  AckWaiter waiter;
  // Unique enough across senders: the monotonic clock with the process id in the high bits.
  const auto mono_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(
                           std::chrono::steady_clock::now().time_since_epoch())
                           .count();
  waiter.request_id = static_cast<std::int64_t>(mono_ns ^ (static_cast<std::int64_t>(::getpid()) << 40));
  result.request_id = waiter.request_id;
  lcm::Subscription* sub = lc.subscribe(options_.ack_channel, &AckWaiter::handle, &waiter);
  // The receive socket is open (and filtered, if asked) before the command leaves.
  try {
    if (options_.local_sources_only) {
      transport::restrictLcmSources(lc, options_.lcm_url, transport::localSources());
    } else {
      (void)lc.getFileno();
    }
  } catch (const std::exception& e) {
    lc.unsubscribe(sub);
    lcm_.reset();
    result.message = "LCM: cannot restrict '" + options_.lcm_url + "' to this host: " + e.what();
    return result;
  }
  ftid_lcm::command_t cmd;
  cmd.utime = transport::realtimeUs();
  cmd.request_id = waiter.request_id;
  cmd.command = static_cast<std::int8_t>(command);
  cmd.argument = argument;
  using Clock = std::chrono::steady_clock;
  const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
  const auto resend = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(options_.resend_period_s > 0.0 ? options_.resend_period_s : 0.5));
  const bool resends = resendsUnanswered(command);
  transport::signCommand(&cmd, key);
  if (lc.publish(options_.command_channel, &cmd) != 0) {
    lc.unsubscribe(sub);
    result.message = "LCM: cannot publish on " + options_.command_channel + " (" + options_.lcm_url + ")";
    return result;
  }
  result.sent = true;
  auto next_send = Clock::now() + resend;
  while (!waiter.got && Clock::now() < deadline) {
    if (resends && Clock::now() >= next_send) {
      transport::signCommand(&cmd, key);  // a fresh sequence each time: a resend is no replay
      lc.publish(options_.command_channel, &cmd);
      next_send += resend;
    }
    lc.handleTimeout(50);
  }
  lc.unsubscribe(sub);
  if (waiter.malformed > 0) {
    std::fprintf(stderr, "ftid: %d malformed message(s) on %s dropped while waiting for the ack\n",
                 waiter.malformed, options_.ack_channel.c_str());
  }
  if (!waiter.got) {
    result.message = "ftidd did not acknowledge the " + name + " within " + seconds(timeout_s) +
                     " s (is it running?)";
    return result;
  }
  result.answered = true;
  result.ok = waiter.ack.ok;
  result.message = waiter.ack.message;
  result.param_version = waiter.ack.param_version;
  for (int i = 0; i < 6; ++i) result.offsets[static_cast<std::size_t>(i)] = waiter.ack.offsets[i];
  return result;
}

}  // namespace ftid::daemon
