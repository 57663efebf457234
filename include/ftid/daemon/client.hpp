#pragma once
// The client side of ftidd's command channel: every program that asks ftidd to do something
// (`ftid --identify`'s reload, `ftid tare`, tests) sends it through this one class. It signs the
// command with the shared key (HMAC-SHA256, ftid/transport/command_auth.hpp; docs/operations.md,
// "Network and commands"), publishes it on the command channel and waits until ftidd's ack_t with
// the same request id arrives or the timeout passes, and returns the answer. RELOAD_PARAMETERS and
// PING are resent (freshly signed, so a resend is no replay) every resend_period_s while
// unanswered; a TARE is published exactly once (a resend would be a second tare).
//
//   ftid::daemon::DaemonClient client(ftid::daemon::DaemonClientOptions::fromConfig(cfg));
//   const ftid::daemon::CommandAck ack = client.sendCommand(ftid::daemon::DaemonCommand::kTare);
//   if (!ack.ok) fail(ack.describe());        // "ftidd refused the TARE: tare refused: ..."
//   else print(ack.message);                   // ftidd's message (TARE: the new offsets)
//
// Not for the real-time loop (it blocks up to the timeout and allocates). Library target
// ftid::daemon_client (transport + config only; it does not pull in the daemon itself).
#include <array>
#include <cstdint>
#include <memory>
#include <string>

namespace ftid::config {
struct DaemonConfig;
}  // namespace ftid::config

namespace ftid::daemon {

/// What to ask ftidd (command_t's constants; docs/daemon.md, "Signals and systemd").
enum class DaemonCommand : std::int8_t {
  kReloadParameters = 1,  ///< reload the configured parameter file (as SIGHUP)
  kPing = 2,              ///< answer only
  kTare = 3,              ///< re-estimate the offsets at the current pose (robot at rest)
  kReidentify = 4,        ///< estimate the payload change from recent motion (argument "" or "apply")
};

/// "RELOAD_PARAMETERS", "PING", "TARE".
const char* daemonCommandName(DaemonCommand command) noexcept;

/// True if an unanswered `command` may be sent again (RELOAD_PARAMETERS, PING); false for TARE
/// and REIDENTIFY, which are published once: a resend would be a second tare or re-identification.
bool resendsUnanswered(DaemonCommand command) noexcept;

struct DaemonClientOptions {
  std::string lcm_url = "udpm://239.255.76.67:7667?ttl=0";
  std::string command_channel = "FTID_COMMAND";
  std::string ack_channel = "FTID_ACK";
  /// The shared command key (lcm.command_key_path); read at every sendCommand().
  std::string key_path = "/etc/ftid/command.key";
  /// A RELOAD_PARAMETERS or PING not yet answered is signed afresh and sent again after this long
  /// [s] (the first one may race the subscription to the ack channel). Never for a TARE: the
  /// client chooses the resend policy from the command (resendsUnanswered()).
  double resend_period_s = 0.5;
  /// Accept acks only from this host (127.0.0.0/8 and the local interface addresses;
  /// transport::restrictLcmSources), as ftidd with lcm.accept_remote false. udpm URLs only.
  bool local_sources_only = false;

  /// The values of an ftidd configuration (lcm.url, lcm.channels.command/.ack,
  /// lcm.command_key_path): the client talks to the ftidd that runs with that file.
  static DaemonClientOptions fromConfig(const config::DaemonConfig& config);
};

/// ftidd's answer (ack_t), or why there is none.
struct CommandAck {
  DaemonCommand command = DaemonCommand::kPing;
  /// True if the command was published; false if nothing was sent (the key cannot be read, LCM
  /// cannot be opened or filtered, the publish failed; message says which).
  bool sent = false;
  /// True if ftidd answered within the timeout (then ok, message and param_version are its own).
  bool answered = false;
  /// True if ftidd executed the command (ack_t.ok; RELOAD: the new parameters are in use).
  bool ok = false;
  /// ftidd's message (the reason if refused, the offsets for TARE), or if !answered why not:
  /// the key cannot be read, LCM cannot be opened, or no answer within the timeout.
  std::string message;
  /// Parameter version in use after the command (ack_t.param_version; 0 if !answered).
  std::int32_t param_version = 0;
  /// ack_t.offsets: after a successful TARE the offsets now in use, [f0_x, f0_y, f0_z] N then
  /// [t0_x, t0_y, t0_z] Nm in the sensor frame S; zeros otherwise.
  std::array<double, 6> offsets{};
  std::int64_t request_id = 0;

  /// One line for a user: "" if ok; else e.g. "ftidd refused the RELOAD_PARAMETERS: <reason>",
  /// "ftidd did not acknowledge the TARE within 3.0 s (is it running?)" or
  /// "cannot sign the TARE command: <key problem> (run as root or as a member of the ftid group)".
  std::string describe() const;
};

class DaemonClient {
 public:
  explicit DaemonClient(DaemonClientOptions options);
  ~DaemonClient();
  DaemonClient(const DaemonClient&) = delete;
  DaemonClient& operator=(const DaemonClient&) = delete;

  /// Signs and sends `command` (with `argument`; ftidd refuses an argument for every command it
  /// knows) and waits up to timeout_s for the ack. Never throws for a missing key, LCM or ftidd:
  /// that is CommandAck::answered = false with the reason in message (sent = false: nothing left
  /// this process; sent = true: no answer within the timeout).
  CommandAck sendCommand(DaemonCommand command, double timeout_s = 3.0,
                         const std::string& argument = {});

  const DaemonClientOptions& options() const noexcept { return options_; }

 private:
  struct Lcm;
  DaemonClientOptions options_;
  std::unique_ptr<Lcm> lcm_;  // opened at the first sendCommand(), kept for the next ones
};

}  // namespace ftid::daemon
