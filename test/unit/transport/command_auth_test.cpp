// SHA-256 / HMAC-SHA256 against the published test vectors (FIPS 180-2 appendix B, RFC 4231
// section 4), command signing and verification (tampering, staleness, replay, key files), and the
// kernel source-address filter used on LCM's receive socket.
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "ftid/common/error.hpp"
#include "ftid/transport/command_auth.hpp"
#include "ftid/transport/hmac_sha256.hpp"
#include "ftid/transport/source_filter.hpp"
#include "ftid_lcm/command_t.hpp"

namespace ftid::transport {
namespace {

std::string hex(const std::uint8_t* d, std::size_t n) {
  std::string s;
  char b[3];
  for (std::size_t i = 0; i < n; ++i) {
    std::snprintf(b, sizeof b, "%02x", d[i]);
    s += b;
  }
  return s;
}
std::string hex(const Sha256Digest& d) { return hex(d.data(), d.size()); }

std::string shaOf(const std::string& s) { return hex(sha256(s.data(), s.size())); }

TEST(Sha256, Fips180Vectors) {
  EXPECT_EQ(shaOf("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(shaOf(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(shaOf("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
  // One million 'a', fed in uneven pieces (exercises the block buffer).
  Sha256 s;
  const std::string chunk(997, 'a');
  std::size_t left = 1000000;
  while (left > 0) {
    const std::size_t n = left < chunk.size() ? left : chunk.size();
    s.update(chunk.data(), n);
    left -= n;
  }
  EXPECT_EQ(hex(s.finish()), "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
}

TEST(Sha256, PaddingBoundaries) {
  // Lengths around the 55/56/64-byte padding boundaries must differ and be stable when split.
  for (std::size_t n : {55u, 56u, 63u, 64u, 65u, 119u, 120u}) {
    const std::string m(n, 'x');
    Sha256 s;
    s.update(m.data(), 1);
    s.update(m.data() + 1, n - 1);
    EXPECT_EQ(hex(s.finish()), shaOf(m)) << n;
  }
  EXPECT_NE(shaOf(std::string(55, 'x')), shaOf(std::string(56, 'x')));
}

std::string hmacHex(const std::vector<std::uint8_t>& key, const std::string& data) {
  return hex(hmacSha256(key.data(), key.size(), data.data(), data.size()));
}

TEST(HmacSha256, Rfc4231Vectors) {
  EXPECT_EQ(hmacHex(std::vector<std::uint8_t>(20, 0x0b), "Hi There"),
            "b0344c61d8db38535ca8afceaf0bf12b881dc200c9833da726e9376c2e32cff7");
  const std::string jefe = "Jefe";
  EXPECT_EQ(hmacHex(std::vector<std::uint8_t>(jefe.begin(), jefe.end()), "what do ya want for nothing?"),
            "5bdcc146bf60754e6a042426089575c75a003f089d2739839dec58b964ec3843");
  EXPECT_EQ(hmacHex(std::vector<std::uint8_t>(20, 0xaa), std::string(50, '\xdd')),
            "773ea91e36800e46854db8ebd09181a72959098b3ef8c122d9635514ced565fe");
  std::vector<std::uint8_t> k4;
  for (int i = 1; i <= 25; ++i) k4.push_back(static_cast<std::uint8_t>(i));
  EXPECT_EQ(hmacHex(k4, std::string(50, '\xcd')),
            "82558a389a443c0ea4cc819899f2083a85f0faa3e578f8077a2e3ff46729665b");
  EXPECT_EQ(hmacHex(std::vector<std::uint8_t>(20, 0x0c), "Test With Truncation").substr(0, 32),
            "a3b6167473100ee06e0c796c2955552b");
  EXPECT_EQ(hmacHex(std::vector<std::uint8_t>(131, 0xaa), "Test Using Larger Than Block-Size Key - Hash Key First"),
            "60e431591ee0b67f0d8a26aacbf5b77f8e0bc6213728c5140546040f0ee37f54");
  EXPECT_EQ(hmacHex(std::vector<std::uint8_t>(131, 0xaa),
                    "This is a test using a larger than block-size key and a larger than block-size data. The "
                    "key needs to be hashed before being used by the HMAC algorithm."),
            "9b09ffa71b942fcb27635fbcd5b0e944bfdc63644f0713938a7f51535c3a35e2");
}

CommandKey testKey(std::uint8_t fill = 0x5a) {
  CommandKey k;
  k.bytes.assign(32, fill);
  k.path = "test";
  return k;
}

ftid_lcm::command_t reload(std::int64_t id) {
  ftid_lcm::command_t c{};
  c.utime = 1700000000000000;
  c.request_id = id;
  c.command = ftid_lcm::command_t::RELOAD_PARAMETERS;
  return c;
}

TEST(CommandAuth, SignedCommandIsAcceptedOnce) {
  const std::int64_t start = 1'000'000'000'000'000;
  CommandVerifier v(testKey(), start);
  ftid_lcm::command_t c = reload(7);
  signCommand(&c, testKey(), start + 10);
  EXPECT_EQ(v.verify(c, start + 20), CommandVerdict::kAccepted);
  EXPECT_EQ(v.verify(c, start + 30), CommandVerdict::kReplayed);  // the same datagram again
  ftid_lcm::command_t older = reload(8);
  signCommand(&older, testKey(), start + 5);  // signed before the last accepted one
  EXPECT_EQ(v.verify(older, start + 40), CommandVerdict::kReplayed);
  ftid_lcm::command_t next = reload(9);
  signCommand(&next, testKey(), start + 50);
  EXPECT_EQ(v.verify(next, start + 60), CommandVerdict::kAccepted);
}

TEST(CommandAuth, EveryCoveredFieldIsAuthenticated) {
  const std::int64_t start = 1'000'000'000'000'000;
  ftid_lcm::command_t base = reload(7);
  signCommand(&base, testKey(), start + 10);
  std::vector<ftid_lcm::command_t> altered(6, base);
  altered[0].utime += 1;
  altered[1].request_id += 1;
  altered[2].command = ftid_lcm::command_t::PING;
  altered[3].sequence += 1;
  altered[4].argument = "/var/lib/ftid/parameters.yaml.bak";
  altered[5].mac[31] = static_cast<std::int8_t>(altered[5].mac[31] ^ 1);
  for (std::size_t i = 0; i < altered.size(); ++i) {
    CommandVerifier v(testKey(), start);
    EXPECT_EQ(v.verify(altered[i], start + 20), CommandVerdict::kBadMac) << "alteration " << i;
  }
  CommandVerifier wrong_key(testKey(0x5b), start);
  EXPECT_EQ(wrong_key.verify(base, start + 20), CommandVerdict::kBadMac);
  CommandVerifier no_key(CommandKey{}, start);
  EXPECT_EQ(no_key.verify(base, start + 20), CommandVerdict::kBadMac);
  ftid_lcm::command_t unsigned_cmd = reload(7);
  CommandVerifier v(testKey(), start);
  EXPECT_EQ(v.verify(unsigned_cmd, start + 20), CommandVerdict::kBadMac);
}

TEST(CommandAuth, StaleCommandsAreRefused) {
  const std::int64_t start = 1'000'000'000'000'000;
  const std::int64_t window = 30'000'000;
  CommandVerifier v(testKey(), start, window);
  ftid_lcm::command_t before_start = reload(1);
  signCommand(&before_start, testKey(), start - 1);  // captured before ftidd (re)started
  EXPECT_EQ(v.verify(before_start, start + 100), CommandVerdict::kStale);
  const std::int64_t now = start + 100 * window;
  ftid_lcm::command_t old = reload(2);
  signCommand(&old, testKey(), now - window - 1);
  EXPECT_EQ(v.verify(old, now), CommandVerdict::kStale);
  ftid_lcm::command_t future = reload(3);
  signCommand(&future, testKey(), now + window + 1);
  EXPECT_EQ(v.verify(future, now), CommandVerdict::kStale);
  ftid_lcm::command_t edge = reload(4);
  signCommand(&edge, testKey(), now - window + 1);
  EXPECT_EQ(v.verify(edge, now), CommandVerdict::kAccepted);
}

std::string scratch(const std::string& name) {
  return ::testing::TempDir() + "ftid_auth_" + std::to_string(::getpid()) + "_" + name;
}

TEST(CommandKeyFile, ReadsHexWithComments) {
  const std::string p = scratch("key_ok");
  {
    std::ofstream f(p);
    f << "# ftid command key\n" << std::string(64, 'a') << "\n";
  }
  ::chmod(p.c_str(), 0640);
  const CommandKey k = loadCommandKey(p);
  EXPECT_EQ(k.bytes, std::vector<std::uint8_t>(32, 0xaa));
  ::unlink(p.c_str());
}

void expectKeyError(const std::string& path, const std::string& want) {
  try {
    loadCommandKey(path);
    ADD_FAILURE() << path << ": accepted, expected an error containing '" << want << "'";
  } catch (const ConfigError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(path), std::string::npos) << msg;
    EXPECT_NE(msg.find(want), std::string::npos) << msg;
  }
}

TEST(CommandKeyFile, RefusesBadFiles) {
  const std::string readable = scratch("key_world");
  {
    std::ofstream f(readable);
    f << std::string(64, 'b') << "\n";
  }
  ::chmod(readable.c_str(), 0644);
  expectKeyError(readable, "accessible to other users");
  const std::string short_key = scratch("key_short");
  {
    std::ofstream f(short_key);
    f << std::string(62, 'c') << "\n";
  }
  ::chmod(short_key.c_str(), 0600);
  expectKeyError(short_key, "too short");
  const std::string not_hex = scratch("key_nothex");
  {
    std::ofstream f(not_hex);
    f << std::string(64, 'c') << "\nzz\n";
  }
  ::chmod(not_hex.c_str(), 0600);
  expectKeyError(not_hex + "", ":2: command key: expected hexadecimal");
  const std::string fifo = scratch("key_fifo");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  expectKeyError(fifo, "regular file");  // and returns at once: O_NONBLOCK
  expectKeyError(scratch("key_missing"), "cannot open");
  for (const auto& p : {readable, short_key, not_hex, fifo}) ::unlink(p.c_str());
}

// ---- source filter: a UDP socket accepts only the allowed source addresses.
int udpSocket(const char* bind_addr, std::uint16_t port) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(port);
  ::inet_pton(AF_INET, bind_addr, &a.sin_addr);
  if (::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

std::uint16_t boundPort(int fd) {
  sockaddr_in a{};
  socklen_t len = sizeof a;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  return ntohs(a.sin_port);
}

bool receives(int rx, int tx, std::uint16_t port, const std::string& payload) {
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(port);
  ::inet_pton(AF_INET, "127.0.0.1", &to.sin_addr);
  ::sendto(tx, payload.data(), payload.size(), 0, reinterpret_cast<sockaddr*>(&to), sizeof to);
  pollfd p{rx, POLLIN, 0};
  if (::poll(&p, 1, 300) <= 0) return false;
  char buf[256];
  const ssize_t n = ::recv(rx, buf, sizeof buf, 0);
  return n == static_cast<ssize_t>(payload.size()) && std::memcmp(buf, payload.data(), payload.size()) == 0;
}

TEST(SourceFilter, DropsDatagramsFromOtherSources) {
  const int rx = udpSocket("0.0.0.0", 0);  // like LCM's udpm receive socket
  ASSERT_GE(rx, 0);
  const std::uint16_t port = boundPort(rx);
  const int from_1 = udpSocket("127.0.0.1", 0);
  const int from_2 = udpSocket("127.0.0.2", 0);
  if (from_2 < 0) GTEST_SKIP() << "cannot bind 127.0.0.2 here";
  // Without a filter both arrive.
  EXPECT_TRUE(receives(rx, from_1, port, "one"));
  EXPECT_TRUE(receives(rx, from_2, port, "two"));
  // Allow only 127.0.0.1 (and an unrelated network, to exercise the jump offsets).
  attachSourceFilter(rx, {{0x0A000000u, 0xFF000000u}, {0x7F000001u, 0xFFFFFFFFu}, {0xC0A80000u, 0xFFFF0000u}});
  EXPECT_TRUE(receives(rx, from_1, port, "three"));
  EXPECT_FALSE(receives(rx, from_2, port, "four"));
  // filterUdpSocketsOnPort finds the socket by its port (as for LCM's hidden socket).
  const int rx2 = udpSocket("0.0.0.0", 0);
  const std::uint16_t port2 = boundPort(rx2);
  EXPECT_TRUE(receives(rx2, from_2, port2, "five"));
  EXPECT_EQ(filterUdpSocketsOnPort(port2, {{0x7F000001u, 0xFFFFFFFFu}}), 1);
  EXPECT_FALSE(receives(rx2, from_2, port2, "six"));
  EXPECT_TRUE(receives(rx2, from_1, port2, "seven"));
  for (int fd : {rx, rx2, from_1, from_2}) ::close(fd);
}

TEST(SourceFilter, LocalSourcesAndUrlPort) {
  const auto local = localSources();
  ASSERT_FALSE(local.empty());
  EXPECT_EQ(local[0].addr, 0x7F000000u);
  EXPECT_EQ(local[0].mask, 0xFF000000u);
  EXPECT_EQ(udpmPort("udpm://239.255.76.67:7667?ttl=0"), 7667);
  EXPECT_EQ(udpmPort("udpm://239.255.76.67:7700"), 7700);
  EXPECT_EQ(udpmPort("memq://"), -1);
  EXPECT_THROW(udpmPort("udpm://239.255.76.67:abc"), ConfigError);
}

}  // namespace
}  // namespace ftid::transport
