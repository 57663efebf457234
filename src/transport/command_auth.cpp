#include "ftid/common/clock.hpp"
#include "ftid/transport/command_auth.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

#include "ftid/common/error.hpp"
#include "ftid_lcm/command_t.hpp"

namespace ftid::transport {
namespace {

constexpr std::size_t kMinKeyBytes = 32;
constexpr std::size_t kMaxKeyFileBytes = 4096;

int hexValue(char c) noexcept {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

}  // namespace

CommandKey parseCommandKey(const std::string& text, const std::string& source) {
  CommandKey key;
  key.path = source;
  int line = 1;
  int pending = -1;
  bool comment = false;
  for (char c : text) {
    if (c == '\n') {
      ++line;
      comment = false;
      continue;
    }
    if (comment) continue;
    if (c == '#') {
      comment = true;
      continue;
    }
    if (c == ' ' || c == '\t' || c == '\r') continue;
    const int v = hexValue(c);
    if (v < 0) {
      throw ConfigError(source + ":" + std::to_string(line) +
                        ": command key: expected hexadecimal digits, found '" +
                        std::string(1, c) + "'");
    }
    if (pending < 0) {
      pending = v;
    } else {
      key.bytes.push_back(static_cast<std::uint8_t>(pending * 16 + v));
      pending = -1;
    }
  }
  if (pending >= 0) throw ConfigError(source + ": command key: odd number of hexadecimal digits");
  if (key.bytes.size() < kMinKeyBytes) {
    throw ConfigError(source + ": command key too short (" + std::to_string(key.bytes.size()) +
                      " bytes, need at least " + std::to_string(kMinKeyBytes) +
                      "); create one with: head -c 32 /dev/urandom | od -An -tx1 | tr -d ' \\n'");
  }
  return key;
}

CommandKey loadCommandKey(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
  if (fd < 0) {
    throw ConfigError(path + ": cannot open the command key (" + std::strerror(errno) + ")");
  }
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    throw ConfigError(path + ": cannot stat the command key (" + std::strerror(errno) + ")");
  }
  if (!S_ISREG(st.st_mode)) throw ConfigError(path + ": the command key must be a regular file");
  if ((st.st_mode & 0007) != 0) {
    char mode[16];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
    throw ConfigError(path + ": the command key is accessible to other users (mode " + mode +
                      "); run: chmod 0640 " + path + " (owner root, group ftid)");
  }
  if (st.st_size > static_cast<off_t>(kMaxKeyFileBytes)) {
    throw ConfigError(path + ": the command key file is larger than 4 kB");
  }
  std::string text(static_cast<std::size_t>(st.st_size), '\0');
  std::size_t got = 0;
  while (got < text.size()) {
    const ssize_t n = ::read(fd, &text[got], text.size() - got);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw ConfigError(path + ": cannot read the command key (" + std::strerror(errno) + ")");
    if (n == 0) break;
    got += static_cast<std::size_t>(n);
  }
  text.resize(got);
  return parseCommandKey(text, path);
}

std::int64_t realtimeUs() noexcept { return ftid::realtimeUs(); }

Sha256Digest commandMac(const ftid_lcm::command_t& c, const CommandKey& key) {
  HmacSha256 h(key.bytes.data(), key.bytes.size());
  static const char kDomain[] = "ftid-command-v1";
  h.update(kDomain, sizeof kDomain - 1);
  std::uint8_t b[8];
  auto put = [&](std::uint64_t v, int bytes) {
    for (int i = 0; i < bytes; ++i) b[i] = static_cast<std::uint8_t>(v >> (8 * (bytes - 1 - i)));
    h.update(b, static_cast<std::size_t>(bytes));
  };
  put(static_cast<std::uint64_t>(c.utime), 8);
  put(static_cast<std::uint64_t>(c.request_id), 8);
  put(static_cast<std::uint8_t>(c.command), 1);
  put(static_cast<std::uint64_t>(c.sequence), 8);
  put(static_cast<std::uint32_t>(c.argument.size()), 4);
  h.update(c.argument.data(), c.argument.size());
  return h.finish();
}

void signCommand(ftid_lcm::command_t* c, const CommandKey& key, std::int64_t sequence) {
  c->sequence = sequence > 0 ? sequence : realtimeUs();
  const Sha256Digest mac = commandMac(*c, key);
  std::memcpy(c->mac, mac.data(), mac.size());
}

const char* commandVerdictName(CommandVerdict v) noexcept {
  switch (v) {
    case CommandVerdict::kAccepted: return "accepted";
    case CommandVerdict::kBadMac: return "bad or missing authenticator";
    case CommandVerdict::kStale: return "stale (clock window or sent before ftidd started)";
    case CommandVerdict::kReplayed: return "replayed (sequence not above the last accepted)";
  }
  return "unknown";
}

CommandVerifier::CommandVerifier(CommandKey key, std::int64_t start_us, std::int64_t window_us)
    : key_(std::move(key)), start_us_(start_us), window_us_(window_us), last_accepted_(start_us) {}

CommandVerdict CommandVerifier::verify(const ftid_lcm::command_t& c, std::int64_t now_us) {
  if (key_.empty()) return CommandVerdict::kBadMac;
  const Sha256Digest mac = commandMac(c, key_);
  if (!digestEqual(mac.data(), reinterpret_cast<const std::uint8_t*>(c.mac), mac.size())) {
    return CommandVerdict::kBadMac;
  }
  if (c.sequence <= start_us_ || c.sequence < now_us - window_us_ || c.sequence > now_us + window_us_) {
    return CommandVerdict::kStale;
  }
  if (c.sequence <= last_accepted_) return CommandVerdict::kReplayed;
  last_accepted_ = c.sequence;
  return CommandVerdict::kAccepted;
}

}  // namespace ftid::transport
