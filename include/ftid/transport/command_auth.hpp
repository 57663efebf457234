#pragma once
// Authentication of ftidd's commands (command_t on FTID_COMMAND; docs/operations.md, "Network
// and commands").
//
// Every command carries sequence (the sender's CLOCK_REALTIME in us when it signed) and
// mac = HMAC-SHA256(key, "ftid-command-v1" | utime | request_id | command | sequence |
// len(argument) | argument), integers big-endian. The key is a file of at least 32 random bytes,
// written as hex (comment lines starting with '#' allowed), readable only by root and the ftid
// group (the Debian package creates /etc/ftid/command.key at install). ftidd accepts a command
// only if the MAC matches, the sequence lies within +-window of its clock and after its own start
// (nothing signed before ftidd started can be replayed into it), and the sequence is strictly above
// the last sequence it accepted (no replay, no reordering).
#include <cstdint>
#include <string>
#include <vector>

#include "ftid/transport/hmac_sha256.hpp"

namespace ftid_lcm {
class command_t;
}  // namespace ftid_lcm

namespace ftid::transport {

struct CommandKey {
  std::vector<std::uint8_t> bytes;
  std::string path;  ///< where it was read from (for messages)
  bool empty() const noexcept { return bytes.empty(); }
};

/// Reads a key file: opened with O_NONBLOCK (a FIFO or device cannot wedge the caller), must be a
/// regular file of at most 4 kB, not readable or writable by others (mode & 007 == 0), holding at
/// least 32 bytes as hex. Throws ConfigError naming the file and the problem.
CommandKey loadCommandKey(const std::string& path);

/// Parses the hex text of a key file ("source" names it in errors). Throws ConfigError.
CommandKey parseCommandKey(const std::string& text, const std::string& source);

/// Current CLOCK_REALTIME in us.
std::int64_t realtimeUs() noexcept;

/// The MAC of a command (over the fields listed above; the mac field itself is not covered).
Sha256Digest commandMac(const ftid_lcm::command_t& command, const CommandKey& key);

/// Sets command->sequence (to `sequence`, or to the current time in us if sequence <= 0) and
/// command->mac.
void signCommand(ftid_lcm::command_t* command, const CommandKey& key, std::int64_t sequence = 0);

enum class CommandVerdict : std::uint8_t {
  kAccepted,
  kBadMac,     ///< no key configured, or the MAC does not match
  kStale,      ///< sequence outside +-window of now, or before ftidd started
  kReplayed,   ///< sequence not above the last accepted one
};
const char* commandVerdictName(CommandVerdict v) noexcept;

class CommandVerifier {
 public:
  /// key may be empty: every command is then refused (kBadMac). start_us: sequences at or before
  /// it are stale. window_us: accepted clock difference between sender and ftidd.
  CommandVerifier(CommandKey key, std::int64_t start_us, std::int64_t window_us = 30'000'000);
  /// Checks and, if accepted, remembers the sequence. now_us: ftidd's CLOCK_REALTIME.
  CommandVerdict verify(const ftid_lcm::command_t& command, std::int64_t now_us);
  bool hasKey() const noexcept { return !key_.empty(); }
  std::int64_t lastAccepted() const noexcept { return last_accepted_; }

 private:
  CommandKey key_;
  std::int64_t start_us_;
  std::int64_t window_us_;
  std::int64_t last_accepted_;
};

}  // namespace ftid::transport
